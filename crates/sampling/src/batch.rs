//! Projected-solid-angle sampling (technique 8), Li et al. 2018 (technique 7) and clipped solid
//! angle sampling (technique 4) of eight (light, shading point) pairs at once.
//!
//! For a packet renderer: structure-of-arrays inputs (segment ends, shading point, normal, ξ
//! per lane) and outputs (direction, density per radius, distance to the line along the
//! direction, and a mask of the lanes that contribute). Lane i is exactly what the scalar
//! `Technique::ProjectedSolidAngle.prepare(..)` + `sample_with_pdf(ξ)` return for the same
//! inputs — bit for bit, since both run the same branch-free building blocks
//! (`LineFrame::lane`, `ProjectedSolidAngle::lane`, `PsaCore::solve_rotated_lane`; the
//! scalar path takes cheap early branches in front of them where a branch pays) with the same
//! operations (no fused multiply-adds are formed by the compiler); likewise clipped solid angle
//! ([`sample_clipped_solid_angle_with`], [`ClippedBatch`]: `LineFrame::lane`,
//! `SolidAngle::lane` and its `sample_lane`, on the same inputs and outputs). A lane whose scalar
//! preparation returns `None` has its bit cleared in [`BatchSamples::mask`] and zero outputs.
//!
//! One implementation per technique: each sampler's math is written once, as functions of one
//! (light, shading point) pair without data-dependent branches — `LineFrame::lane`,
//! `ProjectedSolidAngle::lane`, `PsaCore::solve_rotated_lane` and `direction_and_density`,
//! `Li2018::lane`, `step` and `finish`, `SolidAngle::lane` and `sample_lane`,
//! `LineFrame::direction_to`. The scalar sampler is the one-lane instance: it calls these
//! functions on one pair (taking the rare fresh evaluation of `solve_rotated_lane` and Li et
//! al.'s convergence as branches); a kernel here calls them on every lane of the structure of
//! arrays in one loop. The value type is the lane: the loop over lanes of f32/f64 code is what
//! the compiler vectorises, so the lane types are the arrays of [`linlight_simd::Lanes3`] and
//! `[f32; N]`, not an operator-overloaded vector type. Two pieces keep a scalar form next to the
//! branch-free one, each checked bit for bit against it by the tests here: the frame's
//! constructor (`LineFrame::build`: its early rejections keep the square roots of |a|² and d²
//! apart, see there) and atan2 (`trig::atan2_f64` / `atan2_coarse` against their `_select`
//! forms: the branch starts the division on the predicted path); on the scalar path their
//! branch-free forms take more instructions per sample than the 3 % this layout allows.
//!
//! SIMD: the kernel is one loop over the lanes of branch-free code, which the compiler
//! vectorises (f32 and f64 lanes side by side); it is compiled three times — for AVX-512,
//! for AVX2 + FMA, and for the target's baseline (SSE2 on x86-64, or any other architecture) —
//! and [`sample_projected_solid_angle`] picks one at run time (`is_x86_feature_detected!`), so
//! the binary runs on any CPU of its target. The types are generic over the lane count N
//! ([`LineProblems`], [`LineSamples`], [`Vec3xN`]): a batch has [`BATCH_LANES`] = 8, a renderer's packet
//! [`PACKET_LANES`] = 16 ([`sample_projected_solid_angle_packet`], whose AVX-512 kernel fills
//! 512-bit registers with sixteen f32 lanes). Cost per lane: `cargo bench -p linlight-sampling
//! --bench techniques` (the `batch` and `slice` rows).

use crate::geometry::{normal_is_valid, unit_normal_lane, FrameArc, LineFrame};
use crate::li2018::{Li2018, LiState, MAX_ITERATIONS};
use crate::projected_solid_angle::{
    direction_and_density, ProjectedSolidAngle, PsaCore, DEFAULT_ITERATIONS,
};
use crate::sampler::clamp_xi;
use crate::sampler::LineSampler;
use crate::solid_angle::SolidAngle;
use crate::trig::{atan2_coarse_select, atan2_f64_select};
use glam::Vec3;
pub use linlight_simd::Isa;
use linlight_simd::{dispatch, get3, set3, zero3, Kernel, Lanes3};
pub use linlight_simd::{BATCH_LANES, PACKET_LANES};

// The kernels, each compiled once per instruction set by `linlight_simd::dispatch`: a struct
// holds a kernel's arguments and its `Kernel::run` calls the kernel function.

/// [`kernel`] (one loop over the lanes) or, without `ONE_LOOP`, [`two_chains`] (lane pairs
/// (i, i + N/2)), on `.0`.
struct PsaSample<'a, const N: usize, const ONE_LOOP: bool>(&'a LineProblems<N>);

impl<const N: usize, const ONE_LOOP: bool> Kernel for PsaSample<'_, N, ONE_LOOP> {
    type Output = LineSamples<N>;
    #[inline(always)]
    fn run(self) -> LineSamples<N> {
        if ONE_LOOP {
            kernel(self.0)
        } else {
            two_chains(self.0)
        }
    }
}

/// [`slice`] of `inputs` into `outputs`.
struct PsaSlice<'a, const ONE_LOOP: bool> {
    inputs: &'a [BatchProblems],
    outputs: &'a mut [BatchSamples],
}

impl<const ONE_LOOP: bool> Kernel for PsaSlice<'_, ONE_LOOP> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        slice::<ONE_LOOP>(self.inputs, self.outputs)
    }
}

/// [`prepare_kernel`] of `.0`.
struct Prepare<'a, const N: usize>(&'a LineProblems<N>);

impl<const N: usize> Kernel for Prepare<'_, N> {
    type Output = PreparedBatch<N>;
    #[inline(always)]
    fn run(self) -> PreparedBatch<N> {
        prepare_kernel(self.0)
    }
}

/// [`psa_sample_kernel`] of prepared lanes.
struct SamplePrepared<'a, const N: usize> {
    prepared: &'a PreparedBatch<N>,
    xi: &'a [f32; N],
}

impl<const N: usize> Kernel for SamplePrepared<'_, N> {
    type Output = LineSamples<N>;
    #[inline(always)]
    fn run(self) -> LineSamples<N> {
        psa_sample_kernel(self.prepared, self.xi)
    }
}

/// [`li_sample_kernel`] of prepared lanes.
struct SampleLi<'a, const N: usize> {
    prepared: &'a PreparedBatch<N>,
    xi: &'a [f32; N],
}

impl<const N: usize> Kernel for SampleLi<'_, N> {
    type Output = (LineSamples<N>, u32);
    #[inline(always)]
    fn run(self) -> (LineSamples<N>, u32) {
        li_sample_kernel(self.prepared, self.xi)
    }
}

/// Clipped solid angle: [`clipped_kernel`] (one loop) or, without `ONE_LOOP`,
/// [`clipped_two_chains`], on `.0`.
struct ClippedSample<'a, const N: usize, const ONE_LOOP: bool>(&'a LineProblems<N>);

impl<const N: usize, const ONE_LOOP: bool> Kernel for ClippedSample<'_, N, ONE_LOOP> {
    type Output = LineSamples<N>;
    #[inline(always)]
    fn run(self) -> LineSamples<N> {
        if ONE_LOOP {
            clipped_kernel(self.0)
        } else {
            clipped_two_chains(self.0)
        }
    }
}

