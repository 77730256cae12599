//! Peters 2021 projected-solid-angle sampling (technique 8): Halley iterations on G(φ).
//!
//! Density per radius: p_R(ω) = (n·ω)/Ω⊥_R on the horizon-clipped segment, 0 elsewhere.
//!
//! With φ = asin s (s = u·ω) the unnormalised CDF is C(φ) = n_s sin²φ + n_t(sinφ cosφ + φ) and
//! dC/dφ = 2 cosφ (n·ω) ≥ 0 on the clipped interval [φ_b, φ_e]. Sampling solves
//! G(φ) = C(φ) − C(φ_b) − ξ·[C(φ_e) − C(φ_b)] = 0, starting from the solid-angle sample for the
//! same ξ, with a fixed number of steps of Halley's irrational formula (the root of the quadratic
//! Taylor model closest to the current point), clamped to [φ_b, φ_e].
//!
//! Precision (documented decision): C itself is O(1) while C(φ_e) − C(φ_b) can be O(width²) or
//! smaller, so the textbook difference of two C values cancels catastrophically for short (or
//! distant) segments, and G(φ) = C(φ) − C* inherits the same absolute error. Every difference of
//! C is therefore evaluated directly as a difference, never as C(a) − C(b):
//!
//!   C(a) − C(b) = 2 cos m · sin δ · (n_s sin m + n_t cos m) + n_t (δ − sin δ),
//!   m = (a + b)/2, δ = a − b,
//!
//! (from sin²a − sin²b = sin(a+b) sin δ, ½(sin 2a − sin 2b) = cos(a+b) sin δ,
//! 1 + cos(a+b) = 2cos²m), with δ − sin δ from its Taylor series for |δ| < 1. Both terms are
//! products of accurately computed factors. The unknown is the offset τ = φ − φ_b ∈ [0, Δ], with
//! Δ from tan Δ = (l_e − l_b)d/(d² + l_b l_e) and cos φ_b = d/r_b, so that a short interval near
//! φ = ±π/2 (segment seen almost along its axis, where s = u·ω is quantised to a handful of f32
//! values) keeps full relative resolution; sin/cos of φ_b + τ come from angle addition. Finally
//! n·ω itself cancels near a horizon-clipped end (n_s s + n_t t ≈ 0 with O(1) terms), so it is
//! carried as n·ω(φ_b + τ) = p0 cos τ + p1 sin τ with p0 = n·ω_b and p1 = d(n·ω)/dφ at φ_b,
//! each rounded once from a wider product. With these, f32 arithmetic reaches the same two-
//! iteration backward error as f64 (see `linlight backward-error`); n·ω evaluated as
//! n_s s + n_t t would leave 1.5e-3 on 1e-4-rad intervals at the horizon.
//!
//! Accuracy (the measure: the backward error of a sample, |CDF(τ̂) − ξ| in units of ξ, with
//! CDF the exact per-radius CDF of p_R on the problem as the sampler represents it, evaluated in
//! f64; `linlight backward-error` sweeps normals, sub-intervals down to 1e-4 rad and ξ): with
//! [`DEFAULT_ITERATIONS`] = 2 the f32 sampler's worst case is 1.595e-5 outside the ξ guard and
//! 1.991e-5 including it (the start value returned for ξ within [`XI_GUARD`] of 0 or 1), within
//! the bound 2e-5 (the paper: 1.6e-5); one step leaves 1.548e-2, three 7.85e-7. One step from
//! a better start value is not used (docs/performance.md, "Why the scalar PSA sample stays
//! above 100 ns"):
//! where the density vanishes to second order at an end (n towards the line's closest point,
//! interval reaching φ = ±π/2) the inverse CDF behaves like a cube root, which no start value
//! of one square root and one division follows closely enough (best found: 1.3e-2 after one
//! step). The exact density (n·ω)/Ω⊥_R is what `pdf` reports; the samples follow it up to that
//! backward error.
//!
//! The inversion core is generic over f32/f64 (`Real`) so that the backward-error sweep
//! ([`crate::backward_error`]) can run both precisions through the same code; the sampler uses
//! f32.
//!
//! Cost (the f32 hot path; `cargo bench -p linlight-sampling --bench techniques`): a sample is a
//! chain of dependent evaluations — the frame (f64 square roots and divisions), (sin, cos) at
//! the interval's begin and Δs, the start value (two square roots, a division), two Halley steps
//! (sin/cos of τ/2, δ − sin δ, sqrt, division) and the direction — so its latency, not its
//! instruction count, sets the time. Hence: the f32 `atan2`/`sin_cos` of `Real` are short f64
//! polynomials without libm calls ([`crate::trig`]; a libm call also spills every live SSE
//! register); work that only the total needs (Δ's atan2, sin/cos(Δ/2)) and the start value's own
//! atan2 run beside the chain, not in it: Δs comes from the frame's end values
//! ([`crate::geometry::EndValues`]), and the first Halley step takes sin/cos(τ₀/2) from the
//! start value's bisector (`PsaCore::start_half_with`); the series of δ − sin δ is cut to the
//! f32 precision, evaluated by Estrin's scheme, and reuses sin τ = 2 sin(τ/2)cos(τ/2) above 1;
//! the last step rotates the values it started from instead of a further sin/cos (the lanes of
//! [`crate::batch`] evaluate that sin/cos only when some lane of the batch needs it, see
//! `PsaCore::solve_rotated_lane`); the pdf is (n·ω)/Ω⊥_R with n·ω from that rotation.
//! G = ΔC − ξ·total is summed as a + (b − ξ·total) with b = n_t(τ − sin τ) known before a
//! (`PsaCore::g_of`), the Halley step starts from 2·(sin φ, cos φ) and hands the next
//! evaluation τ/2, and the frame's end values are one multiplication after their division. The
//! f64 instantiation keeps std's functions and the full series.

use crate::geometry::{
    arc_tolerance, normal_is_valid, power_of_two_scaled, tau_in_arc, unit_normal_lane, EndValues,
    LineFrame, Segment,
};
use crate::sampler::{clamp_xi, LineSampler};
use crate::trig::atan2_f64;
use glam::{DVec3, Vec3};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Largest last Halley step |h| after which the values at the sample are rotated from those at
/// the step's start instead of evaluated afresh (see [`PsaCore::solve_with_values`]).
const ROTATION_STEP: f64 = 0.125;

/// Number of Halley steps of the paper.
pub const DEFAULT_ITERATIONS: u32 = 2;

/// Primary samples within this distance of 0 or 1 return the start value (the solid-angle
/// sample) without iterating (the paper's guard against G' → 0 at horizon-clipped endpoints).
pub const XI_GUARD: f64 = 1e-5;

/// Minimal float abstraction for the inversion core (f32 on the hot path, f64 for analysis).
pub(crate) trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    const TWO: Self;
    const HALF: Self;
    /// Coefficients c_k of (δ − sin δ)/(δ³/6) = Σ c_k δ^(2k) = 1 − δ²/20 + δ⁴/840 − …, as many
    /// as this precision needs for |δ| < 1 (see [`delta_minus_sin`]).
    const SERIES: &'static [f64];
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sin_cos(self) -> (Self, Self);
    /// atan2 of the start value (the core's only one; f32: [`crate::trig::atan2_coarse`]).
    fn atan2(self, x: Self) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn is_finite(self) -> bool;
    fn is_nan(self) -> bool;
    /// a·b + c·d with (close to) a single rounding.
    fn dot2(a: Self, b: Self, c: Self, d: Self) -> Self;
    #[inline]
    fn max(self, o: Self) -> Self {
        if self >= o {
            self
        } else {
            o
        }
    }
    #[inline]
    fn min(self, o: Self) -> Self {
        if self <= o {
            self
        } else {
            o
        }
    }
    #[inline]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }
}

