//! The kernels on the adapter wgpu finds (lavapipe without a GPU): agreement with the Rust f32
//! samplers, the backward-error sweep, the table lookup and the MIS weights. Without an adapter
//! every test prints a loud SKIPPED line and passes, unless LINLIGHT_REQUIRE_ADAPTER=1
//! (scripts/test's rust stage, after scripts/setup-gpu), where a missing adapter fails.

use linlight_gpu::certify::{
    agreement, backward_error_sweep, lookup_difference, mis_difference, support_ends,
    AGREEMENT_BOUND, BACKWARD_ERROR_BOUND, SUPPORT_END_BOUND,
};
use linlight_gpu::mutate::{mutated, Mutation};
use linlight_gpu::{Gpu, Technique};
use linlight_sampling::backward_error::SweepConfig;
use linlight_verify::configs::{edge_configs, ltc_table_configs, random_configs};
use std::sync::OnceLock;

fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Option<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| match Gpu::new() {
        Ok(g) => {
            eprintln!("adapter: {}", g.adapter());
            Some(g)
        }
        Err(e) => {
            let required = std::env::var("LINLIGHT_REQUIRE_ADAPTER").as_deref() == Ok("1");
            assert!(!required, "LINLIGHT_REQUIRE_ADAPTER=1 but {e}");
            eprintln!("SKIPPED: GPU kernels: {e} (run scripts/setup-gpu)");
            None
        }
    })
    .as_ref()
}

#[test]
fn prints_the_adapter() {
    let Some(gpu) = gpu() else { return };
    let a = gpu.adapter();
    assert!(!a.name.is_empty());
    println!("adapter: {a}");
}

fn suite_configs() -> Vec<linlight_verify::configs::Config> {
    let mut c = random_configs(1, 64);
    c.extend(edge_configs());
    c.extend(ltc_table_configs());
    c
}

/// The bound of the per-sample agreement (see `linlight_gpu::certify::AGREEMENT_BOUND`), and
/// that both prepare a sampler for the same configurations.
#[test]
fn samples_agree_with_the_rust_f32_samplers() {
    let Some(gpu) = gpu() else { return };
    let configs = suite_configs();
    for t in Technique::ALL {
        let a = agreement(gpu, t, &configs, 256).unwrap();
        println!(
            "{}: {} configs, direction [ulp of 1] {}, density [ulp] {}, worst {}",
            a.technique, a.configs, a.direction, a.density, a.worst_config
        );
        assert!(a.prepared_mismatch.is_empty(), "{:?}", a.prepared_mismatch);
        assert!(
            a.direction.count >= configs.len() * 200,
            "{}",
            a.direction.count
        );
        if let Err(e) = AGREEMENT_BOUND.check(&a) {
            panic!("{}: {e}", a.technique);
        }
    }
}

/// The kernels' support ends within 3ε of the reference's on every configuration of the suite
/// (the precision contract of docs/kernels.md): at every direction near an end the kernels'
/// pdf is one the reference has within [`SUPPORT_END_BOUND`], so that the cross-density check
/// of `linlight samplers --backend gpu` holds at any sample count, not only at the directions
/// its random queries reach. The configurations include those where a support tolerance
/// wider than the reference's showed in that check at 10⁵ samples (named below).
#[test]
fn support_ends_match_the_reference() {
    let Some(gpu) = gpu() else { return };
    let configs = suite_configs();
    for name in ["random-017", "random-037", "random-039", "short-crossing"] {
        assert!(configs.iter().any(|c| c.name == name), "{name}");
    }
    for t in Technique::ALL {
        let ends = support_ends(gpu, t, &configs).unwrap();
        println!(
            "{}: {} directions probed, {} mismatches",
            ends.technique, ends.probes, ends.mismatches
        );
        assert!(ends.probes > configs.len() * 200, "{}", ends.probes);
        assert_eq!(
            ends.mismatches,
            0,
            "{}: support ends more than {SUPPORT_END_BOUND:e} rad from the reference's:\n{}",
            ends.technique,
            ends.examples.join("\n")
        );
    }
}

/// The sweep of `linlight backward-error` on the kernels' inversion: two Halley steps within
/// the Rust f32 path's bound 2e-5 (ξ guard included), one step far outside it (the control).
#[test]
fn backward_error_sweep_on_the_kernels() {
    let Some(gpu) = gpu() else { return };
    for steps in [2, 1] {
        let row = backward_error_sweep(gpu, &SweepConfig::default(), steps).unwrap();
        println!(
            "{steps} steps: worst {:.3e} outside the guard, {:.3e} with it, near ends {:.3e}, {} samples",
            row.worst_outside_guard, row.worst_including_guard, row.worst_near_ends, row.samples
        );
        assert!(row.samples > 10_000_000, "{}", row.samples);
        if steps == 2 {
            assert!(row.worst_including_guard <= BACKWARD_ERROR_BOUND, "{row:?}");
        } else {
            assert!(
                row.worst_outside_guard > 100.0 * BACKWARD_ERROR_BOUND,
                "{row:?}"
            );
        }
    }
}

/// The table lookup within 1e-6 of the Rust one (the entries are O(1); the acos polynomial and
/// the weights round differently), the MIS weights within 1e-6 (including zero densities and
/// ratios of 1e60).
#[test]
fn lookup_and_mis_match_the_rust_ones() {
    let Some(gpu) = gpu() else { return };
    let lookup = lookup_difference(gpu, 40).unwrap();
    let mis = mis_difference(gpu).unwrap();
    println!("lookup {lookup:.3e}, mis {mis:.3e}");
    assert!(lookup <= 1e-6, "{lookup}");
    assert!(mis <= 1e-6, "{mis}");
}

#[test]
fn mutations_compile() {
    let Some(_) = gpu() else { return };
    for m in Mutation::ALL {
        Gpu::with_source(&mutated(linlight_kernels::WGSL, m)).unwrap();
    }
}
