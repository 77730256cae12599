//! `linlight … | head`: a reader that has gone must end the program as SIGPIPE ends a C tool,
//! never with a panic and its backtrace.

mod common;

use common::{command, root};
use std::os::unix::process::ExitStatusExt;
use std::process::Stdio;

/// Runs `args` with a stdout whose reader is already closed: every write fails with EPIPE.
fn run_with_closed_stdout(args: &[&str]) -> (std::process::ExitStatus, String) {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let out = command()
        .args(args)
        .current_dir(root())
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .expect("the linlight binary runs");
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_closed_stdout_never_panics() {
    let reference = "references/mitsuba/two-tubes.exr";
    let commands: [&[&str]; 4] = [
        &["compare", reference, reference],
        &["info", reference],
        &["check", "references/scenes/two-tubes.xml"],
        &["unshadowed", "--help"],
    ];
    for args in commands {
        let (status, stderr) = run_with_closed_stdout(args);
        assert!(!stderr.contains("panicked"), "{args:?} panicked:\n{stderr}");
        // SIGPIPE, or a command that ignores its lost output and exits with its own code.
        let quiet_end = status.signal() == Some(libc::SIGPIPE) || status.code() == Some(0);
        assert!(quiet_end, "{args:?} ended with {status:?}:\n{stderr}");
    }
}
