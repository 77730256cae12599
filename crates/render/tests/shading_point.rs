//! The light estimators at one shading point, against quadrature that knows nothing of the
//! samplers: for random glossy configurations (every BSDF kind, random views, lights near the
//! mirror direction, every third one crossing the horizon), the mean of every estimator — each
//! MIS heuristic (clamped optimal at v = 0, 0.5, 1), LTC only, PSA only — must equal
//!
//!   ∫ K f(v, ω) cos θ dΩ_R,   dΩ_R = 2 |u × ω| dt / r²,
//!
//! along the segment parametrised by the line position t (r = |p(t) − x|, ω = (p(t) − x)/r,
//! u the line direction), computed by adaptive Gauss–Legendre quadrature in f64. Each test is
//! a z-test per channel at the Šidák level of the family (α = 0.01 over every configuration ×
//! estimator × channel), with an f32 floor of 1e-5 relative; it passes for two seeds. The
//! deliberately wrong variants of `linlight_render::power_controls` must fail it. The MIS
//! weights of the two techniques must sum to 1 per channel at every sample direction.

// `!(x > y)` is deliberate: it rejects NaN too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{DVec3, Vec3};
use linlight_brdf::{Blend, Bsdf, ConductorFresnel, Principled, RoughConductor};
use linlight_render::hooks::{BsdfModel, Hooks, LightSampling, SceneBsdf, SpecularSampling};
use linlight_render::power_controls::{
    AlphaScaledEval, LtcHemisphereDensity, LtcWithoutKappa, PrincipledWithoutFresnel,
};
use linlight_render::shading::{estimate_light, shading_frame, Combination, ShadingPoint};
use linlight_render::{Heuristic, Method};
use linlight_sampling::noise::Uniforms;
use linlight_sampling::philox::CounterRng;
use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
use linlight_sampling::rng::Pcg32;
use linlight_sampling::{LineSampler, Segment, SpecularSampler, Technique};
use linlight_verify::quadrature::Adaptive;
use linlight_verify::z_score::{normal_two_sided_quantile, sidak};

/// Family-wise significance level of each test function.
const ALPHA: f64 = 0.01;
/// Samples (one iteration each) per configuration and estimator.
const SAMPLES: usize = 20_000;
/// Relative floor of the tolerance: f32 densities and directions (as in the sampler suite).
const F32_FLOOR: f64 = 1e-5;

struct Case {
    name: String,
    bsdf: Bsdf,
    wi: Vec3,
    segment: Segment,
    k: Vec3,
}

const N: Vec3 = Vec3::Z;

fn conductor(alpha: f32, fresnel: ConductorFresnel) -> Bsdf {
    Bsdf::RoughConductor(RoughConductor {
        alpha,
        fresnel,
        specular_reflectance: [1.0; 3],
    })
}

/// Every BSDF kind the loader accepts (the ones with a GGX lobe, plus a blend with a diffuse
/// part and a twosided).
fn bsdfs() -> Vec<(&'static str, Bsdf)> {
    let gold = ConductorFresnel::Complex {
        eta: [0.143, 0.374, 1.442],
        k: [3.983, 2.385, 1.603],
    };
    vec![
        ("conductor-0.1", conductor(0.1, ConductorFresnel::One)),
        ("conductor-gold-0.35", conductor(0.35, gold.clone())),
        (
            "principled-dielectric",
            Bsdf::Principled(Principled {
                base_color: [0.8, 0.5, 0.2],
                roughness: 0.4,
                ..Principled::new()
            }),
        ),
        (
            "principled-metal",
            Bsdf::Principled(Principled {
                base_color: [0.9, 0.6, 0.3],
                roughness: 0.3,
                metallic: 1.0,
                ..Principled::new()
            }),
        ),
        (
            "principled-mixed",
            Bsdf::Principled(Principled {
                base_color: [0.3, 0.7, 0.5],
                roughness: 0.6,
                metallic: 0.4,
                spec_tint: 0.3,
                flatness: 0.2,
                ..Principled::new()
            }),
        ),
        (
            "blend-diffuse-conductor",
            Bsdf::Blend(Blend {
                weight: 0.6,
                bsdfs: Box::new([
                    Bsdf::Diffuse {
                        reflectance: [0.6, 0.4, 0.3],
                    },
                    conductor(0.2, gold),
                ]),
            }),
        ),
        (
            "twosided-conductor",
            Bsdf::TwoSided(Box::new(conductor(0.25, ConductorFresnel::One))),
        ),
    ]
}

