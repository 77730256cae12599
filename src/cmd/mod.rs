//! One module per subcommand; each exposes `Args` (clap) and `run(Args) -> ExitCode`.

pub mod backward_error;
pub mod calibrate;
pub mod certify;
pub mod check;
pub mod compare;
pub mod external;
pub mod figures;
pub mod fit_ltc;
pub mod gpu_kernels;
pub mod info;
pub mod merge;
pub mod render;
pub mod samplers;
pub mod stack;
pub mod suite_tables;
pub mod unshadowed;

/// `--max-memory` of the commands that read images or render.
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub struct MemoryLimit {
    /// Refuse work that needs more memory than this many GiB: a render, or an image to read
    /// [default: 80 % of the physical memory].
    #[arg(long = "max-memory", value_name = "GiB")]
    pub gib: Option<f64>,
}

impl MemoryLimit {
    /// The limit in bytes and where it comes from (for messages); a non-positive or non-finite
    /// value is refused.
    pub fn bytes(self) -> Result<(u64, &'static str), String> {
        match self.gib {
            Some(g) if g > 0.0 && g.is_finite() => {
                Ok(((g * (1u64 << 30) as f64) as u64, "--max-memory"))
            }
            Some(g) => Err(format!("--max-memory must be positive (got {g})")),
            None => Ok((
                linlight_imagefile::default_memory_limit(),
                "80 % of this machine's memory; raise it with --max-memory",
            )),
        }
    }
}
