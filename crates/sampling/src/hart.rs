//! Hart et al. 2020 cosine warps in clipped-solid-angle primary space (techniques 5 and 6).
//! STUB: to be implemented.

use crate::geometry::{LineFrame, Segment};
use crate::sampler::LineSampler;
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct HartLinear {
    frame: LineFrame,
}

impl HartLinear {
    pub fn prepare(_segment: &Segment, _x: Vec3, _n: Vec3) -> Option<Self> {
        todo!()
    }
}

impl LineSampler for HartLinear {
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

#[derive(Clone, Copy, Debug)]
pub struct HartQuadratic {
    frame: LineFrame,
}

impl HartQuadratic {
    pub fn prepare(_segment: &Segment, _x: Vec3, _n: Vec3) -> Option<Self> {
        todo!()
    }
}

impl LineSampler for HartQuadratic {
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
