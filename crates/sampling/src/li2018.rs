//! Li et al. 2018 projected-solid-angle sampling (technique 7): Newton with bisection fallback.
//! STUB: to be implemented.

use crate::geometry::{LineFrame, Segment};
use crate::sampler::LineSampler;
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Li2018 {
    frame: LineFrame,
}

impl Li2018 {
    pub fn prepare(_segment: &Segment, _x: Vec3, _n: Vec3) -> Option<Self> {
        todo!()
    }
}

impl LineSampler for Li2018 {
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
