//! Rendering a scene into an image of per-pixel means and variances of the mean: [`render`]
//! chooses the renderer. The layers below it, each depending only on those above it in this
//! list: [`crate::options`] (what is asked), [`crate::ray_offset`] and [`crate::render_scene`]
//! (the scene as the renderer sees it), [`crate::frame`] (the tile loop, pixel values, header),
//! [`crate::integrator`] (the scalar path, any hooks) and [`crate::packet`] (ray packets).

use crate::hooks::{BsdfModel, Hooks, LightSampling, SpecularSampling};
use crate::integrator::render_scalar_window;
use crate::options::{check_options, window_of, Cylinders, RenderError, RenderOptions, Window};
use crate::render_scene::RenderScene;
use crate::scene::{CropWindow, Scene};
use linlight_imagefile::Image;
use linlight_simd::Isa;

/// Render `scene`. `progress(done, total)` is called (from worker threads) after each pass of
/// each tile, in camera samples: `total` = pixels × spp × passes.
/// Runs on the current rayon pool (use `ThreadPool::install` to choose the thread count).
///
/// Where it applies ([`crate::packet::applies`]: one light sample, white noise, and a batch
/// technique or a scene with Lambertian surfaces, or exact tubes as every light) the packet
/// renderer renders, whose images equal those of the scalar path
/// [`crate::integrator::render_scalar`]`(scene, opts, &Hooks::new(), …)` bit for bit; the
/// scalar path renders everything else. A scene rendered more than once is [`Prepared`] once
/// instead.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    // Options no render can use are refused before the scene is built.
    check_options(opts)?;
    Prepared::new(scene)?.render(scene.sensor.film.crop, opts, progress)
}

/// A scene with its acceleration structures built once ([`RenderScene`]), for any number of
/// renders of windows of its film, with any options: [`Prepared::render`] of a window is
/// [`render`] of the scene cropped to it, bit for bit. Renders may run at the same time.
pub struct Prepared<'s> {
    scene: &'s Scene,
    /// Built with lines for cylinders; each render shares its acceleration structures
    /// ([`RenderScene::sharing`]).
    rs: RenderScene,
}

impl<'s> Prepared<'s> {
    /// Builds `scene`'s acceleration structures; the errors of [`render`] that do not depend on
    /// the options or the window.
    pub fn new(scene: &'s Scene) -> Result<Self, RenderError> {
        let rs = RenderScene::with_cylinders(scene, Cylinders::Line)?;
        Ok(Self { scene, rs })
    }

    /// [`render`] of the scene with its film cropped to `crop` (full-film pixels; None: the
    /// whole film, whatever the scene's own crop).
    pub fn render(
        &self,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        if !crate::packet::applies(self.scene, opts) {
            return self.render_scalar(crop, opts, &Hooks::new(), progress);
        }
        let (window, rs) = self.window(crop, opts)?;
        crate::packet::render_window(self.scene, &rs, window, opts, Isa::detect(), progress)
    }

