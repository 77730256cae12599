//! Power and false alarms of `linlight certify` on the real scenes (docs/statistics.md §2): the
//! certification must reject deliberately wrong renders and must not reject renders that differ
//! only in their seed. The wrong variants exist only here (test-only subjects through
//! `linlight_render::render_scalar`), never as user-facing options.

mod power;

use glam::Vec3;
use linlight::certify::{self, Subject};
use linlight_imagefile::Image;
use linlight_render::scene::CropWindow;
use linlight_render::{Hooks, LightSampling, LightSelection, Prepared, RenderError, RenderOptions};
use linlight_sampling::area::Area;
use linlight_sampling::li2018::Li2018;
use linlight_sampling::{LineFrame, LineSampler, Segment, Technique};
use linlight_verify::image_stats::{compare, CompareConfig, Region, Verdict};
use power::{assert_rejected, certify_with, options, Hooked};

/// A light sampling in place of the technique (the method stays a single technique).
fn sampled<S: LightSampling>(name: &'static str, sampling: S) -> impl Subject {
    Hooked {
        name,
        method: Technique::ProjectedSolidAngle.into(),
        hooks: Hooks::new().with_technique(sampling),
    }
}

/// (a), (d) A correct technique's render with every mean (and standard error) scaled by
/// `factor`, in the whole image or in one 16×16 region of the film.
struct Scaled {
    technique: Technique,
    factor: f32,
    region: Option<Region>,
}

impl Scaled {
    fn whole(technique: Technique, factor: f32) -> Self {
        Scaled {
            technique,
            factor,
            region: None,
        }
    }
}

impl Subject for Scaled {
    fn name(&self) -> String {
        let (t, k) = (self.technique.name(), self.factor);
        match self.region {
            None => format!("{t} × {k}"),
            Some(r) => format!("{t} × {k} on 16×16 at ({}, {})", r.x, r.y),
        }
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        let mut img = self.technique.render(scene, crop, opts, progress)?;
        let k = self.factor;
        // Certify renders the cells of tiles that need more samples as crop windows of the
        // (uncropped) scene: the region is in film coordinates.
        let (ox, oy) = crop.map_or((0, 0), |c| (c.offset_x as usize, c.offset_y as usize));
        let inside = |fx: usize, fy: usize| {
            self.region.is_none_or(|r| {
                (r.x..r.x + r.width).contains(&fx) && (r.y..r.y + r.height).contains(&fy)
            })
        };
        for y in 0..img.height {
            for x in 0..img.width {
                if inside(ox + x, oy + y) {
                    let i = y * img.width + x;
                    img.mean[i] = img.mean[i].map(|c| c * k);
                    img.var[i] = img.var[i].map(|c| c * k * k);
                }
            }
        }
        Ok(img)
    }
}

/// (b) Area sampling whose reported density is halved wherever the light crosses the horizon
/// (the tangent-plane clip is active): the samples are right, the pdf is wrong there only.
#[derive(Clone)]
struct AreaHalvedAtHorizon;

#[derive(Clone, Copy)]
struct HalvedArea {
    inner: Area,
    factor: f32,
}

impl LineSampler for HalvedArea {
    fn sample(&self, xi: f32) -> Vec3 {
        self.inner.sample(xi)
    }
    fn pdf(&self, dir: Vec3) -> f32 {
        self.factor * self.inner.pdf(dir)
    }
    fn support(&self) -> &LineFrame {
        self.inner.support()
    }
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let (w, p) = self.inner.sample_with_pdf(xi);
        (w, self.factor * p)
    }
}

impl LightSampling for AreaHalvedAtHorizon {
    type Sampler = HalvedArea;
    fn prepare(&self, segment: &Segment, x: Vec3, n: Vec3) -> Option<HalvedArea> {
        let inner = Area::prepare(segment, x, n)?;
        let full = LineFrame::new(segment, x)?;
        let clipped = full
            .clip_to_horizon(n)
            .is_none_or(|c| c.l_begin != full.l_begin || c.l_end != full.l_end);
        Some(HalvedArea {
            inner,
            factor: if clipped { 0.5 } else { 1.0 },
        })
    }
    fn name(&self) -> String {
        "area, pdf halved where clipped".into()
    }
}

/// (c) Li et al. stopped after two iterations, density not corrected.
#[derive(Clone)]
struct LiTwoIterations;

impl LightSampling for LiTwoIterations {
    type Sampler = Li2018;
    fn prepare(&self, segment: &Segment, x: Vec3, n: Vec3) -> Option<Li2018> {
        Some(Li2018::prepare(segment, x, n)?.with_max_iterations(2))
    }
    fn name(&self) -> String {
        "li2018, 2 iterations".into()
    }
}

#[test]
fn rejects_a_render_scaled_by_one_percent() {
    let r = certify_with(
        "floor-*",
        &Scaled::whole(Technique::ProjectedSolidAngle, 1.01),
    );
    // floor-tube vs Mitsuba and vs its closed form, floor-crossing vs Mitsuba.
    assert_eq!(r.rows().count(), 3);
    assert_rejected(&r, "PSA × 1.01");
}

