//! The certify report on one scene with a small budget: `report.html` is self-contained (every
//! picture inline), labels its pictures and colour bars, has the forest plot and the efficiency
//! column, and notes two subjects that rendered identical images; `report.md`'s tables keep one
//! cell per column (no unescaped `|` in link texts).

mod common;

use common::{root, scratch};
use linlight::certify::budget::BudgetRule;
use linlight::certify::{self, Options, Oracle, Subject};
use linlight_imagefile::Image;
use linlight_render::scene::CropWindow;
use linlight_render::{Prepared, RenderError, RenderOptions};
use linlight_sampling::Technique;

/// The production technique under another name: its images are identical to the original's.
struct Twin;

impl Subject for Twin {
    fn name(&self) -> String {
        "twin".into()
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        let opts = RenderOptions {
            method: Technique::ProjectedSolidAngle.into(),
            ..*opts
        };
        scene.render(crop, &opts, progress)
    }
}

/// Cells of a markdown table line: `|` not preceded by a backslash.
fn unescaped_pipes(line: &str) -> usize {
    let b = line.as_bytes();
    (0..b.len())
        .filter(|&i| b[i] == b'|' && (i == 0 || b[i - 1] != b'\\'))
        .count()
}

#[test]
fn report_html_is_self_contained_and_complete() {
    let dir = scratch("report");
    let mut opts = Options::new(root());
    opts.scenes = "floor-tube".into();
    opts.oracle = Oracle::Committed;
    opts.sampler_suite = false;
    opts.report_dir = Some(dir.clone());
    opts.budget = BudgetRule {
        pilot_spp: 64,
        min_spp: 64,
        max_spp: 128,
        ..BudgetRule::default()
    };
    let subjects: [&dyn Subject; 2] = [&Technique::ProjectedSolidAngle, &Twin];
    let report = certify::run(&opts, &subjects, &|_| {}).expect("usable input");
    let rows = report.rows().count();
    assert_eq!(rows, 4, "2 subjects × (Mitsuba, closed form)");

    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    // Self-contained: every picture is a data URI, nothing links to a file.
    let sources: Vec<&str> = html.split("src=\"").skip(1).collect();
    assert!(sources.len() >= 4 * rows, "{} pictures", sources.len());
    assert!(sources
        .iter()
        .all(|s| s.starts_with("data:image/png;base64,")));
    assert!(!html.contains("href="));
    for want in [
        "<figcaption>Rust</figcaption>",
        "<figcaption>Mitsuba</figcaption>",
        "<figcaption>closed form (R → 0)</figcaption>",
        "<figcaption>difference</figcaption>",
        "class=\"bar\"",
        "<svg",
        "variance × time",
        "relative to best",
        "projected-solid-angle and twin rendered identical images",
    ] {
        assert!(html.contains(want), "report.html lacks {want:?}");
    }
    assert_eq!(html.matches("<h3>").count(), rows);

    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let mut table_width = None;
    for line in md.lines() {
        if line.starts_with('|') {
            let n = unescaped_pipes(line);
            match table_width {
                None => table_width = Some(n),
                Some(w) => assert_eq!(n, w, "table line with a different cell count: {line}"),
            }
        } else {
            table_width = None;
        }
    }
    assert!(md.contains("A \\| B \\| Δ"));
    std::fs::remove_dir_all(&dir).ok();
}
