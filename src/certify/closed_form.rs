//! The exact R → 0 image of the scenes in [`super::matrix::EXACT_SCENES`] (unoccluded plane):
//! K·∫ f·cos dΩ_R averaged over each pixel's footprint, zero variance — in closed form,
//! (ρ/π)·K·Ω⊥_R, on Lambertian surfaces, by adaptive quadrature along the line on glossy ones
//! (`crate::ground_truth::closed_form`).

use crate::ground_truth::closed_form::unshadowed_pixel_average;
use linlight_imagefile::Image;
use linlight_render::scene::Scene;

/// The exact image of `scene` (an error if the scene is not of the supported kind).
pub fn image(scene: &Scene, subsamples: u32) -> Result<Option<Image>, String> {
    unshadowed_pixel_average(scene, subsamples)
        .map(Some)
        .map_err(|e| e.to_string())
}

/// The oracle's name in the report: "closed-form" or "quadrature".
pub fn oracle_name(image: &Image) -> &'static str {
    if image.meta.renderer == "linlight closed-form" {
        "closed-form"
    } else {
        "quadrature"
    }
}