fn unit(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.next_f64() - 1.0;
    let phi = std::f64::consts::TAU * rng.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

/// Three configurations per BSDF kind: a view up to 80° off the normal, a segment through a
/// point near the mirror direction (its spread ~ the lobe width), length 0.3–4; the third of
/// each kind crosses the horizon.
fn cases(seed: u64) -> Vec<Case> {
    let mut out = Vec::new();
    for (b, (name, bsdf)) in bsdfs().into_iter().enumerate() {
        for j in 0..3 {
            let mut rng = Pcg32::new(seed, (b * 3 + j) as u64);
            let theta = 80f64.to_radians() * rng.next_f64();
            let phi = std::f64::consts::TAU * rng.next_f64();
            let wi = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            );
            let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
            let dist = 0.5 + 2.0 * rng.next_f64() as f32;
            let center = mirror * dist + unit(&mut rng) * (0.3 * dist);
            let len = 0.3 + 3.7 * rng.next_f64() as f32;
            let (begin, end) = if j == 2 {
                // Crossing the horizon: from below z = 0 up through the centre and beyond.
                let below = Vec3::new(center.x * 0.6, center.y * 0.6, -0.4 * dist);
                let dir = (center - below).normalize();
                (below, center + dir * (0.5 * len))
            } else {
                let dir = unit(&mut rng);
                (center - 0.5 * len * dir, center + 0.5 * len * dir)
            };
            let k = Vec3::new(1.0, 0.7, 0.4) * (0.5 + rng.next_f64() as f32);
            out.push(Case {
                name: format!("{name}-{j}"),
                bsdf: bsdf.clone(),
                wi: wi.normalize(),
                segment: Segment::new(begin, end),
                k,
            });
        }
    }
    // The twosided BSDF seen from below: the integrator shades with the flipped normal, so the
    // estimators see the same configuration mirrored; covered by the one-sided cases.
    out
}

/// ∫ K f(v, ω) cos dΩ_R over the line position t (module documentation), per channel, f64.
fn quadrature(case: &Case) -> DVec3 {
    let (frame, v) = shading_frame(N, case.wi);
    let frame = frame.as_dmat3();
    let b = case.segment.begin.as_dvec3();
    let e = case.segment.end.as_dvec3();
    let len = (e - b).length();
    let u = (e - b) / len;
    // Above the horizon of n = z: b_z + t u_z > 0.
    let (mut t0, mut t1) = (0.0f64, len);
    if u.z != 0.0 {
        let t_h = -b.z / u.z;
        if u.z > 0.0 {
            t0 = t0.max(t_h);
        } else {
            t1 = t1.min(t_h);
        }
    } else if b.z <= 0.0 {
        return DVec3::ZERO;
    }
    if !(t1 > t0) {
        return DVec3::ZERO;
    }
    // Edges equally spaced in the angle seen from x (the integrand is a function of t).
    let tc = -b.dot(u);
    let d = (b + tc * u).length();
    let (a0, a1) = (((t0 - tc) / d).atan(), ((t1 - tc) / d).atan());
    let mut edges: Vec<f64> = (0..=64)
        .map(|i| tc + d * (a0 + (a1 - a0) * i as f64 / 64.0).tan())
        .collect();
    edges[0] = t0;
    edges[64] = t1;
    let k = case.k.as_dvec3();
    let quad = Adaptive::new(15, 1e-10);
    let channel = |c: usize| {
        quad.integrate_partition(&edges, &mut |t: f64| {
            let p = b + t * u;
            let r = p.length();
            let w = p / r;
            let l = frame.transpose() * w;
            let f = case.bsdf.eval(v, l);
            k[c] * f[c] * 2.0 * u.cross(w).length() / (r * r)
        })
        .value
    };
    DVec3::new(channel(0), channel(1), channel(2))
}

struct Estimate {
    mean: DVec3,
    std_error: DVec3,
}

