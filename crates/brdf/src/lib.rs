//! BRDF models for shading linear lights, matching Mitsuba 3's plugins, and the linearly
//! transformed cosine (LTC) tables that importance-sample the GGX lobe.
//!
//! Conventions (all models): directions are unit vectors in the shading frame (z = shading
//! normal), `v` points toward the viewer (Mitsuba's `si.wi`), `l` toward the light. A BRDF value
//! `f(v, l)` excludes the cosine; functions named `*_cos` and every `eval` include the factor
//! cos θ_l = l_z, as Mitsuba's `BSDF::eval` does. Everything is zero unless v_z > 0 and l_z > 0
//! (one-sided), which `twosided` lifts by mirroring both directions when the viewer is below.
//!
//! Models, one per module, each with its evaluation (generic over the precision) and lobe
//! summary: [`diffuse`], [`roughconductor`], [`principled`], [`blendbsdf`], [`twosided`];
//! [`Bsdf`] dispatches over them ([`Bsdf::eval`] in f64, [`Bsdf::eval_f32`],
//! [`Bsdf::eval_lanes`]) and documents the lobe summary ([`Lobes`]) that MIS weights are built
//! from. Shared
//! pieces: [`microfacet`] (GGX D, Smith G1, the F ≡ 1 lobe, visible-normal sampling) and
//! [`fresnel`]; [`lanes`] (N evaluations at once, bit for bit the scalar ones); [`real`] (the
//! precision: f64 for reference, f32 for the renderer, one piece of code).
//!
//! No I/O (the LTC table is compiled in); no dependency on the sampling crate.

// `!(x > 0.0)` is deliberate throughout: it rejects NaN together with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod blendbsdf;
mod bsdf;
pub mod diffuse;
pub mod fresnel;
pub mod lanes;
pub mod ltc;
pub mod microfacet;
pub mod principled;
pub mod real;
pub mod roughconductor;
pub mod twosided;

pub use blendbsdf::Blend;
pub use bsdf::{Bsdf, Lobes, Rgb, SpecularLobe};
pub use principled::Principled;
pub use roughconductor::{ConductorFresnel, RoughConductor};

#[cfg(test)]
mod early_returns;
#[cfg(test)]
pub(crate) mod test_util;
