//! The braking shield's filter: the composite row over velocity and rotation shapes the
//! command, the braking check of the footprint decides how much of it is sent (see
//! `docs/braking.md`).

use super::braking::{clearances_of, BrakingModel, Planes, PointSet, Sweep, TOLERANCE};
use super::composite::CompositeBarrier;
use super::conic::LinearConstraints;
use super::filter::Shield;
use super::filter::{to_world, Filtered};
use super::input::{BodyState, Points, Scan};
use super::lane::Lane;
use super::qp::{QpSolution, MAX_VARS};
use crate::error::{Error, Result};
use crate::simd::SimdLevel;

/// Beyond the farthest reach of the candidates' sweeps (m), points are left out of the
/// search's later passes; a sweep reaching past it fails.
const REACH_SLACK: f64 = 0.2;
/// How much nearer than it is (m) a point already within the clearance may appear to a
/// candidate that does not approach it: the rounding of the half-plane offsets.
const ROUNDING: f64 = 1e-9;
/// Rounds of the search for the largest safe fraction of a candidate, each one pass over the
/// points within reach with [`SEARCH_SCALES`] fractions: the bracket shrinks to `4⁻³`.
const SEARCH_ROUNDS: usize = 3;
const SEARCH_SCALES: usize = 3;
/// The row's command is *stalled* when its progress along the nominal command is below this
/// share of the tight-space command's speed: the tight-space candidate is then weighed too.
const STALL: f64 = 0.5;
/// How far ahead (s) a mover's predicted disc is checked against the standing footprint: a
/// mover reaching it within this time makes the shield weigh the escapes.
const THREAT_HORIZON: f64 = 2.5;
/// Turn rate (1/s) per radian between the heading and an escape's direction.
const ESCAPE_TURN_GAIN: f64 = 3.0;
/// How long (s) an escape is held in its check before the brake.
const ESCAPE_HOLD: f64 = 1.0;
/// How much more margin (m) another escape must keep than the one running for the shield to
/// switch: an escape changed at every call goes nowhere.
const ESCAPE_SWITCH: f64 = 0.3;
/// Calls (periods) between reviews of every escape while one runs; in between, the one running
/// is checked alone and kept if it passes.
const ESCAPE_REVIEW: u32 = 5;
/// The escapes' directions in the current body frame: ahead, back, to either side, and the
/// four diagonals.
const ESCAPES: [[f64; 2]; 8] = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [0.7, 0.7], [0.7, -0.7], [-0.7, 0.7], [-0.7, -0.7]];

/// What the check decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Decision {
    /// The command sent (world-frame translation and `ω`), `None` to brake.
    pub command: Option<[f64; 3]>,
    /// The tight-space candidate (the nominal command at most `tight_speed`) was chosen.
    pub tight: bool,
    /// The least clearance of the standing footprint (m).
    pub clearance: f64,
    /// The row's full command's swept clearance less the clearance required (m).
    pub sweep_margin: f64,
    /// The escape sent: its direction in the current body frame.
    pub escape: Option<[f64; 2]>,
}

/// The candidates of one call: the row's command and the tight-space command, body frame.
struct Candidates<'a> {
    /// The moving objects, and the acceleration they may add.
    movers: &'a [crate::sensors::Mover],
    /// The escape running (sent at the previous call), in the current body frame.
    running: Option<[f64; 2]>,
    /// Every escape is weighed at this call (else only the one running, if it passes).
    review: bool,
    mover_accel: f64,
    row: [f64; 3],
    tight: [f64; 3],
    /// The nominal translation's unit direction (zero for a nominal at rest).
    direction: [f64; 2],
    /// Progress (m/s along `direction`) below which the row's command counts as stalled.
    stall: f64,
    /// The standing footprint's points lie farther than every sweep's reach.
    all_far: bool,
    /// Body to world.
    rotation: crate::math::Mat3,
    /// The body's measured velocity.
    v0: [f64; 3],
    /// The world-frame box of the translation.
    box_world: [f64; 2],
    /// The row's and the tight-space command in the world frame (translation, `ω`): what is
    /// sent, scaled, so the box holds exactly.
    row_world: [f64; 3],
    tight_world: [f64; 3],
}

fn progress(c: &Candidates<'_>, cmd: &[f64; 3], scale: f64) -> f64 {
    scale * (cmd[0] * c.direction[0] + cmd[1] * c.direction[1])
}

