//! Certification machinery: goodness of fit of line samplers (STATISTICS.md §1) and image
//! difference statistics (STATISTICS.md §2).

pub mod heatmap;
pub mod image_stats;
pub mod z_score;
