//! ROS `map_server` maps: a YAML description plus a PGM (P5/P2) or PNG image, turned into an
//! occupancy grid, merged wall segments and a start pose inside the building.
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

use std::path::{Path, PathBuf};

use super::contour::{simplify_walls, thin_corner};
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

/// The keys of a map_server YAML file.
pub const YAML_KEYS: [&str; 7] = ["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"];

/// Parses the YAML text of a map_server description; `path` names the file in errors.
///
/// The text is one YAML document (an optional `---` start, `...` end and `%YAML` directive)
/// holding a block mapping of the [`YAML_KEYS`], each once. A value is a plain,
/// `'single'`- or `"double"`-quoted scalar (a comment starts at a `#` after whitespace) or,
/// for `origin`, a sequence of them, flow (`[x, y, yaw]`) or block (`- x` lines). Anchors,
/// tags, block scalars and nested collections are errors, as is an unknown or repeated key.
pub fn parse_ros_yaml(text: &str, path: &Path) -> Result<RosMapMeta> {
    let entries = yaml_mapping(text).map_err(|(line, reason)| Error::map_file(path, format!("line {line}"), reason))?;
    let (mut image, mut resolution, mut origin) = (None, None, None);
    let (mut negate, mut occ, mut free) = (false, None, None);
    let mut seen: Vec<(&str, usize)> = Vec::new();
    for (line, key, value) in &entries {
        let Some(&field) = YAML_KEYS.iter().find(|k| **k == key.as_str()) else {
            return Err(Error::map_file(path, format!("line {line}"), format!("unknown key `{key}`; the keys are {}", YAML_KEYS.join(", "))));
        };
        let bad = |at: usize, reason: String| Error::map_file(path, format!("line {at}, field {field}"), reason);
        if let Some((_, first)) = seen.iter().find(|s| s.0 == field) {
            return Err(bad(*line, format!("given twice (first on line {first})")));
        }
        seen.push((field, *line));
        let num = |(at, v): (usize, &str)| -> Result<Real> { v.parse::<Real>().ok().filter(|x| x.is_finite()).ok_or_else(|| bad(at, format!("expected a finite number, got `{v}`"))) };
        let scalar = || match value {
            YamlValue::Scalar(at, v) => Ok((*at, v.as_str())),
            YamlValue::Sequence(items) => Err(bad(*line, format!("expected a single value, got a sequence of {}", items.len()))),
        };
        match field {
            "image" => {
                let (at, v) = scalar()?;
                if v.is_empty() {
                    return Err(bad(at, "expected the image's file name, got an empty value".into()));
                }
                image = Some(v.to_string());
            }
            "resolution" => resolution = Some(num(scalar()?)?),
            "origin" => {
                let items = match value {
                    YamlValue::Sequence(items) => items,
                    YamlValue::Scalar(at, v) => return Err(bad(*at, format!("expected `[x, y, yaw]`, got `{v}`"))),
                };
                if items.len() != 3 {
                    return Err(bad(*line, format!("expected 3 numbers, got {}", items.len())));
                }
                let n = |k: usize| num((items[k].0, items[k].1.as_str()));
                origin = Some([n(0)?, n(1)?, n(2)?]);
            }
            "negate" => {
                negate = match scalar()? {
                    (_, "0" | "false" | "False") => false,
                    (_, "1" | "true" | "True") => true,
                    (at, v) => return Err(bad(at, format!("expected 0 or 1, got `{v}`"))),
                }
            }
            "occupied_thresh" => occ = Some(num(scalar()?)?),
            "free_thresh" => free = Some(num(scalar()?)?),
            _ => {
                // mode
                let (at, v) = scalar()?;
                if !matches!(v, "trinary" | "scale") {
                    return Err(bad(at, format!("only `trinary` and `scale` are supported, got `{v}`")));
                }
            }
        }
    }
    let missing = |f: &str| Error::map_file(path, format!("field {f}"), "missing");
    let image = image.ok_or_else(|| missing("image"))?;
    let resolution = resolution.ok_or_else(|| missing("resolution"))?;
    let origin = origin.ok_or_else(|| missing("origin"))?;
    if resolution <= 0.0 {
        return Err(Error::map_file(path, "field resolution", format!("must be > 0, got {resolution}")));
    }
    let (occ_given, free_given) = (occ.is_some(), free.is_some());
    let (occ, free) = (occ.unwrap_or(0.65), free.unwrap_or(0.196));
    for (field, v) in [("occupied_thresh", occ), ("free_thresh", free)] {
        if !(0.0..=1.0).contains(&v) {
            return Err(Error::map_file(path, format!("field {field}"), format!("must lie in [0, 1], got {v}")));
        }
    }
    if free > occ {
        // blame the one the file gives (free_thresh if both)
        let field = if free_given || !occ_given { "free_thresh" } else { "occupied_thresh" };
        let default = |given: bool| if given { "" } else { ", the default" };
        return Err(Error::map_file(path, format!("field {field}"), format!("need free_thresh ({free}{}) <= occupied_thresh ({occ}{})", default(free_given), default(occ_given))));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    Ok(RosMapMeta { image: dir.join(image), resolution, origin, negate, occupied_thresh: occ, free_thresh: free })
}

/// A value of the YAML subset map_server files are written in, with the line each scalar
/// starts on: a scalar or a sequence of scalars.
#[derive(Debug, PartialEq)]
enum YamlValue {
    Scalar(usize, String),
    Sequence(Vec<(usize, String)>),
}

/// An entry of a YAML mapping: the line of its key, the key and the value.
type YamlEntry = (usize, String, YamlValue);

/// The entries of the YAML document `text`, a block mapping; errors are `(line, reason)`.
fn yaml_mapping(text: &str) -> std::result::Result<Vec<YamlEntry>, (usize, String)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<&str> = text.lines().collect();
    // blank or only a comment
    let blank = |l: &str| {
        let t = l.trim_start_matches([' ', '\t']);
        t.is_empty() || t.starts_with('#')
    };
    let marker = |l: &str, m: &str| l.strip_prefix(m).is_some_and(|r| r.is_empty() || r.starts_with([' ', '\t']));
    let (mut started, mut ended) = (false, false);
    let mut indent = None;
    let mut out = Vec::new();
    let mut k = 0;
    while k < lines.len() {
        let (n, line) = (k + 1, lines[k]);
        k += 1;
        if blank(line) {
            continue;
        }
        if ended {
            return Err((n, format!("`{}` after the end of the document (`...`)", line.trim())));
        }
        if marker(line, "---") {
            if started || indent.is_some() {
                return Err((n, "a second YAML document (`---`): a map_server file holds one".into()));
            }
            if !blank(&line[3..]) {
                return Err((n, "expected the mapping on the lines after `---`, not on its line".into()));
            }
            started = true;
            continue;
        }
        if marker(line, "...") {
            if !blank(&line[3..]) {
                return Err((n, format!("`{}` after the end of the document (`...`)", line[3..].trim())));
            }
            ended = true;
            continue;
        }
        if line.starts_with('%') {
            if marker(line, "%YAML") && !started && indent.is_none() {
                continue;
            }
            return Err((n, format!("unsupported directive `{}`", line.trim())));
        }
        let body = line.trim_start_matches(' ');
        let ind = line.len() - body.len();
        if body.starts_with('\t') {
            return Err((n, "a tab in the indentation (YAML indents with spaces)".into()));
        }
        match indent {
            None => indent = Some(ind),
            Some(i) if i != ind => return Err((n, format!("indented by {ind} spaces, the keys above by {i}"))),
            _ => {}
        }
        let (key, rest) = yaml_key(body).map_err(|e| (n, e))?;
        // the value: the rest of the line and the lines that continue it (blank, comments, more
        // indented, or `- ` entries at the key's own indentation)
        let mut value = rest.to_string();
        let mut starts = vec![(0, n)];
        while k < lines.len() {
            let l = lines[k];
            let b = l.trim_start_matches(' ');
            let i = l.len() - b.len();
            if !(blank(l) || i > ind || (i == ind && (b == "-" || b.starts_with("- ") || b.starts_with("-\t")))) {
                break;
            }
            value.push('\n');
            starts.push((value.len(), k + 1));
            value.push_str(l);
            k += 1;
        }
        let mut scan = YamlScan { text: &value, pos: 0, starts };
        let v = scan.value().map_err(|e| (scan.line(), e))?;
        out.push((n, key, v));
    }
    Ok(out)
}