/// [`clipped_prepare_kernel`] of `.0`.
struct ClippedPrepare<'a, const N: usize>(&'a LineProblems<N>);

impl<const N: usize> Kernel for ClippedPrepare<'_, N> {
    type Output = ClippedBatch<N>;
    #[inline(always)]
    fn run(self) -> ClippedBatch<N> {
        clipped_prepare_kernel(self.0)
    }
}

/// [`clipped_sample_kernel`] of prepared lanes.
struct ClippedSamplePrepared<'a, const N: usize> {
    prepared: &'a ClippedBatch<N>,
    xi: &'a [f32; N],
}

impl<const N: usize> Kernel for ClippedSamplePrepared<'_, N> {
    type Output = LineSamples<N>;
    #[inline(always)]
    fn run(self) -> LineSamples<N> {
        clipped_sample_kernel(self.prepared, self.xi)
    }
}

/// N 3-vectors as structure of arrays, `[x, y, z]` (the one lane layout of
/// [`linlight_simd::Lanes3`]).
pub type Vec3xN<const N: usize> = Lanes3<f32, N>;

/// Eight 3-vectors as structure of arrays (a batch's).
pub type Vec3x8 = Vec3xN<BATCH_LANES>;

// Zeros in the lane types generic over N are written out: std implements `Default` for arrays
// of each length up to 32, not for `[T; N]` of a generic N, so `#[derive(Default)]` cannot
// bound their fields.

/// N sampling problems (a batch has [`BATCH_LANES`], a renderer's packet [`PACKET_LANES`]): lane i
/// samples the segment `begin[i]` → `end[i]` seen from the shading point `x[i]` with normal
/// `n[i]` (any length; rejected when zero or not finite, as by [`crate::unit_normal`];
/// projected solid angle and Li et al. do not normalise it, their arithmetic being homogeneous
/// in n, see `ProjectedSolidAngle::lane`) for the primary sample `xi[i]` (clamped to [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))] // 16-lane arrays then fill whole cache lines (see `Pending`)
pub struct LineProblems<const N: usize> {
    pub begin: Vec3xN<N>,
    pub end: Vec3xN<N>,
    pub x: Vec3xN<N>,
    pub n: Vec3xN<N>,
    pub xi: [f32; N],
}

/// Eight sampling problems (a batch).
pub type BatchProblems = LineProblems<BATCH_LANES>;

impl<const N: usize> Default for LineProblems<N> {
    fn default() -> Self {
        Self {
            begin: zero3(),
            end: zero3(),
            x: zero3(),
            n: zero3(),
            xi: [0.0; N],
        }
    }
}

/// Samples of N lanes. Lanes outside `mask` (no contribution: the light is degenerate, below
/// the horizon or seen from on its line) hold zeros.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))] // 16-lane arrays then fill whole cache lines (see `Pending`)
pub struct LineSamples<const N: usize> {
    /// Unit direction toward the line.
    pub dir: Vec3xN<N>,
    /// Density per radius (w.r.t. dΩ_R) of `dir`: (n·ω)/Ω⊥_R.
    pub pdf: [f32; N],
    /// Distance from the shading point to the line along `dir` (d/t with t = ĉ·ω): the end of
    /// a shadow ray toward the sampled point.
    pub distance: [f32; N],
    /// Bit i set: lane i contributes (N ≤ 32).
    pub mask: u32,
}

/// Samples of a batch.
pub type BatchSamples = LineSamples<BATCH_LANES>;

impl<const N: usize> Default for LineSamples<N> {
    fn default() -> Self {
        Self {
            dir: zero3(),
            pdf: [0.0; N],
            distance: [0.0; N],
            mask: 0,
        }
    }
}

impl<const N: usize> LineSamples<N> {
    /// Whether lane i contributes.
    #[inline]
    pub fn contributes(&self, i: usize) -> bool {
        self.mask & (1 << i) != 0
    }
}

/// Sample every lane of `input` with the fastest kernel this CPU runs (see the module
/// documentation). Lane i equals the scalar `ProjectedSolidAngle::prepare` + `sample_with_pdf`
/// on lane i's inputs.
pub fn sample_projected_solid_angle(input: &BatchProblems) -> BatchSamples {
    sample_projected_solid_angle_with(Isa::detect(), input)
}

/// The same with a chosen kernel; one the CPU does not run ([`Isa::supported`]) falls back
/// to the baseline.
pub fn sample_projected_solid_angle_with(isa: Isa, input: &BatchProblems) -> BatchSamples {
    dispatch(isa, PsaSample::<BATCH_LANES, true>(input))
}

/// Sample many batches (`outputs[k]` for `inputs[k]`; the slices must have the same length),
/// choosing the kernel once. Two batches at a time are sampled as one packet of
/// [`PACKET_LANES`] lanes, as [`sample_projected_solid_angle_packet`] does.
pub fn sample_projected_solid_angle_slice(
    isa: Isa,
    inputs: &[BatchProblems],
    outputs: &mut [BatchSamples],
) {
    assert_eq!(inputs.len(), outputs.len(), "one output per input batch");
    if one_loop(isa) {
        dispatch(isa, PsaSlice::<true> { inputs, outputs })
    } else {
        dispatch(isa, PsaSlice::<false> { inputs, outputs })
    }
}

/// Sample the [`PACKET_LANES`] lanes of `input` with the chosen kernel (the baseline where the
/// CPU does not run it): lane i equals the scalar technique bit for bit, as the lanes of
/// [`sample_projected_solid_angle_with`] do. For a renderer whose packets hold sixteen shading
/// points, which fill `input` in place of two batches.
///
/// A lane is one long dependency chain (square roots, divisions and the Halley steps), and the
/// kernel is throughput-bound when it runs two batches' chains side by side. How they are laid
/// out depends on the ISA: with AVX-512 one loop over all sixteen lanes, whose f64 half (the
/// frame, the end values, Δ) the compiler vectorises as two 512-bit registers of eight lanes
/// and whose f32 half (start value, Halley steps, direction) as *one* register of sixteen —
/// two 256-bit registers of eight would take as many micro-operations, since 256-bit
/// operations only get the two ports left to them while 512-bit work is in flight. With AVX2
/// or SSE2, where the one loop over sixteen lanes spills registers, one loop over eight lane
/// pairs (i, i + 8): two eight-lane chains interleaved.
pub fn sample_projected_solid_angle_packet(
    isa: Isa,
    input: &LineProblems<PACKET_LANES>,
) -> LineSamples<PACKET_LANES> {
    if one_loop(isa) {
        dispatch(isa, PsaSample::<PACKET_LANES, true>(input))
    } else {
        dispatch(isa, PsaSample::<PACKET_LANES, false>(input))
    }
}

/// Whether the packet's lanes run in one loop (AVX-512) rather than as two interleaved
/// chains (see [`sample_projected_solid_angle_packet`]). Not `Isa::supported`: the dispatch
/// tests that (once per call, not twice), and AVX-512 asked of
/// a CPU without it runs the baseline's one loop, as fast there as its two chains.
#[inline(always)]
fn one_loop(isa: Isa) -> bool {
    isa == Isa::Avx512
}

