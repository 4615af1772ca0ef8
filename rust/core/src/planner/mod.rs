//! The reactive inspection (view) planner of the paper, Sec. IV-A, Eq. (flip):
//!
//! `p_d(k+1) = p̂_r(k) + ν_x d_insp + ν_y d_hov + ν_z d_vov`, `ψ(k+1) = atan2(ν_x,y, ν_x,x)`
//!
//! with `p_nn` the nearest observed surface point, `ν_x = (p_nn − p̂_r)/‖p_nn − p̂_r‖`,
//! `ν_y = ν_up × ν_x`, `ν_z = ν_x × ν_y`, `d_insp = ‖p_nn − p̂_r‖ − d_view`,
//! `d_hov = 2 tan(α/2) ‖p_nn − p̂_r‖ (1 − γ_H)`, `d_vov = 2 tan(β/2) ‖p_nn − p̂_r‖ (1 − γ_V)`.
//!
//! It runs on the *estimated* pose: points seen in the body frame are placed in the world with
//! the odometry estimate, so an odometry jump fools it exactly as in the paper's Scenario 2.
//!
//! Two ways ([`ViewPlannerConfig::planar`]): **planar** (the default, a ground robot, as in
//! the paper's quadruped experiments, which "ignore the vertical overlap condition"): `p_nn` is
//! the point nearest in the horizontal plane and `ν_x` horizontal, so `ν_z = ẑ` and the
//! vertical term would move only a height the plan does not have: `γ_V` must be 1 there.
//! **3D**: the equation as written, `p_nn` the nearest point in space, `ν_y` the unit vector
//! along `ν_up × ν_x` (the paper calls the three unit vectors) and `p_d` with a height; a
//! nearest point straight above or below the robot leaves no horizontal direction, and then
//! `ν_y` and `ψ` are those of the heading the step starts from.

use crate::error::{Error, Result};
use crate::math::{cross, rot_z, Vec3};

/// Parameters of the view planner; `Default` holds the paper's values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPlannerConfig {
    /// Desired viewing distance `d_view` (m).
    pub d_view: f64,
    /// Horizontal overlap `γ_H` in `[0, 1)`.
    pub gamma_h: f64,
    /// Vertical overlap `γ_V` in `[0, 1]`; 1 ignores vertical motion (the paper's quadruped).
    pub gamma_v: f64,
    /// Horizontal camera field of view `α` (rad).
    pub fov_h: f64,
    /// Vertical camera field of view `β` (rad).
    pub fov_v: f64,
    /// Steps of the predicted inspection path.
    pub horizon: usize,
    /// Plan in the horizontal plane (a ground robot; `γ_V` must be 1) or in space (see the
    /// module's doc).
    pub planar: bool,
    /// A new reference is planned once the estimate is within this distance (m) of the current one.
    pub reach_threshold: f64,
}

impl Default for ViewPlannerConfig {
    fn default() -> Self {
        Self { d_view: 1.5, gamma_h: 0.5, gamma_v: 1.0, fov_h: 69.4_f64.to_radians(), fov_v: 45.0_f64.to_radians(), horizon: 5, planar: true, reach_threshold: 0.3 }
    }
}

/// A reference view pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPose {
    /// Desired position `p_d` (world frame, m); in planar use its `z` is the estimate's.
    pub position: Vec3,
    /// Desired yaw `ψ` (rad).
    pub yaw: f64,
}

/// The stateful reactive view planner: holds the current reference.
#[derive(Debug, Clone)]
pub struct ViewPlanner {
    config: ViewPlannerConfig,
    current: Option<ViewPose>,
    world: Vec<Vec3>,
}

/// Most steps of a predicted path ([`ViewPlannerConfig::horizon`]; the paper leaves its `N`
/// open, our default is 5).
pub const MAX_HORIZON: usize = 10_000;

/// Largest coordinate (m) of points and positions the planner takes: their distances are
/// computed without overflow far beyond any map.
pub const MAX_COORDINATE: f64 = 1e9;

