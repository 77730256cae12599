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
pub mod unshadowed;
