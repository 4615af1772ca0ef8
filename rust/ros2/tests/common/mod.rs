//! Scans and commands the node's tests and the latency example build.

#![allow(dead_code)] // (each test file uses a part)

use shieldnav_ros2::msg::{Header, LaserScan, Twist, Vector3};

/// Beams of the test scans.
pub const BEAMS: usize = 1024;

/// A 360° scan of [`BEAMS`] beams, the first at −π, each beam's range `range(angle)` (m, `inf`
/// for no return; called beam by beam in order), with the given `range_max`.
pub fn ring_scan(range_max: f32, mut range: impl FnMut(f64) -> f32) -> LaserScan {
    let a0 = -std::f32::consts::PI;
    let da = 2.0 * std::f32::consts::PI / BEAMS as f32;
    LaserScan {
        header: Header { frame_id: "laser".into(), ..Default::default() },
        angle_min: a0,
        angle_max: a0 + (BEAMS - 1) as f32 * da,
        angle_increment: da,
        range_min: 0.05,
        range_max,
        ranges: (0..BEAMS).map(|i| range((a0 + i as f32 * da) as f64)).collect(),
        ..Default::default()
    }
}

/// A scan seeing only a wall across the robot's path at `x = d`.
pub fn wall_scan(d: f64) -> LaserScan {
    ring_scan(30.0, |a| if a.cos() > 0.05 { (d / a.cos()).min(1e3) as f32 } else { f32::INFINITY })
}

/// A nominal command forward at `v` m/s.
pub fn forward(v: f64) -> Twist {
    Twist { linear: Vector3 { x: v, y: 0.0, z: 0.0 }, angular: Vector3::default() }
}
