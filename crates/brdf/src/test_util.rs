//! Quadrature and direction helpers shared by the model tests.

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
