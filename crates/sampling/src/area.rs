//! Area sampling (technique 2): a point uniform on the unclipped segment; p_R = r²/(2ℓ sin α).
//! STUB: to be implemented.

use crate::geometry::{LineFrame, Segment};
use crate::sampler::LineSampler;
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Area {
    frame: LineFrame,
}

impl Area {
    pub fn prepare(_segment: &Segment, _x: Vec3, _n: Vec3) -> Option<Self> {
        todo!()
    }
}

impl LineSampler for Area {
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
