//! Sampler cost as the paper reports it (its timing table): shading of the cached hit points of
//! a 1920×1080 frame by linear lights, Lambert + GGX evaluated, no shadow rays, for every
//! technique (the baseline included) in two configurations — 128 lights × 1 sample per pixel,
//! and 1 light × 128 samples per pixel — and for the 8-wide batches of projected solid angle,
//! Li et al. 2018 and clipped solid angle (lanes = 8 lights, or 8 samples of one light; Li
//! iterating until the slowest lane converges, as a GPU warp does), and for their 16-lane
//! packets, the renderer's form (lanes = 16 hit points, one light; [`shade_packet`]).
//!
//! Scene (procedural, the paper's "roughness planes"): a floor z = 0 and a back wall y = 6 seen
//! by a pinhole camera, GGX roughness α in ten stripes from 0.05 to 1 across the image, a
//! gentle procedural bump on the normals, 128 lights (segments of length 0.5–2) above the floor.
//! Shading per sample: f = ρ/π + F·D·G1(v)G1(l)/(4 n·v n·l) (Schlick F, F0 = 0.04; D and G1 of
//! `linlight_brdf::microfacet`), L += K·f·(n·ω)/p(ω).
//!
//! [`measure`] times every row on every `stride`-th pixel of every `stride`-th row, `repeats`
//! times interleaved across the rows (timings on a shared machine are noisy: only rows of one
//! run are compared), and reports per sample, per extrapolated full frame, and as ratios to
//! clipped solid angle (scalar; [`ConfigTiming::ratio`] compares any two rows, e.g. the x8
//! batches like for like). Both the shading benchmark (`cargo bench -p linlight --bench
//! shading`) and `linlight figures` (the timings table) call it.

use glam::Vec3;
use linlight_brdf::microfacet;
use linlight_render::light::Light;
use linlight_sampling::batch::{
    sample_clipped_solid_angle_packet, sample_li2018_with, sample_projected_solid_angle_packet,
    BatchProblems, BatchSamples, ClippedBatch, Isa, LineProblems, LineSamples, PreparedBatch,
    BATCH_LANES, PACKET_LANES,
};
use linlight_sampling::{LineSampler, Segment, Technique};
use linlight_simd::{get3, set3, splat3};
use std::hint::black_box;
use std::time::Instant;

/// Frame of the cached hit points.
pub const WIDTH: usize = 1920;
pub const HEIGHT: usize = 1080;
/// Lights of the 128 × 1 configuration.
pub const LIGHTS: usize = 128;
/// Samples per pixel of the 1 × 128 configuration.
pub const SPP: usize = 128;

/// Cached hit points (structure of arrays).
pub struct HitPoints {
    pub p: Vec<Vec3>,
    pub n: Vec<Vec3>,
    /// Unit direction to the camera.
    pub v: Vec<Vec3>,
    pub alpha: Vec<f32>,
}

/// Every `stride`-th pixel of every `stride`-th row of the 1920×1080 frame.
pub fn hit_points(stride: usize) -> HitPoints {
    let eye = Vec3::new(0.0, -4.0, 2.5);
    let forward = (Vec3::new(0.0, 2.0, 0.3) - eye).normalize();
    let right = forward.cross(Vec3::Z).normalize();
    let up = right.cross(forward);
    let tan_half = (30f32).to_radians().tan();
    let aspect = WIDTH as f32 / HEIGHT as f32;
    let mut h = HitPoints {
        p: Vec::new(),
        n: Vec::new(),
        v: Vec::new(),
        alpha: Vec::new(),
    };
    for y in (0..HEIGHT).step_by(stride) {
        for x in (0..WIDTH).step_by(stride) {
            let sx = (2.0 * (x as f32 + 0.5) / WIDTH as f32 - 1.0) * tan_half * aspect;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / HEIGHT as f32) * tan_half;
            let d = (forward + sx * right + sy * up).normalize();
            // Floor z = 0 or back wall y = 6, whichever is hit first.
            let t_floor = if d.z < 0.0 {
                -eye.z / d.z
            } else {
                f32::INFINITY
            };
            let t_wall = (6.0 - eye.y) / d.y;
            let (t, n0) = if t_floor < t_wall {
                (t_floor, Vec3::Z)
            } else {
                (t_wall, Vec3::NEG_Y)
            };
            let p = eye + t * d;
            let bump = 0.08 * Vec3::new((3.0 * p.x).sin(), (3.0 * p.y).cos(), (2.0 * p.z).sin());
            h.p.push(p);
            h.n.push((n0 + bump - bump.dot(n0) * n0).normalize());
            h.v.push(-d);
            h.alpha.push(0.05 + 0.95 * ((x * 10 / WIDTH) as f32 / 9.0));
        }
    }
    h
}

