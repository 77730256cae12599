//! A linear light seen from one shading point.
//!
//! Measure used everywhere in this crate: the *per-radius* solid angle. A tube of radius R around
//! the segment subtends, as R → 0, a solid angle R·Ω_R; directions toward the line are
//! ω(s) = s·u + t·ĉ with s = u·ω ∈ [−1, 1], t = √(1 − s²), and the measure is dΩ_R = (2/d) ds.
//! Every density returned by a sampler is with respect to dΩ_R.
//!
//! The line is parametrised by l, the signed distance along u from the closest point c:
//! p(l) = c + l·u, s(l) = l / √(l² + d²). A [`LineFrame`] carries an l-interval; horizon
//! clipping only shrinks that interval, the frame (u, ĉ, d) stays the same.

use crate::trig::{atan2_f64, sin_cos_f64, sin_cos_poly};
use glam::Vec3;

/// A segment light in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub begin: Vec3,
    pub end: Vec3,
}

impl Segment {
    pub fn new(begin: Vec3, end: Vec3) -> Self {
        Self { begin, end }
    }
}

/// The line of a segment relative to a shading point x, restricted to an interval of l.
///
/// Invariants (guaranteed by the constructors): `d > 0`, `u` and `c_hat` unit and orthogonal,
/// `l_begin < l_end`, all fields finite, `-1 ≤ s_begin < s_end ≤ 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFrame {
    /// Unit direction of the line.
    pub u: Vec3,
    /// Unit vector from the shading point to the closest point of the infinite line.
    pub c_hat: Vec3,
    /// Distance from the shading point to the infinite line.
    pub d: f32,
    /// Parameter of the first point of the interval (signed, along u, from the closest point).
    pub l_begin: f32,
    /// Parameter of the last point of the interval.
    pub l_end: f32,
    /// s = u·ω at `l_begin`.
    pub s_begin: f32,
    /// s = u·ω at `l_end`.
    pub s_end: f32,
}

/// Smallest d/ℓ-relative distance to the infinite line that still counts as "off the line".
/// Below it the light subtends no solid angle (per radius it would be ~1/d, but the tube would
/// contain the shading point); every technique then reports "no contribution".
const MIN_RELATIVE_DISTANCE: f32 = 1e-7;

/// Bound on |s_of(direction(s)) − s| for s in a frame's interval (a few ulps at 1).
pub const S_ROUNDING: f32 = 4.0 * f32::EPSILON;

/// s = l / √(l² + d²) of the line point at parameter l: [`sin_cos_at`] (in f64, where the
/// squares of f32 values neither overflow nor underflow; no libm `hypotf` call), rounded once.
#[inline(always)]
fn s_of_l(l: f32, d: f32) -> f32 {
    (sin_cos_at(l, d).0 as f32).clamp(-1.0, 1.0)
}

impl LineFrame {
    /// The frame of `segment` seen from `x`. `None` when the segment has zero (or non-finite)
    /// length, when `x` lies on the infinite line (d = 0, relative to the segment scale), or when
    /// any input is not finite.
    ///
    /// Computed in f64 and rounded once: in f32 the closest point c = b − σu cancels for x near
    /// the line (or a far segment seen along its axis), with an error ~ε|b| above
    /// `MIN_RELATIVE_DISTANCE`·|b|, which left ĉ far from orthogonal to u; and the squares in
    /// |b| leave the f32 range for coordinates beyond ~1e±19.
    pub fn new(segment: &Segment, x: Vec3) -> Option<Self> {
        Self::build(segment, x, None).map(|(frame, ..)| frame)
    }

    /// `LineFrame::new(segment, x)?.clip_to_horizon(n)` (n unit) in one pass: the endpoints'
    /// heights n·b, n·e come straight from the input, so the (data-dependent, often
    /// mispredicted) clipping decision resolves before the frame's dependency chain of square
    /// roots and divisions, not after it, and the clipped parameter is formed in f64 as
    /// l = σ + ℓ·n·b/(n·b − n·e) (a sum of like-signed terms in the denominator).
    #[inline]
    pub fn clipped(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        Self::build(segment, x, Some(n)).map(|(frame, ..)| frame)
    }

    /// [`Self::clipped`] and the f64 values at its ends that it computed on the way. `n` may be
    /// any finite positive multiple of the unit normal (the samplers pass the normal as given,
    /// so that the clipping does not wait for its normalisation).
    #[inline]
    pub(crate) fn clipped_with_ends(
        segment: &Segment,
        x: Vec3,
        n: Vec3,
    ) -> Option<(Self, EndValues)> {
        Self::build(segment, x, Some(n)).map(|(frame, ends, _)| (frame, ends))
    }

    /// [`Self::clipped_with_ends`] and, from the same closest point, the frame of the whole
    /// segment: bit for bit `Self::new(segment, x)` wherever the clipped frame exists (u, ĉ, d
    /// do not depend on the horizon; the whole interval is [σ, σ + ℓ]).
    #[inline]
    pub(crate) fn clipped_and_whole(
        segment: &Segment,
        x: Vec3,
        n: Vec3,
    ) -> Option<(Self, EndValues, Option<Self>)> {
        let (frame, ends, (lb, le)) = Self::build(segment, x, Some(n))?;
        let (l_begin, l_end) = (lb as f32, le as f32);
        let whole = (l_begin.is_finite() && l_end.is_finite()).then(|| {
            let (ends, s_end) = EndValues::with_s_end(l_begin, l_end, frame.d);
            Self {
                l_begin,
                l_end,
                s_begin: clamp_s(ends.s_b),
                s_end: clamp_s(s_end),
                ..frame
            }
        });
        Some((frame, ends, whole.and_then(Self::nonempty)))
    }

