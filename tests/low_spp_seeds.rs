//! Seed-only changes at a user's low budget are not "different": `linlight render` of every
//! committed scene at 256 spp (64×64, as the references), several seeds, compared with the
//! committed Mitsuba reference. Before the zero-sample-variance, undersampled and unseen-sample
//! rules, cornell-tube was DIFFERENT for 4 of 4 seeds (max |z| 5.9–9.9).

use std::path::Path;
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn unbiased_renders_at_256_spp_are_never_different_from_the_references() {
    let dir = std::env::temp_dir().join(format!("linlight-low-spp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut verdicts = Vec::new();
    for scene in [
        "cornell-tube",
        "floor-crossing",
        "floor-tube",
        "mesh-occluder",
        "two-tubes",
    ] {
        let seeds: &[u32] = if scene == "cornell-tube" {
            &[1, 2, 3, 4, 13]
        } else {
            &[1, 2]
        };
        for seed in seeds {
            let out = dir.join(format!("{scene}-{seed}.exr"));
            let xml = root().join(format!("references/scenes/{scene}.xml"));
            let r = Command::new(env!("CARGO_BIN_EXE_linlight"))
                .arg("render")
                .arg(&xml)
                .args([
                    "-D",
                    "res=64",
                    "--spp",
                    "256",
                    "--quiet",
                    "--seed",
                    &seed.to_string(),
                ])
                .arg("--out")
                .arg(&out)
                .output()
                .unwrap();
            assert_eq!(
                r.status.code(),
                Some(0),
                "{}",
                String::from_utf8_lossy(&r.stderr)
            );
            let c = Command::new(env!("CARGO_BIN_EXE_linlight"))
                .arg("compare")
                .arg(&out)
                .arg(root().join(format!("references/mitsuba/{scene}.exr")))
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&c.stdout).into_owned();
            // 0 consistent or 3 inconclusive; 1 would be a false alarm, 2 a broken set-up.
            assert!(
                matches!(c.status.code(), Some(0 | 3)),
                "{scene} seed {seed}: {text}{}",
                String::from_utf8_lossy(&c.stderr)
            );
            verdicts.push(format!(
                "{scene}/{seed}: {}",
                text.lines().last().unwrap_or("")
            ));
        }
    }
    eprintln!("{}", verdicts.join("\n"));
}
