//! Deterministic, seeded, mutation-based fuzzing of every reader on the stable toolchain:
//! scene XML, OBJ, PLY, EXR, shard JSON (`certify --merge`) and the LTC table.
//!
//! Each reader starts from its corpus: the files in `tests/fuzz-corpus/<reader>/` (small
//! inputs and every input that ever crashed a reader) and the committed scenes, meshes,
//! images and table. Every corpus file is run as it is, then `LINLIGHT_FUZZ_CASES` (default
//! 10 000) mutants per reader: 1–4 stacked byte-level mutations (bit flips, interesting bytes
//! and integers, deleted, duplicated and spliced ranges, numbers replaced by extreme values,
//! truncation) from the seed `LINLIGHT_FUZZ_SEED` (default 1). Shard reports are also
//! mutated as JSON values and resealed (their hash recomputed, as a forger would), then
//! merged with the other shard: a merge that succeeds must give the unforged verdict.
//!
//! Every case must end in a value or an error: a panic fails the test, a case that runs longer
//! than [`CASE_LIMIT`] aborts it (a hang), and an allocation beyond [`MEMORY_CAP`] of live
//! memory aborts it (unbounded memory). A failing input is saved under
//! `target/fuzz-failures/<reader>/` with the seed and case number; add it to
//! `tests/fuzz-corpus/<reader>/` with the fix.

use linlight::certify::shard;
use linlight_brdf::ltc::table::GgxLtcTable;
use linlight_imagefile::Image;
use serde_json::Value;
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Longest a single case may run.
const CASE_LIMIT: Duration = Duration::from_secs(10);
/// Most live heap memory of the whole fuzz run (all readers run in parallel).
const MEMORY_CAP: usize = 6 << 30;
/// Memory an EXR read may use (the readers' `--max-memory`).
const EXR_MEMORY: u64 = 256 << 20;
/// Largest mutant (duplications grow inputs); XML mutants stay smaller (see [`Reader::max_len`]).
const MAX_CASE_BYTES: usize = 1 << 20;

/// Counts live heap bytes and refuses to grow past [`MEMORY_CAP`].
struct Capped;
static LIVE: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let before = LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        if before + layout.size() > MEMORY_CAP {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            eprintln!(
                "fuzz: an allocation of {} bytes would exceed the cap of {MEMORY_CAP} live bytes \
                 (unbounded memory)",
                layout.size()
            );
            std::process::abort();
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            let grow = new_size - layout.size();
            if LIVE.fetch_add(grow, Ordering::Relaxed) + grow > MEMORY_CAP {
                eprintln!("fuzz: a reallocation to {new_size} bytes exceeds the memory cap");
                std::process::abort();
            }
        } else {
            LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOC: Capped = Capped;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

/// splitmix64: a small deterministic generator.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const NUMBERS: [&str; 16] = [
    "0",
    "-1",
    "1e30",
    "-1e30",
    "1e-300",
    "1e308",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "-2147483649",
    "99999999999999999999",
    "0.0",
    "1e-45",
    "65536",
    "3",
];
const BYTES: [u8; 14] = [
    0, 0xff, 0x7f, 0x80, b'0', b'9', b'<', b'>', b'"', b'/', b'\n', b' ', b'-', b'e',
];
const WORDS: [u32; 8] = [
    0,
    1,
    0x7fff_ffff,
    0xffff_ffff,
    0x8000_0000,
    1 << 20,
    0xffff,
    100_000,
];