    /// The scalar constructors: the computation of [`Self::lane`] with early returns. Not a
    /// call of `lane` (whose results it must equal bit for bit, as `crate::batch` tests): without
    /// the branches the compiler pairs the square roots of |a|² and d² into one packed
    /// instruction, so that u and l wait for d (the frame then takes about 3× as long). Also
    /// returns the unclipped interval [σ, σ + ℓ] in f64.
    #[inline(always)]
    fn build(
        segment: &Segment,
        x: Vec3,
        horizon: Option<Vec3>,
    ) -> Option<(Self, EndValues, (f64, f64))> {
        let b = segment.begin.as_dvec3() - x.as_dvec3();
        let e = segment.end.as_dvec3() - x.as_dvec3();
        // Fraction along the segment where it crosses the horizon, for the end to move. Decided
        // first: the (data-dependent, often mispredicted) branch then resolves before the
        // frame's dependency chain of square roots and divisions, not after it.
        let mut cut = None;
        if let Some(n) = horizon {
            let n = n.as_dvec3();
            let (hb, he) = (n.dot(b), n.dot(e));
            if !(hb > 0.0 || he > 0.0) {
                return None; // entirely below or within the plane (zero projected solid angle)
            }
            if hb < 0.0 {
                cut = Some((true, hb / (hb - he)));
            } else if he < 0.0 {
                cut = Some((false, hb / (hb - he)));
            }
        }
        let axis = e - b;
        let length2 = axis.length_squared();
        if !(length2 > 0.0 && length2 < f64::INFINITY) {
            return None;
        }
        let k = axis.dot(b) / length2;
        let c = b - k * axis;
        let d2 = c.length_squared();
        let scale2 = length2.max(b.length_squared()).max(e.length_squared());
        let min_rel = MIN_RELATIVE_DISTANCE as f64;
        if d2.is_nan() || d2 <= min_rel * min_rel * scale2 {
            return None;
        }
        let length = length2.sqrt();
        let sigma = k * length;
        let (mut lb, mut le) = (sigma, sigma + length);
        match cut {
            Some((true, t)) => lb = (sigma + t * length).max(lb),
            Some((false, t)) => le = (sigma + t * length).min(le),
            None => {}
        }
        let d = d2.sqrt();
        // 1/ℓ and 1/d from one division.
        let inv = 1.0 / (length * d);
        let u = axis * (d * inv);
        let c_hat = (c * (length * inv)).as_vec3();
        let (d, l_begin, l_end) = (d as f32, lb as f32, le as f32);
        if !(d > 0.0 && l_begin.is_finite() && l_end.is_finite()) {
            return None;
        }
        let (ends, s_end) = EndValues::with_s_end(l_begin, l_end, d);
        let frame = Self {
            u: u.as_vec3(),
            c_hat,
            d,
            l_begin,
            l_end,
            s_begin: clamp_s(ends.s_b),
            s_end: clamp_s(s_end),
        };
        frame
            .nonempty()
            .map(|frame| (frame, ends, (sigma, sigma + length)))
    }

    /// The frame as [`Self::new`] / [`Self::clipped`] compute it, without branches (every value
    /// computed, `valid` = whether the constructor returns `Some`): the one implementation of
    /// both the scalar constructors and the lanes of [`crate::batch`].
    #[inline(always)]
    pub(crate) fn lane(
        begin: Vec3,
        end: Vec3,
        x: Vec3,
        horizon: Option<Vec3>,
    ) -> (Self, EndValues, bool) {
        let b = begin.as_dvec3() - x.as_dvec3();
        let e = end.as_dvec3() - x.as_dvec3();
        let axis = e - b;
        let length2 = axis.length_squared();
        // Non-finite b or e makes the axis inf or NaN, so this also rejects non-finite input.
        let mut valid = length2 > 0.0 && length2 < f64::INFINITY;
        // c = b − (a·b/|a|²)a with a the axis: the two dot products run in parallel and only
        // one division precedes c (not the square root and reciprocal that normalise u).
        let k = axis.dot(b) / length2;
        let c = b - k * axis;
        let d2 = c.length_squared();
        // d > MIN_RELATIVE_DISTANCE · max(ℓ, |b|, |e|), compared in squares (no square roots
        // for a degeneracy test).
        let scale2 = length2.max(b.length_squared()).max(e.length_squared());
        let min_rel = MIN_RELATIVE_DISTANCE as f64;
        valid &= d2 > min_rel * min_rel * scale2;
        let length = length2.sqrt();
        let sigma = k * length;
        let (mut lb, mut le) = (sigma, sigma + length);
        if let Some(n) = horizon {
            // Clip to n·p ≥ 0: the plane cuts the segment at the fraction hb/(hb − he) from the
            // begin when exactly one end is below (like-signed terms in hb − he).
            let n = n.as_dvec3();
            let (hb, he) = (n.dot(b), n.dot(e));
            valid &= hb > 0.0 || he > 0.0; // else entirely below or within the plane
            let cut = sigma + hb / (hb - he) * length;
            lb = if hb < 0.0 { cut.max(lb) } else { lb };
            le = if hb >= 0.0 && he < 0.0 {
                cut.min(le)
            } else {
                le
            };
        }
        let d = d2.sqrt();
        // 1/ℓ and 1/d from one division.
        let inv = 1.0 / (length * d);
        let u = axis * (d * inv);
        let c_hat = (c * (length * inv)).as_vec3();
        let (d, l_begin, l_end) = (d as f32, lb as f32, le as f32);
        // Rounded to f32, d may underflow to 0 and l overflow to ±inf.
        valid &= d > 0.0 && l_begin.is_finite() && l_end.is_finite();
        let (ends, s_end) = EndValues::with_s_end(l_begin, l_end, d);
        let frame = Self {
            u: u.as_vec3(),
            c_hat,
            d,
            l_begin,
            l_end,
            s_begin: clamp_s(ends.s_b),
            s_end: clamp_s(s_end),
        };
        valid &= frame.l_end > frame.l_begin && frame.s_end > frame.s_begin;
        (frame, ends, valid)
    }

