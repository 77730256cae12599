//! Cost of one light sample per technique: prepare + sample + pdf (`sample_with_pdf`, which is
//! what a renderer calls), single-threaded, on the same 1024 pseudo-random configurations
//! (Pcg32, fixed seed) for every technique.
//!
//! Run: `cargo bench -p linlight-sampling --bench techniques -- --quick`
//! (a criterion filter such as `-- --quick hart` restricts the criterion groups; the plain
//! timing loop and the ratios are printed at the end of every `--bench` run).

use criterion::{black_box, Criterion, Throughput};
use glam::Vec3;
use linlight_sampling::batch::{
    sample_clipped_solid_angle_packet, sample_clipped_solid_angle_with,
    sample_projected_solid_angle_packet, sample_projected_solid_angle_slice,
    sample_projected_solid_angle_with, BatchProblems, BatchSamples, Isa, LineProblems, LineSamples,
    BATCH_LANES, PACKET_LANES,
};
use linlight_sampling::li2018::Li2018;
use linlight_sampling::rng::Pcg32;
use linlight_sampling::{LineSampler, Segment, Technique};
use linlight_simd::set3;
use std::time::Instant;

/// Techniques skipped because they are still `todo!()` stubs (while written in parallel on
/// another branch). Empty since Li2018 and ProjectedSolidAngle landed on main.
const PENDING: &[Technique] = &[];

const CONFIGURATIONS: usize = 1024;

struct Configuration {
    segment: Segment,
    x: Vec3,
    n: Vec3,
    xi: f32,
}

/// Segments in a box around the shading point's upper hemisphere: most lie above the horizon,
/// some cross it, a few lie entirely below (then every clipping technique returns None, which is
/// part of the cost a renderer pays). Normals are random unit vectors with n_z > 0.2.
fn configurations() -> Vec<Configuration> {
    let mut rng = Pcg32::new(2021, 8);
    let mut in_box = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let mut out = Vec::with_capacity(CONFIGURATIONS);
    while out.len() < CONFIGURATIONS {
        let begin = Vec3::new(in_box(-2.0, 2.0), in_box(-2.0, 2.0), in_box(-0.5, 2.0));
        let end = Vec3::new(in_box(-2.0, 2.0), in_box(-2.0, 2.0), in_box(-0.5, 2.0));
        let n = Vec3::new(in_box(-1.0, 1.0), in_box(-1.0, 1.0), in_box(0.2, 1.0)).normalize();
        let x = Vec3::new(in_box(-0.1, 0.1), in_box(-0.1, 0.1), 0.0);
        let xi = in_box(0.0, 1.0);
        out.push(Configuration {
            segment: Segment::new(begin, end),
            x,
            n,
            xi,
        });
    }
    out
}

/// One pass over all configurations; the returned sum keeps the work observable.
#[inline(never)]
fn pass(technique: Technique, configurations: &[Configuration]) -> f32 {
    let mut acc = 0.0f32;
    for c in configurations {
        // By reference, as the renderer does (see `Technique::prepare`: moving the sampler out
        // of the Option costs a failed store forward per light sample).
        if let Some(p) = &technique.prepare(&c.segment, c.x, c.n) {
            let (dir, pdf) = p.sample_with_pdf(c.xi);
            acc += dir.x + pdf;
        }
    }
    acc
}

/// The configurations as batches of [`BATCH_LANES`] (1024 = 128 full batches).
fn batches(configurations: &[Configuration]) -> Vec<BatchProblems> {
    configurations
        .chunks(BATCH_LANES)
        .map(|chunk| {
            let mut b = BatchProblems::default();
            for (i, c) in chunk.iter().enumerate() {
                set3(&mut b.begin, i, c.segment.begin);
                set3(&mut b.end, i, c.segment.end);
                set3(&mut b.x, i, c.x);
                set3(&mut b.n, i, c.n);
                b.xi[i] = c.xi;
            }
            b
        })
        .collect()
}

/// A kernel of N lanes (prepare + sample + pdf of every lane): an 8-wide batch or, with
/// N = 16, a packet entry point (the renderer's: 16 lanes per call, built in place, not joined
/// from two batches as the slice does).
type LaneKernel<const N: usize> = fn(Isa, &LineProblems<N>) -> LineSamples<N>;

/// An 8-wide kernel.
type Kernel = LaneKernel<BATCH_LANES>;

/// A 16-lane packet kernel.
type PacketKernel = LaneKernel<PACKET_LANES>;

/// The batched techniques: row name and kernel.
const KERNELS: [(&str, Kernel); 2] = [
    ("projected-solid-angle", sample_projected_solid_angle_with),
    ("clipped-solid-angle", sample_clipped_solid_angle_with),
];

