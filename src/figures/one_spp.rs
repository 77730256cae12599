//! The talk's opening: one sample per pixel of area, solid angle and projected solid angle
//! sampling (diffuse shading, shadow rays traced), with crops and each image's RMSE, on the
//! lamps scene (occluders, five lights) and on the unoccluded floor of `floor-tube`.

use super::imaging::{crop, enlarge, outline, rmse, tone, white_scale};
use super::page::{num, picture, row};
use super::{csv, figure_scene, Ctx, Section};
use linlight_imagefile::Image;
use linlight_render::scene::Scene;
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use serde_json::json;

pub const TECHNIQUES: [Technique; 3] = [
    Technique::Area,
    Technique::SolidAngle,
    Technique::ProjectedSolidAngle,
];

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let res = ctx.settings.res;
    let scenes = [
        (
            "lamps",
            figure_scene("lamps"),
            vec![("res", res.to_string())],
        ),
        (
            "floor-tube",
            "references/scenes/floor-tube.xml".to_string(),
            vec![("res", res.to_string())],
        ),
    ];
    let mut out = Outputs::default();
    let mut refs = Vec::new();
    // Progress steps: per scene its reference and one render per technique.
    let steps = (scenes.len() * (TECHNIQUES.len() + 1)) as f64;
    for (i, (name, rel, overrides)) in scenes.iter().enumerate() {
        let (reference, what) = ctx.reference(rel, overrides)?;
        let mut step = (i * (TECHNIQUES.len() + 1)) as f64 + 1.0;
        ctx.progress(step / steps);
        let scene = ctx.scene(rel, overrides)?;
        let mut items = Vec::new();
        for t in TECHNIQUES {
            items.extend(out.technique(ctx, name, &scene, &reference, t)?);
            step += 1.0;
            ctx.progress(step / steps);
        }
        let scale = white_scale(&reference);
        let zoom = (256 / res as usize).max(1);
        let ref_file = ctx.write_png(
            &format!("one-spp-{name}-reference"),
            &tone(&reference, scale),
        )?;
        out.files.push(ref_file);
        items.push(picture(
            &enlarge(&tone(&reference, scale), zoom),
            1,
            "reference",
        ));
        out.body.push_str(&format!("<h3>{name}</h3>"));
        out.body.push_str(&row(&items));
        refs.push(format!("{name}: {what}"));
    }
    out.files.push(ctx.write_text(
        "one-spp.csv",
        &csv(
            &["scene", "technique", "rmse", "seconds_per_sample"],
            &out.csv_rows,
        ),
    )?);
    Ok(Section {
        caption: caption(res, &refs, &out.numbers),
        body: out.body,
        files: out.files,
        numbers: json!({ "renders": out.numbers, "references": refs }),
        ..Default::default()
    })
}

/// The figure as it is built: HTML body, numbers, CSV rows and files written.
#[derive(Default)]
struct Outputs {
    body: String,
    files: Vec<String>,
    numbers: Vec<serde_json::Value>,
    csv_rows: Vec<Vec<String>>,
}

impl Outputs {
    /// Technique `t` on scene `name` at 1 spp: its picture with two crops outlined, the
    /// crops enlarged (the pictures returned), its PNG, RMSE and time per sample.
    fn technique(
        &mut self,
        ctx: &Ctx,
        name: &str,
        scene: &Scene,
        reference: &Image,
        t: Technique,
    ) -> Result<Vec<String>, String> {
        let res = ctx.settings.res;
        let scale = white_scale(reference);
        let zoom = (256 / res as usize).max(1);
        // Two crops: a quarter of the width each.
        let c = (res / 4) as usize;
        let crops = [
            ((res as usize * 3) / 16, (res as usize * 9) / 16),
            ((res as usize * 9) / 16, (res as usize * 5) / 16),
        ];
        let r = ctx.render(scene, t, Noise::Blue, 1, 1, ctx.opts.seed)?;
        let e = rmse(&r.image, reference);
        let mut pic = tone(&r.image, scale);
        let crop_pics: Vec<_> = crops
            .iter()
            .map(|&(x, y)| crop(&pic, x, y, c, c, 2 * zoom))
            .collect();
        for &(x, y) in &crops {
            outline(&mut pic, x, y, c, c, [255, 220, 0]);
        }
        let file = ctx.write_png(
            &format!("one-spp-{name}-{}", t.name()),
            &tone(&r.image, scale),
        )?;
        self.files.push(file);
        let mut items = vec![picture(
            &enlarge(&pic, zoom),
            1,
            &format!("{}: RMSE {}", t.name(), num(e)),
        )];
        for (k, cp) in crop_pics.iter().enumerate() {
            items.push(picture(cp, 1, &format!("{} crop {}", t.name(), k + 1)));
        }
        self.numbers.push(json!({"scene": name, "technique": t.name(), "rmse": e, "seconds_per_sample": r.seconds_per_sample()}));
        self.csv_rows.push(vec![
            name.to_string(),
            t.name().to_string(),
            format!("{e}"),
            format!("{}", r.seconds_per_sample()),
        ]);
        Ok(items)
    }
}

/// What the figure shows, its settings and the RMSE of each technique on each scene.
fn caption(res: u32, refs: &[String], numbers: &[serde_json::Value]) -> String {
    let get = |scene: &str, t: Technique| {
        numbers
            .iter()
            .find(|n| n["scene"] == scene && n["technique"] == t.name())
            .and_then(|n| n["rmse"].as_f64())
            .unwrap_or(f64::NAN)
    };
    format!(
        "What it shows: at one sample per pixel and light, sampling the projected solid angle (ours) removes the \
         noise of the cosine and of the distance that area and solid angle sampling leave, so its error is lowest \
         wherever a light is unoccluded; what remains is visibility noise in penumbrae. Settings: {res}×{res} px, \
         1 spp, one sample per light, blue noise (the paper's teaser setting at N = 1), diffuse BRDF, shadow rays \
         traced, the same seed for every technique; crops (yellow boxes) enlarged. RMSE over pixels and RGB against \
         {} (reference variance subtracted). Measured RMSE, lamps: area {}, solid angle {}, projected solid angle \
         {}; floor-tube (no occluders): area {}, solid angle {}, projected solid angle {}.",
        refs.join("; "),
        num(get("lamps", Technique::Area)),
        num(get("lamps", Technique::SolidAngle)),
        num(get("lamps", Technique::ProjectedSolidAngle)),
        num(get("floor-tube", Technique::Area)),
        num(get("floor-tube", Technique::SolidAngle)),
        num(get("floor-tube", Technique::ProjectedSolidAngle)),
    )
}