/// The key of a mapping line and the text after its `:`.
fn yaml_key(body: &str) -> std::result::Result<(String, &str), String> {
    let expected = || format!("expected `key: value`, got `{}`", body.trim_end());
    if body.starts_with(['\'', '"']) {
        let mut scan = YamlScan { text: body, pos: 0, starts: vec![(0, 0)] };
        let key = scan.quoted()?;
        let rest = &body[scan.pos..];
        let rest = rest.trim_start_matches([' ', '\t']);
        return match rest.strip_prefix(':') {
            Some(r) if r.is_empty() || r.starts_with([' ', '\t']) => Ok((key, r)),
            _ => Err(expected()),
        };
    }
    let mut chars = body.char_indices().peekable();
    let mut prev = ' ';
    while let Some((i, c)) = chars.next() {
        let next = chars.peek().map(|p| p.1);
        if c == '#' && matches!(prev, ' ' | '\t') {
            break;
        }
        if i == 0 && scalar_start_error(c, next).is_some() {
            break;
        }
        if c == ':' && matches!(next, None | Some(' ' | '\t')) {
            let key = body[..i].trim_end();
            return if key.is_empty() { Err(expected()) } else { Ok((key.to_string(), &body[i + 1..])) };
        }
        prev = c;
    }
    Err(expected())
}

/// Why a scalar cannot start with `c` (followed by `next`), if it cannot.
fn scalar_start_error(c: char, next: Option<char>) -> Option<String> {
    let space = matches!(next, None | Some(' ' | '\t' | '\n'));
    match c {
        '&' | '*' | '!' => Some(format!("YAML anchors, aliases and tags (`{c}`) are not supported")),
        '|' | '>' => Some(format!("YAML block scalars (`{c}`) are not supported")),
        '{' => Some("YAML flow mappings (`{`) are not supported".into()),
        '@' | '`' | '%' | ']' | '}' | ',' => Some(format!("unexpected `{c}`")),
        '?' | ':' | '-' if space => Some(format!("unexpected `{c}`")),
        _ => None,
    }
}

/// A cursor over the text of one value: the rest of its key's line and the lines continuing
/// it, joined by `\n`; `starts` holds the (offset, line number) at which each line starts.
struct YamlScan<'a> {
    text: &'a str,
    pos: usize,
    starts: Vec<(usize, usize)>,
}

