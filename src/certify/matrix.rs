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
//! - The finite-tube family ([`super::scenes::FINITE_TUBES_DIR`]): scenes whose tubes have a
//!   radius the R → 0 limit cannot ignore. They are rendered as the cylinders they are
//!   (`--cylinders exact`) by [`FINITE_SUBJECTS`]: every cylinder technique with MIS (balance)
//!   and ours without MIS, and on glossy scenes ours with the lobe's LTC
//!   ([`FINITE_GLOSSY_SUBJECT`]); the line techniques do not apply to them.

use super::Subject;
use linlight_imagefile::Image;
use linlight_render::scene::{CropWindow, Scene};
use linlight_render::{options::cylinder_technique, TubeSampling};
use linlight_render::{Cylinders, Heuristic, Method, Prepared, RenderError, RenderOptions};
use linlight_sampling::cylinder::CylinderTechnique;
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

/// A render of the scene's tubes as the cylinders they are (`linlight render --cylinders exact
/// --cylinder-technique T --cylinder-mis balance|off`), named `exact:T:mis=balance|off`
/// (T: `projected`, `ltc`, `solid-angle`, `gamito`, `area`). The method of the certify options is left
/// as it is: it samples only lights of zero radius, which the finite-tube scenes do not have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExactTubes(pub TubeSampling);

/// The subjects of the finite-tube family: every cylinder technique with MIS (balance), and ours
/// (the projected technique) alone.
pub const FINITE_SUBJECTS: [ExactTubes; 5] = [
    ExactTubes(TubeSampling {
        technique: CylinderTechnique::Projected,
        mis: true,
    }),
    ExactTubes(TubeSampling {
        technique: CylinderTechnique::SolidAngle,
        mis: true,
    }),
    ExactTubes(TubeSampling {
        technique: CylinderTechnique::Gamito,
        mis: true,
    }),
    ExactTubes(TubeSampling {
        technique: CylinderTechnique::Area,
        mis: true,
    }),
    ExactTubes(TubeSampling {
        technique: CylinderTechnique::Projected,
        mis: false,
    }),
];

/// The finite-tube subject of glossy scenes only: ours with the glossy lobe's LTC
/// (`exact:ltc:mis=balance`). On a Lambertian scene `ltc` renders the images of
/// `exact:projected:mis=balance` bit for bit (A = identity), so it is not repeated there.
pub const FINITE_GLOSSY_SUBJECT: ExactTubes = ExactTubes(TubeSampling {
    technique: CylinderTechnique::Ltc,
    mis: true,
});

/// The finite-tube subjects of `scene`: [`FINITE_SUBJECTS`], and on a glossy scene
/// [`FINITE_GLOSSY_SUBJECT`].
pub fn finite_subjects(scene: &Scene) -> Vec<ExactTubes> {
    let mut v = FINITE_SUBJECTS.to_vec();
    if is_glossy(scene) {
        v.push(FINITE_GLOSSY_SUBJECT);
    }
    v
}

impl std::str::FromStr for ExactTubes {
    type Err = String;
    /// `exact:T` (MIS balance, `linlight render`'s default) or `exact:T:mis=balance|off`.
    fn from_str(text: &str) -> Result<Self, String> {
        let rest = text
            .strip_prefix("exact:")
            .ok_or_else(|| format!("'{text}' is not an exact-tube subject (exact:TECHNIQUE)"))?;
        let (technique, mis) = match rest.split_once(":mis=") {
            None => (rest, true),
            Some((t, "balance")) => (t, true),
            Some((t, "off")) => (t, false),
            Some((_, m)) => {
                return Err(format!(
                    "'{text}': unknown cylinder MIS '{m}' (expected balance or off)"
                ))
            }
        };
        Ok(ExactTubes(TubeSampling {
            technique: cylinder_technique(technique)?,
            mis,
        }))
    }
}

impl ExactTubes {
    /// The render options of this subject from certify's.
    pub fn options(&self, opts: &RenderOptions) -> RenderOptions {
        RenderOptions {
            cylinders: Cylinders::Exact(self.0),
            ..*opts
        }
    }
}

impl Subject for ExactTubes {
    fn name(&self) -> String {
        let t = self.0.technique.name();
        format!(
            "exact:{}:mis={}",
            t.strip_prefix("cylinder-").unwrap_or(t),
            if self.0.mis { "balance" } else { "off" }
        )
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        scene.render(crop, &self.options(opts), progress)
    }
    fn exact_tubes(&self) -> bool {
        true
    }
}

/// The default subjects of a scene (see the module documentation); `exact_tubes`: the scene is
/// of the finite-tube family.
pub fn default_subjects(scene: &Scene, exact_tubes: bool) -> Vec<Box<dyn Subject>> {
    if exact_tubes {
        return finite_subjects(scene)
            .into_iter()
            .map(|s| Box::new(s) as Box<dyn Subject>)
            .collect();
    }
    let mut subjects: Vec<Box<dyn Subject>> = Technique::UNBIASED
        .iter()
        .map(|t| Box::new(*t) as Box<dyn Subject>)
        .collect();
    if is_glossy(scene) {
        subjects.extend(glossy_only_subjects());
    }
    subjects
}

/// How many comparisons the default certification makes on a scene (`exact_tubes`: of the
/// finite-tube family).
pub fn default_comparisons(name: &str, scene: &Scene, exact_tubes: bool) -> usize {
    if exact_tubes {
        return finite_subjects(scene).len();
    }
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

    /// `ltc` joins the finite-tube subjects on the glossy scene only.
    #[test]
    fn ltc_is_a_subject_of_the_glossy_finite_tube_scene_only() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("references/finite-tubes");
        for (name, glossy) in [
            ("finite-tube-diffuse", false),
            ("finite-tube-glossy", true),
            ("finite-tube-contact", false),
        ] {
            let scene = linlight_render::xml::load_scene(&dir.join(format!("{name}.xml")), &[])
                .expect(name);
            let subjects = finite_subjects(&scene);
            assert_eq!(subjects.contains(&FINITE_GLOSSY_SUBJECT), glossy, "{name}");
            assert_eq!(default_comparisons(name, &scene, true), 5 + glossy as usize);
        }
        assert_eq!(FINITE_GLOSSY_SUBJECT.name(), "exact:ltc:mis=balance");
        assert_eq!("exact:ltc".parse::<ExactTubes>(), Ok(FINITE_GLOSSY_SUBJECT));
    }

    #[test]
    fn exact_tube_subjects_are_named_as_they_parse() {
        for s in FINITE_SUBJECTS {
            assert!(s.exact_tubes());
            assert_eq!(s.name().parse::<ExactTubes>(), Ok(s));
        }
        let names: Vec<String> = FINITE_SUBJECTS.iter().map(|s| s.name()).collect();
        assert_eq!(names[0], "exact:projected:mis=balance");
        assert_eq!(names[4], "exact:projected:mis=off");
        assert_eq!(
            "exact:gamito".parse::<ExactTubes>(),
            Ok(FINITE_SUBJECTS[2]),
            "MIS balance by default"
        );
        for bad in ["projected", "exact:line", "exact:area:mis=power", "exact:"] {
            assert!(bad.parse::<ExactTubes>().is_err(), "{bad}");
        }
        let o = FINITE_SUBJECTS[4].options(&RenderOptions::default());
        assert!(matches!(o.cylinders, Cylinders::Exact(t) if !t.mis));
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
