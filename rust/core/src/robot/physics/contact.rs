//! The robot's contacts: what a step reports, the tolerance it judges touching by, and the
//! hook that bounds the contacts rapier's solver is given.

use std::sync::atomic::{AtomicU32, Ordering};

use rapier2d::prelude::*;

use crate::math::Real;

/// Footprints closer than this (m) to a wall or obstacle count as touching it: rapier's
/// solver rests bodies up to about a millimetre apart (or into each other).
pub const CONTACT_TOLERANCE: Real = 1e-3;

/// Contacts of the robot after a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactReport {
    /// Walls and obstacles within [`CONTACT_TOLERANCE`] of the footprint.
    pub count: usize,
    /// Of those, walls (static geometry).
    pub with_walls: usize,
    /// Of those, moving obstacles.
    pub with_obstacles: usize,
    /// Deepest penetration (m), 0 if none.
    pub max_penetration: Real,
}

impl ContactReport {
    /// Whether the robot touches anything.
    pub fn any(&self) -> bool {
        self.count > 0
    }

    /// Counts a wall or an obstacle if it is within [`CONTACT_TOLERANCE`] (a distance measured
    /// that far is exact).
    pub(super) fn tally(&mut self, m: Measured) {
        let (d, obstacle) = (m.d, m.obstacle);
        if d <= CONTACT_TOLERANCE {
            debug_assert!(m.exact);
            self.count += 1;
            if obstacle.is_none() {
                self.with_walls += 1;
            } else {
                self.with_obstacles += 1;
            }
            self.max_penetration = self.max_penetration.max(-d);
        }
    }
}

/// Rapier's physics hook on the robot's solver contacts, in one pass over them: it drops those
/// deeper than [`MAX_CONTACT_DEPTH`], and keeps the deepest penetration of the others in
/// `deepest` (`f32` bits, which order non-negative values as the values; reset before each
/// rapier step, see [`DEEP_CONTACT`]). No step sinks
/// the robot 20 cm, but parry can report such a contact where a corner of the footprint touches
/// a wall's end exactly (seen in a concave corner of walls: the manifold of the wall along
/// which the robot lay had the wall's direction as its normal and a point 10.1 m deep, and the
/// solver's correction threw the robot 1.9 cm sideways and 2.2° round in one 0.01 s step,
/// 2.1 cm into the other wall).
#[derive(Debug, Default)]
pub(super) struct ContactGuard {
    pub(super) deepest: AtomicU32,
}

impl PhysicsHooks for ContactGuard {
    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        if let Some(m) = context.rigid_mut() {
            m.solver_contacts.retain(|c| c.dist >= -MAX_CONTACT_DEPTH as f32);
            let deepest = m.solver_contacts.iter().fold(0.0f32, |d, c| d.max(-c.dist));
            self.deepest.fetch_max(deepest.to_bits(), Ordering::Relaxed);
        }
    }
}

/// The deepest solver contact (m) rapier's solver is given (see [`ContactGuard`]): far
/// beyond the depths steps reach (about a centimetre; 5.5 cm for a robot driving into a wall
/// at 16 m/s, see `a_fast_robot_stops_at_a_wall`), far below those of the contacts dropped.
pub(super) const MAX_CONTACT_DEPTH: Real = 0.2;

/// A distance [`PhysicsScene::measure`] gives: to a wall (`obstacle` None) or an obstacle, `d`
/// exact or (`exact` false, a far obstacle) a lower bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Measured {
    pub(super) d: Real,
    pub(super) obstacle: Option<usize>,
    pub(super) exact: bool,
}