/// One byte-level mutation of `data` (`others`: the reader's corpus, for splicing).
fn mutate_once(data: &mut Vec<u8>, others: &[Vec<u8>], rng: &mut Rng) {
    let len = data.len();
    let at = rng.below(len + 1);
    match rng.below(9) {
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
            let i = rng.below(len);
            data[i] = BYTES[rng.below(BYTES.len())];
        }
        2 if len > 0 => {
            let n = 1 + rng.below(16.min(len - at.min(len - 1)));
            let from = at.min(len - 1);
            data.drain(from..(from + n).min(len));
        }
        3 if len > 0 => {
            let from = rng.below(len);
            let n = 1 + rng.below((len - from).min(256));
            let chunk = data[from..from + n].to_vec();
            data.splice(at..at, chunk);
        }
        4 => {
            let n = 1 + rng.below(8);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            data.splice(at..at, bytes);
        }
        5 if len > 1 => data.truncate(rng.below(len)),
        6 => {
            // A run of ASCII digits (with sign, point, exponent) replaced by an extreme number.
            let starts: Vec<usize> = (0..len)
                .filter(|&i| data[i].is_ascii_digit() && (i == 0 || !data[i - 1].is_ascii_digit()))
                .collect();
            if let Some(&s) = starts.get(rng.below(starts.len())) {
                let mut e = s;
                while e < len && (data[e].is_ascii_digit() || b".eE+-".contains(&data[e])) {
                    e += 1;
                }
                let s = if s > 0 && data[s - 1] == b'-' {
                    s - 1
                } else {
                    s
                };
                data.splice(s..e, NUMBERS[rng.below(NUMBERS.len())].bytes());
            }
        }
        7 if !others.is_empty() => {
            let o = &others[rng.below(others.len())];
            if !o.is_empty() {
                let from = rng.below(o.len());
                let n = 1 + rng.below((o.len() - from).min(512));
                data.splice(at..at, o[from..from + n].iter().copied());
            }
        }
        _ if len >= 4 => {
            let i = rng.below(len - 3);
            let w = WORDS[rng.below(WORDS.len())].to_le_bytes();
            data[i..i + 4].copy_from_slice(&w);
        }
        _ => data.push(rng.next() as u8),
    }
}

/// What a reader does with one input file; the error text is not checked (clean errors are
/// the point), only that the call returns.
type ReadFn = fn(&Path, &Path) -> Result<(), String>;

struct Reader {
    name: &'static str,
    /// File name of the case in the reader's scratch directory.
    file: &'static str,
    read: ReadFn,
    /// Largest mutant kept (larger ones are cut).
    max_len: usize,
}

/// A tiny scene loading `mesh.<ext>` from its directory.
fn mesh_scene(ty: &str, file: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>
  </sensor>
  <shape type="{ty}"><string name="filename" value="{file}"/></shape>
  <shape type="cylinder">
    <point name="p0" value="0, 0, 2"/><point name="p1" value="1, 0, 2"/>
    <float name="radius" value="0.01"/>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
</scene>
"#
    )
}

fn read_scene(case: &Path, _dir: &Path) -> Result<(), String> {
    linlight_render::xml::load_scene(case, &[])
        .map(|_| ())
        .map_err(|e| e.to_string())
}

fn read_mesh(case: &Path, dir: &Path) -> Result<(), String> {
    let ext = case.extension().unwrap().to_str().unwrap();
    let scene = dir.join(format!("scene-{ext}.xml"));
    if !scene.exists() {
        std::fs::write(
            &scene,
            mesh_scene(ext, case.file_name().unwrap().to_str().unwrap()),
        )
        .unwrap();
    }
    read_scene(&scene, dir)
}

fn read_exr(case: &Path, _dir: &Path) -> Result<(), String> {
    let a = Image::read_within(case, EXR_MEMORY).map(|_| ());
    let b = Image::read_unchecked_within(case, EXR_MEMORY).map(|_| ());
    a.and(b).map_err(|e| e.to_string())
}

fn read_ltc(case: &Path, _dir: &Path) -> Result<(), String> {
    let bytes = std::fs::read(case).map_err(|e| e.to_string())?;
    GgxLtcTable::from_bytes(&bytes)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// Shard 1 of the corpus pair (read once) and the verdict of the unforged merge with shard 2.
fn shard_pair() -> &'static (PathBuf, linlight::certify::Report, String) {
    static PAIR: std::sync::OnceLock<(PathBuf, linlight::certify::Report, String)> =
        std::sync::OnceLock::new();
    PAIR.get_or_init(|| {
        let dir = root().join("tests/fuzz-corpus/shard");
        let one = dir.join("floor-tube-shard-1-of-2.json");
        let report = shard::read(&one).expect("the corpus shard 1 reads");
        let two = dir.join("floor-tube-shard-2-of-2.json");
        let verdict = merged_verdict(&one, &report, &two).expect("the corpus shards merge");
        (one, report, verdict)
    })
}