/// One pass of an N-lane kernel over all configurations (same work as `pass` for its
/// technique, same checksum).
#[inline(never)]
fn lanes_pass<const N: usize>(kernel: LaneKernel<N>, isa: Isa, inputs: &[LineProblems<N>]) -> f32 {
    let mut acc = 0.0f32;
    for input in inputs {
        let out = kernel(isa, input);
        for i in 0..N {
            acc += out.dir[0][i] + out.pdf[i];
        }
    }
    acc
}

/// One pass through the slice entry point (two batches as one packet per call).
#[inline(never)]
fn slice_pass(isa: Isa, batches: &[BatchProblems], out: &mut [BatchSamples]) -> f32 {
    sample_projected_solid_angle_slice(isa, batches, out);
    out.iter()
        .map(|o| {
            (0..BATCH_LANES)
                .map(|i| o.dir[0][i] + o.pdf[i])
                .sum::<f32>()
        })
        .sum()
}

fn active() -> impl Iterator<Item = Technique> {
    Technique::ALL.into_iter().filter(|t| !PENDING.contains(t))
}

fn criterion_groups(c: &mut Criterion, configurations: &[Configuration]) {
    let mut group = c.benchmark_group("prepare+sample+pdf");
    group.throughput(Throughput::Elements(configurations.len() as u64));
    for technique in active() {
        group.bench_function(technique.name(), |b| {
            b.iter(|| black_box(pass(technique, black_box(configurations))))
        });
    }
    group.finish();
}

/// A timed row: a name and one pass over all configurations.
type Row<'a> = (String, Box<dyn Fn() -> f32 + 'a>);

/// Mean time per configuration in ns of single passes, (median, minimum) over repeats. Repeats
/// are interleaved across the rows (round robin), so that a change of machine load hits all of
/// them alike. On a loaded machine the minimum (a pass that was not descheduled) is the
/// reproducible figure; the median shows the load.
fn plain_timing(rows: &[Row], configurations: usize) -> Vec<(f64, f64)> {
    const REPEATS: usize = 301;
    let mut times = vec![Vec::with_capacity(REPEATS); rows.len()];
    for _ in 0..REPEATS {
        for (k, (_, pass)) in rows.iter().enumerate() {
            let start = Instant::now();
            black_box(pass());
            times[k].push(start.elapsed().as_secs_f64() * 1e9 / configurations as f64);
        }
    }
    times
        .into_iter()
        .map(|mut t| {
            t.sort_by(f64::total_cmp);
            (t[REPEATS / 2], t[0])
        })
        .collect()
}

/// Instruction-count mode for `valgrind --tool=callgrind --toggle-collect='*pass*'`:
/// `LINLIGHT_BENCH_ONLY=<technique> <bench binary>` runs 10 passes of that technique and exits
/// (no criterion, no timing), so that instructions per configuration = Ir(pass) / (10·1024).
/// `batch-<isa>` runs the projected-solid-angle batch, `clipped-batch-<isa>` the clipped
/// solid angle batch.
fn count_mode(name: &str, configurations: &[Configuration]) {
    let mut acc = 0.0;
    let batch = match name.strip_prefix("clipped-") {
        Some(rest) => rest.strip_prefix("batch-").map(|isa| (KERNELS[1].1, isa)),
        None => name.strip_prefix("batch-").map(|isa| (KERNELS[0].1, isa)),
    };
    if let Some((kernel, isa)) = batch {
        let isa: Isa = isa
            .parse()
            .expect("LINLIGHT_BENCH_ONLY=[clipped-]batch-<avx512|avx2|baseline>");
        let batches = batches(configurations);
        for _ in 0..10 {
            acc += black_box(lanes_pass(kernel, isa, black_box(&batches)));
        }
    } else {
        let technique =
            Technique::from_name(name).expect("unknown technique in LINLIGHT_BENCH_ONLY");
        for _ in 0..10 {
            acc += black_box(pass(technique, black_box(configurations)));
        }
    }
    println!("{name}: checksum {acc}");
}

