//! The project's image format (see `shared/README.md`): OpenEXR, float32, linear RGB. Channels
//! R, G, B hold the pixel mean; `var.R`, `var.G`, `var.B` the variance of that mean. Header
//! attributes: `dof`, `spp`, `passes`, `renderer`, `scene_sha256` (+ free-form extras).
//! Both the Rust renderer and the Mitsuba harness write this format.
//! STUB: to be implemented.

use std::collections::BTreeMap;
use std::path::Path;

/// Header metadata of an image file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Metadata {
    /// Degrees of freedom of the variance estimate (passes − 1, or samples − 1).
    pub dof: f64,
    pub spp: u64,
    pub passes: u64,
    pub renderer: String,
    pub scene_sha256: String,
    /// Any further string attributes (technique, seed, mitsuba version, R, K, ...).
    pub extra: BTreeMap<String, String>,
}

/// Mean and variance of the mean per pixel, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub mean: Vec<[f32; 3]>,
    pub var: Vec<[f32; 3]>,
    pub meta: Metadata,
}

#[derive(Debug)]
pub enum ImageError {
    Io(String),
    /// The file is an EXR but not of the shared format (missing channels, NaN, ...).
    Format(String),
}

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ImageError::Io(m) | ImageError::Format(m) => f.write_str(m),
        }
    }
}
impl std::error::Error for ImageError {}

impl Image {
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            mean: vec![[0.0; 3]; width * height],
            var: vec![[0.0; 3]; width * height],
            meta: Metadata::default(),
        }
    }

    pub fn read(_path: &Path) -> Result<Self, ImageError> {
        todo!()
    }

    pub fn write(&self, _path: &Path) -> Result<(), ImageError> {
        todo!()
    }

    /// Tone-mapped sRGB preview (exposure 1, clamp) as PNG.
    pub fn write_preview_png(&self, _path: &Path) -> Result<(), ImageError> {
        todo!()
    }
}