impl LineProblems<PACKET_LANES> {
    /// The packet of two batches.
    #[inline(always)]
    pub fn from_batches(a: &BatchProblems, b: &BatchProblems) -> Self {
        LineProblems {
            begin: join3(&a.begin, &b.begin),
            end: join3(&a.end, &b.end),
            x: join3(&a.x, &b.x),
            n: join3(&a.n, &b.n),
            xi: join(&a.xi, &b.xi),
        }
    }
}

impl LineSamples<PACKET_LANES> {
    /// Batch h (lanes h·[`BATCH_LANES`] … h·[`BATCH_LANES`] + [`BATCH_LANES`] − 1) of the packet's samples.
    #[inline(always)]
    pub fn batch(&self, h: usize) -> BatchSamples {
        LineSamples {
            dir: half3(&self.dir, h),
            pdf: half(&self.pdf, h),
            distance: half(&self.distance, h),
            mask: self.mask >> (h * BATCH_LANES) & ((1 << BATCH_LANES) - 1),
        }
    }
}

/// Lanes of `a` then of `b`.
#[inline(always)]
fn join<const N: usize, const M: usize>(a: &[f32; N], b: &[f32; N]) -> [f32; M] {
    const { assert!(M == 2 * N) };
    std::array::from_fn(|k| if k < N { a[k] } else { b[k - N] })
}

/// Lanes h·N … h·N + N − 1 of `v`.
#[inline(always)]
fn half<const N: usize, const M: usize>(v: &[f32; M], h: usize) -> [f32; N] {
    const { assert!(M == 2 * N) };
    std::array::from_fn(|k| v[h * N + k])
}

#[inline(always)]
fn join3<const N: usize, const M: usize>(a: &Vec3xN<N>, b: &Vec3xN<N>) -> Vec3xN<M> {
    [join(&a[0], &b[0]), join(&a[1], &b[1]), join(&a[2], &b[2])]
}

#[inline(always)]
fn half3<const N: usize, const M: usize>(v: &Vec3xN<M>, h: usize) -> Vec3xN<N> {
    [half(&v[0], h), half(&v[1], h), half(&v[2], h)]
}

/// The slice, two batches at a time as one packet: in one loop (`ONE_LOOP`) or as two chains.
#[inline(always)]
fn slice<const ONE_LOOP: bool>(inputs: &[BatchProblems], outputs: &mut [BatchSamples]) {
    let mut pairs_in = inputs.chunks_exact(2);
    let mut pairs_out = outputs.chunks_exact_mut(2);
    for (i, o) in (&mut pairs_in).zip(&mut pairs_out) {
        let packet = LineProblems::from_batches(&i[0], &i[1]);
        let out = if ONE_LOOP {
            kernel(&packet)
        } else {
            two_chains(&packet)
        };
        o[0] = out.batch(0);
        o[1] = out.batch(1);
    }
    for (i, o) in pairs_in.remainder().iter().zip(pairs_out.into_remainder()) {
        *o = kernel(i);
    }
}

/// N prepared samplers (a batch: [`BATCH_LANES`] = 8 by default; a packet: [`PACKET_LANES`]) as
/// structure of arrays: what [`ProjectedSolidAngle::prepare`] (and [`Li2018::prepare`], which
/// shares it) keep per (light, shading point), to draw any number of samples with
/// [`PreparedBatch::sample_projected_solid_angle`] or [`PreparedBatch::sample_li2018`]. Lanes
/// outside `mask` hold meaningless values. The sample kernel is one loop over the N lanes: with
/// 16 lanes on AVX-512 its f32 half (start value, Halley steps, direction) fills one zmm.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))] // 16-lane arrays then fill whole cache lines (see `Pending`)
pub struct PreparedBatch<const N: usize = BATCH_LANES> {
    u: Vec3xN<N>,
    c_hat: Vec3xN<N>,
    n: Vec3xN<N>,
    d: [f32; N],
    l_begin: [f32; N],
    l_end: [f32; N],
    s_begin: [f32; N],
    s_end: [f32; N],
    // PsaCore
    ns: [f32; N],
    nt: [f32; N],
    s_b: [f32; N],
    c_b: [f32; N],
    delta_s: [f32; N],
    width: [f32; N],
    p0: [f32; N],
    p1: [f32; N],
    total: [f32; N],
    inv_psa: [f32; N],
    tolerance: [f32; N],
    /// Li et al.: n·c and n·u (f32 dot products, not the core's f64-rounded n_s).
    n_dot_c: [f32; N],
    n_dot_u: [f32; N],
    /// Bit i set: lane i contributes (N ≤ 32).
    pub mask: u32,
}

impl<const N: usize> Default for PreparedBatch<N> {
    fn default() -> Self {
        let zero = [0.0; N];
        Self {
            u: zero3(),
            c_hat: zero3(),
            n: zero3(),
            d: zero,
            l_begin: zero,
            l_end: zero,
            s_begin: zero,
            s_end: zero,
            ns: zero,
            nt: zero,
            s_b: zero,
            c_b: zero,
            delta_s: zero,
            width: zero,
            p0: zero,
            p1: zero,
            total: zero,
            inv_psa: zero,
            tolerance: zero,
            n_dot_c: zero,
            n_dot_u: zero,
            mask: 0,
        }
    }
}

impl<const N: usize> PreparedBatch<N> {
    /// Prepare every lane of `input` (its `xi` is not used) with the chosen kernel.
    pub fn prepare(isa: Isa, input: &LineProblems<N>) -> Self {
        dispatch(isa, Prepare(input))
    }

    /// `sampler` (prepared with the default iterations) in every lane, all lanes valid: what
    /// [`Self::prepare`] returns for N copies of its problem when it prepares, without
    /// preparing again. Lane i of [`Self::sample_projected_solid_angle`] then is
    /// `sampler.sample_with_pdf(xi[i])` bit for bit (the kernel runs the scalar sampler's code
    /// on these very fields).
    pub fn splat(sampler: &ProjectedSolidAngle) -> Self {
        debug_assert_eq!(sampler.iterations, DEFAULT_ITERATIONS);
        let li = Li2018::on_exact(*sampler);
        let mut out = Self::default();
        for i in 0..N {
            out.store(i, &li);
        }
        out.mask = pack([true; N]);
        out
    }

    /// One sample per lane for `xi` (projected solid angle, two Halley steps): lane i equals
    /// the scalar sampler's `sample_with_pdf(xi[i])`.
    pub fn sample_projected_solid_angle(&self, isa: Isa, xi: &[f32; N]) -> LineSamples<N> {
        dispatch(isa, SamplePrepared { prepared: self, xi })
    }

    /// One sample per lane for `xi` by Li et al. 2018, iterating until the slowest of the N
    /// lanes has converged (as on a GPU); also returns the number of iterations run.
    pub fn sample_li2018(&self, isa: Isa, xi: &[f32; N]) -> (LineSamples<N>, u32) {
        dispatch(isa, SampleLi { prepared: self, xi })
    }