    /// `Some(self)` iff the interval is non-degenerate in both l and s. A segment so far away
    /// along its own axis that s_begin == s_end in f32 subtends no representable solid angle.
    fn nonempty(self) -> Option<Self> {
        (self.l_end > self.l_begin && self.s_end > self.s_begin).then_some(self)
    }

    /// The same line restricted to `[l_begin, l_end]` (must lie within this frame's line).
    pub fn with_interval(&self, l_begin: f32, l_end: f32) -> Option<Self> {
        if !(l_begin.is_finite() && l_end.is_finite()) {
            return None;
        }
        Self {
            l_begin,
            l_end,
            s_begin: s_of_l(l_begin, self.d),
            s_end: s_of_l(l_end, self.d),
            ..*self
        }
        .nonempty()
    }

    /// Clip the interval to the upper hemisphere of the unit normal `n` (n·ω ≥ 0).
    /// `None` if nothing of positive length remains.
    pub fn clip_to_horizon(&self, n: Vec3) -> Option<Self> {
        // n·p(l) = n·c + l (n·u) is affine in l; h(l) ≥ 0 is a half-line (or all / nothing).
        let nc = self.d * n.dot(self.c_hat);
        let nu = n.dot(self.u);
        let (mut lb, mut le) = (self.l_begin, self.l_end);
        let hb = nc + lb * nu;
        let he = nc + le * nu;
        if !(hb > 0.0 || he > 0.0) {
            return None; // entirely below or within the plane (zero projected solid angle)
        }
        if hb >= 0.0 && he >= 0.0 {
            return Some(*self);
        }
        // Exactly one endpoint below: the root lies strictly inside, nu ≠ 0. Only the moved
        // end's s is recomputed.
        let root = -nc / nu;
        let mut clipped = *self;
        if hb < 0.0 {
            lb = root.max(lb);
            clipped.l_begin = lb;
            clipped.s_begin = s_of_l(lb, self.d);
        } else {
            le = root.min(le);
            clipped.l_end = le;
            clipped.s_end = s_of_l(le, self.d);
        }
        // Test "length > 0" (not "≤ 0") so that a NaN root yields None.
        if le - lb > 0.0 {
            clipped.nonempty()
        } else {
            None
        }
    }

    /// Point on the line at parameter l, relative to the shading point.
    #[inline]
    pub fn point(&self, l: f32) -> Vec3 {
        self.d * self.c_hat + l * self.u
    }

    /// Unit direction toward the line point at parameter l (overflow-safe, unlike
    /// `point(l).normalize()`). Without a branch (both ways computed, one selected): the same
    /// code for one sample and for the lanes of [`crate::batch`].
    #[inline(always)]
    pub fn direction_to(&self, l: f32) -> Vec3 {
        let p = self.point(l);
        let len2 = p.length_squared();
        let direct = p / len2.sqrt();
        // Outside ~[1e-19, 1e19] the squares leave the normal range (or d ĉ + l u overflows):
        // scale by max(d, |l|) first.
        let m = self.d.max(l.abs());
        let q = (self.d / m) * self.c_hat + (l / m) * self.u;
        let scaled = q / q.length();
        if len2 > 1e-30 && len2 <= f32::MAX {
            direct
        } else {
            scaled
        }
    }

    /// Unit direction with u·ω = s.
    #[inline]
    pub fn direction(&self, s: f32) -> Vec3 {
        let s = s.clamp(-1.0, 1.0);
        let t = (1.0 - s * s).max(0.0).sqrt();
        s * self.u + t * self.c_hat
    }

    /// s = u·ω of a direction (clamped to [−1, 1]).
    #[inline]
    pub fn s_of(&self, dir: Vec3) -> f32 {
        self.u.dot(dir).clamp(-1.0, 1.0)
    }

    /// s of the line point at parameter l.
    #[inline]
    pub fn s_at(&self, l: f32) -> f32 {
        s_of_l(l, self.d)
    }

    /// Parameter l of the line point seen in direction with u·ω = s (|s| < 1).
    #[inline]
    pub fn l_of_s(&self, s: f32) -> f32 {
        let t = (1.0 - s * s).max(0.0).sqrt();
        self.d * s / t
    }

    /// Whether s lies in this frame's interval (inclusive), up to the rounding of
    /// `s_of(direction(s))` ([`S_ROUNDING`]): a sample drawn at the end of the interval must not
    /// get density 0 from `pdf`.
    #[inline]
    pub fn contains_s(&self, s: f32) -> bool {
        s >= self.s_begin - S_ROUNDING && s <= self.s_end + S_ROUNDING
    }

    /// n_s = n·u and n_t = n·ĉ, so that n·ω = n_s s + n_t t.
    #[inline]
    pub fn normal_coefficients(&self, n: Vec3) -> (f32, f32) {
        (n.dot(self.u), n.dot(self.c_hat))
    }

