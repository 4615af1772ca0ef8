//! ROS `map_server` maps: a YAML description plus an image (PGM P5/P2, PNG, BMP, JPEG, PPM or
//! PBM), turned into an occupancy grid, merged wall segments and a start pose inside the
//! building.
//!
//! YAML fields: `image` (relative to the YAML file), `resolution` (m/cell), `origin`
//! `[x, y, yaw]` (the pose of the lower-left pixel's corner; the yaw *is* applied, unlike ROS 1),
//! `negate` (0/1, default 0), `occupied_thresh` (default 0.65), `free_thresh` (default 0.196),
//! `mode` (`trinary` or `scale`; both classify cells the same way here). Another key, a key
//! given twice, or YAML beyond what such files are written in (see [`parse_ros_yaml`]) is an
//! error.
//!
//! Classification follows map_server's trinary rule: with `v` the 8-bit luminance
//! (`0.299 R + 0.587 G + 0.114 B` for colour images), `p = (255 − v)/255` (`v/255` if negated);
//! `p > occupied_thresh` is occupied, `p < free_thresh` free, anything else unknown, as is any
//! pixel with alpha 0. A PGM pixel above the header's maxval, or data after the image, is an
//! error.
//!
//! The start is the cell of greatest clearance in the largest free region that does not reach
//! the edge of the [`known_area`] (the image's border, or the unknown cells an image is often
//! framed with) and from which straight lines end on non-free cells inside that area (free space
//! outside a building reaches its edge and is never used); see [`enclosure`]. Only occupied
//! cells become walls unless [`RosMapOptions::unknown_is_wall`] (the default) makes unknown
//! cells walls too. The space beyond the image counts as unknown: with `unknown_is_wall` the
//! image's border is a wall wherever a free cell meets it, so nothing leaves the map there.
//!
//! The parts: `meta` reads the YAML, `image` and `pgm` the image, `start` finds the start.

use std::path::Path;

use super::contour::{simplify_walls, thin_corner};
use super::geometry::Pose2;
use super::grid::{Cell, OccupancyGrid};
use super::map::StaticMap;
use super::region::FreeRegion;
use super::scenario::{Scenario, COORDINATE_LIMIT};
use crate::error::{Error, Result};
use crate::math::Real;

mod grey;
mod image;
mod meta;
mod pgm;
mod start;

pub use grey::MAX_IMAGE_PIXELS;
pub use image::{rasterize, MAX_IMAGE_BYTES};
pub use meta::{parse_ros_yaml, RosMapMeta, YAML_KEYS};
use start::interior_start;
pub use start::{enclosure, known_area, ENCLOSURE, ENCLOSURE_RAYS, START_CLEARANCE};

/// A loaded map: the grid, its walls and a start inside the building.
#[derive(Debug, Clone)]
pub struct RosMap {
    /// The YAML fields.
    pub meta: RosMapMeta,
    /// The occupancy grid (row 0 at the bottom).
    pub grid: OccupancyGrid,
    /// Walls (merged occupied-cell boundaries) and the start pose.
    pub scenario: Scenario,
    /// Clearance at the start (m): distance to the nearest non-free cell centre.
    pub start_clearance: Real,
}

/// How an occupancy map becomes walls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RosMapOptions {
    /// Height of every wall (m).
    pub wall_height: Real,
    /// Whether unknown cells are solid too. SLAM maps often bound their free space with
    /// unknown rather than occupied cells (Willow Garage); without this the robot and the LIDAR
    /// leak out of the mapped building there. The space beyond the image counts as unknown,
    /// so with this the image's border is a wall where free cells meet it.
    pub unknown_is_wall: bool,
    /// Whether to keep the walls no body or beam from the start's region can reach (those of
    /// solid pockets and of free space cut off from the start); they change no scan, contact
    /// or clearance of a robot in that region.
    pub unreachable_walls: bool,
    /// Douglas–Peucker tolerance (cells) of the wall contours: the staircase of cell edges
    /// that a wall drawn at an angle leaves in the image becomes a straight wall within this
    /// many cells of it (see [`super::simplify_walls`]). 0 keeps every cell edge.
    pub simplify: Real,
}

impl Default for RosMapOptions {
    fn default() -> Self {
        Self { wall_height: 2.5, unknown_is_wall: true, unreachable_walls: false, simplify: 1.0 }
    }
}