    #[inline(always)]
    fn store(&mut self, i: usize, li: &Li2018) {
        let p = &li.exact;
        let f = &p.frame;
        set3(&mut self.u, i, f.u);
        set3(&mut self.c_hat, i, f.c_hat);
        set3(&mut self.n, i, p.n);
        (self.d[i], self.l_begin[i], self.l_end[i]) = (f.d, f.l_begin, f.l_end);
        (self.s_begin[i], self.s_end[i]) = (f.s_begin, f.s_end);
        let c = &p.core;
        (self.ns[i], self.nt[i], self.s_b[i], self.c_b[i]) = (c.ns, c.nt, c.s_b, c.c_b);
        (self.delta_s[i], self.width[i], self.p0[i], self.p1[i]) = (c.delta_s, c.width, c.p0, c.p1);
        (self.total[i], self.inv_psa[i], self.tolerance[i]) = (c.total, p.inv_psa, p.tolerance);
        (self.n_dot_c[i], self.n_dot_u[i]) = (li.n_dot_c, li.ns);
    }

    /// Lane i as the scalar sampler (fields read from the arrays, so the lane loop vectorises).
    #[inline(always)]
    fn psa(&self, i: usize) -> ProjectedSolidAngle {
        ProjectedSolidAngle {
            frame: LineFrame {
                u: get3(&self.u, i),
                c_hat: get3(&self.c_hat, i),
                d: self.d[i],
                l_begin: self.l_begin[i],
                l_end: self.l_end[i],
                s_begin: self.s_begin[i],
                s_end: self.s_end[i],
            },
            n: get3(&self.n, i),
            core: PsaCore {
                ns: self.ns[i],
                nt: self.nt[i],
                s_b: self.s_b[i],
                c_b: self.c_b[i],
                delta_s: self.delta_s[i],
                width: self.width[i],
                p0: self.p0[i],
                p1: self.p1[i],
                total: self.total[i],
            },
            inv_psa: self.inv_psa[i],
            tolerance: self.tolerance[i],
            iterations: DEFAULT_ITERATIONS,
        }
    }

    #[inline(always)]
    fn li(&self, i: usize) -> Li2018 {
        Li2018 {
            exact: self.psa(i),
            n_dot_c: self.n_dot_c[i],
            ns: self.n_dot_u[i],
            max_iterations: MAX_ITERATIONS,
            at_start: None,
        }
    }
}

#[inline(always)]
fn prepare_kernel<const N: usize>(input: &LineProblems<N>) -> PreparedBatch<N> {
    let mut out = PreparedBatch::default();
    let mut valid = [false; N];
    #[allow(clippy::needless_range_loop)] // lane i of every array: the loop that vectorises
    for i in 0..N {
        // The normal as given, not normalised (see `ProjectedSolidAngle::lane`).
        let n = get3(&input.n, i);
        let normal_ok = normal_is_valid(n);
        let (frame, ends, frame_ok) = LineFrame::lane(
            get3(&input.begin, i),
            get3(&input.end, i),
            get3(&input.x, i),
            Some(n),
        );
        let (li, ok) = Li2018::lane(frame, ends, n);
        out.store(i, &li);
        valid[i] = normal_ok && frame_ok && ok;
    }
    out.mask = pack(valid);
    out
}

#[inline(always)]
fn psa_sample_kernel<const N: usize>(prepared: &PreparedBatch<N>, xi: &[f32; N]) -> LineSamples<N> {
    let mut pending = Pending::default();
    #[allow(clippy::needless_range_loop)]
    for i in 0..N {
        pending.set(i, &prepared.psa(i), xi[i], prepared.mask & (1 << i) != 0);
    }
    pending.finish()
}

/// The samples of a batch before their directions: the lane loop is split where a lane may need
/// a fresh sin/cos of its sample (`PsaCore::solve_rotated_lane`: in the ξ guard or after a long
/// last step, rare), which is then evaluated only if some lane of the batch needs it, instead of
/// in every lane (a sin/cos on the lane's dependency chain). Bitwise what
/// the scalar [`LineSampler::sample_with_pdf`] returns. The f32 arrays first, from a cache
/// line's start: 16 lanes are one register, which a misaligned store or load would split.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Pending<const N: usize> {
    /// sin φ, cos φ, n·ω at the sample (rotated by the last step).
    s: [f32; N],
    t: [f32; N],
    n_dot_w: [f32; N],
    /// τ to evaluate afresh where `fresh`.
    tau: [f32; N],
    // What `PsaCore::at` and the direction need.
    s_b: [f32; N],
    c_b: [f32; N],
    p0: [f32; N],
    p1: [f32; N],
    u: Vec3xN<N>,
    c_hat: Vec3xN<N>,
    d: [f32; N],
    inv_psa: [f32; N],
    fresh: [bool; N],
    ok: [bool; N],
}

// Every f32 array of a 16-lane `Pending` starts on a cache line (a field of another size, as
// the bools, goes after them).
const _: () = {
    use std::mem::offset_of;
    type P = Pending<PACKET_LANES>;
    let arrays = [
        offset_of!(P, s),
        offset_of!(P, t),
        offset_of!(P, n_dot_w),
        offset_of!(P, tau),
        offset_of!(P, s_b),
        offset_of!(P, c_b),
        offset_of!(P, p0),
        offset_of!(P, p1),
        offset_of!(P, u),
        offset_of!(P, c_hat),
        offset_of!(P, d),
        offset_of!(P, inv_psa),
    ];
    let mut i = 0;
    while i < arrays.len() {
        assert!(
            arrays[i] % 64 == 0,
            "a lane array of `Pending` off a cache line"
        );
        i += 1;
    }
};

impl<const N: usize> Default for Pending<N> {
    fn default() -> Self {
        let zero = [0.0; N];
        Self {
            s: zero,
            t: zero,
            n_dot_w: zero,
            tau: zero,
            fresh: [false; N],
            s_b: zero,
            c_b: zero,
            p0: zero,
            p1: zero,
            u: zero3(),
            c_hat: zero3(),
            d: zero,
            inv_psa: zero,
            ok: [false; N],
        }
    }
}

impl<const N: usize> Pending<N> {
    #[inline(always)]
    fn set(&mut self, i: usize, p: &ProjectedSolidAngle, xi: f32, ok: bool) {
        let ((s, t, n_dot_w), tau, fresh) =
            p.sample_rotated_lane(clamp_xi(xi), atan2_coarse_select);
        (self.s[i], self.t[i], self.n_dot_w[i]) = (s, t, n_dot_w);
        (self.tau[i], self.fresh[i], self.ok[i]) = (tau, fresh, ok);
        let c = &p.core;
        (self.s_b[i], self.c_b[i], self.p0[i], self.p1[i]) = (c.s_b, c.c_b, c.p0, c.p1);
        set3(&mut self.u, i, p.frame.u);
        set3(&mut self.c_hat, i, p.frame.c_hat);
        (self.d[i], self.inv_psa[i]) = (p.frame.d, p.inv_psa);
    }

    #[inline(always)]
    fn finish(mut self) -> LineSamples<N> {
        if self.fresh.contains(&true) {
            #[allow(clippy::needless_range_loop)]
            for i in 0..N {
                // `at` reads the begin's (sin, cos) and p0, p1 only.
                let core = PsaCore {
                    ns: 0.0,
                    nt: 0.0,
                    s_b: self.s_b[i],
                    c_b: self.c_b[i],
                    delta_s: 0.0,
                    width: 0.0,
                    p0: self.p0[i],
                    p1: self.p1[i],
                    total: 0.0,
                };
                let (s, t, n_dot_w) = core.at(self.tau[i]);
                if self.fresh[i] {
                    (self.s[i], self.t[i], self.n_dot_w[i]) = (s, t, n_dot_w);
                }
            }
        }
        let mut out = LineSamples::default();
        let mut valid = [false; N];
        #[allow(clippy::needless_range_loop)]
        for i in 0..N {
            let (u, c_hat) = (get3(&self.u, i), get3(&self.c_hat, i));
            let values = (self.s[i], self.t[i], self.n_dot_w[i]);
            let (dir, pdf) = direction_and_density(u, c_hat, self.inv_psa[i], values);
            let distance = self.d[i] / c_hat.dot(dir);
            valid[i] = store(&mut out, i, (dir, pdf, distance, self.ok[i]));
        }
        out.mask = pack(valid);
        out
    }
}

