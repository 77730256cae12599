//! The packet renderer against the scalar reference path, bit for bit.

use super::*;
use crate::hooks::Hooks;
use crate::integrator::render_scalar;
use crate::light_choice::LightSelection;
use crate::method::Method;
use crate::xml;
use linlight_sampling::mis::Heuristic;

fn scene(name: &str, res: u32) -> Scene {
    let path = crate::test_scenes::dir().join(format!("{name}.xml"));
    xml::load_scene(&path, &[("res".into(), res.to_string())]).expect(name)
}

fn bits(img: &Image) -> Vec<u32> {
    img.mean
        .iter()
        .chain(&img.var)
        .chain(img.tail.iter().flatten())
        .flat_map(|p| p.map(f32::to_bits))
        .collect()
}

/// One light sample per camera sample, white noise, lights as lines.
fn line_options(
    spp: u32,
    passes: u32,
    seed: u64,
    method: Method,
    lights: LightSelection,
) -> RenderOptions {
    RenderOptions {
        spp,
        passes,
        seed,
        method,
        light_samples: 1,
        lights,
        noise: Default::default(),
        cylinders: crate::options::Cylinders::Line,
    }
}

/// The render of every kernel this CPU runs (the baseline always: CPUs without AVX) equals
/// the scalar path's bit for bit, header included (`what` names the case); the scalar image.
fn assert_kernels_equal_scalar(scene: &Scene, opts: &RenderOptions, what: &str) -> Image {
    let scalar = render_scalar(scene, opts, &Hooks::new(), &|_, _| {}).unwrap();
    for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
        let batched = render_isa(scene, opts, isa, &|_, _| {}).unwrap();
        assert!(bits(&batched) == bits(&scalar), "{what}, {isa:?}");
        assert_eq!(batched.meta, scalar.meta, "{what}, {isa:?}");
    }
    scalar
}

/// Every committed scene (Lambertian, glossy, mixed), every method, every kernel the CPU
/// runs: the image equals the scalar path's bit for bit (means, variances, tail shares,
/// header), with spp not a multiple of the packet (packets span pixels) and with passes.
#[test]
fn images_equal_the_scalar_path() {
    let names: Vec<String> = crate::test_scenes::committed()
        .iter()
        .filter_map(|p| p.file_stem()?.to_str().map(String::from))
        .collect();
    // Every method: the techniques with a batch kernel, those sampled lane by lane, LTC
    // and MIS with every heuristic.
    let methods: Vec<Method> = Technique::ALL
        .into_iter()
        .map(Method::from)
        .chain([Method::Ltc])
        .chain(Heuristic::ALL.map(Method::Mis))
        .collect();
    // The committed scenes hide the lights from the camera: also tests/scenes/visible-tube
    // (a sphere hides part of the visible line, so the lines' numbers, drawn after the
    // lights' one or two per light, matter), as is and with a rough conductor sphere.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/scenes/visible-tube.xml");
    let tube = xml::load_scene(&path, &[("res".into(), "24".into())]).unwrap();
    let mut glossy_tube = tube.clone();
    for shape in glossy_tube.shapes.iter_mut().skip(1) {
        shape.bsdf = crate::scene::Bsdf::RoughConductor(linlight_brdf::RoughConductor {
            alpha: 0.2,
            fresnel: linlight_brdf::ConductorFresnel::One,
            specular_reflectance: [1.0; 3],
        });
    }
    // Two lights on a surface that is not Lambertian: `one` with lanes sampled with the
    // scalar code (and LTC's and MIS's two numbers) choosing different lights.
    let mut glossy_two = scene("two-tubes", 24);
    assert_eq!(glossy_two.lights.len(), 2);
    for shape in glossy_two.shapes.iter_mut().step_by(2) {
        shape.bsdf = crate::scene::Bsdf::RoughConductor(linlight_brdf::RoughConductor {
            alpha: 0.3,
            fresnel: linlight_brdf::ConductorFresnel::One,
            specular_reflectance: [1.0; 3],
        });
    }
    // The floor seen from its back (flipped normals): one-sided, nothing reflects; two-sided,
    // the shading normal turns toward the camera (both on the packets' one-shape path).
    let mut back = scene("floor-tube", 24);
    for shape in back.shapes.iter_mut() {
        shape.flip_normals = true;
    }
    let mut two_sided_back = back.clone();
    for shape in two_sided_back.shapes.iter_mut() {
        shape.bsdf = crate::scene::Bsdf::TwoSided(Box::new(shape.bsdf.clone()));
    }
    let extra = [
        ("visible-tube".to_string(), tube),
        ("visible-tube, glossy sphere".to_string(), glossy_tube),
        ("two-tubes, glossy".to_string(), glossy_two),
        ("floor-tube, back".to_string(), back),
        ("floor-tube, two-sided back".to_string(), two_sided_back),
    ];
    let scenes = names
        .iter()
        .map(|name| (name.clone(), scene(name, 24)))
        .chain(extra);
    let mut two_light_renders = 0;
    for (name, scene) in scenes {
        for (technique, lights) in methods
            .iter()
            .flat_map(|&m| LightSelection::ALL.map(|l| (m, l)))
        {
            for (spp, passes) in [(5, 1), (16, 2)] {
                let opts = line_options(spp, passes, 3, technique, lights);
                let what = format!("{name}, {technique}, {lights}, {spp} spp × {passes}");
                assert_kernels_equal_scalar(&scene, &opts, &what);
                if lights == LightSelection::One && scene.lights.len() == 2 {
                    two_light_renders += 1;
                }
            }
        }
    }
    // Every scene, method and light selection, whether `render` takes the batched path or
    // not; the glossy scenes (rough conductor, principled, blend, glossy and Lambertian
    // shapes mixed) are among them, and those with two lights (two-tubes as is and glossy at
    // least) let the lanes choose different lights.
    assert!(names.iter().filter(|n| n.starts_with("glossy-")).count() >= 4);
    assert!(
        two_light_renders >= 2 * 2 * methods.len(),
        "{two_light_renders}"
    );
}

