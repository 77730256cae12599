//! Per-configuration answers of the kernels, in the shape of the sampler suite's answer sources:
//! a batch of primary samples ξ for one configuration → directions, densities and the kernels'
//! own inverse; a batch of directions → densities.

use crate::{CertifyMode, Gpu, GpuError};
use linlight_kernels::{CERTIFY_ANSWER_VEC4S, CERTIFY_QUERY_VEC4S};

/// A light, shading point and shading frame (the sampler suite's configuration): the segment,
/// the shading point x, the unit normal n, the unit view direction (the LTC shading frame's x̂
/// lies in the plane of n and the view) and the LTC matrix A (shading → cosine space), by rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KernelConfig {
    pub begin: [f32; 3],
    pub end: [f32; 3],
    pub x: [f32; 3],
    pub n: [f32; 3],
    pub view: [f32; 3],
    pub a_rows: [[f32; 3]; 3],
}

/// The kernels' techniques.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    Clipped,
    ProjectedSolidAngle,
    Ltc,
}

impl Technique {
    pub const ALL: [Technique; 3] = [
        Technique::Clipped,
        Technique::ProjectedSolidAngle,
        Technique::Ltc,
    ];

    fn mode(self) -> CertifyMode {
        match self {
            Technique::Clipped => CertifyMode::Clipped,
            Technique::ProjectedSolidAngle => CertifyMode::ProjectedSolidAngle,
            Technique::Ltc => CertifyMode::Ltc,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Technique::Clipped => "clipped-solid-angle",
            Technique::ProjectedSolidAngle => "projected-solid-angle",
            Technique::Ltc => "ltc",
        }
    }
}

/// The answers to one batch of primary samples, in order. Where the kernel's `prepare` found
/// nothing to sample (`valid` false) the direction and densities are 0.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SampleAnswers {
    pub directions: Vec<[f32; 3]>,
    /// Density per radius of each sample, as `sample` returns it.
    pub densities: Vec<f32>,
    /// ξ of each sample by the kernel's inverse.
    pub inverse: Vec<f32>,
    pub prepared: bool,
}

fn v4(v: [f32; 3], w: f32) -> [f32; 4] {
    [v[0], v[1], v[2], w]
}

/// One query of the `certify` entry point.
pub(crate) fn query(config: &KernelConfig, xi: f32, probe: [f32; 3]) -> [[f32; 4]; 9] {
    let r = &config.a_rows;
    [
        v4(config.begin, xi),
        v4(config.end, 0.0),
        v4(config.x, 0.0),
        v4(config.n, 0.0),
        v4(config.view, 0.0),
        v4(probe, 0.0),
        v4(r[0], 0.0),
        v4(r[1], 0.0),
        v4(r[2], 0.0),
    ]
}

/// A technique of the kernels on a [`Gpu`], answering per configuration.
pub struct KernelSource<'a> {
    pub gpu: &'a Gpu,
    pub technique: Technique,
}

impl KernelSource<'_> {
    /// The technique prepared for `config`, sampled at every ξ.
    pub fn sample(&self, config: &KernelConfig, xi: &[f32]) -> Result<SampleAnswers, GpuError> {
        let queries: Vec<[f32; 4]> = xi
            .iter()
            .flat_map(|&x| query(config, x, [0.0; 3]))
            .collect();
        let answers = self.gpu.certify(self.technique.mode(), 0, &queries)?;
        debug_assert_eq!(answers.len(), xi.len() * CERTIFY_ANSWER_VEC4S);
        let mut out = SampleAnswers {
            prepared: answers.get(1).is_some_and(|a| a[1] == 1.0),
            ..Default::default()
        };
        for a in answers.chunks_exact(CERTIFY_ANSWER_VEC4S) {
            out.directions.push([a[0][0], a[0][1], a[0][2]]);
            out.densities.push(a[0][3]);
            out.inverse.push(a[1][0]);
        }
        Ok(out)
    }

    /// The technique's density (with its support test) and its cross density (without, where
    /// the technique has one: projected solid angle and LTC on the horizon-clipped line) at
    /// each direction.
    pub fn pdf(
        &self,
        config: &KernelConfig,
        directions: &[[f32; 3]],
    ) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
        let queries: Vec<[f32; 4]> = directions
            .iter()
            .flat_map(|&d| query(config, 0.5, d))
            .collect();
        let answers = self.gpu.certify(self.technique.mode(), 0, &queries)?;
        Ok(answers
            .chunks_exact(CERTIFY_ANSWER_VEC4S)
            .map(|a| (a[1][2], a[1][3]))
            .unzip())
    }

    /// The LTC technique weight scale Ω⊥_o/κ for `config` (0 where the sampler is invalid).
    pub fn ltc_weight_scale(&self, config: &KernelConfig) -> Result<f32, GpuError> {
        let answers = self
            .gpu
            .certify(CertifyMode::Ltc, 0, &query(config, 0.5, [0.0; 3]))?;
        Ok(answers[2][0])
    }
}

const _: () = assert!(CERTIFY_QUERY_VEC4S == 9);
