//! Messages to the shield's inputs: a `LaserScan` or a `PointCloud2` to body-frame points
//! through the sensor's mount, each message checked first. A message that cannot be read
//! whole is rejected with the reason; nothing here panics on any input.

use crate::msg::{LaserScan, PointCloud2, PointField};

/// The sensor's pose on the body (a static transform `base → sensor`): position (m) and yaw
/// (rad). A point `p` in the sensor frame is `R(yaw) p + (x, y, z)` in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mount {
    /// Position in the body frame (m).
    pub translation: [f64; 3],
    /// Yaw about the body's z axis (rad).
    pub yaw: f64,
    cos: f64,
    sin: f64,
}

impl Default for Mount {
    fn default() -> Self {
        Self { translation: [0.0; 3], yaw: 0.0, cos: 1.0, sin: 0.0 }
    }
}

impl Mount {
    /// A mount at `(x, y, z)` turned by `yaw`; the error names the non-finite value.
    pub fn new(x: f64, y: f64, z: f64, yaw: f64) -> Result<Self, (&'static str, String)> {
        for (name, v) in [("mount_x", x), ("mount_y", y), ("mount_z", z), ("mount_yaw", yaw)] {
            if !v.is_finite() {
                return Err((name, format!("must be finite, got {v}")));
            }
        }
        Ok(Self { translation: [x, y, z], yaw, cos: yaw.cos(), sin: yaw.sin() })
    }

    /// The body-frame point of the sensor-frame point `(x, y, z)`.
    #[inline]
    pub fn apply(&self, x: f64, y: f64, z: f64) -> [f64; 3] {
        let t = &self.translation;
        [t[0] + self.cos * x - self.sin * y, t[1] + self.sin * x + self.cos * y, t[2] + z]
    }
}

/// Why a message was not used.
pub type Rejection = String;

/// Beams a scan may hold (a 0.01° scanner has 36,000).
pub const MAX_BEAMS: usize = 1 << 20;
/// Points a cloud may hold.
pub const MAX_CLOUD_POINTS: usize = 1 << 24;

/// The body-frame direction of each beam of a scan layout (`angle_min`, `angle_increment`,
/// beam count, mount yaw), kept from scan to scan: a scanner's layout does not change, and
/// the sines and cosines are most of a scan's translation.
#[derive(Debug, Clone, Default)]
pub struct BeamTable {
    key: Option<(u32, u32, usize, u64)>,
    dirs: Vec<[f64; 2]>,
}

impl BeamTable {
    fn directions(&mut self, a0: f32, da: f32, n: usize, mount: &Mount) -> &[[f64; 2]] {
        let key = (a0.to_bits(), da.to_bits(), n, mount.yaw.to_bits());
        if self.key != Some(key) {
            self.dirs.clear();
            self.dirs.extend((0..n).map(|i| {
                let a = a0 as f64 + i as f64 * da as f64 + mount.yaw;
                [a.cos(), a.sin()]
            }));
            self.key = Some(key);
        }
        &self.dirs
    }
}

/// Appends the scan's returns to `out` as body-frame `(x, y, z)` rows (stride 3; `z` is the
/// mount's height) and returns how many.
///
/// Each beam `i` is at `angle_min + i · angle_increment`. A range that is NaN, `+inf` or
/// outside `[range_min, range_max]` is no return (REP 117); `-inf` ("too close to measure")
/// is an obstacle at `range_min`. The scan is rejected, with the reason, when its angles or
/// range limits are not finite numbers, its increment is zero, its beam count disagrees with
/// its angles by more than one beam, or its intensities are neither empty nor one per range.
pub fn laser_scan_points(msg: &LaserScan, mount: &Mount, out: &mut Vec<f64>) -> Result<usize, Rejection> {
    laser_scan_points_with(msg, mount, &mut BeamTable::default(), out, None)
}

/// [`laser_scan_points`] with the beams' directions kept in `table` from call to call; with
/// `beams`, every beam's point in beam order as well (NaN where there is no return: what the
/// mover tracker segments).
pub fn laser_scan_points_with(msg: &LaserScan, mount: &Mount, table: &mut BeamTable, out: &mut Vec<f64>, mut beams: Option<&mut Vec<[f64; 3]>>) -> Result<usize, Rejection> {
    let (a0, a1, da) = (msg.angle_min as f64, msg.angle_max as f64, msg.angle_increment as f64);
    if !(a0.is_finite() && a1.is_finite() && da.is_finite()) {
        return Err(format!("LaserScan angles are not finite (angle_min {a0}, angle_max {a1}, angle_increment {da})"));
    }
    if da == 0.0 {
        return Err("LaserScan angle_increment is 0".into());
    }
    let n = msg.ranges.len();
    if n == 0 {
        return Err("LaserScan has no ranges".into());
    }
    if n > MAX_BEAMS {
        return Err(format!("LaserScan has {n} ranges, more than {MAX_BEAMS}"));
    }
    // (angle_max − angle_min) / increment + 1 beams; drivers differ by one
    let expected = (a1 - a0) / da + 1.0;
    if !(expected.is_finite() && (expected - n as f64).abs() <= 1.0 + 1e-3 * n as f64) {
        return Err(format!("LaserScan holds {n} ranges but its angles ({a0} to {a1} by {da} rad) give {expected:.1}"));
    }
    if !msg.intensities.is_empty() && msg.intensities.len() != n {
        return Err(format!("LaserScan holds {n} ranges but {} intensities", msg.intensities.len()));
    }
    let (rmin, rmax) = (msg.range_min as f64, msg.range_max as f64);
    if !(rmin.is_finite() && rmin >= 0.0 && !rmax.is_nan() && rmax > rmin) {
        return Err(format!("LaserScan range limits are not 0 ≤ range_min < range_max (range_min {rmin}, range_max {rmax})"));
    }
    let start = out.len();
    out.reserve(3 * n);
    let dirs = table.directions(msg.angle_min, msg.angle_increment, n, mount);
    let t = mount.translation;
    for (&r, d) in msg.ranges.iter().zip(dirs) {
        let r = r as f64;
        let r = if r == f64::NEG_INFINITY {
            rmin
        } else if r.is_finite() && r >= rmin && r <= rmax {
            r
        } else {
            if let Some(b) = beams.as_mut() {
                b.push([f64::NAN; 3]);
            }
            continue;
        };
        let p = [t[0] + r * d[0], t[1] + r * d[1], t[2]];
        out.extend_from_slice(&p);
        if let Some(b) = beams.as_mut() {
            b.push(p);
        }
    }
    Ok((out.len() - start) / 3)
}

