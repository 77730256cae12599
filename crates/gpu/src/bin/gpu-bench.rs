//! The kernels' timing table: one light over a frame of cached shading points (default
//! 1920 × 1080), 1 and 128 samples per point, per technique, as ratios to clipped solid angle.
//!
//! Usage: `cargo run --release -p linlight-gpu --bin gpu-bench [-- WIDTH HEIGHT RUNS
//! SAMPLES...]` (default 1920 1080 3 1 128). On a
//! software adapter (lavapipe) only the ratios mean anything; the absolute times are printed
//! only on a hardware GPU.

use linlight_gpu::bench::{frame, mode_name, time_frame};
use linlight_gpu::Gpu;
use std::process::ExitCode;

fn main() -> ExitCode {
    // First: it may set an environment variable, which only a single thread may do.
    linlight_gpu::without_display_device_select();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let parse = |k: usize, default: usize| -> Result<usize, String> {
        args.get(k).map_or(Ok(default), |s| {
            s.parse::<usize>()
                .ok()
                .filter(|&v| v > 0)
                .ok_or_else(|| format!("argument {} must be a positive integer (got {s:?})", k + 1))
        })
    };
    let (width, height, runs) = match (parse(0, 1920), parse(1, 1080), parse(2, 3)) {
        (Ok(w), Ok(h), Ok(r)) => (w, h, r),
        (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => {
            eprintln!("gpu-bench: {e}; usage: gpu-bench [WIDTH HEIGHT RUNS SAMPLES...]");
            return ExitCode::from(2);
        }
    };
    let mut sample_counts = Vec::new();
    for k in 3..args.len().max(3) {
        match parse(k, 1) {
            Ok(v) => sample_counts.push(v as u32),
            Err(e) => {
                eprintln!("gpu-bench: {e}; usage: gpu-bench [WIDTH HEIGHT RUNS SAMPLES...]");
                return ExitCode::from(2);
            }
        }
    }
    if sample_counts.is_empty() {
        sample_counts = vec![1, 128];
    }
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("gpu-bench: {e} (run scripts/setup-gpu)");
            return ExitCode::from(2);
        }
    };
    let software = gpu.adapter().software;
    println!("adapter: {}", gpu.adapter());
    let points = frame(width, height);
    println!("frame {width} × {height} of cached shading points, 1 light, median of {runs} runs");
    for samples in sample_counts {
        let rows = match time_frame(&gpu, &points, samples, runs) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("gpu-bench: {e}");
                return ExitCode::from(2);
            }
        };
        let base = rows[0].median.as_secs_f64();
        println!("1 light × {samples} sample(s):");
        for r in &rows {
            let time = if software {
                String::new()
            } else {
                format!("  {:.3} ms", r.median.as_secs_f64() * 1e3)
            };
            println!(
                "  {:<36} ratio {:>5.2}{time}  (mean estimate {:.5})",
                mode_name(r.mode),
                r.median.as_secs_f64() / base,
                r.mean_estimate
            );
        }
    }
    ExitCode::SUCCESS
}
