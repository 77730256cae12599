//! The exact R → 0 image of the scenes in [`super::CLOSED_FORM_SCENES`] (unoccluded diffuse
//! plane): (ρ/π)·K·Ω⊥_R averaged over each pixel's footprint, zero variance.
//!
//! HOOK (branch oracle-tests): `linlight_render::closed_form::unshadowed_pixel_average` has not
//! landed on main yet; until it does, `image` returns `Ok(None)` and the closed-form rows are
//! left out of the report (and said to be so).

use linlight_imagefile::Image;
use linlight_render::scene::Scene;

/// Whether this build has the closed form (false until the hook is wired).
pub const AVAILABLE: bool = false;

/// The closed-form image, `None` while the closed form is not part of this build.
pub fn image(_scene: &Scene, _subsamples: u32) -> Result<Option<Image>, String> {
    Ok(None)
}
