//! The external sampler protocol, versions 1 and 2 (docs/external-protocol.md): a program
//! started with `sh -c COMMAND` answers the sampler suite's batches on its stdin/stdout, so that
//! any implementation of a line-sampling technique, in any language, is certified by the same
//! checks as the Rust samplers (`linlight samplers --external`).
//!
//! Every message is one line of JSON, then (for batches) little-endian f32 arrays whose length
//! the line states. The program speaks first (its hello), then answers each request in order.
//! Version 2 adds, for technique `ltc`, the configurations of the fitted GGX table's grid, whose
//! configuration carries the (α, cos θ_o) its matrix A was looked up at (key `ggx`); a version-1
//! program never sees them, nor the key.
//!
//! Everything that is not the protocol, and every request not answered within the timeout,
//! ends the program (killed if still running) and becomes a one-line [`SourceError`].

use glam::Vec3;
use linlight_verify::answers::{AnswerSource, SampleAnswers, SourceError};
use linlight_verify::configs::{ltc_table_grid, Config, GgxPoint};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::process::CommandExt;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// The protocol's name in the hello line.
pub const PROTOCOL: &str = "linlight-external";

/// The newest protocol version this linlight speaks; it speaks every version from 1 on.
pub const VERSION: u32 = 2;

/// Longest JSON line accepted from the program (a longer one is not the protocol).
const MAX_LINE: usize = 64 * 1024;

/// The program's first line.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hello {
    pub protocol: String,
    pub version: u32,
    /// The technique it implements (its reference in the suite): a name of
    /// [`linlight_sampling::Technique::UNBIASED`] or "ltc".
    pub technique: String,
    /// Whether its sample answers carry the inverse ξ' of each direction.
    #[serde(default)]
    pub inverse: bool,
    /// Shown in the report.
    #[serde(default)]
    pub name: Option<String>,
}

/// The header line of an answer.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AnswerHeader {
    id: u64,
    count: usize,
}

/// A configuration as sent to the program: everything an implementation needs, in world space.
#[derive(Serialize)]
struct WireConfig<'a> {
    name: &'a str,
    begin: [f32; 3],
    end: [f32; 3],
    /// Shading point.
    x: [f32; 3],
    /// Unit normal.
    n: [f32; 3],
    /// Unit view direction (defines the LTC shading frame).
    view: [f32; 3],
    /// Shading frame: x̂, ŷ, n as three unit vectors.
    frame: [[f32; 3]; 3],
    /// LTC matrix A (shading → cosine space) in shading-frame coordinates, row-major.
    ltc_a: [[f32; 3]; 3],
    /// Version 2, configurations of the fitted table's grid: where A was looked up.
    #[serde(skip_serializing_if = "Option::is_none")]
    ggx: Option<WireGgx>,
}

#[derive(Serialize)]
struct WireGgx {
    alpha: f32,
    cos_theta_o: f32,
}

impl<'a> WireConfig<'a> {
    fn of(c: &'a Config, ggx: Option<GgxPoint>) -> Self {
        let f = c.shading_frame();
        Self {
            name: &c.name,
            begin: c.begin,
            end: c.end,
            x: c.x,
            n: c.n,
            view: c.view,
            frame: [f.x_axis.into(), f.y_axis.into(), f.z_axis.into()],
            ltc_a: c.a_rows,
            ggx: ggx.map(|g| WireGgx {
                alpha: g.alpha,
                cos_theta_o: g.cos_theta_o,
            }),
        }
    }
}

#[derive(Serialize)]
struct Request<'a> {
    op: &'static str,
    id: u64,
    count: usize,
    config: WireConfig<'a>,
}

/// What the reader thread must read next: an answer of `floats` f32 values to request `id`.
struct Expect {
    id: u64,
    count: usize,
    floats: usize,
}

/// An answer's payload as read, or why it could not be read.
type Answer = Result<Vec<f32>, String>;

/// What the program answered, and the wall time from each request's first byte to its answer's
/// last (the protocol's throughput, the program's own work included).
#[derive(Clone, Copy, Debug, Default)]
pub struct Traffic {
    pub requests: usize,
    /// Primary samples answered (sample requests).
    pub samples: usize,
    /// Directions whose density was answered (pdf requests).
    pub densities: usize,
    pub sample_seconds: f64,
    pub pdf_seconds: f64,
}

