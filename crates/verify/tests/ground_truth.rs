//! Closed-form ground truth: unshadowed Lambertian shading of a linear light,
//! L_o = ρ/π · K · Ω⊥_R, against the Monte Carlo estimate K·(ρ/π)·(n·ω)⁺/p_R of every unbiased
//! technique (docs/sampler-suite.md; the closed form Ω⊥_R of the paper, section "Linear light").
//!
//! Per (technique, configuration): N = 100 000 samples from a fixed seed; pass iff
//! |estimate − truth| ≤ 4 SE + 1e-5·truth (the f32 floor of the suite's normalisation bound).
//! 7 techniques × 6 configurations = 42 tests at 4 SE: family-wise false-alarm rate
//! ≤ 42 · 6.3e-5 ≈ 0.3 %. Peters' sampler is proportional to the integrand: its per-sample
//! relative standard deviation must be < 1e-3.

use glam::Vec3;
use linlight_sampling::philox::CounterRng;
use linlight_sampling::{LineFrame, LineSampler, Segment, Technique};
use linlight_verify::configs::reference_configs;

const RHO: f64 = 0.7;
const K: f64 = 2.5;
const N: usize = 100_000;

/// The shared fixture of the verify crate (`configs::reference_configs`).
fn configs() -> Vec<(String, Segment, Vec3, Vec3)> {
    reference_configs()
        .into_iter()
        .map(|c| (c.name.clone(), c.segment(), c.x(), c.n()))
        .collect()
}

/// Returns (estimate, standard error, per-sample relative std) and the truth.
fn shade(
    t: Technique,
    seg: &Segment,
    x: Vec3,
    n: Vec3,
    stream: u32,
) -> Option<(f64, f64, f64, f64)> {
    let truth = LineFrame::new(seg, x)?
        .clip_to_horizon(n)?
        .projected_solid_angle(n) as f64
        * RHO
        / std::f64::consts::PI
        * K;
    let s = t
        .prepare(seg, x, n)
        .expect("light above the horizon must be prepared");
    let mut rng = CounterRng::new(2021, [stream, 0, 0]);
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    for _ in 0..N {
        let (dir, p) = s.sample_with_pdf(rng.next_f32());
        let cos = (n.dot(dir) as f64).max(0.0);
        let v = if cos > 0.0 {
            K * RHO / std::f64::consts::PI * cos / p as f64
        } else {
            0.0
        };
        assert!(v.is_finite(), "{t}: non-finite estimate (p = {p})");
        sum += v;
        sum_sq += v * v;
    }
    let mean = sum / N as f64;
    let var = (sum_sq / N as f64 - mean * mean).max(0.0) * N as f64 / (N as f64 - 1.0);
    Some((mean, (var / N as f64).sqrt(), var.sqrt() / truth, truth))
}

fn check(t: Technique) {
    for (i, (name, seg, x, n)) in configs().into_iter().enumerate() {
        let (est, se, rel_std, truth) = shade(t, &seg, x, n, i as u32).expect(&name);
        let tol = 4.0 * se + 1e-5 * truth;
        eprintln!("{t} {name}: {est:.7} ± {se:.2e} vs {truth:.7} (rel. std {rel_std:.2e})");
        assert!(
            (est - truth).abs() <= tol,
            "{t} {name}: {est} vs {truth} (tolerance {tol:.3e})"
        );
        if t == Technique::ProjectedSolidAngle {
            assert!(
                rel_std < 1e-3,
                "{t} {name}: relative std {rel_std:.3e} ≥ 1e-3"
            );
        }
    }
}

#[test]
fn paper_sanity_value_of_the_closed_form() {
    // ρ/π·K·Ω⊥_R with Ω⊥_R = 1 + π/2 (the paper); the truth used by every test below.
    let (_, seg, x, n) = configs().swap_remove(0);
    let truth = LineFrame::new(&seg, x)
        .unwrap()
        .clip_to_horizon(n)
        .unwrap()
        .projected_solid_angle(n);
    assert!((truth as f64 - (1.0 + std::f64::consts::FRAC_PI_2)).abs() < 1e-6);
}

#[test]
fn solid_angle() {
    check(Technique::SolidAngle);
}

#[test]
fn clipped_solid_angle() {
    check(Technique::ClippedSolidAngle);
}

#[test]
fn area() {
    check(Technique::Area);
}

#[test]
fn hart_linear() {
    check(Technique::HartLinear);
}

#[test]
fn hart_quadratic() {
    check(Technique::HartQuadratic);
}

#[test]
fn li2018() {
    check(Technique::Li2018);
}

#[test]
fn projected_solid_angle() {
    check(Technique::ProjectedSolidAngle);
}

#[test]
fn every_unbiased_technique_has_a_test() {
    // Guard: adding a technique to UNBIASED must add a test above.
    assert_eq!(Technique::UNBIASED.len(), 7);
}