macro_rules! impl_real {
    ($t:ty, $dot2:expr, $atan2:expr, $sin_cos:expr, $series:expr) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const TWO: Self = 2.0;
            const HALF: Self = 0.5;
            const SERIES: &'static [f64] = $series;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn sin_cos(self) -> (Self, Self) {
                $sin_cos(self)
            }
            #[inline]
            fn atan2(self, x: Self) -> Self {
                $atan2(self, x)
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            #[inline]
            fn dot2(a: Self, b: Self, c: Self, d: Self) -> Self {
                $dot2(a, b, c, d)
            }
        }
    };
}
// f32: atan2 and sin_cos without libm (crate::trig, f64 polynomials, ~1e-11 relative; atan2,
// which only the start value takes, with an f32 division: within 2 ulp), the
// series of δ − sin δ to δ⁸ (truncation < 1e-9 relative for |δ| < 1). f64: std, to δ¹⁶
// (< 1e-17). c_k = 6(−1)^k/(2k + 3)!.
impl_real!(
    f32,
    |a: f32, b: f32, c: f32, d: f32| { (a as f64 * b as f64 + c as f64 * d as f64) as f32 },
    crate::trig::atan2_coarse,
    crate::trig::sin_cos,
    SERIES.split_at(5).0
);
impl_real!(
    f64,
    |a: f64, b: f64, c: f64, d: f64| a.mul_add(b, c * d),
    f64::atan2,
    f64::sin_cos,
    &SERIES
);

/// c_k = 6(−1)^k/(2k + 3)! of the series of (δ − sin δ)/(δ³/6), k = 0..8.
const SERIES: [f64; 9] = [
    1.0,
    -1.0 / 20.0,
    1.0 / 840.0,
    -1.0 / 60_480.0,
    1.0 / 6_652_800.0,
    -1.0 / 1_037_836_800.0,
    1.0 / 217_945_728_000.0,
    -1.0 / 59_281_238_016_000.0,
    1.0 / 20_274_183_401_472_000.0,
];

/// δ − sin δ without cancellation: Taylor series for |δ| < 1 (truncated where the remainder is
/// below the precision: < 1e-17 relative in f64, < 1e-9 in f32, see [`Real::SERIES`]),
/// direct formula above (relative error ≤ ~6 ulp there since δ − sin δ ≥ 0.158·δ).
#[cfg(test)]
pub(crate) fn delta_minus_sin<T: Real>(x: T) -> T {
    delta_minus_sin_given(x, T::from_f64(x.to_f64().sin()))
}

/// [`delta_minus_sin`] with sin δ already known (used only for |δ| ≥ 1): no sin call on the hot
/// path, where sin τ = 2 sin(τ/2) cos(τ/2) is at hand. The series
/// δ³/6 · (1 − δ²/20 + δ⁴/840 − …) is evaluated by Estrin's scheme (pairs of terms, then powers
/// of δ⁴): half the dependency chain of Horner's, which sat on the sampler's critical path.
#[inline(always)]
pub(crate) fn delta_minus_sin_given<T: Real>(x: T, sin_x: T) -> T {
    let x2 = x * x;
    let c = |k: usize| T::from_f64(T::SERIES[k]);
    let x4 = x2 * x2;
    // Σ c_k x^(2k), k = 0..SERIES.len(): pairs c_k + c_(k+1) x², combined in powers of x⁴.
    let mut acc = T::ZERO;
    let mut power = T::ONE;
    let mut k = 0;
    while k < T::SERIES.len() {
        let pair = if k + 1 < T::SERIES.len() {
            c(k) + c(k + 1) * x2
        } else {
            c(k)
        };
        acc = acc + pair * power;
        power = power * x4;
        k += 2;
    }
    let series = x * x2 * T::from_f64(1.0 / 6.0) * acc;
    if x.abs() < T::ONE {
        series
    } else {
        x - sin_x
    }
}

/// Values of the inversion problem at one τ.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Eval<T> {
    /// C(φ_b + τ) − C(φ_b) = `delta_c_cos` + `delta_c_lin` (see [`PsaCore::delta_c_parts`]):
    /// kept apart so that the Halley step subtracts ξ·total from the second part while the
    /// first is still being multiplied (one addition fewer on the sampler's dependency chain).
    pub delta_c_cos: T,
    pub delta_c_lin: T,
    /// sin φ, cos φ, and twice them (formed first: G' = 2t(n·ω) and G'' = 2(t(n·ω)′ − s(n·ω))
    /// are then one multiplication earlier, bit for bit the same).
    pub s: T,
    pub t: T,
    pub s2: T,
    pub t2: T,
    /// n·ω and d(n·ω)/dφ.
    pub n_dot_w: T,
    pub n_dot_w_prime: T,
}

/// The 1D inversion problem of technique 8, independent of the 3D frame.
///
/// The unknown is τ = φ − φ_b ∈ [0, Δ] (offset from the begin of the interval), so that short
/// intervals keep full relative resolution even where φ ≈ ±π/2; sin/cos of φ_b + τ come from
/// angle addition with the accurately known (sin φ_b, cos φ_b).
///
/// Invariants: Δ > 0, n·ω ≥ 0 on the interval, `total` = C(φ_b + Δ) − C(φ_b) > 0.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PsaCore<T> {
    pub ns: T,
    pub nt: T,
    /// sin φ_b, cos φ_b.
    pub s_b: T,
    pub c_b: T,
    /// sin φ_e − sin φ_b = 2 cos(φ_b + Δ/2) sin(Δ/2), for the solid-angle start value.
    pub delta_s: T,
    /// Δ = φ_e − φ_b.
    pub width: T,
    /// n·ω and d(n·ω)/dφ at φ_b (accurately rounded once): n·ω(φ_b + τ) = p0 cos τ + p1 sin τ
    /// keeps full relative accuracy near a horizon-clipped end, where n_s s + n_t t cancels.
    pub p0: T,
    pub p1: T,
    pub total: T,
}

impl<T: Real> PsaCore<T> {
    /// From the endpoint angles (analysis; the sampler uses [`Self::with_frame_values`]).
    #[cfg(test)]
    pub fn from_angles(ns: T, nt: T, phi_b: T, phi_e: T) -> Option<Self> {
        let (s_b, c_b) = phi_b.sin_cos();
        Self::with_frame_values(ns, nt, s_b, c_b, phi_e - phi_b)
    }

    /// From sin φ_b, cos φ_b and Δ, with n·ω and its φ-derivative at φ_b formed here. `None` if
    /// the interval carries no finite, positive projected solid angle.
    #[inline]
    pub fn with_frame_values(ns: T, nt: T, s_b: T, c_b: T, width: T) -> Option<Self> {
        let (p0, p1) = (T::dot2(ns, s_b, nt, c_b), T::dot2(ns, c_b, -nt, s_b));
        Self::new(ns, nt, s_b, c_b, width, p0, p1)
    }

    /// From sin φ_b, cos φ_b, Δ and n·ω = p0, d(n·ω)/dφ = p1 at φ_b (each rounded once from a
    /// more accurate source where the caller has one). One sin/cos of Δ/2 gives Δs and the total.
    #[inline]
    pub fn new(ns: T, nt: T, s_b: T, c_b: T, width: T, p0: T, p1: T) -> Option<Self> {
        let (core, valid) = Self::new_lane(ns, nt, s_b, c_b, width, p0, p1);
        valid.then_some(core)
    }

    /// [`Self::new`] without a branch: the core and whether `new` returns it.
    #[inline(always)]
    pub(crate) fn new_lane(ns: T, nt: T, s_b: T, c_b: T, width: T, p0: T, p1: T) -> (Self, bool) {
        let half = (width * T::HALF).sin_cos();
        Self::half_lane(ns, nt, (s_b, c_b), width, half, (p0, p1))
    }