fn merged_verdict(
    one: &Path,
    first: &linlight::certify::Report,
    two: &Path,
) -> Result<String, String> {
    let b = shard::read(two).map_err(|e| e.to_string())?;
    let shards = vec![(one.into(), first.clone()), (two.into(), b)];
    let r = shard::merge(shards, false).map_err(|e| e.to_string())?;
    Ok(r.verdict.label().to_string())
}

/// Forgeries accepted by the merge (a mutated, resealed shard that merged to another verdict).
static FORGERIES: AtomicU64 = AtomicU64::new(0);

fn read_shard(case: &Path, _dir: &Path) -> Result<(), String> {
    let (one, first, verdict) = shard_pair();
    let merged = merged_verdict(one, first, case);
    if let Ok(v) = &merged {
        if v != verdict {
            FORGERIES.fetch_add(1, Ordering::Relaxed);
            eprintln!(
                "fuzz: forged shard {} merged to {v} (unforged: {verdict})",
                case.display()
            );
        }
    }
    merged.map(|_| ())
}

/// A JSON-level mutation of a shard, resealed: a number changed, a key removed, an array
/// element duplicated or removed, a string or boolean flipped.
fn mutate_json(v: &mut Value, rng: &mut Rng) {
    let mut paths: Vec<Vec<PathStep>> = Vec::new();
    collect(v, &mut Vec::new(), &mut paths);
    let Some(path) = paths.get(rng.below(paths.len())) else {
        return;
    };
    let Some((last, parent_path)) = path.split_last() else {
        return;
    };
    let mut parent = &mut *v;
    for step in parent_path {
        parent = match step {
            PathStep::Key(k) => &mut parent[k.as_str()],
            PathStep::Index(i) => &mut parent[*i],
        };
    }
    let target = match last {
        PathStep::Key(k) => &mut parent[k.as_str()],
        PathStep::Index(i) => &mut parent[*i],
    };
    match rng.below(6) {
        0 => {
            let x: f64 = NUMBERS[rng.below(NUMBERS.len())].parse().unwrap_or(0.0);
            *target = if x.is_finite() {
                Value::from(x)
            } else {
                Value::Null
            };
        }
        1 => {
            if let Some(x) = target.as_f64() {
                *target = Value::from(x * [0.5, 1.5, -1.0, 1e-9, 1e9][rng.below(5)]);
            }
        }
        2 => *target = Value::from(!target.as_bool().unwrap_or(false)),
        3 => {
            *target = Value::from(
                ["CONSISTENT", "DIFFERENT", "INCONCLUSIVE", "mitsuba", ""][rng.below(5)],
            )
        }
        4 => match (parent, last) {
            (Value::Object(m), PathStep::Key(k)) => {
                m.remove(k);
            }
            (Value::Array(a), PathStep::Index(i)) => {
                a.remove(*i);
            }
            _ => {}
        },
        _ => {
            if let (Value::Array(a), PathStep::Index(i)) = (parent, last) {
                let dup = a[*i].clone();
                a.insert(*i, dup);
            }
        }
    }
}

enum PathStep {
    Key(String),
    Index(usize),
}

