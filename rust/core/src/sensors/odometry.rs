//! The pose estimate the planner sees: true motion plus drift and scheduled faults.
//!
//! Each step the true body-frame displacement is integrated with Gaussian noise and a yaw
//! bias; the noise is a random walk in the distance travelled (a step's error has variance
//! `σ² · |d|`, so the error's standard deviation after `D` metres is `σ · √D` whatever the
//! control period); scheduled faults then act on the estimate: a position jump (the
//! paper's Scenario 2, "exceeding 100 m"), a yaw jump, or a freeze (the estimate stops moving).

use rand::Rng;

use super::noise::standard_normal;
use crate::error::Result;
use crate::math::Real;
use crate::world::{wrap_angle, Pose2};
pub use crate::world::{OdometryConfig, OdometryFault};

/// How much earlier (s) than its time an update may come and still apply a fault: far below
/// any control period, far above the rounding of a sum of steps.
pub const FAULT_TIME_TOLERANCE: Real = 1e-9;

/// Whether a fault at `time` is due in the update `(t_prev, t]`.
fn due(time: Real, t_prev: Real, t: Real) -> bool {
    let at = time - FAULT_TIME_TOLERANCE;
    at > t_prev && at <= t
}

/// The running odometry estimate.
#[derive(Debug, Clone)]
pub struct Odometry {
    config: OdometryConfig,
    estimate: Pose2,
    last_true: Pose2,
    last_time: Real,
}

impl Odometry {
    /// Starts with the estimate equal to the true `start` pose at time `t0` (s).
    ///
    /// A jump or yaw jump scheduled at or before `t0` applies from the start (the estimate
    /// starts off the truth); a later one at the first update at or after its time, within
    /// [`FAULT_TIME_TOLERANCE`] (a jump at 20 s fires at the step of time 20 even if adding up
    /// the steps rounds it to 19.999…).
    pub fn new(config: OdometryConfig, start: Pose2, t0: Real) -> Result<Self> {
        config.validate()?;
        start.validate("start")?;
        let mut odo = Self { config, estimate: start, last_true: start, last_time: t0 };
        odo.apply_faults(Real::NEG_INFINITY, t0);
        Ok(odo)
    }

    /// Applies the jumps and yaw jumps due in `(t_prev, t]` (within the tolerance).
    fn apply_faults(&mut self, t_prev: Real, t: Real) {
        for f in &self.config.faults {
            match *f {
                OdometryFault::Jump { time, dx, dy } if due(time, t_prev, t) => {
                    self.estimate.x += dx;
                    self.estimate.y += dy;
                }
                OdometryFault::YawJump { time, dyaw } if due(time, t_prev, t) => {
                    self.estimate.yaw = wrap_angle(self.estimate.yaw + dyaw);
                }
                _ => {}
            }
        }
    }

    /// The current estimate.
    pub fn estimate(&self) -> Pose2 {
        self.estimate
    }

    /// The configuration.
    pub fn config(&self) -> &OdometryConfig {
        &self.config
    }