    /// [`Self::new`] given (sin, cos) of Δ/2 (`half`, which the caller may know without a
    /// sin/cos, consistent with Δ), the begin's (sin φ_b, cos φ_b) and (p0, p1).
    #[inline]
    pub fn with_half_width(
        ns: T,
        nt: T,
        begin: (T, T),
        width: T,
        half: (T, T),
        p: (T, T),
    ) -> Option<Self> {
        let (core, valid) = Self::half_lane(ns, nt, begin, width, half, p);
        valid.then_some(core)
    }

    /// [`Self::new_lane`] given (sin, cos) of Δ/2.
    #[inline(always)]
    fn half_lane(
        ns: T,
        nt: T,
        (s_b, c_b): (T, T),
        width: T,
        (sh, ch): (T, T),
        (p0, p1): (T, T),
    ) -> (Self, bool) {
        let mut core = Self {
            ns,
            nt,
            s_b,
            c_b,
            delta_s: T::ZERO,
            width,
            // Clamped: the interval is clipped to the horizon, n·ω_b < 0 is rounding.
            p0: p0.max(T::ZERO),
            p1,
            total: T::ZERO,
        };
        core.delta_s = T::TWO * core.rotate(sh, ch).1 * sh;
        let (a, b) = core.delta_c_parts(width, sh, ch);
        core.total = a + b;
        let valid = width > T::ZERO && core.total > T::ZERO && core.total.is_finite();
        (core, valid)
    }

    /// (sin, cos) of φ_b + τ given (sin, cos) of τ.
    #[inline(always)]
    fn rotate(&self, sin_tau: T, cos_tau: T) -> (T, T) {
        (
            self.s_b * cos_tau + self.c_b * sin_tau,
            self.c_b * cos_tau - self.s_b * sin_tau,
        )
    }

    /// C(φ_b + τ) − C(φ_b) given (sin, cos) of τ/2 (cancellation-free, see the module
    /// documentation) as its two terms 2 cos m · sin τ · (n·ω)(m) and n_t (τ − sin τ), m the
    /// midpoint φ_b + τ/2. The first is formed as (cos m · (n·ω)(m)) · (4 sin(τ/2) cos(τ/2)):
    /// two multiplications after the midpoint values instead of three in series.
    #[inline(always)]
    fn delta_c_parts(&self, tau: T, sh: T, ch: T) -> (T, T) {
        let cm = self.c_b * ch - self.s_b * sh; // cos of the midpoint φ_b + τ/2
        let n_dot_wm = self.p0 * ch + self.p1 * sh;
        let sin_tau = T::TWO * sh * ch;
        (
            cm * n_dot_wm * (T::TWO * sin_tau),
            self.nt * delta_minus_sin_given(tau, sin_tau),
        )
    }

    /// C(φ_b + τ) − C(φ_b), cancellation-free (see the module documentation), with the values
    /// at φ = φ_b + τ that the Halley step needs.
    #[inline(always)]
    pub fn eval(&self, tau: T) -> Eval<T> {
        let (sh, ch) = (tau * T::HALF).sin_cos();
        self.eval_half(tau, sh, ch)
    }

    /// [`Self::eval`] given (sin, cos) of τ/2.
    #[inline(always)]
    fn eval_half(&self, tau: T, sh: T, ch: T) -> Eval<T> {
        let sin_tau = T::TWO * sh * ch;
        let cos_tau = T::ONE - T::TWO * sh * sh;
        let (delta_c_cos, delta_c_lin) = self.delta_c_parts(tau, sh, ch);
        // 2·(sin φ, cos φ) by rotating with the doubled (exact) begin values.
        let (s2, t2) = (
            T::TWO * self.s_b * cos_tau + T::TWO * self.c_b * sin_tau,
            T::TWO * self.c_b * cos_tau - T::TWO * self.s_b * sin_tau,
        );
        Eval {
            delta_c_cos,
            delta_c_lin,
            s: s2 * T::HALF,
            t: t2 * T::HALF,
            s2,
            t2,
            n_dot_w: self.p0 * cos_tau + self.p1 * sin_tau,
            n_dot_w_prime: self.p1 * cos_tau - self.p0 * sin_tau,
        }
    }

    #[inline]
    pub fn delta_c(&self, tau: T) -> T {
        let (sh, ch) = (tau * T::HALF).sin_cos();
        let (a, b) = self.delta_c_parts(tau, sh, ch);
        a + b
    }

    /// Whether ξ lies in the guard band where the start value is returned unchanged.
    #[inline]
    pub fn in_guard(xi: T) -> bool {
        let g = T::from_f64(XI_GUARD);
        xi < g || xi > T::ONE - g
    }

    /// Start value: τ of the solid-angle sample for the same ξ, i.e. sin(φ_b + τ) = s_b + ξ·Δs.
    /// Computed without forming s = s_b + ξΔs and asin(s) − φ_b (with y = ξΔs, cos φ_b = c_b):
    /// c = √(c_b² − y(2s_b + y)) = cos(φ_b + τ), sin τ = y c_b + s_b·y(2s_b + y)/(c_b + c),
    /// cos τ = c c_b + (s_b + y)s_b. The textbook form is quantised to a few values in f32 when
    /// s_b ≈ ±1 (then two iterations do not recover). Exact at ξ = 0 and 1.
    #[inline(always)]
    pub fn start(&self, xi: T) -> T {
        // The ends as early (predictable) branches on the scalar path.
        if xi <= T::ZERO {
            return T::ZERO;
        }
        if xi >= T::ONE {
            return self.width;
        }
        self.start_with(xi, T::atan2)
    }

    /// [`Self::start`] with a given atan2 (the lanes of [`crate::batch`] use a branch-free one
    /// with bitwise the same results), itself without branches.
    #[inline(always)]
    pub(crate) fn start_with(&self, xi: T, atan2: impl Fn(T, T) -> T) -> T {
        self.start_half_with(xi, atan2).0
    }

    /// [`Self::start_with`] and (sin, cos) of τ/2 for ξ ∈ (0, 1), which the first Halley step
    /// evaluates: from the start value's own quantities, not from τ (so that the atan2 of the
    /// start value runs beside the critical path instead of before a sin/cos of its half on
    /// it). The unit vectors at φ_b and φ = φ_b + τ sum to
    /// w = (c_b + c, s_b + sin φ) = (`denom`, 2s_b + y), |w| = 2 cos(τ/2), and their cross
    /// product is sin τ, so cos(τ/2) = |w|/2 and sin(τ/2) = sin τ/|w| (a sum of squares: no
    /// cancellation; where w → 0, τ → π, its first component dominates).
    #[inline(always)]
    pub(crate) fn start_half_with(&self, xi: T, atan2: impl Fn(T, T) -> T) -> (T, T, T) {
        let y = xi * self.delta_s;
        let wy = T::TWO * self.s_b + y;
        let q = y * wy;
        let c = (self.c_b * self.c_b - q).max(T::ZERO).sqrt();
        let denom = self.c_b + c;
        let cos_tau = c * self.c_b + (self.s_b + y) * self.s_b;
        // atan2 is invariant under a common positive factor: (sin τ, cos τ)·denom saves the
        // division by denom.
        let scaled = denom > T::ZERO;
        let sin_tau = if scaled {
            y * self.c_b * denom + self.s_b * q
        } else {
            y
        };
        let cos_tau = if scaled { cos_tau * denom } else { cos_tau };
        let tau = atan2(sin_tau, cos_tau).clamp(T::ZERO, self.width);
        // Exact ends (also for ξ outside [0, 1]).
        let tau = if xi <= T::ZERO {
            T::ZERO
        } else if xi >= T::ONE {
            self.width
        } else {
            tau
        };
        let w = (denom * denom + wy * wy).sqrt();
        // denom = 0: c_b = c = 0, τ ∈ {0, π}.
        let sh = if scaled {
            sin_tau / (denom * w)
        } else if cos_tau < T::ZERO {
            T::ONE
        } else {
            T::ZERO
        };
        (tau, sh, T::HALF * w)
    }

