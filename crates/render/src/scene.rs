//! The scene description the renderer consumes: what the Mitsuba-XML loader produces.
//! World space, f32 geometry (transforms are composed in f64 by the loader and applied once).

use glam::{Mat4, Vec3};
use std::path::PathBuf;

/// Where an element came from, for error messages and warnings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SourceLocation {
    pub file: PathBuf,
    pub line: u32,
    pub column: u32,
}

impl std::fmt::Display for SourceLocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub sensor: Sensor,
    pub integrator: Integrator,
    pub shapes: Vec<Shape>,
    pub lights: Vec<LinearLight>,
    /// SHA-256 (hex) of the scene file's bytes (the top file; includes are not hashed).
    pub sha256: String,
    /// Non-fatal remarks from loading (e.g. a light radius large compared with the scene).
    pub warnings: Vec<String>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    /// Mitsuba's conversion of a field of view `fov` along this axis to the horizontal one
    /// (degrees), for a film of width / height `aspect`.
    pub fn horizontal_fov(self, fov: f64, aspect: f64) -> f64 {
        let axis = match self {
            FovAxis::Smaller if aspect > 1.0 => FovAxis::Y,
            FovAxis::Smaller => FovAxis::X,
            FovAxis::Larger if aspect > 1.0 => FovAxis::X,
            FovAxis::Larger => FovAxis::Y,
            a => a,
        };
        let half = (0.5 * fov).to_radians().tan();
        match axis {
            FovAxis::Y => 2.0 * (half * aspect).atan().to_degrees(),
            FovAxis::Diagonal => {
                let width = 2.0 * half / (1.0 + 1.0 / (aspect * aspect)).sqrt();
                2.0 * (0.5 * width).atan().to_degrees()
            }
            _ => fov,
        }
    }
}

/// `sensor type="perspective"` with its `film` (hdrfilm, box filter) and `sampler`.
#[derive(Clone, Debug)]
pub struct Sensor {
    /// Camera to world. Camera space as in Mitsuba: +z forward, +x left, +y up.
    pub to_world: Mat4,
    /// Full field of view in degrees along `fov_axis`.
    pub fov_deg: f32,
    pub fov_axis: FovAxis,
    pub principal_point_offset_x: f32,
    pub principal_point_offset_y: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    pub film: Film,
    /// `sampler` `sample_count` (spp) and `seed`.
    pub sample_count: u32,
    pub seed: u64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// `crop_offset_x/y`, `crop_width/height`; the full film when absent.
    pub crop: Option<CropWindow>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CropWindow {
    pub offset_x: u32,
    pub offset_y: u32,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Integrator {
    pub hide_emitters: bool,
    /// `emitter_samples` (default: `shading_samples`, default 1): Mitsuba's light samples per
    /// camera sample, each of one emitter chosen uniformly. `linlight render` takes it as the
    /// default of `--light-samples`, the samples of *every* light per camera sample.
    pub emitter_samples: u32,
}

/// Linear RGB.
pub type Rgb = [f32; 3];

/// The BSDF models and their Mitsuba plugins live in the `linlight-brdf` crate.
pub use linlight_brdf::Bsdf;

#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    /// Triangles in world space. `normals` are per-vertex shading normals, present only when the
    /// mesh has them and `face_normals` is false. Rectangles and cubes become meshes.
    Mesh {
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        indices: Vec<[u32; 3]>,
    },
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// Unit disk in the local xy-plane (normal +z), placed by `to_world`.
    Disk {
        to_world: Mat4,
    },
    /// A cylinder *without* an emitter: an ordinary finite-radius occluder/reflector (no caps).
    Cylinder {
        p0: Vec3,
        p1: Vec3,
        radius: f32,
    },
}

#[derive(Clone, Debug)]
pub struct Shape {
    pub geometry: Geometry,
    pub bsdf: Bsdf,
    pub flip_normals: bool,
    pub location: SourceLocation,
}

/// A `cylinder` with an `area` emitter in the R → 0 limit: a segment with
/// K = radiance_times_radius = radiance × radius held fixed. Invisible to every ray.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearLight {
    pub begin: Vec3,
    pub end: Vec3,
    /// The cylinder's radius in the file (kept for reports; the renderer uses the R → 0 limit).
    pub radius: f32,
    /// K = radiance × radius, per channel.
    pub radiance_times_radius: Rgb,
    /// The emitter's `sampling_weight` (positive; 1 by default): with one light per light
    /// sample ([`crate::light_choice`]) light j is chosen with probability w_j/Σw.
    pub sampling_weight: f32,
    pub location: SourceLocation,
}
