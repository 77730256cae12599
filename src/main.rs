//! `linlight`: certify importance sampling of linear lights and renders against Mitsuba 3.
//!
//! Exit codes of every subcommand: 0 = success / consistent, 1 = a check failed,
//! 2 = bad usage or unusable input, 3 = inconclusive (compare, certify). See docs/exit-codes.md.

use clap::{Parser, Subcommand};
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
    /// The main job: sampler suite + every unbiased technique on every scene against Mitsuba
    /// (exit 0 all consistent, 1 a check failed, 2 unusable input).
    Certify(cmd::certify::Args),
    /// Chi-square certification of every line-sampling technique (exit 0 only if all pass).
    Samplers(cmd::samplers::Args),
    /// Worst backward error of the projected-solid-angle inversion, per iteration count.
    BackwardError(cmd::backward_error::Args),
    /// Render a Mitsuba-XML scene with linear lights to EXR (mean + variance of the mean).
    Render(cmd::render::Args),
    /// Statistical comparison of two mean+variance EXRs (exit 0 consistent, 1 different,
    /// 2 unusable input, 3 inconclusive).
    Compare(cmd::compare::Args),
    /// False-alarm rate and power of compare on real renders (seed pairs per scene family).
    Calibrate(cmd::calibrate::Args),
    /// Fit the GGX LTC table (deterministic) and report its error; --check re-fits a sample
    /// and compares it with the committed table (exit 0 consistent, 1 mismatch, 2 bad input).
    #[command(after_help = cmd::fit_ltc::AFTER_HELP)]
    FitLtc(cmd::fit_ltc::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Certify(a) => cmd::certify::run(a),
        Command::Samplers(a) => cmd::samplers::run(a),
        Command::BackwardError(a) => cmd::backward_error::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Calibrate(a) => cmd::calibrate::run(a),
        Command::FitLtc(a) => cmd::fit_ltc::run(a),
    }
}