/// How one coordinate of a cloud point is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Coord {
    offset: usize,
    float64: bool,
}

fn coord(msg: &PointCloud2, name: &str) -> Result<Option<Coord>, Rejection> {
    let Some(f) = msg.fields.iter().find(|f| f.name == name) else { return Ok(None) };
    let float64 = match f.datatype {
        PointField::FLOAT32 => false,
        PointField::FLOAT64 => true,
        t => return Err(format!("PointCloud2 field {name:?} has datatype {t}; expected FLOAT32 (7) or FLOAT64 (8)")),
    };
    if f.count != 1 {
        return Err(format!("PointCloud2 field {name:?} has count {}; expected 1", f.count));
    }
    let size = if float64 { 8 } else { 4 };
    if f.offset as usize + size > msg.point_step as usize {
        return Err(format!("PointCloud2 field {name:?} at offset {} does not fit in point_step {}", f.offset, msg.point_step));
    }
    Ok(Some(Coord { offset: f.offset as usize, float64 }))
}

#[inline]
fn read(bytes: &[u8], c: Coord, big: bool) -> f64 {
    if c.float64 {
        let b: [u8; 8] = bytes[c.offset..c.offset + 8].try_into().unwrap_or([0; 8]);
        if big {
            f64::from_be_bytes(b)
        } else {
            f64::from_le_bytes(b)
        }
    } else {
        let b: [u8; 4] = bytes[c.offset..c.offset + 4].try_into().unwrap_or([0; 4]);
        (if big { f32::from_be_bytes(b) } else { f32::from_le_bytes(b) }) as f64
    }
}

/// Appends the cloud's points to `out` as body-frame `(x, y, z)` rows (stride 3) and returns
/// how many.
///
/// The fields `x`, `y` (and `z`, else 0) are found by name and read at their offsets,
/// `FLOAT32` or `FLOAT64`, in the cloud's byte order; points with a non-finite coordinate
/// are skipped (an organised cloud's no-returns). The cloud is rejected when `x` or `y` is
/// missing, a field does not fit in `point_step`, or `data` is shorter than its rows.
pub fn point_cloud_points(msg: &PointCloud2, mount: &Mount, out: &mut Vec<f64>) -> Result<usize, Rejection> {
    let x = coord(msg, "x")?.ok_or("PointCloud2 has no field \"x\"")?;
    let y = coord(msg, "y")?.ok_or("PointCloud2 has no field \"y\"")?;
    let z = coord(msg, "z")?;
    let (w, h, step, row) = (msg.width as usize, msg.height as usize, msg.point_step as usize, msg.row_step as usize);
    let n = w.checked_mul(h).filter(|&n| n <= MAX_CLOUD_POINTS).ok_or_else(|| format!("PointCloud2 of {w} × {h} points is larger than {MAX_CLOUD_POINTS}"))?;
    if n == 0 {
        return Ok(0);
    }
    if w.checked_mul(step).is_none_or(|b| b > row) {
        return Err(format!("PointCloud2 row_step {row} is shorter than width {w} × point_step {step}"));
    }
    let need = row.checked_mul(h - 1).and_then(|b| b.checked_add(w * step));
    if need.is_none_or(|need| msg.data.len() < need) {
        return Err(format!("PointCloud2 data holds {} bytes; {h} rows of row_step {row} need {}", msg.data.len(), row.saturating_mul(h)));
    }
    let big = msg.is_bigendian;
    let start = out.len();
    out.reserve(3 * n);
    for r in 0..h {
        let row_bytes = &msg.data[r * row..];
        for c in 0..w {
            let p = &row_bytes[c * step..(c + 1) * step];
            let (px, py) = (read(p, x, big), read(p, y, big));
            let pz = z.map_or(0.0, |z| read(p, z, big));
            if px.is_finite() && py.is_finite() && pz.is_finite() {
                out.extend_from_slice(&mount.apply(px, py, pz));
            }
        }
    }
    Ok((out.len() - start) / 3)
}
