//! The kernels as an answer source of the sampler suite (`linlight_verify::answers`): the
//! suite's χ², pdf-consistency, round-trip, reported-inverse, integral and cross-density checks
//! run on the kernels' outputs exactly as on an external program's.

use crate::source::{KernelConfig, KernelSource, Technique};
use crate::Gpu;
use glam::Vec3;
use linlight_verify::answers::{AnswerSource, SampleAnswers, SourceError};
use linlight_verify::configs::Config;
use std::sync::Arc;

/// One technique of a [`Gpu`]'s kernels answering the suite.
pub struct GpuAnswers {
    pub gpu: Arc<Gpu>,
    pub technique: Technique,
}

fn kernel_config(c: &Config) -> KernelConfig {
    crate::certify::kernel_config(c)
}

impl AnswerSource for GpuAnswers {
    fn sample(&mut self, config: &Config, xi: &[f32]) -> Result<SampleAnswers, SourceError> {
        let source = KernelSource {
            gpu: &self.gpu,
            technique: self.technique,
        };
        let a = source
            .sample(&kernel_config(config), xi)
            .map_err(|e| SourceError(format!("{}: {e}", config.name)))?;
        Ok(SampleAnswers {
            directions: a.directions.iter().map(|&d| Vec3::from(d)).collect(),
            densities: a.densities,
            inverse: Some(a.inverse),
        })
    }

    fn pdf(&mut self, config: &Config, directions: &[Vec3]) -> Result<Vec<f32>, SourceError> {
        let source = KernelSource {
            gpu: &self.gpu,
            technique: self.technique,
        };
        let dirs: Vec<[f32; 3]> = directions.iter().map(|d| d.to_array()).collect();
        source
            .pdf(&kernel_config(config), &dirs)
            .map(|(pdf, _)| pdf)
            .map_err(|e| SourceError(format!("{}: {e}", config.name)))
    }
}
