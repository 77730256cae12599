//! `linlight calibrate` at a small size: 12 seed pairs per family on 24×24 films. The false
//! alarms must stay within a binomial bound of α = 0.01 and the strong injected biases must be
//! rejected in every pair (the full run's numbers are in the README).

use std::process::Command;

#[test]
fn small_calibration_is_calibrated_and_has_power() {
    let dir = std::env::temp_dir().join(format!("linlight-calibrate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("calibration.json");
    let o = Command::new(env!("CARGO_BIN_EXE_linlight"))
        .args([
            "calibrate",
            "--pairs",
            "12",
            "--res",
            "24",
            "--quiet",
            "--root",
        ])
        .arg(env!("CARGO_MANIFEST_DIR"))
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(out.contains("| unoccluded (floor-tube) | certify"), "{out}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let families = r["families"].as_array().unwrap();
    assert_eq!(families.len(), 3);
    for f in families {
        for row in f["rows"].as_array().unwrap() {
            let what = format!("{} at {}", f["family"]["name"], row["budget"]);
            // X ~ Bin(12, 0.01): P(X ≥ 2) = 0.6 %, so 2 or more false alarms fail the test.
            assert!(
                row["different"]["count"].as_u64().unwrap() <= 1,
                "{what}: {row}"
            );
            // Global 2 % and a 10 % 16×16 region: rejected in every pair.
            let global = row["power_global"].as_array().unwrap();
            let local = row["power_local"].as_array().unwrap();
            assert_eq!(global[3]["count"], 12, "{what}: global 2 %");
            assert_eq!(local[2]["count"], 12, "{what}: local 10 %");
            // Power grows with the bias.
            let counts: Vec<u64> = global
                .iter()
                .map(|p| p["count"].as_u64().unwrap())
                .collect();
            assert!(
                counts.windows(2).all(|w| w[0] <= w[1]),
                "{what}: {counts:?}"
            );
        }
    }
    // Unusable input: an unknown family, a film too small for the local region.
    for (args, needle) in [
        (vec!["--families", "specular"], "unknown family 'specular'"),
        (vec!["--res", "16"], "--res must be at least 24"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_linlight"))
            .arg("calibrate")
            .args(&args)
            .arg("--root")
            .arg(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(needle), "{err}");
    }
}
