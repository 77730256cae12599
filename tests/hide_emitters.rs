//! `hide_emitters = false` (Mitsuba's default): the camera sees the tube. The Rust render of
//! tests/scenes/visible-tube.xml (the line in the R → 0 limit, docs/hide-emitters.md) against
//! a committed Mitsuba render of the same file (R = 1e-4, scalar_rgb, 32 passes × 8192 spp,
//! tests/references/visible-tube.exr), judged by `linlight compare`, plus negative controls.
//!
//! Remake the reference (about 25 min on 2 cores) with
//!   scripts/harness render tests/scenes/visible-tube.xml --variant scalar_rgb --passes 32 \
//!     --spp 8192 --out tests/references/visible-tube.exr
//! scalar_rgb: llvm_ad_rgb intersects the cylinder in float32 and misses rays at R ≤ 1e-3. R must
//! be small: where the line passes within the band's width w ≈ 0.006 px of a pixel corner, the
//! finite tube puts O(w²) into pixels the line does not cross.
//!
//! Power. The reference resolves the image mean to ±0.41 % (one standard error; the visible line
//! dominates it, and Mitsuba finds the tube with a few hits per pixel in a hundred samples), so
//! the equivalence margin is set to ±2 % (its 99.67 % interval is ±1.2 %), stated here rather
//! than the default ±0.5 % that this reference cannot resolve. Every difference test runs at
//! compare's defaults (α = 0.01 over its 12 tests). The negative controls must be rejected: the
//! hidden line (what linlight rendered before), and K scaled by 1.05.

mod common;

use common::{linlight, root, scratch, write};
use linlight_imagefile::Image;
use std::path::Path;

const MARGIN: &str = "0.02";

fn scene_text() -> String {
    std::fs::read_to_string(root().join("tests/scenes/visible-tube.xml")).unwrap()
}

fn render(scene: &str, out: &Path) {
    let r = linlight(&[
        "render",
        scene,
        "--spp",
        "256",
        "--passes",
        "16",
        "--seed",
        "1",
        "-o",
        out.to_str().unwrap(),
        "-q",
        // The visible line's estimator (docs/hide-emitters.md); exact tubes are tested in
        // crates/render/src/tube.rs.
        "--cylinders",
        "line",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
}

/// `compare` against the Mitsuba reference; the controls are renders of edited copies of the
/// scene file, so their scene hash differs by design (`--allow-different-scenes`).
fn compare(a: &Path) -> (i32, String) {
    let reference = root().join("tests/references/visible-tube.exr");
    let r = linlight(&[
        "compare",
        a.to_str().unwrap(),
        reference.to_str().unwrap(),
        "--tolerance",
        MARGIN,
        "--allow-different-scenes",
    ]);
    (r.code, r.stdout + &r.stderr)
}

#[test]
fn visible_tube_matches_mitsuba_and_the_controls_fail() {
    let dir = scratch("visible");
    let reference = Image::read(&root().join("tests/references/visible-tube.exr")).unwrap();
    let scene = root().join("tests/scenes/visible-tube.xml");
    // The reference was rendered from this very file.
    let rust = dir.join("rust.exr");
    render(scene.to_str().unwrap(), &rust);
    let img = Image::read(&rust).unwrap();
    assert_eq!(img.meta.scene_sha256, reference.meta.scene_sha256);
    let (code, text) = compare(&rust);
    println!("{text}");
    assert_eq!(code, 0, "{text}");

    // The line carries most of the image: hiding it is 77 %+ darker.
    let hidden = write(
        &dir,
        "hidden.xml",
        scene_text().replace(
            r#"<integer name="bsdf_samples" value="0"/>"#,
            r#"<integer name="bsdf_samples" value="0"/><boolean name="hide_emitters" value="true"/>"#,
        ),
    );
    let out = dir.join("hidden.exr");
    render(&hidden, &out);
    let (code, text) = compare(&out);
    assert_eq!(code, 1, "hidden line accepted:\n{text}");

    let brighter = write(
        &dir,
        "brighter.xml",
        scene_text().replace("15000, 10000, 5000", "15750, 10500, 5250"),
    );
    let out = dir.join("brighter.exr");
    render(&brighter, &out);
    let (code, text) = compare(&out);
    assert_eq!(code, 1, "K × 1.05 accepted:\n{text}");
    std::fs::remove_dir_all(&dir).ok();
}