/// 128 lights above the floor, with K = radiance × radius.
pub fn lights() -> Vec<Light> {
    let mut rng = linlight_sampling::rng::Pcg32::new(128, 1);
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    (0..LIGHTS)
        .map(|_| {
            let c = Vec3::new(r(-4.0, 4.0), r(-1.0, 5.5), r(0.3, 3.0));
            let axis = Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-0.3, 0.3)).normalize();
            let half = 0.5 * r(0.5, 2.0) * axis;
            Light::new(
                Segment::new(c - half, c + half),
                Vec3::new(r(0.5, 1.0), r(0.5, 1.0), r(0.5, 1.0)),
            )
        })
        .collect()
}

/// A primary sample from (pixel, light, sample): a counter hash, the same for every technique.
#[inline(always)]
fn xi(pixel: usize, light: usize, sample: usize) -> f32 {
    let mut h = (pixel as u32).wrapping_mul(0x9E37_79B9)
        ^ (light as u32).wrapping_mul(0x85EB_CA6B)
        ^ (sample as u32).wrapping_mul(0xC2B2_AE35);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7FEB_352D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846C_A68B);
    h ^= h >> 16;
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Lambert (ρ = 0.5) + GGX (F0 = 0.04) with the cosine: f(v, l)·(n·l).
#[inline(always)]
fn brdf_cos(n: Vec3, v: Vec3, l: Vec3, alpha: f32) -> f32 {
    let (nv, nl) = (n.dot(v), n.dot(l));
    let h = (v + l).normalize_or_zero();
    let (nh, vh, lh) = (n.dot(h), v.dot(h), l.dot(h));
    let sin2 = |c: f32| (1.0 - c * c).max(0.0);
    let d = microfacet::d(alpha, sin2(nh), nh);
    let g = microfacet::g1(alpha, sin2(nv), nv, vh) * microfacet::g1(alpha, sin2(nl), nl, lh);
    let m = 1.0 - vh.max(0.0);
    let f = 0.04 + 0.96 * (m * m) * (m * m) * m;
    let spec = f * d * g / (4.0 * nv.max(1e-6));
    if nl > 0.0 && nv > 0.0 {
        0.5 * std::f32::consts::FRAC_1_PI * nl + spec
    } else {
        0.0
    }
}

/// Scalar shading of every hit point: `lights` lights × `spp` samples each.
#[inline(never)]
pub fn shade_scalar(t: Technique, h: &HitPoints, lights: &[Light], spp: usize) -> f32 {
    let mut sum = 0.0f32;
    for i in 0..h.p.len() {
        let (p, n, v, a) = (h.p[i], h.n[i], h.v[i], h.alpha[i]);
        let mut radiance = 0.0f32;
        for (j, Light { segment, k }) in lights.iter().enumerate() {
            // By reference, as the renderer does (see `Technique::prepare`).
            let prepared = t.prepare(segment, p, n);
            let Some(sampler) = &prepared else {
                continue;
            };
            for s in 0..spp {
                let (w, pdf) = sampler.sample_with_pdf(xi(i, j, s));
                if pdf > 0.0 {
                    radiance += k.x * brdf_cos(n, v, w, a) / pdf;
                }
            }
        }
        sum += radiance;
    }
    sum
}

/// The batch's shading: lane i's BRDF, in one loop over the lanes (vectorised with the
/// kernel's ISA only where the compiler does so; here at the baseline).
#[inline(always)]
fn shade_lanes(out: &BatchSamples, n: Vec3, v: Vec3, alpha: f32, k: &[f32; BATCH_LANES]) -> f32 {
    let mut c = [0.0f32; BATCH_LANES];
    for (i, c) in c.iter_mut().enumerate() {
        let w = get3(&out.dir, i);
        let f = brdf_cos(n, v, w, alpha);
        *c = if out.pdf[i] > 0.0 {
            k[i] * f / out.pdf[i]
        } else {
            0.0
        };
    }
    c.iter().sum()
}

