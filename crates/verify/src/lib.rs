//! Certification machinery: goodness of fit of line samplers (docs/statistics.md §1) and image
//! difference statistics (docs/statistics.md §2).

pub mod answers;
pub mod check;
pub mod chi2;
pub mod configs;
pub mod cylinder_suite;
pub mod heatmap;
pub mod image_stats;
pub mod quiet_panic;
pub mod subjects;
pub mod suite;
pub mod z_score;

pub use linlight_quadrature as quadrature;
pub use suite::{run_suite, Settings, SuiteReport};
