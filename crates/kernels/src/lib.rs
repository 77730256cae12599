//! The paper's line-light sampling as shader code: one WGSL source (`shaders/linlight.wgsl`)
//! and its translations by naga, committed in `generated/`: GLSL 450 (one file per entry
//! point), HLSL (shader model 6.0), MSL (2.1) and SPIR-V (1.0). `cargo run -p linlight-kernels
//! --bin gen-kernels` regenerates them; the tests check that the committed files are what the
//! source generates, and validate them (naga; `spirv-val` and `glslangValidator` where
//! installed: `scripts/setup-gpu`).
//!
//! The functions of the source, their conventions (per-radius densities, K = radiance × radius,
//! the line frame and the LTC shading frame of `linlight-sampling`) and what their certification
//! proves are documented in docs/kernels.md.

use naga::back::{glsl, hlsl, msl, spv};
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};
use naga::{Module, ShaderStage};
use std::path::PathBuf;

/// The kernel source.
pub const WGSL: &str = include_str!("../shaders/linlight.wgsl");

/// The compute entry points of the source.
pub const ENTRY_POINTS: [&str; 2] = ["certify", "bench"];

/// Workgroup size of both entry points.
pub const WORKGROUP_SIZE: u32 = 64;

/// vec4f per query and per answer of the `certify` entry point (see the source).
pub const CERTIFY_QUERY_VEC4S: usize = 9;
pub const CERTIFY_ANSWER_VEC4S: usize = 3;
/// vec4f per cached shading point of the `bench` entry point.
pub const BENCH_POINT_VEC4S: usize = 3;

/// The `certify` entry point's modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum CertifyMode {
    Clipped = 0,
    ProjectedSolidAngle = 1,
    Ltc = 2,
    /// The projected-solid-angle inversion alone, on (n_s, n_t, sin φ_b, cos φ_b, Δ, ξ).
    PsaCore = 3,
    Mis = 4,
    /// The GGX table lookup at (α, cos θ_o).
    LtcLookup = 5,
}

/// The `bench` entry point's modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum BenchMode {
    Clipped = 0,
    ProjectedSolidAngle = 1,
    /// LTC and projected solid angle, one sample each, clamped optimal MIS.
    LtcMis = 2,
}

/// The directory of the committed translations.
pub fn generated_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("generated")
}

/// Parses a WGSL source and validates the module with naga's validator (all checks, default
/// capabilities: no f64, nothing beyond what every WebGPU adapter has).
pub fn parse_and_validate(source: &str) -> Result<(Module, ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("WGSL parse error: {}", e.emit_to_string(source)))?;
    let info = validate(&module).map_err(|e| format!("naga validation of the WGSL: {e}"))?;
    Ok((module, info))
}

/// naga's validator on a module.
pub fn validate(module: &Module) -> Result<ModuleInfo, String> {
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(module)
        .map_err(|e| format!("{:?}", e.into_inner()))
}

/// A generated file: its name in [`generated_dir`] and its bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GeneratedFile {
    pub name: String,
    pub bytes: Vec<u8>,
}

/// GLSL file name of an entry point.
pub fn glsl_name(entry_point: &str) -> String {
    format!("linlight.{entry_point}.comp.glsl")
}

pub const HLSL_NAME: &str = "linlight.hlsl";
pub const MSL_NAME: &str = "linlight.metal";
pub const SPIRV_NAME: &str = "linlight.spv";

/// The translations of `source` (the order of [`ENTRY_POINTS`] for the GLSL files, then HLSL,
/// MSL, SPIR-V). Deterministic: the same source gives the same bytes.
pub fn generate(source: &str) -> Result<Vec<GeneratedFile>, String> {
    let (module, info) = parse_and_validate(source)?;
    let mut files = Vec::new();
    for entry_point in ENTRY_POINTS {
        // Explicit layout(binding = k) for group 0's bindings (as Vulkan GLSL needs them).
        let binding_map = (0..4u8)
            .map(|b| {
                let key = naga::ResourceBinding {
                    group: 0,
                    binding: b as u32,
                };
                (key, b)
            })
            .collect();
        let options = glsl::Options {
            version: glsl::Version::Desktop(450),
            writer_flags: glsl::WriterFlags::empty(),
            binding_map,
            ..Default::default()
        };
        let pipeline = glsl::PipelineOptions {
            shader_stage: ShaderStage::Compute,
            entry_point: entry_point.to_string(),
            multiview: None,
        };
        let mut out = String::new();
        glsl::Writer::new(
            &mut out,
            &module,
            &info,
            &options,
            &pipeline,
            Default::default(),
        )
        .and_then(|mut w| w.write().map(|_| ()))
        .map_err(|e| format!("GLSL ({entry_point}): {e}"))?;
        files.push(GeneratedFile {
            name: glsl_name(entry_point),
            bytes: out.into_bytes(),
        });
    }

    let options = hlsl::Options {
        shader_model: hlsl::ShaderModel::V6_0,
        ..Default::default()
    };
    let mut out = String::new();
    hlsl::Writer::new(&mut out, &options, &hlsl::PipelineOptions::default())
        .write(&module, &info, None)
        .map_err(|e| format!("HLSL: {e}"))?;
    files.push(GeneratedFile {
        name: HLSL_NAME.into(),
        bytes: out.into_bytes(),
    });

    let options = msl::Options {
        lang_version: (2, 1),
        ..Default::default()
    };
    let (out, _) = msl::write_string(&module, &info, &options, &Default::default())
        .map_err(|e| format!("MSL: {e}"))?;
    files.push(GeneratedFile {
        name: MSL_NAME.into(),
        bytes: out.into_bytes(),
    });

    let words = spv::write_vec(&module, &info, &spv::Options::default(), None)
        .map_err(|e| format!("SPIR-V: {e}"))?;
    files.push(GeneratedFile {
        name: SPIRV_NAME.into(),
        bytes: words.iter().flat_map(|w| w.to_le_bytes()).collect(),
    });
    Ok(files)
}

#[cfg(test)]
mod tests;
