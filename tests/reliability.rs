//! Outputs and faults through the binary (docs/reliability.md): every output kind refuses a
//! device or FIFO and reports a failed write (exit 2, the path named); outputs are never an
//! input or each other (by device and inode: hard links count); a writer killed at any point
//! (SIGINT, SIGTERM, SIGKILL) or racing another writer leaves the old or the new complete file.

mod common;

use common::{linlight, scratch, write, FLOOR_SCENE};
use linlight_imagefile::{Image, Metadata};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// Two independent images of one scene (different seeds), `w`×`h`, for `merge`.
fn merge_inputs(dir: &Path, w: usize, h: usize) -> (PathBuf, PathBuf) {
    let make = |seed: u64| {
        let mut img = Image::new(w, h);
        let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        for (m, v) in img.mean.iter_mut().zip(img.var.iter_mut()) {
            for c in 0..3 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                m[c] = (x >> 40) as f32 / (1u64 << 24) as f32;
                v[c] = m[c] * 1e-3;
            }
        }
        img.meta = Metadata {
            dof: 15.0,
            spp: 64,
            passes: 16,
            renderer: "linlight test".into(),
            scene_sha256: "ab".repeat(32),
            extra: [("seed".to_string(), seed.to_string())]
                .into_iter()
                .collect(),
        };
        img
    };
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    make(1).write(&a).unwrap();
    make(2).write(&b).unwrap();
    (a, b)
}

