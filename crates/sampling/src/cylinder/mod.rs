//! Finite cylinder lights: the open side of a cylinder of radius R > 0, sampled from a shading
//! point with no R → 0 limit taken (docs/cylinders.md).
//!
//! The light is Mitsuba's `cylinder` shape with an `area` emitter: the side surface around the
//! axis p0 → p1, **no caps**, normals pointing outward, **one-sided** emission (only the outer
//! side emits radiance L; the inside, seen through an open end, is black but still blocks).
//!
//! Measure: every density here is per steradian (solid angle at the shading point x), unlike
//! the line techniques' densities per radius. The estimator of the reflected radiance is
//! L · f(ω) · max(0, n·ω) / p(ω).
//!
//! Coordinates (the view's frame, [`CylinderView`]): ĉ is the unit vector from x toward the
//! axis, perpendicular to it, at distance ρ; w = u × ĉ; u the unit axis. A direction is
//! ω = cos φ · ĉ_α + sin φ · u with ĉ_α = cos α · ĉ + sin α · w: α is its azimuth around the
//! axis direction and φ its elevation toward the axis. In (α, s = sin φ) the solid angle is
//! dΩ = dα ds (Archimedes), which every technique builds on.
//!
//! What x sees: the front-facing part of the side is the set of surface points whose outward
//! normal has a positive component toward x; with ρ > R that is the surface angle
//! |θ| < θ_max = acos(R/ρ) around the point nearest x, along the whole length, and it is never
//! hidden by the rest of the cylinder (it lies outside every tangent plane of the convex solid).
//! Seen from x it covers the azimuths |α| ≤ α_max = asin(R/ρ); at azimuth α the side is a
//! line parallel to the axis at horizontal distance h(α), seen between the elevations
//! φ_a(α) = atan2(a, h) and φ_b(α) = atan2(b, h) (a, b: the ends' axial coordinates relative to
//! the foot of x on the axis). A shading point with ρ ≤ R sees no front face (inside the tube,
//! or beyond an end looking into it): nothing to sample.

pub mod area;
pub mod gamito;
pub mod ltc;
pub mod projected;
pub mod solid_angle;

pub use area::CylinderArea;
pub use gamito::CylinderGamito;
pub use ltc::{CylinderLtc, LtcSlice};
pub use projected::CylinderProjected;
pub use solid_angle::CylinderSolidAngle;

use glam::{DMat3, DVec3, Vec3};

/// A finite open cylinder (no caps): axis from `p0` to `p1`, radius `radius`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    p0: DVec3,
    p1: DVec3,
    radius: f64,
    /// |p1 − p0| and the unit axis (p1 − p0)/|p1 − p0|, formed once for every view.
    length: f64,
    u: DVec3,
}

impl Cylinder {
    /// `None` unless the ends are finite and distinct and the radius is finite and positive.
    pub fn new(p0: DVec3, p1: DVec3, radius: f64) -> Option<Self> {
        let axis = p1 - p0;
        let length = axis.length();
        let ok =
            p0.is_finite() && p1.is_finite() && length > 0.0 && radius.is_finite() && radius > 0.0;
        ok.then_some(Self {
            p0,
            p1,
            radius,
            length,
            u: axis / length,
        })
    }

    /// From f32 scene values (converted exactly).
    pub fn from_f32(p0: Vec3, p1: Vec3, radius: f32) -> Option<Self> {
        Self::new(p0.as_dvec3(), p1.as_dvec3(), radius as f64)
    }

    /// The axis' first end.
    pub fn p0(&self) -> DVec3 {
        self.p0
    }

    /// The axis' second end.
    pub fn p1(&self) -> DVec3 {
        self.p1
    }

    pub fn radius(&self) -> f64 {
        self.radius
    }

    pub fn length(&self) -> f64 {
        self.length
    }

    /// Area of the side, 2πRℓ.
    pub fn area(&self) -> f64 {
        std::f64::consts::TAU * self.radius * self.length()
    }
}