fn collect(v: &Value, at: &mut Vec<PathStep>, out: &mut Vec<Vec<PathStep>>) {
    let here = |at: &Vec<PathStep>| {
        at.iter()
            .map(|s| match s {
                PathStep::Key(k) => PathStep::Key(k.clone()),
                PathStep::Index(i) => PathStep::Index(*i),
            })
            .collect()
    };
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                at.push(PathStep::Key(k.clone()));
                out.push(here(at));
                collect(x, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push(PathStep::Index(i));
                out.push(here(at));
                collect(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn reseal(v: &mut Value) {
    let h = shard::content_hash(v);
    v["content_sha256"] = Value::from(h);
}

fn corpus(reader: &str, committed: &[&str]) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("tests/fuzz-corpus").join(reader))
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default();
    files.sort();
    files.extend(committed.iter().map(|p| root().join(p)));
    files
        .into_iter()
        .filter(|p| p.is_file())
        .map(|p| (p.display().to_string(), std::fs::read(&p).unwrap()))
        .collect()
}

/// The case being run, for the watchdog.
struct Current {
    started_ms: AtomicU64,
    busy: AtomicBool,
    input: Mutex<Vec<u8>>,
    label: Mutex<String>,
}

fn now_ms() -> u64 {
    static T0: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    T0.get_or_init(Instant::now).elapsed().as_millis() as u64
}

fn save_failure(reader: &str, label: &str, input: &[u8]) -> PathBuf {
    let dir = root().join("target/fuzz-failures").join(reader);
    std::fs::create_dir_all(&dir).unwrap();
    let name: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    let p = dir.join(name);
    std::fs::write(&p, input).unwrap();
    p
}

fn quiet_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if std::thread::current()
                .name()
                .is_some_and(|n| n.starts_with("fuzz-"))
            {
                eprintln!("fuzz: panic: {info}");
            } else {
                default(info);
            }
        }));
    });
}

/// Runs the corpus and `cases` mutants through `reader`; returns (cases, failures).
fn fuzz(reader: Reader, committed: &[&str], json_mutants: bool) {
    quiet_panics();
    let cases = env_u64("LINLIGHT_FUZZ_CASES", 10_000) as usize;
    let seed = env_u64("LINLIGHT_FUZZ_SEED", 1);
    let seeds = corpus(reader.name, committed);
    assert!(!seeds.is_empty(), "{}: empty corpus", reader.name);
    let bodies: Vec<Vec<u8>> = seeds.iter().map(|(_, b)| b.clone()).collect();
    let dir = std::env::temp_dir().join(format!(
        "linlight-fuzz-{}-{}",
        std::process::id(),
        reader.name
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let case_path = dir.join(reader.file);

    let current = Arc::new(Current {
        started_ms: AtomicU64::new(0),
        busy: AtomicBool::new(false),
        input: Mutex::new(Vec::new()),
        label: Mutex::new(String::new()),
    });
    let done = Arc::new(AtomicBool::new(false));
    let watchdog = {
        let (current, done, name) = (current.clone(), done.clone(), reader.name);
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
                let started = current.started_ms.load(Ordering::Relaxed);
                if current.busy.load(Ordering::Relaxed)
                    && now_ms().saturating_sub(started) > CASE_LIMIT.as_millis() as u64
                {
                    let label = current.label.lock().unwrap().clone();
                    let p = save_failure(name, &label, &current.input.lock().unwrap());
                    eprintln!(
                        "fuzz: {name} case {label} runs longer than {CASE_LIMIT:?} (a hang); \
                         input saved to {}",
                        p.display()
                    );
                    std::process::abort();
                }
            }
        })
    };

    let mut rng = Rng(seed ^ (reader.name.len() as u64) << 32 ^ reader.name.as_bytes()[0] as u64);
    let mut panics = Vec::new();
    let (mut ok, mut err) = (0usize, 0usize);
    let start = Instant::now();
    let total = seeds.len() + cases;
    for k in 0..total {
        let (label, input) = if k < seeds.len() {
            (format!("corpus {}", seeds[k].0), seeds[k].1.clone())
        } else {
            let base = &bodies[rng.below(bodies.len())];
            let mut data = base.clone();
            let resealed = json_mutants && rng.below(2) == 0;
            if resealed {
                if let Ok(mut v) = serde_json::from_slice::<Value>(&data) {
                    mutate_json(&mut v, &mut rng);
                    reseal(&mut v);
                    data = serde_json::to_vec(&v).unwrap();
                }
            } else {
                for _ in 0..1 + rng.below(4) {
                    mutate_once(&mut data, &bodies, &mut rng);
                }
            }
            data.truncate(reader.max_len);
            (format!("seed {seed} case {k}"), data)
        };
        std::fs::write(&case_path, &input).unwrap();
        *current.input.lock().unwrap() = input.clone();
        *current.label.lock().unwrap() = label.clone();
        current.started_ms.store(now_ms(), Ordering::Relaxed);
        current.busy.store(true, Ordering::Relaxed);
        let result = std::thread::Builder::new()
            .name(format!("fuzz-{}", reader.name))
            .spawn({
                let (p, d, read) = (case_path.clone(), dir.clone(), reader.read);
                move || read(&p, &d)
            })
            .unwrap()
            .join();
        current.busy.store(false, Ordering::Relaxed);
        match result {
            Ok(Ok(())) => ok += 1,
            Ok(Err(_)) => err += 1,
            Err(_) => {
                let p = save_failure(reader.name, &label, &input);
                panics.push(format!("{label}: input saved to {}", p.display()));
            }
        }
    }
    done.store(true, Ordering::Relaxed);
    watchdog.join().unwrap();
    let secs = start.elapsed().as_secs_f64();
    eprintln!(
        "fuzz {}: {total} cases ({} corpus) in {secs:.1} s = {:.0} cases/s; {ok} read, {err} \
         refused with an error, {} panics",
        reader.name,
        seeds.len(),
        total as f64 / secs,
        panics.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        panics.is_empty(),
        "{} panics:\n{}",
        reader.name,
        panics.join("\n")
    );
}