/// The 8-wide batched samplers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Batched {
    ProjectedSolidAngle,
    Li2018,
    ClippedSolidAngle,
}

impl Batched {
    /// Every batched sampler, in the order of the benchmark's rows.
    pub const ALL: [Batched; 3] = [
        Batched::ProjectedSolidAngle,
        Batched::Li2018,
        Batched::ClippedSolidAngle,
    ];

    /// The technique whose lanes it samples (bit for bit) and whose name its rows carry.
    pub fn technique(self) -> Technique {
        match self {
            Batched::ProjectedSolidAngle => Technique::ProjectedSolidAngle,
            Batched::Li2018 => Technique::Li2018,
            Batched::ClippedSolidAngle => Technique::ClippedSolidAngle,
        }
    }
}

/// Batched shading. 128 lights × 1 spp: lanes = 8 lights of a hit point, prepared and sampled
/// once. 1 light × 128 spp: lanes = 8 samples of the one light, prepared once per hit point
/// (every lane the same), sampled 16 times. Returns the sum and Li's iteration count.
#[inline(never)]
pub fn shade_batched(
    which: Batched,
    isa: Isa,
    h: &HitPoints,
    lights: &[Light],
    spp: usize,
) -> (f32, u64) {
    shade_prepared_lanes(which, isa, &BatchRows(Work { h, lights, spp }))
}

/// The hit points and lights a row shades, `spp` samples per (hit point, light).
#[derive(Clone, Copy)]
struct Work<'a> {
    h: &'a HitPoints,
    lights: &'a [Light],
    spp: usize,
}

/// A shading loop over prepared lanes of N (one instance per kind of prepared lanes `Q`, so
/// that no per-batch dispatch or copy of the prepared state is timed): `prepare` a lane input,
/// skip it where `mask` is 0, `sample` it and shade the samples. Returns the sum.
trait PreparedRows<const N: usize> {
    fn shade<Q>(
        &self,
        prepare: impl Fn(&LineProblems<N>) -> Q,
        mask: impl Fn(&Q) -> u32,
        sample: impl FnMut(&Q, &[f32; N]) -> LineSamples<N>,
    ) -> f32;
}

/// [`shade_batched`]'s loop ([`shade_prepared`]).
struct BatchRows<'a>(Work<'a>);

/// [`shade_packet`]'s loop for more than one sample ([`shade_packets_prepared`]).
struct PacketRows<'a>(Work<'a>);

impl PreparedRows<BATCH_LANES> for BatchRows<'_> {
    #[inline(always)]
    fn shade<Q>(
        &self,
        prepare: impl Fn(&BatchProblems) -> Q,
        mask: impl Fn(&Q) -> u32,
        sample: impl FnMut(&Q, &[f32; BATCH_LANES]) -> BatchSamples,
    ) -> f32 {
        shade_prepared(self.0, prepare, mask, sample)
    }
}

impl PreparedRows<P> for PacketRows<'_> {
    #[inline(always)]
    fn shade<Q>(
        &self,
        prepare: impl Fn(&LineProblems<P>) -> Q,
        mask: impl Fn(&Q) -> u32,
        sample: impl FnMut(&Q, &[f32; P]) -> LineSamples<P>,
    ) -> f32 {
        shade_packets_prepared(self.0, prepare, mask, sample)
    }
}

/// `rows` with the prepared lanes of `which` (Li et al. iterating until the slowest lane has
/// converged). Returns the sum and Li's iteration count.
#[inline(always)]
fn shade_prepared_lanes<const N: usize>(
    which: Batched,
    isa: Isa,
    rows: &impl PreparedRows<N>,
) -> (f32, u64) {
    let mut iterations = 0u64;
    let psa = |input: &LineProblems<N>| PreparedBatch::prepare(isa, input);
    let sum = match which {
        Batched::ProjectedSolidAngle => rows.shade(
            psa,
            |p| p.mask,
            |p, xi| p.sample_projected_solid_angle(isa, xi),
        ),
        Batched::Li2018 => rows.shade(
            psa,
            |p| p.mask,
            |p, xi| {
                let (out, k) = p.sample_li2018(isa, xi);
                iterations += k as u64;
                out
            },
        ),
        Batched::ClippedSolidAngle => rows.shade(
            |input| ClippedBatch::prepare(isa, input),
            |p| p.mask,
            |p, xi| p.sample(isa, xi),
        ),
    };
    (sum, iterations)
}

