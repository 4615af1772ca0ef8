//! The paper's filter, Eq. (qp), solved exactly in closed form:
//!
//! `u* = argmin ‖u − u_nom‖²  s.t.  gᵀu ≥ b,  −u_max ≤ u ≤ u_max`
//!
//! with `g = ∂H/∂p`, `b = −α(H) − ∂H/∂t`. This is the Euclidean projection of `u_nom` onto
//! the intersection of a half-space and a box. Its KKT conditions give
//! `u(μ) = clamp(u_nom + μ g)` for a multiplier `μ ≥ 0`, and `φ(μ) = gᵀu(μ)` is
//! non-decreasing and piecewise linear in `μ` with at most `2d` kinks, so the optimum is
//! found by walking the kinks in order and interpolating on the segment where `φ` reaches
//! `b`. (Projecting on the half-space and then clamping is *not* this optimum, and can leave
//! the constraint violated.)
//!
//! Infeasibility and its fallback:
//! - if `‖g‖ ≤ grad_eps` and `b > 0` (e.g. `H < 0` with a vanishing gradient: no direction
//!   raises `H`), the command is `u = 0`: stop;
//! - if the box cannot reach `gᵀu ≥ b` (`Σ |g_j| u_max_j < b`), the command is the one that
//!   violates least, `argmax_{box} gᵀu` = `u_max · sign(g)` (components with `g_j = 0`
//!   stay at `clamp(u_nom_j)`).
//!
//! Both report `feasible = false`; `u_nom` is never returned silently.
//!
//! Up to [`MAX_VARS`] variables: the planar velocity with the yaw rate (`d = 3`) and a 3D
//! velocity with the body's angular velocity (`d = 6`) take the same projection.

use crate::error::{Error, Result};

/// Most variables a filter QP takes: `(v ∈ R³, ω ∈ R³)`.
pub const MAX_VARS: usize = 6;

/// The solution of one filter QP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QpSolution {
    /// The filtered command (the first `d` entries are used).
    pub u: [f64; MAX_VARS],
    /// The constraint row changed the command (multiplier `μ > 0`).
    pub active: bool,
    /// The constraint could be met inside the box.
    pub feasible: bool,
}

/// `gᵀu` on the first `d` entries.
#[inline]
fn dot_d(g: &[f64], u: &[f64]) -> f64 {
    g.iter().zip(u).map(|(a, b)| a * b).sum()
}

/// Solves `min ‖u − u_nom‖² s.t. gᵀu ≥ b` and, with `u_max`, `|u_j| ≤ u_max_j`, exactly.
/// `u_nom`, `g` and `u_max` have the same length `d ∈ 1..=6`, every value finite, `u_max`
/// ≥ 0 and `grad_eps` ≥ 0; else an error naming the argument, as is a row that only a command
/// beyond the largest float meets (`b`).
///
/// ```
/// use shieldnav_core::shield::project_halfspace_box;
/// // keep u_y ≥ 0.5 while asking for (1, 0), inside |u| ≤ 1
/// let s = project_halfspace_box(&[1.0, 0.0], &[0.0, 1.0], 0.5, Some(&[1.0, 1.0]), 1e-9).unwrap();
/// assert_eq!(&s.u[..2], &[1.0, 0.5]);
/// assert!(s.active && s.feasible);
/// ```
pub fn project_halfspace_box(u_nom: &[f64], g: &[f64], b: f64, u_max: Option<&[f64]>, grad_eps: f64) -> Result<QpSolution> {
    check_command(u_nom, u_max)?;
    let d = u_nom.len();
    if g.len() != d {
        return Err(Error::DimensionMismatch { name: "g", expected: d, got: g.len() });
    }
    if !g.iter().all(|v| v.is_finite()) || !b.is_finite() {
        return Err(Error::invalid("g", format!("the row g·u ≥ b must be finite, got g = {g:?}, b = {b}")));
    }
    if !(grad_eps.is_finite() && grad_eps >= 0.0) {
        return Err(Error::invalid("grad_eps", format!("must be finite and ≥ 0, got {grad_eps}")));
    }
    let sol = project_checked(u_nom, g, b, u_max, grad_eps);
    if !sol.u[..d].iter().all(|v| v.is_finite()) {
        // (without a box, a row of b = 1e308 asks for a command no float holds)
        return Err(Error::invalid("b", format!("no finite command meets the row g·u ≥ b (g = {g:?}, b = {b:e})")));
    }
    Ok(sol)
}