    /// One step of Halley's irrational formula on G(τ) = C(φ_b + τ) − C(φ_b) − ξ·total from
    /// the values `e` = `eval(τ)`, clamped to [0, Δ].
    #[inline(always)]
    fn halley_from(&self, tau: T, xi: T, e: &Eval<T>) -> T {
        let (g, den) = self.halley_terms(xi, e);
        let next = tau + -T::TWO * g / den;
        if next.is_nan() {
            tau
        } else {
            next.clamp(T::ZERO, self.width)
        }
    }

    /// [`Self::halley_from`] halved, formed as τ/2 − G/den (bit for bit the half of it, the
    /// scalings by 2 being exact): the argument of the next evaluation's sin/cos without a
    /// multiplication after the division.
    #[inline(always)]
    fn halley_half_from(&self, tau: T, xi: T, e: &Eval<T>) -> T {
        let (g, den) = self.halley_terms(xi, e);
        let half = tau * T::HALF;
        let next = half + -g / den;
        if next.is_nan() {
            half
        } else {
            next.clamp(T::ZERO, self.width * T::HALF)
        }
    }

    /// G and the denominator of the Halley step: h = −2G/den.
    #[inline(always)]
    fn halley_terms(&self, xi: T, e: &Eval<T>) -> (T, T) {
        let g = self.g_of(xi, e);
        // G' = 2t(n·ω), G''/2 = t(n_s t − n_t s) − s(n·ω) with n_s t − n_t s = d(n·ω)/dφ.
        let g1 = e.t2 * e.n_dot_w;
        let g2 = e.t2 * e.n_dot_w_prime - e.s2 * e.n_dot_w;
        // Smallest root of G + G'h + G''h²/2, h = −2G / (G' + √(G'² − 2GG'')) with
        // den = G' + √… ≥ 0 (G' ≥ 0 on the clipped interval). Without branches (their outcome is
        // data-dependent): den = 0 makes h = ±inf, clamped to an end of [0, Δ], or NaN for
        // G = 0, where τ is kept.
        // g·(2G'') is 2G·G'' bit for bit, one multiplication after G fewer.
        let den = g1.max(T::ZERO) + (g1 * g1 - g * (T::TWO * g2)).max(T::ZERO).sqrt();
        (g, den)
    }

    /// G(τ) = C(φ_b + τ) − C(φ_b) − ξ·total from the values `e` = `eval(τ)`, as
    /// `delta_c_cos` + (`delta_c_lin` − ξ·total): the last two are known before the first.
    #[inline(always)]
    fn g_of(&self, xi: T, e: &Eval<T>) -> T {
        e.delta_c_cos + (e.delta_c_lin - xi * self.total)
    }

    /// τ of the sample for ξ ∈ [0, 1] after `iterations` Halley steps (that of
    /// [`Self::solve_rotated_lane`]).
    #[inline]
    pub fn solve(&self, xi: T, iterations: u32) -> T {
        self.solve_rotated_lane(xi, iterations, T::atan2).1
    }

    /// The first `iterations − 1` Halley steps (`iterations` ≥ 1) from the start value (whose
    /// half-angle values the first evaluation takes, see [`Self::start_half_with`]): the start
    /// value, τ before the last step and the values there.
    #[inline(always)]
    fn iterate(&self, xi: T, iterations: u32, atan2: impl Fn(T, T) -> T) -> (T, T, Eval<T>) {
        let (start, sh, ch) = self.start_half_with(xi, atan2);
        let mut e = self.eval_half(start, sh, ch);
        let mut tau = start;
        for _ in 1..iterations {
            let half = self.halley_half_from(tau, xi, &e);
            tau = T::TWO * half;
            let (sh, ch) = half.sin_cos();
            e = self.eval_half(tau, sh, ch);
        }
        (start, tau, e)
    }

    /// (sin φ, cos φ, n·ω) at φ = φ_b + τ, τ ∈ [0, Δ] ⊂ [0, π]: (sin, cos) τ from the half
    /// angle, which is in the range of the libm-free [`Real::sin_cos`].
    #[inline(always)]
    pub fn at(&self, tau: T) -> (T, T, T) {
        let (sh, ch) = (tau * T::HALF).sin_cos();
        let (st, ct) = (T::TWO * sh * ch, T::ONE - T::TWO * sh * sh);
        let (s, t) = self.rotate(st, ct);
        (s, t, self.p0 * ct + self.p1 * st)
    }

    /// [`Self::solve`] and (sin φ, cos φ, n·ω) at the sample: the one-lane instance of
    /// [`Self::solve_rotated_lane`], whose fresh evaluation it takes as a branch.
    #[inline(always)]
    pub fn solve_with_values(&self, xi: T, iterations: u32) -> (T, (T, T, T)) {
        let (rotated, tau, fresh) = self.solve_rotated_lane(xi, iterations, T::atan2);
        (tau, if fresh { self.at(tau) } else { rotated })
    }

    /// [`Self::solve`] without branches up to its last decision (both ways of every earlier
    /// decision computed, then selected): the values (sin φ, cos φ, n·ω) at the sample, the τ
    /// of the sample, and whether the values must be evaluated afresh at τ (with [`Self::at`])
    /// instead.
    /// The last step starts from values at τ that its evaluation already holds; rotating them
    /// by the step h (short Taylor series for |h| ≤ [`ROTATION_STEP`], almost always the case
    /// for the last step) replaces a further sin/cos. Fresh values are needed in the ξ guard
    /// and after a last step longer than [`ROTATION_STEP`] (rare): the lanes of [`crate::batch`]
    /// evaluate `at(τ)` only when some lane of the batch needs it (one sin/cos of the chain's
    /// length per lane saved in almost every batch).
    #[inline(always)]
    pub(crate) fn solve_rotated_lane(
        &self,
        xi: T,
        iterations: u32,
        atan2: impl Fn(T, T) -> T,
    ) -> ((T, T, T), T, bool) {
        let (start, tau, e) = self.iterate(xi, iterations.max(1), atan2);
        let next = self.halley_from(tau, xi, &e);
        let h = next - tau;
        let guard = iterations == 0 || Self::in_guard(xi);
        let fresh = guard || h.abs() > T::from_f64(ROTATION_STEP);
        (
            Self::rotate_by(&e, h),
            if guard { start } else { next },
            fresh,
        )
    }

    /// (sin φ, cos φ, n·ω) of `e` rotated by a small angle h (|h| ≤ [`ROTATION_STEP`]).
    #[inline(always)]
    fn rotate_by(e: &Eval<T>, h: T) -> (T, T, T) {
        // sin h and cos h to h⁵ and h⁶: truncation < 1e-9 relative for |h| ≤ 1/8.
        let h2 = h * h;
        let sin_h = h - h * h2 * T::from_f64(1.0 / 6.0) * (T::ONE - h2 * T::from_f64(1.0 / 20.0));
        let one_minus_cos_h = h2
            * T::HALF
            * (T::ONE - h2 * T::from_f64(1.0 / 12.0) * (T::ONE - h2 * T::from_f64(1.0 / 30.0)));
        let rot = |a: T, b: T| a - a * one_minus_cos_h + b * sin_h;
        (
            rot(e.s, e.t),
            rot(e.t, -e.s),
            rot(e.n_dot_w, e.n_dot_w_prime),
        )
    }

