//! Noise comparison: white vs blue vs jittered blue noise at N = 1 and 3 samples per pixel, with
//! each image's RMSE and a low-pass-filtered RMSE (blue noise moves its error to high
//! frequencies, which the eye at a distance — or a denoiser — averages away).

use super::imaging::{enlarge, low_pass_rmse, rmse, tone, white_scale};
use super::page::{num, picture, row, table};
use super::{csv, Ctx, Section};
use linlight_imagefile::Image;
use linlight_render::scene::Scene;
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use serde_json::json;

/// Standard deviation of the low-pass filter, pixels.
pub const LOW_PASS_SIGMA: f64 = 1.5;
pub const COUNTS: [u32; 2] = [1, 3];

/// The scenes of the figure: the paper's setting (room, several lights, penumbrae, glossy floor)
/// and an unoccluded diffuse floor (projected-solid-angle sampling is exact there for the light,
/// so the error is the pixel footprint's alone: the film position, a two-dimensional blue-noise
/// sample, without visibility noise).
const SCENES: [(&str, &str); 2] = [("room", "figures/room"), ("floor-tube", "floor-tube")];

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let res = ctx.settings.res;
    let mut out = Outputs::default();
    let mut references = Vec::new();
    for (i, (label, file)) in SCENES.into_iter().enumerate() {
        let rel = format!("references/scenes/{file}.xml");
        let overrides = vec![("res", res.to_string())];
        let (reference, what) = ctx.reference(&rel, &overrides)?;
        references.push(format!("{label}: {what}"));
        let scene = ctx.scene(&rel, &overrides)?;
        out.body.push_str(&format!("<h3>{label}</h3>"));
        out.scene(ctx, label, &scene, &reference, i)?;
    }
    out.files.push(ctx.write_text(
        "noise.csv",
        &csv(
            &["scene", "noise", "spp", "rmse", "low_pass_rmse"],
            &out.rows,
        ),
    )?);
    out.body.push_str(&rows_table(&out.rows));
    let caption = caption(ctx, &references, &out.numbers);
    Ok(Section {
        caption,
        body: out.body,
        files: out.files,
        numbers: json!({ "references": references, "low_pass_sigma_px": LOW_PASS_SIGMA, "renders": out.numbers }),
        ..Default::default()
    })
}

/// The figure as it is built: HTML body, CSV rows, numbers and files written.
#[derive(Default)]
struct Outputs {
    body: String,
    rows: Vec<Vec<String>>,
    numbers: Vec<serde_json::Value>,
    files: Vec<String>,
}

impl Outputs {
    /// Scene number `i` (`label`) rendered at each count of [`COUNTS`] with each noise: one
    /// picture row per count, one CSV row and number per render.
    fn scene(
        &mut self,
        ctx: &Ctx,
        label: &str,
        scene: &Scene,
        reference: &Image,
        i: usize,
    ) -> Result<(), String> {
        let res = ctx.settings.res;
        let zoom = (256 / res as usize).max(1);
        let scale = white_scale(reference);
        let total = (SCENES.len() * COUNTS.len() * Noise::ALL.len()) as f64;
        let mut done = (i * COUNTS.len() * Noise::ALL.len()) as f64;
        for n in COUNTS {
            let mut items = Vec::new();
            for noise in Noise::ALL {
                let r = ctx.render(
                    scene,
                    Technique::ProjectedSolidAngle,
                    noise,
                    n,
                    1,
                    ctx.opts.seed,
                )?;
                done += 1.0;
                ctx.progress(done / total);
                let (e, lp) = (
                    rmse(&r.image, reference),
                    low_pass_rmse(&r.image, reference, LOW_PASS_SIGMA),
                );
                let pic = tone(&r.image, scale);
                self.files
                    .push(ctx.write_png(&format!("noise-{label}-{}-{n}spp", noise.name()), &pic)?);
                items.push(picture(
                    &enlarge(&pic, zoom),
                    1,
                    &format!("{noise}, N = {n}: RMSE {}, low-pass {}", num(e), num(lp)),
                ));
                self.rows.push(vec![
                    label.to_string(),
                    noise.name().to_string(),
                    n.to_string(),
                    format!("{e}"),
                    format!("{lp}"),
                ]);
                self.numbers.push(json!({"scene": label, "noise": noise.name(), "spp": n, "rmse": e, "low_pass_rmse": lp}));
            }
            self.body
                .push_str(&format!("<h4>N = {n}</h4>{}", row(&items)));
        }
        Ok(())
    }
}

/// The table of every render's RMSE and low-pass RMSE.
fn rows_table(rows: &[Vec<String>]) -> String {
    table(
        &["scene", "noise", "N", "RMSE", "low-pass RMSE"],
        &rows
            .iter()
            .map(|r| {
                vec![
                    r[0].clone(),
                    r[1].clone(),
                    r[2].clone(),
                    num(r[3].parse().unwrap_or(f64::NAN)),
                    num(r[4].parse().unwrap_or(f64::NAN)),
                ]
            })
            .collect::<Vec<_>>(),
    )
}

/// What the figure shows, its settings and the measured low-pass RMSE of every render.
fn caption(ctx: &Ctx, references: &[String], numbers: &[serde_json::Value]) -> String {
    let res = ctx.settings.res;
    let get = |scene: &str, noise: Noise, n: u32| {
        numbers
            .iter()
            .find(|x| x["scene"] == scene && x["noise"] == noise.name() && x["spp"] == n)
            .and_then(|x| x["low_pass_rmse"].as_f64())
            .unwrap_or(f64::NAN)
    };
    let measured: Vec<String> = SCENES
        .iter()
        .flat_map(|(label, _)| {
            COUNTS.iter().map(move |&n| {
                format!(
                    "{label} at N = {n}: white {}, blue {}, jittered blue {}",
                    num(get(label, Noise::White, n)),
                    num(get(label, Noise::Blue, n)),
                    num(get(label, Noise::BlueJittered, n)),
                )
            })
        })
        .collect();
    format!(
        "What it shows: the same estimator with three sources of primary samples. Blue noise (void-and-cluster \
         dither arrays generated in-project, a random toroidal shift per pass) gives each pixel the same \
         distribution as white noise — the RMSE barely changes — but arranges the errors of neighbouring pixels \
         so that they cancel under a low-pass filter; jittered blue noise (ξ_i = (ξ₀ + i)/N, the paper's \
         stratification) also stratifies the N samples of a pixel. Settings: room (the paper's setting: glossy \
         floor, principled, roughness 0.4; three lights; penumbrae) and floor-tube (one light over an unoccluded \
         diffuse floor, where projected-solid-angle sampling is exact for the light: its error is the pixel \
         footprint's alone, so blue and jittered blue noise coincide there), {res}×{res} px, projected-solid-angle sampling with the full BRDF (one sample per light \
         and camera sample; the paper uses LTC MIS in the room), shadow rays, seed {}. The film position inside \
         the pixel is a blue-noise dimension too: at small sizes the pixel footprint (edges, the fall-off near a \
         light) is a large part of the room's error, and it cancels less well than the light sample's. RMSE \
         over pixels and RGB against {}; low-pass: Gaussian of σ = {LOW_PASS_SIGMA} px applied to both images. \
         Measured low-pass RMSE: {}.",
        ctx.opts.seed,
        references.join("; "),
        measured.join("; "),
    )
}
