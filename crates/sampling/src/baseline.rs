//! Baseline (technique 1): a point uniform on the segment with the density *forced to 1*.
//! Deliberately biased; it exists only as the timing floor of the benchmarks.

use crate::geometry::{normal_is_valid, LineFrame, Segment};
use crate::sampler::{clamp_xi, LineSampler};
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Baseline {
    frame: LineFrame,
}

impl Baseline {
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        if !normal_is_valid(n) {
            return None;
        }
        Some(Self {
            frame: LineFrame::new(segment, x)?,
        })
    }
}

impl LineSampler for Baseline {
    fn sample(&self, xi: f32) -> Vec3 {
        let f = &self.frame;
        let l = (f.l_begin + clamp_xi(xi) * (f.l_end - f.l_begin)).min(f.l_end);
        f.direction_to(l)
    }
    /// Not a density: 1 wherever the segment is, on purpose.
    fn pdf(&self, dir: Vec3) -> f32 {
        if self.frame.contains_s(self.frame.s_of(dir)) {
            1.0
        } else {
            0.0
        }
    }
    fn support(&self) -> &LineFrame {
        &self.frame
    }
}
