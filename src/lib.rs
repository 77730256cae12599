//! Library side of the `linlight` program: the orchestration of `linlight certify`, so that
//! end-to-end tests can run the same certification with their own (deliberately wrong) subjects.

// `!(x > 0.0)` is deliberate: it rejects NaN together with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod calibrate;
pub mod certify;
pub mod compare_report;
pub mod external;
pub mod figures;
pub mod ground_truth;
pub mod merge;
pub mod outputs;