    /// Exact CDF: ξ of τ (clamped to the interval).
    #[inline]
    pub fn cdf(&self, tau: T) -> T {
        let tau = tau.clamp(T::ZERO, self.width);
        (self.delta_c(tau) / self.total).clamp(T::ZERO, T::ONE)
    }
}

/// Most Halley steps of [`PsaCore::solve_converged`] (it stops as soon as a step changes τ by
/// no more than its rounding: after 2–7 steps from the solid-angle start value on the tails of
/// the fitted-table LTC configurations of the sampler suite; the bound only stops a
/// pathological case).
const CONVERGED_MAX_STEPS: u32 = 60;

impl PsaCore<f64> {
    /// τ with C(φ_b + τ) − C(φ_b) = ξ·total to the f64 rounding of the CDF, without the ξ guard:
    /// Halley steps from the start value, each kept inside the bracket [lo, hi] of the root
    /// (G is increasing) and replaced by bisection where it would leave it. For the rare ξ where
    /// the guarded two-step [`Self::solve`] is not accurate enough: within [`XI_GUARD`] of 0 or
    /// 1 it returns the solid-angle sample, whose projected-solid-angle CDF is off by up to
    /// ~1e-5 in ξ — harmless in the segment's own φ, but not where a sampler maps the ends of
    /// this segment non-linearly onto a wide range (LTC of a sharp lobe, `crate::ltc`).
    pub fn solve_converged(&self, xi: f64) -> f64 {
        if xi.is_nan() || xi <= 0.0 {
            return 0.0;
        }
        if xi >= 1.0 {
            return self.width;
        }
        let (mut lo, mut hi) = (0.0, self.width);
        let mut tau = self.start(xi);
        for _ in 0..CONVERGED_MAX_STEPS {
            let e = self.eval(tau);
            let g = self.g_of(xi, &e);
            if g < 0.0 {
                lo = tau;
            } else if g > 0.0 {
                hi = tau;
            } else {
                return tau;
            }
            let step = self.halley_from(tau, xi, &e);
            if (step - tau).abs() <= 4.0 * f64::EPSILON * tau {
                return step;
            }
            tau = if step > lo && step < hi {
                step
            } else {
                0.5 * (lo + hi)
            };
        }
        tau
    }
}

impl PsaCore<f32> {
    /// The same interval and normal in f64: the f32 parameters converted exactly, Δs and the
    /// total recomputed in f64 (the f32 total is rounded: its CDF would reach 1 − ~3e-8 at Δ,
    /// a large error relative to the last 1e-6 of the mass). `None` where [`PsaCore::new`] is.
    pub fn widened(&self) -> Option<PsaCore<f64>> {
        let f = |x: f32| x as f64;
        PsaCore::new(
            f(self.ns),
            f(self.nt),
            f(self.s_b),
            f(self.c_b),
            f(self.width),
            f(self.p0),
            f(self.p1),
        )
    }
}

/// Projected-solid-angle sampler of Peters 2021 (technique 8).
#[derive(Clone, Copy, Debug)]
pub struct ProjectedSolidAngle {
    /// Horizon-clipped frame: the support.
    pub(crate) frame: LineFrame,
    /// The normal scaled by a power of two (largest |component| in [1, 2),
    /// [`power_of_two_scaled`]), not normalised: the core and the density are homogeneous in n.
    pub(crate) n: Vec3,
    /// The core of `n` (its C, G and total carry the factor |n|).
    pub(crate) core: PsaCore<f32>,
    /// 1/(|n| Ω⊥_R) = d / (C(φ_e) − C(φ_b)), so that the density per radius of a direction is
    /// (n·ω)·`inv_psa` = (n̂·ω)/Ω⊥_R for the stored (not unit) `n`.
    pub(crate) inv_psa: f32,
    /// Support tolerance of the arc ([`arc_tolerance`]); the arc itself is (s_b, c_b, Δ) of
    /// `core`, not stored twice (keeps the struct, and `Prepared`, small enough to be moved
    /// without a memcpy call).
    pub(crate) tolerance: f32,
    pub(crate) iterations: u32,
}