/// The cylinder seen from a shading point x with unit normal n (the frame of the module
/// documentation). Invariants: ρ > R > 0, a < b, n unit.
#[derive(Clone, Copy, Debug)]
pub struct CylinderView {
    /// Shading point.
    pub x: DVec3,
    /// Unit shading normal.
    pub n: DVec3,
    /// Unit axis direction p0 → p1.
    pub u: DVec3,
    /// Unit vector from x toward the axis, perpendicular to it.
    pub c: DVec3,
    /// u × ĉ.
    pub w: DVec3,
    /// Distance of x from the axis.
    pub rho: f64,
    pub radius: f64,
    /// Axial coordinates of p0 and p1 relative to the foot of x on the axis (a < b).
    pub a: f64,
    pub b: f64,
    /// asin(R/ρ): the visible azimuths are |α| ≤ α_max.
    pub alpha_max: f64,
    /// acos(R/ρ): the visible surface angles are |θ| ≤ θ_max.
    pub theta_max: f64,
    /// n·u, n·ĉ, n·w.
    pub n_u: f64,
    pub n_c: f64,
    pub n_w: f64,
}

impl CylinderView {
    /// `None` when x sees no front face (ρ ≤ R), or for a non-finite x or an invalid normal.
    pub fn new(cylinder: &Cylinder, x: DVec3, n: DVec3) -> Option<Self> {
        let n = n.try_normalize()?;
        if !x.is_finite() {
            return None;
        }
        let (length, u) = (cylinder.length, cylinder.u);
        let z = (x - cylinder.p0).dot(u);
        let radial = cylinder.p0 + z * u - x;
        let rho = radial.length();
        let radius = cylinder.radius;
        if rho.is_nan() || rho <= radius || !rho.is_finite() {
            return None;
        }
        let c = radial / rho;
        let w = u.cross(c);
        // (ρ − R)(ρ + R) without cancellation of ρ² − R².
        let tangent = ((rho - radius) * (rho + radius)).sqrt();
        Some(Self {
            x,
            n,
            u,
            c,
            w,
            rho,
            radius,
            a: -z,
            b: length - z,
            alpha_max: radius.atan2(tangent),
            theta_max: tangent.atan2(radius),
            n_u: n.dot(u),
            n_c: n.dot(c),
            n_w: n.dot(w),
        })
    }

    /// From f32 scene values.
    #[inline]
    pub fn from_f32(cylinder: &Cylinder, x: Vec3, n: Vec3) -> Option<Self> {
        Self::new(cylinder, x.as_dvec3(), n.as_dvec3())
    }

    /// Horizontal distance from x to the front side at azimuth α (|α| ≤ α_max):
    /// h = (ρ² − R²) / (ρ cos α + √(R² − ρ² sin² α)), the near root of the circle, in a form
    /// without cancellation.
    #[inline]
    pub fn h(&self, alpha: f64) -> f64 {
        self.h_of(alpha.sin(), alpha.cos())
    }

    /// [`Self::h`] from sin α and cos α.
    #[inline]
    pub(crate) fn h_of(&self, sin_alpha: f64, cos_alpha: f64) -> f64 {
        let (r, rho) = (self.radius, self.rho);
        let p = rho * sin_alpha.abs();
        let k = ((r - p).max(0.0) * (r + p)).sqrt();
        (rho - r) * (rho + r) / (rho * cos_alpha + k)
    }

    /// The slice at azimuth α: sin α, cos α (one evaluation), h(α) and n·ĉ_α, the values of
    /// [`Self::h`] and [`Self::n_t`] bit for bit.
    #[inline]
    pub fn slice_at(&self, alpha: f64) -> SliceAt {
        let (sin, cos) = alpha.sin_cos();
        SliceAt {
            alpha,
            sin,
            cos,
            h: self.h_of(sin, cos),
            n_t: self.n_t_of(sin, cos),
        }
    }

