//! ROS `map_server` maps: a YAML description plus a PGM (P5/P2) or PNG image, turned into an
//! occupancy grid, merged wall segments and a start pose inside the building.
//!
//! YAML fields: `image` (relative to the YAML file), `resolution` (m/cell), `origin`
//! `[x, y, yaw]` (the pose of the lower-left pixel's corner; the yaw *is* applied, unlike ROS 1),
//! `negate` (0/1, default 0), `occupied_thresh` (default 0.65), `free_thresh` (default 0.196),
//! `mode` (`trinary` or `scale`; both classify cells the same way here).
//!
//! Classification follows map_server's trinary rule: with `v` the 8-bit luminance
//! (`0.299 R + 0.587 G + 0.114 B` for colour images), `p = (255 − v)/255` (`v/255` if negated);
//! `p > occupied_thresh` is occupied, `p < free_thresh` free, anything else unknown, as is any
//! pixel with alpha 0.
//!
//! The start is the cell of greatest clearance in the largest free region that does not touch
//! the image border and from which straight lines end on non-free cells (free space outside a
//! building reaches the border and is never used); see [`enclosure`]. Only occupied cells
//! become walls unless [`RosMapOptions::unknown_is_wall`] (the default) makes unknown cells
//! walls too.

use std::path::{Path, PathBuf};

use super::contour::simplify_walls;
use super::geometry::Pose2;
use super::grid::{Cell, OccupancyGrid};
use super::map::StaticMap;
use super::region::FreeRegion;
use super::scenario::{Scenario, COORDINATE_LIMIT};
use crate::error::{Error, Result};
use crate::math::Real;

/// The fields of a map_server YAML file.
#[derive(Debug, Clone, PartialEq)]
pub struct RosMapMeta {
    /// The image path, resolved against the YAML file's folder.
    pub image: PathBuf,
    /// Cell edge (m).
    pub resolution: Real,
    /// `[x, y, yaw]` of the lower-left pixel corner (m, rad).
    pub origin: [Real; 3],
    /// Whether white means occupied.
    pub negate: bool,
    /// Occupancy probability above which a cell is occupied.
    pub occupied_thresh: Real,
    /// Occupancy probability below which a cell is free.
    pub free_thresh: Real,
}

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

/// Parses the YAML text of a map_server description; `path` names the file in errors.
pub fn parse_ros_yaml(text: &str, path: &Path) -> Result<RosMapMeta> {
    let (mut image, mut resolution, mut origin) = (None, None, None);
    let (mut negate, mut occ, mut free) = (false, 0.65, 0.196);
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let err = |reason: String| Error::map_file(path, format!("line {line_no}"), reason);
        let (key, value) = line.split_once(':').ok_or_else(|| err(format!("expected `key: value`, got `{line}`")))?;
        let (key, value) = (key.trim(), value.trim());
        let num = |v: &str, field: &str| -> Result<Real> {
            v.parse::<Real>().ok().filter(|x| x.is_finite()).ok_or_else(|| Error::map_file(path, format!("line {line_no}, field {field}"), format!("expected a finite number, got `{v}`")))
        };
        match key {
            "image" => image = Some(value.trim_matches(|c| c == '"' || c == '\'').to_string()),
            "resolution" => resolution = Some(num(value, "resolution")?),
            "origin" => {
                let inner = value.strip_prefix('[').and_then(|v| v.strip_suffix(']')).ok_or_else(|| Error::map_file(path, format!("line {line_no}, field origin"), format!("expected `[x, y, yaw]`, got `{value}`")))?;
                let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
                if parts.len() != 3 {
                    return Err(Error::map_file(path, format!("line {line_no}, field origin"), format!("expected 3 numbers, got {}", parts.len())));
                }
                origin = Some([num(parts[0], "origin")?, num(parts[1], "origin")?, num(parts[2], "origin")?]);
            }
            "negate" => {
                negate = match value {
                    "0" | "false" | "False" => false,
                    "1" | "true" | "True" => true,
                    _ => return Err(Error::map_file(path, format!("line {line_no}, field negate"), format!("expected 0 or 1, got `{value}`"))),
                }
            }
            "occupied_thresh" => occ = num(value, "occupied_thresh")?,
            "free_thresh" => free = num(value, "free_thresh")?,
            "mode" if !matches!(value, "trinary" | "scale") => {
                return Err(Error::map_file(path, format!("line {line_no}, field mode"), format!("only `trinary` and `scale` are supported, got `{value}`")));
            }
            _ => {} // other map_server keys carry nothing we use
        }
    }
    let missing = |f: &str| Error::map_file(path, format!("field {f}"), "missing");
    let image = image.ok_or_else(|| missing("image"))?;
    let resolution = resolution.ok_or_else(|| missing("resolution"))?;
    let origin = origin.ok_or_else(|| missing("origin"))?;
    if resolution <= 0.0 {
        return Err(Error::map_file(path, "field resolution", format!("must be > 0, got {resolution}")));
    }
    if !(0.0..=1.0).contains(&free) || !(0.0..=1.0).contains(&occ) || free > occ {
        return Err(Error::map_file(path, "field free_thresh", format!("need 0 <= free_thresh ({free}) <= occupied_thresh ({occ}) <= 1")));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    Ok(RosMapMeta { image: dir.join(image), resolution, origin, negate, occupied_thresh: occ, free_thresh: free })
}

