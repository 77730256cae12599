//! The pieces of the integrator that tests may replace: the line technique, the specular
//! sampler and the BSDF evaluation. Production renders use [`Hooks::new`] (through
//! [`crate::render`](fn@crate::render)); [`crate::render_scalar`] renders with any [`Hooks`], which is how power
//! controls render deliberately wrong variants (`power_controls`, with the `test-support`
//! feature, has the ready-made ones). Generic, so that the production path stays monomorphic.
//!
//! What each hook replaces:
//!
//! | field | replaces | used by |
//! |---|---|---|
//! | `technique` | the technique of [`Method::Technique`](crate::Method) (`None`: the method's) | single-technique renders |
//! | `specular` | the LTC sampler prepared from (segment, shading point, frame, A) | [`Method::Ltc`](crate::Method), [`Method::Mis`](crate::Method) |
//! | `bsdf` | BSDF evaluation and the lobe summary (table lookup, MIS weights) | every method on non-Lambertian surfaces |
//!
//! The diffuse technique of `Ltc`/`Mis` is always the projected solid angle. Lambertian
//! surfaces take a fast path (f = ρ/π) that does not call `bsdf`.
//!
//! Example (a power control: κ := 1 in the LTC density, rendered with MIS):
//!
//! ```
//! use linlight_render::hooks::Hooks;
//! use linlight_render::power_controls::LtcWithoutKappa;
//! use linlight_render::{Method, RenderOptions};
//! let hooks = Hooks::new().with_specular(LtcWithoutKappa);
//! let opts = RenderOptions { spp: 4, method: Method::default(), ..Default::default() };
//! // linlight_render::render_scalar(&scene, &opts, &hooks, &|_, _| {})
//! # let _ = (hooks, opts);
//! ```

use glam::{DVec3, Mat3, Vec3};
use linlight_brdf::{Bsdf, Lobes};
use linlight_sampling::ltc::LtcLine;
use linlight_sampling::{LineFrame, LineSampler, Prepared, Segment, SpecularSampler, Technique};
use linlight_simd::{dispatch, get3, set3, splat3, Isa, Kernel, Lanes3};

/// Directions of one [`BsdfModel::eval_lanes`] call: eight f32 lanes (an AVX2 register), the
/// light samples of a camera sample at certify's most (8).
pub const EVAL_LANES: usize = 8;

/// How the integrator samples a light at a shading point with one technique.
/// [`Technique`] is the production implementation.
pub trait LightSampling: Sync {
    type Sampler: LineSampler;
    /// The sampler for `segment` seen from `x` with normal `n`; `None`: no contribution.
    fn prepare(&self, segment: &Segment, x: Vec3, n: Vec3) -> Option<Self::Sampler>;
    /// Name recorded in the image metadata (`technique`).
    fn name(&self) -> String;
}

impl LightSampling for Technique {
    type Sampler = Prepared;
    #[inline]
    fn prepare(&self, segment: &Segment, x: Vec3, n: Vec3) -> Option<Prepared> {
        Technique::prepare(*self, segment, x, n)
    }
    fn name(&self) -> String {
        Technique::name(*self).to_string()
    }
}

/// How the specular technique is prepared for one light. [`Ltc`] is the production one.
pub trait SpecularSampling: Sync {
    type Sampler: SpecularSampler;
    /// The sampler for `segment` seen from `x`; `frame` has the columns x̂, ŷ, n of the
    /// shading frame (x̂ toward the viewer), `a` maps shading to cosine space (the table's A).
    /// `None`: the lobe is empty on the line (the integrator then samples diffusely only).
    fn prepare(&self, segment: &Segment, x: Vec3, frame: Mat3, a: Mat3) -> Option<Self::Sampler>;
    /// [`Self::prepare`] with `line` = `LineFrame::new(segment, x)` given (the same sampler).
    fn prepare_on_line(
        &self,
        segment: &Segment,
        x: Vec3,
        _line: &LineFrame,
        frame: Mat3,
        a: Mat3,
    ) -> Option<Self::Sampler> {
        self.prepare(segment, x, frame, a)
    }
    /// Name recorded in the image metadata (`specular_hook`); `None` for the production LTC.
    fn name(&self) -> Option<String> {
        None
    }
}