/// Lanes of a packet.
const P: usize = PACKET_LANES;

/// Packet shading, the renderer's form: lanes = [`PACKET_LANES`] consecutive hit points (the
/// last packet padded with lanes of zero normal, which do not contribute), one light for all
/// lanes. 128 lights × 1 spp: every (packet, light) is one fused prepare + sample, as the
/// renderer's `sample_projected_solid_angle_packet` / `sample_clipped_solid_angle_packet` (Li et
/// al.: a 16-lane prepared batch and one sample, `sample_li2018_with`, as the renderer).
/// 1 light × 128 spp: one 16-lane prepared batch per packet ([`PreparedBatch`] /
/// [`ClippedBatch`] with 16 lanes), sampled 128 times. Returns the sum and Li's iteration count.
#[inline(never)]
pub fn shade_packet(
    which: Batched,
    isa: Isa,
    h: &HitPoints,
    lights: &[Light],
    spp: usize,
) -> (f32, u64) {
    if spp != 1 {
        return shade_prepared_lanes(which, isa, &PacketRows(Work { h, lights, spp }));
    }
    let mut iterations = 0u64;
    let sum = match which {
        Batched::ProjectedSolidAngle => shade_packets_fused(h, lights, |input| {
            sample_projected_solid_angle_packet(isa, input)
        }),
        Batched::ClippedSolidAngle => shade_packets_fused(h, lights, |input| {
            sample_clipped_solid_angle_packet(isa, input)
        }),
        Batched::Li2018 => shade_packets_fused(h, lights, |input| {
            let (out, k) = sample_li2018_with(isa, input);
            iterations += k as u64;
            out
        }),
    };
    (sum, iterations)
}

/// The packet's shading: lane l is hit point `first + l` (clamped; padding lanes have pdf 0),
/// all lanes lit by one light of radiance `k`.
#[inline(always)]
fn shade_packet_lanes(out: &LineSamples<P>, h: &HitPoints, first: usize, k: f32) -> f32 {
    let last = h.p.len() - 1;
    let mut c = [0.0f32; P];
    for (l, c) in c.iter_mut().enumerate() {
        let i = (first + l).min(last);
        let f = brdf_cos(h.n[i], h.v[i], get3(&out.dir, l), h.alpha[i]);
        *c = if out.pdf[l] > 0.0 {
            k * f / out.pdf[l]
        } else {
            0.0
        };
    }
    c.iter().sum()
}

/// The input of the packet of hit points `first..`: shading points and normals (zero normals in
/// padding lanes past the last hit point, so that they do not contribute).
#[inline(always)]
fn packet_input(h: &HitPoints, first: usize) -> LineProblems<P> {
    let mut input = LineProblems::default();
    let last = h.p.len() - 1;
    for l in 0..P {
        let i = (first + l).min(last);
        set3(&mut input.x, l, h.p[i]);
        set3(
            &mut input.n,
            l,
            if first + l <= last {
                h.n[i]
            } else {
                Vec3::ZERO
            },
        );
    }
    input
}

/// [`shade_packet`] with one fused prepare + sample per (packet, light).
#[inline(always)]
fn shade_packets_fused(
    h: &HitPoints,
    lights: &[Light],
    mut sample: impl FnMut(&LineProblems<P>) -> LineSamples<P>,
) -> f32 {
    let mut sum = 0.0f32;
    for first in (0..h.p.len()).step_by(P) {
        let mut input = packet_input(h, first);
        for (
            j,
            Light {
                segment,
                k: radiance,
            },
        ) in lights.iter().enumerate()
        {
            input.begin = splat3(segment.begin);
            input.end = splat3(segment.end);
            input.xi = std::array::from_fn(|l| xi(first + l, j, 0));
            let out = sample(&input);
            if out.mask != 0 {
                sum += shade_packet_lanes(&out, h, first, radiance.x);
            }
        }
    }
    sum
}