/// An 8-bit luminance image with an optional "unknown" mask (alpha 0).
#[derive(Debug)]
struct GreyImage {
    width: usize,
    height: usize,
    /// Row-major from the top row.
    value: Vec<u8>,
    transparent: Vec<bool>,
}

fn read_pgm(bytes: &[u8], path: &Path) -> Result<GreyImage> {
    let bad = |what: &str, reason: String| Error::map_file(path, what.to_string(), reason);
    // header tokens, skipping `#` comments
    let mut pos = 0;
    let mut tokens = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && (bytes[pos].is_ascii_whitespace() || bytes[pos] == b'#') {
            if bytes[pos] == b'#' {
                while pos < bytes.len() && bytes[pos] != b'\n' {
                    pos += 1;
                }
            } else {
                pos += 1;
            }
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(bad("header", "truncated PGM header".into()));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    let magic = tokens[0].as_str();
    let num = |s: &str, f: &str| s.parse::<usize>().map_err(|_| bad("header", format!("{f}: expected an integer, got `{s}`")));
    let (w, h, maxval) = (num(&tokens[1], "width")?, num(&tokens[2], "height")?, num(&tokens[3], "maxval")?);
    if w == 0 || h == 0 || maxval == 0 || maxval > 65535 {
        return Err(bad("header", format!("bad size {w} x {h} or maxval {maxval}")));
    }
    let scale = |v: usize| ((v * 255 + maxval / 2) / maxval).min(255) as u8;
    let n = w * h;
    let value: Vec<u8> = match magic {
        "P5" => {
            let data = &bytes[pos + 1..];
            let bpp = if maxval > 255 { 2 } else { 1 };
            if data.len() < n * bpp {
                return Err(bad("pixel data", format!("expected {} bytes, found {}", n * bpp, data.len())));
            }
            if bpp == 1 {
                data[..n].iter().map(|&v| scale(v as usize)).collect()
            } else {
                data[..2 * n].chunks(2).map(|c| scale(((c[0] as usize) << 8) | c[1] as usize)).collect()
            }
        }
        "P2" => {
            let text = String::from_utf8_lossy(&bytes[pos..]);
            let vals: Vec<usize> = text
                .split_ascii_whitespace()
                .take(n)
                .map(|t| t.parse::<usize>().map_err(|_| bad("pixel data", format!("expected an integer, got `{t}`"))))
                .collect::<Result<_>>()?;
            if vals.len() < n {
                return Err(bad("pixel data", format!("expected {n} values, found {}", vals.len())));
            }
            vals.into_iter().map(scale).collect()
        }
        _ => return Err(bad("header", format!("expected a P5 or P2 PGM, got magic `{magic}`"))),
    };
    Ok(GreyImage { width: w, height: h, value, transparent: vec![false; n] })
}

fn read_png(bytes: &[u8], path: &Path) -> Result<GreyImage> {
    let bad = |reason: String| Error::map_file(path, "PNG data", reason);
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| bad(e.to_string()))?;
    let size = reader.output_buffer_size().ok_or_else(|| bad("image too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(|e| bad(e.to_string()))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let ch = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(bad("palette was not expanded".into())),
    };
    let mut value = Vec::with_capacity(w * h);
    let mut transparent = Vec::with_capacity(w * h);
    for row in 0..h {
        let line = &buf[row * info.line_size..row * info.line_size + w * ch];
        for px in line.chunks(ch) {
            let lum = if ch >= 3 { (0.299 * px[0] as Real + 0.587 * px[1] as Real + 0.114 * px[2] as Real).round() as u8 } else { px[0] };
            value.push(lum);
            transparent.push((ch == 2 || ch == 4) && px[ch - 1] == 0);
        }
    }
    Ok(GreyImage { width: w, height: h, value, transparent })
}

/// How an occupancy map becomes walls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RosMapOptions {
    /// Height of every wall (m).
    pub wall_height: Real,
    /// Whether unknown cells are solid too. SLAM maps often bound their free space with
    /// unknown rather than occupied cells (Willow Garage); without this the robot and the LIDAR
    /// leak out of the mapped building there.
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
            return Err(Error::map_file(yaml, field, format!("the map ({} × {} cells of {} m from origin {:?}) reaches ({}, {}); it must lie within {COORDINATE_LIMIT} m of (0, 0)", grid.width, grid.height, meta.resolution, meta.origin, p[0], p[1])));
        }
    }
    let (start, start_clearance) = interior_start(&grid).ok_or_else(|| Error::map_file(yaml, "map", "no free region inside the building (away from the image border) is wide enough to start in"))?;
    let mut map = StaticMap::new();
    let unknown_is_wall = options.unknown_is_wall;
    let solid = |c: Cell| c == Cell::Occupied || (unknown_is_wall && c == Cell::Unknown);
    let walls = if options.unreachable_walls {
        grid.wall_segments(options.wall_height, solid)
    } else {
        let cell = grid.world_to_cell([start.x, start.y]).ok_or_else(|| Error::map_file(yaml, "map", "the start lies off the grid"))?;
        let region = FreeRegion::through(&grid, cell, [!solid(Cell::Free), !solid(Cell::Occupied), !solid(Cell::Unknown)]);
        // cells off the region are solid; their edges on the image's border face nothing
        let (w, h, r) = (grid.width as Real * grid.resolution, grid.height as Real * grid.resolution, grid.resolution);
        let on_border = |s: &super::Segment| {
            let (a, b) = (grid.origin.inverse_transform_point(s.a), grid.origin.inverse_transform_point(s.b));
            let at = |v: Real, edge: Real| (v - edge).abs() < 0.25 * r;
            (at(a[0], 0.0) && at(b[0], 0.0)) || (at(a[0], w) && at(b[0], w)) || (at(a[1], 0.0) && at(b[1], 0.0)) || (at(a[1], h) && at(b[1], h))
        };
        let mut walls = region.as_grid(&grid)?.wall_segments(options.wall_height, |c| c != Cell::Free);
        walls.retain(|s| !on_border(s));
        walls
    };
    // chains break where two solid cells meet only at a corner, in either mode alike
    let is_solid = |i: i64, j: i64| i >= 0 && j >= 0 && (i as usize) < grid.width && (j as usize) < grid.height && solid(grid.get(i as usize, j as usize));
    let pinch = |(i, j): (i64, i64)| {
        let (a, b, c, d) = (is_solid(i - 1, j - 1), is_solid(i, j - 1), is_solid(i - 1, j), is_solid(i, j));
        a == d && b == c && a != b
    };
    map.segments = simplify_walls(&grid, &walls, options.simplify, pinch)?;
    let name = yaml.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let scenario = Scenario::new(name, map, start);
    Ok(RosMap { meta, grid, scenario, start_clearance })
}

