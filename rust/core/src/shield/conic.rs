//! The general filter QP with many rows, solved with Clarabel:
//!
//! `min ‖u − u_nom‖²  s.t.  a_kᵀu ≥ c_k (k = 1..M),  −u_max ≤ u ≤ u_max`.
//!
//! Used by the distance baseline (one row per LIDAR point) and whenever a user adds extra
//! linear constraints. If the rows cannot all be met, the fallback is the command that
//! violates least: first `t* = min t s.t. a_kᵀu + t ≥ c_k, t ≥ 0` (an LP), then the command
//! closest to `u_nom` with that violation; the outcome says `feasible = false`.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

use super::qp::QpSolution;
use crate::error::{Error, Result};

/// Linear rows `a_kᵀu ≥ c_k` over a `dim`-dimensional command, row-major.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinearConstraints {
    dim: usize,
    rows: Vec<f64>,
    rhs: Vec<f64>,
}

impl LinearConstraints {
    /// Empty rows for a `dim`-dimensional command.
    pub fn new(dim: usize) -> Self {
        Self { dim, rows: Vec::new(), rhs: Vec::new() }
    }

    /// Rows from a row-major `(M, dim)` matrix `a` and `(M,)` right-hand side `c`.
    pub fn from_rows(dim: usize, a: &[f64], c: &[f64]) -> Result<Self> {
        if dim == 0 || a.len() != c.len() * dim {
            return Err(Error::invalid("extra_A", format!("expected shape ({}, {dim}) to match extra_b, got {} values", c.len(), a.len())));
        }
        if a.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("extra_A", "contains NaN or inf"));
        }
        if c.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("extra_b", "contains NaN or inf"));
        }
        Ok(Self { dim, rows: a.to_vec(), rhs: c.to_vec() })
    }

    /// Appends `aᵀu ≥ c` (`a` of the rows' dimension, every value finite).
    pub fn push(&mut self, a: &[f64], c: f64) -> Result<()> {
        if a.len() != self.dim {
            return Err(Error::DimensionMismatch { name: "extra_A", expected: self.dim, got: a.len() });
        }
        if !a.iter().all(|v| v.is_finite()) || !c.is_finite() {
            return Err(Error::invalid("extra_A", format!("a row must be finite, got {a:?} ≥ {c}")));
        }
        self.rows.extend_from_slice(a);
        self.rhs.push(c);
        Ok(())
    }

    /// Appends every row of `other` (of the same dimension).
    pub fn extend(&mut self, other: &LinearConstraints) -> Result<()> {
        if other.dim != self.dim {
            return Err(Error::DimensionMismatch { name: "extra_A", expected: self.dim, got: other.dim });
        }
        self.rows.extend_from_slice(&other.rows);
        self.rhs.extend_from_slice(&other.rhs);
        Ok(())
    }

    /// Removes all rows, keeping the allocation.
    pub fn clear(&mut self) {
        self.rows.clear();
        self.rhs.clear();
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.rhs.len()
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.rhs.is_empty()
    }

    /// Command dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Row `k` as `(a_k, c_k)`.
    ///
    /// # Panics
    ///
    /// If `k` is not below [`LinearConstraints::len`], as slice indexing does.
    pub fn row(&self, k: usize) -> (&[f64], f64) {
        (&self.rows[k * self.dim..(k + 1) * self.dim], self.rhs[k])
    }

    /// Largest violation `max_k (c_k − a_kᵀu)⁺` of a command; NaN if a row's value at `u` is
    /// none (its products overflow in both directions).
    pub fn max_violation(&self, u: &[f64]) -> f64 {
        (0..self.len())
            .map(|k| {
                let (a, c) = self.row(k);
                c - a.iter().zip(u).map(|(x, y)| x * y).sum::<f64>()
            })
            .fold(0.0, |m: f64, v| if m.is_nan() || v.is_nan() { f64::NAN } else { m.max(v) })
    }
}

fn settings() -> DefaultSettings<f64> {
    DefaultSettingsBuilder::default().verbose(false).max_iter(100).tol_feas(1e-12).tol_gap_abs(1e-12).tol_gap_rel(1e-12).build().expect("static Clarabel settings are valid")
}

