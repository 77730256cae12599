//! Ground truths of the renderer that share no code with its samplers: the exact R → 0 image of
//! an unoccluded plane ([`closed_form`]) and the unshadowed line integral at a point by adaptive
//! quadrature ([`line_quadrature`]). The renderer does not need them; certify, `linlight
//! unshadowed`, the figures and the tests do.

pub mod closed_form;
pub mod line_quadrature;