    /// [`Self::direction`] at the slice's azimuth (the same bits).
    #[inline]
    pub fn direction_at(&self, slice: &SliceAt, phi: f64) -> DVec3 {
        let (s, c) = phi.sin_cos();
        c * (slice.cos * self.c + slice.sin * self.w) + s * self.u
    }

    /// The direction with azimuth α and axial sine s if it hits the visible side, else `None`
    /// (α beyond ±α_max, NaN, or s outside the side's [s_a, s_b] at α).
    #[inline]
    pub fn front_direction(&self, alpha: f64, s: f64) -> Option<DVec3> {
        self.front_sample_at(alpha, s).map(|(dir, _)| dir)
    }

    /// [`Self::front_direction`] and the distance h/cos φ from x to the side along it.
    #[inline]
    pub(crate) fn front_sample_at(&self, alpha: f64, s: f64) -> Option<(DVec3, f64)> {
        if alpha.is_nan() || alpha.abs() > self.alpha_max {
            return None;
        }
        let (sin, cos) = alpha.sin_cos();
        self.front_sample(sin, cos, s)
    }

    /// The direction with azimuth α (|α| ≤ α_max, given by sin α and cos α) and axial sine s
    /// if it hits the visible side, and the distance h/cos φ from x to the side along it; `None`
    /// for s outside the side's [s_a, s_b] at α (also NaN). One pass of arithmetic: the ends
    /// compared as s with e/√(e² + h²), as [`Self::front_hit`] does.
    #[inline]
    pub(crate) fn front_sample(&self, sin: f64, cos: f64, s: f64) -> Option<(DVec3, f64)> {
        let h = self.h_of(sin, cos);
        let end = |e: f64| e / (e * e + h * h).sqrt();
        if !(s >= end(self.a) && s <= end(self.b)) {
            return None;
        }
        let t = ((1.0 - s) * (1.0 + s)).max(0.0).sqrt();
        Some((t * (cos * self.c + sin * self.w) + s * self.u, h / t))
    }

    /// ĉ_α = cos α ĉ + sin α w.
    #[inline]
    pub fn c_alpha(&self, alpha: f64) -> DVec3 {
        let (s, c) = alpha.sin_cos();
        c * self.c + s * self.w
    }

    /// n·ĉ_α.
    #[inline]
    pub fn n_t(&self, alpha: f64) -> f64 {
        let (s, c) = alpha.sin_cos();
        self.n_t_of(s, c)
    }

    /// n·ĉ_α from sin α and cos α.
    #[inline]
    pub(crate) fn n_t_of(&self, sin_alpha: f64, cos_alpha: f64) -> f64 {
        cos_alpha * self.n_c + sin_alpha * self.n_w
    }

    /// The unit direction (α, φ).
    #[inline]
    pub fn direction(&self, alpha: f64, phi: f64) -> DVec3 {
        let (s, c) = phi.sin_cos();
        c * self.c_alpha(alpha) + s * self.u
    }

    /// (α, φ) of a direction (any length > 0).
    #[inline]
    pub fn angles(&self, dir: DVec3) -> (f64, f64) {
        let (dc, dw) = (dir.dot(self.c), dir.dot(self.w));
        (dw.atan2(dc), dir.dot(self.u).atan2(dc.hypot(dw)))
    }

    /// Elevations of the two ends at azimuth α, given h(α).
    #[inline]
    pub fn phi_range(&self, h: f64) -> (f64, f64) {
        (self.a.atan2(h), self.b.atan2(h))
    }

    /// (α, φ, h) of a direction that hits the front side, `None` otherwise.
    #[inline]
    pub fn hit(&self, dir: DVec3) -> Option<(f64, f64, f64)> {
        let (alpha, phi) = self.angles(dir);
        if alpha.is_nan() || alpha.abs() > self.alpha_max {
            return None;
        }
        let h = self.h(alpha);
        let (pa, pb) = self.phi_range(h);
        (phi >= pa && phi <= pb).then_some((alpha, phi, h))
    }