#[test]
fn fuzz_scene_xml() {
    fuzz(
        Reader {
            name: "xml",
            file: "scene.xml",
            read: read_scene,
            // Mutants stay below 64 KiB (the committed scenes are 2–5 KiB): larger ones only
            // cost throughput.
            max_len: 64 << 10,
        },
        &[
            "references/scenes/cornell-tube.xml",
            "references/scenes/floor-crossing.xml",
            "references/scenes/floor-tube.xml",
            "references/scenes/glossy-blend.xml",
            "references/scenes/glossy-conductor-rough.xml",
            "references/scenes/glossy-conductor-sharp.xml",
            "references/scenes/glossy-cornell.xml",
            "references/scenes/glossy-principled.xml",
            "references/scenes/mesh-occluder.xml",
            "references/scenes/two-tubes.xml",
            "tests/scenes/visible-tube.xml",
        ],
        false,
    );
}

#[test]
fn fuzz_obj() {
    fuzz(
        Reader {
            name: "obj",
            file: "mesh.obj",
            read: read_mesh,
            max_len: MAX_CASE_BYTES,
        },
        &["references/scenes/meshes/torus.obj"],
        false,
    );
}

#[test]
fn fuzz_ply() {
    fuzz(
        Reader {
            name: "ply",
            file: "mesh.ply",
            read: read_mesh,
            max_len: MAX_CASE_BYTES,
        },
        &[],
        false,
    );
}

#[test]
fn fuzz_exr() {
    fuzz(
        Reader {
            name: "exr",
            file: "image.exr",
            read: read_exr,
            max_len: MAX_CASE_BYTES,
        },
        &["tests/references/visible-tube.exr"],
        false,
    );
}

#[test]
fn fuzz_shard_json() {
    fuzz(
        Reader {
            name: "shard",
            file: "shard.json",
            read: read_shard,
            max_len: MAX_CASE_BYTES,
        },
        &[],
        true,
    );
    assert_eq!(
        FORGERIES.load(Ordering::Relaxed),
        0,
        "forged shards merged to another verdict"
    );
}

#[test]
fn fuzz_ltc_table() {
    fuzz(
        Reader {
            name: "ltc",
            file: "table.bin",
            read: read_ltc,
            max_len: MAX_CASE_BYTES,
        },
        &["crates/brdf/data/ggx_ltc.bin"],
        false,
    );
}