/// Reads the image of `meta` and classifies its pixels into an occupancy grid.
pub fn rasterize(meta: &RosMapMeta) -> Result<OccupancyGrid> {
    let bytes = std::fs::read(&meta.image).map_err(|e| Error::map_file(&meta.image, "file", e.to_string()))?;
    let img = if bytes.starts_with(b"\x89PNG") {
        read_png(&bytes, &meta.image)?
    } else if bytes.starts_with(b"P5") || bytes.starts_with(b"P2") {
        read_pgm(&bytes, &meta.image)?
    } else {
        return Err(Error::map_file(&meta.image, "header", "neither a PNG nor a P5/P2 PGM image"));
    };
    let origin = Pose2::new(meta.origin[0], meta.origin[1], meta.origin[2]);
    let mut grid = OccupancyGrid::new(img.width, img.height, meta.resolution, origin, Cell::Unknown)?;
    for row in 0..img.height {
        let j = img.height - 1 - row;
        for i in 0..img.width {
            let k = row * img.width + i;
            if img.transparent[k] {
                continue;
            }
            let v = img.value[k] as Real;
            let p = if meta.negate { v / 255.0 } else { (255.0 - v) / 255.0 };
            let c = if p > meta.occupied_thresh {
                Cell::Occupied
            } else if p < meta.free_thresh {
                Cell::Free
            } else {
                Cell::Unknown
            };
            grid.set(i, j, c);
        }
    }
    Ok(grid)
}