#[test]
fn rejects_area_with_halved_density_where_the_light_crosses_the_horizon() {
    let r = certify_with(
        "floor-crossing",
        &sampled("area-halved-at-horizon", AreaHalvedAtHorizon),
    );
    assert_rejected(&r, "area, pdf × 0.5 where clipped");
}

#[test]
fn rejects_li2018_stopped_after_two_iterations() {
    // Not floor-crossing: on an unoccluded diffuse surface the projected-solid-angle estimator
    // K·f·cos/p = K·ρ/π·Ω⊥_R is the same for every direction of the support, so *where* the
    // unconverged iteration puts a sample cannot change the image there (measured: li2018 with 1
    // or 2 iterations is consistent with Mitsuba on floor-crossing, floor-tube and two-tubes).
    // Only visibility makes the sample distribution matter: the Cornell box, whose tube casts
    // penumbrae through the box.
    let r = certify_with(
        "cornell-tube",
        &sampled("li2018-2-iterations", LiTwoIterations),
    );
    assert_rejected(&r, "Li 2018, 2 iterations");
}

/// The detection power certify promises in every scene (docs/budget.md), at its default budget:
/// a 0.5 % global bias is rejected.
#[test]
fn rejects_a_half_percent_global_bias_in_every_scene() {
    let r = certify_with("*", &Scaled::whole(Technique::ProjectedSolidAngle, 1.005));
    // One comparison per scene and oracle (Mitsuba, and the exact image where there is one); the
    // finite-tube family has its own controls (tests/certify_finite.rs).
    let oracles: usize = certify::selected_scenes(&options("*"))
        .expect("scenes with references")
        .iter()
        .filter(|s| !s.exact_tubes)
        .map(|s| 1 + usize::from(certify::matrix::has_exact_oracle(&s.name)))
        .sum();
    assert_eq!(r.rows().count(), oracles);
    assert_rejected(&r, "PSA × 1.005");
}

/// ... and a 5 % bias of one 16×16 tile: in every scene the tile the budget found hardest to
/// resolve (the largest need among the covered tiles, for the same pilot certify renders).
#[test]
fn rejects_a_five_percent_tile_bias_in_every_scene() {
    let opts = options("*");
    let (_, cfg) = certify::comparison_config(&opts).expect("usable input");
    let scenes = certify::selected_scenes(&opts).expect("scenes with references");
    // The line family (the finite tubes: tests/certify_finite.rs).
    for s in scenes.into_iter().filter(|s| !s.exact_tubes) {
        let pilot = linlight_render::render(
            &s.scene,
            &RenderOptions {
                spp: opts.budget.pilot_spp,
                passes: 1,
                seed: certify::pilot_seed(opts.seed),
                method: Technique::ProjectedSolidAngle.into(),
                light_samples: 1,
                lights: LightSelection::Every,
                noise: Default::default(),
                cylinders: linlight_render::Cylinders::Line,
            },
            &|_, _| {},
        )
        .unwrap();
        let budget = opts.budget.choose(&pilot, &s.reference, &cfg).unwrap();
        let tests = budget.tests.expect("test-power budget");
        let region = tests.hardest_tile.expect("a covered tile");
        assert!(
            tests.detectable_tile_bias.unwrap() <= 0.05,
            "{}: {tests:?}",
            s.name
        );
        let r = certify_with(
            &s.name,
            &Scaled {
                technique: Technique::ProjectedSolidAngle,
                factor: 1.05,
                region: Some(region),
            },
        );
        assert_rejected(
            &r,
            &format!("{}: PSA × 1.05 on the tile at {region:?}", s.name),
        );
    }
}

/// False alarms: two Rust renders of every scene that differ only in the seed are consistent
/// under `compare` at its default α = 0.01 (one comparison per scene, fixed seeds).
#[test]
fn renders_differing_only_in_seed_pass_compare() {
    // The Lambertian scenes (tests/certify_glossy_power.rs has the glossy ones).
    let scenes = certify::selected_scenes(&options(
        "floor-tube,floor-crossing,two-tubes,cornell-tube,mesh-occluder",
    ))
    .expect("scenes with references");
    assert_eq!(scenes.len(), 5);
    for s in &scenes {
        let opts = |seed| RenderOptions {
            spp: 1024,
            passes: 1,
            seed,
            method: Technique::ProjectedSolidAngle.into(),
            light_samples: 1,
            lights: LightSelection::Every,
            noise: Default::default(),
            cylinders: linlight_render::Cylinders::Line,
        };
        let a = linlight_render::render(&s.scene, &opts(11), &|_, _| {}).unwrap();
        let b = linlight_render::render(&s.scene, &opts(12), &|_, _| {}).unwrap();
        let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
        assert_eq!(
            cmp.verdict,
            Verdict::Consistent,
            "{}: seeds 11 and 12 judged different: {:?}",
            s.name,
            cmp.failures
        );
    }
}