/// [`shade_packet`] with one prepared packet per (packet, light) and `spp` samples of it.
#[inline(always)]
fn shade_packets_prepared<Q>(
    Work { h, lights, spp }: Work,
    prepare: impl Fn(&LineProblems<P>) -> Q,
    mask: impl Fn(&Q) -> u32,
    mut sample: impl FnMut(&Q, &[f32; P]) -> LineSamples<P>,
) -> f32 {
    let mut sum = 0.0f32;
    for first in (0..h.p.len()).step_by(P) {
        let mut input = packet_input(h, first);
        for (
            j,
            Light {
                segment,
                k: radiance,
            },
        ) in lights.iter().enumerate()
        {
            input.begin = splat3(segment.begin);
            input.end = splat3(segment.end);
            let prepared = prepare(&input);
            if mask(&prepared) == 0 {
                continue;
            }
            for s in 0..spp {
                let xi: [f32; P] = std::array::from_fn(|l| xi(first + l, j, s));
                sum += shade_packet_lanes(&sample(&prepared, &xi), h, first, radiance.x);
            }
        }
    }
    sum
}

/// [`shade_batched`]'s loop for one kind of prepared batch `Q` ([`PreparedRows`]).
#[inline(always)]
fn shade_prepared<Q>(
    Work { h, lights, spp }: Work,
    prepare: impl Fn(&BatchProblems) -> Q,
    mask: impl Fn(&Q) -> u32,
    mut sample: impl FnMut(&Q, &[f32; BATCH_LANES]) -> BatchSamples,
) -> f32 {
    let mut sum = 0.0f32;
    for i in 0..h.p.len() {
        let (p, n, v, a) = (h.p[i], h.n[i], h.v[i], h.alpha[i]);
        let mut input = BatchProblems {
            x: splat3(p),
            n: splat3(n),
            ..Default::default()
        };
        if spp == 1 {
            for (g, group) in lights.chunks(BATCH_LANES).enumerate() {
                let mut k = [0.0f32; BATCH_LANES];
                for (
                    l,
                    Light {
                        segment,
                        k: radiance,
                    },
                ) in group.iter().enumerate()
                {
                    set3(&mut input.begin, l, segment.begin);
                    set3(&mut input.end, l, segment.end);
                    k[l] = radiance.x;
                }
                let prepared = prepare(&input);
                if mask(&prepared) == 0 {
                    continue;
                }
                let xi: [f32; BATCH_LANES] = std::array::from_fn(|l| xi(i, g * BATCH_LANES + l, 0));
                sum += shade_lanes(&sample(&prepared, &xi), n, v, a, &k);
            }
        } else {
            let Light {
                segment,
                k: radiance,
            } = lights[0];
            input.begin = splat3(segment.begin);
            input.end = splat3(segment.end);
            let prepared = prepare(&input);
            if mask(&prepared) == 0 {
                continue;
            }
            let k = [radiance.x; BATCH_LANES];
            for s in (0..spp).step_by(BATCH_LANES) {
                let xi: [f32; BATCH_LANES] = std::array::from_fn(|l| xi(i, 0, s + l));
                sum += shade_lanes(&sample(&prepared, &xi), n, v, a, &k);
            }
        }
    }
    sum
}

/// The shading loops of [`shade_batched`] (`lanes` = [`BATCH_LANES`]) or [`shade_packet`] (`lanes` =
/// [`PACKET_LANES`]) with a stand-in sampler (the direction to the point at ξ along the segment,
/// density 1, no preparation): what a row costs besides its sampler (the count mode's `shade-x8` and
/// `shade-x16` rows; not a technique, not in the table).
#[inline(never)]
pub fn shade_stand_in(lanes: usize, h: &HitPoints, lights: &[Light], spp: usize) -> f32 {
    let work = Work { h, lights, spp };
    if lanes == BATCH_LANES {
        BatchRows(work).shade(|input| *input, |_| u32::MAX, stand_in)
    } else if spp == 1 {
        shade_packets_fused(h, lights, |input| stand_in(input, &input.xi))
    } else {
        PacketRows(work).shade(|input| *input, |_| u32::MAX, stand_in)
    }
}