/// LTC line sampling ([`LtcLine`]), the production specular technique.
#[derive(Clone, Copy, Debug, Default)]
pub struct Ltc;

impl SpecularSampling for Ltc {
    type Sampler = LtcLine;
    #[inline]
    fn prepare(&self, segment: &Segment, x: Vec3, frame: Mat3, a: Mat3) -> Option<LtcLine> {
        LtcLine::prepare(segment, x, frame, a)
    }
    #[inline]
    fn prepare_on_line(
        &self,
        segment: &Segment,
        x: Vec3,
        line: &LineFrame,
        frame: Mat3,
        a: Mat3,
    ) -> Option<LtcLine> {
        LtcLine::on_frame(segment, x, line, frame, a)
    }
}

/// BSDF evaluation and lobe summary. [`SceneBsdf`] (the scene's BSDF as loaded) is the
/// production one.
pub trait BsdfModel: Sync {
    /// f(v, l)·cos θ_l in the shading frame (`Bsdf::eval`'s contract).
    fn eval(&self, bsdf: &Bsdf, v: DVec3, l: DVec3) -> DVec3;
    /// The lobe summary that selects the LTC table entry and the MIS weights.
    fn lobes(&self, bsdf: &Bsdf, v: DVec3) -> Lobes;
    /// f·cos of the first `len` lanes of `l` (f32 directions in the shading frame) seen from
    /// `v`: lane k is `eval(bsdf, v, l_k)` rounded to f32, bit for bit; lanes from `len` on
    /// are unspecified.
    #[inline]
    fn eval_lanes(
        &self,
        bsdf: &Bsdf,
        v: DVec3,
        l: &Lanes3<f32, EVAL_LANES>,
        len: usize,
    ) -> Lanes3<f32, EVAL_LANES> {
        let mut out = [[0.0; EVAL_LANES]; 3];
        for k in 0..len.min(EVAL_LANES) {
            set3(
                &mut out,
                k,
                self.eval(bsdf, v, get3(l, k).as_dvec3()).as_vec3(),
            );
        }
        out
    }
    /// Name recorded in the image metadata (`bsdf_hook`); `None` for the scene's BSDF.
    fn name(&self) -> Option<String> {
        None
    }
}

/// The scene's BSDFs, evaluated as loaded, in f32 as Mitsuba evaluates them
/// ([`Bsdf::eval_f32`] of v and l rounded to f32: the renderer passes f32 values, so nothing
/// is rounded, and the packet renderer's lanes give the same bits).
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneBsdf;

impl BsdfModel for SceneBsdf {
    #[inline]
    fn eval(&self, bsdf: &Bsdf, v: DVec3, l: DVec3) -> DVec3 {
        bsdf.eval_f32(v.as_vec3(), l.as_vec3()).as_dvec3()
    }
    #[inline]
    fn lobes(&self, bsdf: &Bsdf, v: DVec3) -> Lobes {
        bsdf.lobes(v)
    }
    /// [`Bsdf::eval_lanes`] on all lanes, in the SIMD lanes of the CPU's instruction set
    /// ([`EvalLanes`]); lane k is [`Bsdf::eval_f32`] of lane k, bit for bit.
    #[inline]
    fn eval_lanes(
        &self,
        bsdf: &Bsdf,
        v: DVec3,
        l: &Lanes3<f32, EVAL_LANES>,
        _len: usize,
    ) -> Lanes3<f32, EVAL_LANES> {
        dispatch(
            Isa::detect(),
            EvalLanes {
                bsdf,
                v: v.as_vec3(),
                l,
            },
        )
    }
}

