//! What `linlight certify` runs on which scene by default, and which scenes also have an exact
//! oracle.
//!
//! - Every scene: every unbiased single technique ([`Technique::UNBIASED`]); on a glossy surface
//!   each applies to the full BSDF (K·f·cos/p), so every one must certify there too.
//! - Glossy scenes (some surface is not Lambertian): also the configurations that exist for
//!   glossy shading only, [`GLOSSY_ONLY`] (the LTC technique and the MIS estimators with each
//!   heuristic, once the renderer has them: adding one is one line there).
//! - [`EXACT_SCENES`]: unoccluded planes whose R → 0 image is known without sampling
//!   (`linlight_render::closed_form`: closed form on Lambertian surfaces, quadrature along the line
//!   on glossy ones); every render of such a scene is compared with that image as well.

use super::Subject;
use linlight_render::scene::Scene;
use linlight_sampling::Technique;

/// Scenes also compared with their exact unshadowed image (closed form or line quadrature).
pub const EXACT_SCENES: [&str; 4] = [
    "floor-tube",
    "glossy-conductor-sharp",
    "glossy-conductor-rough",
    "glossy-blend",
];

/// The configurations certified on glossy scenes only, by name (the subjects are built by
/// [`glossy_only_subjects`]). Empty until the renderer has the LTC technique and MIS.
pub const GLOSSY_ONLY: [&str; 0] = [];

/// Whether some surface of the scene is not Lambertian.
pub fn is_glossy(scene: &Scene) -> bool {
    scene.shapes.iter().any(|s| s.bsdf.lambertian().is_none())
}

/// Whether certify also compares the scene `name` with its exact image.
pub fn has_exact_oracle(name: &str) -> bool {
    EXACT_SCENES.contains(&name)
}

/// The subjects of [`GLOSSY_ONLY`].
fn glossy_only_subjects() -> Vec<Box<dyn Subject>> {
    Vec::new()
}

/// The default subjects of a scene (see the module documentation).
pub fn default_subjects(scene: &Scene) -> Vec<Box<dyn Subject>> {
    let mut subjects: Vec<Box<dyn Subject>> = Technique::UNBIASED
        .iter()
        .map(|t| Box::new(*t) as Box<dyn Subject>)
        .collect();
    if is_glossy(scene) {
        subjects.extend(glossy_only_subjects());
    }
    subjects
}

/// How many comparisons the default certification makes on a scene.
pub fn default_comparisons(name: &str, scene: &Scene) -> usize {
    let oracles = 1 + usize::from(has_exact_oracle(name));
    let subjects = Technique::UNBIASED.len() + if is_glossy(scene) { GLOSSY_ONLY.len() } else { 0 };
    oracles * subjects
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glossy_only_names_match_their_subjects() {
        let names: Vec<String> = glossy_only_subjects().iter().map(|s| s.name()).collect();
        assert_eq!(names, GLOSSY_ONLY.map(String::from).to_vec());
    }
}