#[inline(always)]
fn stand_in<const N: usize>(input: &LineProblems<N>, xi: &[f32; N]) -> LineSamples<N> {
    let mut out = LineSamples::default();
    for (l, &xi) in xi.iter().enumerate() {
        let m = get3(&input.begin, l).lerp(get3(&input.end, l), xi);
        set3(&mut out.dir, l, (m - get3(&input.x, l)).normalize_or_zero());
        out.pdf[l] = if get3(&input.n, l) == Vec3::ZERO {
            0.0
        } else {
            1.0
        };
    }
    out.mask = u32::MAX >> (32 - N);
    out
}

/// What a row of the table times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowKind {
    Scalar(Technique),
    /// The 8-wide batch ([`shade_batched`]).
    Batched(Batched),
    /// The 16-lane packet ([`shade_packet`]).
    Packet(Batched),
}

/// Timings of one row: seconds per timed pass (all hit points), median and minimum.
#[derive(Clone, Debug)]
pub struct RowTiming {
    pub name: String,
    pub kind: RowKind,
    pub median_s: f64,
    pub min_s: f64,
}

/// One configuration (128 lights × 1 spp, or 1 light × 128 spp).
#[derive(Clone, Debug)]
pub struct ConfigTiming {
    pub name: &'static str,
    pub lights: usize,
    pub spp: usize,
    /// Samples of one timed pass.
    pub samples: f64,
    /// Full-frame pixels / timed pixels.
    pub frame_scale: f64,
    pub rows: Vec<RowTiming>,
    /// Newton–bisection iterations per batch of the x8 Li et al. row.
    pub li_iterations_per_batch: f64,
    /// Newton–bisection iterations per packet of the x16 Li et al. row.
    pub li_iterations_per_packet: f64,
    /// The 1-minute load average when the configuration finished.
    pub load: String,
}

impl ConfigTiming {
    /// ns per sample (median, minimum).
    pub fn ns_per_sample(&self, row: &RowTiming) -> (f64, f64) {
        (
            row.median_s * 1e9 / self.samples,
            row.min_s * 1e9 / self.samples,
        )
    }
    /// ms per 1920×1080 frame (median, minimum).
    pub fn ms_per_frame(&self, row: &RowTiming) -> (f64, f64) {
        (
            row.median_s * 1e3 * self.frame_scale,
            row.min_s * 1e3 * self.frame_scale,
        )
    }
    /// The row of a kind.
    pub fn row(&self, kind: RowKind) -> Option<&RowTiming> {
        self.rows.iter().find(|r| r.kind == kind)
    }
    /// Time relative to (scalar) clipped solid angle (median/median, minimum/minimum).
    pub fn ratio_to_clipped(&self, row: &RowTiming) -> (f64, f64) {
        self.ratio(row.kind, RowKind::Scalar(Technique::ClippedSolidAngle))
    }
    /// Time of row `a` relative to row `b` (median/median, minimum/minimum); NaN when either
    /// was not measured.
    pub fn ratio(&self, a: RowKind, b: RowKind) -> (f64, f64) {
        match (self.row(a), self.row(b)) {
            (Some(a), Some(b)) => (a.median_s / b.median_s, a.min_s / b.min_s),
            _ => (f64::NAN, f64::NAN),
        }
    }
}

/// A whole run of the table.
#[derive(Clone, Debug)]
pub struct Measurement {
    pub stride: usize,
    pub repeats: usize,
    pub hit_points: usize,
    /// The batch kernel the CPU runs.
    pub isa: &'static str,
    pub configs: Vec<ConfigTiming>,
}

/// The 1-minute load average (shared machine: timings depend on it).
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "n/a".into())
}