fn estimate<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
    case: &Case,
    hooks: &Hooks<D, S, B>,
    method: Method,
    stream: [u32; 3],
    seed: u64,
) -> Estimate {
    let sp = ShadingPoint::new(&hooks.bsdf, &case.bsdf, Vec3::ZERO, N, case.wi);
    let mut rng = CounterRng::new(seed, stream);
    let (mut sum, mut sum_sq) = (DVec3::ZERO, DVec3::ZERO);
    let mut dropped = 0;
    for _ in 0..SAMPLES {
        let e = estimate_light(
            hooks,
            method,
            &sp,
            &case.segment,
            case.k,
            1,
            &mut rng,
            &mut |_, _| true,
            &mut dropped,
        )
        .as_dvec3();
        sum += e;
        sum_sq += e * e;
    }
    assert_eq!(dropped, 0, "{}: non-finite contributions", case.name);
    let n = SAMPLES as f64;
    let mean = sum / n;
    let var = (sum_sq / n - mean * mean).max(DVec3::ZERO) * (n / (n - 1.0));
    Estimate {
        mean,
        std_error: (var / n).map(f64::sqrt),
    }
}

fn methods() -> Vec<Method> {
    vec![
        Method::Technique(Technique::ProjectedSolidAngle),
        Method::Ltc,
        Method::Mis(Heuristic::Balance),
        Method::Mis(Heuristic::Power),
        Method::Mis(Heuristic::Weighted),
        Method::Mis(Heuristic::ClampedOptimal(0.0)),
        Method::Mis(Heuristic::ClampedOptimal(0.5)),
        Method::Mis(Heuristic::ClampedOptimal(1.0)),
    ]
}

/// Largest |z| over the channels: (mean − truth)/(SE + floor).
fn worst_z(e: &Estimate, truth: DVec3) -> f64 {
    (0..3)
        .map(|c| {
            let tol = e.std_error[c] + F32_FLOOR * truth[c].abs();
            let diff = (e.mean[c] - truth[c]).abs();
            if diff == 0.0 {
                0.0
            } else {
                diff / tol
            }
        })
        .fold(0.0, f64::max)
}

/// The z threshold of a family of `m` two-sided tests at family-wise α.
fn z_threshold(m: usize) -> f64 {
    normal_two_sided_quantile(sidak(ALPHA, m))
}

/// Every estimator is unbiased on every configuration, for two seeds (a seed-only change must
/// pass too). Prints the table of z-scores.
#[test]
fn every_estimator_matches_quadrature() {
    let methods = methods();
    for seed in [1u64, 2] {
        let cases = cases(0x5eed);
        let m = cases.len() * methods.len() * 3;
        let z_c = z_threshold(m);
        let mut worst = (0.0, String::new());
        let mut failures = Vec::new();
        for (i, case) in cases.iter().enumerate() {
            let truth = quadrature(case);
            assert!(truth.min_element() > 0.0, "{}: no light", case.name);
            let mut row = format!("{:26} truth {:.4e}", case.name, truth.x);
            for (j, &method) in methods.iter().enumerate() {
                let e = estimate(case, &Hooks::new(), method, [i as u32, j as u32, 0], seed);
                let z = worst_z(&e, truth);
                row += &format!(" {z:5.2}");
                if z > worst.0 {
                    worst = (z, format!("{} {}", case.name, method));
                }
                if !(z <= z_c) {
                    failures.push(format!(
                        "{} {method}: mean {:?} vs {:?} (SE {:?}), |z| = {z:.2} > {z_c:.2}",
                        case.name, e.mean, truth, e.std_error
                    ));
                }
            }
            println!("{row}");
        }
        println!(
            "seed {seed}: {m} tests, z_c = {z_c:.2}, worst |z| = {:.2} ({})",
            worst.0, worst.1
        );
        assert!(failures.is_empty(), "seed {seed}:\n{}", failures.join("\n"));
    }
}

/// A deliberately wrong variant is rejected by the same test on at least `min_share` of the
/// configurations (and at least one), for every method that uses the replaced piece.
fn assert_rejected<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
    what: &str,
    hooks: &Hooks<D, S, B>,
    methods: &[Method],
    applies: impl Fn(&Case) -> bool,
    min_share: f64,
) {
    let all = cases(0x5eed);
    // The level of the unbiasedness test (the controls are judged as the real estimators).
    let z_c = z_threshold(all.len() * self::methods().len() * 3);
    let cases: Vec<Case> = all.into_iter().filter(|c| applies(c)).collect();
    for &method in methods {
        let mut rejected = 0;
        let mut zs = Vec::new();
        for (i, case) in cases.iter().enumerate() {
            let truth = quadrature(case);
            let e = estimate(case, hooks, method, [i as u32, 100, 0], 3);
            let z = worst_z(&e, truth);
            zs.push(format!("{z:.1}"));
            rejected += usize::from(z > z_c);
        }
        println!(
            "{what}, {method}: rejected {rejected}/{} (|z|: {})",
            cases.len(),
            zs.join(" ")
        );
        let needed = ((min_share * cases.len() as f64).ceil() as usize).max(1);
        assert!(
            rejected >= needed,
            "{what} with {method}: rejected on {rejected} of {} configurations, {needed} needed",
            cases.len()
        );
    }
}

