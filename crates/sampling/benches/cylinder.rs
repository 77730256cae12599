//! Cost of one light sample from a finite cylinder per technique: view + prepare + sample +
//! pdf of the sample (`pdf`, as MIS with a BSDF sample needs it), single-threaded, on the same
//! 1024 pseudo-random configurations (Pcg32, fixed seed) for every technique; the line
//! technique (projected solid angle on the axis, the R → 0 model) for scale. `cylinder-ltc`
//! has a glossy LTC lobe (a fixed isotropic A in a frame around n); the others ignore it.
//!
//! Run: `cargo bench -p linlight-sampling --bench cylinder -- --quick`
//! (the plain timing loop and the ratios are printed at the end of every `--bench` run).

use criterion::{black_box, Criterion, Throughput};
use glam::{DMat3, DVec3, Vec3};
use linlight_sampling::cylinder::{Cylinder, CylinderSampler, CylinderTechnique, CylinderView};
use linlight_sampling::rng::Pcg32;
use linlight_sampling::{LineSampler, Segment, Technique};
use std::time::Instant;

const CONFIGURATIONS: usize = 1024;

struct Configuration {
    cylinder: Cylinder,
    x: DVec3,
    n: DVec3,
    xi: [f32; 2],
    /// Shading frame (columns x̂, ŷ, n) of the LTC lobe.
    frame: DMat3,
}

/// A glossy lobe's LTC matrix (isotropic form, rows [[a, 0, b], [0, c, 0], [d, 0, 1]]).
fn glossy_lobe() -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.3, 0.0, -0.05),
        DVec3::new(0.0, 0.35, 0.0),
        DVec3::new(0.1, 0.0, 1.0),
    )
}

/// Axes in a box around the shading point's upper hemisphere (as the line techniques' bench),
/// radii log-uniform in [1e-4, 0.2]; configurations whose x lies inside the tube are redrawn.
fn configurations() -> Vec<Configuration> {
    let mut rng = Pcg32::new(2016, 9);
    let mut in_box = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_f64();
    let mut out = Vec::with_capacity(CONFIGURATIONS);
    while out.len() < CONFIGURATIONS {
        let p0 = DVec3::new(in_box(-2.0, 2.0), in_box(-2.0, 2.0), in_box(-0.5, 2.0));
        let p1 = DVec3::new(in_box(-2.0, 2.0), in_box(-2.0, 2.0), in_box(-0.5, 2.0));
        let radius = 1e-4 * (2000f64).powf(in_box(0.0, 1.0));
        let n = DVec3::new(in_box(-1.0, 1.0), in_box(-1.0, 1.0), in_box(0.2, 1.0)).normalize();
        let x = DVec3::new(in_box(-0.1, 0.1), in_box(-0.1, 0.1), 0.0);
        let xi = [in_box(0.0, 1.0) as f32, in_box(0.0, 1.0) as f32];
        let Some(cylinder) = Cylinder::new(p0, p1, radius) else {
            continue;
        };
        if CylinderView::new(&cylinder, x, n).is_none() {
            continue;
        }
        let (t, b) = n.any_orthonormal_pair();
        let frame = DMat3::from_cols(t, b, n);
        out.push(Configuration {
            cylinder,
            x,
            n,
            xi,
            frame,
        });
    }
    out
}

/// One pass over all configurations; the returned sum keeps the work observable.
#[inline(never)]
fn pass(technique: CylinderTechnique, configurations: &[Configuration]) -> f64 {
    let mut acc = 0.0;
    for c in configurations {
        let Some(view) = CylinderView::new(&c.cylinder, c.x, c.n) else {
            continue;
        };
        if let Some(s) = technique.prepare_with_lobe(&view, Some((c.frame, glossy_lobe()))) {
            if let Some((dir, p)) = s.sample_with_pdf(c.xi) {
                acc += p + s.pdf(dir);
            }
        }
    }
    acc
}

/// The line technique on the axis (f32, as the renderer calls it), for scale.
#[inline(never)]
fn line_pass(configurations: &[Configuration]) -> f64 {
    let mut acc = 0.0;
    for c in configurations {
        let seg = Segment::new(c.cylinder.p0().as_vec3(), c.cylinder.p1().as_vec3());
        let (x, n): (Vec3, Vec3) = (c.x.as_vec3(), c.n.as_vec3());
        if let Some(s) = Technique::ProjectedSolidAngle.prepare(&seg, x, n) {
            let (dir, p) = s.sample_with_pdf(c.xi[1]);
            acc += (p + s.pdf(dir)) as f64;
        }
    }
    acc
}

fn main() {
    let configurations = configurations();
    let mut criterion = Criterion::default().configure_from_args();
    {
        let mut group = criterion.benchmark_group("cylinder view+prepare+sample+pdf");
        group.throughput(Throughput::Elements(configurations.len() as u64));
        for t in CylinderTechnique::ALL {
            group.bench_function(t.name(), |b| {
                b.iter(|| black_box(pass(t, black_box(&configurations))))
            });
        }
        group.bench_function("line projected-solid-angle", |b| {
            b.iter(|| black_box(line_pass(black_box(&configurations))))
        });
        group.finish();
    }
    criterion.final_summary();
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    const REPEATS: usize = 101;
    let configurations = &configurations;
    let mut rows: Vec<(String, Box<dyn Fn() -> f64 + '_>)> = CylinderTechnique::ALL
        .iter()
        .map(|&t| -> (String, Box<dyn Fn() -> f64 + '_>) {
            (
                t.name().to_string(),
                Box::new(move || pass(t, configurations)),
            )
        })
        .collect();
    rows.push((
        "line projected-solid-angle".to_string(),
        Box::new(|| line_pass(configurations)),
    ));
    let mut times = vec![Vec::with_capacity(REPEATS); rows.len()];
    for _ in 0..REPEATS {
        for (k, (_, f)) in rows.iter().enumerate() {
            let start = Instant::now();
            black_box(f());
            times[k].push(start.elapsed().as_secs_f64() * 1e9 / configurations.len() as f64);
        }
    }
    let stats: Vec<(f64, f64)> = times
        .into_iter()
        .map(|mut t| {
            t.sort_by(f64::total_cmp);
            (t[REPEATS / 2], t[0])
        })
        .collect();
    println!("\nplain timing loop ({REPEATS} interleaved passes, ns per configuration):");
    println!("  {:<32} {:>8} {:>8}", "", "median", "minimum");
    for ((name, _), (med, min)) in rows.iter().zip(&stats) {
        println!("  {name:<32} {med:>8.1} {min:>8.1}");
    }
    let ratio = |a: usize, b: usize| (stats[a].0 / stats[b].0, stats[a].1 / stats[b].1);
    for (label, a, b) in [
        ("cylinder-projected / cylinder-solid-angle", 2, 1),
        ("cylinder-projected / cylinder-gamito", 2, 3),
        ("cylinder-projected / cylinder-area", 2, 0),
        ("cylinder-projected / line projected-solid-angle", 2, 5),
        ("cylinder-ltc / cylinder-projected", 4, 2),
    ] {
        let (med, min) = ratio(a, b);
        println!("  ratio {label}: {med:.3} (median)  {min:.3} (minimum)");
    }
}
