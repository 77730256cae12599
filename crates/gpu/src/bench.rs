//! The paper's timing experiment, GPU-style: one light over a frame of cached shading points,
//! 1 light × 1 sample and 1 light × 128 samples per point, timed per technique. Only the ratios
//! of the times to clipped solid angle's mean anything on a software adapter (lavapipe); on a
//! hardware GPU the absolute times do too.
//!
//! The frame: a camera looking down at a floor (z = 0) under a horizontal line light, every
//! pixel a shading point on the floor (normal +z, the view toward the camera), roughness α
//! varying across the frame from 0.05 to 0.8, diffuse albedo 0.5.

use crate::{BenchMode, Gpu, GpuError};
use std::time::Duration;

/// The light: a segment 2 units long, 1 above the floor; K = radiance × radius in w.
pub const LIGHT: [[f32; 4]; 2] = [[-1.0, 0.0, 1.0, 0.0], [1.0, 0.0, 1.0, 10.0]];

/// The cached shading points of a `width` × `height` frame (3 vec4f each).
pub fn frame(width: usize, height: usize) -> Vec<[f32; 4]> {
    let eye = [0.0f32, -4.0, 3.0];
    let mut out = Vec::with_capacity(width * height * 3);
    for j in 0..height {
        for i in 0..width {
            // The floor square [−3, 3]² mapped onto the frame.
            let u = (i as f32 + 0.5) / width as f32;
            let w = (j as f32 + 0.5) / height as f32;
            let x = [6.0 * u - 3.0, 6.0 * w - 3.0, 0.0];
            let to_eye = [eye[0] - x[0], eye[1] - x[1], eye[2] - x[2]];
            let len = (to_eye[0].powi(2) + to_eye[1].powi(2) + to_eye[2].powi(2)).sqrt();
            let alpha = 0.05 + 0.75 * u;
            out.push([x[0], x[1], x[2], alpha]);
            out.push([0.0, 0.0, 1.0, 0.0]);
            out.push([to_eye[0] / len, to_eye[1] / len, to_eye[2] / len, 0.5]);
        }
    }
    out
}

/// One row of the timing table.
#[derive(Clone, Debug)]
pub struct Timing {
    pub mode: BenchMode,
    pub samples: u32,
    /// Median over the timed runs (after one untimed warm-up dispatch).
    pub median: Duration,
    /// Mean of the estimates over the frame (so that the work cannot be skipped; also a sanity
    /// check: clipped and projected solid angle estimate the same diffuse integral).
    pub mean_estimate: f64,
}

pub fn mode_name(mode: BenchMode) -> &'static str {
    match mode {
        BenchMode::Clipped => "clipped solid angle",
        BenchMode::ProjectedSolidAngle => "projected solid angle",
        BenchMode::LtcMis => "LTC + projected solid angle, MIS",
    }
}

/// Times every technique at `samples` samples per point over `points` (from [`frame`]), each
/// `runs` times after a one-sample warm-up.
pub fn time_frame(
    gpu: &Gpu,
    points: &[[f32; 4]],
    samples: u32,
    runs: usize,
) -> Result<Vec<Timing>, GpuError> {
    let mut out = Vec::new();
    for mode in [
        BenchMode::Clipped,
        BenchMode::ProjectedSolidAngle,
        BenchMode::LtcMis,
    ] {
        // Warm-up: the first dispatch pays one-time costs (allocation, on some drivers the
        // compilation); one sample per point suffices.
        gpu.bench(mode, 1, points, LIGHT)?;
        let mut times = Vec::new();
        let mut mean = 0.0;
        for _ in 0..runs.max(1) {
            let (values, time) = gpu.bench(mode, samples, points, LIGHT)?;
            mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len().max(1) as f64;
            times.push(time);
        }
        times.sort();
        out.push(Timing {
            mode,
            samples,
            median: times[times.len() / 2],
            mean_estimate: mean,
        });
    }
    Ok(out)
}