impl ViewPlanner {
    /// Validates `config`.
    pub fn new(config: ViewPlannerConfig) -> Result<Self> {
        let c = &config;
        let pos = |name: &'static str, v: f64| if v.is_finite() && v > 0.0 { Ok(()) } else { Err(Error::invalid(name, format!("must be finite and > 0, got {v}"))) };
        pos("d_view", c.d_view)?;
        pos("reach_threshold", c.reach_threshold)?;
        if !(0.0..1.0).contains(&c.gamma_h) {
            return Err(Error::invalid("gamma_h", format!("must be in [0, 1), got {}", c.gamma_h)));
        }
        if !(0.0..=1.0).contains(&c.gamma_v) {
            return Err(Error::invalid("gamma_v", format!("must be in [0, 1], got {}", c.gamma_v)));
        }
        if c.planar && c.gamma_v != 1.0 {
            return Err(Error::invalid("gamma_v", format!("must be 1 for a planar planner (its vertical term moves only a height the plan does not have; plan in 3D for it), got {}", c.gamma_v)));
        }
        for (name, v) in [("fov_h", c.fov_h), ("fov_v", c.fov_v)] {
            if !(v > 0.0 && v < std::f64::consts::PI) {
                return Err(Error::invalid(name, format!("must be in (0, π) rad, got {v}")));
            }
        }
        if !(1..=MAX_HORIZON).contains(&c.horizon) {
            return Err(Error::invalid("horizon", format!("must be from 1 to {MAX_HORIZON}, got {}", c.horizon)));
        }
        Ok(Self { config, current: None, world: Vec::new() })
    }

    /// The configuration.
    pub fn config(&self) -> &ViewPlannerConfig {
        &self.config
    }

    /// The current reference, if any.
    pub fn current(&self) -> Option<ViewPose> {
        self.current
    }

    /// Forgets the current reference.
    pub fn reset(&mut self) {
        self.current = None;
    }

    /// Checks the inputs of every call; each error names its argument.
    fn check(points_body: &[f64], stride: usize, position: &Vec3, yaw: f64) -> Result<()> {
        if stride != 2 && stride != 3 || !points_body.len().is_multiple_of(stride) {
            return Err(Error::invalid("points", format!("expected rows of 2 or 3 coordinates, got {} values with stride {stride}", points_body.len())));
        }
        let within = |v: &f64| v.abs() <= MAX_COORDINATE;
        if !points_body.iter().all(within) {
            return Err(Error::invalid("points", format!("must be finite and within {MAX_COORDINATE:e} m")));
        }
        if !position.iter().all(within) {
            return Err(Error::invalid("position", format!("must be finite and within {MAX_COORDINATE:e} m, got {position:?}")));
        }
        if !yaw.is_finite() {
            return Err(Error::invalid("yaw", format!("must be finite, got {yaw}")));
        }
        Ok(())
    }

    fn load(&mut self, points_body: &[f64], stride: usize, position: &Vec3, yaw: f64) -> Result<()> {
        Self::check(points_body, stride, position, yaw)?;
        let r = rot_z(yaw);
        self.world.clear();
        for c in points_body.chunks_exact(stride) {
            let z = if stride == 3 { c[2] } else { 0.0 };
            let w = crate::math::mat_vec(&r, &[c[0], c[1], z]);
            self.world.push([w[0] + position[0], w[1] + position[1], w[2] + position[2]]);
        }
        Ok(())
    }

