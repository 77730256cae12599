//! Importance sampling of linear lights (infinitesimally thin cylinder lights).
//!
//! Implements every technique of C. Peters, *BRDF Importance Sampling for Linear Lights*
//! (CGF 40(8), HPG 2021) and the comparisons of that paper. All densities are per radius:
//! with respect to dΩ_R = (2/d) ds on directions toward the line (see [`geometry`]).
//! No I/O; `f32` (glam) on the hot path.

pub mod area;
pub mod backward_error;
pub mod baseline;
pub mod batch;
pub mod cylinder;
pub mod geometry;
pub mod hart;
pub mod li2018;
pub mod ltc;
pub mod mis;
pub mod mixture;
pub mod noise;
pub mod philox;
pub mod projected_solid_angle;
pub mod rng;
pub mod sampler;
pub mod solid_angle;
pub mod specular;
pub mod technique;
pub mod trig;

pub use geometry::{
    antiderivative_at, projected_antiderivative, unit_normal, FrameArc, LineFrame, Segment,
};
pub use sampler::LineSampler;
pub use specular::SpecularSampler;
pub use technique::{Prepared, Technique};
