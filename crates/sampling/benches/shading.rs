//! Sampler cost as the paper reports it (its timing table): shading of the cached hit points of
//! a 1920×1080 frame by linear lights, Lambert + GGX evaluated, no shadow rays, for every
//! technique (the baseline included) in two configurations — 128 lights × 1 sample per pixel,
//! and 1 light × 128 samples per pixel — and for the 8-wide batches of projected solid angle
//! and Li et al. 2018 (lanes = 8 lights, or 8 samples of one light; Li iterating until the
//! slowest lane converges, as a GPU warp does).
//!
//! Scene (procedural, the paper's "roughness planes"): a floor z = 0 and a back wall y = 6 seen
//! by a pinhole camera, GGX roughness α in ten stripes from 0.05 to 1 across the image, a
//! gentle procedural bump on the normals, 128 lights (segments of length 0.5–2) above the floor.
//! Shading per sample: f = ρ/π + F·D·G1(v)G1(l)/(4 n·v n·l) (Schlick F, F0 = 0.04; D and G1 of
//! `linlight_brdf::microfacet`), L += K·f·(n·ω)/p(ω).
//!
//! Timing: by default every 8th pixel of every 8th row (32 400 pixels, 4.1 M samples per row
//! of the table; `LINLIGHT_SHADING_STRIDE=1` shades the whole frame), 5 repeats interleaved
//! across the rows; reported per sample and per (extrapolated) full frame, median and minimum,
//! and as a ratio to clipped solid angle.
//!
//! Run: `cargo bench -p linlight-sampling --bench shading`.

use glam::Vec3;
use linlight_brdf::microfacet;
use linlight_sampling::batch::{Isa, PreparedBatch, PsaBatchInput, PsaBatchOutput, Vec3x8, LANES};
use linlight_sampling::{LineSampler, Segment, Technique};
use std::hint::black_box;
use std::time::Instant;

const WIDTH: usize = 1920;
const HEIGHT: usize = 1080;
const LIGHTS: usize = 128;
const SPP: usize = 128;

/// Cached hit points (structure of arrays).
struct HitPoints {
    p: Vec<Vec3>,
    n: Vec<Vec3>,
    /// Unit direction to the camera.
    v: Vec<Vec3>,
    alpha: Vec<f32>,
}