/// A pixel's samples taken in film-position order (`order`, forced on these small scenes), so
/// that packets hold other samples than in index order: at 40 spp (packets of one pixel or of
/// two), every committed scene and light selection, the projected solid angle (batch
/// lanes) and MIS (lanes sampled with the scalar code), two passes and the visible tube; the
/// image equals the scalar path's bit for bit.
#[test]
fn reordered_samples_equal_the_scalar_path() {
    super::order::ALWAYS.set(true);
    let names: Vec<String> = crate::test_scenes::committed()
        .iter()
        .filter_map(|p| p.file_stem()?.to_str().map(String::from))
        .collect();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/scenes/visible-tube.xml");
    let tube = xml::load_scene(&path, &[("res".into(), "12".into())]).unwrap();
    let scenes = names
        .iter()
        .map(|name| (name.clone(), scene(name, 12)))
        .chain([("visible-tube".to_string(), tube)]);
    let methods = [
        Method::from(Technique::ProjectedSolidAngle),
        Method::Mis(Heuristic::Balance),
    ];
    for (name, scene) in scenes {
        for (method, lights) in methods
            .iter()
            .flat_map(|&m| LightSelection::ALL.map(|l| (m, l)))
        {
            let opts = line_options(40, 2, 5, method, lights);
            let what = format!("{name}, {method}, {lights}, 40 spp × 2");
            assert_kernels_equal_scalar(&scene, &opts, &what);
        }
    }
    super::order::ALWAYS.set(false);
}

/// Exact tubes (`--cylinders exact`) on the committed finite-R scenes (diffuse with the tube
/// seen by the camera, glossy, resting on the floor) and on cornell-tube and two-tubes
/// (R = 1e-4; two tubes shadowing each other, the light chosen per lane): every cylinder
/// technique, with and without MIS, every light selection on two lights, every kernel the
/// CPU runs; the packet renderer renders them and its image equals the scalar path's bit
/// for bit (means, variances, tail shares, header).
#[test]
fn exact_tubes_equal_the_scalar_path() {
    use crate::options::TubeSampling;
    use linlight_sampling::cylinder::CylinderTechnique;
    let finite =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../references/finite-tubes");
    let scenes: Vec<(String, Scene)> = [
        "finite-tube-diffuse",
        "finite-tube-glossy",
        "finite-tube-contact",
    ]
    .iter()
    .map(|n| {
        let path = finite.join(format!("{n}.xml"));
        let s = xml::load_scene(&path, &[("res".into(), "16".into())]).expect(n);
        (n.to_string(), s)
    })
    .chain(["cornell-tube", "two-tubes"].map(|n| (n.to_string(), scene(n, 16))))
    .collect();
    // One scene's camera sees its tube; one scene has two tubes.
    assert!(scenes.iter().any(|(_, s)| !s.integrator.hide_emitters));
    assert!(scenes.iter().any(|(_, s)| s.lights.len() == 2));
    let samplings = CylinderTechnique::ALL
        .iter()
        .map(|&technique| TubeSampling {
            technique,
            mis: true,
        })
        .chain([false].map(|mis| TubeSampling {
            technique: CylinderTechnique::Projected,
            mis,
        }));
    let mut renders = 0;
    for sampling in samplings {
        for (name, scene) in &scenes {
            let selections: &[LightSelection] = if scene.lights.len() > 1 {
                &LightSelection::ALL
            } else {
                &[LightSelection::Every]
            };
            for &lights in selections {
                for (spp, passes) in [(5, 1), (16, 2)] {
                    let opts = RenderOptions {
                        spp,
                        passes,
                        seed: 11,
                        method: Method::default(),
                        light_samples: 1,
                        lights,
                        noise: Default::default(),
                        cylinders: Cylinders::Exact(sampling),
                    };
                    assert!(applies(scene, &opts), "{name}");
                    let what = format!("{name}, {sampling:?}, {lights}, {spp} spp × {passes}");
                    let scalar = assert_kernels_equal_scalar(scene, &opts, &what);
                    assert_eq!(scalar.meta.extra["cylinders"], "exact");
                    renders += 1;
                }
            }
        }
    }
    assert_eq!(renders, 6 * (4 * 2 + 3 * 2));
}

