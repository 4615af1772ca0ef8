//! Deadlock: the robot is stuck while the mission is unfinished.
//!
//! Over the last `window` seconds: no new wall inspected and less than `displacement` metres of
//! net motion (true position now against `window` seconds ago), with coverage incomplete.

use std::collections::VecDeque;

use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::Point2;

/// Deadlock thresholds. `Default`: 10 s window, 0.2 m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadlockConfig {
    /// Length of the window (s).
    pub window: Real,
    /// Net displacement below which the robot counts as stuck (m).
    pub displacement: Real,
}

impl Default for DeadlockConfig {
    fn default() -> Self {
        Self { window: 10.0, displacement: 0.2 }
    }
}

impl DeadlockConfig {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        if !(self.window.is_finite() && self.window > 0.0) {
            return Err(Error::invalid("deadlock_window", format!("must be finite and > 0 s, got {}", self.window)));
        }
        if !(self.displacement.is_finite() && self.displacement > 0.0) {
            return Err(Error::invalid("deadlock_displacement", format!("must be finite and > 0 m, got {}", self.displacement)));
        }
        Ok(())
    }
}

/// The sliding window of `(time, position, inspected pieces)`.
#[derive(Debug, Clone)]
pub struct DeadlockMonitor {
    config: DeadlockConfig,
    history: VecDeque<(Real, Point2, usize)>,
}

impl DeadlockMonitor {
    /// Validates `config`.
    pub fn new(config: DeadlockConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self { config, history: VecDeque::new() })
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.history.clear();
    }

    /// Records the state at `time` and tells whether the robot is deadlocked now.
    pub fn update(&mut self, time: Real, position: Point2, inspected: usize, complete: bool) -> bool {
        self.history.push_back((time, position, inspected));
        // keep the newest sample at least `window` old as the reference
        while self.history.len() >= 2 && time - self.history[1].0 >= self.config.window - 1e-9 {
            self.history.pop_front();
        }
        let (t0, p0, n0) = self.history[0];
        !complete && time - t0 >= self.config.window - 1e-9 && n0 == inspected && (position[0] - p0[0]).hypot(position[1] - p0[1]) < self.config.displacement
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stuck_for_a_full_window_is_a_deadlock_and_progress_clears_it() {
        let mut m = DeadlockMonitor::new(DeadlockConfig::default()).unwrap();
        let dt = 0.02;
        // creeping at 0.3 mm per step: 0.15 m in 10 s
        let pos = |k: usize| [0.0003 * k as Real, 0.0];
        assert!(!m.update(0.0, pos(0), 3, false));
        for k in 1..500 {
            assert!(!m.update(k as Real * dt, pos(k), 3, false), "{} s is short of the window", k as Real * dt);
        }
        assert!(m.update(500.0 * dt, pos(500), 3, false), "10 s with 0.15 m net motion and no coverage");
        // new coverage breaks the deadlock
        assert!(!m.update(501.0 * dt, pos(501), 4, false));
        // complete missions are never deadlocked
        assert!(!m.update(40.0, pos(501), 4, true));
    }

    #[test]
    fn moving_robot_is_not_deadlocked() {
        let mut m = DeadlockMonitor::new(DeadlockConfig::default()).unwrap();
        for k in 0..2000 {
            let t = k as Real * 0.02;
            assert!(!m.update(t, [0.05 * k as Real, 0.0], 0, false), "at {t}");
        }
    }

    #[test]
    fn bad_thresholds_are_rejected() {
        assert!(DeadlockMonitor::new(DeadlockConfig { window: 0.0, ..Default::default() }).is_err());
        assert!(DeadlockMonitor::new(DeadlockConfig { displacement: Real::NAN, ..Default::default() }).is_err());
    }
}