/// The minimum clearance (m) an interior start must have: the robot's circumscribed radius.
pub const START_CLEARANCE: Real = 0.6;

/// Share of [`ENCLOSURE_RAYS`] rays from a start that must end on a non-free (occupied or
/// unknown) cell inside the image, rather than leave the image through free cells.
pub const ENCLOSURE: Real = 0.9;

/// Rays of the enclosure test.
pub const ENCLOSURE_RAYS: usize = 64;

/// Share of rays from cell `(i, j)` that stop on a non-free cell before leaving the grid.
pub fn enclosure(grid: &OccupancyGrid, i: usize, j: usize) -> Real {
    let (w, h) = (grid.width as Real, grid.height as Real);
    let mut hits = 0;
    for k in 0..ENCLOSURE_RAYS {
        let (s, c) = (k as Real * std::f64::consts::TAU / ENCLOSURE_RAYS as Real).sin_cos();
        let (mut x, mut y) = (i as Real + 0.5, j as Real + 0.5);
        loop {
            x += 0.5 * c;
            y += 0.5 * s;
            if x < 0.0 || y < 0.0 || x >= w || y >= h {
                break;
            }
            if grid.get(x as usize, y as usize) != Cell::Free {
                hits += 1;
                break;
            }
        }
    }
    hits as Real / ENCLOSURE_RAYS as Real
}