    /// [`crate::integrator::render_scalar`] of the scene with its film cropped to `crop` (None:
    /// the whole film).
    pub fn render_scalar<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
        &self,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        hooks: &Hooks<D, S, B>,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        let (window, rs) = self.window(crop, opts)?;
        render_scalar_window(self.scene, &rs, window, opts, hooks, progress)
    }

    /// The pixels of `crop` and the render scene with `opts.cylinders`, or the errors of
    /// [`render`] that the options and the window make.
    fn window(
        &self,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
    ) -> Result<(Window, RenderScene), RenderError> {
        check_options(opts)?;
        let window = window_of(&self.scene.sensor.film, crop)?;
        Ok((window, self.rs.sharing(self.scene, opts.cylinders)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::render_scalar;
    use crate::options::TubeSampling;
    use crate::scene_builder::{floor, light, scene, sensor};
    use crate::LightSelection;
    use glam::Vec3;
    use linlight_sampling::cylinder::CylinderTechnique;
    use linlight_sampling::noise::Noise;
    use linlight_sampling::Technique;

    /// `scene` with its film cropped to `crop`.
    fn cropped(scene: &Scene, crop: Option<CropWindow>) -> Scene {
        let mut s = scene.clone();
        s.sensor.film.crop = crop;
        s
    }

    /// The render of `scene` by the renderer's own entry point (packets where they apply,
    /// else the scalar path), each building its render scene itself.
    fn unprepared(scene: &Scene, opts: &RenderOptions) -> Image {
        let quiet = |_: usize, _: usize| {};
        if crate::packet::applies(scene, opts) {
            crate::packet::render(scene, opts, &quiet).unwrap()
        } else {
            render_scalar(scene, opts, &Hooks::new(), &quiet).unwrap()
        }
    }

    /// The options a prepared scene is rendered with below: the packets, the scalar path
    /// (two light samples; blue noise) and, where the scene has tubes, exact tubes.
    fn option_sets(tubes: bool) -> Vec<RenderOptions> {
        let base = RenderOptions {
            spp: 3,
            passes: 2,
            seed: 11,
            method: Technique::ProjectedSolidAngle.into(),
            ..Default::default()
        };
        let mut sets = vec![
            base,
            RenderOptions {
                light_samples: 2,
                lights: LightSelection::One,
                ..base
            },
            RenderOptions {
                noise: Noise::Blue,
                passes: 1,
                spp: 4,
                ..base
            },
        ];
        if tubes {
            sets.push(RenderOptions {
                cylinders: Cylinders::Exact(TubeSampling {
                    technique: CylinderTechnique::Projected,
                    mis: true,
                }),
                ..base
            });
        }
        sets
    }

    /// Every committed scene and a finite-tube scene, each prepared once: its renders of two
    /// windows at the same time, and of the whole film, equal the unprepared render of the
    /// scene cropped to them, bit for bit and headers included, with every option set.
    #[test]
    fn prepared_windows_equal_renders_of_the_cropped_scene() {
        let res = [("res".to_string(), "24".to_string())];
        let mut paths = crate::test_scenes::committed();
        paths.push(crate::test_scenes::dir().join("../finite-tubes/finite-tube-contact.xml"));
        let windows = [
            Some(CropWindow {
                offset_x: 7,
                offset_y: 5,
                width: 10,
                height: 9,
            }),
            Some(CropWindow {
                offset_x: 0,
                offset_y: 16,
                width: 24,
                height: 8,
            }),
            None,
        ];
        for path in &paths {
            let sc = crate::xml::load_scene(path, &res).unwrap();
            let prepared = Prepared::new(&sc).unwrap();
            let tubes = sc.lights.iter().any(|l| l.radius > 0.0);
            for o in option_sets(tubes) {
                let quiet = |_: usize, _: usize| {};
                let at = |crop| prepared.render(crop, &o, &quiet).unwrap();
                let (a, (b, c)) = rayon::join(
                    || at(windows[0]),
                    || rayon::join(|| at(windows[1]), || at(windows[2])),
                );
                for (got, crop) in [a, b, c].iter().zip(windows) {
                    let want = unprepared(&cropped(&sc, crop), &o);
                    assert_eq!(*got, want, "{} {o:?} {crop:?}", path.display());
                }
            }
        }
    }

    /// Renders of one prepared scene at the same time count the samples they drop each (a light
    /// whose K/p overflows: every lane that chooses it is dropped).
    #[test]
    fn prepared_renders_count_their_own_dropped_samples() {
        let huge = [f32::MAX; 3];
        let s = scene(
            sensor(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 40.0, 8, 8),
            vec![floor(3.0, [0.5; 3])],
            vec![
                light(Vec3::new(-0.5, 0.0, 1.0), Vec3::new(0.5, 0.0, 1.0), huge),
                light(
                    Vec3::new(-0.5, 0.5, 1.0),
                    Vec3::new(0.5, 0.5, 1.0),
                    [1.0; 3],
                ),
            ],
        );
        let o = |spp| RenderOptions {
            spp,
            lights: LightSelection::One,
            method: Technique::ProjectedSolidAngle.into(),
            ..Default::default()
        };
        let dropped = |img: &Image| -> u64 { img.meta.extra["nonfinite_dropped"].parse().unwrap() };
        let quiet = |_: usize, _: usize| {};
        let prepared = Prepared::new(&s).unwrap();
        let (a, b) = rayon::join(
            || prepared.render(None, &o(16), &quiet).unwrap(),
            || prepared.render(None, &o(64), &quiet).unwrap(),
        );
        let (want_a, want_b) = (unprepared(&s, &o(16)), unprepared(&s, &o(64)));
        assert!(dropped(&want_a) > 0 && dropped(&want_b) > dropped(&want_a));
        assert_eq!(
            (dropped(&a), dropped(&b)),
            (dropped(&want_a), dropped(&want_b))
        );
        assert_eq!((a, b), (want_a, want_b));
    }
}
