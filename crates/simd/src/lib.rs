//! The SIMD vocabulary shared by the samplers (linlight-sampling), the BSDF lanes
//! (linlight-brdf), the BVH and the packet renderer (linlight-render):
//!
//! - [`Isa`]: the instruction sets a kernel is compiled for, and which one this CPU runs;
//! - [`Kernel`] and [`dispatch`]: one kernel compiled once per instruction set and called
//!   through the variant the CPU runs. Every call reads `dispatch(isa, SomeKernel { .. })`, and
//!   `SomeKernel`'s [`Kernel::run`] names the code it runs, so a reader (or `grep`) goes from
//!   the call to the kernel in one step;
//! - the lane widths, named for what a lane holds: [`BATCH_LANES`] sampling problems of a
//!   sampler batch, [`PACKET_LANES`] camera samples of a ray packet;
//! - the lane layout of 3-vectors, [`Lanes3`] (structure of arrays `[x, y, z]`), and
//!   [`Aligned`], lanes on a cache line.
//!
//! Kernels are branch-free loops over lanes that the compiler vectorises; no intrinsics here.
//! `+ − × ÷ √` round the same in every instruction set and no fused multiply-add is formed, so
//! a kernel's results are bit for bit the same whichever variant runs.

mod isa;
mod lanes;

pub use isa::{dispatch, Isa, Kernel};
pub use lanes::{get3, lane3, set3, set_lane3, splat3, zero3, Aligned, Lanes3};

/// Sampling problems of a sampler batch (`linlight_sampling::batch`): eight f32 lanes fill an
/// AVX2 register.
pub const BATCH_LANES: usize = 8;

/// Camera samples of a ray packet (the packet renderer and the BVH's packet walk), and the
/// lanes of the samplers' packet kernels: sixteen f32 lanes fill an AVX-512 register.
pub const PACKET_LANES: usize = 2 * BATCH_LANES;