    /// Ω_R = (2/d)(s(l_end) − s(l_begin)), solid angle per radius of the interval.
    ///
    /// Evaluated in f64 from the l-interval, not from the stored f32 `s_end − s_begin`: near
    /// |s| → 1 each stored s is rounded by up to ε/4 absolute, which is a relative error of
    /// ~1e-4 in Δs for an interval of width 1e-4 there (parallel to the view, far along the
    /// axis); the interval the density must integrate to 1 over is the segment's, [l_b, l_e].
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        let (sb, _) = sin_cos_at(self.l_begin, self.d);
        let (se, _) = sin_cos_at(self.l_end, self.d);
        (2.0 / self.d as f64 * (se - sb)) as f32
    }

    /// Ω⊥_R = (1/d)[C(φ_end) − C(φ_begin)], projected solid angle per radius of the interval,
    /// with C(φ) = n_s sin²φ + n_t (sin φ cos φ + φ) evaluated in f64 from l (see
    /// [`Self::solid_angle`] for why not from the stored f32 s). Meaningful (non-negative) for a
    /// frame clipped to the horizon of `n`.
    #[inline]
    pub fn projected_solid_angle(&self, n: Vec3) -> f32 {
        let (ns, nt) = (
            n.as_dvec3().dot(self.u.as_dvec3()),
            n.as_dvec3().dot(self.c_hat.as_dvec3()),
        );
        let (d, c) = (self.d as f64, |l: f32| l as f64);
        let total = antiderivative_at(ns, nt, c(self.l_end), d)
            - antiderivative_at(ns, nt, c(self.l_begin), d);
        (total / d) as f32
    }
}

/// f64 values at the ends of a frame's interval: (sin φ_b, cos φ_b) and sin φ_e − sin φ_b
/// ([`sin_cos_pair`]). The frame's constructors compute them on the way to `s_begin` and
/// `s_end` and hand them to the samplers that need them unrounded (computed once, not
/// recomputed from the rounded frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EndValues {
    pub s_b: f64,
    pub c_b: f64,
    pub delta_s: f64,
}

impl EndValues {
    /// The values of `frame`'s interval (what its constructor computed).
    #[inline(always)]
    pub fn of(frame: &LineFrame) -> Self {
        Self::with_s_end(frame.l_begin, frame.l_end, frame.d).0
    }

    #[inline(always)]
    fn with_s_end(lb: f32, le: f32, d: f32) -> (Self, f64) {
        let ((s_b, c_b), (s_e, _), delta_s) = sin_cos_pair(lb, le, d);
        (Self { s_b, c_b, delta_s }, s_e)
    }
}

/// The directions toward a frame's interval as an arc φ ∈ [φ_b, φ_b + Δ] in the plane of
/// (u, ĉ), φ = atan2(l, d). For support tests, densities and samples that must stay accurate
/// where s = u·ω does not: near |s| → 1 (line seen almost along its axis) consecutive f32 s are
/// ε/2 apart, more than a short interval's whole width, and for ℓ/d ≳ 3000 the frame's s_end
/// rounds to 1 so that "s ≤ s_end" admits the entire rest of the infinite line. The offset
/// τ = φ − φ_b of an f32 direction, by contrast, is known to ~ε absolute.
///
/// Scalar arithmetic in f64 (a handful of operations per call): with (sin φ_b, cos φ_b) rounded
/// to f32 the pair is off the unit circle and its angle off φ_b by up to ~ε/2, a constant shift
/// of τ that is 2e-5 of a 3e-3-rad interval and moved a steep density's normalisation by 1.4e-5.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameArc {
    /// sin φ_b, cos φ_b.
    pub s_b: f64,
    pub c_b: f64,
    /// Δ = φ_e − φ_b > 0.
    pub width: f64,
    /// sin φ_e − sin φ_b = 2 cos(φ_b + Δ/2) sin(Δ/2), without cancellation.
    pub delta_s: f64,
    /// Rounding tolerance of the support test in τ (radians).
    pub tolerance: f64,
}

impl FrameArc {
    pub fn of(frame: &LineFrame) -> Self {
        Self::on_ends(frame, EndValues::of(frame), atan2_f64)
    }

    /// [`Self::of`] from the [`EndValues`] the frame's constructor computed (not recomputed),
    /// with a given atan2 (branch-free in the lanes of [`crate::batch`]; bitwise equal): the one
    /// implementation of the scalar path and the lanes. No branch: Δ ∈ (0, π] for a valid
    /// frame, so Δ/2 is in the range of [`sin_cos_poly`].
    #[inline(always)]
    pub(crate) fn on_ends(
        frame: &LineFrame,
        ends: EndValues,
        atan2: impl Fn(f64, f64) -> f64,
    ) -> Self {
        let (lb, le, d) = (frame.l_begin as f64, frame.l_end as f64, frame.d as f64);
        let EndValues { s_b, c_b, .. } = ends;
        // tan(φ_e − φ_b) = (l_e − l_b)d / (d² + l_b l_e), free of the cancellation of φ_e − φ_b.
        let width = atan2((le - lb) * d, d * d + lb * le);
        let (sh, ch) = sin_cos_poly(0.5 * width);
        let delta_s = 2.0 * (c_b * ch - s_b * sh) * sh;
        Self {
            s_b,
            c_b,
            width,
            delta_s,
            tolerance: arc_tolerance(width),
        }
    }

    /// τ = φ − φ_b of a direction toward the line, if it points into the arc (up to rounding);
    /// clamped to [0, Δ].
    #[inline]
    pub fn tau_in_support(&self, frame: &LineFrame, dir: Vec3) -> Option<f64> {
        tau_in_arc(frame, (self.s_b, self.c_b, self.width), self.tolerance, dir)
            .map(|tau| tau.clamp(0.0, self.width))
    }