    /// Surface angle θ ∈ [−θ_max, θ_max] of the front point at azimuth α (0: nearest x).
    #[inline]
    pub fn theta_of_alpha(&self, alpha: f64) -> f64 {
        let h = self.h(alpha);
        let (s, c) = alpha.sin_cos();
        (h * s).atan2(self.rho - h * c)
    }

    /// Azimuth α of the front point at surface angle θ, and dα/dθ.
    #[inline]
    pub fn alpha_of_theta(&self, theta: f64) -> (f64, f64) {
        let (r, rho) = (self.radius, self.rho);
        let (s, c) = theta.sin_cos();
        let (hx, hy) = (rho - r * c, r * s);
        let h2 = hx * hx + hy * hy;
        (hy.atan2(hx), r * (rho * c - r) / h2)
    }

    /// Unshadowed projected solid angle ∫ max(0, n·ω) dΩ of the visible side, by `nodes`-point
    /// Gauss–Legendre quadrature in θ on `panels` panels (the integrand is smooth in θ; in α it
    /// has a square-root edge at α_max), the φ-integral in closed form. For reference values.
    pub fn projected_solid_angle_quadrature(&self, panels: usize, nodes: &[(f64, f64)]) -> f64 {
        let mut sum = 0.0;
        let width = 2.0 * self.theta_max / panels as f64;
        for k in 0..panels {
            let lo = -self.theta_max + k as f64 * width;
            for &(x, wgt) in nodes {
                let theta = lo + 0.5 * width * (x + 1.0);
                let (alpha, jac) = self.alpha_of_theta(theta);
                let slice = projected::slice_total(self, alpha, self.h(alpha)).unwrap_or(0.0);
                sum += 0.5 * width * wgt * jac * 0.5 * slice;
            }
        }
        sum
    }
}

impl CylinderView {
    /// Where `dir` (any length) meets the front, from its components along ĉ, w and u: the
    /// azimuth by one atan2, everything else as ratios, the ends compared as sin φ with
    /// e/√(e² + h²). `None` off the front (also for a NaN component, which makes α NaN).
    pub(crate) fn front_hit(&self, dir: DVec3) -> Option<FrontHit> {
        let (dc, dw, du) = (dir.dot(self.c), dir.dot(self.w), dir.dot(self.u));
        let horizontal = (dc * dc + dw * dw).sqrt();
        let alpha = crate::trig::atan2_f64(dw, dc);
        if horizontal <= 0.0 || alpha.is_nan() || alpha.abs() > self.alpha_max {
            return None;
        }
        let (sin, cos) = (dw / horizontal, dc / horizontal);
        let h = self.h_of(sin, cos);
        let length = (horizontal * horizontal + du * du).sqrt();
        let s = du / length;
        let end = |e: f64| e / (e * e + h * h).sqrt();
        if !(s >= end(self.a) && s <= end(self.b)) {
            return None;
        }
        let slice = SliceAt {
            alpha,
            sin,
            cos,
            h,
            n_t: self.n_t_of(sin, cos),
        };
        Some(FrontHit {
            slice,
            s,
            t: horizontal / length,
            n_dot_w: self.n.dot(dir) / length,
            distance: h * length / horizontal,
        })
    }
}

/// A direction's hit on the front ([`CylinderView::front_hit`]): its slice, sin φ and cos φ,
/// n·ω of the unit direction, and the distance from x to the side.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FrontHit {
    pub slice: SliceAt,
    pub s: f64,
    pub t: f64,
    pub n_dot_w: f64,
    pub distance: f64,
}

/// The values of one azimuth α that the slice there needs ([`CylinderView::slice_at`]).
#[derive(Clone, Copy, Debug)]
pub struct SliceAt {
    pub alpha: f64,
    pub sin: f64,
    pub cos: f64,
    /// h(α).
    pub h: f64,
    /// n·ĉ_α.
    pub n_t: f64,
}

