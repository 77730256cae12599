//! `linlight render` end to end: a small scene renders to the shared EXR format, byte-identical
//! run to run; warnings survive --quiet; the output format follows the extension; --time and
//! --match-variance. (Unusable input: tests/bad_inputs.rs.)

mod common;

use common::{linlight, scratch, write, FLOOR_SCENE};
use linlight_imagefile::Image;

#[test]
fn renders_a_scene_to_the_shared_format() {
    let dir = scratch("ok");
    // R = 1e-5 (the same K): no finite-radius warning, so --quiet prints nothing at all.
    let thin = FLOOR_SCENE
        .replace(r#"value="0.0001""#, r#"value="0.00001""#)
        .replace("20000, 10000, 5000", "200000, 100000, 50000");
    let scene = write(&dir, "floor.xml", thin);
    let out = dir.join("floor.exr");
    let png = dir.join("floor.png");
    let (o, p) = (out.to_str().unwrap(), png.to_str().unwrap());
    let args = [
        "render",
        &scene,
        "--out",
        o,
        "--preview",
        p,
        "--passes",
        "3",
        "--seed",
        "5",
        "-D",
        "spp=2",
        "--quiet",
        "--threads",
        "2",
    ];
    let r = linlight(&args);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.is_empty(), "--quiet must be quiet: {}", r.stderr);
    assert!(png.is_file());
    let img = Image::read(&out).unwrap();
    assert_eq!((img.width, img.height), (24, 16));
    assert_eq!((img.meta.spp, img.meta.passes, img.meta.dof), (6, 3, 2.0));
    // The default method: MIS with clamped optimal weights, v = 0.5; light samples from the
    // scene's emitter_samples.
    assert_eq!(img.meta.extra["technique"], "mis");
    assert_eq!(img.meta.extra["mis"], "clamped-optimal");
    assert_eq!(img.meta.extra["mis_v"], "0.5");
    assert_eq!(img.meta.extra["light_samples"], "1");
    assert_eq!(img.meta.extra["seed"], "5");
    assert_eq!(img.meta.scene_sha256.len(), 64);
    // Traceable to its inputs: scene file name and the -D overrides.
    assert_eq!(img.meta.extra["scene"], "floor.xml");
    assert_eq!(img.meta.extra["overrides"], "spp=2");
    // The heavy-tail share of the 3 passes, in [0, 2/3].
    let tail = img.tail.as_ref().expect("tail channels");
    assert!(tail
        .iter()
        .flatten()
        .all(|&t| (0.0..=2.0 / 3.0 + 1e-6).contains(&t)));
    assert!(img.mean.iter().any(|m| m[0] > 0.0));
    assert!(img
        .mean
        .iter()
        .chain(&img.var)
        .flatten()
        .all(|c| c.is_finite()));
    // The same render again (other thread count, short options) gives the same bytes.
    let again = dir.join("again.exr");
    let args2 = [
        "render",
        &scene,
        "-o",
        again.to_str().unwrap(),
        "--passes",
        "3",
        "--seed",
        "5",
        "-D",
        "spp=2",
        "-q",
        "-t",
        "1",
    ];
    assert_eq!(linlight(&args2).code, 0);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn one_sample_in_one_pass_warns_even_when_quiet_and_compare_refuses_it() {
    let dir = scratch("spp1");
    let scene = write(&dir, "floor.xml", FLOOR_SCENE);
    let out = dir.join("one.exr");
    let r = linlight(&[
        "render",
        &scene,
        "--spp",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(
        r.stderr.contains("no variance estimate (dof 0)"),
        "{}",
        r.stderr
    );
    let r = linlight(&["compare", out.to_str().unwrap(), out.to_str().unwrap()]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains("image A has no variance estimate"),
        "{}",
        r.stderr
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// --quiet drops progress and the summary, never a warning (here: negative radiance, the biased
/// baseline technique, the PNG output's missing variance).
#[test]
fn quiet_never_hides_a_warning() {
    let dir = scratch("quiet");
    let scene = write(
        &dir,
        "negative.xml",
        FLOOR_SCENE.replace("20000, 10000, 5000", "-20000, 10000, 5000"),
    );
    let out = dir.join("n.png");
    let r = linlight(&[
        "render",
        &scene,
        "-q",
        "-o",
        out.to_str().unwrap(),
        "--technique",
        "baseline",
        "--exposure",
        "-2",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    for want in [
        "negative component",
        "biased by design",
        "pixels have a negative mean",
        "variance is not saved",
    ] {
        assert!(r.stderr.contains(want), "missing '{want}' in: {}", r.stderr);
    }
    assert!(
        r.stderr.lines().all(|l| l.starts_with("warning: ")),
        "{}",
        r.stderr
    );
    assert_eq!(&std::fs::read(&out).unwrap()[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn time_limit_and_match_variance() {
    let dir = scratch("budget");
    let scene = write(&dir, "floor.xml", FLOOR_SCENE);
    let timed = dir.join("timed.exr");
    let r = linlight(&[
        "render",
        &scene,
        "--spp",
        "4",
        "--time",
        "0.5",
        "-o",
        timed.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let img = Image::read(&timed).unwrap();
    let batches: u64 = img.meta.extra["batches"].parse().unwrap();
    assert!(batches >= 1);
    // Batches of 4 single-pass samples merge into one pass of 4·B samples.
    assert_eq!(
        (img.meta.spp, img.meta.dof),
        (4 * batches, (4 * batches - 1) as f64)
    );

    // A reference rendered with 4096 spp: matching its variance needs about 4096 spp again
    // (the budget rule is a 99 % quantile over pixels of a noisy pilot, in steps of 64). The
    // line limit, whose per-sample variance the range below was set from.
    let reference = dir.join("ref.exr");
    let r = linlight(&[
        "render",
        &scene,
        "--spp",
        "4096",
        "--seed",
        "9",
        "-o",
        reference.to_str().unwrap(),
        "-q",
        "--cylinders",
        "line",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let matched = dir.join("matched.exr");
    let r = linlight(&[
        "render",
        &scene,
        "--match-variance",
        reference.to_str().unwrap(),
        "-o",
        matched.to_str().unwrap(),
        "--cylinders",
        "line",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("--match-variance: "), "{}", r.stderr);
    let spp = Image::read(&matched).unwrap().meta.spp;
    assert!((2048..=8192).contains(&spp), "{spp}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `--noise`: every choice renders, is recorded in the header and is deterministic; blue noise
/// gives other numbers than white; an unknown noise is unusable input.
#[test]
fn noise_choices() {
    let dir = scratch("noise");
    let scene = write(&dir, "floor.xml", FLOOR_SCENE);
    let mut means = Vec::new();
    for noise in ["white", "blue", "blue-jittered"] {
        let out = dir.join(format!("{noise}.exr"));
        let o = out.to_str().unwrap();
        let args = [
            "render", &scene, "-o", o, "--noise", noise, "--spp", "3", "--passes", "4", "-q",
        ];
        let r = linlight(&args);
        assert_eq!(r.code, 0, "{noise}: {}", r.stderr);
        let img = Image::read(&out).unwrap();
        assert_eq!(
            img.meta.extra.get("noise").map(String::as_str),
            (noise != "white").then_some(noise),
            "{noise}"
        );
        assert!(img
            .mean
            .iter()
            .chain(&img.var)
            .flatten()
            .all(|c| c.is_finite()));
        let again = dir.join(format!("{noise}-again.exr"));
        let args = [
            "render",
            &scene,
            "-o",
            again.to_str().unwrap(),
            "--noise",
            noise,
            "--spp",
            "3",
            "--passes",
            "4",
            "-q",
            "-t",
            "1",
        ];
        assert_eq!(linlight(&args).code, 0);
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&again).unwrap(),
            "{noise}"
        );
        means.push(img.mean);
    }
    assert_ne!(means[0], means[1]);
    assert_ne!(means[1], means[2]);
    let r = linlight(&[
        "render",
        &scene,
        "--noise",
        "pink",
        "-o",
        dir.join("x.exr").to_str().unwrap(),
    ]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("unknown noise 'pink'"), "{}", r.stderr);
}

/// The method flags reach the header: --technique, --mis (with v for clamped optimal) and
/// --light-samples (default: the scene's emitter_samples) and --lights (default every); `--help`
/// lists every method.
#[test]
fn method_flags_are_recorded_in_the_header() {
    let dir = scratch("methods");
    let scene = write(
        &dir,
        "floor.xml",
        FLOOR_SCENE.replace(
            r#"<integer name="emitter_samples" value="1"/>"#,
            r#"<integer name="emitter_samples" value="3"/>"#,
        ),
    );
    type Case<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)]);
    let cases: [Case; 7] = [
        (
            &[],
            &[
                ("technique", "mis"),
                ("mis", "clamped-optimal"),
                ("mis_v", "0.5"),
                ("light_samples", "3"),
                ("light_selection", "every"),
            ],
        ),
        (&["--lights", "one"], &[("light_selection", "one")]),
        (&["--lights", "tree"], &[("light_selection", "tree")]),
        (
            &["--mis", "power", "--light-samples", "2"],
            &[
                ("technique", "mis"),
                ("mis", "power"),
                ("light_samples", "2"),
            ],
        ),
        (
            &["--mis", "clamped-optimal=0"],
            &[("mis", "clamped-optimal"), ("mis_v", "0")],
        ),
        (
            &["--technique", "ltc"],
            &[("technique", "ltc"), ("light_samples", "3")],
        ),
        (
            &["--technique", "area", "--light-samples", "1"],
            &[("technique", "area"), ("light_samples", "1")],
        ),
    ];
    for (k, (flags, want)) in cases.iter().enumerate() {
        let out = dir.join(format!("m{k}.exr"));
        let mut args = vec![
            "render",
            &scene,
            "-q",
            "-D",
            "spp=2",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(flags);
        let r = linlight(&args);
        assert_eq!(r.code, 0, "{flags:?}: {}", r.stderr);
        let img = Image::read(&out).unwrap();
        for (key, value) in *want {
            assert_eq!(
                img.meta.extra.get(*key).map(String::as_str),
                Some(*value),
                "{flags:?}: {key}"
            );
        }
        if !flags.is_empty() && flags[0] == "--technique" {
            assert!(!img.meta.extra.contains_key("mis"), "{flags:?}");
        }
    }
    let help = linlight(&["render", "--help"]);
    for name in [
        "mis",
        "ltc",
        "projected-solid-angle",
        "area",
        "balance",
        "clamped-optimal",
        "--light-samples",
        "emitter_samples",
        "--lights one",
        "sampling_weight",
    ] {
        assert!(
            help.stdout.contains(name),
            "--help lacks {name}: {}",
            help.stdout
        );
    }
    // An unknown selection is bad usage, named.
    let r = linlight(&["render", &scene, "-q", "--lights", "all"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains("--lights") && r.stderr.contains("one, every or tree"),
        "{}",
        r.stderr
    );
    std::fs::remove_dir_all(&dir).ok();
}