/// The check on the points of `set`: the row's command, else the largest safe fraction of it
/// or of the tight-space command, whichever makes more progress, else the brake.
fn decide<T: Lane>(model: &BrakingModel, level: SimdLevel, mut set: PointSet<'_, T>, near: &mut Vec<T>, c: &Candidates<'_>, path: &mut Vec<[f64; 2]>, extra: Option<&LinearConstraints>) -> Decision {
    // the movers: the body at rest before any reaches it (see `BrakingModel::mover_margin`)
    let clear_of_movers = |cmd: &[f64; 3]| c.movers.is_empty() || model.mover_margin(c.v0, *cmd, c.movers, c.mover_accel) >= model.clearance();
    let here = Planes::of_footprint(&model.footprint);
    let keep = model.clearance();
    let row = model.sweep_with(c.v0, c.row, path);
    let tight = model.sweep_with(c.v0, c.tight, path);
    // (a fraction's sweep reaching farther than this fails: the points beyond are not kept)
    let reach = row.extent.max(tight.extent) + keep + REACH_SLACK;
    let whole = set;
    near.clear();
    let ([row_raw], clearance) = if c.all_far {
        ([f64::MAX], f64::MAX)
    } else {
        set.reach = set.reach.min(reach);
        clearances_of([&row.planes], &here, set, Some(near), keep, level)
    };
    // the clearance each candidate must keep: the margin; with a point already nearer, no
    // point may come nearer than it is (the swept polygon's exact half-plane clearance, which
    // holds the approach of the translation and the turn to the middle heading), and the
    // growth beyond it (the path's bends, the turn either side, the lag's tail) stays within
    // TOLERANCE: the least clearance never shrinks, so it cannot be ratcheted down
    let within = clearance < keep;
    let required = if within { clearance } else { keep };
    // within the clearance, which side of the footprint a point lies on is only known up to the
    // range noise: near a corner the noise moves a point from one edge's side to the other's.
    // So every edge a point within the clearance may lie against (its half-plane value within
    // `keep` of the point's clearance) is held: no candidate's chord may move toward it
    let held = if within { held_edges(&model.footprint, near, keep) } else { 0 };
    let toward_held = |sw: &Sweep| {
        let (s, c) = sw.heading.sin_cos();
        model.footprint.edges().enumerate().any(|(j, (n, _))| held >> j & 1 == 1 && (c * n[0] - s * n[1]) * sw.chord[0] + (s * n[0] + c * n[1]) * sw.chord[1] > ROUNDING)
    };
    let static_ok = |sw: &Sweep, raw: f64| if within { raw >= clearance - ROUNDING && sw.growth <= TOLERANCE && !toward_held(sw) } else { raw - sw.growth >= keep };
    let passes = |sw: &Sweep, raw: f64, cmd: &[f64; 3]| sw.extent + keep <= reach && static_ok(sw, raw) && clear_of_movers(cmd);
    let sweep_margin = row_raw.min(f64::MAX / 2.0) - row.growth - required;
    let near_set = PointSet { pts: &near[..], stride: 2, motion: None, reach: f64::INFINITY, band: None };
    let largest = |cmd: &[f64; 3], full_passes: bool, path: &mut Vec<[f64; 2]>| -> Option<f64> {
        if full_passes {
            return Some(1.0);
        }
        let (mut lo, mut hi, mut found) = (0.0, 1.0, None);
        for _ in 0..SEARCH_ROUNDS {
            let scales: [f64; SEARCH_SCALES] = std::array::from_fn(|k| lo + (hi - lo) * (k + 1) as f64 / (SEARCH_SCALES + 1) as f64);
            let sweeps: [Sweep; SEARCH_SCALES] = std::array::from_fn(|k| model.sweep_with(c.v0, cmd.map(|v| v * scales[k]), path));
            let (raw, _): ([f64; SEARCH_SCALES], f64) = clearances_of(std::array::from_fn(|k| &sweeps[k].planes), &here, near_set, None, keep, level);
            match (0..SEARCH_SCALES).rev().find(|&k| passes(&sweeps[k], raw[k], &cmd.map(|v| v * scales[k]))) {
                Some(k) => {
                    (lo, found) = (scales[k], Some(scales[k]));
                    if k + 1 < SEARCH_SCALES {
                        hi = scales[k + 1];
                    }
                }
                None => hi = scales[0],
            }
        }
        found
    };
    let mut row_scale = largest(&c.row, passes(&row, row_raw, &c.row), path);
    let (mut row_cmd, mut row_world) = (c.row, c.row_world);
    if within && row_scale != Some(1.0) {
        // within the clearance a turn grows the sweep and a held edge forbids its side: the
        // row's translation alone, less its components toward the held edges, may still
        // carry the footprint away
        let mut t = [c.row[0], c.row[1]];
        for (j, (n, _)) in model.footprint.edges().enumerate() {
            let toward = n[0] * t[0] + n[1] * t[1];
            if held >> j & 1 == 1 && toward > 0.0 {
                t = [t[0] - toward * n[0], t[1] - toward * n[1]];
            }
        }
        let straight = [t[0], t[1], 0.0];
        let world = crate::math::mat_vec(&c.rotation, &straight);
        let sw = model.sweep_with(c.v0, straight, path);
        let ([raw], _) = clearances_of([&sw.planes], &here, near_set, None, keep, level);
        let s = largest(&straight, passes(&sw, raw, &straight), path);
        let speed = |s: Option<f64>, t: &[f64; 3]| s.map_or(-1.0, |s| s * t[0].hypot(t[1]));
        if speed(s, &straight) > speed(row_scale, &c.row) {
            (row_scale, row_cmd, row_world) = (s, straight, [world[0], world[1], 0.0]);
        }
    }
    let row_progress = row_scale.map_or(f64::NEG_INFINITY, |s| progress(c, &row_cmd, s));
    let mut chosen = row_scale.map(|s| (row_world.map(|v| v * s), false));
    // within the clearance the row's command (which raises H: away from the points) goes
    // first; the tight-space command is weighed where the row stalls in free space, or
    // where the row has no safe fraction at all
    if row_progress < c.stall && (!within || row_scale.is_none()) {
        let ([tight_raw], _) = if c.all_far { ([f64::MAX], 0.0) } else { clearances_of([&tight.planes], &here, near_set, None, keep, level) };
        if let Some(s) = largest(&c.tight, passes(&tight, tight_raw, &c.tight), path) {
            let tight_world = c.tight_world.map(|v| v * s);
            // the user's rows hold for the tight-space command as sent (a fraction of a
            // command that meets `aᵀu ≥ b` with b > 0 may not)
            if progress(c, &c.tight, s) > row_progress.max(0.0) + 1e-9 && meets_rows(extra, &tight_world) {
                chosen = Some((tight_world, true));
            }
        }
    }
    // a mover coming at the standing robot: stepping out of its way beats being reached at
    // rest. Each escape is held for ESCAPE_HOLD in its check, then the brake: it passes the
    // static check over every point and keeps the movers' margin while the robot moves
    let mut escape = None;
    if !c.movers.is_empty() && model.standing_mover_margin(c.movers, c.mover_accel, THREAT_HORIZON) < keep {
        let hold = (ESCAPE_HOLD / model.dt).ceil().max(1.0) as usize;
        let t = &model.tracker;
        // an escape runs along a direction fixed in the current frame: the body turns to face
        // it and drives at the most speed the box allows along it
        // (the heading error is the direction's angle less the heading, wrapped: no `atan2` or
        // `sin_cos` per replayed period, the escapes' largest cost)
        let steer = |d: [f64; 2]| {
            let goal = d[1].atan2(d[0]);
            move |th: f64, s: f64, co: f64| {
                let b = [co * d[0] + s * d[1], -s * d[0] + co * d[1]];
                let speed = (t.v_max[0] / b[0].abs().max(1e-12)).min(t.v_max[1] / b[1].abs().max(1e-12));
                let error = (goal - th + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
                [b[0] * speed, b[1] * speed, (ESCAPE_TURN_GAIN * error).clamp(-t.w_max, t.w_max)]
            }
        };
        // the eight directions, and the escape running (last, when there is one)
        const N: usize = ESCAPES.len() + 1;
        let dirs: [[f64; 2]; N] = std::array::from_fn(|k| {
            let d = if k < ESCAPES.len() { ESCAPES[k] } else { c.running.unwrap_or(ESCAPES[0]) };
            let n = d[0].hypot(d[1]);
            [d[0] / n, d[1] / n]
        });
        // the first period's command as sent, within the world-frame box
        let sent = |k: usize| {
            let first = steer(dirs[k])(0.0, 0.0, 1.0);
            let w = crate::math::mat_vec(&c.rotation, &[first[0], first[1], 0.0]);
            let scale = (0..2).map(|j| if w[j].abs() > c.box_world[j] { c.box_world[j] / w[j].abs() } else { 1.0 }).fold(1.0, f64::min);
            [w[0] * scale, w[1] * scale, first[2]]
        };
        // between reviews the escape running is checked alone, and kept if it passes
        let mut pick = None;
        if c.running.is_some() && !c.review {
            let k = N - 1;
            let margin = model.mover_margin_steered(c.v0, hold, c.movers, c.mover_accel, steer(dirs[k]));
            if margin >= keep {
                let sweep = model.sweep_steered(c.v0, hold, path, steer(dirs[k]));
                let first = model.sweep_with(c.v0, steer(dirs[k])(0.0, 0.0, 1.0), path);
                let ([raw, raw1], _) = if c.all_far { ([f64::MAX; 2], 0.0) } else { clearances_of([&sweep.planes, &first.planes], &here, whole, None, keep, level) };
                if static_ok(&sweep, raw) && static_ok(&first, raw1) && meets_rows(extra, &sent(k)) {
                    pick = Some((k, sent(k)));
                }
            }
        }
        if pick.is_none() {
            // the movers' margin first (a replay each): where no escape keeps it, the static
            // checks over every point are not needed
            let margins: [f64; N] =
                std::array::from_fn(|k| if k < ESCAPES.len() || c.running.is_some() { model.mover_margin_steered(c.v0, hold, c.movers, c.mover_accel, steer(dirs[k])) } else { f64::NEG_INFINITY });
            let passing: Vec<(usize, f64, [f64; 3])> = if margins.iter().all(|&m| m < keep) {
                Vec::new()
            } else {
                let sweeps: [Sweep; N] = std::array::from_fn(|k| model.sweep_steered(c.v0, hold, path, steer(dirs[k])));
                let (raw, _) = if c.all_far { ([f64::MAX; N], 0.0) } else { clearances_of(std::array::from_fn(|k| &sweeps[k].planes), &here, whole, None, keep, level) };
                // the first period's command with the brake after it passes too: the next call
                // may find nothing better than the brake, and braking is safe by induction only
                // from what was checked with the brake
                let firsts: [Sweep; N] = std::array::from_fn(|k| model.sweep_with(c.v0, steer(dirs[k])(0.0, 0.0, 1.0), path));
                let (raw1, _) = if c.all_far { ([f64::MAX; N], 0.0) } else { clearances_of(std::array::from_fn(|k| &firsts[k].planes), &here, whole, None, keep, level) };
                // of those keeping the margin while the robot moves, the one keeping the most
                (0..N)
                    .filter(|&k| margins[k] >= keep && static_ok(&sweeps[k], raw[k]) && static_ok(&firsts[k], raw1[k]))
                    .map(|k| (k, margins[k], sent(k)))
                    .filter(|(_, _, w)| meets_rows(extra, w))
                    .collect()
            };
            let best = passing.iter().max_by(|a, b| a.1.total_cmp(&b.1));
            // the escape running goes on unless another keeps clearly more margin: an escape
            // changed at every call goes nowhere
            let running = passing.iter().find(|e| e.0 == N - 1);
            pick = match (running, best) {
                (Some(r), Some(b)) if b.1 <= r.1 + ESCAPE_SWITCH => Some(r),
                (_, b) => b,
            }
            .map(|&(k, _, w)| (k, w));
        }
        if let Some((k, w)) = pick {
            chosen = Some((w, false));
            escape = Some(dirs[k]);
        }
    }
    Decision { command: chosen.map(|(cmd, _)| cmd), tight: chosen.is_some_and(|(_, t)| t), clearance, sweep_margin, escape }
}

/// Whether the world-frame command `u` (translation, `ω`) meets the user's rows `aᵀu ≥ b`, up to
/// their solver's tolerance.
fn meets_rows(extra: Option<&LinearConstraints>, u: &[f64; 3]) -> bool {
    extra.is_none_or(|e| {
        (0..e.len()).all(|k| {
            let (a, b) = e.row(k);
            a.iter().zip(u).map(|(a, u)| a * u).sum::<f64>() >= b - 1e-9 * (1.0 + b.abs())
        })
    })
}

/// The footprint's edges (bit `j` for edge `j`) that a point within `keep` of the footprint
/// may lie against: those whose half-plane value for it is within `keep` of its clearance.
fn held_edges<T: Lane>(fp: &super::braking::Footprint, near: &[T], keep: f64) -> u32 {
    let mut held = 0u32;
    for p in near.chunks_exact(2) {
        let q = [p[0].to_f64(), p[1].to_f64()];
        let c = fp.clearance(q);
        if c < keep {
            for (j, (n, off)) in fp.edges().enumerate() {
                if n[0] * q[0] + n[1] * q[1] - off >= c - keep {
                    held |= 1 << j;
                }
            }
        }
    }
    held
}

impl Shield {
    /// The braking shield: the composite row over velocity and rotation, then the braking
    /// check of the footprint: the row's command, the largest safe fraction of it or of the
    /// tight-space command, or the brake (see `docs/braking.md`).
    pub(super) fn braking_row(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<Filtered> {
        let (dim, r) = (self.dim(), state.rotation);
        let alpha = self.config.alpha;
        let u_max = self.config.u_max.clone();
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
        // moving objects add their share of ∂H/∂t (the robot's own turn is the ω column)
        let dh_movers = self.movers_dh_dt(scan.movers(), b.value);
        let mut sol = self.solve_row_n(&x_nom[..n], &row[..n], -alpha * b.value - dh_movers, &lim[..n], extra)?;
        for k in dim..n {
            sol.u[k] /= w;
        }
        let recovering = b.h_min < 0.0;
        let mut decision = Decision { command: Some([sol.u[0], sol.u[1], sol.u[2]]), tight: false, clearance: f64::MAX, sweep_margin: f64::NAN, escape: None };
        if dim == 2 && (b.num_points > 0 || !scan.movers().is_empty()) {
            let v0 = *state.velocity.as_ref().ok_or_else(|| Error::invalid("velocity", "the braking shield needs the body's measured velocity (v_x, v_y, ω), body frame"))?;
            // the tight-space command: the nominal one in the box and the user's rows
            let nominal = match extra {
                None => None,
                Some(e) => {
                    let mut t = self.solve_row_n(&x_nom[..n], &row[..n], f64::NEG_INFINITY, &lim[..n], Some(e))?;
                    t.u[dim] /= w;
                    Some(t.u)
                }
            };
            let c = self.candidates(&b, state, u_nom, &sol, v0, nominal, scan.movers());
            decision = self.check(scan, &c, extra, state.velocity_error);
            match decision.command {
                Some(cmd) => {
                    let changed = (0..3).any(|k| cmd[k] != sol.u[k]);
                    sol.u[..3].copy_from_slice(&cmd);
                    sol.active |= changed;
                }
                None => sol = QpSolution { u: [0.0; MAX_VARS], active: true, feasible: sol.feasible },
            }
        }
        // the escape sent, kept in the world frame for the next call
        self.escape_calls = if decision.escape.is_some() { self.escape_calls + 1 } else { 0 };
        self.escape = decision.escape.map(|d| {
            let w = crate::math::mat_vec(&r, &[d[0], d[1], 0.0]);
            [w[0], w[1]]
        });
        let mut u = [0.0; MAX_VARS];
        u[..dim].copy_from_slice(&sol.u[..dim]);
        let mut omega_out = [0.0; 3];
        if dim == 2 {
            omega_out[2] = sol.u[2];
        } else {
            omega_out.copy_from_slice(&sol.u[3..6]);
        }
        let dh_dt = (0..3).map(|k| b.grad_omega[k] * omega_out[k]).sum::<f64>() + dh_movers;
        Ok(Filtered {
            value: b.value,
            h_min: b.h_min,
            grad_p: g,
            dh_dt,
            num_points: b.num_points,
            sol: QpSolution { u, ..sol },
            omega: omega_out,
            braked: decision.command.is_none(),
            recovering,
            sweep_h: decision.sweep_margin,
            tight: decision.tight,
            clearance: decision.clearance,
        })
    }

    /// The row's command and the tight-space command in the body frame, and what the
    /// composite pass already tells of the points' distance.
    #[allow(clippy::too_many_arguments)]
    fn candidates<'a>(
        &self,
        b: &CompositeBarrier,
        state: &BodyState,
        u_nom: &[f64],
        sol: &QpSolution,
        v0: [f64; 3],
        nominal: Option<[f64; MAX_VARS]>,
        movers: &'a [crate::sensors::Mover],
    ) -> Candidates<'a> {
        let r = &state.rotation;
        let row_t = crate::math::mat_t_vec(r, &[sol.u[0], sol.u[1], 0.0]);
        let t = &self.config.braking.tracker;
        // the nominal command in the QP's box (world frame), the turn in the tracker's
        let lim = self.config.u_max.as_deref().unwrap_or(&t.v_max);
        let nom_w = match nominal {
            Some(u) => [u[0], u[1], u[2]],
            None => [u_nom[0].clamp(-lim[0], lim[0]), u_nom[1].clamp(-lim[1], lim[1]), state.omega[2].clamp(-t.w_max, t.w_max)],
        };
        let nom_b = crate::math::mat_t_vec(r, &[nom_w[0], nom_w[1], 0.0]);
        let nom = [nom_b[0], nom_b[1], nom_w[2]];
        let speed = nom[0].hypot(nom[1]);
        let cap = if speed > self.config.tight_speed { self.config.tight_speed / speed } else { 1.0 };
        let direction = if speed > 1e-9 { [nom[0] / speed, nom[1] / speed] } else { [0.0; 2] };
        // every point lies outside the ellipse scaled by √(1 + h_min), which holds the disc
        // of radius b_min √(1 + h_min): farther than any sweep reaches (a generous bound)
        let semi = self.envelope.semi_axes();
        let shortest = semi[0].min(semi[1]);
        let model = &self.config.braking;
        let bound = 2.0 * (v0[0].hypot(v0[1]) + t.v_max[0].hypot(t.v_max[1])) * ((v0[0].hypot(v0[1]) + t.v_max[0].hypot(t.v_max[1])) / t.a_max[0].min(t.a_max[1]) + 10.0 * t.tau + 2.0 * model.dt)
            + 3.0 * model.footprint.radius()
            + model.clearance()
            + REACH_SLACK;
        let all_far = b.h_min >= 0.0 && shortest * (1.0 + b.h_min.min(1e12)).sqrt() > bound;
        let running = self.escape.map(|d| {
            let b = crate::math::mat_t_vec(r, &[d[0], d[1], 0.0]);
            [b[0], b[1]]
        });
        Candidates {
            movers,
            running,
            review: self.escape_calls.is_multiple_of(ESCAPE_REVIEW),
            mover_accel: self.config.mover_accel,
            box_world: [lim[0], lim[1]],
            v0,
            row: [row_t[0], row_t[1], sol.u[2]],
            tight: nom.map(|v| v * cap),
            row_world: [sol.u[0], sol.u[1], sol.u[2]],
            tight_world: nom_w.map(|v| v * cap),
            direction,
            stall: STALL * self.config.tight_speed.min(speed),
            all_far,
            rotation: state.rotation,
        }
    }

    /// The check over the points the composite used.
    fn check(&mut self, scan: &Scan, c: &Candidates<'_>, extra: Option<&LinearConstraints>, velocity_error: f64) -> Decision {
        let mut model = self.config.braking;
        if velocity_error > 0.0 {
            // a velocity off by e brakes to a stop within e (|v₀| + e)/a + e (3τ + dt) of the
            // replay's (the acceleration-limited stop's extra distance plus the lag's): kept as
            // more clearance
            let t = &model.tracker;
            let speed = c.v0[0].hypot(c.v0[1]);
            model.brake_margin += velocity_error * ((speed + velocity_error) / t.a_max[0].min(t.a_max[1]) + 3.0 * t.tau + model.dt);
        }
        let mut path = std::mem::take(&mut self.brake_path);
        let level = self.level;
        let out = if self.config.scan.downsamples() {
            // the down-sampled points (already moved, cropped and banded), as the barrier took them
            let dim = self.dim();
            match scan.points {
                Points::F32(_) => decide(&model, level, PointSet { pts: &self.buf32, stride: dim, motion: None, reach: f64::INFINITY, band: None }, &mut self.near32, c, &mut path, extra),
                Points::F64(_) => decide(&model, level, PointSet { pts: &self.buf64, stride: dim, motion: None, reach: f64::INFINITY, band: None }, &mut self.near64, c, &mut path, extra),
            }
        } else {
            let reach = self.config.scan.crop_radius.unwrap_or(f64::INFINITY);
            let band = if scan.stride == 3 { self.config.scan.height_band } else { None };
            match scan.points {
                Points::F32(p) => decide(&model, level, PointSet { pts: p, stride: scan.stride, motion: scan.motion, reach, band }, &mut self.near32, c, &mut path, extra),
                Points::F64(p) => decide(&model, level, PointSet { pts: p, stride: scan.stride, motion: scan.motion, reach, band }, &mut self.near64, c, &mut path, extra),
            }
        };
        self.brake_path = path;
        out
    }
}