#[inline(always)]
fn li_sample_kernel<const N: usize>(
    prepared: &PreparedBatch<N>,
    xi: &[f32; N],
) -> (LineSamples<N>, u32) {
    // The iteration state as structure of arrays (so that the step loop vectorises).
    let (mut l, mut lo, mut hi, mut done) = ([0.0f32; N], [0.0; N], [0.0; N], [0u32; N]);
    let mut xs = [0.0f32; N];
    for i in 0..N {
        let s = prepared.li(i).start_state();
        (l[i], lo[i], hi[i]) = (s.l, s.lo, s.hi);
        // Lanes without a contribution start converged (inactive, as threads of a GPU warp).
        done[i] = (prepared.mask & (1 << i) == 0) as u32;
        xs[i] = clamp_xi(xi[i]);
    }
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS && done.contains(&0) {
        for i in 0..N {
            let state = LiState {
                l: l[i],
                lo: lo[i],
                hi: hi[i],
                done: done[i] != 0,
            };
            let next = prepared.li(i).step(state, xs[i], atan2_f64_select);
            (l[i], lo[i], hi[i], done[i]) = (next.l, next.lo, next.hi, next.done as u32);
        }
        iterations += 1;
    }
    let state: [LiState; N] = std::array::from_fn(|i| LiState {
        l: l[i],
        ..LiState::default()
    });
    let mut out = LineSamples::default();
    let mut valid = [false; N];
    #[allow(clippy::needless_range_loop)]
    for i in 0..N {
        let li = prepared.li(i);
        let (dir, pdf) = li.finish(state[i].l);
        let f = li.support();
        let ok = prepared.mask & (1 << i) != 0;
        valid[i] = store(&mut out, i, (dir, pdf, f.d / f.c_hat.dot(dir), ok));
    }
    out.mask = pack(valid);
    (out, iterations)
}

/// Li et al. 2018 (technique 7) on every lane of `input` (prepare and one sample; N = [`BATCH_LANES`]
/// for a batch, [`PACKET_LANES`] for a renderer's packet), as on a GPU: the Newton–bisection
/// iteration runs until the *last* of the N lanes has converged (at most 20 steps), every lane
/// paying for the slowest. Lane i equals the scalar `Technique::Li2018` bit for bit. Returns
/// the outputs and the number of iterations run.
pub fn sample_li2018_with<const N: usize>(
    isa: Isa,
    input: &LineProblems<N>,
) -> (LineSamples<N>, u32) {
    PreparedBatch::prepare(isa, input).sample_li2018(isa, &input.xi)
}

/// Clipped solid angle sampling (technique 4) on every lane of `input` (prepare and one sample)
/// with the chosen kernel (the baseline where the CPU does not run it): lane i equals the scalar
/// `Technique::ClippedSolidAngle.prepare(..)` + `sample_with_pdf(xi)` bit for bit, its
/// `distance` is d/(ĉ·ω) as for the other kernels.
pub fn sample_clipped_solid_angle_with(isa: Isa, input: &BatchProblems) -> BatchSamples {
    dispatch(isa, ClippedSample::<BATCH_LANES, true>(input))
}

/// Clipped solid angle sampling on the [`PACKET_LANES`] lanes of `input` with the chosen kernel
/// (the baseline where the CPU does not run it), as two interleaved eight-lane chains (lanes
/// i and i + 8 in one loop) on every ISA: lane i equals the scalar technique bit for bit, as
/// the lanes of [`sample_clipped_solid_angle_with`] do. Unlike projected solid angle, one loop
/// over all sixteen lanes does not pay with AVX-512: clipped solid angle's work is nearly all
/// f64 (the arcs), which the compiler vectorises eight lanes at a time either way.
pub fn sample_clipped_solid_angle_packet(
    isa: Isa,
    input: &LineProblems<PACKET_LANES>,
) -> LineSamples<PACKET_LANES> {
    dispatch(isa, ClippedSample::<PACKET_LANES, false>(input))
}

/// N prepared clipped-solid-angle samplers (a batch: [`BATCH_LANES`] = 8 by default; a packet:
/// [`PACKET_LANES`]) as structure of arrays: what `SolidAngle` keeps per (light, shading point)
/// for its samples — the frame's u, ĉ, d, the arc of the clipped interval in f64 ([`FrameArc`]
/// without its support tolerance, which sampling does not read) and 1/Ω_R. Lanes outside `mask`
/// hold meaningless values. The sample kernel is one loop over the N lanes (its arcs are f64:
/// eight lanes per zmm whatever N is).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))] // 16-lane arrays then fill whole cache lines (see `Pending`)
pub struct ClippedBatch<const N: usize = BATCH_LANES> {
    u: Vec3xN<N>,
    c_hat: Vec3xN<N>,
    d: [f32; N],
    s_b: [f64; N],
    c_b: [f64; N],
    width: [f64; N],
    delta_s: [f64; N],
    inv_solid_angle: [f32; N],
    /// Bit i set: lane i contributes (N ≤ 32).
    pub mask: u32,
}

impl<const N: usize> Default for ClippedBatch<N> {
    fn default() -> Self {
        Self {
            u: zero3(),
            c_hat: zero3(),
            d: [0.0; N],
            s_b: [0.0; N],
            c_b: [0.0; N],
            width: [0.0; N],
            delta_s: [0.0; N],
            inv_solid_angle: [0.0; N],
            mask: 0,
        }
    }
}

impl<const N: usize> ClippedBatch<N> {
    /// Prepare every lane of `input` (its `xi` is not used) with the chosen kernel.
    pub fn prepare(isa: Isa, input: &LineProblems<N>) -> Self {
        dispatch(isa, ClippedPrepare(input))
    }

    /// One sample per lane for `xi`: lane i equals the scalar sampler's `sample_with_pdf(xi[i])`.
    pub fn sample(&self, isa: Isa, xi: &[f32; N]) -> LineSamples<N> {
        dispatch(isa, ClippedSamplePrepared { prepared: self, xi })
    }

    #[inline(always)]
    fn store(&mut self, i: usize, sampler: &SolidAngle) {
        let (frame, arc, inv_solid_angle) = (&sampler.frame, &sampler.arc, sampler.inv_solid_angle);
        set3(&mut self.u, i, frame.u);
        set3(&mut self.c_hat, i, frame.c_hat);
        (self.d[i], self.inv_solid_angle[i]) = (frame.d, inv_solid_angle);
        (self.s_b[i], self.c_b[i]) = (arc.s_b, arc.c_b);
        (self.width[i], self.delta_s[i]) = (arc.width, arc.delta_s);
    }