fn two_technique_methods() -> Vec<Method> {
    vec![
        Method::Ltc,
        Method::Mis(Heuristic::Balance),
        Method::Mis(Heuristic::ClampedOptimal(0.5)),
    ]
}

#[test]
fn ltc_without_kappa_is_biased() {
    assert_rejected(
        "κ := 1",
        &Hooks::new().with_specular(LtcWithoutKappa),
        &two_technique_methods(),
        |_| true,
        0.5,
    );
}

#[test]
fn hemisphere_ltc_density_is_biased() {
    assert_rejected(
        "hemisphere LTC density",
        &Hooks::new().with_specular(LtcHemisphereDensity),
        &two_technique_methods(),
        |_| true,
        0.5,
    );
}

#[test]
fn principled_without_fresnel_is_biased() {
    let mut methods = two_technique_methods();
    methods.push(Method::Technique(Technique::ProjectedSolidAngle));
    assert_rejected(
        "principled without Fresnel",
        &Hooks::new().with_bsdf(PrincipledWithoutFresnel),
        &methods,
        |c| matches!(c.bsdf, Bsdf::Principled(_)),
        0.5,
    );
}

#[test]
fn alpha_off_by_five_percent_in_eval_is_biased() {
    let mut methods = two_technique_methods();
    methods.push(Method::Technique(Technique::ProjectedSolidAngle));
    assert_rejected(
        "α × 1.05 in eval",
        &Hooks::new().with_bsdf(AlphaScaledEval(1.05)),
        &methods,
        |_| true,
        0.2,
    );
}