/// That `u_nom` (of 1 to [`MAX_VARS`] finite values) and `u_max` (as many, finite and ≥ 0) fit together.
pub(crate) fn check_command(u_nom: &[f64], u_max: Option<&[f64]>) -> Result<()> {
    let d = u_nom.len();
    if !(1..=MAX_VARS).contains(&d) || !u_nom.iter().all(|v| v.is_finite()) {
        return Err(Error::invalid("u_nom", format!("expected 1 to {MAX_VARS} finite values, got {u_nom:?}")));
    }
    if let Some(m) = u_max {
        if m.len() != d {
            return Err(Error::DimensionMismatch { name: "u_max", expected: d, got: m.len() });
        }
        if !m.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err(Error::invalid("u_max", format!("must be finite and ≥ 0, got {m:?}")));
        }
    }
    Ok(())
}

/// [`project_halfspace_box`] on checked arguments.
pub(crate) fn project_checked(u_nom: &[f64], g: &[f64], b: f64, u_max: Option<&[f64]>, grad_eps: f64) -> QpSolution {
    let d = u_nom.len();
    debug_assert!(d <= MAX_VARS && g.len() == d && u_max.is_none_or(|m| m.len() == d));
    let mut u = [0.0; MAX_VARS];
    let clamp = |j: usize, v: f64| match u_max {
        Some(m) => v.clamp(-m[j], m[j]),
        None => v,
    };
    for j in 0..d {
        u[j] = clamp(j, u_nom[j]);
    }
    if dot_d(g, &u[..d]) >= b {
        return QpSolution { u, active: false, feasible: true };
    }
    let g2 = dot_d(g, g);
    if g2.sqrt() <= grad_eps {
        return QpSolution { u: [0.0; MAX_VARS], active: true, feasible: false };
    }
    let Some(m) = u_max else {
        let mu = (b - dot_d(g, u_nom)) / g2;
        for j in 0..d {
            u[j] = u_nom[j] + mu * g[j];
        }
        // the optimum lies on the row; a huge `u_nom` cancels in `u_nom + μ g` (1e17 m/s left
        // it short by 1.16): one step more from the command found, small then, reaches it
        let short = b - dot_d(g, &u[..d]);
        for j in 0..d {
            u[j] += short / g2 * g[j];
        }
        return QpSolution { u, active: true, feasible: meets_row(g, &u[..d], b) };
    };
    let reach: f64 = (0..d).map(|j| g[j].abs() * m[j]).sum();
    if reach < b {
        for j in 0..d {
            if g[j] != 0.0 {
                u[j] = m[j].copysign(g[j]);
            }
        }
        return QpSolution { u, active: true, feasible: false };
    }
    // Kinks of φ(μ) = Σ g_j clamp(u_nom_j + μ g_j): where a component enters or leaves the box.
    let mut kinks = [0.0f64; 2 * MAX_VARS];
    let mut nk = 0;
    for j in 0..d {
        if g[j] != 0.0 {
            for bound in [-m[j], m[j]] {
                let mu = (bound - u_nom[j]) / g[j];
                if mu > 0.0 {
                    kinks[nk] = mu;
                    nk += 1;
                }
            }
        }
    }
    kinks[..nk].sort_unstable_by(f64::total_cmp);
    let phi = |mu: f64| -> f64 { (0..d).map(|j| g[j] * clamp(j, u_nom[j] + mu * g[j])).sum() };
    let (mut lo, mut phi_lo) = (0.0, phi(0.0));
    let mut mu_star = None;
    for &k in &kinks[..nk] {
        let phi_k = phi(k);
        if phi_k >= b {
            let slope = (phi_k - phi_lo) / (k - lo);
            mu_star = Some(lo + (b - phi_lo) / slope);
            break;
        }
        (lo, phi_lo) = (k, phi_k);
    }
    // Past the last kink φ is constant at `reach` ≥ b, so the loop found the segment unless
    // rounding put φ(last kink) a hair below b: take the last kink then.
    let mu = mu_star.unwrap_or(lo);
    for j in 0..d {
        u[j] = clamp(j, u_nom[j] + mu * g[j]);
    }
    QpSolution { u, active: true, feasible: meets_row(g, &u[..d], b) }
}