impl ProjectedSolidAngle {
    /// The paper's sampler (two Halley iterations).
    #[inline]
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        Self::prepare_with_iterations(segment, x, n, DEFAULT_ITERATIONS)
    }

    /// Same with a chosen number of iterations. For analysis and tests only: the density stays
    /// the exact (n·ω)/Ω⊥_R, so fewer than 2 iterations sample a visibly different density than
    /// `pdf` reports (1 iteration is the chi-square suite's negative control).
    #[inline]
    pub fn prepare_with_iterations(
        segment: &Segment,
        x: Vec3,
        n: Vec3,
        iterations: u32,
    ) -> Option<Self> {
        if !normal_is_valid(n) {
            return None;
        }
        // Clipped with the normal as given: the horizon depends on its direction only. Nor does
        // the sampler normalise it (see [`Self::lane`]).
        let (frame, ends) = LineFrame::clipped_with_ends(segment, x, n)?;
        Self::on_frame_with(frame, ends, n, iterations)
    }

    /// [`Self::prepare`] and the frame of the whole segment from `x` (bit for bit
    /// `LineFrame::new(segment, x)`; `None` where that is `None`), from one closest-point
    /// computation: for a technique that clips the line itself (LTC beside this one in the
    /// two-technique estimator).
    #[inline]
    pub fn prepare_with_whole_frame(
        segment: &Segment,
        x: Vec3,
        n: Vec3,
    ) -> Option<(Self, Option<LineFrame>)> {
        if !normal_is_valid(n) {
            return None;
        }
        let (frame, ends, whole) = LineFrame::clipped_and_whole(segment, x, n)?;
        Self::on_frame_with(frame, ends, n, DEFAULT_ITERATIONS).map(|s| (s, whole))
    }

    /// On an already clipped frame (frame clipped to the horizon of n; n of any length that
    /// [`crate::unit_normal`] accepts: debug-asserted in `Self::on_frame_with`, an invalid n
    /// is a caller's bug here; `Self::lane` runs invalid lanes on purpose).
    #[inline]
    pub fn on_frame(frame: LineFrame, n: Vec3, iterations: u32) -> Option<Self> {
        Self::on_frame_with(frame, EndValues::of(&frame), n, iterations)
    }

    /// [`Self::on_frame`] with the frame's [`EndValues`] from its constructor.
    #[inline]
    pub(crate) fn on_frame_with(
        frame: LineFrame,
        ends: EndValues,
        n: Vec3,
        iterations: u32,
    ) -> Option<Self> {
        debug_assert!(normal_is_valid(n), "on_frame_with: invalid normal {n}");
        let (sampler, valid) = Self::lane(frame, ends, n, iterations, atan2_f64);
        valid.then_some(sampler)
    }

    /// [`Self::on_frame`] without branches: the sampler and whether `on_frame` returns it (the
    /// one implementation of the scalar path and the lanes of [`crate::batch`]).
    #[inline(always)]
    pub(crate) fn lane(
        frame: LineFrame,
        ends: EndValues,
        n: Vec3,
        iterations: u32,
        atan2: impl Fn(f64, f64) -> f64,
    ) -> (Self, bool) {
        // n is not normalised (that took an f64 square root and division, ~40 cycles of the
        // divider per 8 lanes): ΔC, G, G', G'' and the total are all linear in n, so the Halley
        // steps (h = −2G/(G' + √(G'² − 2GG''))) and the density (n·ω)·d/total do not depend on
        // its length. It is scaled by a power of two instead (exact: rounds nothing), so that
        // its length lies in [1, 2√3) like a unit normal's, whatever the caller passed; a unit
        // normal thus gives bit for bit the sampler of the unit normal, up to exact factors 2.
        let n = power_of_two_scaled(n);
        // In f64 from the f32 frame (no overflow, exact products), each value rounded once:
        // n_s, n_t; (sin φ_b, cos φ_b) = (l_b, d)/r_b, cos φ_b accurate where s_b ≈ ±1 is not;
        // Δ from tan Δ = (l_e − l_b)d / (d² + l_b l_e), free of the cancellation of φ_e − φ_b;
        // p0 = n·ω_b and p1 = d(n·ω)/dφ at φ_b: at a horizon-clipped begin p0 ≈ 0 is a
        // difference of O(1) terms, whose f32 rounding would be ~1e-5 of Ω⊥ of a 3e-3-rad
        // interval.
        let (n64, d, lb, le) = (
            n.as_dvec3(),
            frame.d as f64,
            frame.l_begin as f64,
            frame.l_end as f64,
        );
        let (ns, nt) = (n64.dot(frame.u.as_dvec3()), n64.dot(frame.c_hat.as_dvec3()));
        // (s_b, c_b) and Δs as the frame's constructor computed them ([`EndValues`]); Δs for
        // the start value from there, not from sin/cos(Δ/2) after Δ's atan2: the start value no
        // longer waits for that chain (only the total, needed one evaluation later, does).
        let EndValues { s_b, c_b, delta_s } = ends;
        let width = atan2((le - lb) * d, d * d + lb * le);
        let (core, valid) = PsaCore::new_lane(
            ns as f32,
            nt as f32,
            s_b as f32,
            c_b as f32,
            width as f32,
            (ns * s_b + nt * c_b) as f32,
            (ns * c_b - nt * s_b) as f32,
        );
        let core = PsaCore {
            delta_s: delta_s as f32,
            ..core
        };
        let inv_psa = frame.d / core.total;
        let sampler = Self {
            frame,
            n,
            core,
            inv_psa,
            tolerance: arc_tolerance(width) as f32,
            iterations,
        };
        (sampler, valid && inv_psa.is_finite() && inv_psa > 0.0)
    }

    /// The sample for ξ with τ from `PsaCore::solve_converged` on the sampler's own core
    /// widened to f64 (`PsaCore::widened`), as an f64 direction; no ξ guard. Slower than [`LineSampler::sample`] (a
    /// libm-based f64 solve of several steps): for the few ξ where a caller needs the exact
    /// inverse CDF, e.g. the tails of [`crate::ltc::LtcLine`].
    pub fn sample_converged(&self, xi: f32) -> DVec3 {
        let Some(core) = self.core.widened() else {
            return self.sample(xi).as_dvec3();
        };
        let tau = core.solve_converged(clamp_xi(xi) as f64);
        let (s, t, _) = core.at(tau);
        s * self.frame.u.as_dvec3() + t.max(0.0) * self.frame.c_hat.as_dvec3()
    }

    /// Ω⊥_R of the clipped segment (for the unit normal): 1/(|n| `inv_psa`), see `inv_psa`.
    pub fn projected_solid_angle(&self) -> f32 {
        1.0 / (self.inv_psa * self.n.length())
    }

    /// The unit normal the sampler was prepared with, normalised in f64 like
    /// [`crate::unit_normal`] (an f32 `normalize` gave (0, 0, 0.99999994) for (0, 0, 3.7)).
    pub fn normal(&self) -> Vec3 {
        // `n` is valid in every constructed sampler.
        unit_normal_lane(self.n).0
    }

    /// Exact CDF at the line parameter l (clamped to the support): the fraction of Ω⊥_R between
    /// l_begin and l. τ(l) = atan2((l − l_b)d, d² + l_b l) avoids the cancellation of φ − φ_b.
    pub fn cdf_of_l(&self, l: f32) -> f32 {
        self.cdf_of_l_with(l, atan2_f64)
    }

    /// [`Self::cdf_of_l`] with a given atan2 (branch-free in [`crate::batch`]; bitwise equal).
    #[inline(always)]
    pub(crate) fn cdf_of_l_with(&self, l: f32, atan2: impl Fn(f64, f64) -> f64) -> f32 {
        let f = &self.frame;
        // max/min rather than clamp: no assertion (a branch) in the lanes of a batch.
        let (lb, l, d) = (
            f.l_begin as f64,
            l.max(f.l_begin).min(f.l_end) as f64,
            f.d as f64,
        );
        // In f64 as in `on_frame` (no overflow, no division before atan2's).
        let tau = atan2((l - lb) * d, d * d + lb * l) as f32;
        self.core.cdf(tau)
    }

    /// τ = φ − φ_b of the sample for ξ (for analysis).
    #[inline]
    pub fn sample_tau(&self, xi: f32) -> f32 {
        self.core.solve(clamp_xi(xi), self.iterations)
    }

    /// Direction and density of the sample for ξ.
    #[inline]
    fn sample_values(&self, xi: f32) -> (Vec3, f32) {
        let (_, values) = self.core.solve_with_values(clamp_xi(xi), self.iterations);
        direction_and_density(self.frame.u, self.frame.c_hat, self.inv_psa, values)
    }

    /// [`LineSampler::sample_with_pdf`] without branches, up to the direction, for the lanes of
    /// [`crate::batch`] (see [`PsaCore::solve_rotated_lane`]): (sin φ, cos φ, n·ω) rotated by
    /// the last step, the τ to evaluate instead, and whether. The direction is then
    /// s·u + max(t, 0)·ĉ and the density max(n·ω, 0)/Ω⊥_R, as in `sample_with_pdf`.
    #[inline(always)]
    pub(crate) fn sample_rotated_lane(
        &self,
        xi: f32,
        atan2: impl Fn(f32, f32) -> f32,
    ) -> ((f32, f32, f32), f32, bool) {
        self.core.solve_rotated_lane(xi, self.iterations, atan2)
    }

    /// Density of a direction known to lie in the support (no support test): (n·ω)⁺/Ω⊥_R.
    /// The MIS cross density of a specular (LTC) sample, which always lies on the
    /// horizon-clipped line this sampler covers.
    #[inline]
    pub fn density_in_support(&self, dir: Vec3) -> f32 {
        self.n.dot(dir).max(0.0) * self.inv_psa
    }

    /// τ of a direction if it points into the support (up to rounding).
    #[inline]
    fn tau_in_support(&self, dir: Vec3) -> Option<f32> {
        let c = &self.core;
        let arc = (c.s_b as f64, c.c_b as f64, c.width as f64);
        tau_in_arc(&self.frame, arc, self.tolerance as f64, dir).map(|tau| tau as f32)
    }
}

/// The sample's direction s·u + max(t, 0)·ĉ and density max(n·ω, 0)·`inv_psa` from its values
/// (s, t, n·ω) = (sin φ, cos φ, n·ω) on the frame (u, ĉ): the end of
/// [`LineSampler::sample_with_pdf`], scalar and in the lanes of [`crate::batch`].
#[inline(always)]
pub(crate) fn direction_and_density(
    u: Vec3,
    c_hat: Vec3,
    inv_psa: f32,
    (s, t, n_dot_w): (f32, f32, f32),
) -> (Vec3, f32) {
    (s * u + t.max(0.0) * c_hat, n_dot_w.max(0.0) * inv_psa)
}

impl LineSampler for ProjectedSolidAngle {
    fn sample(&self, xi: f32) -> Vec3 {
        self.sample_values(xi).0
    }

    /// Support test in τ rather than via the frame's s-interval: s is coarsely quantised when the
    /// line is seen almost along its axis, τ is not (both describe the same interval).
    fn pdf(&self, dir: Vec3) -> f32 {
        match self.tau_in_support(dir) {
            Some(_) => self.density_in_support(dir),
            None => 0.0,
        }
    }

    fn support(&self) -> &LineFrame {
        &self.frame
    }

    fn inverse(&self, dir: Vec3) -> Option<f32> {
        self.tau_in_support(dir).map(|tau| self.core.cdf(tau))
    }

