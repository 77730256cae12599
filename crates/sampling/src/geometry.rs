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

#[inline]
fn s_of_l(l: f32, d: f32) -> f32 {
    // l / √(l² + d²), robust for large |l| (hypot avoids overflow).
    (l / l.hypot(d)).clamp(-1.0, 1.0)
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
        let b = segment.begin.as_dvec3() - x.as_dvec3();
        let e = segment.end.as_dvec3() - x.as_dvec3();
        let axis = e - b;
        let length = axis.length();
        if !(length > 0.0 && length.is_finite() && b.is_finite() && e.is_finite()) {
            return None;
        }
        let u = axis / length;
        let sigma = u.dot(b);
        let c = b - sigma * u;
        let d = c.length();
        let scale = length.max(b.length()).max(e.length());
        if !(d.is_finite() && d > MIN_RELATIVE_DISTANCE as f64 * scale) {
            return None;
        }
        let c_hat = (c / d).as_vec3();
        let (d, l_begin, l_end) = (d as f32, sigma as f32, (sigma + length) as f32);
        // Rounded to f32, d may underflow to 0 and l overflow to ±inf.
        if !(d > 0.0 && l_begin.is_finite() && l_end.is_finite()) {
            return None;
        }
        let frame = Self {
            u: u.as_vec3(),
            c_hat,
            d,
            l_begin,
            l_end,
            s_begin: s_of_l(l_begin, d),
            s_end: s_of_l(l_end, d),
        };
        frame.nonempty()
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
        // Exactly one endpoint below: the root lies strictly inside, nu ≠ 0.
        let root = -nc / nu;
        if hb < 0.0 {
            lb = root.max(lb);
        } else {
            le = root.min(le);
        }
        // Test "length > 0" (not "≤ 0") so that a NaN root yields None.
        if le - lb > 0.0 {
            self.with_interval(lb, le)
        } else {
            None
        }
    }

    /// Point on the line at parameter l, relative to the shading point.
    #[inline]
    pub fn point(&self, l: f32) -> Vec3 {
        self.d * self.c_hat + l * self.u
    }

    /// Unit direction toward the line point at parameter l.
    #[inline]
    pub fn direction_to(&self, l: f32) -> Vec3 {
        let p = self.point(l);
        let len2 = p.length_squared();
        if len2 > 1e-30 && len2 <= f32::MAX {
            return p / len2.sqrt();
        }
        // Outside ~[1e-19, 1e19] the squares leave the normal range (or d ĉ + l u overflows):
        // scale by max(d, |l|) first.
        let m = self.d.max(l.abs());
        let p = (self.d / m) * self.c_hat + (l / m) * self.u;
        p / p.length()
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

    /// Ω_R = (2/d)(s_end − s_begin), solid angle per radius of the interval.
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        2.0 / self.d * (self.s_end - self.s_begin)
    }

    /// Ω⊥_R = (1/d)[C(s_end) − C(s_begin)], projected solid angle per radius of the interval.
    /// Meaningful (non-negative) for a frame clipped to the horizon of `n`.
    #[inline]
    pub fn projected_solid_angle(&self, n: Vec3) -> f32 {
        let (ns, nt) = self.normal_coefficients(n);
        (projected_antiderivative(ns, nt, self.s_end)
            - projected_antiderivative(ns, nt, self.s_begin))
            / self.d
    }
}

/// C(s) = n_s s² + n_t (s√(1−s²) + asin s), so that ∫ (n·ω) dΩ_R = (1/d)[C].
#[inline]
pub fn projected_antiderivative(ns: f32, nt: f32, s: f32) -> f32 {
    let s = s.clamp(-1.0, 1.0);
    let t = (1.0 - s * s).max(0.0).sqrt();
    ns * s * s + nt * (s * t + s.asin())
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

/// Normalise a user-supplied normal. Policy of this crate: normals are *normalised*; a zero,
/// denormal-length or non-finite normal is rejected (`None`), which makes the light contribute
/// nothing at that shading point.
#[inline]
pub fn unit_normal(n: Vec3) -> Option<Vec3> {
    let len = stable_length(n);
    (len > 1e-20 && len.is_finite()).then(|| n / len)
}

#[cfg(test)]
mod tests {
    use super::*;

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