impl YamlScan<'_> {
    fn peek(&self) -> Option<char> {
        self.text[self.pos..].chars().next()
    }

    fn peek2(&self) -> Option<char> {
        self.text[self.pos..].chars().nth(1)
    }

    /// Index into `starts` of the line holding the cursor.
    fn line_index(&self) -> usize {
        self.starts.partition_point(|&(o, _)| o <= self.pos) - 1
    }

    /// The file's line number at the cursor.
    fn line(&self) -> usize {
        self.starts[self.line_index()].1
    }

    fn column(&self) -> usize {
        self.pos - self.starts[self.line_index()].0
    }

    /// Whether the cursor follows whitespace (or starts the text, which follows the `:`).
    fn after_space(&self) -> bool {
        self.pos == 0 || matches!(self.text.as_bytes()[self.pos - 1], b' ' | b'\t' | b'\n')
    }

    fn skip_blanks(&mut self) {
        while matches!(self.peek(), Some(' ' | '\t')) {
            self.pos += 1;
        }
    }

    /// Skips whitespace, line breaks and comments (a `#` after whitespace, to the line's end).
    fn skip_space(&mut self) {
        while let Some(c) = self.peek() {
            match c {
                ' ' | '\t' | '\n' => self.pos += 1,
                '#' if self.after_space() => self.pos = self.text[self.pos..].find('\n').map_or(self.text.len(), |k| self.pos + k),
                _ => break,
            }
        }
    }

    /// The whole value: a scalar, a flow sequence or a block sequence, then nothing but
    /// whitespace and comments.
    fn value(&mut self) -> std::result::Result<YamlValue, String> {
        self.skip_space();
        let line = self.line();
        let value = match self.peek() {
            None => return Err("no value".into()),
            Some('-') if matches!(self.peek2(), None | Some(' ' | '\t' | '\n')) => YamlValue::Sequence(self.block_sequence()?),
            Some('[') => YamlValue::Sequence(self.flow_sequence()?),
            Some('\'' | '"') => YamlValue::Scalar(line, self.quoted()?),
            Some(c) => {
                if let Some(e) = scalar_start_error(c, self.peek2()) {
                    return Err(e);
                }
                YamlValue::Scalar(line, self.plain(false, false)?)
            }
        };
        self.skip_space();
        match self.peek() {
            None => Ok(value),
            Some(_) => Err(format!("unexpected `{}` after the value", self.text[self.pos..].lines().next().unwrap_or("").trim())),
        }
    }

    /// A plain scalar from the cursor: to a comment or the line's end (in a flow sequence also
    /// to `,`, `[`, `]`, `{` or `}`), continued on the following lines unless `one_line`; line
    /// breaks fold into a space (`n` + 1 of them into `n` newlines).
    fn plain(&mut self, flow: bool, one_line: bool) -> std::result::Result<String, String> {
        let mut out = String::new();
        let mut breaks = 0;
        loop {
            let (start, mut end) = (self.pos, self.pos);
            while let Some(c) = self.peek() {
                let next = self.peek2();
                match c {
                    '\n' => break,
                    '#' if self.after_space() => break,
                    ',' | '[' | ']' | '{' | '}' if flow => break,
                    ':' if matches!(next, None | Some(' ' | '\t' | '\n')) || (flow && matches!(next, Some(',' | '[' | ']' | '{' | '}'))) => {
                        return Err("`: ` inside a plain value (quote the value)".into());
                    }
                    _ => {}
                }
                self.pos += c.len_utf8();
                if c != ' ' && c != '\t' {
                    end = self.pos;
                }
            }
            let part = &self.text[start..end];
            if !part.is_empty() {
                if !out.is_empty() {
                    out.push_str(&if breaks == 1 { " ".to_string() } else { "\n".repeat(breaks - 1) });
                }
                out.push_str(part);
                breaks = 0;
            }
            if one_line || self.peek() != Some('\n') {
                return Ok(out);
            }
            // the next line continues the scalar unless it is a comment
            self.pos += 1;
            breaks += 1;
            self.skip_blanks();
            if self.peek() == Some('#') {
                return Ok(out);
            }
        }
    }

    /// A sequence's entry at the cursor: quoted, or plain (see [`YamlScan::plain`] for `flow`
    /// and `one_line`).
    fn item(&mut self, flow: bool, one_line: bool) -> std::result::Result<String, String> {
        match self.peek() {
            Some('\'' | '"') => self.quoted(),
            Some(c) => match scalar_start_error(c, self.peek2()) {
                Some(e) => Err(e),
                None => self.plain(flow, one_line),
            },
            None => Err("an empty entry".into()),
        }
    }

    /// A `'single'`- or `"double"`-quoted scalar at the cursor, its escapes (`''`; `\` ones)
    /// resolved and its line breaks folded.
    fn quoted(&mut self) -> std::result::Result<String, String> {
        let q = self.peek().unwrap_or('"');
        self.pos += 1;
        let mut out = String::new();
        // trailing whitespace before a line break is dropped, up to the last escape
        let mut kept = 0;
        loop {
            let Some(c) = self.peek() else { return Err(format!("no closing `{q}`")) };
            self.pos += c.len_utf8();
            match c {
                '\'' if q == '\'' => {
                    if self.peek() != Some('\'') {
                        return Ok(out);
                    }
                    self.pos += 1;
                    out.push('\'');
                }
                '"' if q == '"' => return Ok(out),
                '\\' if q == '"' => {
                    let Some(e) = self.peek() else { return Err(format!("no closing `{q}`")) };
                    self.pos += e.len_utf8();
                    let hex = |s: &mut Self, n: usize| -> std::result::Result<char, String> {
                        let digits = s.text.get(s.pos..s.pos + n).filter(|d| d.bytes().all(|b| b.is_ascii_hexdigit()));
                        let c = digits.and_then(|d| u32::from_str_radix(d, 16).ok()).and_then(char::from_u32).ok_or_else(|| format!("bad escape `\\{e}`: expected {n} hex digits of a character"))?;
                        s.pos += n;
                        Ok(c)
                    };
                    let ch = match e {
                        '0' => '\0',
                        'a' => '\x07',
                        'b' => '\x08',
                        't' | '\t' => '\t',
                        'n' => '\n',
                        'v' => '\x0b',
                        'f' => '\x0c',
                        'r' => '\r',
                        'e' => '\x1b',
                        ' ' | '"' | '/' | '\\' => e,
                        'N' => '\u{85}',
                        '_' => '\u{a0}',
                        'L' => '\u{2028}',
                        'P' => '\u{2029}',
                        'x' => hex(self, 2)?,
                        'u' => hex(self, 4)?,
                        'U' => hex(self, 8)?,
                        '\n' => {
                            // an escaped line break: joined without a space
                            self.skip_blanks();
                            kept = out.len();
                            continue;
                        }
                        _ => return Err(format!("unknown escape `\\{e}`")),
                    };
                    out.push(ch);
                    kept = out.len();
                }
                '\n' => {
                    while out.len() > kept && out.ends_with([' ', '\t']) {
                        out.pop();
                    }
                    self.skip_blanks();
                    let mut blank_lines = 0;
                    while self.peek() == Some('\n') {
                        self.pos += 1;
                        blank_lines += 1;
                        self.skip_blanks();
                    }
                    out.push_str(&if blank_lines == 0 { " ".to_string() } else { "\n".repeat(blank_lines) });
                }
                _ => out.push(c),
            }
        }
    }

    /// `[a, b, ...]` at the cursor (items plain or quoted scalars).
    fn flow_sequence(&mut self) -> std::result::Result<Vec<(usize, String)>, String> {
        self.pos += 1;
        let mut items = Vec::new();
        loop {
            self.skip_space();
            let line = self.line();
            match self.peek() {
                None => return Err("no closing `]`".into()),
                Some(']') => {
                    self.pos += 1;
                    return Ok(items);
                }
                Some('[') => return Err("nested sequences are not supported".into()),
                Some(',') => return Err("an empty item in `[...]`".into()),
                Some(_) => items.push((line, self.item(true, false)?)),
            }
            self.skip_space();
            match self.peek() {
                None => return Err("no closing `]`".into()),
                Some(',') => self.pos += 1,
                Some(']') => {}
                Some(c) => return Err(format!("expected `,` or `]` in `[...]`, got `{c}`")),
            }
        }
    }

    /// `- a` entries at the cursor, one a line, aligned, starting on a line after the key's.
    fn block_sequence(&mut self) -> std::result::Result<Vec<(usize, String)>, String> {
        if self.line_index() == 0 {
            return Err("a `- ` sequence must start on the line after its key".into());
        }
        let column = self.column();
        let mut items = Vec::new();
        loop {
            if self.column() != column {
                return Err(format!("a `- ` entry at column {}, the first at column {}", self.column() + 1, column + 1));
            }
            self.pos += 1;
            self.skip_blanks();
            let line = self.line();
            match self.peek() {
                None | Some('\n' | '#') => return Err("an empty `- ` entry".into()),
                Some('[') => return Err("nested sequences are not supported".into()),
                Some(_) => items.push((line, self.item(false, true)?)),
            }
            self.skip_blanks();
            match self.peek() {
                None | Some('\n') => {}
                Some('#') if self.after_space() => {}
                Some(c) => return Err(format!("unexpected `{c}` after a `- ` entry")),
            }
            self.skip_space();
            match self.peek() {
                None => return Ok(items),
                Some('-') if matches!(self.peek2(), None | Some(' ' | '\t' | '\n')) => {}
                Some(_) => return Err(format!("expected a `- ` entry, got `{}`", self.text[self.pos..].lines().next().unwrap_or("").trim())),
            }
        }
    }
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
    if magic != "P5" && magic != "P2" {
        return Err(bad("header", format!("expected a P5 or P2 PGM, got magic `{magic}`")));
    }
    let num = |s: &str, f: &str| s.parse::<usize>().map_err(|_| bad("header", format!("{f}: expected an integer, got `{s}`")));
    let (w, h, maxval) = (num(&tokens[1], "width")?, num(&tokens[2], "height")?, num(&tokens[3], "maxval")?);
    if w == 0 || h == 0 || maxval == 0 || maxval > 65535 {
        return Err(bad("header", format!("bad size {w} x {h} or maxval {maxval}")));
    }
    let bpp = if maxval > 255 { 2 } else { 1 };
    let Some(n) = w.checked_mul(h).filter(|n| n.checked_mul(bpp).is_some() && *n <= MAX_IMAGE_PIXELS) else {
        return Err(bad("header", format!("size {w} x {h}: more than the {MAX_IMAGE_PIXELS} pixels a map image may have")));
    };
    // a pixel value of row `k / w` from the top, column `k % w`, at most maxval
    let value = |k: usize, v: usize| -> Result<u8> {
        if v > maxval {
            return Err(bad("pixel data", format!("value {v} at column {}, row {} (from the top) exceeds maxval {maxval}", k % w, k / w)));
        }
        Ok(((v * 255 + maxval / 2) / maxval) as u8)
    };
    let value: Vec<u8> = if magic == "P5" {
        // exactly one whitespace byte (the token ended on it) between maxval and the pixels
        if pos >= bytes.len() {
            return Err(bad("header", "ends after maxval: expected one whitespace byte and then the pixel data".into()));
        }
        let data = &bytes[pos + 1..];
        if data.len() < n * bpp {
            return Err(bad("pixel data", format!("expected {} bytes, found {}", n * bpp, data.len())));
        }
        if data.len() > n * bpp {
            return Err(bad("pixel data", format!("{} bytes after the {} of the {w} x {h} image (one image a file)", data.len() - n * bpp, n * bpp)));
        }
        if bpp == 1 {
            data.iter().enumerate().map(|(k, &v)| value(k, v as usize)).collect::<Result<_>>()?
        } else {
            data.chunks(2).enumerate().map(|(k, c)| value(k, ((c[0] as usize) << 8) | c[1] as usize)).collect::<Result<_>>()?
        }
    } else {
        let text = String::from_utf8_lossy(&bytes[pos..]);
        let mut out = Vec::with_capacity(n.min(bytes.len()));
        for (k, t) in text.split_ascii_whitespace().enumerate() {
            if k == n {
                return Err(bad("pixel data", format!("more than the {n} values of {w} x {h} pixels")));
            }
            let v = t.parse::<usize>().map_err(|_| bad("pixel data", format!("expected an integer from 0 to maxval {maxval}, got `{t}`")))?;
            out.push(value(k, v)?);
        }
        if out.len() < n {
            return Err(bad("pixel data", format!("expected {n} values, found {}", out.len())));
        }
        out
    };
    Ok(GreyImage { width: w, height: h, value, transparent: vec![false; n] })
}