/// Time every row of both configurations (see the module documentation), the x8 and x16 rows
/// with the kernels of `isa` (the baseline's where the CPU does not run it). `progress(done,
/// total)` after each timed pass.
pub fn measure(
    stride: usize,
    repeats: usize,
    isa: Isa,
    progress: &dyn Fn(usize, usize),
) -> Measurement {
    let (stride, repeats) = (stride.max(1), repeats.max(1));
    let h = hit_points(stride);
    let all_lights = lights();
    let isa = if isa.supported() { isa } else { Isa::Baseline };
    let frame_scale = (WIDTH * HEIGHT) as f64 / h.p.len() as f64;
    let kinds: Vec<(String, RowKind)> = Technique::ALL
        .into_iter()
        .map(|t| (t.name().to_string(), RowKind::Scalar(t)))
        .chain(
            [
                ("x8", RowKind::Batched as fn(Batched) -> RowKind),
                ("x16", RowKind::Packet),
            ]
            .into_iter()
            .flat_map(|(width, kind)| {
                Batched::ALL.map(|b| {
                    let name = b.technique().name();
                    (format!("{name} {width} ({})", isa.name()), kind(b))
                })
            }),
        )
        .collect();
    let total = 2 * repeats * kinds.len();
    let mut done = 0;
    let mut configs = Vec::new();
    for (name, lights, spp) in [
        ("128 lights x 1 spp", &all_lights[..], 1usize),
        ("1 light x 128 spp", &all_lights[..1], SPP),
    ] {
        let samples = (h.p.len() * lights.len() * spp) as f64;
        let (mut li_iterations, mut li_packet_iterations) = (0u64, 0u64);
        let mut times = vec![Vec::new(); kinds.len()];
        for _ in 0..repeats {
            for (k, (_, kind)) in kinds.iter().enumerate() {
                let start = Instant::now();
                match *kind {
                    RowKind::Scalar(t) => {
                        black_box(shade_scalar(t, &h, lights, spp));
                    }
                    RowKind::Batched(b) => {
                        let (sum, it) = shade_batched(b, isa, &h, lights, spp);
                        black_box(sum);
                        if b == Batched::Li2018 {
                            li_iterations = it;
                        }
                    }
                    RowKind::Packet(b) => {
                        let (sum, it) = shade_packet(b, isa, &h, lights, spp);
                        black_box(sum);
                        if b == Batched::Li2018 {
                            li_packet_iterations = it;
                        }
                    }
                }
                times[k].push(start.elapsed().as_secs_f64());
                done += 1;
                progress(done, total);
            }
        }
        let rows = kinds
            .iter()
            .zip(&mut times)
            .map(|((name, kind), t)| {
                t.sort_by(f64::total_cmp);
                RowTiming {
                    name: name.clone(),
                    kind: *kind,
                    median_s: t[t.len() / 2],
                    min_s: t[0],
                }
            })
            .collect();
        configs.push(ConfigTiming {
            name,
            lights: lights.len(),
            spp,
            samples,
            frame_scale,
            rows,
            li_iterations_per_batch: li_iterations as f64 / (samples / BATCH_LANES as f64),
            li_iterations_per_packet: li_packet_iterations as f64
                / (h.p.len().div_ceil(P) * lights.len() * spp) as f64,
            load: load_average(),
        });
    }
    Measurement {
        stride,
        repeats,
        hit_points: h.p.len(),
        isa: isa.name(),
        configs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every batched row (x8 and x16) draws the samples of its scalar technique (the same ξ per
    /// hit point, light and sample; lanes bit for bit the scalar sampler) and shades them with
    /// the same BRDF, so its sum equals the scalar row's up to the order of the f32 sum (a
    /// relative 1e-4 bounds it here: 2 160 terms of one sign, worst case n·ε ≈ 1.3e-4, seen
    /// ≤ 3.4e-7). A lost or doubled hit point moves the sum by ≈ 1/135.
    #[test]
    fn batched_rows_shade_what_the_scalar_rows_shade() {
        let h = hit_points(128);
        let all = lights();
        let isa = Isa::detect();
        for (lights, spp) in [(&all[..16], 1), (&all[..1], 16)] {
            for b in Batched::ALL {
                let scalar = shade_scalar(b.technique(), &h, lights, spp);
                assert!(scalar > 0.0, "{b:?}: nothing shaded");
                let x8 = shade_batched(b, isa, &h, lights, spp).0;
                let x16 = shade_packet(b, isa, &h, lights, spp).0;
                for (row, sum) in [("x8", x8), ("x16", x16)] {
                    assert!(
                        (sum - scalar).abs() <= 1e-4 * scalar,
                        "{b:?} {row}, {} lights x {spp} spp: {sum} against scalar {scalar}",
                        lights.len()
                    );
                }
            }
        }
    }
}
