//! Library side of the `linlight` program: the orchestration of `linlight certify`, so that
//! end-to-end tests can run the same certification with their own (deliberately wrong) subjects.

pub mod calibrate;
pub mod certify;