fn read_png(bytes: &[u8], path: &Path) -> Result<GreyImage> {
    let bad = |reason: String| Error::map_file(path, "PNG data", reason);
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| bad(e.to_string()))?;
    let (w, h) = (reader.info().width as usize, reader.info().height as usize);
    if w.saturating_mul(h) > MAX_IMAGE_PIXELS {
        return Err(Error::map_file(path, "header", format!("size {w} x {h}: more than the {MAX_IMAGE_PIXELS} pixels a map image may have")));
    }
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

/// The most pixels a map image may have (8192 × 8192): its header is checked before anything
/// is allocated, so a small file declaring a huge image is an error, not an abort.
pub const MAX_IMAGE_PIXELS: usize = 1 << 26;

/// The largest map image file read (bytes); only regular files are read (not `/dev/zero`).
pub const MAX_IMAGE_BYTES: u64 = 512 << 20;

/// The bytes of the image file `path`: a regular file of at most [`MAX_IMAGE_BYTES`].
fn read_image_file(path: &Path) -> Result<Vec<u8>> {
    use std::io::Read;
    let err = |reason: String| Error::map_file(path, "file", reason);
    let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
    if !meta.is_file() {
        return Err(err("not a regular file".into()));
    }
    if meta.len() > MAX_IMAGE_BYTES {
        return Err(err(format!("{} bytes: larger than the {MAX_IMAGE_BYTES} bytes a map image may have", meta.len())));
    }
    // (read at most one byte past the limit: the file may grow while it is read)
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path).and_then(|f| f.take(MAX_IMAGE_BYTES + 1).read_to_end(&mut bytes)).map_err(|e| err(e.to_string()))?;
    if bytes.len() as u64 > MAX_IMAGE_BYTES {
        return Err(err(format!("larger than the {MAX_IMAGE_BYTES} bytes a map image may have")));
    }
    Ok(bytes)
}

