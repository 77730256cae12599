//! The first hour with your own scene and your own renderer, end to end: every refusal at once
//! (`check`, `render`), plain images from any renderer (`stack`, `info`), header-less images
//! and the sample advice (`compare`), the progress of `--match-variance` and the render summary.

mod common;

use common::{linlight, scratch, write, FLOOR_SCENE};
use linlight_imagefile::{write_rgb_exr, Image};
use std::collections::BTreeMap;
use std::path::Path;

/// A scene with six refused features, as a tutorial scene has them.
const SIX_PROBLEMS: &str = r#"<scene version="3.0.0">
<integrator type="path"/>
<sensor type="perspective">
  <float name="focus_distance" value="3"/>
  <film type="hdrfilm"><string name="component_format" value="float32"/><rfilter type="gaussian"/></film>
</sensor>
<bsdf type="dielectric" id="glass"/>
<shape type="sphere"><ref id="glass"/></shape>
<shape type="rectangle"><bsdf type="conductor"/><emitter type="area"/></shape>
<emitter type="envmap"/>
<texture type="bitmap" id="unused"/>
</scene>
"#;

#[test]
fn check_and_render_report_every_refusal_in_file_order() {
    let d = scratch("six");
    let scene = write(&d, "six.xml", SIX_PROBLEMS);
    let r = linlight(&["check", &scene]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    let refused = r.stdout.split("warned (").next().unwrap();
    let places: Vec<&str> = refused
        .lines()
        .filter_map(|l| l.strip_prefix(&format!("  {scene}:")))
        .map(|rest| &rest[..rest.find(": ").unwrap()])
        .collect();
    assert_eq!(
        places,
        ["2:1", "5:73", "7:1", "9:25", "9:49", "10:1"],
        "{}",
        r.stdout
    );
    assert!(
        r.stdout.contains("refused (6, in file order):"),
        "{}",
        r.stdout
    );
    assert!(r.stdout.contains("warned (1):"), "{}", r.stdout);
    assert!(
        r.stdout.contains("texture 'bitmap' is not referenced"),
        "{}",
        r.stdout
    );
    // render refuses the same scene with the same list.
    let out = d.join("six.exr");
    let r = linlight(&["render", &scene, "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(r.code, 2);
    assert!(
        r.stderr
            .contains("6 problems in this scene (listed in file order)"),
        "{}",
        r.stderr
    );
    assert!(
        r.stderr.contains("write <integrator type=\"direct\"/>"),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
}

#[test]
fn check_lists_what_is_supported() {
    let d = scratch("ok");
    let scene = write(&d, "floor.xml", FLOOR_SCENE);
    let r = linlight(&["check", &scene]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
    for want in [
        ": loads",
        "supported:",
        "sensor perspective, film 24×16 px, sampler independent 4 spp, seed 0",
        "integrator direct (1 emitter sample(s), hide_emitters)",
        "1 × shape mesh (2 triangles), diffuse",
        "1 × shape sphere, diffuse",
        "linear light at",
    ] {
        assert!(r.stdout.contains(want), "missing '{want}':\n{}", r.stdout);
    }
    assert!(!r.stdout.contains("refused"), "{}", r.stdout);
}

/// N plain RGB renders: pixel (x, y) of render s is base + s-dependent noise.
fn plain(dir: &Path, name: &str, w: usize, h: usize, seed: u32) -> String {
    let rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let n = ((i as u32 + 1).wrapping_mul(2_654_435_761) ^ seed.wrapping_mul(40503)) % 1000;
            let v = 0.5 + n as f32 / 4000.0;
            [v, 0.5 * v, 0.25]
        })
        .collect();
    let p = dir.join(name);
    write_rgb_exr(&p, w, h, &rgb, &BTreeMap::new()).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn stack_turns_plain_renders_into_an_image_with_variance() {
    let d = scratch("stack");
    let inputs: Vec<String> = (1..=4)
        .map(|s| plain(&d, &format!("m{s}.exr"), 8, 4, s))
        .collect();
    // info on a plain input: not an image of the shared format (exit 1, as its help says).
    let r = linlight(&["info", &inputs[0]]);
    assert_eq!(r.code, 1, "{}{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("8×4 px plain RGB image"), "{}", r.stdout);
    assert!(r.stdout.contains("linlight stack"), "{}", r.stdout);
    // compare refuses it with its reason.
    let r = linlight(&["compare", &inputs[0], &inputs[1]]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("var.R"), "{}", r.stderr);

    let scene = write(&d, "scene.xml", FLOOR_SCENE);
    let out = d.join("stacked.exr");
    let o = out.to_str().unwrap();
    let mut args = vec!["stack", "-o", o, "--scene", &scene, "--spp", "256"];
    args.extend(inputs.iter().map(String::as_str));
    let r = linlight(&args);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let img = Image::read(&out).unwrap();
    assert_eq!(
        (img.width, img.height, img.meta.dof, img.meta.spp),
        (8, 4, 3.0, 1024)
    );
    assert_eq!(img.meta.extra["stacked_images"], "4");
    assert_eq!(img.meta.extra["stacked_sha256"].split(';').count(), 4);
    assert_eq!(img.meta.scene_sha256.len(), 64);
    assert!(img.var.iter().any(|v| v[0] > 0.0));
    assert_eq!(linlight(&["info", o]).code, 0);

    // Refusals: one input, different sizes, the same seed twice.
    let r = linlight(&["stack", "-o", o, &inputs[0]]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("at least two"), "{}", r.stderr);
    let wide = plain(&d, "wide.exr", 9, 4, 7);
    let r = linlight(&["stack", "-o", o, &inputs[0], &wide]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("is 8×4 but"), "{}", r.stderr);
    let again = plain(&d, "again.exr", 8, 4, 1);
    let r = linlight(&["stack", "-o", o, &inputs[0], &inputs[1], &again]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("identical pixels"), "{}", r.stderr);
    // An image of the shared format is not plain: merge it instead.
    let r = linlight(&[
        "stack",
        "-o",
        d.join("x.exr").to_str().unwrap(),
        o,
        &inputs[1],
    ]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("linlight merge"), "{}", r.stderr);
}

/// Header-less images: compare says which checks it skipped, in text and JSON.
#[test]
fn compare_says_what_a_header_less_image_skips() {
    let d = scratch("headerless");
    let inputs: Vec<String> = (1..=3)
        .map(|s| plain(&d, &format!("p{s}.exr"), 8, 4, s))
        .collect();
    let b = d.join("b.exr");
    let mut args = vec!["stack", "-q", "-o", b.to_str().unwrap()];
    args.extend(inputs.iter().map(String::as_str));
    assert_eq!(linlight(&args).code, 0);
    let json = d.join("r.json");
    let r = linlight(&[
        "compare",
        b.to_str().unwrap(),
        b.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(r.stdout.contains("spp unknown / unknown"), "{}", r.stdout);
    assert!(
        r.stdout
            .contains("worst tile: tile at pixel (0, 0), 8×4 (channel"),
        "{}",
        r.stdout
    );
    assert!(
        r.stdout
            .contains("note: A has no scene hash (scene_sha256): the same-scene check was skipped"),
        "{}",
        r.stdout
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let notes = v["notes"].as_array().unwrap();
    assert!(notes
        .iter()
        .any(|n| n == "B has no scene hash (scene_sha256): the same-scene check was skipped"));
}

/// The render summary times load, build and render apart; --match-variance says what it does
/// before the render (pilot, chosen spp, estimated time), without a terminal.
#[test]
fn render_reports_its_steps() {
    let d = scratch("steps");
    let scene = write(&d, "floor.xml", FLOOR_SCENE);
    let reference = d.join("ref.exr");
    let r = linlight(&[
        "render",
        &scene,
        "-o",
        reference.to_str().unwrap(),
        "--passes",
        "4",
        "-D",
        "spp=2",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let time = r
        .stderr
        .lines()
        .find(|l| l.starts_with("time: load "))
        .unwrap_or_else(|| panic!("no time line in {}", r.stderr));
    assert!(
        time.contains(" s, build ")
            && time.contains(" s, render ")
            && time.contains("M samples/s while rendering"),
        "{time}"
    );

    let mine = d.join("mine.exr");
    let r = linlight(&[
        "render",
        &scene,
        "-o",
        mine.to_str().unwrap(),
        "--match-variance",
        reference.to_str().unwrap(),
        "--seed",
        "9",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines: Vec<&str> = r.stderr.lines().collect();
    let pilot = lines
        .iter()
        .position(|l| l.contains("pilot render of"))
        .expect(&r.stderr);
    let eta = lines
        .iter()
        .position(|l| l.contains("the render needs about"))
        .expect(&r.stderr);
    let wrote = lines
        .iter()
        .position(|l| l.starts_with("wrote "))
        .expect(&r.stderr);
    assert!(pilot < eta && eta < wrote, "{}", r.stderr);
}

/// A tube of visible radius rendered as a line: a warning with the estimated per-pixel effect,
/// recorded in the header for compare. Rendered exact (the default), neither.
#[test]
fn a_thick_tube_is_warned_about_and_recorded() {
    let d = scratch("thick");
    let thick = FLOOR_SCENE
        .replace(r#"value="0.0001""#, r#"value="0.01""#)
        .replace("20000, 10000, 5000", "200, 100, 50");
    let scene = write(&d, "thick.xml", thick);
    let out = d.join("thick.exr");
    let r = linlight(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "-q",
        "--cylinders",
        "line",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("(R = 0.01): up to"), "{}", r.stderr);
    assert!(
        r.stderr.contains("% per pixel (Mitsuba darker)"),
        "{}",
        r.stderr
    );
    let img = Image::read(&out).unwrap();
    assert!(img.meta.extra["finite_radius_effect"].contains("R = 0.01"));
    assert_eq!(img.meta.extra["cylinders"], "line");
    let r = linlight(&["render", &scene, "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(!r.stderr.contains("per pixel"), "{}", r.stderr);
    let img = Image::read(&out).unwrap();
    assert!(!img.meta.extra.contains_key("finite_radius_effect"));
    assert_eq!(img.meta.extra["cylinders"], "exact");
}

/// The walkthrough's scene: a Cornell box as the Mitsuba tutorials write it is refused with
/// every problem in one run (5, each naming its replacement); the scene written from those
/// messages loads.
#[test]
fn the_tutorial_cornell_box_takes_one_round_of_edits() {
    let scenes = common::root().join("tests/scenes");
    let tutorial = scenes.join("tutorial-cbox.xml");
    let r = linlight(&["check", tutorial.to_str().unwrap()]);
    assert_eq!(r.code, 2, "{}", r.stdout);
    assert!(
        r.stdout.contains("refused (5, in file order):"),
        "{}",
        r.stdout
    );
    for want in [
        "write <integrator type=\"direct\"/>, without max_depth",
        "write <rfilter type=\"box\"/>",
        "closest: principled with metallic 0",
        "closest: roughconductor with <string name=\"distribution\" value=\"ggx\"/>",
        "use a <shape type=\"cylinder\">",
    ] {
        assert!(r.stdout.contains(want), "missing '{want}':\n{}", r.stdout);
    }
    let fixed = scenes.join("tutorial-cbox-direct.xml");
    let r = linlight(&["check", fixed.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stdout);
}
