//! The PGM images of map_server maps, binary (P5) and ASCII (P2), 8 or 16 bits a sample.
//!
//! The `image` crate reads PNM too, but clamps a sample above the header's maxval, ignores
//! data after the image and scales samples in `f32`; map files are read more strictly here:
//! both are errors naming the pixel or the byte count, and samples scale to 8 bits by exact
//! integer rounding.

use std::path::Path;

use super::grey::{GreyImage, MAX_IMAGE_PIXELS};
use crate::error::{Error, Result};

/// Decodes the P5 or P2 PGM `bytes`; `path` names the file in errors.
pub(super) fn read_pgm(bytes: &[u8], path: &Path) -> Result<GreyImage> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
