//! Every kernel of the workspace is compiled for exactly the features that `Isa::supported`
//! checks: a `#[target_feature]` list with a feature it does not detect would run that
//! feature's instructions on CPUs without it.

use std::path::{Path, PathBuf};

const AVX2: &str = "avx2,fma,bmi1,bmi2,lzcnt,popcnt";
const AVX512: &str = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt";

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn every_target_feature_list_is_one_the_dispatch_detects() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut files = Vec::new();
    for dir in ["crates", "src", "benches", "examples", "tests"] {
        if root.join(dir).is_dir() {
            rust_files(&root.join(dir), &mut files);
        }
    }
    let key = "target_feature(enable=\"";
    let mut seen = [0usize; 2];
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        // Without white space: rustfmt breaks long attributes over lines.
        let text: String = text.chars().filter(|c| !c.is_whitespace()).collect();
        for (at, _) in text.match_indices(key) {
            let rest = &text[at + key.len()..];
            let list = &rest[..rest.find('"').unwrap()];
            match list {
                AVX2 => seen[0] += 1,
                AVX512 => seen[1] += 1,
                _ => panic!("{}: target_feature list {list:?}", file.display()),
            }
        }
    }
    // The kernels exist: the scan found the workspace's sources.
    assert!(seen[0] > 10 && seen[1] > 10, "lists found: {seen:?}");
}
