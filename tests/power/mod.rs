//! Fixtures of the certify power-control tests (tests/certify_power.rs and
//! tests/certify_glossy_power.rs include this module with `mod power;`): the default
//! certification of a few scenes with one deliberately wrong subject, and the check that every
//! comparison rejected it.

#![allow(dead_code)] // each test crate uses a different subset

use linlight::certify::{self, matrix, Options, Oracle, Report, Subject};
use linlight_imagefile::Image;
use linlight_render::hooks::{BsdfModel, LightSampling, SpecularSampling};
use linlight_render::scene::CropWindow;
use linlight_render::{Hooks, Method, Prepared, RenderError, RenderOptions};
use linlight_verify::image_stats::Verdict;
use std::path::Path;

/// The default certification (committed references) of the scenes matching `scenes`, without
/// the sampler suite (it has its own negative controls), without the blue-noise renders of the
/// production technique (only the subject under test), and without writing a report.
pub fn options(scenes: &str) -> Options {
    let mut o = Options::new(Path::new(env!("CARGO_MANIFEST_DIR")));
    o.scenes = scenes.into();
    o.oracle = Oracle::Committed;
    o.sampler_suite = false;
    o.gpu_kernels = false;
    o.variant_renders.clear();
    o
}

/// [`options`] run with one subject.
pub fn certify_with(scenes: &str, subject: &dyn Subject) -> Report {
    certify::run(&options(scenes), &[subject], &|_| {}).expect("usable input")
}

/// The run compared the subject with every oracle of every scene (Mitsuba, and the exact image
/// where there is one) and every comparison says DIFFERENT (so the run fails).
pub fn assert_rejected(report: &Report, what: &str) {
    for row in report.rows() {
        eprintln!(
            "{what}: {} vs {}: {:?}, rel. diff {:?}, failures {:?}",
            row.scene,
            row.oracle,
            row.verdict,
            row.rel_diff,
            row.comparison
                .failures
                .iter()
                .map(|f| f.test)
                .collect::<Vec<_>>()
        );
    }
    let oracles: usize = report
        .scenes
        .iter()
        .map(|s| 1 + usize::from(matrix::has_exact_oracle(&s.name)))
        .sum();
    assert!(oracles > 0, "{what}: no scene certified");
    assert_eq!(report.rows().count(), oracles, "{what}: comparisons");
    assert!(!report.passed, "{what}: certification passed");
    for row in report.rows() {
        assert_eq!(
            row.verdict,
            Verdict::Different,
            "{what}: {} vs {} not rejected: rel. diff {:?}, CI {:?}",
            row.scene,
            row.oracle,
            row.rel_diff,
            row.rel_ci
        );
    }
}

/// A method rendered with replaced pieces ([`Hooks`]): a power control.
pub struct Hooked<D, S, B> {
    pub name: &'static str,
    pub method: Method,
    pub hooks: Hooks<D, S, B>,
}

impl<D: LightSampling, S: SpecularSampling, B: BsdfModel> Subject for Hooked<D, S, B> {
    fn name(&self) -> String {
        self.name.into()
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        scene.render_scalar(
            crop,
            &RenderOptions {
                method: self.method,
                ..*opts
            },
            &self.hooks,
            progress,
        )
    }
}