    /// Lane i as the scalar sampler, with the fields sampling reads (the rest zero).
    #[inline(always)]
    fn sampler(&self, i: usize) -> SolidAngle {
        let frame = LineFrame {
            u: get3(&self.u, i),
            c_hat: get3(&self.c_hat, i),
            d: self.d[i],
            l_begin: 0.0,
            l_end: 0.0,
            s_begin: 0.0,
            s_end: 0.0,
        };
        let arc = FrameArc {
            s_b: self.s_b[i],
            c_b: self.c_b[i],
            width: self.width[i],
            delta_s: self.delta_s[i],
            tolerance: 0.0,
        };
        SolidAngle {
            frame,
            arc,
            inv_solid_angle: self.inv_solid_angle[i],
        }
    }
}

#[inline(always)]
fn clipped_prepare_kernel<const N: usize>(input: &LineProblems<N>) -> ClippedBatch<N> {
    let mut out = ClippedBatch::default();
    let mut valid = [false; N];
    #[allow(clippy::needless_range_loop)] // lane i of every array: the loop that vectorises
    for i in 0..N {
        let (sampler, ok) = clipped_lane(input, i);
        out.store(i, &sampler);
        valid[i] = ok;
    }
    out.mask = pack(valid);
    out
}

/// Lane i's clipped solid angle sampler (meaningless where the lane does not contribute) and
/// whether it contributes.
#[inline(always)]
fn clipped_lane<const N: usize>(input: &LineProblems<N>, i: usize) -> (SolidAngle, bool) {
    // Clipped with the unit normal, as the scalar `SolidAngle::prepare_clipped`.
    let (n, normal_ok) = unit_normal_lane(get3(&input.n, i));
    let (frame, ends, frame_ok) = LineFrame::lane(
        get3(&input.begin, i),
        get3(&input.end, i),
        get3(&input.x, i),
        Some(n),
    );
    let (sampler, ok) = SolidAngle::lane(frame, ends, atan2_f64_select);
    (sampler, normal_ok && frame_ok && ok)
}

/// Lane i of clipped solid angle, prepared and sampled, into `out`; returns whether it
/// contributes.
#[inline(always)]
fn clipped_sample_lane<const N: usize>(
    input: &LineProblems<N>,
    i: usize,
    out: &mut LineSamples<N>,
) -> bool {
    let (sampler, ok) = clipped_lane(input, i);
    let (dir, pdf) = sampler.sample_lane(input.xi[i], atan2_f64_select);
    let distance = sampler.frame.d / sampler.frame.c_hat.dot(dir);
    store(out, i, (dir, pdf, distance, ok))
}

/// Clipped solid angle on the lanes of `input` as two interleaved chains, lanes i and i + N/2
/// (see [`two_chains`]).
#[inline(always)]
fn clipped_two_chains<const N: usize>(input: &LineProblems<N>) -> LineSamples<N> {
    let mut out = LineSamples::default();
    let mut valid = [false; N];
    for i in 0..N / 2 {
        valid[i] = clipped_sample_lane(input, i, &mut out);
        valid[i + N / 2] = clipped_sample_lane(input, i + N / 2, &mut out);
    }
    out.mask = pack(valid);
    out
}

#[inline(always)]
fn clipped_sample_kernel<const N: usize>(
    prepared: &ClippedBatch<N>,
    xi: &[f32; N],
) -> LineSamples<N> {
    let mut out = LineSamples::default();
    let mut valid = [false; N];
    #[allow(clippy::needless_range_loop)]
    for i in 0..N {
        let (dir, pdf) = prepared.sampler(i).sample_lane(xi[i], atan2_f64_select);
        let distance = prepared.d[i] / get3(&prepared.c_hat, i).dot(dir);
        let ok = prepared.mask & (1 << i) != 0;
        valid[i] = store(&mut out, i, (dir, pdf, distance, ok));
    }
    out.mask = pack(valid);
    out
}

#[inline(always)]
fn clipped_kernel<const N: usize>(input: &LineProblems<N>) -> LineSamples<N> {
    clipped_sample_kernel(&clipped_prepare_kernel(input), &input.xi)
}

/// The lanes of `input` as two interleaved chains: one loop over the lane pairs (i, i + N/2)
/// (two independent dependency chains per vector instruction stream).
#[inline(always)]
fn two_chains<const N: usize>(input: &LineProblems<N>) -> LineSamples<N> {
    const { assert!(N.is_multiple_of(2)) };
    let mut pending = Pending::default();
    for i in 0..N / 2 {
        lane(input, i, &mut pending);
        lane(input, i + N / 2, &mut pending);
    }
    pending.finish()
}

/// Write lane i's results (zeros where it does not contribute); returns whether it does.
#[inline(always)]
fn store<const N: usize>(
    out: &mut LineSamples<N>,
    i: usize,
    (dir, pdf, distance, ok): (Vec3, f32, f32, bool),
) -> bool {
    out.dir[0][i] = if ok { dir.x } else { 0.0 };
    out.dir[1][i] = if ok { dir.y } else { 0.0 };
    out.dir[2][i] = if ok { dir.z } else { 0.0 };
    out.pdf[i] = if ok { pdf } else { 0.0 };
    out.distance[i] = if ok { distance } else { 0.0 };
    ok
}

#[inline(always)]
fn pack<const N: usize>(valid: [bool; N]) -> u32 {
    const { assert!(N <= 32) };
    valid
        .iter()
        .enumerate()
        .fold(0u32, |m, (i, &v)| m | ((v as u32) << i))
}

/// One loop over the lanes of branch-free code (vectorised by the compiler).
#[inline(always)]
fn kernel<const N: usize>(input: &LineProblems<N>) -> LineSamples<N> {
    let mut pending = Pending::default();
    #[allow(clippy::needless_range_loop)] // lane i of every array: the loop that vectorises
    for i in 0..N {
        lane(input, i, &mut pending);
    }
    pending.finish()
}

