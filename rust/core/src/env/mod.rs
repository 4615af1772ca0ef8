//! One episode of corridor inspection, as the Gymnasium environments run it.
//!
//! Each control period ([`Episode::step`]): the agent's action becomes the nominal command
//! `u_nom` ([`ActionMode`]); the shield filters it against the latest scan, moved into the
//! current body frame; the tracker and rapier advance the robot; the LIDAR scans at its own
//! rate; a scan inspects the wall pieces in the camera's view ([`Coverage`]); the reward,
//! the deadlock monitor and the episode totals are updated.
//!
//! The shield runs in the robot's body frame at the current instant (rotation `I`, yaw rate
//! `ω`): the composite barrier and its QP are invariant to the choice of world frame, and the
//! box `|u_j| ≤ u_max,j` then is the robot's own body-frame speed limit.
//!
//! ```
//! use shieldnav_core::env::{Episode, EpisodeConfig, Site};
//! let mut ep = Episode::new(Site::Preset("constricted_passage".into()), EpisodeConfig::default(), 0).unwrap();
//! let r = ep.step([0.3, 0.0, 0.0]).unwrap();
//! assert_eq!(r.cost, 0.0);
//! let mut obs = vec![0.0f32; ep.observation_len()];
//! ep.observe(&mut obs).unwrap();
//! ```

mod action;
mod batch;
mod coverage;
mod deadlock;
mod episode;
pub mod keywords;
mod observation;
mod pool;

pub use action::{check_action, nominal_command, ActionMode, ACTION_TOLERANCE};
pub use batch::{AutoReset, Batch, SlotOutcome};
pub use coverage::{Coverage, CoverageConfig, Piece, COVERAGE_GRID, LINE_OF_SIGHT_TOLERANCE, PROBE_OFFSET};
pub use deadlock::{DeadlockConfig, DeadlockMonitor};
pub use episode::{pushed, Episode, EpisodeConfig, EpisodeSummary, RewardConfig, Site, StepReport, CONTACT_EVENT_GAP, MOVING_CONTACT_SPEED, REWARD_WEIGHT_LIMIT};
pub use observation::{bin_ranges, ObservationConfig, PROPRIO_LEN};
