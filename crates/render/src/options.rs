//! What a render is asked to do ([`RenderOptions`]) and why it can refuse ([`RenderError`]).

use crate::light_choice::LightSelection;
use crate::method::Method;
use crate::scene::{CropWindow, Film, Scene};
use linlight_sampling::cylinder::CylinderTechnique;
use linlight_sampling::noise::Noise;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel in each pass.
    pub spp: u32,
    /// Independent passes (≥ 1).
    pub passes: u32,
    pub seed: u64,
    /// How each light is sampled (a single technique, LTC, or MIS with a heuristic).
    pub method: Method,
    /// Iterations per light and camera sample (≥ 1): samples of the single technique, or
    /// pairs of a diffuse and a specular sample; the light's estimate is their mean. The CLI's
    /// default is the scene's `emitter_samples` (see `linlight render --help`).
    pub light_samples: u32,
    /// Which lights each light sample samples: every light (the default) or one chosen at
    /// random (Mitsuba's estimator; [`crate::light_choice`]).
    pub lights: LightSelection,
    /// Where the primary samples come from (white by default; see [`linlight_sampling::noise`]).
    pub noise: Noise,
    /// How cylinders with an area emitter are rendered: the R → 0 line limit or the tube of
    /// radius R ([`Cylinders`]; the library's default is the line, `linlight render`'s exact).
    pub cylinders: Cylinders,
}

/// How a `cylinder` shape with an `area` emitter is rendered (`linlight render --cylinders`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cylinders {
    /// The R → 0 limit: a linear light with K = radiance × radius, invisible to every ray.
    Line,
    /// The cylinder of radius R as Mitsuba has it (open, emitting radiance L outward, opaque),
    /// sampled by a cylinder technique, optionally combined with BSDF sampling
    /// ([`crate::tube`]).
    Exact(TubeSampling),
}

/// The sampling of an exact tube light at a shading point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TubeSampling {
    /// The emitter technique (densities per steradian over the visible side).
    pub technique: CylinderTechnique,
    /// Whether a cosine-weighted BSDF-side sample joins the emitter sample, both weighted by
    /// the balance heuristic.
    pub mis: bool,
}

impl Default for TubeSampling {
    /// Ours (the line sampler along the axis, composed across the section) with MIS.
    fn default() -> Self {
        Self {
            technique: CylinderTechnique::Projected,
            mis: true,
        }
    }
}

impl Cylinders {
    /// The exact tubes with the default sampling.
    pub const EXACT: Cylinders = Cylinders::Exact(TubeSampling {
        technique: CylinderTechnique::Projected,
        mis: true,
    });

    /// `line` or `exact` (the `cylinders` header entry).
    pub fn name(self) -> &'static str {
        match self {
            Cylinders::Line => "line",
            Cylinders::Exact(_) => "exact",
        }
    }

    /// The header entries: `cylinders`, and for exact tubes `cylinder_technique` and
    /// `cylinder_mis` (`balance` or `off`).
    pub fn header(self) -> Vec<(&'static str, String)> {
        let mut v = vec![("cylinders", self.name().to_string())];
        if let Cylinders::Exact(t) = self {
            v.push(("cylinder_technique", t.technique.name().to_string()));
            v.push((
                "cylinder_mis",
                if t.mis { "balance" } else { "off" }.to_string(),
            ));
        }
        v
    }
}

/// The cylinder technique of a `--cylinder-technique` name: `area`, `solid-angle`, `gamito`,
/// `projected`, `ltc` (with or without the `cylinder-` prefix).
pub fn cylinder_technique(name: &str) -> Result<CylinderTechnique, String> {
    let bare = name.strip_prefix("cylinder-").unwrap_or(name);
    CylinderTechnique::ALL
        .into_iter()
        .find(|t| t.name().strip_prefix("cylinder-") == Some(bare))
        .ok_or_else(|| {
            format!(
                "unknown cylinder technique '{name}' (expected projected, ltc, solid-angle, \
                 gamito or area)"
            )
        })
}

impl Default for RenderOptions {
    /// 1 spp, 1 pass, seed 0, the default method (MIS, clamped optimal, v = 0.5), 1 light
    /// sample of every light, white noise, cylinders as lines.
    fn default() -> Self {
        Self {
            spp: 1,
            passes: 1,
            seed: 0,
            method: Method::default(),
            light_samples: 1,
            lights: LightSelection::Every,
            noise: Noise::White,
            cylinders: Cylinders::Line,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum RenderError {
    /// The scene cannot be rendered as given (film size, crop, camera).
    Scene(String),
    /// The options cannot be used (spp, passes or light samples zero).
    Options(String),
}

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenderError::Scene(m) | RenderError::Options(m) => f.write_str(m),
        }
    }
}
impl std::error::Error for RenderError {}

/// Pixel window actually rendered: the crop, or the whole film.
pub(crate) fn window(scene: &Scene) -> Result<Window, RenderError> {
    let film = &scene.sensor.film;
    window_of(film, film.crop)
}

/// Pixels of a film rendered: x0, y0 (full-film), width, height.
pub(crate) type Window = (u32, u32, u32, u32);

/// The pixels of `film` that `crop` (None: the whole film) renders, or why it cannot be
/// rendered.
pub(crate) fn window_of(film: &Film, crop: Option<CropWindow>) -> Result<Window, RenderError> {
    if film.width == 0 || film.height == 0 {
        return Err(RenderError::Scene(format!(
            "film has zero size ({}x{})",
            film.width, film.height
        )));
    }
    if film.width as u64 * film.height as u64 > 1 << 32 {
        return Err(RenderError::Scene(format!(
            "film {}x{} has more than 2^32 pixels (the random streams are indexed by a 32-bit \
             pixel index)",
            film.width, film.height
        )));
    }
    match crop {
        None => Ok((0, 0, film.width, film.height)),
        Some(c) => {
            let fits = c.width > 0
                && c.height > 0
                && c.offset_x
                    .checked_add(c.width)
                    .is_some_and(|e| e <= film.width)
                && c.offset_y
                    .checked_add(c.height)
                    .is_some_and(|e| e <= film.height);
            if !fits {
                return Err(RenderError::Scene(format!(
                    "crop window {}x{}+{}+{} does not fit the {}x{} film",
                    c.width, c.height, c.offset_x, c.offset_y, film.width, film.height
                )));
            }
            Ok((c.offset_x, c.offset_y, c.width, c.height))
        }
    }
}

/// Reject options no render can use.
pub(crate) fn check_options(opts: &RenderOptions) -> Result<(), RenderError> {
    if opts.spp == 0 || opts.passes == 0 || opts.light_samples == 0 {
        return Err(RenderError::Options(
            "spp, passes and light samples must be at least 1".into(),
        ));
    }
    Ok(())
}