/// A running external sampler.
pub struct ExternalSampler {
    command: String,
    child: Child,
    hello: Hello,
    timeout: Duration,
    stdin: Option<Sender<Vec<u8>>>,
    expect: Option<Sender<Expect>>,
    answers: Receiver<Answer>,
    stderr_tail: Arc<Mutex<String>>,
    threads: Vec<JoinHandle<()>>,
    next_id: u64,
    traffic: Arc<Mutex<Traffic>>,
    /// Version ≥ 2: the (α, cos θ_o) of each fitted-table configuration, by name.
    ggx: HashMap<String, GgxPoint>,
}

impl ExternalSampler {
    /// Start `sh -c command` and read its hello (within `timeout`).
    pub fn start(command: &str, timeout: Duration) -> Result<Self, SourceError> {
        // Its own process group, so that a hung program is ended with everything it started.
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(command)
            .process_group(0)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| SourceError(format!("cannot start `sh -c {command}`: {e}")))?;
        let stdin = child.stdin.take().expect("piped stdin");
        let stdout = child.stdout.take().expect("piped stdout");
        let stderr = child.stderr.take().expect("piped stderr");
        let stderr_tail = Arc::new(Mutex::new(String::new()));
        // The writer thread owns the pipe: a program that stops reading blocks that thread,
        // never the suite (which then times out).
        let (to_writer, writer_rx) = mpsc::channel::<Vec<u8>>();
        let (expect_tx, expect_rx) = mpsc::channel::<Expect>();
        let (answer_tx, answer_rx) = mpsc::channel::<Answer>();
        let (hello_tx, hello_rx) = mpsc::channel::<Result<String, String>>();
        let mut threads = vec![writer_thread(writer_rx, stdin)];
        threads.push(std::thread::spawn(move || {
            read_answers(stdout, hello_tx, expect_rx, answer_tx)
        }));
        let tail = Arc::clone(&stderr_tail);
        threads.push(std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if !line.trim().is_empty() {
                    *tail.lock().unwrap_or_else(|e| e.into_inner()) = line;
                }
            }
        }));
        let mut me = Self {
            command: command.to_string(),
            child,
            hello: Hello {
                protocol: String::new(),
                version: 0,
                technique: String::new(),
                inverse: false,
                name: None,
            },
            timeout,
            stdin: Some(to_writer),
            expect: Some(expect_tx),
            answers: answer_rx,
            stderr_tail,
            threads,
            next_id: 0,
            traffic: Arc::default(),
            ggx: HashMap::new(),
        };
        let line = match hello_rx.recv_timeout(timeout) {
            Ok(Ok(line)) => line,
            Ok(Err(e)) => return Err(me.fail(&format!("no hello line: {e}"))),
            Err(_) => {
                return Err(me.fail(&format!(
                    "no hello line within {} s (--timeout)",
                    timeout.as_secs_f64()
                )))
            }
        };
        let hello: Hello = serde_json::from_str(&line).map_err(|e| {
            me.fail(&format!(
                "its hello line is not the protocol's ({e}): {}",
                shorten(&line)
            ))
        })?;
        if hello.protocol != PROTOCOL || !(1..=VERSION).contains(&hello.version) {
            return Err(me.fail(&format!(
                "it speaks protocol \"{}\" version {}; this linlight speaks \"{PROTOCOL}\" \
                 versions 1 to {VERSION}",
                hello.protocol, hello.version
            )));
        }
        if hello.version >= 2 {
            me.ggx = ltc_table_grid()
                .into_iter()
                .map(|(g, c)| (c.name, g))
                .collect();
        }
        me.hello = hello;
        Ok(me)
    }

    pub fn hello(&self) -> &Hello {
        &self.hello
    }

    /// A handle on the traffic counters (readable after the sampler is boxed into the suite).
    pub fn traffic(&self) -> Arc<Mutex<Traffic>> {
        Arc::clone(&self.traffic)
    }

    /// End the program (killed if running) and describe why, with its exit status and the last
    /// line it wrote to stderr.
    fn fail(&mut self, what: &str) -> SourceError {
        self.stdin = None;
        let status = match self.child.try_wait() {
            Ok(Some(s)) => Some(s),
            _ => {
                // It may be exiting: give it a moment before killing it.
                std::thread::sleep(Duration::from_millis(200));
                match self.child.try_wait() {
                    Ok(Some(s)) => Some(s),
                    _ => {
                        self.kill_group();
                        let _ = self.child.wait();
                        None
                    }
                }
            }
        };
        self.join_threads();
        let status = match status {
            Some(s) => match s.code() {
                Some(c) => format!("; it exited with status {c}"),
                None => format!("; it was ended by a signal ({s})"),
            },
            None => "; it was killed".to_string(),
        };
        let tail = self.stderr_tail.lock().unwrap_or_else(|e| e.into_inner());
        let tail = if tail.is_empty() {
            String::new()
        } else {
            format!("; its last stderr line: {}", shorten(&tail))
        };
        SourceError(format!(
            "external sampler `{}`: {what}{status}{tail}",
            self.command
        ))
    }

    /// SIGKILL to the program's process group (the shell and everything it started). Only
    /// while the shell is not yet reaped, so that its process group id is still ours.
    fn kill_group(&mut self) {
        // SAFETY: kill(2) with a negative pid signals the process group; no memory is involved.
        unsafe {
            libc::kill(-(self.child.id() as libc::pid_t), libc::SIGKILL);
        }
    }

    /// Close the channels to the threads and wait for them (the pipes are closed or the program
    /// is gone, so each ends).
    fn join_threads(&mut self) {
        self.stdin = None;
        self.expect = None;
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }

    /// Send one request and read its answer of `floats` f32 values.
    fn ask(
        &mut self,
        op: &'static str,
        config: &Config,
        count: usize,
        payload: &[f32],
        floats: usize,
    ) -> Result<Vec<f32>, SourceError> {
        let id = self.next_id;
        self.next_id += 1;
        let what = format!("{op} request {id} ({}, {count} entries)", config.name);
        let header = serde_json::to_string(&Request {
            op,
            id,
            count,
            config: WireConfig::of(config, self.ggx.get(&config.name).copied()),
        })
        .expect("a request serialises");
        let mut bytes = Vec::with_capacity(header.len() + 1 + 4 * payload.len());
        bytes.extend_from_slice(header.as_bytes());
        bytes.push(b'\n');
        for v in payload {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let started = std::time::Instant::now();
        let sent = self
            .expect
            .as_ref()
            .is_some_and(|e| e.send(Expect { id, count, floats }).is_ok())
            && self.stdin.as_ref().is_some_and(|s| s.send(bytes).is_ok());
        if !sent {
            return Err(self.fail(&format!("it stopped reading before {what}")));
        }
        match self.answers.recv_timeout(self.timeout) {
            Ok(Ok(values)) => {
                let seconds = started.elapsed().as_secs_f64();
                let mut t = self.traffic.lock().unwrap_or_else(|e| e.into_inner());
                t.requests += 1;
                if op == "sample" {
                    t.samples += count;
                    t.sample_seconds += seconds;
                } else {
                    t.densities += count;
                    t.pdf_seconds += seconds;
                }
                Ok(values)
            }
            Ok(Err(e)) => Err(self.fail(&format!("{e} (answering {what})"))),
            Err(RecvTimeoutError::Timeout) => Err(self.fail(&format!(
                "no answer to {what} within {} s (--timeout)",
                self.timeout.as_secs_f64()
            ))),
            Err(RecvTimeoutError::Disconnected) => {
                Err(self.fail(&format!("its stdout closed (answering {what})")))
            }
        }
    }

    /// Send "end", close its stdin and wait (within the timeout) for exit status 0.
    pub fn finish(&mut self) -> Result<(), SourceError> {
        if let Some(s) = self.stdin.take() {
            let _ = s.send(b"{\"op\":\"end\"}\n".to_vec());
        }
        let deadline = std::time::Instant::now() + self.timeout;
        loop {
            match self.child.try_wait() {
                Ok(Some(s)) if s.success() => {
                    self.join_threads();
                    return Ok(());
                }
                Ok(Some(_)) => return Err(self.fail("after the last request")),
                Ok(None) if std::time::Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20))
                }
                _ => {
                    return Err(self.fail(&format!(
                        "it did not exit within {} s of the end of the requests (--timeout)",
                        self.timeout.as_secs_f64()
                    )))
                }
            }
        }
    }
}