    /// Advances to time `t` (s) given the true pose then; returns the new estimate.
    pub fn update<R: Rng + ?Sized>(&mut self, t: Real, true_pose: Pose2, rng: &mut R) -> Pose2 {
        let c = &self.config;
        let t_prev = self.last_time;
        let frozen = c.faults.iter().any(|f| matches!(*f, OdometryFault::Freeze { start, end } if t > start && t_prev < end));
        let d = self.last_true.between(&true_pose);
        if !frozen {
            let (mut dx, mut dy, mut dyaw) = (d.x, d.y, d.yaw);
            // (a random walk in the distance: variance σ²·|d| per step, not (σ·|d|)², whose sum
            // over a distance shrank with the control period)
            if c.translation_noise > 0.0 {
                dx += c.translation_noise * dx.abs().sqrt() * standard_normal(rng);
                dy += c.translation_noise * dy.abs().sqrt() * standard_normal(rng);
            }
            if c.yaw_noise > 0.0 {
                dyaw += c.yaw_noise * dyaw.abs().sqrt() * standard_normal(rng);
            }
            dyaw += c.yaw_bias * (t - t_prev);
            self.estimate = self.estimate.compose(&Pose2::new(dx, dy, dyaw));
        }
        self.apply_faults(t_prev, t);
        self.last_true = true_pose;
        self.last_time = t;
        self.estimate
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn drive(cfg: OdometryConfig) -> Vec<(Pose2, Pose2)> {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut odo = Odometry::new(cfg, Pose2::default(), 0.0).unwrap();
        (1..=300)
            .map(|k| {
                let t = k as Real * 0.1;
                let truth = Pose2::new(0.5 * t, 0.0, 0.0);
                (truth, odo.update(t, truth, &mut rng))
            })
            .collect()
    }

    #[test]
    fn perfect_odometry_tracks_truth() {
        for (truth, est) in drive(OdometryConfig::default()) {
            assert!((truth.x - est.x).abs() < 1e-9 && (truth.y - est.y).abs() < 1e-12);
        }
    }

    #[test]
    fn jump_happens_once_at_its_time() {
        let cfg = OdometryConfig { faults: vec![OdometryFault::Jump { time: 20.0, dx: 120.0, dy: 0.0 }], ..Default::default() };
        let run = drive(cfg);
        let before = run[198]; // t = 19.9
        let after = run[200]; // t = 20.1
        assert!((before.1.x - before.0.x).abs() < 1e-9);
        assert!((after.1.x - after.0.x - 120.0).abs() < 1e-9);
        assert!((run[299].1.x - run[299].0.x - 120.0).abs() < 1e-9);
    }

    #[test]
    fn freeze_stops_the_estimate() {
        let cfg = OdometryConfig { faults: vec![OdometryFault::Freeze { start: 5.0, end: 10.0 }], ..Default::default() };
        let run = drive(cfg);
        // estimate at t = 10 equals estimate at t = 5; afterwards it moves again but lags by 2.5 m
        assert!((run[99].1.x - run[49].1.x).abs() < 1e-12);
        assert!((run[299].0.x - run[299].1.x - 2.5).abs() < 1e-9);
    }

    #[test]
    fn noisy_odometry_drifts_but_stays_plausible() {
        let cfg = OdometryConfig { translation_noise: 0.05, yaw_noise: 0.0, yaw_bias: 0.001, faults: vec![] };
        let (truth, est) = drive(cfg)[299];
        let err = (truth.x - est.x).hypot(truth.y - est.y);
        assert!(err > 1e-4 && err < 2.0, "drift {err}");
    }

    /// The std of the error after a fixed distance (or turn) over many seeds is `σ · √D` at a
    /// control period of 0.01 s and of 0.1 s alike (it was `σ · √(D · step)`: 0.019 m after
    /// 11.7 m at 0.01 s, 0.050 at 0.1 s).
    #[test]
    fn drift_std_grows_with_the_square_root_of_distance_not_with_dt() {
        let std_after = |dt: Real, turn: bool| {
            let (speed, dist, seeds) = (1.0, 10.0, 2000u64);
            let steps = (dist / (speed * dt)).round() as usize;
            let cfg = OdometryConfig { translation_noise: 0.05, yaw_noise: 0.02, ..Default::default() };
            let errs: Vec<Real> = (0..seeds)
                .map(|seed| {
                    let mut rng = ChaCha8Rng::seed_from_u64(seed);
                    let mut odo = Odometry::new(cfg.clone(), Pose2::default(), 0.0).unwrap();
                    let mut est = Pose2::default();
                    let mut truth = Pose2::default();
                    for k in 1..=steps {
                        let t = k as Real * dt;
                        // straight along x, or turning in place (unwrapped yaw below π)
                        truth = if turn { Pose2::new(0.0, 0.0, 0.3 * t) } else { Pose2::new(speed * t, 0.0, 0.0) };
                        est = odo.update(t, truth, &mut rng);
                    }
                    if turn {
                        wrap_angle(est.yaw - truth.yaw)
                    } else {
                        est.x - truth.x
                    }
                })
                .collect();
            let mean = errs.iter().sum::<Real>() / errs.len() as Real;
            (errs.iter().map(|e| (e - mean).powi(2)).sum::<Real>() / (errs.len() - 1) as Real).sqrt()
        };
        let want_x = 0.05 * (10.0 as Real).sqrt();
        let want_yaw = 0.02 * (3.0 as Real).sqrt();
        for dt in [0.01, 0.1] {
            let sx = std_after(dt, false);
            assert!((sx / want_x - 1.0).abs() < 0.1, "dt {dt}: x error std {sx}, want {want_x}");
            let sy = std_after(dt, true);
            assert!((sy / want_yaw - 1.0).abs() < 0.1, "dt {dt}: yaw error std {sy}, want {want_yaw}");
        }
    }

    #[test]
    fn bad_config_is_an_error() {
        let cfg = OdometryConfig { translation_noise: -1.0, ..Default::default() };
        assert!(Odometry::new(cfg, Pose2::default(), 0.0).is_err());
        let cfg = OdometryConfig { faults: vec![OdometryFault::Freeze { start: 3.0, end: 1.0 }], ..Default::default() };
        assert!(cfg.validate().is_err());
    }
}
