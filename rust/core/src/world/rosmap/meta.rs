//! The YAML description of a map_server map: [`parse_ros_yaml`] turns it into a [`RosMapMeta`],
//! naming the file, the line and the field of whatever it refuses.

use std::path::{Path, PathBuf};

// saphyr-parser: the maintained YAML 1.2 parser of the saphyr project (serde_yaml is archived);
// its event stream keeps each scalar's line and every key, so a repeated key is seen, not merged.
use saphyr_parser::{Event, Parser, ScalarStyle};

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

/// The keys of a map_server YAML file.
pub const YAML_KEYS: [&str; 7] = ["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"];

/// Parses the YAML text of a map_server description; `path` names the file in errors.
///
/// The text is one YAML document holding a mapping of the [`YAML_KEYS`], each once. A value is
/// a scalar (plain, quoted or a block scalar) or, for `origin`, a sequence of scalars (flow
/// `[x, y, yaw]` or block `- x` lines); numbers and `negate` may be quoted. Anchors, aliases,
/// tags and nested collections are errors, as are an unknown or repeated key, a second
/// document and text that is not YAML (the parser's message, with its line).
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
        let num = |(at, v): (usize, &str)| -> Result<Real> { v.trim().parse::<Real>().ok().filter(|x| x.is_finite()).ok_or_else(|| bad(at, format!("expected a finite number, got `{v}`"))) };
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

/// A value of a map_server file, with the line each scalar starts on: a scalar or a sequence
/// of scalars.
#[derive(Debug, PartialEq)]
enum YamlValue {
    Scalar(usize, String),
    Sequence(Vec<(usize, String)>),
}

/// An entry of the YAML mapping: the line of its key, the key and the value.
type YamlEntry = (usize, String, YamlValue);

/// What the event `e` is, for errors.
fn event_name(e: &Event) -> String {
    match e {
        Event::Scalar(v, ..) => format!("`{v}`"),
        Event::SequenceStart(..) => "a sequence".into(),
        Event::MappingStart(..) => "a mapping".into(),
        Event::Alias(_) => "an alias".into(),
        Event::DocumentStart(_) => "a YAML document".into(),
        _ => "the end of the file".into(),
    }
}

/// The events of one YAML text with the line each starts on; a parser error is
/// `(line, reason)`.
struct Events<'a> {
    parser: Parser<'a, saphyr_parser::StrInput<'a>>,
    /// The line of the last event (for the end of the text).
    line: usize,
}

impl<'a> Events<'a> {
    fn next(&mut self) -> std::result::Result<(Event<'a>, usize), (usize, String)> {
        match self.parser.next() {
            Some(Ok((e, span))) => {
                self.line = span.start.line();
                // anchors and tags: an anchor id above 0, or a tag, on a node
                let (anchor, tag) = match &e {
                    Event::Scalar(_, _, a, t) => (*a, t.is_some()),
                    Event::SequenceStart(a, t) | Event::MappingStart(a, t) => (*a, t.is_some()),
                    Event::Alias(_) => (1, false),
                    _ => (0, false),
                };
                if anchor > 0 || tag {
                    return Err((self.line, "YAML anchors, aliases and tags are not supported".into()));
                }
                Ok((e, self.line))
            }
            Some(Err(e)) => Err((e.marker().line(), format!("not valid YAML (column {}): {}", e.marker().col() + 1, e.info()))),
            None => Err((self.line, "unexpected end of the YAML text".into())),
        }
    }
}