fn main() {
    let configurations = configurations();
    if let Ok(name) = std::env::var("LINLIGHT_BENCH_ONLY") {
        count_mode(&name, &configurations);
        return;
    }
    let mut criterion = Criterion::default().configure_from_args();
    criterion_groups(&mut criterion, &configurations);
    criterion.final_summary();

    // `cargo test --benches` runs each benchmark once (no `--bench` argument): skip the loop.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    println!("\nplain timing loop (301 interleaved single passes, ns per configuration):");
    println!("  {:<40} {:>8}    {:>8}", "", "median", "minimum");
    let techniques: Vec<Technique> = active().collect();
    let batches = batches(&configurations);
    let packets: Vec<LineProblems<PACKET_LANES>> = batches
        .chunks_exact(2)
        .map(|p| LineProblems::from_batches(&p[0], &p[1]))
        .collect();
    assert_eq!(2 * packets.len(), batches.len(), "whole packets");
    let packets = &packets;
    let out = std::cell::RefCell::new(vec![BatchSamples::default(); batches.len()]);
    let out = &out;
    let mut rows: Vec<Row> = techniques
        .iter()
        .map(|&t| -> Row {
            let c = &configurations;
            (
                t.name().to_string(),
                Box::new(move || pass(t, black_box(c))),
            )
        })
        .collect();
    let b = &batches;
    // Row index of each (kernel, ISA) batch row, for the like-for-like ratios.
    let mut batch_rows = Vec::new();
    for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
        for (k, (name, kernel)) in KERNELS.into_iter().enumerate() {
            batch_rows.push((k, isa, rows.len(), kernel));
            rows.push((
                format!("{name} batch x{BATCH_LANES} {}", isa.name()),
                Box::new(move || lanes_pass(kernel, isa, black_box(b))),
            ));
        }
        rows.push((
            format!("  psa, slice of batches {}", isa.name()),
            Box::new(move || slice_pass(isa, black_box(b), &mut out.borrow_mut())),
        ));
        let packet_kernels: [(&str, PacketKernel); 2] = [
            ("psa", sample_projected_solid_angle_packet),
            ("clipped", sample_clipped_solid_angle_packet),
        ];
        for (name, kernel) in packet_kernels {
            rows.push((
                format!("  {name}, packets x{PACKET_LANES} {}", isa.name()),
                Box::new(move || lanes_pass(kernel, isa, black_box(packets))),
            ));
        }
    }
    let times = plain_timing(&rows, configurations.len());
    let mut ns = std::collections::HashMap::new();
    for (k, (name, _)) in rows.iter().enumerate() {
        let (median, min) = times[k];
        let prepared = match techniques.get(k) {
            Some(&t) => configurations
                .iter()
                .filter(|c| t.prepare(&c.segment, c.x, c.n).is_some())
                .count(),
            None => {
                let kernel = batch_rows
                    .iter()
                    .find(|r| r.2 == k)
                    .map_or(KERNELS[0].1, |r| r.3);
                batches
                    .iter()
                    .map(|b| kernel(Isa::Baseline, b).mask.count_ones() as usize)
                    .sum()
            }
        };
        println!(
            "  {name:<40} {median:8.2} ns {min:8.2} ns   ({prepared}/{} prepared)",
            CONFIGURATIONS
        );
        if let Some(&t) = techniques.get(k) {
            ns.insert(t, (median, min));
        }
    }
    let ratio = |a: Technique, b: Technique| match (ns.get(&a), ns.get(&b)) {
        (Some(x), Some(y)) => format!("{:.3} (median)  {:.3} (minimum)", x.0 / y.0, x.1 / y.1),
        _ => "n/a (pending)".to_string(),
    };
    println!(
        "  ratio li2018 / projected-solid-angle:              {}",
        ratio(Technique::Li2018, Technique::ProjectedSolidAngle)
    );
    println!(
        "  ratio projected-solid-angle / clipped-solid-angle: {}",
        ratio(Technique::ProjectedSolidAngle, Technique::ClippedSolidAngle)
    );
    // Like for like: both techniques 8-wide with the same ISA.
    for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
        let row = |kernel: usize| {
            let r = batch_rows.iter().find(|r| r.0 == kernel && r.1 == isa);
            times[r.expect("a row per kernel and ISA").2]
        };
        let (psa, clipped) = (row(0), row(1));
        println!(
            "  ratio projected-solid-angle x{BATCH_LANES} / clipped-solid-angle x{BATCH_LANES} ({}): \
             {:.3} (median)  {:.3} (minimum)",
            isa.name(),
            psa.0 / clipped.0,
            psa.1 / clipped.1
        );
    }
    // Li et al.'s cost is proportional to its iteration count (mean, not the worst case that a
    // GPU warp would wait for).
    let evaluations: Vec<u32> = configurations
        .iter()
        .filter_map(|c| {
            Li2018::prepare(&c.segment, c.x, c.n).map(|l| (l.sample_l(c.xi).1 + 1).min(20))
        })
        .collect();
    println!(
        "  li2018: {:.2} CDF evaluations per sample on average (max {})",
        evaluations.iter().sum::<u32>() as f64 / evaluations.len() as f64,
        evaluations.iter().max().unwrap_or(&0)
    );
}