/// A sample of a cylinder technique: the unit direction toward the visible side, its density
/// per steradian and the distance from the shading point along it to the side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylinderSample {
    pub dir: DVec3,
    pub pdf: f64,
    pub distance: f64,
}

impl CylinderSample {
    /// The sample if its density and distance are positive and finite (else it contributes
    /// nothing).
    pub(crate) fn checked(dir: DVec3, pdf: f64, distance: f64) -> Option<Self> {
        (pdf > 0.0 && pdf.is_finite() && distance > 0.0 && distance.is_finite()).then_some(Self {
            dir,
            pdf,
            distance,
        })
    }
}

/// A technique prepared for one cylinder at one shading point: the triad of the line samplers
/// (sample, pdf, inverse) on the two-dimensional primary sample space.
pub trait CylinderSampler {
    /// Direction toward the visible side and its density per steradian for the primary sample
    /// ξ ∈ [0, 1]² (values outside are clamped). `None`: the sample contributes nothing (its
    /// estimate is 0, which the technique's density accounts for).
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)>;

    /// Density per steradian of any direction (0 where the technique does not sample).
    fn pdf(&self, dir: DVec3) -> f64;

    /// [`Self::sample_with_pdf`] with the distance from x along the direction to the visible
    /// side (`None` also where the rounded direction misses the side).
    fn sample_toward(&self, xi: [f32; 2]) -> Option<CylinderSample> {
        let (dir, pdf) = self.sample_with_pdf(xi)?;
        let (_, phi, h) = self.view().hit(dir)?;
        Some(CylinderSample {
            dir,
            pdf,
            distance: h / phi.cos(),
        })
    }

    /// For a unit direction that hits the visible side: its density per steradian ([`Self::pdf`],
    /// 0 where the technique does not sample) and the distance from x along it to the side;
    /// `None` where it misses the side ([`CylinderView::hit`]).
    fn pdf_toward(&self, dir: DVec3) -> Option<(f64, f64)> {
        let (_, phi, h) = self.view().hit(dir)?;
        Some((self.pdf(dir), h / phi.cos()))
    }

    /// The primary sample that maps to `dir`, where the technique has a closed-form inverse.
    fn inverse(&self, _dir: DVec3) -> Option<[f64; 2]> {
        None
    }

    fn view(&self) -> &CylinderView;
}

/// Run-time choice of a cylinder technique.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CylinderTechnique {
    /// Uniform by area on the visible side.
    Area,
    /// Uniform in solid angle over the visible side.
    SolidAngle,
    /// The azimuth across the section, the elevation by the paper's projected-solid-angle
    /// line sampler.
    Projected,
    /// Uniform in solid angle by Gamito's construction: a bounding spherical rectangle and
    /// rejection.
    Gamito,
    /// The azimuth across the section fitted to the LTC mass of the slices, the elevation by
    /// the paper's LTC line sampler ([`CylinderLtc`]); [`Self::Projected`] where the surface
    /// has no LTC lobe ([`Self::prepare`]).
    Ltc,
}

impl CylinderTechnique {
    pub const ALL: [CylinderTechnique; 5] = [
        CylinderTechnique::Area,
        CylinderTechnique::SolidAngle,
        CylinderTechnique::Projected,
        CylinderTechnique::Gamito,
        CylinderTechnique::Ltc,
    ];

