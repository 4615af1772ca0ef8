//! The paper's baselines: hard-min (the nearest point's ellipsoidal CBF) and distance (one
//! spherical CBF row per point).

use super::conic::{solve_rows, LinearConstraints};
use super::filter::Shield;
use super::filter::{to_world, Filtered};
use super::input::{BodyState, Scan};
use super::qp::{QpSolution, MAX_VARS};
use crate::error::{Error, Result};
use crate::math::Vec3;

impl Shield {
    /// The hard-min baseline: the nearest point's ellipsoidal CBF only.
    pub(super) fn hard_min_row(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<Filtered> {
        let (dim, r) = (self.dim(), state.rotation);
        let alpha = self.config.alpha;
        let u_max = self.config.u_max.clone();
        let env = self.envelope;
        let pts = self.selected_f64(scan);
        let n = pts.len() / dim;
        let mut nearest: Option<(f64, Vec3)> = None;
        for i in 0..n {
            let c = &pts[i * dim..(i + 1) * dim];
            let p = [c[0], c[1], if dim == 3 { c[2] } else { 0.0 }];
            let h = env.h_body(&p);
            // (a point 1e154 m away: its h, gradient or ∂h/∂t overflows)
            if !(h.is_finite() && env.dh_dt_body(&p, &state.omega).is_finite()) {
                return Err(too_far());
            }
            if nearest.is_none_or(|(hn, _)| h < hn) {
                nearest = Some((h, p));
            }
        }
        match nearest {
            None => {
                let sol = self.solve_row(u_nom, &[0.0; 3], f64::NEG_INFINITY, u_max.as_deref(), extra)?;
                Ok(Filtered::unchecked(f64::MAX, f64::MAX, [0.0; 3], 0.0, 0, sol, state.omega))
            }
            Some((h, p)) => {
                let g = to_world(&r, dim, &env.grad_body(&p));
                let dt = env.dh_dt_body(&p, &state.omega);
                let sol = self.solve_row(u_nom, &g, -alpha * h - dt, u_max.as_deref(), extra)?;
                Ok(Filtered::unchecked(h, h, g, dt, n, sol, state.omega))
            }
        }
    }

    /// The distance baseline: one spherical row `‖p_i‖² − s_d² ≥ 0` per point, all in one
    /// Clarabel QP.
    pub(super) fn distance_row(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<Filtered> {
        let (dim, r) = (self.dim(), state.rotation);
        let alpha = self.config.alpha;
        let u_max = self.config.u_max.clone();
        let pts = self.selected_f64(scan).to_vec();
        let n = pts.len() / dim;
        let sd2 = self.config.safety_distance * self.config.safety_distance;
        self.rows.clear();
        let (mut h_min, mut g_near, mut stuck) = (f64::MAX, [0.0; 3], false);
        for i in 0..n {
            let p = &pts[i * dim..(i + 1) * dim];
            let d = to_world(&r, dim, &[p[0], p[1], if dim == 3 { p[2] } else { 0.0 }]);
            let h = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - sd2;
            if !h.is_finite() {
                return Err(too_far());
            }
            let g = [-2.0 * d[0], -2.0 * d[1], -2.0 * d[2]];
            self.rows.push(&g[..dim], -alpha * h)?;
            // a violated row no direction helps (a point at the robot's centre)
            stuck |= -alpha * h > 0.0 && (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt() <= self.config.grad_eps;
            if h < h_min {
                (h_min, g_near) = (h, g);
            }
        }
        if let Some(e) = extra {
            self.rows.extend(e)?;
        }
        // stop, as the composite does with a vanishing gradient (see `qp`)
        let sol = if stuck { QpSolution { u: [0.0; MAX_VARS], active: true, feasible: false } } else { solve_rows(u_nom, &self.rows, u_max.as_deref())? };
        Ok(Filtered::unchecked(h_min, h_min, g_near, 0.0, n, sol, state.omega))
    }
}

/// The error of a point whose barrier is no finite number: the composite kernel's.
fn too_far() -> Error {
    Error::invalid("points", "contains NaN or inf (or a coordinate too large to square)")
}