impl Drop for ExternalSampler {
    fn drop(&mut self) {
        self.stdin = None;
        if let Ok(None) = self.child.try_wait() {
            self.kill_group();
        }
        let _ = self.child.wait();
    }
}

impl AnswerSource for ExternalSampler {
    fn sample(&mut self, config: &Config, xi: &[f32]) -> Result<SampleAnswers, SourceError> {
        let n = xi.len();
        let per = 4 + usize::from(self.hello.inverse);
        let v = self.ask("sample", config, n, xi, per * n)?;
        let directions = v[..3 * n]
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let densities = v[3 * n..4 * n].to_vec();
        let inverse = self.hello.inverse.then(|| v[4 * n..5 * n].to_vec());
        Ok(SampleAnswers {
            directions,
            densities,
            inverse,
        })
    }

    fn pdf(&mut self, config: &Config, directions: &[Vec3]) -> Result<Vec<f32>, SourceError> {
        let flat: Vec<f32> = directions.iter().flat_map(|d| d.to_array()).collect();
        self.ask("pdf", config, directions.len(), &flat, directions.len())
    }

    fn finish(&mut self) -> Result<(), SourceError> {
        ExternalSampler::finish(self)
    }
}

/// At most 200 characters of a line from the program, printable.
fn shorten(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .take(200)
        .collect();
    if s.chars().count() > 200 {
        format!("{t}…")
    } else {
        t
    }
}