    pub fn name(self) -> &'static str {
        match self {
            CylinderTechnique::Area => "cylinder-area",
            CylinderTechnique::SolidAngle => "cylinder-solid-angle",
            CylinderTechnique::Projected => "cylinder-projected",
            CylinderTechnique::Gamito => "cylinder-gamito",
            CylinderTechnique::Ltc => "cylinder-ltc",
        }
    }

    /// The technique for a surface without an LTC lobe (A = identity: [`Self::Ltc`] is
    /// [`Self::Projected`], the same distribution).
    pub fn prepare(self, view: &CylinderView) -> Option<PreparedCylinder> {
        self.prepare_with_lobe(view, None)
    }

    /// The technique for a surface whose glossy lobe has the LTC matrix `a` in the shading
    /// frame `frame` (columns x̂, ŷ, n; `None`: no lobe). Only [`Self::Ltc`] uses it; where
    /// [`CylinderLtc::new`] refuses A it is [`Self::Projected`].
    #[inline]
    pub fn prepare_with_lobe(
        self,
        view: &CylinderView,
        lobe: Option<(DMat3, DMat3)>,
    ) -> Option<PreparedCylinder> {
        Some(match self {
            CylinderTechnique::Area => PreparedCylinder::Area(CylinderArea::new(view)?),
            CylinderTechnique::SolidAngle => {
                PreparedCylinder::SolidAngle(CylinderSolidAngle::boxed(view)?)
            }
            CylinderTechnique::Projected => {
                PreparedCylinder::Projected(CylinderProjected::new(view)?)
            }
            CylinderTechnique::Gamito => PreparedCylinder::Gamito(CylinderGamito::new(view)?),
            CylinderTechnique::Ltc => match lobe.and_then(|(f, a)| CylinderLtc::new(view, f, a)) {
                Some(ltc) => PreparedCylinder::Ltc(ltc),
                None => PreparedCylinder::Projected(CylinderProjected::new(view)?),
            },
        })
    }
}

/// A prepared cylinder technique of any kind.
#[derive(Clone, Debug)]
pub enum PreparedCylinder {
    Area(CylinderArea),
    /// Boxed: its envelope and quadrature tables make it ~500 bytes.
    SolidAngle(Box<CylinderSolidAngle>),
    Projected(CylinderProjected),
    Gamito(CylinderGamito),
    Ltc(CylinderLtc),
}

macro_rules! dispatch {
    ($self:ident, $s:ident => $e:expr) => {
        match $self {
            PreparedCylinder::Area($s) => $e,
            PreparedCylinder::SolidAngle($s) => $e,
            PreparedCylinder::Projected($s) => $e,
            PreparedCylinder::Gamito($s) => $e,
            PreparedCylinder::Ltc($s) => $e,
        }
    };
}

impl CylinderSampler for PreparedCylinder {
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)> {
        dispatch!(self, s => s.sample_with_pdf(xi))
    }
    fn pdf(&self, dir: DVec3) -> f64 {
        dispatch!(self, s => s.pdf(dir))
    }
    fn sample_toward(&self, xi: [f32; 2]) -> Option<CylinderSample> {
        dispatch!(self, s => s.sample_toward(xi))
    }
    fn pdf_toward(&self, dir: DVec3) -> Option<(f64, f64)> {
        dispatch!(self, s => s.pdf_toward(dir))
    }
    fn inverse(&self, dir: DVec3) -> Option<[f64; 2]> {
        dispatch!(self, s => s.inverse(dir))
    }
    fn view(&self) -> &CylinderView {
        dispatch!(self, s => s.view())
    }
}

/// Clamp a primary sample to [0, 1] in f64; NaN becomes 0.
#[inline]
pub(crate) fn clamp_xi(xi: f32) -> f64 {
    crate::sampler::clamp_xi(xi) as f64
}