/// Loads a map_server YAML and its image. Errors name the file and the line or field.
pub fn load_ros_map(yaml: impl AsRef<Path>, options: &RosMapOptions) -> Result<RosMap> {
    if !(options.wall_height.is_finite() && options.wall_height > 0.0) {
        return Err(Error::invalid("wall_height", format!("must be finite and > 0, got {}", options.wall_height)));
    }
    let yaml = yaml.as_ref();
    let text = std::fs::read_to_string(yaml).map_err(|e| match e.kind() {
        std::io::ErrorKind::InvalidData => Error::map_file(yaml, "file", "not text: expected the map's map_server YAML file (which names its image), not the image"),
        _ => Error::map_file(yaml, "file", e.to_string()),
    })?;
    let meta = parse_ros_yaml(&text, yaml)?;
    let grid = rasterize(&meta).map_err(|e| match e {
        Error::MapFile { path, location, reason } if location == "file" => Error::map_file(yaml, "field image", format!("{path}: {reason}")),
        other => other,
    })?;
    // the whole image within the coordinates a scenario may use (the physics runs in f32)
    let (w, h) = (grid.width as Real * grid.resolution, grid.height as Real * grid.resolution);
    for corner in [[0.0, 0.0], [w, 0.0], [0.0, h], [w, h]] {
        let p = grid.origin.transform_point(corner);
        if !(p[0].abs() <= COORDINATE_LIMIT && p[1].abs() <= COORDINATE_LIMIT) {
            let field = if meta.origin[0].abs().max(meta.origin[1].abs()) > COORDINATE_LIMIT { "field origin" } else { "field resolution" };
            return Err(Error::map_file(
                yaml,
                field,
                format!(
                    "the map ({} × {} cells of {} m from origin {:?}) reaches ({}, {}); it must lie within {COORDINATE_LIMIT} m of (0, 0)",
                    grid.width, grid.height, meta.resolution, meta.origin, p[0], p[1]
                ),
            ));
        }
    }
    let (start, start_clearance) = interior_start(&grid)
        .ok_or_else(|| Error::map_file(yaml, "map", "no free region inside the building (away from the image border and the unknown around the map) is wide enough to start in"))?;
    let mut map = StaticMap::new();
    let unknown_is_wall = options.unknown_is_wall;
    let solid = |c: Cell| c == Cell::Occupied || (unknown_is_wall && c == Cell::Unknown);
    // the space beyond the image is unknown: a wall where it is solid and meets an open cell
    // (with `unreachable_walls`, of the image; else of the region through the start)
    let cell = grid.world_to_cell([start.x, start.y]).ok_or_else(|| Error::map_file(yaml, "map", "the start lies off the grid"))?;
    // cells off the region are solid; so is the space beyond the image when unknown cells are
    // (otherwise the region runs on off the image and its border is no wall)
    let region = FreeRegion::through(&grid, cell, [!solid(Cell::Free), !solid(Cell::Occupied), !solid(Cell::Unknown)]).as_grid(&grid)?;
    let walls = walls_beyond(&region, Cell::Occupied, |c| c != Cell::Free, options.wall_height, unknown_is_wall)?;
    // chains break where two solid cells meet only at a corner, in either mode alike
    let is_solid = |i: i64, j: i64| i >= 0 && j >= 0 && (i as usize) < grid.width && (j as usize) < grid.height && solid(grid.get(i as usize, j as usize));
    let pinch = |(i, j): (i64, i64)| {
        let (a, b, c, d) = (is_solid(i - 1, j - 1), is_solid(i, j - 1), is_solid(i - 1, j), is_solid(i, j));
        a == d && b == c && a != b
    };
    // solids one cell thick, in the image or off the region, keep their thickness
    let off_region = |i: i64, j: i64| i >= 0 && j >= 0 && (i as usize) < grid.width && (j as usize) < grid.height && region.get(i as usize, j as usize) != Cell::Free;
    let thin = |v| thin_corner(is_solid, v) || thin_corner(off_region, v);
    map.segments = simplify_walls(&grid, &walls, options.simplify, pinch, thin)?;
    if options.unreachable_walls {
        // the walls the region cannot reach, simplified apart: the region's own walls, and so
        // every scan from inside it, are the same in either mode
        let key = |s: &super::Segment| [s.a[0], s.a[1], s.b[0], s.b[1]].map(Real::to_bits);
        let reachable: std::collections::HashSet<_> = walls.iter().map(key).collect();
        let mut rest = walls_beyond(&grid, Cell::Unknown, solid, options.wall_height, true)?;
        rest.retain(|s| !reachable.contains(&key(s)));
        map.segments.extend(simplify_walls(&grid, &rest, options.simplify, pinch, thin)?);
    }
    let name = yaml.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let scenario = Scenario::new(name, map, start);
    Ok(RosMap { meta, grid, scenario, start_clearance })
}