/// The entries of the YAML document `text`, a mapping; errors are `(line, reason)`.
fn yaml_mapping(text: &str) -> std::result::Result<Vec<YamlEntry>, (usize, String)> {
    let mut ev = Events { parser: Parser::new_from_str(text.strip_prefix('\u{feff}').unwrap_or(text)), line: 1 };
    let mut out = Vec::new();
    // stream start, then the document (none in an empty text)
    ev.next()?;
    match ev.next()? {
        (Event::StreamEnd, _) => return Ok(out),
        (Event::DocumentStart(_), _) => {}
        (e, line) => return Err((line, format!("expected a YAML document, got {}", event_name(&e)))),
    }
    match ev.next()? {
        (Event::MappingStart(..), _) => {}
        (Event::Scalar(v, ..), line) => return Err((line, format!("expected `key: value` lines, got `{}`", v.lines().next().unwrap_or("")))),
        (e, line) => return Err((line, format!("expected a mapping of `key: value` lines, got {}", event_name(&e)))),
    }
    loop {
        let (key, line) = match ev.next()? {
            (Event::MappingEnd, _) => break,
            (Event::Scalar(k, ..), line) => (k.into_owned(), line),
            (e, line) => return Err((line, format!("expected a key, got {}", event_name(&e)))),
        };
        let value = match ev.next()? {
            (Event::Scalar(v, style, ..), at) => {
                if style == ScalarStyle::Plain && matches!(v.as_ref(), "" | "~" | "null" | "Null" | "NULL") {
                    return Err((line, "no value".into()));
                }
                YamlValue::Scalar(at, v.into_owned())
            }
            (Event::SequenceStart(..), _) => {
                let mut items = Vec::new();
                loop {
                    match ev.next()? {
                        (Event::SequenceEnd, _) => break,
                        (Event::Scalar(v, ..), at) => items.push((at, v.into_owned())),
                        (Event::SequenceStart(..), at) => return Err((at, "nested sequences are not supported".into())),
                        (e, at) => return Err((at, format!("expected a value in the sequence, got {}", event_name(&e)))),
                    }
                }
                YamlValue::Sequence(items)
            }
            (e, at) => return Err((at, format!("expected a value of `{key}`, got {}", event_name(&e)))),
        };
        out.push((line, key, value));
    }
    // the end of the document and of the text: nothing follows
    match ev.next()? {
        (Event::DocumentEnd, _) => {}
        (e, line) => return Err((line, format!("expected the end of the document, got {}", event_name(&e)))),
    }
    match ev.next()? {
        (Event::StreamEnd, _) => Ok(out),
        (Event::DocumentStart(_), line) => Err((line, "a second YAML document: a map_server file holds one".into())),
        (e, line) => Err((line, format!("{} after the end of the document", event_name(&e)))),
    }
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
            // a flow mapping
            "{image: room#2.pgm, resolution: 0.05, origin: [0, 1, 0]}\n",
        ] {
            assert_eq!(yaml(text).unwrap_or_else(|e| panic!("{text:?}: {e}")), want, "{text:?}");
        }
        // quotes, escapes, folded plain scalars and block scalars
        assert_eq!(yaml("image: 'it''s a\n  map.pgm'\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/it's a map.pgm"));
        assert_eq!(yaml("image: my\n  map.pgm\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/my map.pgm"));
        assert_eq!(yaml("image: \"a\\tb\\u00e9.pgm\"\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/a\tbé.pgm"));
        assert_eq!(yaml("image: >-\n  a.pgm\nresolution: 1\norigin: [0, 0, 0]\n").unwrap().image, PathBuf::from("/maps/a.pgm"));
        // what is not this YAML is an error naming the line (and the field, for a value)
        let ok = "image: a.pgm\nresolution: 0.05\n";
        for (text, want) in [
            (format!("{ok}origin:\n  - 0.0\n  - x\n  - 0.0\n"), "line 5, field origin: expected a finite number, got `x`"),
            (format!("{ok}origin:\n  - 0.0\n   - 1.0\n  - 0.0\n"), "line 3, field origin: expected 3 numbers, got 2"),
            (format!("{ok}origin: - 0.0\n"), "line 3: not valid YAML (column 9): block sequence entries are not allowed"),
            (format!("{ok}origin: [0, 0, 0\n"), "line 4: not valid YAML (column 1): while parsing a flow sequence, expected ',' or ']'"),
            (format!("{ok}origin: [0, [0], 0]\n"), "line 3: nested sequences are not supported"),
            (format!("{ok}origin: &o [0, 0, 0]\n"), "line 3: YAML anchors, aliases and tags"),
            (format!("{ok}origin: !!seq [0, 0, 0]\n"), "line 3: YAML anchors, aliases and tags"),
            (format!("{ok}origin: [0, 0, 0]\nmode: 'raw'\n"), "line 4, field mode: only `trinary` and `scale`"),
            (format!("{ok}origin: [0, 0, 0]\nnegate: [1]\n"), "line 4, field negate: expected a single value"),
            (format!("{ok}origin: [0, 0, 0]\nnegate: {{a: 1}}\n"), "line 4: expected a value of `negate`, got a mapping"),
            (format!("{ok}origin: [0, 0, 0]\nimage: \"a.pgm\n"), "line 4: not valid YAML (column 8): while scanning a quoted scalar, found unexpected end of stream"),
            (format!("{ok}origin: [0, 0, 0] x\n"), "line 3: not valid YAML"),
            (format!("{ok}origin: [0, 0, 0]\n\tnegate: 1\n"), "line 4: not valid YAML"),
            ("  image: a.pgm\n origin: [0, 0, 0]\n".to_string(), "line 2: not valid YAML"),
            (format!("{ok} origin: [0, 0, 0]\n"), "line 3: not valid YAML"),
            (format!("{ok}origin: [0, 0, 0]\n---\nnegate: 1\n"), "line 4: a second YAML document: a map_server file holds one"),
            (format!("{ok}origin: [0, 0, 0]\n...\nnegate: 1\n"), "line 5: a second YAML document: a map_server file holds one"),
            (format!("{ok}origin: [0, 0, 0]\nnegate: a: b\n"), "line 4: not valid YAML"),
            (format!("{ok}origin: [0, 0, 0]\nnegate:\n"), "line 4: no value"),
            (format!("{ok}origin: [0, 0, 0]\nnegate:1\n"), "line 5: not valid YAML"),
            (format!("{ok}- origin\n"), "line 3: not valid YAML"),
            ("- image\n".to_string(), "line 1: expected a mapping of `key: value` lines, got a sequence"),
        ] {
            let e = yaml(&text).unwrap_err().to_string();
            assert!(e.starts_with(&format!("/maps/test.yaml: {want}")), "{text:?}: {e}");
        }
    }
}