/// Rejection sampling as a deterministic function of ξ: the first candidate is drawn from ξ,
/// later ones from a PCG32 stream (`stream`) keyed by ξ's bits, at most `max_candidates` in all.
/// `candidate` maps two uniforms to a candidate `C`; `accept` returns its sample or `None`.
pub(crate) fn reject_until_accepted<C, T>(
    xi: [f32; 2],
    stream: u64,
    max_candidates: usize,
    candidate: impl Fn(f64, f64) -> C,
    accept: impl Fn(C) -> Option<T>,
) -> Option<T> {
    if let Some(sample) = accept(candidate(clamp_xi(xi[0]), clamp_xi(xi[1]))) {
        return Some(sample);
    }
    let seed = ((xi[0].to_bits() as u64) << 32) | xi[1].to_bits() as u64;
    let mut rng = crate::rng::Pcg32::new(seed, stream);
    (1..max_candidates).find_map(|_| accept(candidate(rng.next_f64(), rng.next_f64())))
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::*;

    /// Gauss–Legendre nodes and weights on [−1, 1].
    pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
        linlight_quadrature::GaussLegendre::new(n)
            .points()
            .collect()
    }

    /// Ω of the visible side by a reference quadrature independent of the techniques': θ-panels
    /// graded geometrically toward θ = 0 (edges θ_max·2^−k, k ≤ 60), 24 nodes each, of
    /// (s_b − s_a)·dα/dθ with α(θ) and h from the view; with both ends on one side of x's foot
    /// (a b > 0), s_b − s_a = h²(b − a)(b + a)/((b r_a + a r_b) r_a r_b), r_e = √(h² + e²),
    /// which does not cancel far beyond an end.
    pub fn omega_reference(v: &CylinderView) -> f64 {
        let nodes = gauss_legendre(24);
        let mut half = 0.0;
        let mut hi = v.theta_max;
        for k in 0..=60 {
            let lo = if k == 60 { 0.0 } else { 0.5 * hi };
            for &(x, wt) in &nodes {
                let theta = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x;
                let (alpha, jac) = v.alpha_of_theta(theta);
                let h = v.h(alpha);
                let (ra, rb) = (v.a.hypot(h), v.b.hypot(h));
                let ds = if v.a * v.b > 0.0 {
                    h * h * (v.b - v.a) * (v.b + v.a) / ((v.b * ra + v.a * rb) * ra * rb)
                } else {
                    v.b / rb - v.a / ra
                };
                half += 0.5 * (hi - lo) * wt * jac * ds;
            }
            hi = lo;
        }
        2.0 * half
    }

    /// ∫ g(α, φ) dΩ over the visible side: θ-panels × φ between the ends, Gauss–Legendre in
    /// both, the φ-interval split at the horizon (densities may kink or jump there).
    pub fn integrate(view: &CylinderView, g: &mut dyn FnMut(f64, f64) -> f64) -> f64 {
        let nodes = gauss_legendre(24);
        let panels = 16;
        let width = 2.0 * view.theta_max / panels as f64;
        let mut sum = 0.0;
        for k in 0..panels {
            let lo = -view.theta_max + k as f64 * width;
            for &(x, wt) in &nodes {
                let theta = lo + 0.5 * width * (x + 1.0);
                let (alpha, jac) = view.alpha_of_theta(theta);
                let (pa, pb) = view.phi_range(view.h(alpha));
                let mut cuts = vec![pa, pb];
                let (ns, nt) = (view.n_u, view.n_t(alpha));
                let horizon = (-nt).atan2(ns);
                let horizon = if horizon > std::f64::consts::FRAC_PI_2 {
                    horizon - std::f64::consts::PI
                } else if horizon < -std::f64::consts::FRAC_PI_2 {
                    horizon + std::f64::consts::PI
                } else {
                    horizon
                };
                if horizon > pa && horizon < pb {
                    cuts.insert(1, horizon);
                }
                let mut inner = 0.0;
                for seg in cuts.windows(2) {
                    let (p, q) = (seg[0], seg[1]);
                    for &(y, wy) in &nodes {
                        let phi = p + 0.5 * (q - p) * (y + 1.0);
                        inner += 0.5 * (q - p) * wy * g(alpha, phi) * phi.cos();
                    }
                }
                sum += 0.5 * width * wt * jac * inner;
            }
        }
        sum
    }

    pub fn configs() -> Vec<(Cylinder, DVec3, DVec3)> {
        let cyl = |p0: [f64; 3], p1: [f64; 3], r: f64| {
            Cylinder::new(DVec3::from(p0), DVec3::from(p1), r).unwrap()
        };
        vec![
            // Thin, above a floor point.
            (
                cyl([-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], 1e-4),
                DVec3::ZERO,
                DVec3::Z,
            ),
            // R = 0.3 × the distance, tilted normal.
            (
                cyl([-1.0, 0.2, 1.0], [1.5, -0.3, 1.2], 0.3),
                DVec3::ZERO,
                DVec3::new(0.3, -0.2, 1.0),
            ),
            // Close to the tube (ρ = 1.05 R), beside its end.
            (
                cyl([0.0, 0.0, 0.5], [2.0, 0.0, 0.5], 0.4),
                DVec3::new(-0.1, 0.0, 0.08),
                DVec3::Z,
            ),
            // Crossing the tangent plane.
            (
                cyl([-1.0, 0.5, -0.6], [1.0, 0.3, 0.9], 0.2),
                DVec3::ZERO,
                DVec3::Z,
            ),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;

    #[test]
    fn solid_angle_of_an_infinite_like_tube_is_four_alpha_max() {
        // A very long tube seen from its middle: Ω → 2·2α_max (s from −1 to 1).
        let cyl =
            Cylinder::new(DVec3::new(-1e6, 0.0, 1.0), DVec3::new(1e6, 0.0, 1.0), 0.25).unwrap();
        let v = CylinderView::new(&cyl, DVec3::ZERO, DVec3::Z).unwrap();
        let omega = integrate(&v, &mut |_, _| 1.0);
        assert!((omega - 4.0 * v.alpha_max).abs() < 1e-9, "{omega}");
        // Projected: ∫ n·ω dα ds with n = ĉ: 2 ∫cos α dα · ∫ √(1−s²) ds = 2 sin α_max · π/2.
        let psa = integrate(&v, &mut |a, p| v.direction(a, p).dot(v.n).max(0.0));
        let q = v.projected_solid_angle_quadrature(8, &gauss_legendre(16));
        let exact = 2.0 * v.alpha_max.sin() * std::f64::consts::FRAC_PI_2;
        assert!(
            (psa - exact).abs() < 1e-9 && (q - exact).abs() < 1e-9,
            "{psa} {q} {exact}"
        );
    }

    #[test]
    fn hit_agrees_with_the_surface_point() {
        for (cyl, x, n) in configs() {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            for i in 0..=20 {
                let theta = v.theta_max * (i as f64 / 10.0 - 1.0) * 0.999;
                let (alpha, _) = v.alpha_of_theta(theta);
                assert!((v.theta_of_alpha(alpha) - theta).abs() < 1e-9);
                let h = v.h(alpha);
                // The point at horizontal distance h along ĉ_α lies on the circle.
                let p = v.rho * v.c - h * v.c_alpha(alpha);
                assert!((p.length() - v.radius).abs() < 1e-9 * v.rho);
                let l = 0.5 * (v.a + v.b);
                let dir = (h * v.c_alpha(alpha) + l * v.u).normalize();
                let (a2, _, h2) = v.hit(dir).unwrap();
                assert!((a2 - alpha).abs() < 1e-12 && (h2 - h).abs() < 1e-9 * v.rho);
            }
            // Beyond the silhouette and beyond the ends: no hit.
            assert!(v.hit(v.direction(1.001 * v.alpha_max, 0.0)).is_none());
            let (_, pb) = v.phi_range(v.h(0.0));
            assert!(v.hit(v.direction(0.0, pb + 1e-6)).is_none());
        }
    }

    #[test]
    fn inside_the_tube_sees_nothing() {
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::X, 0.5).unwrap();
        assert!(CylinderView::new(&cyl, DVec3::new(2.0, 0.1, 0.0), DVec3::Z).is_none());
        assert!(CylinderView::new(&cyl, DVec3::new(0.5, 0.5, 0.0), DVec3::Z).is_none());
        assert!(Cylinder::new(DVec3::ZERO, DVec3::X, 0.0).is_none());
        assert!(Cylinder::new(DVec3::ZERO, DVec3::X, f64::NAN).is_none());
    }
}