/// Reads the image of `meta` and classifies its pixels into an occupancy grid.
pub fn rasterize(meta: &RosMapMeta) -> Result<OccupancyGrid> {
    let bytes = read_image_file(&meta.image)?;
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
/// unknown) cell inside the known area (see [`known_area`]), rather than leave it through free
/// cells.
pub const ENCLOSURE: Real = 0.9;

/// Rays of the enclosure test.
pub const ENCLOSURE_RAYS: usize = 64;

/// The known area of a map: the smallest box of cells `[i0, i1] × [j0, j1]` holding every
/// occupied and free cell (none if every cell is unknown). An image is often framed by
/// unknown cells; free space that reaches the edge of this box is as open as free space
/// that reaches the image's border.
pub fn known_area(grid: &OccupancyGrid) -> Option<[usize; 4]> {
    let w = grid.width;
    let known = |k: &usize| grid.cells[*k] != Cell::Unknown;
    let first = (0..grid.cells.len()).find(known)?;
    let last = (0..grid.cells.len()).rev().find(known)?;
    let columns = |i: usize| (first / w..=last / w).any(|j| grid.cells[j * w + i] != Cell::Unknown);
    let i0 = (0..w).find(|&i| columns(i))?;
    let i1 = (i0..w).rev().find(|&i| columns(i))?;
    Some([i0, i1, first / w, last / w])
}

/// Share of rays from cell `(i, j)` that stop on a non-free cell before leaving the known
/// area.
pub fn enclosure(grid: &OccupancyGrid, i: usize, j: usize) -> Real {
    known_area(grid).map_or(0.0, |area| enclosure_in(grid, area, i, j))
}

/// [`enclosure`] with the known area given.
fn enclosure_in(grid: &OccupancyGrid, area: [usize; 4], i: usize, j: usize) -> Real {
    (ENCLOSURE_RAYS - escaped_rays(grid, area, i, j, ENCLOSURE_RAYS)) as Real / ENCLOSURE_RAYS as Real
}

/// How many of the [`ENCLOSURE_RAYS`] rays from cell `(i, j)` leave the known area `area`
/// without ending on a non-free cell, counted until more than `limit` have.
fn escaped_rays(grid: &OccupancyGrid, [i0, i1, j0, j1]: [usize; 4], i: usize, j: usize, limit: usize) -> usize {
    let (x0, x1, y0, y1) = (i0 as Real, (i1 + 1) as Real, j0 as Real, (j1 + 1) as Real);
    let mut escaped = 0;
    for k in 0..ENCLOSURE_RAYS {
        let (s, c) = (k as Real * std::f64::consts::TAU / ENCLOSURE_RAYS as Real).sin_cos();
        let (mut x, mut y) = (i as Real + 0.5, j as Real + 0.5);
        loop {
            x += 0.5 * c;
            y += 0.5 * s;
            if x < x0 || y < y0 || x >= x1 || y >= y1 {
                escaped += 1;
                break;
            }
            if grid.get(x as usize, y as usize) != Cell::Free {
                break;
            }
        }
        if escaped > limit {
            break;
        }
    }
    escaped
}

/// Whether cell `(i, j)` passes the [`enclosure`] test (`enclosure_in(..) >= ENCLOSURE`), its
/// rays cast until too many have escaped to pass: a map of open floor refuses each candidate
/// after a few rays rather than all of them.
fn enclosed_in(grid: &OccupancyGrid, area: [usize; 4], i: usize, j: usize) -> bool {
    // the most rays that may escape: the largest `e` with (RAYS − e) / RAYS ≥ ENCLOSURE
    (0..=ENCLOSURE_RAYS).rev().find(|&e| (ENCLOSURE_RAYS - e) as Real / ENCLOSURE_RAYS as Real >= ENCLOSURE).is_some_and(|allowed| escaped_rays(grid, area, i, j, allowed) <= allowed)
}

/// The start cell: in the largest free 4-connected region that does not reach the edge of the
/// [`known_area`] (the image's border or the unknown frame around the map), the cell of
/// greatest clearance, if that is at least [`START_CLEARANCE`] and it passes the [`enclosure`]
/// test. Maps whose building is open to a free exterior (gaps in the outer wall) have no such
/// region; then the greatest-clearance cell (on a 10-cell lattice) that passes the enclosure
/// test is used.
fn interior_start(grid: &OccupancyGrid) -> Option<(Pose2, Real)> {
    let (w, h) = (grid.width, grid.height);
    let area = known_area(grid)?;
    let [i0, i1, j0, j1] = area;
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
            // free cells lie in the known area: on its edge they touch the image's border or
            // the unknown beyond the map
            border |= i == i0 || j == j0 || i == i1 || j == j1;
            let mut visit = |n: usize| {
                if grid.cells[n] == Cell::Free && label[n] == u32::MAX {
                    label[n] = next;
                    stack.push(n);
                }
            };
            if i > 0 {
                visit(c - 1);
            }
            if i + 1 < w {
                visit(c + 1);
            }
            if j > 0 {
                visit(c - w);
            }
            if j + 1 < h {
                visit(c + w);
            }
        }
        next += 1;
        if !border && clearance[best] >= START_CLEARANCE {
            regions.push((size, best));
        }
    }
    regions.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let enclosed = |c: usize| enclosed_in(grid, area, c % w, c / w);
    let chosen = regions.iter().map(|r| r.1).find(|&c| enclosed(c)).or_else(|| {
        let mut lattice: Vec<usize> = (0..h).step_by(10).flat_map(|j| (0..w).step_by(10).map(move |i| j * w + i)).filter(|&c| grid.cells[c] == Cell::Free && clearance[c] >= START_CLEARANCE).collect();
        lattice.sort_by(|a, b| clearance[*b].total_cmp(&clearance[*a]).then(a.cmp(b)));
        lattice.into_iter().find(|&c| enclosed(c))
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

    /// CRC-32 of PNG chunks (ISO 3309), to forge headers.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }

    #[test]
    fn the_enclosure_test_stops_early_with_the_same_verdict() {
        // a room with a door, open floor around: cells inside, in the door and outside
        let mut g = OccupancyGrid::new(120, 100, 0.05, Pose2::new(0.0, 0.0, 0.0), Cell::Free).unwrap();
        for i in 30..90 {
            for j in [30, 70] {
                g.set(i, j, Cell::Occupied);
            }
        }
        for j in 30..71 {
            g.set(30, j, Cell::Occupied);
            if !(45..55).contains(&j) {
                g.set(89, j, Cell::Occupied);
            }
        }
        let area = [0, 119, 0, 99];
        for (i, j) in [(60, 50), (35, 35), (85, 50), (95, 50), (5, 5), (60, 80), (88, 50)] {
            assert_eq!(enclosed_in(&g, area, i, j), enclosure_in(&g, area, i, j) >= ENCLOSURE, "cell ({i}, {j})");
        }
    }

    #[test]
    fn a_huge_declared_image_or_a_device_is_refused_before_reading_it() {
        let d = temp_dir("hostile");
        // a 1 x 1 grey PNG whose header then claims 100000 x 100000 pixels (a 10 GB buffer)
        let mut png_bytes = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut png_bytes, 1, 1);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Eight);
            enc.write_header().unwrap().write_image_data(&[254]).unwrap();
        }
        png_bytes[16..24].copy_from_slice(&[100_000u32.to_be_bytes(), 100_000u32.to_be_bytes()].concat());
        let crc = crc32(&png_bytes[12..29]);
        png_bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        std::fs::write(d.0.join("huge.png"), &png_bytes).unwrap();
        std::fs::write(d.0.join("huge.yaml"), "image: huge.png\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
        let e = load_ros_map(d.0.join("huge.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
        assert!(e.contains("huge.png") && e.contains("100000 x 100000") && e.contains("pixels a map image may have"), "{e}");
        // the same in a PGM header
        std::fs::write(d.0.join("huge.pgm"), b"P5\n100000 100000\n255\n\x00").unwrap();
        std::fs::write(d.0.join("huge_pgm.yaml"), "image: huge.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
        let e = load_ros_map(d.0.join("huge_pgm.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
        assert!(e.contains("pixels a map image may have"), "{e}");
        // an endless device is no image file
        if std::path::Path::new("/dev/zero").exists() {
            std::fs::write(d.0.join("zero.yaml"), "image: /dev/zero\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
            let e = load_ros_map(d.0.join("zero.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
            assert!(e.contains("/dev/zero") && e.contains("not a regular file"), "{e}");
        }
    }

    fn start_cell(m: &RosMap) -> (usize, usize) {
        m.grid.world_to_cell([m.scenario.start.x, m.scenario.start.y]).unwrap()
    }

    #[test]
    fn malformed_pgm_headers_are_errors_not_panics() {
        let err = |bytes: &[u8]| read_pgm(bytes, Path::new("x.pgm")).unwrap_err().to_string();
        // nothing after maxval (no whitespace byte, no pixels)
        let e = err(b"P5\n80 60\n255");
        assert!(e.starts_with("x.pgm: header: ends after maxval"), "{e}");
        // a size whose pixel count overflows
        for magic in ["P5", "P2"] {
            let e = err(format!("{magic}\n4294967296 4294967296\n255\n\x00\x00").as_bytes());
            assert!(e.starts_with("x.pgm: header: size 4294967296 x 4294967296"), "{e}");
        }
        let e = err(b"P5\n4294967296 4294967296\n65535\n\x00\x00");
        assert!(e.starts_with("x.pgm: header"), "{e}");
        // the whole image through load_ros_map: the image's file and its header
        let d = temp_dir("pgm");
        std::fs::write(d.0.join("t.pgm"), b"P5\n80 60\n255").unwrap();
        std::fs::write(d.0.join("m.yaml"), "image: t.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
        let e = load_ros_map(d.0.join("m.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
        assert!(e.contains("t.pgm: header: ends after maxval"), "{e}");
    }

    #[test]
    fn pgm_values_above_maxval_and_extra_data_are_errors() {
        let err = |bytes: &[u8]| read_pgm(bytes, Path::new("x.pgm")).unwrap_err().to_string();
        let e = err(b"P5\n2 1\n100\n\x00\x65");
        assert_eq!(e, "x.pgm: pixel data: value 101 at column 1, row 0 (from the top) exceeds maxval 100");
        let e = err(b"P2\n2 2\n100\n0 0\n101 0\n");
        assert_eq!(e, "x.pgm: pixel data: value 101 at column 0, row 1 (from the top) exceeds maxval 100");
        let e = err(b"P5\n1 1\n1000\n\x03\xe9");
        assert!(e.contains("value 1001 at column 0, row 0 (from the top) exceeds maxval 1000"), "{e}");
        // a second image, or values beyond the image, are not dropped silently
        let e = err(b"P5\n2 1\n255\n\x00\x00\x00");
        assert!(e.starts_with("x.pgm: pixel data: 1 bytes after the 2"), "{e}");
        let e = err(b"P2\n2 1\n255\n0 0 0\n");
        assert!(e.starts_with("x.pgm: pixel data: more than the 2 values"), "{e}");
        // maxval itself is white, in 8 and 16 bits; trailing whitespace after P2 values is fine
        assert_eq!(read_pgm(b"P2\n3 1\n100\n100 0 50\n\n", Path::new("x.pgm")).unwrap().value, [255, 0, 128]);
        assert_eq!(read_pgm(b"P5\n2 1\n1000\n\x03\xe8\x00\x00", Path::new("x.pgm")).unwrap().value, [255, 0]);
    }

    #[test]
    fn unknown_and_repeated_keys_are_errors() {
        let base = "image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
        let e = yaml(&format!("{base}occupied_tresh: 0.99\n")).unwrap_err().to_string();
        assert_eq!(e, "/maps/test.yaml: line 4: unknown key `occupied_tresh`; the keys are image, resolution, origin, negate, occupied_thresh, free_thresh, mode");
        let e = yaml(&format!("{base}resolution: 0.1\n")).unwrap_err().to_string();
        assert_eq!(e, "/maps/test.yaml: line 4, field resolution: given twice (first on line 2)");
        // each threshold's own field is named
        let e = yaml(&format!("{base}occupied_thresh: 1.5\n")).unwrap_err().to_string();
        assert!(e.contains("field occupied_thresh: must lie in [0, 1], got 1.5"), "{e}");
        let e = yaml(&format!("{base}free_thresh: -0.1\n")).unwrap_err().to_string();
        assert!(e.contains("field free_thresh: must lie in [0, 1]"), "{e}");
        let e = yaml(&format!("{base}occupied_thresh: 0.1\n")).unwrap_err().to_string();
        assert!(e.contains("field occupied_thresh: need free_thresh (0.196, the default) <= occupied_thresh (0.1)"), "{e}");
        let e = yaml(&format!("{base}occupied_thresh: 0.5\nfree_thresh: 0.6\n")).unwrap_err().to_string();
        assert!(e.contains("field free_thresh: need free_thresh (0.6) <= occupied_thresh (0.5)"), "{e}");
    }

    #[test]
    fn yaml_as_map_server_files_may_write_it() {
        let want = RosMapMeta { image: PathBuf::from("/maps/room#2.pgm"), resolution: 0.05, origin: [0.0, 1.0, 0.0], negate: false, occupied_thresh: 0.65, free_thresh: 0.196 };
        for text in [
            // a document marker, quoted scalars, a block sequence, a `#` inside a plain scalar
            "---\nimage: \"room#2.pgm\"\nresolution: '0.05'\norigin:\n  - 0.0\n  - 1.0   # y\n  - 0.0\nnegate: \"0\"\nmode: 'trinary'\n...\n",
            "%YAML 1.2\n---\nimage: room#2.pgm # the image\nresolution: 0.05\norigin:\n- 0.0\n- 1.0\n- 0.0\nmode: trinary\n",
            // a flow sequence over lines, indented keys, a value on the next line, CRLF, a BOM
            "\u{feff}  image:\r\n    'room#2.pgm'\r\n  # comment\r\n  resolution: 5e-2\r\n  origin: [ 0.0,\r\n    1.0, \"0.0\" ]\r\n",
            "\"image\": \"room\\x232.pgm\"\n'resolution': 0.05\norigin: [0, 1, 0,]\nnegate: false\n",
        ] {
            assert_eq!(yaml(text).unwrap_or_else(|e| panic!("{text:?}: {e}")), want, "{text:?}");
        }
        // quotes, escapes and folded plain scalars
        assert_eq!(yaml("image: 'it''s a\n  map.pgm'\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/it's a map.pgm"));
        assert_eq!(yaml("image: my\n  map.pgm\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/my map.pgm"));
        assert_eq!(yaml("image: \"a\\tb\\u00e9.pgm\"\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/a\tbé.pgm"));
        // what is not this YAML is an error naming the line (and the field, for a value)
        let ok = "image: a.pgm\nresolution: 0.05\n";
        for (text, want) in [
            (format!("{ok}origin:\n  - 0.0\n  - x\n  - 0.0\n"), "line 5, field origin: expected a finite number, got `x`"),
            (format!("{ok}origin:\n  - 0.0\n   - 1.0\n"), "line 5: a `- ` entry at column 4, the first at column 3"),
            (format!("{ok}origin: - 0.0\n"), "line 3: a `- ` sequence must start"),
            (format!("{ok}origin: [0, 0, 0\n"), "line 3: no closing `]`"),
            (format!("{ok}origin: [0, [0], 0]\n"), "line 3: nested sequences"),
            (format!("{ok}origin: &o [0, 0, 0]\n"), "line 3: YAML anchors, aliases and tags"),
            (format!("{ok}origin: [0, 0, 0]\nmode: 'raw'\n"), "line 4, field mode: only `trinary` and `scale`"),
            (format!("{ok}origin: [0, 0, 0]\nnegate: [1]\n"), "line 4, field negate: expected a single value"),
            (format!("{ok}origin: [0, 0, 0]\nimage: \"a.pgm\n"), "line 4: no closing `\"`"),
            (format!("{ok}origin: [0, 0, 0] x\n"), "line 3: unexpected `x` after the value"),
            (format!("{ok}origin: [0, 0, 0]\n\tnegate: 1\n"), "line 4: a tab in the indentation"),
            ("  image: a.pgm\n origin: [0, 0, 0]\n".to_string(), "line 2: indented by 1 spaces, the keys above by 2"),
            (format!("{ok} origin: [0, 0, 0]\n"), "line 3: `: ` inside a plain value"),
            (format!("{ok}origin: [0, 0, 0]\n---\nnegate: 1\n"), "line 4: a second YAML document"),
            (format!("{ok}origin: [0, 0, 0]\n...\nnegate: 1\n"), "line 5: `negate: 1` after the end of the document"),
            (format!("{ok}origin: [0, 0, 0]\nnegate: a: b\n"), "line 4: `: ` inside a plain value"),
            (format!("{ok}origin: [0, 0, 0]\nnegate:\n"), "line 4: no value"),
            (format!("{ok}origin: [0, 0, 0]\nnegate:1\n"), "line 4: expected `key: value`, got `negate:1`"),
        ] {
            let e = yaml(&text).unwrap_err().to_string();
            assert!(e.starts_with(&format!("/maps/test.yaml: {want}")), "{text:?}: {e}");
        }
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
