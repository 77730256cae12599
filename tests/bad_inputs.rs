//! The table of unusable inputs (issue 9): each row is a command line, the exit code it must
//! give, and a piece of its one-line message. Every row is also checked to have written no
//! output: unusable input is detected before anything is rendered.

mod common;

use common::{linlight, scratch, write, FLOOR_SCENE};
use linlight_imagefile::Image;
use std::path::Path;

/// One bad input: command line (`{dir}` stands for the scratch directory), exit code, message
/// fragment.
struct Case {
    what: &'static str,
    args: Vec<String>,
    code: i32,
    message: &'static str,
}

fn case(what: &'static str, args: &[&str], code: i32, message: &'static str) -> Case {
    Case {
        what,
        args: args.iter().map(|s| s.to_string()).collect(),
        code,
        message,
    }
}

/// The floor scene with one substitution.
fn variant(dir: &Path, name: &str, from: &str, to: &str) {
    assert!(FLOOR_SCENE.contains(from), "{from}");
    write(dir, name, FLOOR_SCENE.replacen(from, to, 1));
}

fn setup(dir: &Path) {
    write(dir, "good.xml", FLOOR_SCENE);
    write(dir, "truncated.xml", &FLOOR_SCENE[..400]);
    variant(dir, "zero.xml", r#"value="16""#, r#"value="0""#);
    variant(dir, "torus.xml", r#"type="sphere""#, r#"type="torus""#);
    variant(
        dir,
        "no_samples.xml",
        r#"<integer name="emitter_samples" value="1"/>"#,
        r#"<integer name="emitter_samples" value="0"/>"#,
    );
    variant(
        dir,
        "shading.xml",
        r#"<integer name="bsdf_samples" value="0"/>"#,
        r#"<integer name="shading_samples" value="2"/>"#,
    );
    write(dir, "empty.obj", "# no faces\nv 0 0 0\n");
    // A header declaring 10⁷ triangles (the body is never read: the budget refuses it first).
    write(
        dir,
        "huge.ply",
        "ply\nformat binary_little_endian 1.0\nelement vertex 5000002\nproperty float x\n\
         property float y\nproperty float z\nelement face 10000000\n\
         property list uchar int vertex_indices\nend_header\n",
    );
    // One polygon of 30 000 corners: 29 998 triangles, more than --max-memory 0.065 allows.
    write(
        dir,
        "huge.obj",
        format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf{}\n", " 1 2 3".repeat(10_000)),
    );
    write(
        dir,
        "nan.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\nnan 1 0\n0 1 0\n3 0 1 2\n",
    );
    for (name, file) in [("huge_ply.xml", "huge.ply"), ("nan_ply.xml", "nan.ply")] {
        variant(
            dir,
            name,
            r#"<shape type="sphere">"#,
            &format!(
                r#"<shape type="ply"><string name="filename" value="{file}"/></shape><shape type="sphere">"#
            ),
        );
    }
    variant(
        dir,
        "huge_obj.xml",
        r#"<shape type="sphere">"#,
        r#"<shape type="obj"><string name="filename" value="huge.obj"/></shape><shape type="sphere">"#,
    );
    variant(
        dir,
        "empty_obj.xml",
        r#"<shape type="sphere">"#,
        r#"<shape type="obj"><string name="filename" value="empty.obj"/></shape><shape type="sphere">"#,
    );
    variant(
        dir,
        "rgba.xml",
        r#"<string name="component_format" value="float32"/>"#,
        r#"<string name="pixel_format" value="rgba"/>"#,
    );
    variant(
        dir,
        "elliptic.xml",
        r#"<float name="radius" value="0.0001"/>"#,
        r#"<float name="radius" value="0.0001"/><transform name="to_world"><scale x="2"/></transform>"#,
    );
    variant(dir, "huge.xml", r#"value="16""#, r#"value="100000""#);
    // Zero-area lights (issue 22): a tube of length 0, a tube of radius 0.
    variant(
        dir,
        "zero_length_tube.xml",
        r#"<point name="p1" value="0.7, 0.4, 1.2"/>"#,
        r#"<point name="p1" value="-0.5, -0.3, 0.3"/>"#,
    );
    variant(
        dir,
        "zero_radius_tube.xml",
        r#"<float name="radius" value="0.0001"/>"#,
        r#"<float name="radius" value="0"/>"#,
    );
    write(
        dir,
        "deep.xml",
        format!(
            "<scene version=\"3.0.0\">{}{}</scene>",
            "<shape type=\"cube\">".repeat(10_000),
            "</shape>".repeat(10_000)
        ),
    );
    std::fs::create_dir_all(dir.join("a_directory.exr")).unwrap();
    // A 4×4 image for --match-variance with the wrong size, and images for info and merge.
    let mut small = Image::new(4, 4);
    small.meta.dof = 3.0;
    small.meta.spp = 4;
    small.meta.passes = 4;
    small.write(&dir.join("small.exr")).unwrap();
    let mut ok = Image::new(24, 16);
    ok.meta.dof = 3.0;
    ok.meta.spp = 16;
    ok.meta.passes = 4;
    ok.meta.extra.insert("seed".into(), "1".into());
    ok.write(&dir.join("a.exr")).unwrap();
    ok.mean[0] = [1.0; 3];
    ok.write(&dir.join("same_seed.exr")).unwrap();
}

fn cases() -> Vec<Case> {
    vec![
        // render: the scene and its parameters
        case(
            "a PLY header of 10^7 triangles above --max-memory",
            &["render", "{dir}/huge_ply.xml", "--max-memory", "0.5"],
            2,
            "declares 10000000 faces in its PLY header",
        ),
        case(
            "an OBJ of 29 998 triangles above --max-memory",
            &["render", "{dir}/huge_obj.xml", "--max-memory", "0.065"],
            2,
            "has faces of 29998 triangles",
        ),
        case(
            "a PLY vertex with a NaN coordinate",
            &["render", "{dir}/nan_ply.xml"],
            2,
            "vertex 1 of 3 has a non-finite position (NaN, 1, 0)",
        ),
        case(
            "no scene file",
            &["render", "{dir}/missing.xml"],
            2,
            "cannot read scene file",
        ),
        case(
            "unknown technique",
            &["render", "{dir}/good.xml", "--technique", "nope"],
            2,
            "unknown technique 'nope'",
        ),
        case(
            "unknown MIS heuristic",
            &["render", "{dir}/good.xml", "--mis", "optimal"],
            2,
            "unknown MIS heuristic 'optimal'",
        ),
        case(
            "clamped optimal v outside [0, 1]",
            &["render", "{dir}/good.xml", "--mis", "clamped-optimal=1.5"],
            2,
            "v must be a number in [0, 1]",
        ),
        case(
            "--mis with a single technique",
            &[
                "render",
                "{dir}/good.xml",
                "--technique",
                "ltc",
                "--mis",
                "power",
            ],
            2,
            "does not apply to --technique ltc",
        ),
        case(
            "zero light samples",
            &["render", "{dir}/good.xml", "--light-samples", "0"],
            2,
            "--light-samples must be at least 1",
        ),
        case(
            "-D without =",
            &["render", "{dir}/good.xml", "-D", "novalue"],
            2,
            "-D expects NAME=VALUE",
        ),
        case(
            "-D for an undeclared name",
            &["render", "{dir}/good.xml", "-D", "nope=1"],
            2,
            "found unused parameters: $nope=1",
        ),
        case(
            "repeated -D",
            &["render", "{dir}/good.xml", "-D", "res=16", "-D", "res=8"],
            2,
            "found unused parameters: $res=8",
        ),
        case(
            "--spp 0",
            &["render", "{dir}/good.xml", "--spp", "0"],
            2,
            "must be at least 1",
        ),
        case(
            "--passes 0",
            &["render", "{dir}/good.xml", "--passes", "0"],
            2,
            "must be at least 1",
        ),
        case(
            "truncated XML",
            &["render", "{dir}/truncated.xml"],
            2,
            "malformed XML",
        ),
        case("empty film", &["render", "{dir}/zero.xml"], 2, "is empty"),
        case(
            "tube of length 0",
            &["render", "{dir}/zero_length_tube.xml"],
            2,
            "cylinder p0 and p1 coincide",
        ),
        case(
            "tube of radius 0",
            &["render", "{dir}/zero_radius_tube.xml"],
            2,
            "cylinder radius must be positive and finite (got 0)",
        ),
        case(
            "unsupported shape",
            &["render", "{dir}/torus.xml"],
            2,
            "unsupported shape type 'torus'",
        ),
        case(
            "no emitter and no BSDF samples",
            &["render", "{dir}/no_samples.xml"],
            2,
            "at least 1 BSDF or emitter sample",
        ),
        case(
            "shading_samples with emitter_samples",
            &["render", "{dir}/shading.xml"],
            2,
            "cannot specify both 'shading_samples'",
        ),
        case(
            "empty OBJ",
            &["render", "{dir}/empty_obj.xml"],
            2,
            "contains no faces",
        ),
        case(
            "pixel_format rgba",
            &["render", "{dir}/rgba.xml"],
            2,
            "pixel_format 'rgba' is not supported",
        ),
        case(
            "elliptic cylinder",
            &["render", "{dir}/elliptic.xml"],
            2,
            "cross-section a circle",
        ),
        case(
            "10000-deep XML",
            &["render", "{dir}/deep.xml"],
            2,
            "nested more than 64 deep",
        ),
        // render: outputs and resources
        case(
            "--out is the scene",
            &["render", "{dir}/good.xml", "-o", "{dir}/good.xml"],
            2,
            "is the scene file",
        ),
        case(
            "--out is the scene, other spelling",
            &["render", "{dir}/good.xml", "-o", "{dir}/./good.xml"],
            2,
            "is the scene file",
        ),
        case(
            "--preview is --out",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.png",
                "--preview",
                "{dir}/x.png",
            ],
            2,
            "is the --out image",
        ),
        case(
            "--preview not PNG",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--preview",
                "{dir}/x.exr",
            ],
            2,
            "must be a .png file",
        ),
        case(
            "--out of unknown format",
            &["render", "{dir}/good.xml", "-o", "{dir}/x.jpg"],
            2,
            "cannot tell the image format",
        ),
        case(
            "--out in a missing directory",
            &["render", "{dir}/good.xml", "-o", "{dir}/missing/x.exr"],
            2,
            "does not exist",
        ),
        case(
            "--out is a directory",
            &["render", "{dir}/good.xml", "-o", "{dir}/a_directory.exr"],
            2,
            "it is a directory",
        ),
        case(
            "100000² film",
            &[
                "render",
                "{dir}/huge.xml",
                "-D",
                "res=100000",
                "-o",
                "{dir}/x.exr",
            ],
            2,
            "more than the limit of",
        ),
        case(
            "--max-memory too small",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--max-memory",
                "0.01",
            ],
            2,
            "more than the limit of 10 MiB (--max-memory)",
        ),
        case(
            "--threads 10000",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--threads",
                "10000",
            ],
            2,
            "--threads 10000 is more than",
        ),
        case(
            "--threads 0",
            &["render", "{dir}/good.xml", "-o", "{dir}/x.exr", "-t", "0"],
            2,
            "--threads must be at least 1",
        ),
        case(
            "--match-variance of another size",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--match-variance",
                "{dir}/small.exr",
            ],
            2,
            "is 4×4 but the scene renders 24×16",
        ),
        case(
            "--match-variance unreadable",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--match-variance",
                "{dir}/missing.exr",
            ],
            2,
            "--match-variance: cannot read",
        ),
        case(
            "--time 0",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--time",
                "0",
            ],
            2,
            "--time must be a positive number",
        ),
        case(
            "--exposure NaN",
            &[
                "render",
                "{dir}/good.xml",
                "-o",
                "{dir}/x.exr",
                "--exposure",
                "NaN",
            ],
            2,
            "--exposure NaN",
        ),
        // certify: outputs checked before the sampler suite or any render
        case(
            "certify --json in a missing directory",
            &[
                "certify",
                "--json",
                "{dir}/missing/r.json",
                "--report-dir",
                "{dir}/report",
            ],
            2,
            "does not exist",
        ),
        case(
            "certify --scenes-dir that does not exist",
            &[
                "certify",
                "--scenes-dir",
                "{dir}/no_scenes",
                "--report-dir",
                "{dir}/report",
            ],
            2,
            "cannot read the scene directory",
        ),
        case(
            "certify --report-dir under a file",
            &["certify", "--report-dir", "{dir}/good.xml/report"],
            2,
            "cannot create directory",
        ),
        case(
            "certify --threads 10000",
            &[
                "certify",
                "--threads",
                "10000",
                "--report-dir",
                "{dir}/report",
            ],
            2,
            "--threads 10000 is more than",
        ),
        // info
        case(
            "info of a missing file",
            &["info", "{dir}/missing.exr"],
            2,
            "cannot read",
        ),
        case(
            "info of a scene file",
            &["info", "{dir}/good.xml"],
            2,
            "not a readable OpenEXR file",
        ),
        // merge
        case(
            "merge of different sizes",
            &[
                "merge",
                "{dir}/a.exr",
                "{dir}/small.exr",
                "-o",
                "{dir}/m.exr",
            ],
            2,
            "is 24×16 but",
        ),
        case(
            "merge of dependent images",
            &[
                "merge",
                "{dir}/a.exr",
                "{dir}/same_seed.exr",
                "-o",
                "{dir}/m.exr",
            ],
            2,
            "the same seed",
        ),
        case(
            "merge over an input",
            &[
                "merge",
                "{dir}/a.exr",
                "{dir}/small.exr",
                "-o",
                "{dir}/a.exr",
            ],
            2,
            "is the input",
        ),
        case(
            "merge to PNG",
            &[
                "merge",
                "{dir}/a.exr",
                "{dir}/small.exr",
                "-o",
                "{dir}/m.png",
            ],
            2,
            "must be an .exr file",
        ),
        case(
            "merge of one image",
            &["merge", "{dir}/a.exr", "-o", "{dir}/m.exr"],
            2,
            "required",
        ),
        case(
            "info: image above --max-memory",
            &["info", "{dir}/a.exr", "--max-memory", "0.00001"],
            2,
            "more than the limit of 10 KiB",
        ),
        case(
            "compare: image above --max-memory",
            &[
                "compare",
                "{dir}/a.exr",
                "{dir}/a.exr",
                "--max-memory",
                "0.00001",
            ],
            2,
            "more than the limit of 10 KiB",
        ),
        case(
            "compare: --max-memory 0",
            &["compare", "{dir}/a.exr", "{dir}/a.exr", "--max-memory", "0"],
            2,
            "--max-memory must be positive",
        ),
        case(
            "merge: image above --max-memory",
            &[
                "merge",
                "{dir}/a.exr",
                "{dir}/same_seed.exr",
                "-o",
                "{dir}/m.exr",
                "--max-memory",
                "0.00001",
            ],
            2,
            "more than the limit of 10 KiB",
        ),
        case(
            "stack: image above --max-memory",
            &[
                "stack",
                "{dir}/a.exr",
                "{dir}/same_seed.exr",
                "-o",
                "{dir}/m.exr",
                "--max-memory",
                "0.00001",
            ],
            2,
            "more than the limit of 10 KiB",
        ),
    ]
}

