//! The exact R → 0 image of the scenes in [`super::CLOSED_FORM_SCENES`] (unoccluded diffuse
//! plane): (ρ/π)·K·Ω⊥_R averaged over each pixel's footprint, zero variance
//! (`linlight_render::closed_form`).

use linlight_imagefile::Image;
use linlight_render::closed_form::unshadowed_pixel_average;
use linlight_render::scene::Scene;

/// The closed-form image of `scene` (an error if the scene is not of the supported kind).
pub fn image(scene: &Scene, subsamples: u32) -> Result<Option<Image>, String> {
    unshadowed_pixel_average(scene, subsamples)
        .map(Some)
        .map_err(|e| e.to_string())
}