/// The writer thread: writes each buffer to the program's stdin until the channel closes or a
/// write fails (the program exited: the reader reports it).
fn writer_thread(rx: Receiver<Vec<u8>>, mut stdin: ChildStdin) -> JoinHandle<()> {
    std::thread::spawn(move || {
        for bytes in rx {
            if stdin.write_all(&bytes).and_then(|_| stdin.flush()).is_err() {
                break;
            }
        }
    })
}

/// One line of at most [`MAX_LINE`] bytes, without its newline.
fn read_line(r: &mut impl BufRead) -> Result<String, String> {
    let mut line = Vec::new();
    let read = r
        .take(MAX_LINE as u64 + 1)
        .read_until(b'\n', &mut line)
        .map_err(|e| format!("reading its stdout: {e}"))?;
    if read == 0 {
        return Err("its stdout ended".to_string());
    }
    if line.last() != Some(&b'\n') {
        return Err(if line.len() > MAX_LINE {
            format!("a line longer than {MAX_LINE} bytes where a JSON line was expected")
        } else {
            format!(
                "its stdout ended in the middle of a line: {}",
                shorten(&String::from_utf8_lossy(&line))
            )
        });
    }
    line.pop();
    String::from_utf8(line).map_err(|_| "a line that is not UTF-8".to_string())
}

/// The reader thread: the hello line, then for each expected answer its header and payload.
fn read_answers(
    stdout: std::process::ChildStdout,
    hello: Sender<Result<String, String>>,
    expect: Receiver<Expect>,
    answers: Sender<Answer>,
) {
    let mut r = BufReader::with_capacity(1 << 20, stdout);
    let first = read_line(&mut r);
    let ok = first.is_ok();
    if hello.send(first).is_err() || !ok {
        return;
    }
    for e in expect {
        let answer = read_answer(&mut r, &e);
        let ok = answer.is_ok();
        if answers.send(answer).is_err() || !ok {
            return;
        }
    }
}

fn read_answer(r: &mut impl BufRead, e: &Expect) -> Answer {
    let line = read_line(r)?;
    let header: AnswerHeader = serde_json::from_str(&line).map_err(|err| {
        format!(
            "an answer header that is not the protocol's ({err}): {}",
            shorten(&line)
        )
    })?;
    if header.id != e.id {
        return Err(format!(
            "the answer to request {} where {} was expected",
            header.id, e.id
        ));
    }
    if header.count != e.count {
        return Err(format!(
            "an answer of {} entries to a request of {}",
            header.count, e.count
        ));
    }
    let mut bytes = vec![0u8; 4 * e.floats];
    let mut filled = 0;
    while filled < bytes.len() {
        match r.read(&mut bytes[filled..]) {
            Ok(0) => {
                return Err(format!(
                    "its stdout ended after {filled} of the answer's {} payload bytes",
                    bytes.len()
                ))
            }
            Ok(k) => filled += k,
            Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
            Err(err) => return Err(format!("reading its stdout: {err}")),
        }
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}