/// `A` in CSC for `n` variables: the `M` rows negated (`−a_kᵀx + s = −c_k`), then the box
/// `±x_j ≤ u_max_j` on the first `d` variables, then `extra_cols` identity-like columns given
/// as `(row, col, value)` triples.
fn build(rows: &LinearConstraints, n: usize, u_max: Option<&[f64]>, extra: &[(usize, usize, f64)]) -> CscMatrix<f64> {
    let d = rows.dim();
    let m = rows.len();
    let n_box = if u_max.is_some() { 2 * d } else { 0 };
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    colptr.push(0);
    for j in 0..n {
        if j < d {
            for k in 0..m {
                let v = rows.row(k).0[j];
                if v != 0.0 {
                    rowval.push(k);
                    nzval.push(-v);
                }
            }
            if u_max.is_some() {
                rowval.push(m + j);
                nzval.push(1.0);
                rowval.push(m + d + j);
                nzval.push(-1.0);
            }
        }
        for &(r, c, v) in extra {
            if c == j {
                rowval.push(r);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    let n_rows = m + n_box + extra.iter().map(|&(r, _, _)| r + 1).max().unwrap_or(0).saturating_sub(m + n_box);
    CscMatrix::new(n_rows, n, colptr, rowval, nzval)
}

fn rhs(rows: &LinearConstraints, u_max: Option<&[f64]>) -> Vec<f64> {
    let mut b: Vec<f64> = rows.rhs.iter().map(|c| -c).collect();
    if let Some(mx) = u_max {
        b.extend_from_slice(mx);
        b.extend_from_slice(mx);
    }
    b
}

fn run(p: &CscMatrix<f64>, q: &[f64], a: &CscMatrix<f64>, b: &[f64]) -> Result<(SolverStatus, Vec<f64>)> {
    let cones = [SupportedConeT::NonnegativeConeT(b.len())];
    let mut solver = DefaultSolver::new(p, q, a, b, &cones, settings()).map_err(|e| Error::Solver(format!("{e:?}")))?;
    solver.solve();
    Ok((solver.solution.status, solver.solution.x.clone()))
}

fn solved(s: SolverStatus) -> bool {
    matches!(s, SolverStatus::Solved | SolverStatus::AlmostSolved)
}

fn infeasible(s: SolverStatus) -> bool {
    matches!(s, SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible)
}

/// `P = I/σ`, `q = −u_nom/σ`: the objective `(½‖u‖² − u_nomᵀu)/σ`.
fn objective(u_nom: &[f64], sigma: f64) -> (CscMatrix<f64>, Vec<f64>) {
    let mut p = CscMatrix::identity(u_nom.len());
    p.nzval.iter_mut().for_each(|v| *v /= sigma);
    (p, u_nom.iter().map(|v| -v / sigma).collect())
}

/// The least violation `t*` of `rows` within the box, an LP in `(u, t)`, and its solution;
/// Clarabel's status if it finds none.
fn least_violation(rows: &LinearConstraints, u_max: Option<&[f64]>) -> Result<std::result::Result<(f64, Vec<f64>), SolverStatus>> {
    let (d, m) = (rows.dim(), rows.len());
    let n_box = if u_max.is_some() { 2 * d } else { 0 };
    let mut t_col: Vec<(usize, usize, f64)> = (0..m).map(|k| (k, d, -1.0)).collect();
    t_col.push((m + n_box, d, -1.0)); // −t + s = 0, s ≥ 0  ⇔  t ≥ 0
    let a_t = build(rows, d + 1, u_max, &t_col);
    let mut b_t = rhs(rows, u_max);
    b_t.push(0.0);
    let mut q_t = vec![0.0; d + 1];
    q_t[d] = 1.0;
    let (status, x) = run(&CscMatrix::zeros((d + 1, d + 1)), &q_t, &a_t, &b_t)?;
    Ok(if solved(status) { Ok((x[d].max(0.0), x)) } else { Err(status) })
}

/// Solves the many-row filter QP with Clarabel (see the module docs for the fallback).
pub fn solve_rows(u_nom: &[f64], rows: &LinearConstraints, u_max: Option<&[f64]>) -> Result<QpSolution> {
    super::qp::check_command(u_nom, u_max)?;
    let d = u_nom.len();
    if rows.dim() != d {
        return Err(Error::DimensionMismatch { name: "extra_A", expected: d, got: rows.dim() });
    }
    let mut clamped = [0.0; super::qp::MAX_VARS];
    for j in 0..d {
        clamped[j] = u_max.map_or(u_nom[j], |m| u_nom[j].clamp(-m[j], m[j]));
    }
    let violation = rows.max_violation(&clamped[..d]);
    if violation.is_nan() {
        return Err(Error::invalid("u_nom", format!("the rows' values a_k·u at u_nom = {u_nom:?} overflow: command and rows too large together")));
    }
    if violation <= 0.0 {
        return Ok(QpSolution { u: clamped, active: false, feasible: true });
    }
    let a = build(rows, d, u_max, &[]);
    let b = rhs(rows, u_max);
    // ½‖u‖² − u_nomᵀu; if Clarabel stops with neither an answer nor infeasibility, once more
    // divided by σ = ‖u_nom‖∞ (the same minimiser, a linear term of order 1: a command of 1e10
    // m/s against a box of 1.6 m/s stops the unscaled solve with DualInfeasible)
    let (p, q) = objective(u_nom, 1.0);
    let (mut status, mut x) = run(&p, &q, &a, &b)?;
    if !solved(status) && !infeasible(status) {
        let sigma = u_nom.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
        let (p_s, q_s) = objective(u_nom, sigma);
        (status, x) = run(&p_s, &q_s, &a, &b)?;
    }
    let mut u = [0.0; super::qp::MAX_VARS];
    // a command is called feasible only if it meets every row to the tolerance the closed-form
    // filter uses (at extreme magnitudes an interior point solver can stop short of a row)
    let given = rows;
    let meets = |u: &[f64]| {
        (0..given.len()).all(|k| {
            let (row, c) = given.row(k);
            row.iter().zip(u).map(|(a, v)| a * v).sum::<f64>() >= c - super::qp::ROW_TOLERANCE * c.abs().max(1.0)
        })
    };
    if solved(status) {
        // Clarabel's answer, held to the box exactly
        for j in 0..d {
            u[j] = u_max.map_or(x[j], |m| x[j].clamp(-m[j], m[j]));
        }
        return Ok(QpSolution { u, active: true, feasible: meets(&u[..d]) });
    }
    // Infeasible, or Clarabel stopped without an answer (a row 0·u ≥ 1e150: NumericalError):
    // Stage 1: the least possible violation t*; if Clarabel fails on the rows as given, on the
    // rows divided by max(1, |c_k|, ‖a_k‖∞), the same half-spaces
    let (rows, t_star, x) = match least_violation(rows, u_max)? {
        Ok((t, x)) => (rows.clone(), t, x),
        Err(_) => {
            let mut scaled = LinearConstraints::new(d);
            for k in 0..rows.len() {
                let (row, c) = rows.row(k);
                let s = row.iter().fold(c.abs().max(1.0), |m, v| m.max(v.abs()));
                let row: Vec<f64> = row.iter().map(|v| v / s).collect();
                scaled.push(&row, c / s)?;
            }
            match least_violation(&scaled, u_max)? {
                Ok((t, x)) => (scaled, t, x),
                Err(status) => return Err(Error::Solver(format!("Clarabel could not find the least violation: {status:?}"))),
            }
        }
    };
    // Stage 2: the command closest to u_nom with violation at most t*.
    let mut relaxed = LinearConstraints::new(d);
    for k in 0..rows.len() {
        let (row, c) = rows.row(k);
        relaxed.push(row, c - t_star - 1e-9 * (1.0 + t_star))?;
    }
    let (status, x2) = run(&p, &q, &build(&relaxed, d, u_max, &[]), &rhs(&relaxed, u_max))?;
    let src = if solved(status) { &x2 } else { &x };
    for j in 0..d {
        u[j] = u_max.map_or(src[j], |m| src[j].clamp(-m[j], m[j]));
    }
    Ok(QpSolution { u, active: true, feasible: meets(&u[..d]) })
}
