//! What `linlight certify` runs on which scene by default, and which scenes also have an exact
//! oracle.
//!
//! - Every scene: every unbiased single technique ([`Technique::UNBIASED`]); on a glossy surface
//!   each applies to the full BSDF (K·f·cos/p), so every one must certify there too.
//! - Glossy scenes (some surface is not Lambertian): also the configurations that exist for
//!   glossy shading only, [`GLOSSY_ONLY`]: LTC and the MIS estimator with every heuristic
//!   (on Lambertian surfaces they reduce to the projected solid angle, already certified).
//!   LTC alone has infinite variance where a light crosses the edge of the LTC support inside
//!   the hemisphere, but only logarithmically so (tail P(X > y) ~ y⁻², measured exponent 2.0),
//!   and it certifies within the default budget (docs/glossy-scenes.md, "LTC alone").
//! - [`EXACT_SCENES`]: unoccluded planes whose R → 0 image is known without sampling
//!   (`crate::ground_truth::closed_form`: closed form on Lambertian surfaces, quadrature along the line
//!   on glossy ones); every render of such a scene is compared with that image as well.

use super::Subject;
use linlight_render::scene::Scene;
use linlight_render::{Heuristic, Method};
use linlight_sampling::Technique;

/// Scenes also compared with their exact unshadowed image (closed form or line quadrature).
pub const EXACT_SCENES: [&str; 4] = [
    "floor-tube",
    "glossy-conductor-sharp",
    "glossy-conductor-rough",
    "glossy-blend",
];

/// The configurations certified on glossy scenes only, by [`Method::name`]: LTC (with the
/// projected solid angle where the LTC cannot sample) and the MIS estimator with each heuristic,
/// clamped optimal at v ∈ {0, 0.5, 1} (v never changes the expectation, so every v must certify).
pub const GLOSSY_ONLY: [&str; 7] = [
    "ltc",
    "mis:balance",
    "mis:power",
    "mis:weighted",
    "mis:clamped-optimal=0",
    "mis:clamped-optimal=0.5",
    "mis:clamped-optimal=1",
];

/// The methods of [`GLOSSY_ONLY`].
pub fn glossy_only_methods() -> Vec<Method> {
    let mut methods = vec![Method::Ltc];
    methods.extend(
        [
            Heuristic::Balance,
            Heuristic::Power,
            Heuristic::Weighted,
            Heuristic::ClampedOptimal(0.0),
            Heuristic::ClampedOptimal(0.5),
            Heuristic::ClampedOptimal(1.0),
        ]
        .map(Method::Mis),
    );
    methods
}

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
    glossy_only_methods()
        .into_iter()
        .map(|m| Box::new(m) as Box<dyn Subject>)
        .collect()
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
    let subjects = Technique::UNBIASED.len()
        + if is_glossy(scene) {
            GLOSSY_ONLY.len()
        } else {
            0
        };
    oracles * subjects
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glossy_only_names_match_their_subjects() {
        let names: Vec<String> = glossy_only_subjects().iter().map(|s| s.name()).collect();
        assert_eq!(names, GLOSSY_ONLY.map(String::from).to_vec());
        for name in GLOSSY_ONLY {
            let m: Method = name.parse().unwrap();
            assert_eq!(m.name(), name);
            assert!(m.is_unbiased());
        }
    }

    #[test]
    fn every_heuristic_is_in_the_glossy_matrix() {
        let methods = glossy_only_methods();
        for h in Heuristic::ALL {
            assert!(
                methods
                    .iter()
                    .any(|m| matches!(m, Method::Mis(x) if x.name() == h.name())),
                "{h} missing"
            );
        }
        for v in [0.0, 0.5, 1.0] {
            assert!(methods.contains(&Method::Mis(Heuristic::ClampedOptimal(v))));
        }
    }
}