/// With more lights than the numbers the packet draws ahead (`kept_blocks`), `every` draws the
/// further dimensions block by block: nine lights (two-tubes' and seven shifted copies), as
/// exact tubes with MIS and as lines, every selection, every kernel, equal the scalar path bit
/// for bit.
#[test]
fn images_with_many_lights_equal_the_scalar_path() {
    use crate::options::TubeSampling;
    use glam::Vec3;
    use linlight_sampling::cylinder::CylinderTechnique;
    let mut scene = scene("two-tubes", 8);
    let base = scene.lights.clone();
    for i in 0..7 {
        let mut l = base[i % base.len()].clone();
        let shift = Vec3::new(0.05, 0.03, -0.02) * (i + 1) as f32;
        (l.begin, l.end) = (l.begin + shift, l.end + shift);
        scene.lights.push(l);
    }
    assert_eq!(scene.lights.len(), 9);
    let exact = Cylinders::Exact(TubeSampling {
        technique: CylinderTechnique::Projected,
        mis: true,
    });
    for cylinders in [exact, Cylinders::Line] {
        for lights in LightSelection::ALL {
            let opts = RenderOptions {
                spp: 5,
                seed: 3,
                lights,
                cylinders,
                ..Default::default()
            };
            assert!(applies(&scene, &opts));
            assert_kernels_equal_scalar(&scene, &opts, &format!("{cylinders:?}, {lights}"));
        }
    }
}

/// Exact tubes take the packets only with every light a tube and one light sample; a scene
/// that mixes a tube and a light of radius 0 (a line) renders on the scalar path, and
/// `render_isa` refuses it.
#[test]
fn exact_tubes_take_the_packets_only_when_every_light_is_one() {
    let mut s = scene("two-tubes", 8);
    let opts = RenderOptions {
        cylinders: Cylinders::EXACT,
        ..Default::default()
    };
    assert!(applies(&s, &opts));
    let two = RenderOptions {
        light_samples: 2,
        ..opts
    };
    assert!(!applies(&s, &two));
    s.lights[1].radius = 0.0;
    assert!(!applies(&s, &opts));
    assert!(render_isa(&s, &opts, Isa::Baseline, &|_, _| {}).is_err());
    assert!(crate::render::render(&s, &opts, &|_, _| {}).is_ok());
}

/// A scene with one light draws no choice number: `one` and `every` render the same pixels
/// bit for bit, on the scalar path (glossy scenes, several light samples, the two-technique
/// estimator) and the batched one; only the header's `light_selection` differs.
#[test]
fn one_light_scenes_render_the_same_image_under_both_selections() {
    for (name, light_samples) in [("cornell-tube", 1), ("glossy-conductor-rough", 3)] {
        let scene = scene(name, 16);
        assert_eq!(scene.lights.len(), 1);
        let opts = |lights| RenderOptions {
            spp: 4,
            seed: 7,
            light_samples,
            lights,
            ..Default::default()
        };
        let one = opts(LightSelection::One);
        let every = opts(LightSelection::Every);
        let (a, b) = (
            crate::render::render(&scene, &one, &|_, _| {}).unwrap(),
            crate::render::render(&scene, &every, &|_, _| {}).unwrap(),
        );
        assert!(bits(&a) == bits(&b), "{name}");
        assert_eq!(a.meta.extra["light_selection"], "one");
        assert_eq!(b.meta.extra["light_selection"], "every");
    }
}

/// Several light samples per camera sample and blue noise take the scalar path, and so do
/// methods without a batch kernel on scenes without Lambertian surfaces.
#[test]
fn applies_only_where_it_can() {
    let opts = RenderOptions {
        spp: 1,
        passes: 1,
        seed: 0,
        method: Technique::Area.into(),
        light_samples: 1,
        lights: LightSelection::One,
        noise: Default::default(),
        cylinders: crate::options::Cylinders::Line,
    };
    let cornell = scene("cornell-tube", 8);
    let mixed = scene("glossy-cornell", 8);
    let glossy = scene("glossy-conductor-rough", 8);
    let psa = RenderOptions {
        method: Technique::ProjectedSolidAngle.into(),
        ..opts
    };
    // Without a Lambertian surface only the batch techniques pay in packets.
    assert!(applies(&glossy, &psa));
    for method in [Technique::Area.into(), Method::Ltc, Method::default()] {
        assert!(!applies(&glossy, &RenderOptions { method, ..opts }));
        assert!(applies(&mixed, &RenderOptions { method, ..opts }));
    }
    for scene in [&cornell, &mixed] {
        assert!(applies(scene, &opts));
        // Blue noise reaches the light samples through the scalar path only.
        let blue = RenderOptions {
            noise: linlight_sampling::noise::Noise::Blue,
            ..opts
        };
        assert!(!applies(scene, &blue));
        assert!(render(scene, &blue, &|_, _| {}).is_err());
        let two = RenderOptions {
            light_samples: 2,
            ..opts
        };
        assert!(!applies(scene, &two));
    }
}