    #[inline]
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        self.sample_values(xi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn configs() -> Vec<(Segment, Vec3, Vec3)> {
        vec![
            (
                Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)),
                Vec3::ZERO,
                Vec3::Z,
            ),
            // Crosses the horizon (clipped), tilted normal.
            (
                Segment::new(Vec3::new(-0.3, 0.5, -0.4), Vec3::new(1.2, -0.2, 1.1)),
                Vec3::ZERO,
                Vec3::new(0.2, 0.1, 1.0),
            ),
            // Long line, shading point close to it (d small).
            (
                Segment::new(Vec3::new(-50.0, 0.0, 0.01), Vec3::new(50.0, 0.0, 0.01)),
                Vec3::ZERO,
                Vec3::new(0.3, 0.0, 1.0),
            ),
            // Short distant segment seen almost along its axis (s ≈ 1).
            (
                Segment::new(Vec3::new(0.0, 1.0, 100.0), Vec3::new(0.0, 1.0, 101.0)),
                Vec3::ZERO,
                Vec3::new(0.0, 0.0, 1.0),
            ),
            // Grazing: normal almost parallel to the plane of the line.
            (
                Segment::new(Vec3::new(-1.0, 1.0, 0.02), Vec3::new(1.0, 1.0, 0.02)),
                Vec3::ZERO,
                Vec3::Z,
            ),
        ]
    }

    /// ∫ pdf dΩ_R by the midpoint rule in τ (dΩ_R = (2/d) cos φ dφ), in f64.
    fn integrate_pdf(p: &ProjectedSolidAngle) -> f64 {
        let f = p.support();
        let c = p.core;
        let m = 200_000;
        let h = c.width as f64 / m as f64;
        let mut sum = 0.0;
        for i in 0..m {
            let tau = (i as f64 + 0.5) * h;
            let (st, ct) = tau.sin_cos();
            let s = c.s_b as f64 * ct + c.c_b as f64 * st;
            let t = c.c_b as f64 * ct - c.s_b as f64 * st;
            let dir = (s as f32) * f.u + (t as f32) * f.c_hat;
            sum += p.pdf(dir) as f64 * 2.0 / f.d as f64 * t;
        }
        sum * h
    }

    #[test]
    fn density_is_normalised() {
        for (seg, x, n) in configs() {
            let p = ProjectedSolidAngle::prepare(&seg, x, n).unwrap();
            let total = integrate_pdf(&p);
            assert!((total - 1.0).abs() < 1e-4, "{seg:?}: ∫pdf = {total}");
            // Ω⊥_R agrees with the frame's (naive) formula where that one is accurate.
            let naive = p.support().projected_solid_angle(p.normal());
            let ours = p.projected_solid_angle();
            assert!(
                (naive - ours).abs() < 1e-3 * ours + 1e-6,
                "{naive} vs {ours}"
            );
        }
    }

    #[test]
    fn paper_sanity_value() {
        let (seg, x, n) = configs()[0];
        let p = ProjectedSolidAngle::prepare(&seg, x, n).unwrap();
        let psa = p.projected_solid_angle();
        assert!(
            (psa - (1.0 + std::f32::consts::FRAC_PI_2)).abs() < 1e-6,
            "{psa}"
        );
    }

    #[test]
    fn stable_difference_matches_naive_f64() {
        let c = |phi: f64| 0.3 * phi.sin().powi(2) + 0.8 * (phi.sin() * phi.cos() + phi);
        for &(a, b) in &[
            (0.5, -1.2),
            (1.4, 1.3999),
            (-0.2, -0.2001),
            (1.0, -1.0),
            (1.3, 0.9),
        ] {
            let core = PsaCore::from_angles(0.3f64, 0.8, b, a).unwrap();
            let stable = core.delta_c(a - b);
            let naive = c(a) - c(b);
            assert!(
                (stable - naive).abs() < 1e-12,
                "{a} {b}: {stable} vs {naive}"
            );
            // f32 arithmetic on the same (f32-representable) problem, relative to f64.
            let (a32, b32) = (a as f32, b as f32);
            let c32 = PsaCore::from_angles(0.3f32, 0.8, b32, a32).unwrap();
            let c64 = PsaCore::with_frame_values(
                0.3f32 as f64,
                0.8f32 as f64,
                c32.s_b as f64,
                c32.c_b as f64,
                c32.width as f64,
            )
            .unwrap();
            let (s32, exact) = (c32.total as f64, c64.total);
            assert!(
                (s32 - exact).abs() <= 1e-6 * exact,
                "{a} {b}: {s32} vs {exact}"
            );
        }
        for &x in &[1e-8f64, 1e-3, 0.3, 0.999, 1.0, 2.0, 3.1] {
            let direct = x - x.sin();
            let series = delta_minus_sin(x);
            assert!((series - direct).abs() <= 1e-15 + 1e-9 * direct, "{x}");
        }
        let x = 1e-3f64;
        assert!((delta_minus_sin(x) - (x.powi(3) / 6.0 - x.powi(5) / 120.0)).abs() < 1e-24);
    }

    #[test]
    fn samples_in_support_and_round_trip() {
        for (seg, x, n) in configs() {
            let p = ProjectedSolidAngle::prepare(&seg, x, n).unwrap();
            let f = *p.support();
            for i in 0..=1000 {
                let xi = i as f32 / 1000.0;
                let (dir, pdf) = p.sample_with_pdf(xi);
                assert!((dir.length() - 1.0).abs() < 1e-5);
                assert!(pdf.is_finite() && pdf >= 0.0);
                // Points at the line: the direction is in the plane of u and ĉ.
                assert!(f.u.cross(f.c_hat).dot(dir).abs() < 1e-5);
                // In the support (pdf > 0 except on a horizon-clipped rim), and the inverse
                // (exact CDF) recovers ξ to the accuracy of two iterations.
                let back = p.inverse(dir).expect("sample outside the support");
                assert!((back - xi).abs() < 2e-5, "{seg:?} ξ={xi}: {back}");
                let full = p.pdf(dir);
                assert!(
                    (full - pdf).abs() <= 1e-4 * pdf.max(1e-3),
                    "{xi}: {full} vs {pdf}"
                );
            }
            // A direction at the line outside the clipped part, and one not toward the line.
            assert_eq!(p.pdf(-f.c_hat), 0.0);
            assert!(p.inverse(-f.c_hat).is_none());
        }
    }

    /// Backward error in f64 of the f32 sampler, in units of ξ, away from the guard band.
    #[test]
    fn two_iterations_accurate_one_iteration_not() {
        let mut worst_one = 0.0f64;
        for (seg, x, n) in configs() {
            let worst = |k: u32| {
                let p = ProjectedSolidAngle::prepare_with_iterations(&seg, x, n, k).unwrap();
                let c = p.core;
                let c64 = PsaCore::with_frame_values(
                    c.ns as f64,
                    c.nt as f64,
                    c.s_b as f64,
                    c.c_b as f64,
                    c.width as f64,
                )
                .unwrap();
                let mut w = 0.0f64;
                for i in 1..20_000 {
                    let xi = i as f32 / 20_000.0;
                    let tau = p.sample_tau(xi) as f64;
                    w = w.max((c64.delta_c(tau) / c64.total - xi as f64).abs());
                }
                w
            };
            let (one, two, three) = (worst(1), worst(2), worst(3));
            eprintln!("{seg:?}: worst |e| for 1/2/3 iterations: {one:.2e} {two:.2e} {three:.2e}");
            assert!(two < 2e-5, "{seg:?} two iterations: {two}");
            assert!(three < 2e-6, "{seg:?} three iterations: {three}");
            // (On short or symmetric intervals one step already reaches the f32 floor, so the
            // negative control is asserted on the worst configuration only.)
            worst_one = worst_one.max(one);
        }
        assert!(
            worst_one > 1e-3,
            "one iteration should be visibly worse: {worst_one}"
        );
        // ξ = 0 and 1 are exact endpoints; out-of-range ξ is clamped.
        let (seg, x, n) = configs()[1];
        let p = ProjectedSolidAngle::prepare(&seg, x, n).unwrap();
        assert_eq!(p.sample_tau(0.0), 0.0);
        assert_eq!(p.sample_tau(1.0), p.core.width);
        assert_eq!(p.sample_tau(-3.0), 0.0);
        assert_eq!(p.sample_tau(f32::NAN), 0.0);
    }

    /// `prepare` is homogeneous of degree 0 in the normal (it scales n by a power of two,
    /// [`power_of_two_scaled`]): n·s gives the sampler of n bit for bit where s is a power of
    /// two (also 2⁻⁶⁰, whose normal is far below f32's unit range), and within 1e-6 otherwise
    /// (n·s itself rounds, and so does the arithmetic on another scaled n), in the samples,
    /// `pdf`, `inverse`, `projected_solid_angle()` and `normal()`. Ω⊥ relatively; ξ, unit
    /// vectors and samples (in the CDF's measure: their ξ under the base sampler) absolutely; the
    /// density (n̂·ω)/Ω⊥ relative to its largest value 1/Ω⊥ (the forward
    /// error of the f32 dot product n·ω: near a clipped end, n·ω ≈ 0 is a cancellation, where
    /// its relative error reaches ~2e-6 between two scalings).
    #[test]
    fn prepare_is_homogeneous_in_the_normal() {
        let mut compared = 0;
        for (seg, x, n) in configs() {
            let base = ProjectedSolidAngle::prepare(&seg, x, n).unwrap();
            let psa = base.projected_solid_angle();
            for s in [2f32.powi(-60), 0.5, 1024.0, 0.3, 3.7, 1e30] {
                let p = ProjectedSolidAngle::prepare(&seg, x, n * s).unwrap();
                let exact = s.to_bits() & 0x007f_ffff == 0;
                let mut same = |a: f32, b: f32, scale: f32, what: &str| {
                    if exact {
                        assert_eq!(a.to_bits(), b.to_bits(), "{what}, s = {s:e}: {a} vs {b}");
                    } else {
                        assert!(
                            (a - b).abs() <= 1e-6 * scale,
                            "{what}, s = {s:e}: {a} vs {b} ({:e} of {scale})",
                            (a - b).abs() / scale
                        );
                    }
                    compared += 1;
                };
                same(p.projected_solid_angle(), psa, psa, "Ω⊥");
                for k in 0..3 {
                    same(p.normal()[k], base.normal()[k], 1.0, "normal()");
                }
                for i in 0..=64 {
                    let xi = (i as f32 + 0.01) / 64.02;
                    let (d, d0) = (p.sample(xi), base.sample(xi));
                    if exact {
                        for k in 0..3 {
                            same(d[k], d0[k], 1.0, "sample");
                        }
                    } else {
                        // In the sampler's measure (the base's CDF): a direction moves by
                        // Δξ/pdf, up to 9e-6 here where the density is low.
                        let (u, u0) = (base.inverse(d).unwrap(), base.inverse(d0).unwrap());
                        same(u, u0, 1.0, "sample's ξ");
                    }
                    same(p.pdf(d0), base.pdf(d0), 1.0 / psa, "pdf");
                    let (a, b) = (p.inverse(d0).unwrap(), base.inverse(d0).unwrap());
                    same(a, b, 1.0, "inverse");
                }
            }
        }
        assert_eq!(compared, 5 * (3 * (4 + 65 * 5) + 3 * (4 + 65 * 3)));
        // normal() is normalised in f64: the unit vector of (0, 0, 3.7) is exactly z.
        let (seg, x, _) = configs()[0];
        let p = ProjectedSolidAngle::prepare(&seg, x, Vec3::new(0.0, 0.0, 3.7)).unwrap();
        assert_eq!(p.normal(), Vec3::Z);
    }

    #[test]
    fn degenerate_inputs() {
        let seg = Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        assert!(ProjectedSolidAngle::prepare(&seg, Vec3::ZERO, Vec3::ZERO).is_none());
        assert!(ProjectedSolidAngle::prepare(&seg, Vec3::ZERO, -Vec3::Z).is_none());
        // Shading point on the line.
        assert!(ProjectedSolidAngle::prepare(&seg, Vec3::new(0.0, 0.0, 1.0), Vec3::Z).is_none());
        // Tiny d relative to the segment is still fine and finite.
        let p = ProjectedSolidAngle::prepare(
            &seg,
            Vec3::new(0.0, 0.0, 1.0 - 1e-4),
            Vec3::new(0.3, 0.0, 1.0),
        );
        let p = p.unwrap();
        for i in 0..=100 {
            let (dir, pdf) = p.sample_with_pdf(i as f32 / 100.0);
            assert!(dir.is_finite() && pdf.is_finite());
        }
    }

    /// The f64 solve without the guard inverts the CDF to rounding for every ξ: in the guard
    /// band, at horizon-clipped ends (G' = 0 there: the CDF starts as τ²), on a wide interval
    /// reaching φ ≈ ±π/2 and on a short one. The guarded two-step solve returns the
    /// solid-angle start value in the band, off by a large factor in ξ on the clipped ends.
    #[test]
    fn converged_solve_inverts_the_cdf() {
        use std::f64::consts::FRAC_PI_2;
        // (ψ, φ_b, φ_e) with (n_s, n_t) = (sin ψ, cos ψ): n·ω = cos(φ − ψ).
        let cases = [
            (0.3, 0.3 - FRAC_PI_2, 1.0),               // horizon-clipped begin
            (-0.4, -0.9, FRAC_PI_2 - 0.4),             // horizon-clipped end
            (0.0, 1e-4 - FRAC_PI_2, FRAC_PI_2 - 1e-4), // almost the whole line
            (0.1, 0.2, 0.2003),                        // short
            (1.2, -0.3, 0.4),                          // grazing normal
        ];
        let xis = [
            1e-9, 1e-7, 1e-6, 5e-6, 9.99e-6, 1e-5, 0.3, 0.5, 0.99, 0.99999, 0.999999, 0.9999999,
        ];
        let mut worst_guarded = 0.0f64;
        for (psi, phi_b, phi_e) in cases {
            let (ns, nt) = f64::sin_cos(psi);
            let core = PsaCore::<f64>::from_angles(ns, nt, phi_b, phi_e).unwrap();
            for xi in xis {
                let tau = core.solve_converged(xi);
                assert!((0.0..=core.width).contains(&tau), "{psi} {xi}: τ = {tau}");
                let cdf = core.delta_c(tau) / core.total;
                // Relative to the smaller tail mass ξ or 1 − ξ, plus the rounding of 1 − ξ.
                let tail = xi.min(1.0 - xi);
                let err = (cdf - xi).abs();
                assert!(
                    err <= 1e-9 * tail + 1e-15,
                    "ψ = {psi}, [{phi_b}, {phi_e}], ξ = {xi}: CDF {cdf} (error {err:e})"
                );
                if PsaCore::<f64>::in_guard(xi) {
                    let guarded = core.delta_c(core.solve(xi, DEFAULT_ITERATIONS)) / core.total;
                    worst_guarded = worst_guarded.max((guarded - xi).abs() / tail);
                }
            }
        }
        // The guard's start value is far from the inverse CDF relative to the tail mass.
        assert!(worst_guarded > 0.5, "{worst_guarded}");
        assert_eq!(
            PsaCore::<f64>::from_angles(1.0, 0.0, -0.5, 0.5)
                .unwrap()
                .solve_converged(f64::NAN),
            0.0
        );
    }
}
