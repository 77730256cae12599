//! Quadrature and direction helpers shared by the model tests.

use crate::{Blend, Bsdf, ConductorFresnel, Principled, RoughConductor};
use glam::DVec3;
use std::f64::consts::PI;

/// Positive nodes and weights of the 8-point Gauss–Legendre rule on [−1, 1].
const X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// Composite Gauss–Legendre (8 nodes) of f on [a, b] split into n equal panels.
pub fn gauss(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    (0..n)
        .map(|i| {
            let m = a + (i as f64 + 0.5) * h;
            X.iter()
                .zip(W)
                .map(|(&x, w)| w * (f(m - 0.5 * h * x) + f(m + 0.5 * h * x)))
                .sum::<f64>()
                * 0.5
                * h
        })
        .sum()
}

pub fn unit(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z).normalize()
}

pub fn dir(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// ∫ f(l) dω_l over the upper hemisphere per channel: composite Gauss–Legendre (8 nodes) with
/// n panels in θ and 2n in φ.
pub fn hemisphere_integral(f: impl Fn(DVec3) -> DVec3, n: usize) -> DVec3 {
    let rule = |a: f64, b: f64, panels: usize| {
        let h = (b - a) / panels as f64;
        (0..panels).flat_map(move |i| {
            let m = a + (i as f64 + 0.5) * h;
            X.iter().zip(W).flat_map(move |(&x, w)| {
                [
                    (m - 0.5 * h * x, 0.5 * h * w),
                    (m + 0.5 * h * x, 0.5 * h * w),
                ]
            })
        })
    };
    let mut total = DVec3::ZERO;
    for (theta, wt) in rule(0.0, PI / 2.0, n) {
        let mut ring = DVec3::ZERO;
        for (phi, wp) in rule(0.0, 2.0 * PI, 2 * n) {
            ring += f(dir(theta, phi)) * wp;
        }
        total += ring * (wt * theta.sin());
    }
    total
}

fn conductor(alpha: f32, fresnel: ConductorFresnel) -> Bsdf {
    Bsdf::RoughConductor(RoughConductor {
        alpha,
        fresnel,
        specular_reflectance: [0.9, 0.7, 0.5],
    })
}

fn blend(weight: f32, a: Bsdf, b: Bsdf) -> Bsdf {
    Bsdf::Blend(Blend {
        weight,
        bsdfs: Box::new([a, b]),
    })
}

/// BSDFs for bit-exactness tests: every model and nesting the lanes write out (and one deeper),
/// with the parameters that switch terms on and off.
pub fn bsdfs() -> Vec<Bsdf> {
    let gold = ConductorFresnel::Complex {
        eta: [0.143, 0.375, 1.442],
        k: [3.983, 2.386, 1.603],
    };
    let diffuse = Bsdf::Diffuse {
        reflectance: [0.25, 0.45, 0.6],
    };
    let principled = |metallic, spec_tint, flatness| {
        Bsdf::Principled(Principled {
            base_color: [0.55, 0.35, 0.25],
            roughness: 0.4,
            metallic,
            spec_tint,
            flatness,
            ..Principled::new()
        })
    };
    let mut out = vec![
        diffuse.clone(),
        conductor(0.3, ConductorFresnel::One),
        conductor(0.0, gold.clone()),
        conductor(0.2, gold.clone()),
        principled(0.0, 0.0, 0.0),
        principled(0.5, 0.3, 0.6),
        principled(1.0, 0.0, 0.0),
        Bsdf::Principled(Principled {
            eta: 1.0,
            ..Principled::new()
        }),
        blend(0.35, diffuse.clone(), conductor(0.2, gold.clone())),
        blend(
            0.5,
            blend(0.3, diffuse.clone(), principled(0.0, 0.0, 0.0)),
            diffuse,
        ),
    ];
    let two: Vec<Bsdf> = out
        .iter()
        .map(|b| Bsdf::TwoSided(Box::new(b.clone())))
        .collect();
    out.extend(two);
    out
}

/// Pairs (v, l) with l at angles k·α·(step) from the mirror direction of v, k = 0, 1, …, where
/// a lobe of roughness α is steep (the sharp conductor's α = 1e-4 has no random pair there):
/// several elevations and azimuths of v, offsets in and across the plane of incidence.
pub fn mirror_pairs(alpha: f64) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for &(theta, phi) in &[(0.0, 0.0), (0.3, 0.4), (0.9, -2.0), (1.3, 2.7), (1.5, 1.0)] {
        let (st, ct) = f64::sin_cos(theta);
        let (sp, cp) = f64::sin_cos(phi);
        let v = DVec3::new(st * cp, st * sp, ct);
        let m = DVec3::new(-v.x, -v.y, v.z);
        // Two unit vectors perpendicular to m: in and across the plane of incidence.
        let across = DVec3::Z.cross(m).try_normalize().unwrap_or(DVec3::Y);
        let within = across.cross(m);
        for t in [within, across, (within + across).normalize()] {
            for k in 0..=40 {
                let (s, c) = f64::sin_cos(0.25 * k as f64 * alpha);
                out.push((v, c * m + s * t));
            }
        }
    }
    out
}

/// Directions: random unit vectors on the sphere (both sides) and the degenerate cases
/// (v = −l: no half vector; l = v = n; grazing; exactly in the horizon).
pub fn pairs() -> Vec<(DVec3, DVec3)> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut unit = || loop {
        let d = DVec3::new(next(), next(), next());
        if d.length_squared() > 1e-3 && d.length_squared() <= 1.0 {
            return d.normalize();
        }
    };
    let mut out: Vec<(DVec3, DVec3)> = (0..2000).map(|_| (unit(), unit())).collect();
    let v = DVec3::new(0.3, -0.2, 0.9).normalize();
    let grazing = DVec3::new(1.0, 0.0, 1e-9).normalize();
    let horizon = DVec3::new(0.6, 0.8, 0.0);
    out.extend([
        (v, -v),
        (DVec3::Z, DVec3::Z),
        (-DVec3::Z, -DVec3::Z),
        (v, grazing),
        (grazing, v),
        (v, horizon),
        (horizon, v),
        (v, DVec3::new(-v.x, -v.y, v.z)),
    ]);
    out
}
