//! Backward error of a projected-solid-angle sample, in units of ξ.
//! STUB: to be implemented.