#[test]
fn every_bad_input_gives_its_exit_code_and_message_before_any_work() {
    let dir = scratch("table");
    setup(&dir);
    let d = dir.to_str().unwrap();
    let before: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    let mut failures = Vec::new();
    for c in cases() {
        let args: Vec<String> = c.args.iter().map(|a| a.replace("{dir}", d)).collect();
        let r = linlight(&args);
        let err = r.stderr.trim();
        let command = args[0].as_str();
        let one_line = err.lines().count() == 1 || c.message == "required";
        let prefixed = err.starts_with(&format!("linlight {command}: ")) || c.message == "required";
        let doubled = err.matches("cannot write").count() > 1;
        if r.code != c.code || !err.contains(c.message) || !one_line || !prefixed || doubled {
            failures.push(format!(
                "{}: exit {} (want {}), stderr {err:?} (want '{}')",
                c.what, r.code, c.code, c.message
            ));
        }
    }
    // Nothing was written (the report directories of certify are created by the check itself).
    let after: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n != "report")
        .collect();
    assert_eq!(before, after, "a refused command left files behind");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    std::fs::remove_dir_all(&dir).ok();
}

/// What Mitsuba accepts and the loader must too: the cylinder idiom scale(r, r, L)·rotate·
/// translate, and an unused <default>.
#[test]
fn accepted_like_mitsuba() {
    let dir = scratch("accepted");
    let scene = FLOOR_SCENE.replace(
        r#"<point name="p0" value="-0.5, -0.3, 0.3"/>
    <point name="p1" value="0.7, 0.4, 1.2"/>
    <float name="radius" value="0.0001"/>"#,
        r#"<transform name="to_world"><scale x="0.0001" y="0.0001" z="1.2"/><rotate y="1" angle="60"/><translate x="-0.5" z="0.3"/></transform>"#,
    );
    assert_ne!(scene, FLOOR_SCENE);
    let path = write(&dir, "idiom.xml", scene);
    let out = dir.join("idiom.exr");
    let r = linlight(&["render", &path, "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let img = Image::read(&out).unwrap();
    assert!(img.mean.iter().any(|m| m[0] > 0.0));
    assert_eq!(img.meta.extra["technique"], "mis");
    std::fs::remove_dir_all(&dir).ok();
}

/// Zero-area surfaces (issue 22) are handled as Mitsuba does: a rectangle scaled by 0 and a mesh
/// of only degenerate triangles are never hit; the render succeeds, its image is finite, the
/// degenerate mesh gets a warning naming its file and line, and neither changes the image.
#[test]
fn zero_area_surfaces_render_and_change_nothing() {
    let dir = scratch("zero-area");
    write(
        &dir,
        "degenerate.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
    );
    let sphere = r#"<shape type="sphere">"#;
    assert!(FLOOR_SCENE.contains(sphere));
    let zero_area = FLOOR_SCENE.replacen(
        sphere,
        r#"<shape type="rectangle"><transform name="to_world"><scale value="0"/></transform><bsdf type="diffuse"/></shape>
  <shape type="obj"><string name="filename" value="degenerate.obj"/></shape>
  <shape type="sphere">"#,
        1,
    );
    let plain = write(&dir, "plain.xml", FLOOR_SCENE);
    let zero = write(&dir, "zero_area.xml", zero_area);
    let mut images = Vec::new();
    for (scene, name) in [(&plain, "plain.exr"), (&zero, "zero_area.exr")] {
        let out = dir.join(name);
        let r = linlight(&["render", scene.as_str(), "-o", out.to_str().unwrap(), "-q"]);
        assert_eq!(r.code, 0, "{scene}: {}", r.stderr);
        images.push((Image::read(&out).unwrap(), r.stderr));
    }
    let (plain_img, _) = &images[0];
    let (zero_img, warnings) = &images[1];
    assert!(
        warnings.contains("zero_area.xml:") && warnings.contains("degenerate triangles"),
        "{warnings}"
    );
    assert!(zero_img
        .mean
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
    assert!(zero_img.mean.iter().flatten().any(|v| *v > 0.0));
    // Same seed, same light, no surface hit differently: the same pixels.
    assert_eq!(plain_img.mean, zero_img.mean);
    std::fs::remove_dir_all(&dir).ok();
}

/// The floor scene with `n` tubes (a row of short lights above the floor) instead of one.
fn many_lights_scene(n: usize) -> String {
    let tube = r#"<shape type="cylinder">
    <point name="p0" value="-0.5, -0.3, 0.3"/>
    <point name="p1" value="0.7, 0.4, 1.2"/>
    <float name="radius" value="0.0001"/>
    <emitter type="area"><rgb name="radiance" value="20000, 10000, 5000"/></emitter>
  </shape>"#;
    assert!(FLOOR_SCENE.contains(tube));
    let lights: String = (0..n)
        .map(|i| {
            let x = -1.0 + 2.0 * (i % 100) as f64 / 100.0;
            let y = -1.0 + 2.0 * (i / 100) as f64 / (n / 100).max(1) as f64;
            format!(
                "<shape type=\"cylinder\"><point name=\"p0\" value=\"{x}, {y}, 1\"/>\
                 <point name=\"p1\" value=\"{}, {y}, 1\"/><float name=\"radius\" value=\"0.0001\"/>\
                 <emitter type=\"area\"><rgb name=\"radiance\" value=\"10, 10, 10\"/></emitter></shape>\n",
                x + 0.01
            )
        })
        .collect();
    FLOOR_SCENE.replacen(tube, &lights, 1)
}

/// 10⁴ lights load and render (1 spp, one light chosen per sample) to a finite, non-negative
/// image. How the cost grows with the number of lights is a benchmark's question, not this test's.
#[test]
fn ten_thousand_lights_render() {
    let dir = scratch("many-lights");
    let n = 10_000;
    let scene = write(&dir, &format!("lights{n}.xml"), many_lights_scene(n));
    let out = dir.join(format!("lights{n}.exr"));
    let args = [
        "render",
        scene.as_str(),
        "-D",
        "spp=1",
        "-D",
        "res=8",
        "-t",
        "1",
        "--lights",
        "one",
        "-o",
        out.to_str().unwrap(),
        "-q",
    ];
    let r = linlight(&args);
    assert_eq!(r.code, 0, "{n} lights: {}", r.stderr);
    let img = Image::read(&out).unwrap();
    assert!(img
        .mean
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
    std::fs::remove_dir_all(&dir).ok();
}
