//! An exact planar / 3D LIDAR by polar sweep, configurable like an Ouster OS0.
//!
//! For each wall in range the sweep finds the beams inside the wall's angular interval (seen
//! from the sensor) and gives each the exact `f64` ray–segment distance; each beam keeps its
//! nearest hit. No BVH and no `f32`: ranges equal a brute-force `f64` ray cast to rounding
//! (≪ 1e-6 m), grazing beams down a corridor included.
//!
//! Frames: column `i` looks at azimuth `2π·i/columns`, counter-clockwise from the sensor's
//! `+x`; channel `k` at elevation `lo + k·(hi − lo)/(channels − 1)` (channel 0 lowest; a single
//! channel looks level). Walls are vertical, from the floor (`z = 0`) to their height; a beam
//! that passes over a wall or hits nothing gives no return. Floor and ceiling are not modelled.
//!
//! ```
//! use shieldnav_core::sensors::{Lidar, LidarConfig, Scan};
//! use shieldnav_core::world::{Pose2, Segment};
//! use rand::SeedableRng;
//! let mut lidar = Lidar::new(LidarConfig { range_noise_std: 0.0, ..LidarConfig::default() }).unwrap();
//! let wall = [Segment::new([2.0, -5.0], [2.0, 5.0], 2.5)];
//! let mut scan = Scan::default();
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
//! lidar.scan_into(&[&wall], Pose2::default(), 0.0, &mut rng, &mut scan).unwrap();
//! assert!((scan.ranges[0] - 2.0).abs() < 1e-12); // column 0 looks along +x
//! ```
//!
//! Three backends give the same ranges: the brute-force sweep over every wall
//! ([`Lidar::scan_into`]), the bucket index for big maps ([`Lidar::scan_indexed_into`]) and
//! the walk of a triangulation ([`Lidar::scan_mesh_into`]). Each is a file of this folder
//! over the shared beam tables and sweeps of `beams.rs`.

use rand::Rng;

mod beams;
mod brute;
mod config;
mod indexed;
mod mesh;
mod numeric;
mod simd;
#[cfg(test)]
mod tests;

use beams::Beams;
use brute::BruteScratch;
pub use config::{LidarConfig, LidarMount, Scan, MAX_RANGE_LIMIT};
pub use indexed::IndexedScanStats;
use indexed::IndexedScratch;
use mesh::MeshScratch;
pub use mesh::{MeshScanStats, NoMesh, ScanMesh};

use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::{Pose2, Segment, SegmentIndex};

/// The LIDAR: configuration plus precomputed beam tables and the scratch of each backend.
#[derive(Debug, Clone)]
pub struct Lidar {
    beams: Beams,
    brute: BruteScratch,
    indexed: IndexedScratch,
    mesh: MeshScratch,
}

impl Lidar {
    /// Builds the beam tables after validating `config`.
    pub fn new(config: LidarConfig) -> Result<Self> {
        Ok(Self { beams: Beams::new(config)?, brute: Default::default(), indexed: Default::default(), mesh: Default::default() })
    }

    /// The configuration.
    pub fn config(&self) -> &LidarConfig {
        &self.beams.config
    }

    /// Seconds between scans.
    pub fn period(&self) -> Real {
        1.0 / self.beams.config.rate_hz
    }

    /// The sensor's planar pose in the world for a robot at `body`.
    pub fn sensor_pose(&self, body: Pose2) -> Pose2 {
        self.beams.sensor_pose(body)
    }

    /// Unit direction of column `i`, channel `k` in the sensor frame.
    ///
    /// # Panics
    ///
    /// If `k` is not below the channels or `i` not below the columns, as slice indexing does.
    pub fn beam_direction(&self, k: usize, i: usize) -> [Real; 3] {
        self.beams.beam_direction(k, i)
    }

    /// Scans `walls` (each slice in the world frame) from a robot whose true pose is `body`,
    /// at time `stamp`; noise and dropout are drawn from `rng`. Writes into `out`, reusing its
    /// buffers.
    pub fn scan_into<R: Rng + ?Sized>(&mut self, walls: &[&[Segment]], body: Pose2, stamp: Real, rng: &mut R, out: &mut Scan) -> Result<()> {
        let sp = self.beams.begin_scan(body, stamp, out)?;
        // (the walls are the caller's, new each call: a wall with a NaN end or height would be
        // skipped or scanned silently)
        if let Some(s) = walls.iter().flat_map(|w| w.iter()).find(|s| !(s.a.iter().chain(&s.b).all(|v| v.is_finite()) && s.height.is_finite())) {
            return Err(Error::invalid("walls", format!("every end point and height must be finite, got {s:?}")));
        }
        // (an AVX2 build of this sweep measured slower, unlike the indexed one)
        self.beams.sweep_walls(&mut self.brute, walls, sp, out);
        self.beams.sweep_tops(&mut self.brute, walls, sp, &mut out.ranges);
        self.beams.finish(rng, out);
        Ok(())
    }

    /// Scans the walls of `index` plus `extra` (moving obstacles, few) from a robot at `body`.
    /// Ranges are identical to [`Lidar::scan_into`] over the same walls.
    pub fn scan_indexed_into<R: Rng + ?Sized>(&mut self, index: &SegmentIndex, extra: &[Segment], body: Pose2, stamp: Real, rng: &mut R, out: &mut Scan) -> Result<()> {
        let sp = self.beams.begin_scan(body, stamp, out)?;
        self.beams.sweep_index_any(&mut self.indexed, index, extra, sp, out);
        self.beams.sweep_tops(&mut self.brute, &[index.segments(), extra], sp, &mut out.ranges);
        self.beams.finish(rng, out);
        Ok(())
    }

    /// Scans the walls of `index` plus `extra` as [`Lidar::scan_indexed_into`] does, a planar
    /// scan by walking `mesh` (a [`ScanMesh`] of the same walls) where it can: the same ranges.
    #[allow(clippy::too_many_arguments)]
    pub fn scan_mesh_into<R: Rng + ?Sized>(&mut self, mesh: &ScanMesh, index: &SegmentIndex, extra: &[Segment], body: Pose2, stamp: Real, rng: &mut R, out: &mut Scan) -> Result<()> {
        let sp = self.beams.begin_scan(body, stamp, out)?;
        if self.beams.sweep_mesh(&mut self.mesh, mesh, sp, out) {
            self.beams.sweep_extra(extra, sp, &mut out.ranges);
        } else {
            self.beams.sweep_index_any(&mut self.indexed, index, extra, sp, out);
            self.beams.sweep_tops(&mut self.brute, &[index.segments(), extra], sp, &mut out.ranges);
        }
        self.beams.finish(rng, out);
        Ok(())
    }

    /// What the last [`Lidar::scan_indexed_into`] did (buckets visited and culled, walls swept).
    pub fn last_indexed_stats(&self) -> IndexedScanStats {
        self.indexed.stats
    }

    /// What the last [`Lidar::scan_mesh_into`] did.
    pub fn last_mesh_stats(&self) -> MeshScanStats {
        self.mesh.stats
    }
}
