//! End-to-end: `linlight fit-ltc` fits a small table, writes the table, the JSON report and the
//! error heat map; `--check` re-fits columns and passes on that table (and on the compiled-in
//! one), fails (exit 1) on a tampered table, and rejects unusable input with exit 2.

mod common;

use common::scratch;
use std::path::Path;
use std::process::Output;

fn linlight(args: &[&str]) -> Output {
    common::command()
        .arg("fit-ltc")
        .args(args)
        .output()
        .expect("run linlight")
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn fit_writes_table_report_and_heatmap_and_check_agrees() {
    let dir = scratch("fit");
    let (table, json) = (dir.join("small.bin"), dir.join("small.json"));
    let out = linlight(&[
        "--size",
        "6",
        "--out",
        s(&table),
        "--json",
        s(&json),
        "--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let stdout = text(&out);
    assert!(stdout.contains("fit error E₁"), "{stdout}");
    assert!(stdout.contains("worst entries"), "{stdout}");

    // 28-byte header + 36 records of 7 f32.
    assert_eq!(std::fs::metadata(&table).unwrap().len(), 28 + 36 * 28);
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let entries = doc["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 36);
    for e in entries {
        let err = e["error_l1"].as_f64().unwrap();
        let rho = e["rho_s"].as_f64().unwrap();
        assert!((0.0..=2.0).contains(&err) && rho > 0.0 && rho <= 1.0, "{e}");
    }
    let png = dir.join("small-error.png");
    // PNG signature, then the IHDR chunk: width and height (big-endian) at bytes 16..24.
    let head = std::fs::read(&png).expect("heat map PNG");
    assert_eq!(&head[1..4], b"PNG");
    let dim = |o: usize| u32::from_be_bytes(head[o..o + 4].try_into().unwrap());
    assert_eq!((dim(16), dim(20)), (48, 48), "6×6 entries of 8×8 pixels");

    // --check re-fits columns of that table: bit-identical on the same machine.
    let out = linlight(&["--check", "--table", s(&table), "--columns", "5,2"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(
        text(&out).contains("bit-identical: 12/12"),
        "{}",
        text(&out)
    );
    assert!(text(&out).contains("PASS"));

    // Tamper with entry (√α 5, θ 3): b += 1e-3 (still a valid, normalised table).
    let mut bytes = std::fs::read(&table).unwrap();
    let offset = 28 + (3 * 6 + 5) * 28 + 4;
    let b = f32::from_le_bytes(bytes[offset..offset + 4].try_into().unwrap()) + 1e-3;
    bytes[offset..offset + 4].copy_from_slice(&b.to_le_bytes());
    let tampered = dir.join("tampered.bin");
    std::fs::write(&tampered, &bytes).unwrap();
    let out = linlight(&["--check", "--table", s(&tampered), "--columns", "5"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        text(&out).contains("(√α column 5, θ_o row 3)"),
        "{}",
        text(&out)
    );
    // The untouched column still passes.
    let out = linlight(&["--check", "--table", s(&tampered), "--columns", "2"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn check_of_the_compiled_in_table_passes() {
    // α = 1 column: the cheapest column of the committed table (64 entries).
    let out = linlight(&["--check", "--columns", "63"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(text(&out).contains("compiled-in table"), "{}", text(&out));
}

#[test]
fn unusable_input_exits_2() {
    let dir = scratch("unusable");
    std::fs::create_dir_all(&dir).unwrap();
    let garbage = dir.join("garbage.bin");
    std::fs::write(&garbage, b"not a table").unwrap();
    let missing = dir.join("missing.bin");
    let no_dir = dir.join("no/such/dir/t.bin");
    for args in [
        vec!["--check", "--table", s(&garbage)],
        vec!["--check", "--table", s(&missing)],
        vec!["--check", "--columns", "64"],
        vec!["--size", "1"],
        vec!["--out", s(&no_dir)],
        vec!["--threads", "0"],
        vec!["--table", s(&garbage)],   // --table needs --check
        vec!["--check", "--size", "8"], // --check uses the table's own size
    ] {
        let out = linlight(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out));
    }
    assert!(text(&linlight(&["--check", "--table", s(&garbage)])).contains("not a GGX LTC table"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn help_has_examples_and_runtime() {
    let out = linlight(&["--help"]);
    assert_eq!(out.status.code(), Some(0));
    let help = text(&out);
    assert!(
        help.contains("Examples:") && help.contains("Runtime"),
        "{help}"
    );
}
