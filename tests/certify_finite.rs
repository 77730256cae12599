//! The finite-tube family of `linlight certify` (references/finite-tubes, docs/cylinders.md):
//! its scenes rendered with exact tubes are consistent with their Mitsuba references, compared
//! exactly (no contact pixels, no allowance), and two wrong renders through the same comparison
//! are rejected: the R → 0 line limit of the fat tubes, and ours without MIS with every tube
//! estimate divided by 1.01 (its pdf × 1.01).

mod power;

use linlight::certify::matrix::{ExactTubes, FINITE_SUBJECTS};
use linlight::certify::{self, Subject};
use linlight_imagefile::Image;
use linlight_render::scene::CropWindow;
use linlight_render::{Cylinders, Prepared, RenderError, RenderOptions};
use linlight_sampling::Technique;
use linlight_verify::image_stats::Verdict;
use power::{assert_rejected, certify_with, options};

const FAMILY: &str = "finite-tube-*";

/// The fat tubes rendered as their R → 0 limit (a line with K = L·R, sampled by the projected
/// solid angle): the line density used for a cylinder of radius 0.06–0.12.
struct LineLimit;

impl Subject for LineLimit {
    fn name(&self) -> String {
        "line limit (projected solid angle)".into()
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        let o = RenderOptions {
            method: Technique::ProjectedSolidAngle.into(),
            cylinders: Cylinders::Line,
            ..*opts
        };
        scene.render(crop, &o, progress)
    }
    fn exact_tubes(&self) -> bool {
        true
    }
}

/// An exact-tube subject's render with every mean divided by `divisor` (standard errors too).
/// For ours without MIS on a scene whose camera does not see the tube (finite-tube-glossy),
/// this is exactly the render with the technique's pdf × `divisor`: every pixel is reflected
/// light, each estimate L·f·cos/p.
struct Divided {
    subject: ExactTubes,
    divisor: f32,
}

impl Subject for Divided {
    fn name(&self) -> String {
        format!("{} ÷ {}", self.subject.name(), self.divisor)
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        let mut img = self.subject.render(scene, crop, opts, progress)?;
        let k = 1.0 / self.divisor;
        for (m, v) in img.mean.iter_mut().zip(img.var.iter_mut()) {
            *m = m.map(|c| c * k);
            *v = v.map(|c| c * k * k);
        }
        Ok(img)
    }
    fn exact_tubes(&self) -> bool {
        true
    }
}

/// Ours without MIS: the cheapest subject of the family.
fn ours_alone() -> ExactTubes {
    FINITE_SUBJECTS[4]
}

/// Every scene of the family with exact tubes, ours with and without MIS, against Mitsuba:
/// consistent, with no pixel tested apart as a contact (the contact scene's tube rests on the
/// floor) and no contact allowance. The line techniques do not render these scenes.
#[test]
fn finite_tube_scenes_are_consistent_with_mitsuba() {
    let opts = options(FAMILY);
    let scenes = certify::selected_scenes(&opts).expect("scenes with references");
    assert_eq!(scenes.len(), 3);
    assert!(scenes.iter().all(|s| s.exact_tubes));
    let subjects = [
        &FINITE_SUBJECTS[0] as &dyn Subject,
        &ours_alone(),
        &Technique::ProjectedSolidAngle,
    ];
    let r = certify::run(&opts, &subjects, &|_| {}).expect("usable input");
    assert_eq!(
        r.rows().count(),
        2 * 3,
        "two exact subjects on three scenes"
    );
    for row in r.rows() {
        eprintln!(
            "{} / {}: {:?}, rel. diff {:?} ± {:?}, worst tile p {:?}",
            row.scene, row.subject, row.verdict, row.rel_diff, row.rel_ci, row.worst_tile_p
        );
        assert!(row.subject.starts_with("exact:"), "{}", row.subject);
        // No pixel is tested apart, so the contact allowance applies to none.
        assert!(row.comparison.contact_pixels.is_empty(), "{}", row.scene);
        assert_eq!(
            row.verdict,
            Verdict::Consistent,
            "{} / {}: {:?}",
            row.scene,
            row.subject,
            row.comparison.failures
        );
    }
    assert!(r.passed);
}

/// The line limit of the fat tubes is rejected on every scene of the family.
#[test]
fn the_line_limit_of_a_fat_tube_is_rejected() {
    let r = certify_with(FAMILY, &LineLimit);
    assert_eq!(r.rows().count(), 3);
    assert_rejected(&r, "line limit on the finite tubes");
}

/// Ours without MIS with its estimates divided by 1.01 (on finite-tube-glossy exactly its pdf ×
/// 1.01) is rejected on every scene of the family.
#[test]
fn ours_divided_by_one_percent_is_rejected() {
    let r = certify_with(
        FAMILY,
        &Divided {
            subject: ours_alone(),
            divisor: 1.01,
        },
    );
    assert_eq!(r.rows().count(), 3);
    assert_rejected(&r, "ours ÷ 1.01 on the finite tubes");
}
