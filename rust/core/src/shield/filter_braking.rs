//! The braking shield's filter: the composite row over velocity and rotation, checked against
//! the body's braking (see `docs/braking.md`).

use super::braking::{self, Sweep};
use super::conic::LinearConstraints;
use super::filter::Shield;
use super::filter::{to_world, Filtered};
use super::input::{BodyState, Points, Scan};
use super::qp::{QpSolution, MAX_VARS};
use crate::error::{Error, Result};

/// The fractions of the row's command the braking shield tries, in turn, before it brakes:
/// near a wall the full command may fail the check while a slower one of the same direction
/// passes (a robot standing by a wall would otherwise brake for ever).
const BRAKING_SCALES: [f64; 4] = [1.0, 0.5, 0.25, 0.125];

impl Shield {
    /// The braking shield: the composite row over velocity and rotation, then the braking check
    /// of the command, its fractions, or the brake (see `docs/braking.md`).
    pub(super) fn braking_row(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<Filtered> {
        let (dim, r) = (self.dim(), state.rotation);
        let alpha = self.config.alpha;
        let u_max = self.config.u_max.clone();
        let (mut braked, mut sweep_h) = (false, f64::NAN);
        let still = BodyState { omega: [0.0; 3], ..*state };
        let b = self.barrier(scan, &still)?;
        let g = to_world(&r, dim, &b.grad_body);
        // variables (u, ω): the rotation term of ∂H/∂t is linear in ω
        let nw = if dim == 2 { 1 } else { 3 };
        let n = dim + nw;
        let mut x_nom = [0.0; MAX_VARS];
        let mut row = [0.0; MAX_VARS];
        let mut lim = [0.0; MAX_VARS];
        x_nom[..dim].copy_from_slice(u_nom);
        row[..dim].copy_from_slice(&g[..dim]);
        let t = &self.config.braking.tracker;
        match &u_max {
            Some(m) => lim[..dim].copy_from_slice(m),
            None => lim[..2].copy_from_slice(&t.v_max),
        }
        // the rotation enters the QP as w·ω, so its distance counts w² times a speed's
        let w = self.config.rotation_weight;
        for k in 0..nw {
            let axis = if dim == 2 { 2 } else { k };
            x_nom[dim + k] = w * state.omega[axis];
            row[dim + k] = b.grad_omega[axis] / w;
            lim[dim + k] = w * t.w_max;
        }
        let mut sol = self.solve_row_n(&x_nom[..n], &row[..n], -alpha * b.value, &lim[..n], extra)?;
        for k in dim..n {
            sol.u[k] /= w;
        }
        let recovering = b.h_min < 0.0;
        if dim == 2 && !recovering && b.num_points > 0 {
            let v0 = *state.velocity.as_ref().ok_or_else(|| Error::invalid("velocity", "the braking shield needs the body's measured velocity (v_x, v_y, ω), body frame"))?;
            let cmd = crate::math::mat_t_vec(&r, &[sol.u[0], sol.u[1], 0.0]);
            let semi = self.envelope.semi_axes();
            // the row's command, else the largest of its fractions that passes, else the
            // brake: the command's check in one pass over the points, its fractions'
            // together in a second
            let passes = |h: f64, here: f64| h >= 0.0 || h >= here - braking::WORSE;
            let model = self.config.braking;
            let mut path = std::mem::take(&mut self.brake_path);
            let w_cmd = sol.u[2];
            let mut sweep = |scale: f64| model.sweep_with(v0, [scale * cmd[0], scale * cmd[1], scale * w_cmd], [semi[0], semi[1]], &mut path);
            let ([h], here) = self.sweep_least_h(scan, &[sweep(1.0)]);
            sweep_h = h;
            let mut passed = passes(h, here).then_some(1.0);
            if passed.is_none() {
                let fractions = [sweep(BRAKING_SCALES[1]), sweep(BRAKING_SCALES[2]), sweep(BRAKING_SCALES[3])];
                let (hs, here) = self.sweep_least_h(scan, &fractions);
                passed = (0..3).find(|&k| passes(hs[k], here)).map(|k| BRAKING_SCALES[k + 1]);
            }
            self.brake_path = path;
            match passed {
                Some(1.0) => {}
                Some(scale) => {
                    sol.u.iter_mut().for_each(|v| *v *= scale);
                    sol.active = true;
                }
                None => {
                    braked = true;
                    sol = QpSolution { u: [0.0; MAX_VARS], active: true, feasible: sol.feasible };
                }
            }
        }
        let mut u = [0.0; MAX_VARS];
        u[..dim].copy_from_slice(&sol.u[..dim]);
        let mut omega_out = [0.0; 3];
        if dim == 2 {
            omega_out[2] = sol.u[2];
        } else {
            omega_out.copy_from_slice(&sol.u[3..6]);
        }
        let dh_dt = (0..3).map(|k| b.grad_omega[k] * omega_out[k]).sum();
        Ok(Filtered { value: b.value, h_min: b.h_min, grad_p: g, dh_dt, num_points: b.num_points, sol: QpSolution { u, ..sol }, omega: omega_out, braked, recovering, sweep_h })
    }

    /// The braking check's least `h` over the points the composite used.
    fn sweep_least_h<const K: usize>(&self, scan: &Scan, sweeps: &[Sweep; K]) -> ([f64; K], f64) {
        if self.config.scan.downsamples() {
            // the down-sampled points (already moved, cropped and banded), as the barrier took them
            return match scan.points {
                Points::F32(_) => braking::least_h_of(sweeps, &self.buf32, self.dim(), None, f64::INFINITY, None, self.level),
                Points::F64(_) => braking::least_h_of(sweeps, &self.buf64, self.dim(), None, f64::INFINITY, None, self.level),
            };
        }
        let crop = self.config.scan.crop_radius.unwrap_or(f64::INFINITY);
        let band = if scan.stride == 3 { self.config.scan.height_band } else { None };
        match scan.points {
            Points::F32(p) => braking::least_h_of(sweeps, p, scan.stride, scan.motion, crop, band, self.level),
            Points::F64(p) => braking::least_h_of(sweeps, p, scan.stride, scan.motion, crop, band, self.level),
        }
    }
}
