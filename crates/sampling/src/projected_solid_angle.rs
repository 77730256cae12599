//! Peters 2021 projected-solid-angle sampling (technique 8): Halley iterations on G(φ).
//! STUB: to be implemented.

use crate::geometry::{LineFrame, Segment};
use crate::sampler::LineSampler;
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct ProjectedSolidAngle {
    frame: LineFrame,
}

impl ProjectedSolidAngle {
    pub fn prepare(_segment: &Segment, _x: Vec3, _n: Vec3) -> Option<Self> {
        todo!()
    }
}

impl LineSampler for ProjectedSolidAngle {
    fn sample(&self, _xi: f32) -> Vec3 {
        todo!()
    }
    fn pdf(&self, _dir: Vec3) -> f32 {
        todo!()
    }
    fn support(&self) -> &LineFrame {
        &self.frame
    }
}