    /// One step of Eq. (flip) from `from`, heading `yaw`, against the loaded world points;
    /// `None` without points apart from `from` (in the plane: off its vertical line), which
    /// give no direction.
    fn step(&self, from: &Vec3, yaw: f64) -> Option<ViewPose> {
        let c = &self.config;
        let vertical = if c.planar { 0.0 } else { 1.0 };
        let offset = |p: &Vec3| [p[0] - from[0], p[1] - from[1], vertical * (p[2] - from[2])];
        let norm = |d: [f64; 3]| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let (dist, d) = self.world.iter().map(|p| (norm(offset(p)), offset(p))).filter(|&(r, _)| r > 0.0).min_by(|a, b| a.0.total_cmp(&b.0))?;
        let nx = [d[0] / dist, d[1] / dist, d[2] / dist];
        let up_x = cross(&[0.0, 0.0, 1.0], &nx);
        let across = (up_x[0] * up_x[0] + up_x[1] * up_x[1]).sqrt();
        // (straight above or below: the heading the step starts from)
        let ny = if across > 0.0 { [up_x[0] / across, up_x[1] / across, 0.0] } else { [-yaw.sin(), yaw.cos(), 0.0] };
        let nz = cross(&nx, &ny);
        let d_insp = dist - c.d_view;
        let d_hov = 2.0 * (c.fov_h / 2.0).tan() * dist * (1.0 - c.gamma_h);
        let d_vov = 2.0 * (c.fov_v / 2.0).tan() * dist * (1.0 - c.gamma_v);
        let mut p = *from;
        for k in 0..3 {
            p[k] += nx[k] * d_insp + ny[k] * d_hov + nz[k] * d_vov;
        }
        Some(ViewPose { position: p, yaw: if across > 0.0 { nx[1].atan2(nx[0]) } else { yaw } })
    }

    /// Plans one reference from body-frame `points` seen at the estimated pose
    /// (`position`, `yaw`), without touching the held reference.
    pub fn plan(&mut self, points: &[f64], stride: usize, position: &Vec3, yaw: f64) -> Result<Option<ViewPose>> {
        self.load(points, stride, position, yaw)?;
        Ok(self.step(position, yaw))
    }

    /// The predicted inspection path: Eq. (flip) applied `horizon` times from the estimate.
    pub fn predict_path(&mut self, points: &[f64], stride: usize, position: &Vec3, yaw: f64) -> Result<Vec<ViewPose>> {
        self.load(points, stride, position, yaw)?;
        let mut path = Vec::new();
        let (mut from, mut heading) = (*position, yaw);
        for _ in 0..self.config.horizon {
            match self.step(&from, heading) {
                Some(v) => {
                    (from, heading) = (v.position, v.yaw);
                    path.push(v);
                }
                None => break,
            }
        }
        Ok(path)
    }