    /// Whether a direction toward the line points into the arc (up to rounding).
    #[inline]
    pub fn contains(&self, frame: &LineFrame, dir: Vec3) -> bool {
        self.tau_in_support(frame, dir).is_some()
    }

    /// sin(φ_b + τ) − sin φ_b = c_b sin τ − 2 s_b sin²(τ/2), without cancellation.
    #[inline]
    pub fn delta_s_at(&self, tau: f64) -> f64 {
        let (sh, ch) = sin_cos_f64(0.5 * tau);
        2.0 * sh * (self.c_b * ch - self.s_b * sh)
    }

    /// τ ∈ [0, Δ] with sin(φ_b + τ) − sin φ_b = y, y ∈ [0, Δs], without forming s_b + y and
    /// asin: with q = y(2s_b + y), c = √(c_b² − q) = cos(φ_b + τ),
    /// sin τ = y c_b + s_b q/(c_b + c), cos τ = c c_b + (s_b + y) s_b.
    #[inline]
    pub fn tau_of_delta_s(&self, y: f64) -> f64 {
        self.tau_of_delta_s_with(y, atan2_f64)
    }

    /// [`Self::tau_of_delta_s`] with a given atan2, without branches (the ends y ≤ 0, y ≥ Δs and
    /// NaN are selected after the formula, which is then evaluated in vain): the one
    /// implementation of the scalar path and the lanes of [`crate::batch`].
    #[inline(always)]
    pub(crate) fn tau_of_delta_s_with(&self, y: f64, atan2: impl Fn(f64, f64) -> f64) -> f64 {
        let q = y * (2.0 * self.s_b + y);
        let c = (self.c_b * self.c_b - q).max(0.0).sqrt();
        let denom = self.c_b + c;
        let cos_tau = c * self.c_b + (self.s_b + y) * self.s_b;
        // atan2 is invariant under a common positive factor: (sin τ, cos τ)·denom saves the
        // division by denom.
        let (sin_tau, cos_tau) = if denom > 0.0 {
            (y * self.c_b * denom + self.s_b * q, cos_tau * denom)
        } else {
            (y, cos_tau)
        };
        // max/min rather than clamp: no assertion (a branch) in the lanes of a batch, whose
        // invalid lanes may hold a NaN Δ.
        let tau = atan2(sin_tau, cos_tau).max(0.0).min(self.width);
        let tau = if y >= self.delta_s { self.width } else { tau };
        if y.is_nan() || y <= 0.0 {
            0.0
        } else {
            tau
        }
    }

    /// Unit direction at offset τ (clamped to [0, Δ]); (sin, cos) τ from the half angle, which
    /// is in the range of the polynomial [`sin_cos_poly`] (no branch: the lanes of
    /// [`crate::batch`] call it too).
    #[inline(always)]
    pub fn direction(&self, frame: &LineFrame, tau: f64) -> Vec3 {
        let (sh, ch) = sin_cos_poly(0.5 * tau.max(0.0).min(self.width));
        let (st, ct) = (2.0 * sh * ch, 1.0 - 2.0 * sh * sh);
        let s = self.s_b * ct + self.c_b * st;
        let t = (self.c_b * ct - self.s_b * st).max(0.0);
        (s * frame.u.as_dvec3() + t * frame.c_hat.as_dvec3()).as_vec3()
    }
}

/// Rounding tolerance (radians) of a support test in τ for an arc of width Δ: an f32 direction's
/// φ is rounded by ~ε, τ of the interval's own ends by ~ε·Δ. Shared by every technique.
#[inline]
pub fn arc_tolerance(width: f64) -> f64 {
    2.5e-7 + 1e-6 * width
}

/// The support test of every technique: τ = φ − φ_b of a direction toward the line relative to
/// the arc `(sin φ_b, cos φ_b, Δ)` in the plane of (u, ĉ), if it lies in [−tol, Δ + tol] (not
/// clamped). In f64 from the f32 direction (exact products, one rounding per sum), with the
/// libm-free [`atan2_f64`].
#[inline]
pub fn tau_in_arc(
    frame: &LineFrame,
    (s_b, c_b, width): (f64, f64, f64),
    tolerance: f64,
    dir: Vec3,
) -> Option<f64> {
    let w = dir.as_dvec3();
    let (s, t) = (frame.u.as_dvec3().dot(w), frame.c_hat.as_dvec3().dot(w));
    let tau = atan2_f64(s * c_b - t * s_b, t * c_b + s * s_b);
    (t >= 0.0 && tau >= -tolerance && tau <= width + tolerance).then_some(tau)
}

/// (sin φ, cos φ) = (l, d)/√(l² + d²) of the line point at parameter l, in f64 (squares of f32
/// values neither overflow nor underflow there).
/// One division (a reciprocal) for both.
#[inline(always)]
pub fn sin_cos_at(l: f32, d: f32) -> (f64, f64) {
    let (l, d) = (l as f64, d as f64);
    let inv_r = 1.0 / (l * l + d * d).sqrt();
    (l * inv_r, d * inv_r)
}