/// Lane i up to its direction (every value computed, garbage where the lane does not
/// contribute), into `pending`.
#[inline(always)]
fn lane<const N: usize>(input: &LineProblems<N>, i: usize, pending: &mut Pending<N>) {
    // The normal as given, not normalised (see `ProjectedSolidAngle::lane`).
    let n = get3(&input.n, i);
    let normal_ok = normal_is_valid(n);
    let (frame, ends, frame_ok) = LineFrame::lane(
        get3(&input.begin, i),
        get3(&input.end, i),
        get3(&input.x, i),
        Some(n),
    );
    let (sampler, sampler_ok) =
        ProjectedSolidAngle::lane(frame, ends, n, DEFAULT_ITERATIONS, atan2_f64_select);
    pending.set(
        i,
        &sampler,
        input.xi[i],
        normal_ok && frame_ok && sampler_ok,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::{LineSampler, Segment, Technique};
    use linlight_simd::splat3;

    /// Random problems in the benchmark's box plus degenerate lanes of every kind.
    fn batches(count: usize) -> Vec<BatchProblems> {
        let mut rng = Pcg32::new(99, 4);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut out = Vec::new();
        for k in 0..count {
            let mut b = BatchProblems::default();
            for i in 0..BATCH_LANES {
                let scale = [1.0, 1e-3, 1e3, 1e-12, 1e12][(k + i) % 5];
                set3(
                    &mut b.begin,
                    i,
                    scale * Vec3::new(r(-2.0, 2.0), r(-2.0, 2.0), r(-0.5, 2.0)),
                );
                set3(
                    &mut b.end,
                    i,
                    scale * Vec3::new(r(-2.0, 2.0), r(-2.0, 2.0), r(-0.5, 2.0)),
                );
                set3(
                    &mut b.x,
                    i,
                    scale * Vec3::new(r(-0.1, 0.1), r(-0.1, 0.1), r(-0.01, 0.01)),
                );
                set3(
                    &mut b.n,
                    i,
                    Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-0.2, 1.0)),
                );
                // Every other batch with interior ξ only, so that (almost always) no lane needs
                // the fresh evaluation of `Pending::finish`; the others with ends, guard band
                // and invalid ξ in some lanes, so that it runs next to rotated lanes.
                b.xi[i] = if k % 2 == 1 {
                    r(0.0, 1.0)
                } else {
                    [r(0.0, 1.0), 0.0, 1.0, 3e-6, 1.0 - 3e-6, -1.0, f32::NAN][i % 7]
                };
            }
            out.push(b);
        }
        // Degenerate lanes: zero / NaN normal, zero-length segment, shading point on the line,
        // segment below the horizon, in the tangent plane, non-finite input, far along the axis.
        let mut d = out[0];
        set3(&mut d.n, 0, Vec3::ZERO);
        set3(&mut d.n, 1, Vec3::new(f32::NAN, 0.0, 1.0));
        set3(&mut d.end, 2, get3(&d.begin, 2));
        set3(&mut d.x, 3, 0.5 * (get3(&d.begin, 3) + get3(&d.end, 3)));
        set3(&mut d.begin, 4, Vec3::new(-1.0, 0.0, -1.0));
        set3(&mut d.end, 4, Vec3::new(1.0, 0.0, -1.0));
        set3(&mut d.x, 4, Vec3::ZERO);
        set3(&mut d.n, 4, Vec3::Z);
        set3(&mut d.begin, 5, Vec3::new(-1.0, 1.0, 0.0));
        set3(&mut d.end, 5, Vec3::new(1.0, 1.0, 0.0));
        set3(&mut d.x, 5, Vec3::ZERO);
        set3(&mut d.n, 5, Vec3::Z);
        set3(&mut d.begin, 6, Vec3::new(f32::INFINITY, 0.0, 1.0));
        set3(&mut d.begin, 7, Vec3::new(0.0, 1e-3, 1e4));
        set3(&mut d.end, 7, Vec3::new(0.0, 1e-3, 1e4 + 1.0));
        set3(&mut d.x, 7, Vec3::ZERO);
        set3(&mut d.n, 7, Vec3::Z);
        out.push(d);
        // Normals at the ends of `normal_is_valid`: infinite, too short (1e-25, rejected),
        // huge (1e38, valid: scaled by 2^-126 into [1, 2)), the shortest valid, subnormal ones.
        let mut e = out[1];
        set3(&mut e.n, 0, Vec3::new(0.0, f32::INFINITY, 1.0));
        set3(&mut e.n, 1, Vec3::new(1e-25, 0.0, 1e-25));
        set3(&mut e.n, 2, Vec3::new(0.3e38, -0.2e38, 1e38));
        set3(&mut e.n, 3, Vec3::splat(1e38));
        set3(&mut e.n, 4, Vec3::new(0.0, 0.0, 1.1e-20));
        set3(&mut e.n, 5, Vec3::new(f32::from_bits(3), 0.0, 2e-20));
        set3(
            &mut e.n,
            6,
            Vec3::new(f32::NEG_INFINITY, 0.0, f32::INFINITY),
        );
        out.push(e);
        out
    }

    /// The slice entry point (two batches as a packet, and an odd remainder) and the packet
    /// entry points (projected and clipped solid angle) give the same outputs as one batch at a
    /// time, on every ISA (projected solid angle: AVX-512's one loop over sixteen lanes, the
    /// others' two chains).
    #[test]
    fn slices_and_packets_equal_single_batches() {
        let inputs = batches(7);
        for isa in Isa::ALL.into_iter().filter(|isa| isa.supported()) {
            let mut outputs = vec![BatchSamples::default(); inputs.len()];
            sample_projected_solid_angle_slice(isa, &inputs, &mut outputs);
            for (input, out) in inputs.iter().zip(&outputs) {
                assert_eq!(
                    *out,
                    sample_projected_solid_angle_with(isa, input),
                    "{isa:?}"
                );
            }
            for pair in inputs.windows(2) {
                let packet = LineProblems::from_batches(&pair[0], &pair[1]);
                let out = sample_projected_solid_angle_packet(isa, &packet);
                let single = pair
                    .iter()
                    .map(|b| sample_projected_solid_angle_with(isa, b));
                for (h, single) in single.enumerate() {
                    assert_eq!(out.batch(h), single, "{isa:?} half {h}");
                }
                let clipped = sample_clipped_solid_angle_packet(isa, &packet);
                let single = pair.iter().map(|b| sample_clipped_solid_angle_with(isa, b));
                for (h, single) in single.enumerate() {
                    assert_eq!(clipped.batch(h), single, "clipped {isa:?} half {h}");
                }
            }
        }
    }

    /// The batches of [`batches`] joined pairwise into packets (every batch in both halves).
    fn packets(count: usize) -> Vec<LineProblems<PACKET_LANES>> {
        let b = batches(count);
        b.windows(2)
            .map(|pair| LineProblems::from_batches(&pair[0], &pair[1]))
            .collect()
    }

    /// Prepared once, sampled several times: the same as preparing and sampling together, for
    /// batches (against the 8-lane fused kernels) and packets (16-lane prepared batches against
    /// the renderer's packet kernels).
    #[test]
    fn prepared_batches_sample_like_the_fused_kernel() {
        for input in batches(300) {
            for isa in Isa::ALL.into_iter().filter(|isa| isa.supported()) {
                let prepared = PreparedBatch::prepare(isa, &input);
                let clipped = ClippedBatch::prepare(isa, &input);
                for k in 0..3 {
                    let xi: [f32; BATCH_LANES] =
                        std::array::from_fn(|i| input.xi[(i + k) % BATCH_LANES]);
                    let fused =
                        sample_projected_solid_angle_with(isa, &BatchProblems { xi, ..input });
                    assert_eq!(prepared.sample_projected_solid_angle(isa, &xi), fused);
                    let fused =
                        sample_clipped_solid_angle_with(isa, &BatchProblems { xi, ..input });
                    assert_eq!(clipped.sample(isa, &xi), fused);
                }
            }
        }
        for input in packets(150) {
            for isa in Isa::ALL.into_iter().filter(|isa| isa.supported()) {
                let prepared = PreparedBatch::prepare(isa, &input);
                let clipped = ClippedBatch::prepare(isa, &input);
                for k in 0..3 {
                    let xi: [f32; PACKET_LANES] =
                        std::array::from_fn(|i| input.xi[(i + 5 * k) % PACKET_LANES]);
                    let packet = LineProblems { xi, ..input };
                    let fused = sample_projected_solid_angle_packet(isa, &packet);
                    assert_eq!(
                        prepared.sample_projected_solid_angle(isa, &xi),
                        fused,
                        "{isa:?}"
                    );
                    let fused = sample_clipped_solid_angle_packet(isa, &packet);
                    assert_eq!(clipped.sample(isa, &xi), fused, "clipped {isa:?}");
                }
            }
        }
    }

    /// A scalar sampler splatted into every lane: the batch that preparing N copies of its
    /// problem gives, and lane i samples ξ_i as the scalar sampler, bit for bit.
    #[test]
    fn splatted_sampler_equals_the_prepared_batch_and_the_scalar_sampler() {
        let mut splatted = 0;
        for input in batches(300) {
            let (begin, end, x, n) = (
                get3(&input.begin, 0),
                get3(&input.end, 0),
                get3(&input.x, 0),
                get3(&input.n, 0),
            );
            let Some(psa) = ProjectedSolidAngle::prepare(&Segment::new(begin, end), x, n) else {
                continue;
            };
            splatted += 1;
            let batch = PreparedBatch::<BATCH_LANES>::splat(&psa);
            let copies = LineProblems::<BATCH_LANES> {
                begin: splat3(begin),
                end: splat3(end),
                x: splat3(x),
                n: splat3(n),
                xi: [0.0; BATCH_LANES],
            };
            for isa in Isa::ALL.into_iter().filter(|isa| isa.supported()) {
                assert_eq!(PreparedBatch::prepare(isa, &copies), batch, "{isa:?}");
                let out = batch.sample_projected_solid_angle(isa, &input.xi);
                for (i, &xi) in input.xi.iter().enumerate() {
                    let (dir, pdf) = psa.sample_with_pdf(xi);
                    assert_eq!(
                        (get3(&out.dir, i), out.pdf[i]),
                        (dir, pdf),
                        "{isa:?} lane {i}"
                    );
                }
            }
        }
        assert!(splatted > 200, "{splatted} of 300 problems prepared");
    }

    /// Li et al. on every lane equals the scalar technique bit for bit, and the batch runs as
    /// many iterations as its slowest contributing lane: eight lanes, and sixteen (a prepared
    /// packet).
    #[test]
    fn li2018_lanes_equal_the_scalar_technique() {
        li2018_lanes_equal(&batches(1500), sample_li2018_with);
        li2018_lanes_equal(&packets(600), sample_li2018_with);
    }

    fn li2018_lanes_equal<const N: usize>(
        inputs: &[LineProblems<N>],
        kernel: fn(Isa, &LineProblems<N>) -> (LineSamples<N>, u32),
    ) {
        let mut total = (0u64, 0u64);
        for input in inputs {
            for isa in Isa::ALL.into_iter().filter(|isa| isa.supported()) {
                let (out, iterations) = kernel(isa, input);
                let mut slowest = 0;
                for i in 0..N {
                    let seg = Segment::new(get3(&input.begin, i), get3(&input.end, i));
                    match Li2018::prepare(&seg, get3(&input.x, i), get3(&input.n, i)) {
                        Some(li) => {
                            assert!(out.contributes(i));
                            let (dir, pdf) = li.sample_with_pdf(input.xi[i]);
                            assert_eq!(
                                (get3(&out.dir, i).to_array(), out.pdf[i]),
                                (dir.to_array(), pdf),
                                "lane {i}"
                            );
                            let k = li.sample_l(input.xi[i]).1;
                            slowest = slowest.max((k + 1).min(MAX_ITERATIONS));
                            total.1 += (k + 1).min(MAX_ITERATIONS) as u64;
                        }
                        None => assert!(!out.contributes(i)),
                    }
                }
                assert_eq!(iterations, slowest);
                total.0 += (iterations * out.mask.count_ones()) as u64;
            }
        }
        // Lanes wait for the slowest: the batch pays more iterations than the lanes need.
        assert!(total.0 > total.1, "{total:?}");
    }

    /// Every lane equals the scalar technique bit for bit (direction, density, distance,
    /// mask), on every compiled variant this CPU can run, for projected solid angle and for
    /// clipped solid angle: the fused 8-lane kernels, the renderer's 16-lane packet kernels,
    /// and the 16-lane prepared batches (prepare, then one sample).
    #[test]
    fn lanes_equal_the_scalar_technique() {
        let kernels: [(Technique, Kernel<BATCH_LANES>); 2] = [
            (
                Technique::ProjectedSolidAngle,
                sample_projected_solid_angle_with,
            ),
            (
                Technique::ClippedSolidAngle,
                sample_clipped_solid_angle_with,
            ),
        ];
        let inputs = batches(3000);
        for (technique, kernel) in kernels {
            lanes_equal(technique, kernel, &inputs);
        }
        let wide: [(Technique, Kernel<PACKET_LANES>); 4] = [
            (
                Technique::ProjectedSolidAngle,
                sample_projected_solid_angle_packet,
            ),
            (Technique::ProjectedSolidAngle, |isa, input| {
                PreparedBatch::prepare(isa, input).sample_projected_solid_angle(isa, &input.xi)
            }),
            (
                Technique::ClippedSolidAngle,
                sample_clipped_solid_angle_packet,
            ),
            (Technique::ClippedSolidAngle, |isa, input| {
                ClippedBatch::prepare(isa, input).sample(isa, &input.xi)
            }),
        ];
        let inputs = packets(1500);
        for (technique, kernel) in wide {
            lanes_equal(technique, kernel, &inputs);
        }
    }

    /// A kernel of N lanes (prepare and one sample per lane).
    type Kernel<const N: usize> = fn(Isa, &LineProblems<N>) -> LineSamples<N>;

    fn lanes_equal<const N: usize>(
        technique: Technique,
        kernel: Kernel<N>,
        inputs: &[LineProblems<N>],
    ) {
        let mut valid = 0;
        let mut invalid = 0;
        for input in inputs {
            let outputs = Isa::ALL
                .into_iter()
                .filter(|isa| isa.supported())
                .map(|isa| (isa, kernel(isa, input)));
            for (isa, out) in outputs {
                for i in 0..N {
                    let seg = Segment::new(get3(&input.begin, i), get3(&input.end, i));
                    let scalar = technique.prepare(&seg, get3(&input.x, i), get3(&input.n, i));
                    match scalar {
                        Some(p) => {
                            valid += 1;
                            assert!(
                                out.contributes(i),
                                "{technique} {isa:?} lane {i} of {input:?}"
                            );
                            let (dir, pdf) = p.sample_with_pdf(input.xi[i]);
                            let got = get3(&out.dir, i);
                            assert_eq!(
                                (got.to_array().map(f32::to_bits), out.pdf[i].to_bits()),
                                (dir.to_array().map(f32::to_bits), pdf.to_bits()),
                                "{technique} {isa:?} lane {i}: {got:?} {} vs {dir:?} {pdf}",
                                out.pdf[i]
                            );
                            let f = p.support();
                            assert_eq!(
                                out.distance[i].to_bits(),
                                (f.d / f.c_hat.dot(dir)).to_bits()
                            );
                        }
                        None => {
                            invalid += 1;
                            assert!(
                                !out.contributes(i),
                                "{technique} {isa:?} lane {i} of {input:?}"
                            );
                            assert_eq!((get3(&out.dir, i), out.pdf[i]), (Vec3::ZERO, 0.0));
                        }
                    }
                }
            }
        }
        assert!(
            valid > 10_000 && invalid > 1_000,
            "{technique}: {valid} {invalid}"
        );
    }
}