/// Whether `u` meets the row `gᵀu ≥ b` up to rounding ([`ROW_TOLERANCE`] of `max(|b|, 1)`):
/// a solution is called feasible only if it does (rounding in a huge `u_nom` can leave it
/// short).
fn meets_row(g: &[f64], u: &[f64], b: f64) -> bool {
    dot_d(g, u) >= b - ROW_TOLERANCE * b.abs().max(1.0)
}

/// How far (relative) a solution may fall short of its row and still be called feasible:
/// far above the rounding of a command of ordinary size (about 1e-16), far below any margin.
pub(crate) const ROW_TOLERANCE: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamp_after_projection_is_not_the_optimum() {
        // g = (1, 1)/√2 style row: u_x + u_y ≥ 1.5 from u_nom = (1.5, −1) in |u| ≤ 1.
        let s = project_halfspace_box(&[1.5, -1.0], &[1.0, 1.0], 1.5, Some(&[1.0, 1.0]), 1e-9).unwrap();
        assert!(s.feasible && s.active);
        assert!((s.u[0] - 1.0).abs() < 1e-12 && (s.u[1] - 0.5).abs() < 1e-12, "{:?}", s.u);
        // naive: project onto the row alone, then clamp: (2, −0.5) → (1, −0.5), which violates it
        let free = project_halfspace_box(&[1.5, -1.0], &[1.0, 1.0], 1.5, None, 1e-9).unwrap();
        let naive = [free.u[0].clamp(-1.0, 1.0), free.u[1].clamp(-1.0, 1.0)];
        assert_eq!(naive, [1.0, -0.5]);
        assert!(naive[0] + naive[1] < 1.5 && s.u[0] + s.u[1] >= 1.5 - 1e-12);
    }

    /// A huge `u_nom` without a box: the command meets the row (the exact `u_x = b / g_x`),
    /// not the cancelled `u_nom + μ g` that fell short of it while called feasible.
    #[test]
    fn huge_nominal_command_still_meets_the_row() {
        // (a point 0.5 m ahead: the row pushes back along −x)
        let (g, b) = ([-0.7, 0.0], -1.131);
        for big in [1e15, 1e17, -1e17] {
            let s = project_halfspace_box(&[big, 3.0], &g, b, None, 1e-9).unwrap();
            let row = g[0] * s.u[0] + g[1] * s.u[1];
            if big > 0.0 {
                assert!(s.active && s.feasible && (s.u[0] - b / g[0]).abs() <= 1e-12 * (b / g[0]).abs() && s.u[1] == 3.0, "{big}: {:?}", s.u);
            } else {
                assert!(!s.active && s.feasible && s.u[0] == big);
            }
            assert!(row >= b - 1e-12, "{big}: {row} < {b}");
        }
        // far beyond, the rounding of 1e300 is left: the command is called feasible only if
        // it meets the row
        for big in [1e300, 3e299, 1e200] {
            let s = project_halfspace_box(&[big, 0.0], &g, b, None, 1e-9).unwrap();
            assert!(!s.feasible || g[0] * s.u[0] >= b - 1e-9 * b.abs(), "{big}: {:?} called feasible", s.u);
        }
    }

    #[test]
    fn infeasible_box_returns_least_violating_command() {
        let s = project_halfspace_box(&[0.3, 0.2], &[1.0, -2.0], 5.0, Some(&[1.0, 0.5]), 1e-9).unwrap();
        assert!(!s.feasible);
        assert_eq!(&s.u[..2], &[1.0, -0.5]);
    }

    #[test]
    fn vanishing_gradient_with_violation_stops() {
        let s = project_halfspace_box(&[0.3, 0.2], &[0.0, 0.0], 0.1, None, 1e-9).unwrap();
        assert!(!s.feasible && s.active);
        assert_eq!(s.u, [0.0; MAX_VARS]);
    }

    #[test]
    fn unconstrained_when_row_holds() {
        let s = project_halfspace_box(&[0.3, 0.2, -0.1], &[1.0, 0.0, 0.0], -1.0, None, 1e-9).unwrap();
        assert!(s.feasible && !s.active);
        assert_eq!(&s.u[..3], &[0.3, 0.2, -0.1]);
    }
}