/// (sin φ, cos φ) of both ends of an l-interval ([`sin_cos_at`] of each) and
/// sin φ_e − sin φ_b without cancellation, in f64 with one division for all: where the ends lie
/// on the same side of l = 0, Δs = (s_e² − s_b²)/(s_e + s_b) = d²(l_e − l_b)(l_e + l_b) /
/// (r_b r_e (l_e r_b + l_b r_e)) (like-signed terms in the last factor), else Δs = s_e − s_b is
/// a difference of opposite-signed sines. Products of a few f32-range values stay in the f64
/// range.
#[inline(always)]
pub fn sin_cos_pair(lb: f32, le: f32, d: f32) -> ((f64, f64), (f64, f64), f64) {
    let (lb, le, d) = (lb as f64, le as f64, d as f64);
    let (rb, re) = ((lb * lb + d * d).sqrt(), (le * le + d * d).sqrt());
    let same_side = lb * le > 0.0;
    // (A select the compiler keeps before the division: otherwise it splits the one division
    // into one per arm in the branch-free lanes of `crate::batch`.)
    let f = std::hint::select_unpredictable(same_side, le * rb + lb * re, 1.0);
    let zf = 1.0 / (rb * re * f);
    // 1/r_b = r_e f·zf, 1/r_e = r_b f·zf: the numerators formed beside the division, so that
    // each value is one multiplication after it (they start the samplers' dependency chains).
    let (ref_, rbf) = (re * f, rb * f);
    let (s_b, c_b) = (lb * ref_ * zf, d * ref_ * zf);
    let (s_e, c_e) = (le * rbf * zf, d * rbf * zf);
    let delta_s = if same_side {
        d * d * (le - lb) * (le + lb) * zf
    } else {
        s_e - s_b
    };
    ((s_b, c_b), (s_e, c_e), delta_s)
}

#[inline(always)]
fn clamp_s(s: f64) -> f32 {
    (s as f32).clamp(-1.0, 1.0)
}

/// The antiderivative of the projected solid angle along a line, the one implementation of the
/// crate: C(φ) = n_s sin²φ + n_t (sin φ cos φ + φ) at φ = atan2(l, d), so that
/// ∫ (n·ω) dΩ_R = (1/d)\[C\] between two line parameters (n_s = n·u, n_t = n·ĉ). In f64 with
/// std's atan2, for references and preparation (the sampler's hot path evaluates differences of
/// C without cancellation instead: `projected_solid_angle::PsaCore`). A difference of two C
/// values cancels for short or distant intervals; that is the caller's concern.
#[inline]
pub fn antiderivative_at(ns: f64, nt: f64, l: f64, d: f64) -> f64 {
    let inv_r = 1.0 / (l * l + d * d).sqrt();
    let (s, t) = (l * inv_r, d * inv_r);
    ns * s * s + nt * (s * t + l.atan2(d))
}

/// C in terms of s = sin φ: n_s s² + n_t (s√(1−s²) + asin s) ([`antiderivative_at`] at
/// (l, d) = (s, √(1 − s²))), rounded to f32.
#[inline]
pub fn projected_antiderivative(ns: f32, nt: f32, s: f32) -> f32 {
    let s = s.clamp(-1.0, 1.0) as f64;
    let t = (1.0 - s * s).max(0.0).sqrt();
    antiderivative_at(ns as f64, nt as f64, s, t) as f32
}

/// |v| without underflow or overflow of the squares, which leave the normal f32 range for |v|
/// outside ~[1e-19, 1e19] (glam's `length` then loses all precision or returns inf/0).
#[inline]
pub fn stable_length(v: Vec3) -> f32 {
    let m = v.abs().max_element();
    if m > 0.0 && m.is_finite() {
        m * (v / m).length()
    } else {
        v.length()
    }
}

/// [`unit_normal`] without a branch: the normalised normal (meaningless when invalid) and
/// whether it is valid.
#[inline(always)]
pub(crate) fn unit_normal_lane(n: Vec3) -> (Vec3, bool) {
    let len = n.as_dvec3().length_squared().sqrt();
    ((n.as_dvec3() * (1.0 / len)).as_vec3(), normal_is_valid(n))
}

/// Whether `n` is accepted as a normal ([`unit_normal`]'s policy): finite, with a length in
/// (1e-20, ∞), compared in squares (in f64, where the squares of f32 components neither
/// overflow nor underflow): no square root for the test.
#[inline(always)]
pub(crate) fn normal_is_valid(n: Vec3) -> bool {
    let len2 = n.as_dvec3().length_squared();
    len2 > 1e-40 && len2 < f64::INFINITY
}

/// n·2^k with the integer k that puts the largest |component| into [1, 2): a normal of the
/// same direction and a length in [1, 2√3), without rounding (a power-of-two scaling is exact)
/// except for components below 2⁻¹²⁶ of the largest, which become f32 subnormals (rounded; below
/// 2⁻¹⁵⁰ of it, zero), and without the square root and division of [`unit_normal`]. For the
/// samplers whose arithmetic is homogeneous in n (projected solid angle: its density (n·ω)/Ω⊥ and its
/// inversion are of degree 0 in n). Meaningless (but no panic) where `n` is not
/// [`normal_is_valid`].
#[inline(always)]
pub(crate) fn power_of_two_scaled(n: Vec3) -> Vec3 {
    let n = n.as_dvec3();
    // m = 2^e·f with f ∈ [1, 2) and biased exponent E = e + 1023; 2^(−e) has the biased
    // exponent 2046 − E (a normal f64 for every f32 m; wrapping for inf/NaN, which are invalid).
    let m = n.abs().max_element();
    let scale = f64::from_bits(2046u64.wrapping_sub(m.to_bits() >> 52) << 52);
    (n * scale).as_vec3()
}