/// The start cell: in the largest free 4-connected region that does not touch the image
/// border, the cell of greatest clearance, if that is at least [`START_CLEARANCE`] and it
/// passes the [`enclosure`] test. Maps whose building is open to a free exterior (gaps in the
/// outer wall) have no such region; then the greatest-clearance cell (on a 10-cell lattice)
/// that passes the enclosure test is used.
fn interior_start(grid: &OccupancyGrid) -> Option<(Pose2, Real)> {
    let (w, h) = (grid.width, grid.height);
    let clearance = grid.distance_field(|c| c != Cell::Free);
    let mut label = vec![u32::MAX; w * h];
    let mut regions: Vec<(usize, usize)> = Vec::new(); // (size, best cell) of interior regions
    let mut next = 0u32;
    let mut stack = Vec::new();
    for s in 0..w * h {
        if grid.cells[s] != Cell::Free || label[s] != u32::MAX {
            continue;
        }
        let (mut size, mut border, mut best) = (0usize, false, s);
        label[s] = next;
        stack.push(s);
        while let Some(c) = stack.pop() {
            size += 1;
            if clearance[c] > clearance[best] || (clearance[c] == clearance[best] && c < best) {
                best = c;
            }
            let (i, j) = (c % w, c / w);
            border |= i == 0 || j == 0 || i == w - 1 || j == h - 1;
            let mut visit = |n: usize| {
                if grid.cells[n] == Cell::Free && label[n] == u32::MAX {
                    label[n] = next;
                    stack.push(n);
                }
            };
            if i > 0 { visit(c - 1); }
            if i + 1 < w { visit(c + 1); }
            if j > 0 { visit(c - w); }
            if j + 1 < h { visit(c + w); }
        }
        next += 1;
        if !border && clearance[best] >= START_CLEARANCE {
            regions.push((size, best));
        }
    }
    regions.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let chosen = regions.iter().map(|r| r.1).find(|&c| enclosure(grid, c % w, c / w) >= ENCLOSURE).or_else(|| {
        let mut lattice: Vec<usize> = (0..h).step_by(10).flat_map(|j| (0..w).step_by(10).map(move |i| j * w + i)).filter(|&c| grid.cells[c] == Cell::Free && clearance[c] >= START_CLEARANCE).collect();
        lattice.sort_by(|a, b| clearance[*b].total_cmp(&clearance[*a]).then(a.cmp(b)));
        lattice.into_iter().find(|&c| enclosure(grid, c % w, c / w) >= ENCLOSURE)
    })?;
    let p = grid.cell_center(chosen % w, chosen / w);
    Some((Pose2::new(p[0], p[1], grid.origin.yaw), clearance[chosen]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yaml(text: &str) -> Result<RosMapMeta> {
        parse_ros_yaml(text, Path::new("/maps/test.yaml"))
    }

    #[test]
    fn parses_the_map_server_fields() {
        let m = yaml("image: a.pgm\nresolution: 0.05 # m\norigin: [-1.5, 2.0, 0.25]\nnegate: 1\noccupied_thresh: 0.7\nfree_thresh: 0.2\n").unwrap();
        assert_eq!(m.image, PathBuf::from("/maps/a.pgm"));
        assert_eq!(m.origin, [-1.5, 2.0, 0.25]);
        assert!(m.negate);
        assert_eq!((m.occupied_thresh, m.free_thresh), (0.7, 0.2));
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let e = yaml("image: a.pgm\nresolution: fast\norigin: [0, 0, 0]\n").unwrap_err().to_string();
        assert!(e.contains("/maps/test.yaml: line 2, field resolution"), "{e}");
        let e = yaml("image: a.pgm\norigin: [0, 0]\nresolution: 0.1\n").unwrap_err().to_string();
        assert!(e.contains("line 2, field origin"), "{e}");
        let e = yaml("image: a.pgm\norigin: [0, 0, 0]\n").unwrap_err().to_string();
        assert!(e.contains("field resolution: missing"), "{e}");
        let e = yaml("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thresh: 0.9\n").unwrap_err().to_string();
        assert!(e.contains("free_thresh"), "{e}");
        let e = yaml("resolution 0.1\n").unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
    }

    #[test]
    fn pgm_p2_and_p5_decode_alike() {
        let p2 = b"P2\n# comment\n3 2\n255\n0 128 255\n255 255 0\n";
        let mut p5 = b"P5\n3 2\n255\n".to_vec();
        p5.extend_from_slice(&[0, 128, 255, 255, 255, 0]);
        let a = read_pgm(p2, Path::new("a.pgm")).unwrap();
        let b = read_pgm(&p5, Path::new("b.pgm")).unwrap();
        assert_eq!(a.value, b.value);
        assert_eq!((a.width, a.height), (3, 2));
        assert!(read_pgm(b"P6\n3 2\n255\n", Path::new("c.pgm")).unwrap_err().to_string().contains("c.pgm: header"));
        assert!(read_pgm(b"P5\n3 2\n255\n\x00", Path::new("d.pgm")).unwrap_err().to_string().contains("pixel data"));
    }
}