/// Runs the binary with a deadline (a FIFO must be refused, not block): exit code and stderr.
fn run_with_deadline(args: &[String], deadline: Duration) -> (i32, String) {
    let mut child = common::command()
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            use std::io::Read;
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut err)
                .unwrap();
            return (status.code().unwrap_or(-1), err);
        }
        if start.elapsed() > deadline {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("{args:?} hangs");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn every_output_kind_refuses_devices_and_fifos() {
    let dir = scratch("devices");
    let scene = write(&dir, "scene.xml", FLOOR_SCENE);
    let (a, b) = merge_inputs(&dir, 8, 4);
    let (a, b) = (s(&a), s(&b));
    let good = s(&dir.join("good.exr"));
    let r = linlight(&["render", &scene, "-o", &good, "--quiet"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let fifo = dir.join("fifo");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    // /dev/full behind a name with the right extension, and a FIFO.
    for (target, what) in [(Path::new("/dev/full"), "full"), (fifo.as_path(), "fifo")] {
        let link = |ext: &str| {
            let p = dir.join(format!("{what}.{ext}"));
            let _ = std::fs::remove_file(&p);
            std::os::unix::fs::symlink(target, &p).unwrap();
            s(&p)
        };
        let (exr, png, json, bin) = (link("exr"), link("png"), link("json"), link("bin"));
        let cases: Vec<Vec<&str>> = vec![
            vec!["render", &scene, "-o", &exr],
            vec!["render", &scene, "-o", &png],
            vec!["render", &scene, "-o", &good, "--preview", &png],
            vec!["compare", &good, &good, "--heatmap", &png],
            vec!["compare", &good, &good, "--json", &json],
            vec!["compare", &good, &good, "--diff-exr", &exr],
            vec!["merge", &a, &b, "-o", &exr],
            vec!["stack", &a, &b, "-o", &exr],
            vec!["fit-ltc", "--size", "2", "--out", &bin],
            vec!["fit-ltc", "--size", "2", "--out", &good, "--heatmap", &png],
            vec!["samplers", "--json", &json],
            vec!["backward-error", "--json", &json],
            vec!["certify", "--json", &json, "--scenes", "nothing-matches"],
        ];
        for args in cases {
            let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
            let (code, err) = run_with_deadline(&args, Duration::from_secs(60));
            assert_eq!(code, 2, "{args:?}: {err}");
            assert!(
                err.contains(&format!("{what}.")) && err.contains("not a regular file"),
                "{args:?}: {err}"
            );
        }
    }
    // Inputs: a device or a FIFO is refused before it is opened (no hang, no endless read).
    let fifo = s(&fifo);
    let unused = s(&dir.join("unused.exr"));
    for input in ["/dev/zero", fifo.as_str()] {
        for args in [
            vec!["info", input],
            vec!["compare", input, &good],
            vec!["merge", &a, input, "-o", &unused],
            vec!["stack", input, &a, "-o", &unused],
            vec!["render", input],
        ] {
            let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
            let (code, err) = run_with_deadline(&args, Duration::from_secs(60));
            assert_eq!(code, 2, "{args:?}: {err}");
            assert!(
                err.contains("not a regular file") || err.contains("cannot read"),
                "{args:?}: {err}"
            );
        }
    }
    // The good output survived every refusal.
    assert!(Image::read(&dir.join("good.exr")).is_ok());
}

/// A write that fails half-way (the file size limit, as a full disk would): exit 2 naming the
/// path, the old output intact, no temporary file left.
#[test]
fn failed_writes_are_errors_and_keep_the_old_file() {
    let dir = scratch("efbig");
    let scene = write(&dir, "scene.xml", FLOOR_SCENE);
    let out = dir.join("out.exr");
    let r = linlight(&["render", &scene, "-o", &s(&out), "--quiet"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let old = std::fs::read(&out).unwrap();
    assert!(old.len() > 2048);
    let bin = env!("CARGO_BIN_EXE_linlight");
    for (args, target) in [
        (
            format!("render {scene} -o {} --seed 2 --quiet", s(&out)),
            out.clone(),
        ),
        (
            format!(
                "compare {0} {0} --json {1}",
                s(&out),
                s(&dir.join("c.json"))
            ),
            dir.join("c.json"),
        ),
    ] {
        if target != out {
            std::fs::write(&target, "x".repeat(4000)).unwrap();
        }
        let before = std::fs::read(&target).unwrap();
        // SIGXFSZ ignored: writes beyond 1 block (512 B or 1 KiB) fail with EFBIG.
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!("trap '' XFSZ; ulimit -f 1; exec {bin} {args}"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args}: {err}");
        assert!(err.contains(&s(&target)), "{args}: {err}");
        assert_eq!(std::fs::read(&target).unwrap(), before, "{args}");
    }
    let left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn outputs_are_never_inputs_or_each_other() {
    let dir = scratch("identity");
    let scene = write(&dir, "scene.xml", FLOOR_SCENE);
    let (a, b) = merge_inputs(&dir, 8, 4);
    let link = |from: &Path, name: &str| {
        let p = dir.join(name);
        std::fs::hard_link(from, &p).unwrap();
        s(&p)
    };
    let scene_link = link(Path::new(&scene), "scene-link.exr");
    let a_link = link(&a, "a-link.exr");
    let (a, b) = (s(&a), s(&b));
    let scene_bytes = std::fs::read(&scene).unwrap();
    let a_bytes = std::fs::read(&a).unwrap();
    let table = s(&dir.join("t.bin"));
    for (args, want) in [
        (vec!["render", &scene, "-o", &scene_link], "scene"),
        (vec!["merge", &a, &b, "-o", &a_link], "input"),
        (vec!["compare", &a, &b, "--diff-exr", &a_link], "a-link.exr"),
        (
            vec![
                "fit-ltc",
                "--size",
                "2",
                "--out",
                &table,
                "--heatmap",
                &table,
            ],
            "two different outputs",
        ),
    ] {
        let r = linlight(&args);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(want), "{args:?}: {}", r.stderr);
    }
    assert_eq!(std::fs::read(&scene).unwrap(), scene_bytes);
    assert_eq!(std::fs::read(&a).unwrap(), a_bytes);
}

/// A tiny deterministic generator for the kill points.
struct Lcg(u64);
impl Lcg {
    fn below(&mut self, n: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) % n
    }
}

/// `merge` killed at random points by SIGINT, SIGTERM or SIGKILL: the output is always the old
/// complete file or the new complete file.
#[test]
fn killed_writers_leave_old_or_new_file() {
    let dir = scratch("kill");
    let (a, b) = merge_inputs(&dir, 640, 480);
    let out = dir.join("merged.exr");
    // The old file: a different merge (other order, other merged_from); its duration sets the
    // range of the kill points (up to 1.5 times it: before, during and after the write).
    let t = Instant::now();
    let r = linlight(&["merge", &s(&b), &s(&a), "-o", &s(&out), "--quiet"]);
    let span = (t.elapsed().as_millis() as u64 * 3 / 2).max(50);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let old = std::fs::read(&out).unwrap();
    let mut rng = Lcg(25);
    let (mut old_seen, mut new_seen) = (0, 0);
    let start = Instant::now();
    let mut new: Option<Vec<u8>> = None;
    for round in 0..24 {
        let signal = ["INT", "TERM", "KILL"][round % 3];
        let mut child = common::command()
            .args(["merge", &s(&a), &s(&b), "-o", &s(&out), "--quiet"])
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(rng.below(span)));
        let _ = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(child.id().to_string())
            .status();
        let _ = child.wait();
        let now = std::fs::read(&out).unwrap();
        if now == old {
            old_seen += 1;
        } else {
            let img = Image::read(&out).unwrap_or_else(|e| panic!("round {round}: {e}"));
            assert_eq!(img.meta.extra["merged_from"], "a.exr;b.exr");
            match &new {
                Some(n) => assert_eq!(&now, n, "round {round}"),
                None => new = Some(now.clone()),
            }
            new_seen += 1;
            // Back to the old file for the next round.
            std::fs::write(&out, &old).unwrap();
        }
    }
    eprintln!(
        "24 kills within {span} ms: {old_seen} old, {new_seen} new file, {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert_eq!(old_seen + new_seen, 24);
}

/// Two merges writing one path at once: both succeed and the file is one of their outputs.
#[test]
fn concurrent_merges_leave_one_complete_file() {
    let dir = scratch("race");
    let (a, b) = merge_inputs(&dir, 320, 240);
    let out = dir.join("merged.exr");
    for round in 0..5 {
        let spawn = |x: &Path, y: &Path| {
            common::command()
                .args(["merge", &s(x), &s(y), "-o", &s(&out), "--quiet"])
                .spawn()
                .unwrap()
        };
        let (mut p, mut q) = (spawn(&a, &b), spawn(&b, &a));
        assert!(p.wait().unwrap().success() && q.wait().unwrap().success());
        let img = Image::read(&out).unwrap_or_else(|e| panic!("round {round}: {e}"));
        let from = &img.meta.extra["merged_from"];
        assert!(from == "a.exr;b.exr" || from == "b.exr;a.exr", "{from}");
    }
}

/// Refused before the work, not after it: radiance that overflows the f32 variance; and a scene
/// name outside Latin-1 is recorded escaped instead of failing at the end of the render.
#[test]
fn problems_are_found_before_rendering() {
    let dir = scratch("before");
    let hot = FLOOR_SCENE.replace("20000, 10000, 5000", "1e30, 1e30, 1e30");
    let scene = write(&dir, "hot.xml", hot);
    let out = s(&dir.join("hot.exr"));
    let start = Instant::now();
    let r = linlight(&["render", &scene, "-o", &out, "-D", "spp=4096"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains("overflow") && r.stderr.contains("hot.xml:"),
        "{}",
        r.stderr
    );
    assert!(start.elapsed() < Duration::from_secs(5));
    assert!(!Path::new(&out).exists());
    let scene = write(&dir, "сцена.xml", FLOOR_SCENE);
    let out = dir.join("сцена.exr");
    let r = linlight(&["render", &scene, "-o", &s(&out), "--quiet"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let img = Image::read(&out).unwrap();
    assert!(
        img.meta.extra["scene"].contains("%D1%81%D1%86%D0%B5%D0%BD%D0%B0.xml"),
        "{:?}",
        img.meta.extra
    );
}
