//! The decoded map image both decoders produce (PGM by [`super::pgm`], the other formats by
//! [`super::image`]), and the size limit they share.

/// An 8-bit luminance image with an "unknown" mask (alpha 0).
#[derive(Debug)]
pub(super) struct GreyImage {
    pub(super) width: usize,
    pub(super) height: usize,
    /// Row-major from the top row.
    pub(super) value: Vec<u8>,
    pub(super) transparent: Vec<bool>,
}

/// The most pixels a map image may have (8192 × 8192): its header is checked before anything
/// is allocated, so a small file declaring a huge image is an error, not an abort.
pub const MAX_IMAGE_PIXELS: usize = 1 << 26;
