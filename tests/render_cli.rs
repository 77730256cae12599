//! `linlight render` rejects unusable input with exit code 2 and a one-line reason.

use std::process::Command;

fn linlight(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_linlight"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_input_exits_with_2() {
    let dir = std::env::temp_dir().join(format!("linlight-render-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("empty.xml");
    std::fs::write(&scene, "<scene version=\"3.0.0\">").unwrap();
    let s = scene.to_str().unwrap();
    for args in [
        vec!["render", "/nonexistent/scene.xml"],
        vec!["render", s, "--technique", "no-such-technique"],
        vec!["render", s, "-D", "novalue"],
        vec!["render", s, "--spp", "0"],
        vec!["render", s], // malformed XML
    ] {
        let (code, err) = linlight(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("linlight render: "), "{err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