fn hit_points(stride: usize) -> HitPoints {
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
fn lights() -> Vec<(Segment, Vec3)> {
    let mut rng = linlight_sampling::rng::Pcg32::new(128, 1);
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    (0..LIGHTS)
        .map(|_| {
            let c = Vec3::new(r(-4.0, 4.0), r(-1.0, 5.5), r(0.3, 3.0));
            let axis = Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-0.3, 0.3)).normalize();
            let half = 0.5 * r(0.5, 2.0) * axis;
            (
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
fn shade_scalar(t: Technique, h: &HitPoints, lights: &[(Segment, Vec3)], spp: usize) -> f32 {
    let mut sum = 0.0f32;
    for i in 0..h.p.len() {
        let (p, n, v, a) = (h.p[i], h.n[i], h.v[i], h.alpha[i]);
        let mut radiance = 0.0f32;
        for (j, (segment, k)) in lights.iter().enumerate() {
            let Some(sampler) = t.prepare(segment, p, n) else {
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
fn shade_lanes(out: &PsaBatchOutput, n: Vec3, v: Vec3, alpha: f32, k: &[f32; LANES]) -> f32 {
    let mut c = [0.0f32; LANES];
    for (i, c) in c.iter_mut().enumerate() {
        let w = out.dir.get(i);
        let f = brdf_cos(n, v, w, alpha);
        *c = if out.pdf[i] > 0.0 {
            k[i] * f / out.pdf[i]
        } else {
            0.0
        };
    }
    c.iter().sum()
}

#[derive(Clone, Copy, PartialEq)]
enum Batched {
    ProjectedSolidAngle,
    Li2018,
}

/// Batched shading. 128 lights × 1 spp: lanes = 8 lights of a hit point, prepared and sampled
/// once. 1 light × 128 spp: lanes = 8 samples of the one light, prepared once per hit point
/// (every lane the same), sampled 16 times. Returns the sum and Li's iteration count.
#[inline(never)]
fn shade_batched(
    which: Batched,
    isa: Isa,
    h: &HitPoints,
    lights: &[(Segment, Vec3)],
    spp: usize,
) -> (f32, u64) {
    let mut sum = 0.0f32;
    let mut iterations = 0u64;
    let mut sample = |prepared: &PreparedBatch, xi: &[f32; LANES]| -> PsaBatchOutput {
        match which {
            Batched::ProjectedSolidAngle => prepared.sample_projected_solid_angle(isa, xi),
            Batched::Li2018 => {
                let (out, k) = prepared.sample_li2018(isa, xi);
                iterations += k as u64;
                out
            }
        }
    };
    for i in 0..h.p.len() {
        let (p, n, v, a) = (h.p[i], h.n[i], h.v[i], h.alpha[i]);
        let mut input = PsaBatchInput {
            x: Vec3x8::splat(p),
            n: Vec3x8::splat(n),
            ..Default::default()
        };
        if spp == 1 {
            for (g, group) in lights.chunks(LANES).enumerate() {
                let mut k = [0.0f32; LANES];
                for (l, (segment, radiance)) in group.iter().enumerate() {
                    input.begin.set(l, segment.begin);
                    input.end.set(l, segment.end);
                    k[l] = radiance.x;
                }
                let prepared = PreparedBatch::prepare(isa, &input);
                if prepared.mask == 0 {
                    continue;
                }
                let xi: [f32; LANES] = std::array::from_fn(|l| xi(i, g * LANES + l, 0));
                sum += shade_lanes(&sample(&prepared, &xi), n, v, a, &k);
            }
        } else {
            let (segment, radiance) = lights[0];
            input.begin = Vec3x8::splat(segment.begin);
            input.end = Vec3x8::splat(segment.end);
            let prepared = PreparedBatch::prepare(isa, &input);
            if prepared.mask == 0 {
                continue;
            }
            let k = [radiance.x; LANES];
            for s in (0..spp).step_by(LANES) {
                let xi: [f32; LANES] = std::array::from_fn(|l| xi(i, 0, s + l));
                sum += shade_lanes(&sample(&prepared, &xi), n, v, a, &k);
            }
        }
    }
    (sum, iterations)
}

/// A row of the table: name, technique it stands for (ratios), one timed pass.
struct Row<'a> {
    name: String,
    pass: Box<dyn FnMut() -> f32 + 'a>,
}

/// Instruction-count mode for callgrind (`--toggle-collect='*shade_*'`):
/// `LINLIGHT_SHADING_ONLY=<row>:<config>` with row a technique name, `psa-x8` or `li-x8`, config
/// `128x1` or `1x128`, shades once and prints the number of samples (instructions per sample
/// = Ir / samples). Batches run the kernel the CPU supports (under valgrind: AVX2).
fn count_mode(spec: &str, stride: usize) {
    let (row, config) = spec
        .split_once(':')
        .expect("LINLIGHT_SHADING_ONLY=<row>:<128x1|1x128>");
    let h = hit_points(stride);
    let all = lights();
    let (lights, spp) = match config {
        "128x1" => (&all[..], 1),
        "1x128" => (&all[..1], SPP),
        _ => panic!("config must be 128x1 or 1x128"),
    };
    let isa = Isa::detect();
    let sum = match row {
        "psa-x8" => shade_batched(Batched::ProjectedSolidAngle, isa, &h, lights, spp).0,
        "li-x8" => shade_batched(Batched::Li2018, isa, &h, lights, spp).0,
        t => shade_scalar(t.parse().expect("technique"), &h, lights, spp),
    };
    println!(
        "{spec}: {} samples, checksum {sum}",
        h.p.len() * lights.len() * spp
    );
}

fn main() {
    let stride_of = |default: usize| {
        std::env::var("LINLIGHT_SHADING_STRIDE")
            .ok()
            .and_then(|s| s.parse().ok())
            .filter(|&s| s >= 1)
            .unwrap_or(default)
    };
    if let Ok(spec) = std::env::var("LINLIGHT_SHADING_ONLY") {
        count_mode(&spec, stride_of(32));
        return;
    }
    if !std::env::args().any(|a| a == "--bench") {
        return; // `cargo test --benches`: nothing to check here
    }
    let stride = stride_of(8);
    let repeats: usize = std::env::var("LINLIGHT_SHADING_REPEATS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&s| s >= 1)
        .unwrap_or(5);
    let h = hit_points(stride);
    let all_lights = lights();
    let isa = Isa::detect();
    let frame_scale = (WIDTH * HEIGHT) as f64 / h.p.len() as f64;
    println!(
        "shading benchmark: {} of {}x{} hit points (stride {stride}), Lambert + GGX, no shadow rays, \
         {repeats} interleaved repeats; batch kernel {}",
        h.p.len(),
        WIDTH,
        HEIGHT,
        isa.name()
    );
    for (config, lights, spp) in [
        ("128 lights x 1 spp", &all_lights[..], 1usize),
        ("1 light x 128 spp", &all_lights[..1], SPP),
    ] {
        let samples = (h.p.len() * lights.len() * spp) as f64;
        let li_iterations = std::cell::Cell::new(0u64);
        let mut rows: Vec<Row> = Technique::ALL
            .into_iter()
            .map(|t| Row {
                name: t.name().to_string(),
                pass: Box::new({
                    let h = &h;
                    move || shade_scalar(t, h, lights, spp)
                }),
            })
            .collect();
        for (which, name) in [
            (Batched::ProjectedSolidAngle, "projected-solid-angle x8"),
            (Batched::Li2018, "li2018 x8"),
        ] {
            let (h, li_iterations) = (&h, &li_iterations);
            rows.push(Row {
                name: format!("{name} ({})", isa.name()),
                pass: Box::new(move || {
                    let (sum, k) = shade_batched(which, isa, h, lights, spp);
                    if which == Batched::Li2018 {
                        li_iterations.set(k);
                    }
                    sum
                }),
            });
        }
        let mut times = vec![Vec::new(); rows.len()];
        for _ in 0..repeats {
            for (k, row) in rows.iter_mut().enumerate() {
                let start = Instant::now();
                black_box((row.pass)());
                times[k].push(start.elapsed().as_secs_f64());
            }
        }
        let stats: Vec<(f64, f64)> = times
            .iter_mut()
            .map(|t| {
                t.sort_by(f64::total_cmp);
                (t[t.len() / 2], t[0])
            })
            .collect();
        let index = |name: &str| rows.iter().position(|r| r.name.starts_with(name)).unwrap();
        let clipped = stats[index("clipped-solid-angle")];
        println!(
            "\n{config} ({:.1} M samples timed; uptime load: {})",
            samples / 1e6,
            load()
        );
        println!(
            "  {:<28} {:>10} {:>10} {:>12} {:>12} {:>8} {:>8}",
            "technique", "ns/sample", "(min)", "ms/frame", "(min)", "/clipped", "(min)"
        );
        for (row, &(median, min)) in rows.iter().zip(&stats) {
            println!(
                "  {:<28} {:>10.2} {:>10.2} {:>12.1} {:>12.1} {:>8.3} {:>8.3}",
                row.name,
                median * 1e9 / samples,
                min * 1e9 / samples,
                median * 1e3 * frame_scale,
                min * 1e3 * frame_scale,
                median / clipped.0,
                min / clipped.1
            );
        }
        let ratio = |a: usize, b: usize| (stats[a].0 / stats[b].0, stats[a].1 / stats[b].1);
        let (psa, li) = (index("projected-solid-angle"), index("li2018"));
        let (psa8, li8) = (index("projected-solid-angle x8"), index("li2018 x8"));
        let scalar = ratio(li, psa);
        let simd = ratio(li8, psa8);
        println!(
            "  li2018 / projected-solid-angle: scalar {:.3} (min {:.3}), x8 {:.3} (min {:.3}); \
             x8 li2018 ran {:.2} iterations per batch",
            scalar.0,
            scalar.1,
            simd.0,
            simd.1,
            li_iterations.get() as f64 / (samples / LANES as f64)
        );
    }
}

/// The 1-minute load average (shared machine: timings depend on it).
fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "n/a".into())
}
