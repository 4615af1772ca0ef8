//! Map images: the file read within limits, decoded into 8-bit grey (PGM by [`super::pgm`];
//! PNG, BMP, JPEG, PPM and PBM by the `image` crate) and classified into an occupancy grid.

use std::path::Path;

use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader, Limits};

use super::grey::{GreyImage, MAX_IMAGE_PIXELS};
use super::meta::RosMapMeta;
use super::pgm::read_pgm;
use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::geometry::Pose2;
use crate::world::grid::{Cell, OccupancyGrid};

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

/// The formats the `image` crate decodes here, with their names in errors (PNM: the PPM and
/// PBM kinds; a PGM is read by [`read_pgm`]).
const IMAGE_FORMATS: [(ImageFormat, &str); 4] = [(ImageFormat::Png, "PNG"), (ImageFormat::Bmp, "BMP"), (ImageFormat::Jpeg, "JPEG"), (ImageFormat::Pnm, "PNM")];

/// Decodes a PNG, BMP, JPEG or PNM (PPM, PBM) image: its declared size is checked against
/// [`MAX_IMAGE_PIXELS`] before the pixels are decoded, and [`Limits`] bound what the decoder
/// may allocate. Colour becomes luminance `0.299 R + 0.587 G + 0.114 B` (rounded), 16-bit
/// samples keep their high byte, and a pixel with alpha 0 is transparent.
fn read_image(bytes: &[u8], path: &Path) -> Result<GreyImage> {
    let header = |reason: String| Error::map_file(path, "header", reason);
    let mut reader = ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| header(e.to_string()))?;
    let Some(&(_, name)) = IMAGE_FORMATS.iter().find(|f| reader.format() == Some(f.0)) else {
        return Err(header("not a PGM (P5/P2), PNG, BMP, JPEG or PPM/PBM image".into()));
    };
    let bad = |e: image::ImageError| Error::map_file(path, format!("{name} data"), e.to_string());
    let mut limits = Limits::default();
    // the decoded image (at most 8 bytes a pixel, RGBA16) and as much again for the decoder
    limits.max_alloc = Some(16 * MAX_IMAGE_PIXELS as u64);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(bad)?;
    let (w, h) = decoder.dimensions();
    let (w, h) = (w as usize, h as usize);
    if w == 0 || h == 0 {
        return Err(header(format!("size {w} x {h}: a map image has at least one pixel")));
    }
    if w.saturating_mul(h) > MAX_IMAGE_PIXELS {
        return Err(header(format!("size {w} x {h}: more than the {MAX_IMAGE_PIXELS} pixels a map image may have")));
    }
    let (channels, samples) = match DynamicImage::from_decoder(decoder).map_err(bad)? {
        DynamicImage::ImageLuma8(b) => (1, b.into_raw()),
        DynamicImage::ImageLumaA8(b) => (2, b.into_raw()),
        DynamicImage::ImageRgb8(b) => (3, b.into_raw()),
        DynamicImage::ImageRgba8(b) => (4, b.into_raw()),
        DynamicImage::ImageLuma16(b) => (1, high_bytes(b.into_raw())),
        DynamicImage::ImageLumaA16(b) => (2, high_bytes(b.into_raw())),
        DynamicImage::ImageRgb16(b) => (3, high_bytes(b.into_raw())),
        DynamicImage::ImageRgba16(b) => (4, high_bytes(b.into_raw())),
        other => (4, other.into_rgba8().into_raw()),
    };
    let mut value = Vec::with_capacity(w * h);
    let mut transparent = Vec::with_capacity(w * h);
    for px in samples.chunks_exact(channels) {
        let lum = if channels >= 3 { (0.299 * px[0] as Real + 0.587 * px[1] as Real + 0.114 * px[2] as Real).round() as u8 } else { px[0] };
        value.push(lum);
        transparent.push(channels % 2 == 0 && px[channels - 1] == 0);
    }
    Ok(GreyImage { width: w, height: h, value, transparent })
}

/// The high byte of each 16-bit sample.
fn high_bytes(samples: Vec<u16>) -> Vec<u8> {
    samples.into_iter().map(|v| (v >> 8) as u8).collect()
}

/// Reads the image of `meta` and classifies its pixels into an occupancy grid.
pub fn rasterize(meta: &RosMapMeta) -> Result<OccupancyGrid> {
    let bytes = read_image_file(&meta.image)?;
    let img = if bytes.starts_with(b"P5") || bytes.starts_with(b"P2") { read_pgm(&bytes, &meta.image)? } else { read_image(&bytes, &meta.image)? };
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
