use super::*;
use std::path::Path;
use std::process::Command;

fn committed(name: &str) -> Vec<u8> {
    let path = generated_dir().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

#[test]
fn committed_translations_are_what_the_source_generates() {
    let files = generate(WGSL).unwrap();
    assert_eq!(files.len(), ENTRY_POINTS.len() + 3);
    for file in &files {
        assert!(
            committed(&file.name) == file.bytes,
            "generated/{} is stale: run `cargo run -p linlight-kernels --bin gen-kernels`",
            file.name
        );
    }
    // Deterministic: a second translation is byte-identical.
    assert_eq!(generate(WGSL).unwrap(), files);
}

#[test]
fn source_validates_with_both_compute_entry_points() {
    let (module, _) = parse_and_validate(WGSL).unwrap();
    let names: Vec<_> = module
        .entry_points
        .iter()
        .map(|e| (e.name.as_str(), e.stage, e.workgroup_size))
        .collect();
    for name in ENTRY_POINTS {
        assert!(
            names.contains(&(name, ShaderStage::Compute, [WORKGROUP_SIZE, 1, 1])),
            "{names:?}"
        );
    }
}

#[test]
fn a_broken_source_is_rejected_with_its_line() {
    let broken = WGSL.replace("fn ll_psa_cdf(", "fn ll_psa_cdf(oops ");
    let err = generate(&broken).unwrap_err();
    assert!(
        err.contains("WGSL parse error") && err.contains("ll_psa_cdf"),
        "{err}"
    );
}

#[test]
fn spirv_and_glsl_parse_back_and_validate_with_naga() {
    let spv = committed(SPIRV_NAME);
    let module = naga::front::spv::parse_u8_slice(&spv, &Default::default()).unwrap();
    validate(&module).unwrap();
    assert_eq!(module.entry_points.len(), ENTRY_POINTS.len());
    for entry_point in ENTRY_POINTS {
        let glsl = String::from_utf8(committed(&glsl_name(entry_point))).unwrap();
        let options = naga::front::glsl::Options::from(ShaderStage::Compute);
        let module = naga::front::glsl::Frontend::default()
            .parse(&options, &glsl)
            .unwrap_or_else(|e| panic!("{entry_point}: {e:?}"));
        validate(&module).unwrap_or_else(|e| panic!("{entry_point}: {e}"));
    }
}

#[test]
fn msl_has_both_kernels() {
    let msl = String::from_utf8(committed(MSL_NAME)).unwrap();
    for entry_point in ENTRY_POINTS {
        assert!(
            msl.contains(&format!("kernel void {entry_point}(")),
            "{entry_point}"
        );
    }
}

/// Runs an external validator; `None` (with a loud message) when it is not installed, unless
/// LINLIGHT_REQUIRE_GPU_TOOLS=1 (scripts/test sets it after scripts/setup-gpu), where a missing
/// tool fails the test.
fn run_tool(tool: &str, args: &[&str]) -> Option<(bool, String)> {
    match Command::new(tool).args(args).output() {
        Ok(out) => {
            let text = format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            Some((out.status.success(), text))
        }
        Err(e) => {
            let required = std::env::var("LINLIGHT_REQUIRE_GPU_TOOLS").as_deref() == Ok("1");
            assert!(
                !required,
                "{tool} is required (LINLIGHT_REQUIRE_GPU_TOOLS=1): {e}"
            );
            eprintln!(
                "SKIPPED: {tool} not found ({e}); run scripts/setup-gpu to install it \
                 (Debian: spirv-tools, glslang-tools)"
            );
            None
        }
    }
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

#[test]
fn spirv_val_accepts_the_spirv() {
    let path = generated_dir().join(SPIRV_NAME);
    if let Some((ok, text)) = run_tool("spirv-val", &[path_str(&path)]) {
        assert!(ok, "spirv-val rejects {}: {text}", path.display());
    }
}

#[test]
fn glslang_accepts_the_glsl_and_the_hlsl() {
    for entry_point in ENTRY_POINTS {
        let path = generated_dir().join(glsl_name(entry_point));
        if let Some((ok, text)) = run_tool("glslangValidator", &["-S", "comp", path_str(&path)]) {
            assert!(ok, "glslangValidator rejects {}: {text}", path.display());
        }
        // glslang's HLSL front end, compiled to SPIR-V, which spirv-val then checks.
        let hlsl = generated_dir().join(HLSL_NAME);
        let out = std::env::temp_dir().join(format!(
            "linlight-kernels-{}-{entry_point}.spv",
            std::process::id()
        ));
        let args = [
            "-D",
            "-V",
            "-S",
            "comp",
            "-e",
            entry_point,
            "-o",
            path_str(&out),
            path_str(&hlsl),
        ];
        if let Some((ok, text)) = run_tool("glslangValidator", &args) {
            assert!(
                ok,
                "glslangValidator rejects the HLSL ({entry_point}): {text}"
            );
            if let Some((ok, text)) = run_tool("spirv-val", &[path_str(&out)]) {
                assert!(
                    ok,
                    "spirv-val rejects the HLSL's SPIR-V ({entry_point}): {text}"
                );
            }
            let _ = std::fs::remove_file(&out);
        }
    }
}
