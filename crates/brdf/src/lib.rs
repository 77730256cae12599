//! BRDF models for shading linear lights, matching Mitsuba 3's plugins, and the linearly
//! transformed cosine (LTC) tables that importance-sample the GGX lobe.
//!
//! Conventions (all models): directions are unit vectors in the shading frame (z = shading
//! normal), `v` points toward the viewer (Mitsuba's `si.wi`), `l` toward the light. A BRDF value
//! `f(v, l)` excludes the cosine; functions named `*_cos` include the factor cos θ_l = l_z, as
//! Mitsuba's `BSDF::eval` does. Everything is zero unless v_z > 0 and l_z > 0 (one-sided), which
//! `twosided` lifts by flipping the frame toward the viewer.
//!
//! No I/O (the LTC table is compiled in); no dependency on the sampling crate.

// `!(x > 0.0)` is deliberate throughout: it rejects NaN together with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod ltc;
pub mod microfacet;
