//! Throughput of the renderer: M samples/s, one sample = camera ray + one light sample + shadow
//! ray, on references/scenes/cornell-tube.xml at 256×256 with 2 threads — the scene and settings
//! of `scripts/bench-render` (which also runs Mitsuba in the same run and measures memory).
//! `cargo bench -p linlight-render --bench render`; techniques via LINLIGHT_BENCH_TECHNIQUE
//! (comma-separated, default projected-solid-angle,clipped-solid-angle).

use linlight_render::{render, xml, RenderOptions};
use linlight_sampling::Technique;
use std::time::Instant;

/// CPU seconds (user + system) of this process, from /proc/self/stat (Linux; None elsewhere).
/// On a loaded machine wall time says little; samples per CPU second still compare runs.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

fn main() {
    let techniques: Vec<Technique> = std::env::var("LINLIGHT_BENCH_TECHNIQUE")
        .unwrap_or_else(|_| "projected-solid-angle,clipped-solid-angle".into())
        .split(',')
        .map(|t| t.parse().expect("LINLIGHT_BENCH_TECHNIQUE"))
        .collect();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../references/scenes/cornell-tube.xml");
    let scene = xml::load_scene(&path, &[("res".into(), "256".into())]).expect("cornell-tube.xml");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for technique in techniques {
        let opts = RenderOptions {
            spp: 16,
            passes: 1,
            seed: 1,
            method: technique.into(),
            light_samples: 1,
            lights: Default::default(),
            noise: Default::default(),
            cylinders: linlight_render::Cylinders::Line,
        };
        let samples = 256.0 * 256.0 * opts.spp as f64;
        let mut rates = Vec::new();
        let cpu0 = cpu_seconds();
        for _ in 0..5 {
            let start = Instant::now();
            let img = pool.install(|| render(&scene, &opts, &|_, _| {})).unwrap();
            let secs = start.elapsed().as_secs_f64();
            assert!(img.mean.iter().all(|m| m.iter().all(|c| c.is_finite())));
            rates.push(samples / secs / 1e6);
        }
        let cpu = cpu0.zip(cpu_seconds()).map(|(a, b)| b - a);
        rates.sort_by(f64::total_cmp);
        println!(
            "render/cornell-tube-256x256/{technique}/2 threads: median {:.2} M samples/s (best {:.2}, {} spp)",
            rates[rates.len() / 2],
            rates[rates.len() - 1],
            opts.spp
        );
        if let Some(cpu) = cpu.filter(|c| *c > 0.0) {
            println!(
                "  per CPU second: {:.2} M samples/s per thread ({:.2} s CPU for 5 renders)",
                5.0 * samples / cpu / 1e6,
                cpu
            );
        }
    }
}