/// The weights of the diffuse and the specular sample sum to 1 per channel at every direction
/// either technique samples, for every combination (every heuristic, clamped optimal at
/// several v, the support indicator of `ltc`), on every configuration.
#[test]
fn weights_of_the_two_techniques_sum_to_one() {
    let mut combinations: Vec<Combination> = [
        Heuristic::Balance,
        Heuristic::Power,
        Heuristic::Weighted,
        Heuristic::ClampedOptimal(0.0),
        Heuristic::ClampedOptimal(0.25),
        Heuristic::ClampedOptimal(0.5),
        Heuristic::ClampedOptimal(0.75),
        Heuristic::ClampedOptimal(1.0),
    ]
    .map(Combination::Heuristic)
    .to_vec();
    combinations.push(Combination::SupportIndicator);
    let mut checked = 0;
    for seed in 0..4 {
        for case in cases(seed) {
            let sp = ShadingPoint::new(&SceneBsdf, &case.bsdf, Vec3::ZERO, N, case.wi);
            let Some(psa) = ProjectedSolidAngle::prepare(&case.segment, Vec3::ZERO, N) else {
                continue;
            };
            let Some((a, rho)) = sp.ltc else { continue };
            let Some(ltc) =
                linlight_render::hooks::Ltc.prepare(&case.segment, Vec3::ZERO, sp.frame, a)
            else {
                continue;
            };
            let w_d =
                sp.lobes.diffuse.as_vec3().max(Vec3::splat(0.01)) * psa.projected_solid_angle();
            let k_s = sp.lobes.specular.unwrap().weight.as_vec3();
            let w_s = k_s * rho * ltc.weight_scale();
            for i in 0..64 {
                let xi = (i as f32 + 0.5) / 64.0;
                for dir in [psa.sample(xi), ltc.sample(xi)] {
                    let p_d = psa.density_in_support(dir);
                    let p_s = ltc.density_on_clipped_line(dir);
                    if !(p_d + p_s > 0.0) {
                        continue;
                    }
                    for c in &combinations {
                        let sum = c.weight(false, p_d, p_s, w_d, w_s)
                            + c.weight(true, p_s, p_d, w_s, w_d);
                        assert!(
                            (sum - Vec3::ONE).abs().max_element() < 1e-6,
                            "{} {c:?}: p_d {p_d} p_s {p_s} W_d {w_d} W_s {w_s}: {sum}",
                            case.name
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 10_000, "{checked}");
}

/// Uniforms from a fixed list, cycled.
struct Fixed(Vec<f32>, usize);

impl Uniforms for Fixed {
    fn next_f32(&mut self) -> f32 {
        let v = self.0[self.1 % self.0.len()];
        self.1 += 1;
        v
    }
}

/// LTC alone at the ends of the renderer's uniform lattice (k·2⁻²⁴; docs/glossy-scenes.md, "LTC
/// alone"): the glossy-principled floor point of pixel (0, 36) of a 64² render and its cool tube,
/// which crosses the edge of the LTC support inside the hemisphere (θ_o = 54.5°, α = 0.16). The
/// one-iteration estimate with the LTC sample at the first or last lattice point (ξ_s = 0 or
/// 1 − 2⁻²⁴; ξ_d = 0.5, on the complement's side or not) weighs 2⁻²⁴ in the expectation: it
/// must not add more than 1e-3 of the point's value to it, i.e. stay below 2²⁴·10⁻³ ≈ 1.7·10⁴
/// times the quadrature value. With the sample for ξ = 0 placed on the support's edge (density
/// = f32 rounding noise) it would be 7.7·10⁴ times here (2.3·10⁵ at the same point in the
/// render, whose shading point is not at the origin); on the √ξ law of the rest of the tail it
/// is ~500.
#[test]
fn ltc_alone_is_bounded_at_the_lattice_ends() {
    let x = Vec3::new(-1.311_127_3, -0.081_670_165, 0.0);
    let case = Case {
        name: "glossy-principled floor (0, 36), cool tube".into(),
        bsdf: Bsdf::Principled(Principled {
            base_color: [0.55, 0.35, 0.25],
            roughness: 0.4,
            metallic: 0.0,
            ..Principled::new()
        }),
        wi: Vec3::new(0.400_753_83, -0.708_611_4, 0.580_746_3).normalize(),
        segment: Segment::new(Vec3::new(1.5, -0.8, 1.2) - x, Vec3::new(1.7, 0.6, 1.3) - x),
        k: Vec3::new(0.3, 0.5, 0.9),
    };
    let truth = quadrature(&case);
    assert!(truth.min_element() > 0.0);
    let hooks = Hooks::new();
    let sp = ShadingPoint::new(&hooks.bsdf, &case.bsdf, Vec3::ZERO, N, case.wi);
    let (a, _) = sp.ltc.expect("a specular lobe");
    let ltc = linlight_sampling::ltc::LtcLine::prepare(&case.segment, Vec3::ZERO, sp.frame, a)
        .expect("the lobe reaches the line");
    // The support begins or ends on the lobe's horizon: the line crosses the support's edge.
    let z_o = |l: f32| {
        let aw = a * (sp.frame.transpose() * ltc.support().direction_to(l));
        aw.z / aw.length()
    };
    let (l_b, l_e) = (ltc.support().l_begin, ltc.support().l_end);
    assert!(z_o(l_b).min(z_o(l_e)) < 1e-6, "{} {}", z_o(l_b), z_o(l_e));
    let bound = 16_777_216.0 * 1e-3;
    for xi_s in [0.0f32, 1.0 - 1.0 / 16_777_216.0] {
        let mut dropped = 0;
        let e = estimate_light(
            &hooks,
            Method::Ltc,
            &sp,
            &case.segment,
            case.k,
            1,
            &mut Fixed(vec![0.5, xi_s], 0),
            &mut |_, _| true,
            &mut dropped,
        );
        assert_eq!(dropped, 0);
        let ratio = (e.as_dvec3() / truth).max_element();
        assert!(
            ratio < bound,
            "ξ_s = {xi_s}: estimate {e:?} = {ratio:.3e} × the quadrature value {truth:?}"
        );
    }
}

/// With N > 1 light samples per call the scalar path shades in chunks of lanes; its estimate
/// is the mean of N one-sample calls on the same random stream (the same numbers drawn in the
/// same order), for every method and single technique, N across the chunk size, with a
/// visibility test that rejects some samples: bit for bit where an iteration adds one term;
/// with MIS (two terms per iteration, summed one by one in a call, as a pair by the calls)
/// within 1e-6 relative per channel.
#[test]
fn light_samples_in_chunks_are_one_sample_calls() {
    let mut methods = methods();
    methods
        .extend([Technique::Area, Technique::HartLinear, Technique::Li2018].map(Method::Technique));
    let visible = |w: Vec3, _: f32| w.x > -0.3;
    let hooks = Hooks::new();
    let mut compared = 0;
    for (i, case) in cases(0xc4a1).iter().enumerate() {
        let sp = ShadingPoint::new(&hooks.bsdf, &case.bsdf, Vec3::ZERO, N, case.wi);
        for &method in &methods {
            for n in [2u32, 3, 8, 9, 13] {
                let stream = [i as u32, n, 7];
                let (mut chunked, mut one) =
                    (CounterRng::new(3, stream), CounterRng::new(3, stream));
                let (mut dropped_n, mut dropped_1) = (0, 0);
                let all = estimate_light(
                    &hooks,
                    method,
                    &sp,
                    &case.segment,
                    case.k,
                    n,
                    &mut chunked,
                    &mut { visible },
                    &mut dropped_n,
                );
                let mut sum = Vec3::ZERO;
                for _ in 0..n {
                    sum += estimate_light(
                        &hooks,
                        method,
                        &sp,
                        &case.segment,
                        case.k,
                        1,
                        &mut one,
                        &mut { visible },
                        &mut dropped_1,
                    );
                }
                let mean = sum / n as f32;
                let close = match method {
                    Method::Mis(_) => (all - mean).abs().cmple(mean.abs() * 1e-6).all(),
                    _ => all == mean,
                };
                assert!(
                    close && dropped_n == dropped_1,
                    "{} {method} N = {n}: {all:?} vs {mean:?}",
                    case.name
                );
                assert_eq!(
                    chunked.next_f32(),
                    one.next_f32(),
                    "{} {method} N = {n}",
                    case.name
                );
                compared += usize::from(all != Vec3::ZERO);
            }
        }
    }
    assert!(compared > 500, "{compared}");
}

/// A method and its [`Method::same_renders_as`] (clamped optimal at v = 0 and balance, at
/// v = 1 and weighted) give the same estimate bit for bit and draw the same numbers, at one
/// light sample and in chunks, with a visibility test that rejects some samples: certify
/// reuses the render of one for the other.
#[test]
fn methods_of_the_same_weights_estimate_the_same_bits() {
    let hooks = Hooks::new();
    let visible = |w: Vec3, _: f32| w.x > -0.3;
    let pairs: Vec<(Method, Method)> = methods()
        .into_iter()
        .map(|m| (m, m.same_renders_as()))
        .filter(|(m, same)| m != same)
        .collect();
    assert_eq!(pairs.len(), 2, "{pairs:?}");
    let mut nonzero = 0;
    for (i, case) in cases(0x5a3e).iter().enumerate() {
        let sp = ShadingPoint::new(&hooks.bsdf, &case.bsdf, Vec3::ZERO, N, case.wi);
        for &(method, same) in &pairs {
            for n in [1u32, 2, 8, 9] {
                let stream = [i as u32, n, 11];
                let (mut a, mut b) = (CounterRng::new(5, stream), CounterRng::new(5, stream));
                let (mut dropped_a, mut dropped_b) = (0, 0);
                let run = |m: Method, rng: &mut CounterRng, dropped: &mut u32| {
                    estimate_light(
                        &hooks,
                        m,
                        &sp,
                        &case.segment,
                        case.k,
                        n,
                        rng,
                        &mut { visible },
                        dropped,
                    )
                };
                let (ea, eb) = (
                    run(method, &mut a, &mut dropped_a),
                    run(same, &mut b, &mut dropped_b),
                );
                let bits = |e: Vec3| e.to_array().map(f32::to_bits);
                assert_eq!(
                    bits(ea),
                    bits(eb),
                    "{} {method} / {same} N = {n}",
                    case.name
                );
                assert_eq!(dropped_a, dropped_b);
                assert_eq!(a.next_f32(), b.next_f32(), "{} {method} N = {n}", case.name);
                nonzero += usize::from(ea != Vec3::ZERO);
            }
        }
    }
    assert!(nonzero > 100, "{nonzero}");
}