/// Normalise a user-supplied normal. Policy of this crate: normals are *normalised*; a zero,
/// denormal-length or non-finite normal is rejected (`None`; `normal_is_valid`), which makes
/// the light contribute nothing at that shading point. (Projected solid angle and Li et al.,
/// whose arithmetic is homogeneous in n, scale it by a power of two instead,
/// `power_of_two_scaled`: the same direction without a rounding.)
///
/// In f64, where the squares of f32 components neither overflow nor underflow: one square root
/// and one division, no rescaling pass.
#[inline]
pub fn unit_normal(n: Vec3) -> Option<Vec3> {
    let (n, valid) = unit_normal_lane(n);
    valid.then_some(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest |component| lands in [1, 2) for every f32 exponent, subnormals included, by
    /// an exact power of two (direction and ratios kept bit for bit); no panic on 0, inf, NaN.
    #[test]
    fn power_of_two_scaled_puts_the_largest_component_into_one_two() {
        for e in -149..=127 {
            for (i, m) in [1.0f32, 1.5, 1.999_999_9, 1.234_567]
                .into_iter()
                .enumerate()
            {
                let big = (m as f64 * 2f64.powi(e)) as f32;
                if big == 0.0 || !big.is_finite() {
                    continue;
                }
                let n = [
                    Vec3::new(big, -0.25 * big, 0.5 * big),
                    Vec3::new(0.0, -big, 0.0),
                    Vec3::new(0.75 * big, 0.0, -big),
                ][i % 3];
                let s = power_of_two_scaled(n);
                let largest = s.abs().max_element();
                assert!((1.0..2.0).contains(&largest), "2^{e}·{m}: {n} -> {s}");
                // Exact where the scaled components stay normal (every input ratio here does).
                let k = (largest as f64 / big.abs() as f64).log2();
                assert_eq!(k, k.round(), "2^{e}·{m}: factor 2^{k}");
                assert_eq!(
                    s.as_dvec3() / s.abs().max_element() as f64,
                    n.as_dvec3() / big.abs() as f64
                );
            }
        }
        for n in [
            Vec3::ZERO,
            Vec3::splat(f32::INFINITY),
            Vec3::new(f32::NAN, 1.0, 0.0),
        ] {
            let _ = power_of_two_scaled(n);
        }
    }

    /// The accepted normals: length in (1e-20, ∞), compared in squares in f64.
    #[test]
    fn normal_is_valid_boundaries() {
        assert!(normal_is_valid(Vec3::Z));
        assert!(normal_is_valid(Vec3::new(0.0, 1.01e-20, 0.0)));
        assert!(!normal_is_valid(Vec3::new(0.0, 0.99e-20, 0.0)));
        assert!(!normal_is_valid(Vec3::new(0.7e-20, 0.0, 0.7e-20)));
        assert!(normal_is_valid(Vec3::new(0.72e-20, 0.0, 0.72e-20)));
        assert!(normal_is_valid(Vec3::splat(f32::MAX)));
        assert!(normal_is_valid(Vec3::new(f32::from_bits(1), 0.0, 1e-19)));
        assert!(!normal_is_valid(Vec3::ZERO));
        assert!(!normal_is_valid(Vec3::new(1.0, f32::INFINITY, 0.0)));
        assert!(!normal_is_valid(Vec3::new(0.0, 0.0, f32::NEG_INFINITY)));
        assert!(!normal_is_valid(Vec3::new(f32::NAN, 1.0, 0.0)));
        assert!(!normal_is_valid(Vec3::new(1.0, 1.0, f32::NAN)));
    }

    fn sanity_frame() -> LineFrame {
        let seg = Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        LineFrame::new(&seg, Vec3::ZERO).unwrap()
    }

    #[test]
    fn sanity_values_of_the_paper() {
        let f = sanity_frame();
        assert!((f.solid_angle() - 2.0 * 2f32.sqrt()).abs() < 1e-6);
        let psa = f.projected_solid_angle(Vec3::Z);
        assert!(
            (psa - (1.0 + std::f32::consts::FRAC_PI_2)).abs() < 1e-6,
            "{psa}"
        );
    }

    #[test]
    fn direction_points_at_the_line() {
        let f = sanity_frame();
        for &s in &[-0.7f32, -0.2, 0.0, 0.3, 0.7] {
            let w = f.direction(s);
            let p = f.point(f.l_of_s(s));
            assert!((w - p.normalize()).length() < 1e-6);
        }
    }

    #[test]
    fn horizon_clipping() {
        // Line from below to above the plane z = 0.
        let seg = Segment::new(Vec3::new(1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0));
        let f = LineFrame::new(&seg, Vec3::ZERO).unwrap();
        let c = f.clip_to_horizon(Vec3::Z).unwrap();
        assert!((c.point(c.l_begin) - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6);
        assert_eq!(c.l_end, f.l_end);
        // Entirely below.
        assert!(f
            .clip_to_horizon(Vec3::new(0.0, 0.0, 1.0).normalize() * 1.0)
            .is_some());
        let below = Segment::new(Vec3::new(1.0, 0.0, -2.0), Vec3::new(1.0, 0.0, -1.0));
        let fb = LineFrame::new(&below, Vec3::ZERO).unwrap();
        assert!(fb.clip_to_horizon(Vec3::Z).is_none());
        // Parallel to the plane and below it: the root is ±inf/NaN, must give None.
        let par = Segment::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0));
        let fp = LineFrame::new(&par, Vec3::ZERO).unwrap();
        assert!(fp.clip_to_horizon(Vec3::Z).is_none());
        // Lying in the plane: zero projected solid angle, nothing to sample.
        let inplane = Segment::new(Vec3::new(-1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
        let fi = LineFrame::new(&inplane, Vec3::ZERO).unwrap();
        assert!(fi.clip_to_horizon(Vec3::Z).is_none());
    }

    /// The whole frame from the clipped frame's construction is `LineFrame::new` bit for bit,
    /// and the clipped one `LineFrame::clipped`, over random segments crossing the horizon or
    /// not and far, near and oblique shading points.
    #[test]
    fn clipped_and_whole_equal_their_constructors() {
        let mut rng = crate::rng::Pcg32::new(5, 11);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut both = 0;
        for _ in 0..20_000 {
            let scale = 10f32.powf(r(-3.0, 3.0));
            let seg = Segment::new(
                Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)) * scale,
                Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)) * scale,
            );
            let x = Vec3::new(r(-0.1, 0.1), r(-0.1, 0.1), r(-0.1, 0.1));
            let n = Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(0.1, 1.0)) * r(0.5, 2.0);
            let clipped = LineFrame::clipped(&seg, x, n);
            match LineFrame::clipped_and_whole(&seg, x, n) {
                Some((frame, ends, whole)) => {
                    assert_eq!(Some(frame), clipped);
                    assert_eq!(ends, EndValues::of(&frame));
                    assert_eq!(whole, LineFrame::new(&seg, x));
                    both += whole.is_some() as u32;
                }
                None => assert_eq!(clipped, None),
            }
        }
        assert!(both > 10_000, "{both}");
    }

    #[test]
    fn degenerate_inputs() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert!(LineFrame::new(&Segment::new(p, p), Vec3::ZERO).is_none());
        // Shading point on the infinite line.
        let seg = Segment::new(Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
        assert!(LineFrame::new(&seg, Vec3::ZERO).is_none());
        assert!(LineFrame::new(&Segment::new(Vec3::NAN, p), Vec3::ZERO).is_none());
        assert!(LineFrame::new(&Segment::new(Vec3::INFINITY, p), Vec3::ZERO).is_none());
        assert!(unit_normal(Vec3::ZERO).is_none());
        assert!(unit_normal(Vec3::new(f32::NAN, 0.0, 1.0)).is_none());
        assert_eq!(unit_normal(Vec3::new(0.0, 0.0, 3.0)), Some(Vec3::Z));
    }

    /// Segment seen almost along its axis: s ∈ [0.99980, 0.999994] (f32 s rounded by up to
    /// ε/4, 1.5e-4 of Δs); the frame's measures and arc must be those of the segment.
    #[test]
    fn measures_and_arc_near_the_axis_are_exact() {
        let seg = Segment::new(Vec3::new(0.01, 0.0, 0.5), Vec3::new(0.01, 0.0, 3.0));
        let f = LineFrame::new(&seg, Vec3::ZERO).unwrap();
        let (d, lb, le) = (f.d as f64, f.l_begin as f64, f.l_end as f64);
        let s = |l: f64| l / l.hypot(d);
        let omega = 2.0 / d * (s(le) - s(lb));
        assert!(((f.solid_angle() as f64) - omega).abs() < 1e-6 * omega);
        // n = z = u: Ω⊥_R = (1/d)(s_e² − s_b²).
        let psa = (s(le).powi(2) - s(lb).powi(2)) / d;
        let got = f.projected_solid_angle(Vec3::Z) as f64;
        assert!((got - psa).abs() < 1e-6 * psa, "{got} vs {psa}");
        let arc = FrameArc::of(&f);
        let width = le.atan2(d) - lb.atan2(d);
        assert!((arc.width - width).abs() < 1e-12);
        assert!((arc.delta_s - (s(le) - s(lb))).abs() < 1e-12);
        for i in 0..=100 {
            let tau = width * i as f64 / 100.0;
            let y = arc.delta_s_at(tau);
            assert!((arc.tau_of_delta_s(y) - tau).abs() < 1e-10, "{tau}");
            let dir = arc.direction(&f, tau);
            let back = arc.tau_in_support(&f, dir).expect("in support");
            assert!((back - tau).abs() < 2e-7, "{tau}: {back}");
        }
        // Beyond either end by 1e-5 rad: outside, although s_of differs there by < 4ε.
        let beyond = |phi: f64| phi.sin() * f.u.as_dvec3() + phi.cos() * f.c_hat.as_dvec3();
        assert!(!arc.contains(&f, beyond(le.atan2(d) + 1e-5).as_vec3()));
        assert!(!arc.contains(&f, beyond(lb.atan2(d) - 1e-5).as_vec3()));
        assert!(!arc.contains(&f, -f.c_hat));
    }

    #[test]
    fn projected_solid_angle_matches_quadrature() {
        let seg = Segment::new(Vec3::new(-0.3, 0.5, 0.4), Vec3::new(1.2, -0.2, 1.1));
        let n = Vec3::new(0.2, 0.1, 1.0).normalize();
        let f = LineFrame::new(&seg, Vec3::ZERO)
            .unwrap()
            .clip_to_horizon(n)
            .unwrap();
        // Midpoint rule in s on (n·ω)(2/d).
        let m = 200_000;
        let mut sum = 0.0f64;
        for i in 0..m {
            let s = f.s_begin as f64 + (i as f64 + 0.5) / m as f64 * (f.s_end - f.s_begin) as f64;
            let w = f.direction(s as f32);
            sum += (n.dot(w) as f64).max(0.0) * 2.0 / f.d as f64;
        }
        sum *= (f.s_end - f.s_begin) as f64 / m as f64;
        let psa = f.projected_solid_angle(n) as f64;
        assert!((sum - psa).abs() < 1e-4 * psa, "{sum} vs {psa}");
    }
}