    /// The reference to track now: the held one until the estimate comes within
    /// `reach_threshold` of it, then a newly planned one.
    pub fn update(&mut self, points: &[f64], stride: usize, position: &Vec3, yaw: f64) -> Result<Option<ViewPose>> {
        // (the inputs are checked on every call, also while the held reference stands)
        Self::check(points, stride, position, yaw)?;
        let reached = match self.current {
            None => true,
            Some(v) => {
                let dz = if self.config.planar { 0.0 } else { v.position[2] - position[2] };
                ((v.position[0] - position[0]).powi(2) + (v.position[1] - position[1]).powi(2) + dz * dz).sqrt() < self.config.reach_threshold
            }
        };
        if reached {
            if let Some(v) = self.plan(points, stride, position, yaw)? {
                self.current = Some(v);
            }
        }
        Ok(self.current)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall_right() -> Vec<f64> {
        // a 40 m wall 2 m to the robot's right (y = −2), points every 5 cm
        (-400..=400).flat_map(|k| [k as f64 * 0.05, -2.0]).collect()
    }

    /// A horizon beyond the bound is an error (2^40 aborted the process allocating the path);
    /// inputs are checked on every update, also while a reference is held; each named.
    #[test]
    fn bounds_and_checks_name_the_argument() {
        for h in [0, MAX_HORIZON + 1, 1 << 40] {
            let e = ViewPlanner::new(ViewPlannerConfig { horizon: h, ..ViewPlannerConfig::default() }).unwrap_err().to_string();
            assert!(e.contains("`horizon`"), "{e}");
        }
        let mut p = ViewPlanner::new(ViewPlannerConfig { horizon: MAX_HORIZON, ..ViewPlannerConfig::default() }).unwrap();
        assert!(p.predict_path(&wall_right(), 2, &[0.0; 3], 0.0).unwrap().len() <= MAX_HORIZON);
        assert!(p.update(&wall_right(), 2, &[0.0; 3], 0.0).unwrap().is_some());
        for (pts, pos, yaw, name) in [
            (wall_right(), [f64::NAN, 0.0, 0.0], 0.0, "position"),
            (wall_right(), [0.0; 3], f64::NAN, "yaw"),
            (vec![1e200, 1e200], [0.0; 3], 0.0, "points"),
            (vec![f64::NAN, 0.0], [0.0; 3], 0.0, "points"),
        ] {
            let e = p.update(&pts, 2, &pos, yaw).unwrap_err().to_string();
            assert!(e.contains(&format!("`{name}`")), "{e}");
            let e = p.plan(&pts, 2, &pos, yaw).unwrap_err().to_string();
            assert!(e.contains(&format!("`{name}`")), "{e}");
        }
    }

    #[test]
    fn flip_step_matches_the_equation() {
        let mut p = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        let v = p.plan(&wall_right(), 2, &[0.0; 3], 0.0).unwrap().unwrap();
        // p_nn = (0, −2): ν_x = (0, −1), ν_y = ẑ × ν_x = (1, 0); d_insp = 0.5
        let d_hov = 2.0 * (69.4_f64.to_radians() / 2.0).tan() * 2.0 * 0.5;
        assert!((v.position[0] - d_hov).abs() < 1e-12);
        assert!((v.position[1] - (-0.5)).abs() < 1e-12);
        assert!((v.yaw + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn planner_uses_the_estimated_pose() {
        let mut p = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        let truth = p.plan(&wall_right(), 2, &[0.0; 3], 0.0).unwrap().unwrap();
        let jumped = p.plan(&wall_right(), 2, &[120.0, 0.0, 0.0], 0.0).unwrap().unwrap();
        assert!((jumped.position[0] - truth.position[0] - 120.0).abs() < 1e-9);
    }

    #[test]
    fn reference_is_held_until_reached() {
        let mut p = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        let first = p.update(&wall_right(), 2, &[0.0; 3], 0.0).unwrap().unwrap();
        let held = p.update(&wall_right(), 2, &[0.2, 0.0, 0.0], 0.0).unwrap().unwrap();
        assert_eq!(first, held);
        let near = [first.position[0] - 0.1, first.position[1], 0.0];
        let next = p.update(&wall_right(), 2, &near, 0.0).unwrap().unwrap();
        assert!(next.position[0] > first.position[0]);
    }

    #[test]
    fn predicted_path_advances_along_the_wall() {
        let mut p = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        let path = p.predict_path(&wall_right(), 2, &[0.0, 0.0, 0.0], 0.0).unwrap();
        assert_eq!(path.len(), 5);
        for w in path.windows(2) {
            assert!(w[1].position[0] > w[0].position[0]);
            assert!((w[1].position[1] + 0.5).abs() < 0.02, "keeps d_view from the wall (up to the 5 cm point spacing)");
        }
    }

    /// The points turned by the estimated yaw (R, not Rᵀ): a wall seen 2 m to the body's
    /// right while heading 0.8 rad lies along the heading, 2 m to its right in the world.
    #[test]
    fn flip_step_turns_the_points_by_the_yaw() {
        let yaw: f64 = 0.8;
        let mut p = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        let v = p.plan(&wall_right(), 2, &[1.0, 2.0, 0.0], yaw).unwrap().unwrap();
        let d_hov = 2.0 * (69.4_f64.to_radians() / 2.0).tan() * 2.0 * 0.5;
        // body frame: 0.5 toward the wall (−y), d_hov along it (+x); into the world by R(yaw)
        let (c, s) = (yaw.cos(), yaw.sin());
        let want = [1.0 + c * d_hov + s * 0.5, 2.0 + s * d_hov - c * 0.5];
        assert!((v.position[0] - want[0]).abs() < 1e-12 && (v.position[1] - want[1]).abs() < 1e-12, "{v:?} {want:?}");
        assert!((v.yaw - (yaw - std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
    }

    /// Planar: the nearest point in the plane (a point below the robot is not the nearest),
    /// and γ_V must be 1; 3D: the nearest in space, the equation with its vertical term.
    #[test]
    fn planar_and_spatial_planning() {
        // a point 0.5 m straight below, a wall 2 m to the right at the robot's height
        let pts: Vec<f64> = [0.0, 0.0, -0.5].into_iter().chain(wall_right().chunks(2).flat_map(|c| [c[0], c[1], 0.0])).collect();
        let mut planar = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        let v = planar.plan(&pts, 3, &[0.0; 3], 0.0).unwrap().unwrap();
        assert!((v.yaw + std::f64::consts::FRAC_PI_2).abs() < 1e-12 && v.position[2] == 0.0);
        let e = ViewPlanner::new(ViewPlannerConfig { gamma_v: 0.5, ..Default::default() }).unwrap_err().to_string();
        assert!(e.contains("`gamma_v`") && e.contains("planar"), "{e}");
        // 3D: a point 1 m ahead and 1 m up; ν_x = (1, 0, 1)/√2, ν_y = (0, 1, 0), ν_z = (−1, 0, 1)/√2
        let config = ViewPlannerConfig { planar: false, gamma_v: 0.0, ..Default::default() };
        let mut space = ViewPlanner::new(config).unwrap();
        let v = space.plan(&[1.0, 0.0, 1.0], 3, &[0.0; 3], 0.0).unwrap().unwrap();
        let dist = 2f64.sqrt();
        let (d_insp, d_hov, d_vov) = (dist - 1.5, 2.0 * (config.fov_h / 2.0).tan() * dist * 0.5, 2.0 * (config.fov_v / 2.0).tan() * dist);
        let r = std::f64::consts::FRAC_1_SQRT_2;
        let want = [r * d_insp - r * d_vov, d_hov, r * d_insp + r * d_vov];
        for k in 0..3 {
            assert!((v.position[k] - want[k]).abs() < 1e-12, "{v:?} {want:?}");
        }
        assert!(v.yaw.abs() < 1e-12);
        // straight above: the heading the step starts from
        let v = space.plan(&[0.0, 0.0, 2.0], 3, &[0.0; 3], 0.3).unwrap().unwrap();
        // ν_x = ẑ, ν_y = (−sin 0.3, cos 0.3, 0), ν_z = ν_x × ν_y = (−cos 0.3, −sin 0.3, 0)
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let (d_hov, d_vov) = (2.0 * (config.fov_h / 2.0).tan() * 2.0 * 0.5, 2.0 * (config.fov_v / 2.0).tan() * 2.0);
        let want = [-s * d_hov - c * d_vov, c * d_hov - s * d_vov, 0.5];
        assert!((v.yaw - 0.3).abs() < 1e-12, "{v:?}");
        for k in 0..3 {
            assert!((v.position[k] - want[k]).abs() < 1e-12, "{v:?} {want:?}");
        }
    }

    #[test]
    fn bad_config_and_input_are_errors() {
        assert!(ViewPlanner::new(ViewPlannerConfig { d_view: 0.0, ..Default::default() }).is_err());
        assert!(ViewPlanner::new(ViewPlannerConfig { gamma_h: 1.0, ..Default::default() }).is_err());
        let mut p = ViewPlanner::new(ViewPlannerConfig::default()).unwrap();
        assert!(p.plan(&[f64::NAN, 0.0], 2, &[0.0; 3], 0.0).is_err());
        assert_eq!(p.plan(&[], 2, &[0.0; 3], 0.0).unwrap(), None);
    }
}