/// The walls of `grid` between `solid` cells and open ones (as
/// [`OccupancyGrid::wall_segments`] gives them) with the space beyond the grid made of `beyond`
/// cells rather than of nothing: the grid's border is a wall where an open cell meets a solid
/// `beyond`, or a solid cell an open one, and no wall faces out of `beyond`. Walls on the
/// grid's border are dropped unless `border_walls`.
fn walls_beyond(grid: &OccupancyGrid, beyond: Cell, solid: impl Fn(Cell) -> bool, height: Real, border_walls: bool) -> Result<Vec<super::Segment>> {
    let (w, h) = (grid.width, grid.height);
    // the grid inside a frame of `beyond`, in cells (unit cells at the origin): the walls'
    // ends are whole numbers, mapped back exactly as the grid's own walls would be
    let mut framed = OccupancyGrid::new(w + 2, h + 2, 1.0, Pose2::new(0.0, 0.0, 0.0), beyond)?;
    for j in 0..h {
        framed.cells[(j + 1) * (w + 2) + 1..][..w].copy_from_slice(grid.row(j));
    }
    let (wf, hf) = ((w + 2) as Real, (h + 2) as Real);
    // both ends on one of the lines x = `x`, x = `wf` - `x`, y = `x`, y = `hf` - `x`
    let on_frame = |s: &super::Segment, x: Real| (s.a[0] == x && s.b[0] == x) || (s.a[0] == wf - x && s.b[0] == wf - x) || (s.a[1] == x && s.b[1] == x) || (s.a[1] == hf - x && s.b[1] == hf - x);
    let mut walls = framed.wall_segments(height, solid);
    walls.retain(|s| !on_frame(s, 0.0) && (border_walls || !on_frame(s, 1.0)));
    let r = grid.resolution;
    for s in &mut walls {
        s.a = grid.grid_to_world([(s.a[0] - 1.0) * r, (s.a[1] - 1.0) * r]);
        s.b = grid.grid_to_world([(s.b[0] - 1.0) * r, (s.b[1] - 1.0) * r]);
    }
    Ok(walls)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// Pixel values of the synthetic maps: free, occupied and unknown by the default thresholds.
    const FREE: u8 = 254;
    const OCC: u8 = 0;
    const UNK: u8 = 128;

    /// A scratch folder, removed when dropped (also when the test fails).
    struct TempDir(PathBuf);

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn temp_dir(tag: &str) -> TempDir {
        let d = std::env::temp_dir().join(format!("shieldnav_rosmap_unit_{tag}_{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        TempDir(d)
    }

    /// Writes `name.pgm`, `w` × `h` cells whose pixel `cell(i, j)` gives (row 0 at the bottom),
    /// and `name.yaml` with resolution `res` at the origin; returns the YAML's path.
    fn write_map(dir: &TempDir, name: &str, (w, h): (usize, usize), res: Real, cell: impl Fn(usize, usize) -> u8) -> PathBuf {
        let mut pgm = format!("P5\n{w} {h}\n255\n").into_bytes();
        pgm.extend((0..h).rev().flat_map(|j| (0..w).map(move |i| (i, j))).map(|(i, j)| cell(i, j)));
        std::fs::write(dir.0.join(format!("{name}.pgm")), pgm).unwrap();
        let yaml = dir.0.join(format!("{name}.yaml"));
        std::fs::write(&yaml, format!("image: {name}.pgm\nresolution: {res}\norigin: [0.0, 0.0, 0.0]\n")).unwrap();
        yaml
    }

    fn start_cell(m: &RosMap) -> (usize, usize) {
        m.grid.world_to_cell([m.scenario.start.x, m.scenario.start.y]).unwrap()
    }

    /// A closed 6 × 4 m building in a yard of free cells framed by one row of unknown ones:
    /// the yard, the largest free region, reaches no border of the image yet is outside.
    #[test]
    fn free_space_framed_by_unknown_is_outside() {
        let d = temp_dir("framed");
        let frame = |i: usize, j: usize, (w, h): (usize, usize)| i == 0 || j == 0 || i == w - 1 || j == h - 1;
        let inside = |i: usize, j: usize| (40..160).contains(&i) && (40..120).contains(&j);
        let walls = |i: usize, j: usize| (38..162).contains(&i) && (38..122).contains(&j) && !inside(i, j);
        let yaml = write_map(&d, "closed", (200, 160), 0.05, |i, j| {
            if frame(i, j, (200, 160)) {
                UNK
            } else if walls(i, j) {
                OCC
            } else {
                FREE
            }
        });
        let m = load_ros_map(&yaml, &RosMapOptions::default()).unwrap();
        assert_eq!(known_area(&m.grid), Some([1, 198, 1, 158]));
        let (i, j) = start_cell(&m);
        assert!(inside(i, j), "start at cell ({i}, {j}), outside the building");
        assert!((m.start_clearance - 2.0).abs() < 0.05, "{}", m.start_clearance);
        // the same building with a door east, in a yard wide enough that the yard's cells have
        // the greater clearance: from them rays end on the frame, beyond the known area
        let inside = |i: usize, j: usize| (20..140).contains(&i) && (20..100).contains(&j);
        let door = |i: usize, j: usize| (140..142).contains(&i) && (50..70).contains(&j);
        let walls = |i: usize, j: usize| (18..142).contains(&i) && (18..102).contains(&j) && !inside(i, j) && !door(i, j);
        let yaml = write_map(&d, "door", (300, 240), 0.05, |i, j| {
            if frame(i, j, (300, 240)) {
                UNK
            } else if walls(i, j) {
                OCC
            } else {
                FREE
            }
        });
        let m = load_ros_map(&yaml, &RosMapOptions::default()).unwrap();
        let (i, j) = start_cell(&m);
        assert!(inside(i, j), "start at cell ({i}, {j}), outside the building");
        assert!(enclosure(&m.grid, 220, 120) < 0.5 && enclosure(&m.grid, i, j) >= ENCLOSURE);
        // the yard's clearance is greater: it is the enclosure test that keeps the start inside
        let clearance = m.grid.distance_field(|c| c != Cell::Free);
        assert!(clearance[120 * 300 + 220] > m.start_clearance + 1.0);
    }

    /// A room with a door west in an image of free cells: the free cells on the image's border
    /// meet the unknown beyond it, a wall with `unknown_is_wall`, in both wall modes.
    #[test]
    fn the_image_border_is_a_wall_where_free_cells_meet_it() {
        let d = temp_dir("border");
        let room = |i: usize, j: usize| (10..70).contains(&i) && (10..50).contains(&j);
        let inside = |i: usize, j: usize| (11..69).contains(&i) && (11..49).contains(&j);
        let door = |i: usize, j: usize| i == 10 && (25..35).contains(&j);
        let yaml = write_map(&d, "room", (80, 60), 0.1, |i, j| if room(i, j) && !inside(i, j) && !door(i, j) { OCC } else { FREE });
        let (w, h) = (8.0, 6.0);
        for unreachable_walls in [false, true] {
            let m = load_ros_map(&yaml, &RosMapOptions { unreachable_walls, simplify: 0.0, ..RosMapOptions::default() }).unwrap();
            let (si, sj) = start_cell(&m);
            assert!(inside(si, sj), "start at cell ({si}, {sj})");
            let walls = &m.scenario.map.segments;
            // each border line walled over its whole length, the image's outside on the left
            let on = |v: Real, e: Real| (v - e).abs() < 1e-9;
            for (k, len) in [(0, h), (1, w), (2, h), (3, w)] {
                let at = |p: [Real; 2]| match k {
                    0 => on(p[0], 0.0),
                    1 => on(p[1], 0.0),
                    2 => on(p[0], w),
                    _ => on(p[1], h),
                };
                let border: Vec<_> = walls.iter().filter(|s| at(s.a) && at(s.b)).collect();
                let total: Real = border.iter().map(|s| s.length()).sum();
                assert!((total - len).abs() < 1e-9, "unreachable_walls {unreachable_walls}, border {k}: {total} m of walls");
                for s in border {
                    let m = [(s.a[0] + s.b[0]) / 2.0 - 0.01 * (s.b[1] - s.a[1]), (s.a[1] + s.b[1]) / 2.0 + 0.01 * (s.b[0] - s.a[0])];
                    assert!(!(0.0..=w).contains(&m[0]) || !(0.0..=h).contains(&m[1]), "{s:?} faces out of the image");
                }
            }
            // closed contours: at every corner as many walls start as end
            let mut balance = std::collections::HashMap::new();
            for s in walls {
                let key = |p: [Real; 2]| ((p[0] * 10.0).round() as i64, (p[1] * 10.0).round() as i64);
                *balance.entry(key(s.a)).or_insert(0) += 1;
                *balance.entry(key(s.b)).or_insert(0) -= 1;
            }
            assert!(balance.values().all(|&v| v == 0), "unreachable_walls {unreachable_walls}: open contours");
            // driving west from the start, out of the door, ends on the image's border
            let s = m.scenario.start;
            let west = walls.iter().filter_map(|w| crate::sensors::ray_segment_distance([s.x, s.y], [-1.0, 0.0], w.a, w.b)).fold(Real::INFINITY, Real::min);
            assert!((west - s.x).abs() < 1e-9, "west: {west} m from x = {}", s.x);
        }
        // without unknown_is_wall the space beyond is open: no wall on the border
        for unreachable_walls in [false, true] {
            let m = load_ros_map(&yaml, &RosMapOptions { unknown_is_wall: false, unreachable_walls, ..RosMapOptions::default() }).unwrap();
            let p: Vec<[Real; 2]> = m.scenario.map.segments.iter().flat_map(|s| [s.a, s.b]).collect();
            assert!(p.iter().all(|p| (1.0 - 1e-9..=7.0 + 1e-9).contains(&p[0]) && (1.0 - 1e-9..=5.0 + 1e-9).contains(&p[1])), "unreachable_walls {unreachable_walls}");
        }
    }
}