/// The kernel of [`SceneBsdf::eval_lanes`]: `bsdf` seen from `v` toward every lane of `l`.
pub struct EvalLanes<'a> {
    pub bsdf: &'a Bsdf,
    pub v: Vec3,
    pub l: &'a Lanes3<f32, EVAL_LANES>,
}

impl Kernel for EvalLanes<'_> {
    type Output = Lanes3<f32, EVAL_LANES>;
    #[inline(always)]
    fn run(self) -> Self::Output {
        self.bsdf.eval_lanes(&splat3(self.v), self.l)
    }
}

/// The replaceable pieces of a render (module documentation).
#[derive(Clone, Copy, Debug)]
pub struct Hooks<D = Technique, S = Ltc, B = SceneBsdf> {
    /// Replaces the technique of `Method::Technique(_)`; `None`: the method's own.
    pub technique: Option<D>,
    pub specular: S,
    pub bsdf: B,
}

impl Default for Hooks {
    fn default() -> Self {
        Self::new()
    }
}

impl Hooks {
    /// The production pieces: the method's own technique, [`Ltc`], [`SceneBsdf`].
    pub fn new() -> Self {
        Hooks {
            technique: None,
            specular: Ltc,
            bsdf: SceneBsdf,
        }
    }
}

impl<D, S, B> Hooks<D, S, B> {
    /// The same hooks with `technique` as the single technique.
    pub fn with_technique<D2: LightSampling>(self, technique: D2) -> Hooks<D2, S, B> {
        Hooks {
            technique: Some(technique),
            specular: self.specular,
            bsdf: self.bsdf,
        }
    }

    /// The same hooks with another specular sampler.
    pub fn with_specular<S2: SpecularSampling>(self, specular: S2) -> Hooks<D, S2, B> {
        Hooks {
            technique: self.technique,
            specular,
            bsdf: self.bsdf,
        }
    }

    /// The same hooks with another BSDF model.
    pub fn with_bsdf<B2: BsdfModel>(self, bsdf: B2) -> Hooks<D, S, B2> {
        Hooks {
            technique: self.technique,
            specular: self.specular,
            bsdf,
        }
    }
}

impl<D: LightSampling, S: SpecularSampling, B: BsdfModel> Hooks<D, S, B> {
    /// Header entries naming the replaced pieces (none for production hooks).
    pub fn header(&self) -> Vec<(&'static str, String)> {
        let mut v = Vec::new();
        if let Some(s) = self.specular.name() {
            v.push(("specular_hook", s));
        }
        if let Some(b) = self.bsdf.name() {
            v.push(("bsdf_hook", b));
        }
        v
    }
}

/// The pieces of one render with the line technique resolved: what the integrator is generic
/// over. `technique` is the hook's technique for single-technique renders if one is given,
/// else the method's technique; the two-technique methods use the projected solid angle on
/// Lambertian surfaces (their diffuse-only path).
#[derive(Debug)]
pub struct Resolved<'a, T, S, B> {
    pub technique: &'a T,
    pub specular: &'a S,
    pub bsdf: &'a B,
}

impl<T, S, B> Clone for Resolved<'_, T, S, B> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T, S, B> Copy for Resolved<'_, T, S, B> {}

/// Calls `$body` with `$r` bound to the [`Resolved`] pieces of `$hooks` for `$method` (two
/// monomorphic instances: the hook's technique, or a `Technique`).
macro_rules! with_resolved {
    ($hooks:expr, $method:expr, |$r:ident| $body:expr) => {{
        let hooks = $hooks;
        match (&hooks.technique, $method) {
            (Some(d), $crate::method::Method::Technique(_)) => {
                let $r = $crate::hooks::Resolved {
                    technique: d,
                    specular: &hooks.specular,
                    bsdf: &hooks.bsdf,
                };
                $body
            }
            (_, m) => {
                let t = $crate::method::lambert_technique(m);
                let $r = $crate::hooks::Resolved {
                    technique: &t,
                    specular: &hooks.specular,
                    bsdf: &hooks.bsdf,
                };
                $body
            }
        }
    }};
}
pub(crate) use with_resolved;
