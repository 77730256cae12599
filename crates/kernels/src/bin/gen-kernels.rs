//! Regenerates crates/kernels/generated/ from crates/kernels/shaders/linlight.wgsl.
//!
//! Usage: `cargo run -p linlight-kernels --bin gen-kernels [-- --check]`. With `--check` nothing
//! is written; the exit code is 1 when a committed file differs from what the source generates.
//! Exit 2 when the source does not translate.

use std::process::ExitCode;

fn main() -> ExitCode {
    let check = match std::env::args().nth(1).as_deref() {
        None => false,
        Some("--check") => true,
        Some(other) => {
            eprintln!("gen-kernels: unknown argument {other:?} (expected nothing or --check)");
            return ExitCode::from(2);
        }
    };
    let files = match linlight_kernels::generate(linlight_kernels::WGSL) {
        Ok(files) => files,
        Err(e) => {
            eprintln!("gen-kernels: {e}");
            return ExitCode::from(2);
        }
    };
    let dir = linlight_kernels::generated_dir();
    let mut stale = 0;
    for file in &files {
        let path = dir.join(&file.name);
        let same = std::fs::read(&path).is_ok_and(|old| old == file.bytes);
        if check {
            if !same {
                eprintln!(
                    "gen-kernels: {} is not what the source generates",
                    path.display()
                );
                stale += 1;
            }
            continue;
        }
        if let Err(e) =
            std::fs::create_dir_all(&dir).and_then(|_| std::fs::write(&path, &file.bytes))
        {
            eprintln!("gen-kernels: cannot write {}: {e}", path.display());
            return ExitCode::from(2);
        }
        println!(
            "{} {} ({} bytes)",
            if same { "unchanged" } else { "wrote" },
            path.display(),
            file.bytes.len()
        );
    }
    if stale > 0 {
        eprintln!("gen-kernels: {stale} file(s) stale: run `cargo run -p linlight-kernels --bin gen-kernels`");
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}
