//! The paper's timing table: `linlight::figures::shading_cost` (every technique shading the cached
//! hit points of a 1920×1080 frame, Lambert + GGX, no shadow rays, 128 lights × 1 spp and
//! 1 light × 128 spp), printed as ns per sample, ms per frame, ratios to clipped solid angle,
//! and Peters / clipped and Li / Peters scalar, x8 (8-wide batches) and x16 (16-lane packets of
//! hit points, the renderer's form), each like for like.
//! `linlight figures --only timings` draws the same measurement as a table.
//!
//! Timing: by default every 8th pixel of every 8th row (32 400 pixels, 4.1 M samples per row
//! of the table; `LINLIGHT_SHADING_STRIDE=1` shades the whole frame), 5 repeats interleaved
//! across the rows (`LINLIGHT_SHADING_REPEATS`).
//!
//! Instruction-count mode for callgrind (`--toggle-collect='*shade_*'`):
//! `LINLIGHT_SHADING_ONLY=<row>:<config>` with row a technique name, `psa-x8`, `li-x8`,
//! `clipped-x8`, `psa-x16`, `li-x16`, `clipped-x16`, or `shade-x8` / `shade-x16` (the x8 / x16
//! shading loops with a stand-in sampler: what those rows cost besides their sampler), config
//! `128x1` or `1x128`, shades once and prints the number of samples
//! (instructions per sample = Ir / samples). Batches run the kernel the CPU supports (under
//! valgrind: AVX2).
//!
//! `LINLIGHT_SHADING_ISA=<avx512|avx2|baseline>` runs the x8 and x16 rows with that kernel
//! variant instead of the fastest the CPU runs (both modes), e.g. the 8-wide batch with AVX2,
//! whose f32 lanes fill a register, on a CPU with AVX-512.
//!
//! Run: `cargo bench -p linlight --bench shading`.

use linlight::figures::shading_cost::{
    hit_points, lights, measure, shade_batched, shade_packet, shade_scalar, shade_stand_in,
    Batched, RowKind, SPP,
};
use linlight_sampling::Technique;
use linlight_simd::{Isa, BATCH_LANES, PACKET_LANES};

/// The kernel variant of the x8 and x16 rows: `LINLIGHT_SHADING_ISA`, else the fastest the CPU
/// runs. Exits with status 2 on a name that is not a variant or one the CPU does not run.
fn isa() -> Isa {
    let Ok(name) = std::env::var("LINLIGHT_SHADING_ISA") else {
        return Isa::detect();
    };
    match name.parse::<Isa>() {
        Ok(isa) if isa.supported() => isa,
        Ok(isa) => {
            eprintln!(
                "LINLIGHT_SHADING_ISA: this CPU does not run the {} kernels",
                isa.name()
            );
            std::process::exit(2);
        }
        Err(e) => {
            eprintln!("LINLIGHT_SHADING_ISA: {e}");
            std::process::exit(2);
        }
    }
}

fn count_mode(spec: &str, stride: usize, isa: Isa) {
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
    let sum = match row {
        "psa-x8" => shade_batched(Batched::ProjectedSolidAngle, isa, &h, lights, spp).0,
        "li-x8" => shade_batched(Batched::Li2018, isa, &h, lights, spp).0,
        "clipped-x8" => shade_batched(Batched::ClippedSolidAngle, isa, &h, lights, spp).0,
        "psa-x16" => shade_packet(Batched::ProjectedSolidAngle, isa, &h, lights, spp).0,
        "li-x16" => shade_packet(Batched::Li2018, isa, &h, lights, spp).0,
        "clipped-x16" => shade_packet(Batched::ClippedSolidAngle, isa, &h, lights, spp).0,
        "shade-x8" => shade_stand_in(BATCH_LANES, &h, lights, spp),
        "shade-x16" => shade_stand_in(PACKET_LANES, &h, lights, spp),
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
        count_mode(&spec, stride_of(32), isa());
        return;
    }
    if !std::env::args().any(|a| a == "--bench") {
        return; // `cargo test --benches`: nothing to check here
    }
    let repeats: usize = std::env::var("LINLIGHT_SHADING_REPEATS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&s| s >= 1)
        .unwrap_or(5);
    let m = measure(stride_of(8), repeats, isa(), &|_, _| {});
    println!(
        "shading benchmark: {} of 1920x1080 hit points (stride {}), Lambert + GGX, no shadow rays, \
         {} interleaved repeats; batch kernel {}",
        m.hit_points, m.stride, m.repeats, m.isa
    );
    for c in &m.configs {
        println!(
            "\n{} ({:.1} M samples timed; uptime load: {})",
            c.name,
            c.samples / 1e6,
            c.load
        );
        println!(
            "  {:<36} {:>10} {:>10} {:>12} {:>12} {:>8} {:>8}",
            "technique", "ns/sample", "(min)", "ms/frame", "(min)", "/clipped", "(min)"
        );
        for row in &c.rows {
            let (ns, ns_min) = c.ns_per_sample(row);
            let (ms, ms_min) = c.ms_per_frame(row);
            let (r, r_min) = c.ratio_to_clipped(row);
            println!(
                "  {:<36} {ns:>10.2} {ns_min:>10.2} {ms:>12.1} {ms_min:>12.1} {r:>8.3} {r_min:>8.3}",
                row.name
            );
        }
        // Numerator / denominator, each scalar, as the x8 batch and as the x16 packet.
        let pairs = [
            (Batched::ProjectedSolidAngle, Batched::ClippedSolidAngle),
            (Batched::Li2018, Batched::ProjectedSolidAngle),
        ];
        for (ab, bb) in pairs {
            let (a, b) = (ab.technique(), bb.technique());
            let scalar = c.ratio(RowKind::Scalar(a), RowKind::Scalar(b));
            let simd = c.ratio(RowKind::Batched(ab), RowKind::Batched(bb));
            let packet = c.ratio(RowKind::Packet(ab), RowKind::Packet(bb));
            print!(
                "  {} / {}: scalar {:.3} (min {:.3}), x8 {:.3} (min {:.3}), x16 {:.3} (min {:.3})",
                a.name(),
                b.name(),
                scalar.0,
                scalar.1,
                simd.0,
                simd.1,
                packet.0,
                packet.1
            );
            if a == Technique::Li2018 {
                print!(
                    "; li2018 ran {:.2} iterations per x8 batch, {:.2} per x16 packet",
                    c.li_iterations_per_batch, c.li_iterations_per_packet
                );
            }
            println!();
        }
    }
}
