//! `linlight`: certify importance sampling of linear lights and renders against Mitsuba 3.
//!
//! Exit codes of every subcommand: 0 = success / consistent, 1 = a check failed,
//! 2 = bad usage or unusable input, 3 = inconclusive (compare, certify). See docs/exit-codes.md.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

mod cmd;

#[derive(Parser)]
#[command(name = "linlight", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job: sampler suite + every unbiased technique (on glossy scenes also LTC and MIS
    /// with every heuristic) on every scene against Mitsuba (exit 0 all consistent, 1 a check
    /// failed, 2 unusable input, 3 inconclusive).
    #[command(after_help = cmd::certify::AFTER_HELP)]
    Certify(cmd::certify::Args),
    /// Chi-square certification of every line-sampling and finite-cylinder technique (exit 0
    /// only if all pass).
    Samplers(cmd::samplers::Args),
    /// Worst backward error of the projected-solid-angle inversion, per iteration count.
    BackwardError(cmd::backward_error::Args),
    /// Render a Mitsuba-XML scene with linear lights to EXR (mean + variance of the mean).
    Render(cmd::render::Args),
    /// Statistical comparison of two mean+variance EXRs (exit 0 consistent, 1 different,
    /// 2 unusable input, 3 inconclusive).
    Compare(cmd::compare::Args),
    /// Header, per-channel mean ± standard error and NaN/inf/negative/zero-variance pixel counts
    /// of an image (exit 1 if it is not a valid image of the shared format, a plain RGB EXR
    /// included; 2 if it cannot be read).
    Info(cmd::info::Args),
    /// Combine independent mean+variance images of one scene into one (runs, machines).
    Merge(cmd::merge::Args),
    /// Mean + variance image (dof N − 1) from N ≥ 2 independent plain RGB renders of any
    /// renderer (different seeds), for compare, info and merge.
    Stack(cmd::stack::Args),
    /// Load a scene without rendering: what is supported, every refusal (file:line:col, in file
    /// order) and every warning (exit 0 loads, 2 refused).
    Check(cmd::check::Args),
    /// Regenerate every experiment of the paper: PNGs, plots, CSV/JSON and one index.html
    /// (--quick: small sizes, a few minutes).
    #[command(after_help = cmd::figures::AFTER_HELP)]
    Figures(cmd::figures::Args),
    /// False-alarm rate and power of compare on real renders (seed pairs per scene family).
    Calibrate(cmd::calibrate::Args),
    /// Fit the GGX LTC table (deterministic) and report its error; --check re-fits a sample
    /// and compares it with the committed table (exit 0 consistent, 1 mismatch, 2 bad input).
    #[command(after_help = cmd::fit_ltc::AFTER_HELP)]
    FitLtc(cmd::fit_ltc::Args),
    /// The exact unshadowed image of an unoccluded plane (closed form, or quadrature along the
    /// line for glossy BSDFs), variance 0: the ground truth certify compares with.
    Unshadowed(cmd::unshadowed::Args),
}

/// The method names for `--help` (from the render crate, so the list cannot go stale).
fn technique_help() -> String {
    let names: Vec<String> = linlight_render::Method::technique_names()
        .into_iter()
        .map(|(name, what)| format!("{name} ({what})"))
        .collect();
    format!("Light sampling method: {}", names.join("; "))
}

/// `linlight … | head`: when stdout's reader has gone, the program ends as a C tool does on
/// SIGPIPE (status 141 in a shell) instead of panicking in `println!`. Only that panic is caught:
/// the pipes to an external sampler report their errors as values (SIGPIPE stays ignored there).
fn end_quietly_on_closed_stdout() {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info.payload_as_str().unwrap_or("");
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            // SAFETY: restoring the default disposition and raising a signal have no
            // preconditions; the default action of SIGPIPE ends the process.
            unsafe {
                libc::signal(libc::SIGPIPE, libc::SIG_DFL);
                libc::raise(libc::SIGPIPE);
            }
        }
        previous(info)
    }));
}

fn main() -> ExitCode {
    // First: it may set an environment variable, which only a single thread may do.
    #[cfg(feature = "gpu")]
    linlight_gpu::without_display_device_select();
    end_quietly_on_closed_stdout();
    let command = Cli::command().mut_subcommand("render", |c| {
        c.mut_arg("technique", |a| a.help(technique_help()))
    });
    let cli = match Cli::from_arg_matches(&command.get_matches()) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    match cli.command {
        Command::Certify(a) => cmd::certify::run(a),
        Command::Samplers(a) => cmd::samplers::run(a),
        Command::BackwardError(a) => cmd::backward_error::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Info(a) => cmd::info::run(a),
        Command::Merge(a) => cmd::merge::run(a),
        Command::Stack(a) => cmd::stack::run(a),
        Command::Check(a) => cmd::check::run(a),
        Command::Calibrate(a) => cmd::calibrate::run(a),
        Command::FitLtc(a) => cmd::fit_ltc::run(a),
        Command::Unshadowed(a) => cmd::unshadowed::run(a),
        Command::Figures(a) => cmd::figures::run(a),
    }
}
