// linlight kernels: BRDF importance sampling of linear lights (C. Peters, "BRDF Importance
// Sampling for Linear Lights", HPG 2021), per shading point and light, prepare once and sample
// many times. The one source of the generated GLSL, HLSL, MSL and SPIR-V in ../generated.
//
// Conventions (those of the Rust crate linlight-sampling):
// - A linear light is the segment from `begin` to `end`, an infinitesimally thin cylinder of
//   radius R. Every density is per radius: with respect to dΩ_R = (2/d) ds on the directions
//   toward the line (s = u·ω, d the distance of the shading point to the infinite line), so that
//   R·Ω_R is the tube's solid angle as R → 0. The light's emission enters as K = radiance × R:
//   the estimate of the reflected radiance of one sample ω is K · f(ω) · (n·ω) / pdf(ω).
// - The line frame: u the unit direction of the line, ĉ the unit vector from the shading point to
//   the closest point of the infinite line, l the signed distance along u from that point; a
//   direction toward the line is ω = sin φ·u + cos φ·ĉ with φ = atan2(l, d). An interval of the
//   line is the arc φ ∈ [φ_b, φ_b + Δ]; samples are parametrised by τ = φ − φ_b ∈ [0, Δ].
// - The shading frame of the LTC table: columns x̂, ŷ, n with x̂ = normalize(v − (n·v)n) (any x̂
//   ⊥ n when v ∥ n) and ŷ = n × x̂; the table's A maps shading coordinates to cosine space.
// - `prepare` returns a struct whose `valid` is false when the light cannot contribute (zero
//   length, below the horizon, shading point on the line): then do not sample it. A valid struct
//   samples only directions in its support, with finite positive densities.
//
// Precision: f32 throughout. sin, cos and atan2 are the polynomials below (a few ulp on the
// ranges used), not the built-ins, whose precision WGSL and Vulkan leave to the implementation
// (Vulkan allows 2^-11 absolute for sin and cos): the projected-solid-angle inversion evaluates
// differences of its CDF that are O(Δ²) for an interval of width Δ, and needs sin(τ/2) to full
// relative precision. Coordinates are expected within |·| < 1e18 (squares stay finite).

const LL_PI: f32 = 3.14159265358979;
const LL_HALF_PI_HI: f32 = 1.57079637050628662;
const LL_HALF_PI_LO: f32 = -4.37113900018624e-8;
const LL_QUARTER_PI: f32 = 0.785398163397448;
const LL_TAN_PI_8: f32 = 0.414213562373095;

// Number of Halley steps of the projected-solid-angle inversion (the paper's 2).
const LL_HALLEY_STEPS: u32 = 2u;
// Primary samples within this distance of 0 or 1 return the start value without iterating.
const LL_XI_GUARD: f32 = 1e-5;
// Scale of every reported density (1; the certification's negative control sets 1.01).
const LL_PDF_SCALE: f32 = 1.0;
// The LTC sampler keeps ξ in [2^-25, 1 - 2^-24] (the renderer's lattice of uniforms k·2^-24 never
// samples the end of a support where the density vanishes).
const LL_XI_LATTICE_START: f32 = 2.98023223876953e-8;
const LL_XI_LATTICE_END: f32 = 0.999999940395355;
// Shading points closer to the line than this fraction of the segment's scale see no light.
const LL_MIN_RELATIVE_DISTANCE: f32 = 1e-7;
// A matrix A with ‖A‖³/|det A| beyond this counts as singular (the LTC sampler is then invalid).
const LL_MAX_ILL_CONDITION: f32 = 1e7;

// ---------------------------------------------------------------------------------------------
// Elementary functions.

// (sin x, cos x) for x ∈ [0, π/2]: Taylor polynomials on [0, π/4] (truncation < 4e-10
// relative), the complementary angle above.
fn ll_sin_cos(x: f32) -> vec2f {
    let upper = x > LL_QUARTER_PI;
    let y = select(x, (LL_HALF_PI_HI - x) + LL_HALF_PI_LO, upper);
    let y2 = y * y;
    let s = y * (1.0 - y2 / 6.0 * (1.0 - y2 / 20.0 * (1.0 - y2 / 42.0 * (1.0 - y2 / 72.0
        * (1.0 - y2 / 110.0)))));
    let c = 1.0 - y2 / 2.0 * (1.0 - y2 / 12.0 * (1.0 - y2 / 30.0 * (1.0 - y2 / 56.0
        * (1.0 - y2 / 90.0 * (1.0 - y2 / 132.0)))));
    return select(vec2f(s, c), vec2f(c, s), upper);
}

// atan(a) for a ∈ [0, 1]: the series to a^17 on [0, tan(π/8)] (truncation < 1e-8 relative),
// π/4 + atan((a − 1)/(a + 1)) above.
fn ll_atan_unit(a: f32) -> f32 {
    let upper = a > LL_TAN_PI_8;
    let b = select(a, (a - 1.0) / (a + 1.0), upper);
    let b2 = b * b;
    var p = 1.0 / 17.0;
    p = 1.0 / 15.0 - b2 * p;
    p = 1.0 / 13.0 - b2 * p;
    p = 1.0 / 11.0 - b2 * p;
    p = 1.0 / 9.0 - b2 * p;
    p = 1.0 / 7.0 - b2 * p;
    p = 1.0 / 5.0 - b2 * p;
    p = 1.0 / 3.0 - b2 * p;
    let r = b - b * b2 * p;
    return select(r, LL_QUARTER_PI + r, upper);
}

// atan2(y, x) ∈ [−π, π]; 0 for (0, 0).
fn ll_atan2(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let mx = max(ax, ay);
    let mn = min(ax, ay);
    let a = select(mn / mx, 0.0, mx == 0.0);
    var r = ll_atan_unit(a);
    r = select(r, (LL_HALF_PI_HI - r) + LL_HALF_PI_LO, ay > ax);
    r = select(r, LL_PI - r, x < 0.0);
    return select(r, -r, y < 0.0);
}

// a·b + c·d rounded about once, also where the two products cancel (n·ω at a horizon): both
// products exactly, in 64-bit two's complement fixed point with 60 fraction bits (as (lo, hi)
// words; integer arithmetic, because a compiler may reassociate floating-point sums, as Mesa's
// does, which defeats error-free float transformations). Requires |a·b|, |c·d| < 4; parts of a
// product below 2^-60 are dropped.

// |x| as (24-bit significand, exponent) with |x| = m·2^e, and the sign bit.
fn ll_unpack(x: f32) -> vec3i {
    let bits = bitcast<u32>(x);
    let biased = i32((bits >> 23u) & 0xffu);
    let m = (bits & 0x7fffffu) | select(0u, 0x800000u, biased != 0);
    return vec3i(i32(m), max(biased, 1) - 150, i32(bits >> 31u));
}

// Two's complement of a 64-bit value.
fn ll_fixed_negate(x: vec2u) -> vec2u {
    let lo = ~x.x + 1u;
    return vec2u(lo, ~x.y + select(0u, 1u, lo == 0u));
}

fn ll_fixed_add(x: vec2u, y: vec2u) -> vec2u {
    let lo = x.x + y.x;
    return vec2u(lo, x.y + y.y + select(0u, 1u, lo < x.x));
}

// a·b exactly (up to the dropped bits below 2^-60).
fn ll_fixed_product(a: f32, b: f32) -> vec2u {
    let ua = ll_unpack(a);
    let ub = ll_unpack(b);
    let a1 = u32(ua.x) >> 12u;
    let a0 = u32(ua.x) & 0xfffu;
    let b1 = u32(ub.x) >> 12u;
    let b0 = u32(ub.x) & 0xfffu;
    // The 48-bit product hh·2^24 + mid·2^12 + ll as (lo, hi).
    let hh = a1 * b1;
    let mid = a1 * b0 + a0 * b1;
    var p = ll_fixed_add(vec2u(a0 * b0, 0u), vec2u(mid << 12u, mid >> 20u));
    p = ll_fixed_add(p, vec2u(hh << 24u, hh >> 8u));
    // Scaled to 2^-60 units: shifted left by s = e_a + e_b + 60 (≤ 15 for |a·b| < 4).
    let s = ua.y + ub.y + 60;
    if s > 0 {
        let k = u32(s);
        p = vec2u(p.x << k, (p.y << k) | (p.x >> (32u - k)));
    } else if s < 0 {
        let r = u32(-s);
        if r >= 64u {
            p = vec2u(0u, 0u);
        } else if r >= 32u {
            p = vec2u(p.y >> (r - 32u), 0u);
        } else {
            p = vec2u((p.x >> r) | (p.y << (32u - r)), p.y >> r);
        }
    }
    return select(p, ll_fixed_negate(p), (ua.z ^ ub.z) != 0);
}

fn ll_fixed_to_f32(x: vec2u) -> f32 {
    let negative = (x.y >> 31u) != 0u;
    let m = select(x, ll_fixed_negate(x), negative);
    let v = f32(m.y) * 3.7252902984e-9 + f32(m.x) * 8.6736173799e-19;
    return select(v, -v, negative);
}

fn ll_dot2(a: f32, b: f32, c: f32, d: f32) -> f32 {
    return ll_fixed_to_f32(ll_fixed_add(ll_fixed_product(a, b), ll_fixed_product(c, d)));
}

// ---------------------------------------------------------------------------------------------
// The line seen from a shading point.

// The infinite line through a segment relative to a shading point, restricted to [l_b, l_e].
struct LlFrame {
    u: vec3f,
    c_hat: vec3f,
    d: f32,
    l_b: f32,
    l_e: f32,
    valid: bool,
}

// The frame of the segment [begin, end] seen from x (not clipped). The closest point is formed
// from the endpoint nearer to x (less cancellation in c = p − (a·p/|a|²)a), then made
// orthogonal to u once more.
fn ll_frame(begin: vec3f, end: vec3f, x: vec3f) -> LlFrame {
    var f: LlFrame;
    let b = begin - x;
    let e = end - x;
    let axis = e - b;
    let length2 = dot(axis, axis);
    let length = sqrt(length2);
    f.u = axis / length;
    let from_end = dot(e, e) < dot(b, b);
    let p = select(b, e, from_end);
    var c = p - dot(f.u, p) * f.u;
    c = c - dot(f.u, c) * f.u;
    let d2 = dot(c, c);
    f.d = sqrt(d2);
    f.c_hat = c / f.d;
    // l of the nearer endpoint, the other one at ± the length.
    let lp = dot(f.u, p);
    f.l_b = select(lp, lp - length, from_end);
    f.l_e = select(lp + length, lp, from_end);
    let scale2 = max(length2, max(dot(b, b), dot(e, e)));
    let m = LL_MIN_RELATIVE_DISTANCE;
    f.valid = length2 > 0.0 && d2 > m * m * scale2 && f.l_e > f.l_b && f.d > 0.0;
    return f;
}

// The frame's interval clipped to the half-space n·p ≥ 0 (n need not be unit): the height
// h(l) = d(n·ĉ) + l(n·u) is affine in l.
fn ll_frame_clip(f_in: LlFrame, n: vec3f) -> LlFrame {
    var f = f_in;
    let nc = f.d * dot(n, f.c_hat);
    let nu = dot(n, f.u);
    let hb = nc + f.l_b * nu;
    let he = nc + f.l_e * nu;
    let root = -nc / nu;
    f.l_b = select(f.l_b, max(root, f.l_b), hb < 0.0 && he > 0.0);
    f.l_e = select(f.l_e, min(root, f.l_e), he < 0.0 && hb > 0.0);
    f.valid = f.valid && (hb > 0.0 || he > 0.0) && f.l_e > f.l_b;
    return f;
}

// The frame's interval as an arc: sin φ_b, cos φ_b and Δ, with tan Δ = (l_e − l_b)d/(d² + l_b l_e)
// (no cancellation of φ_e − φ_b); sin φ_e, cos φ_e for the support test at the end.
struct LlArc {
    u: vec3f,
    c_hat: vec3f,
    d: f32,
    s_b: f32,
    c_b: f32,
    width: f32,
    s_e: f32,
    c_e: f32,
}

fn ll_arc(f: LlFrame) -> LlArc {
    var a: LlArc;
    a.u = f.u;
    a.c_hat = f.c_hat;
    a.d = f.d;
    let r_b = sqrt(f.l_b * f.l_b + f.d * f.d);
    a.s_b = f.l_b / r_b;
    a.c_b = f.d / r_b;
    a.width = ll_atan2((f.l_e - f.l_b) * f.d, fma(f.l_b, f.l_e, f.d * f.d));
    let r_e = sqrt(f.l_e * f.l_e + f.d * f.d);
    a.s_e = f.l_e / r_e;
    a.c_e = f.d / r_e;
    return a;
}

// (sin, cos) of φ_b + τ given (sin, cos) of τ.
fn ll_arc_rotate(a: LlArc, sin_tau: f32, cos_tau: f32) -> vec2f {
    return vec2f(a.s_b * cos_tau + a.c_b * sin_tau, a.c_b * cos_tau - a.s_b * sin_tau);
}

// The direction at τ ∈ [0, Δ].
fn ll_arc_direction(a: LlArc, tau: f32) -> vec3f {
    let h = ll_sin_cos(0.5 * clamp(tau, 0.0, a.width));
    let st = ll_arc_rotate(a, 2.0 * h.x * h.y, 1.0 - 2.0 * h.x * h.x);
    return st.x * a.u + max(st.y, 0.0) * a.c_hat;
}

// The angle φ − φ_r of a direction with plane coordinates s = u·ω, t = ĉ·ω from the direction
// (sin φ_r, cos φ_r): accurate to a few ulps of itself near 0 (no cancellation against φ_r).
fn ll_angle_from(s: f32, t: f32, sin_r: f32, cos_r: f32) -> f32 {
    return ll_atan2(s * cos_r - t * sin_r, t * cos_r + s * sin_r);
}

// τ = φ − φ_b of a direction toward the line (its component off the plane of u and ĉ dropped;
// behind the shading point, t < 0, counts as t = 0). Not clamped.
fn ll_arc_tau(a: LlArc, dir: vec3f) -> f32 {
    return ll_angle_from(dot(a.u, dir), max(dot(a.c_hat, dir), 0.0), a.s_b, a.c_b);
}

// Whether a direction points into the arc widened by 2.5e-7 + 1e-6·Δ rad at each end (the
// rounding of an f32 direction and of the arc's own ends; the tolerance of linlight's Rust
// samplers). Each end is tested by the angle from its own direction: τ near Δ, measured from
// φ_b, carries the rounding of Δ and of τ (~ε·Δ), which would move the far end.
fn ll_arc_contains(a: LlArc, dir: vec3f) -> bool {
    let s = dot(a.u, dir);
    let t = dot(a.c_hat, dir);
    let tol = 2.5e-7 + 1e-6 * a.width;
    return t >= 0.0 && ll_angle_from(s, t, a.s_b, a.c_b) >= -tol
        && ll_angle_from(s, t, a.s_e, a.c_e) <= tol;
}

// sin(φ_b + τ) − sin φ_b = 2 sin(τ/2) cos(φ_b + τ/2), without cancellation.
fn ll_arc_delta_s(a: LlArc, tau: f32) -> f32 {
    let h = ll_sin_cos(0.5 * tau);
    return 2.0 * h.x * (a.c_b * h.y - a.s_b * h.x);
}

// ---------------------------------------------------------------------------------------------
// Clipped solid angle sampling: s = u·ω uniform on the horizon-clipped interval, density
// 1/Ω_R = d/(2Δs) per radius.

struct LlClipped {
    arc: LlArc,
    delta_s: f32,
    pdf: f32,
    valid: bool,
}

struct LlSample {
    dir: vec3f,
    pdf: f32,
}

fn ll_clipped_prepare(begin: vec3f, end: vec3f, x: vec3f, n: vec3f) -> LlClipped {
    var c: LlClipped;
    let f = ll_frame_clip(ll_frame(begin, end, x), n);
    c.arc = ll_arc(f);
    c.delta_s = ll_arc_delta_s(c.arc, c.arc.width);
    c.pdf = c.arc.d / (2.0 * c.delta_s);
    c.valid = f.valid && c.arc.width > 0.0 && c.delta_s > 0.0 && c.pdf > 0.0 && c.pdf < 3e38;
    return c;
}

// τ with sin(φ_b + τ) − sin φ_b = y ∈ [0, Δs], without forming asin: q = y(2s_b + y),
// c = √(c_b² − q) = cos(φ_b + τ), sin τ = y c_b + s_b q/(c_b + c), cos τ = c c_b + (s_b + y)s_b.
fn ll_clipped_tau(c: LlClipped, xi: f32) -> f32 {
    let a = c.arc;
    let y = clamp(xi, 0.0, 1.0) * c.delta_s;
    let q = y * (2.0 * a.s_b + y);
    let cc = sqrt(max(a.c_b * a.c_b - q, 0.0));
    let denom = a.c_b + cc;
    let sin_tau = select(y, y * a.c_b + a.s_b * q / denom, denom > 0.0);
    let cos_tau = cc * a.c_b + (a.s_b + y) * a.s_b;
    var tau = clamp(ll_atan2(sin_tau, cos_tau), 0.0, a.width);
    tau = select(tau, 0.0, xi <= 0.0);
    return select(tau, a.width, xi >= 1.0);
}

fn ll_clipped_sample(c: LlClipped, xi: f32) -> LlSample {
    return LlSample(ll_arc_direction(c.arc, ll_clipped_tau(c, xi)), c.pdf * LL_PDF_SCALE);
}

fn ll_clipped_pdf(c: LlClipped, dir: vec3f) -> f32 {
    return select(0.0, c.pdf * LL_PDF_SCALE, ll_arc_contains(c.arc, dir));
}

// ξ of a direction in the support (the CDF): Δs(τ)/Δs.
fn ll_clipped_inverse(c: LlClipped, dir: vec3f) -> f32 {
    let tau = clamp(ll_arc_tau(c.arc, dir), 0.0, c.arc.width);
    return clamp(ll_arc_delta_s(c.arc, tau) / c.delta_s, 0.0, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Projected solid angle sampling (the paper's technique): density (n·ω)/Ω⊥_R on the
// horizon-clipped line. With φ = φ_b + τ, the unnormalised CDF is
// C(φ) = n_s sin²φ + n_t (sin φ cos φ + φ) (n_s = n·u, n_t = n·ĉ), dC/dφ = 2 cos φ (n·ω), and
// Ω⊥_R = [C(φ_e) − C(φ_b)]/d. Sampling solves G(τ) = C(φ_b + τ) − C(φ_b) − ξ·total = 0 from the
// solid-angle sample for the same ξ (the start value) by LL_HALLEY_STEPS steps of Halley's
// irrational formula. Differences of C are evaluated as
//   C(φ_b + τ) − C(φ_b) = 2 cos m sin τ (n·ω)(m) + n_t (τ − sin τ),  m = φ_b + τ/2,
// products of accurate factors, never as a difference of two C values (which cancels for short
// or distant segments); n·ω(φ_b + τ) = p0 cos τ + p1 sin τ with p0, p1 its value and derivative
// at φ_b (no cancellation near a horizon-clipped end).

struct LlPsaCore {
    ns: f32,
    nt: f32,
    s_b: f32,
    c_b: f32,
    // sin φ_e − sin φ_b (the start value's Δs).
    delta_s: f32,
    width: f32,
    p0: f32,
    p1: f32,
    // C(φ_e) − C(φ_b).
    total: f32,
}

// The values at τ that a Halley step needs.
struct LlPsaEval {
    // C(φ_b + τ) − C(φ_b) as its two terms.
    delta_c_cos: f32,
    delta_c_lin: f32,
    // 2 sin φ, 2 cos φ.
    s2: f32,
    t2: f32,
    n_dot_w: f32,
    n_dot_w_prime: f32,
}

struct LlPsa {
    arc: LlArc,
    // The unit normal.
    n: vec3f,
    core: LlPsaCore,
    // d/total = 1/Ω⊥_R.
    inv_psa: f32,
    valid: bool,
}

// δ − sin δ without cancellation: (δ³/6)(1 − δ²/20 + δ⁴/840 − δ⁶/60480 + δ⁸/6652800) for
// |δ| < 1 (truncation < 1e-9 relative), δ − sin δ above.
fn ll_delta_minus_sin(x: f32, sin_x: f32) -> f32 {
    let x2 = x * x;
    let series = x * x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0
        * (1.0 - x2 / 110.0))));
    return select(x - sin_x, series, abs(x) < 1.0);
}

// C(φ_b + τ) − C(φ_b) given (sin, cos) of τ/2, as its two terms.
fn ll_psa_delta_c_parts(c: LlPsaCore, tau: f32, sh: f32, ch: f32) -> vec2f {
    let cm = c.c_b * ch - c.s_b * sh;
    let n_dot_wm = c.p0 * ch + c.p1 * sh;
    let sin_tau = 2.0 * sh * ch;
    return vec2f(cm * n_dot_wm * (2.0 * sin_tau), c.nt * ll_delta_minus_sin(tau, sin_tau));
}

// The core from n_s, n_t, the arc (sin φ_b, cos φ_b, Δ); `total` > 0 iff the interval carries
// projected solid angle.
fn ll_psa_core(ns: f32, nt: f32, s_b: f32, c_b: f32, width: f32) -> LlPsaCore {
    var c: LlPsaCore;
    c.ns = ns;
    c.nt = nt;
    c.s_b = s_b;
    c.c_b = c_b;
    c.width = width;
    // n·ω_b ≥ 0 on the clipped interval (a negative value is rounding).
    c.p0 = max(ll_dot2(ns, s_b, nt, c_b), 0.0);
    c.p1 = ll_dot2(ns, c_b, -nt, s_b);
    let h = ll_sin_cos(0.5 * width);
    c.delta_s = 2.0 * (c_b * h.y - s_b * h.x) * h.x;
    let parts = ll_psa_delta_c_parts(c, width, h.x, h.y);
    c.total = parts.x + parts.y;
    return c;
}

fn ll_psa_eval_half(c: LlPsaCore, tau: f32, sh: f32, ch: f32) -> LlPsaEval {
    var e: LlPsaEval;
    let sin_tau = 2.0 * sh * ch;
    let cos_tau = 1.0 - 2.0 * sh * sh;
    let parts = ll_psa_delta_c_parts(c, tau, sh, ch);
    e.delta_c_cos = parts.x;
    e.delta_c_lin = parts.y;
    e.s2 = 2.0 * c.s_b * cos_tau + 2.0 * c.c_b * sin_tau;
    e.t2 = 2.0 * c.c_b * cos_tau - 2.0 * c.s_b * sin_tau;
    e.n_dot_w = c.p0 * cos_tau + c.p1 * sin_tau;
    e.n_dot_w_prime = c.p1 * cos_tau - c.p0 * sin_tau;
    return e;
}

// The start value: τ of the solid-angle sample for ξ (sin(φ_b + τ) = s_b + ξΔs, without asin),
// and (sin, cos) of τ/2 from the same quantities: the unit vectors at φ_b and φ_b + τ sum to
// w = (c_b + c, 2s_b + y) with |w| = 2 cos(τ/2) and cross product sin τ.
fn ll_psa_start(c: LlPsaCore, xi: f32) -> vec3f {
    let y = xi * c.delta_s;
    let wy = 2.0 * c.s_b + y;
    let q = y * wy;
    let cc = sqrt(max(c.c_b * c.c_b - q, 0.0));
    let denom = c.c_b + cc;
    let scaled = denom > 0.0;
    // atan2 is invariant under the common factor denom > 0.
    let sin_tau = select(y, y * c.c_b * denom + c.s_b * q, scaled);
    let cos_tau = select(1.0, denom, scaled) * (cc * c.c_b + (c.s_b + y) * c.s_b);
    var tau = clamp(ll_atan2(sin_tau, cos_tau), 0.0, c.width);
    tau = select(tau, 0.0, xi <= 0.0);
    tau = select(tau, c.width, xi >= 1.0);
    let w = sqrt(denom * denom + wy * wy);
    let sh = select(select(0.0, 1.0, cos_tau < 0.0), sin_tau / (denom * w), scaled);
    return vec3f(tau, sh, 0.5 * w);
}

// G and the denominator of the Halley step h = −2G/den, den = G' + √(G'² − 2GG'') ≥ 0.
fn ll_psa_halley_terms(c: LlPsaCore, xi: f32, e: LlPsaEval) -> vec2f {
    let g = e.delta_c_cos + (e.delta_c_lin - xi * c.total);
    let g1 = e.t2 * e.n_dot_w;
    let g2 = e.t2 * e.n_dot_w_prime - e.s2 * e.n_dot_w;
    let den = max(g1, 0.0) + sqrt(max(g1 * g1 - g * (2.0 * g2), 0.0));
    return vec2f(g, den);
}

// τ + h clamped to [0, limit] (h = −scale·G/den; den = 0 moves to the end G points to).
fn ll_psa_step(tau: f32, limit: f32, g: f32, den: f32, scale: f32) -> f32 {
    let stepped = clamp(tau - scale * g / den, 0.0, limit);
    let end = select(select(tau, 0.0, g > 0.0), limit, g < 0.0);
    return select(end, stepped, den > 0.0);
}

// τ of the sample for ξ ∈ [0, 1] after `steps` Halley steps (the start value within
// LL_XI_GUARD of 0 or 1).
fn ll_psa_solve(c: LlPsaCore, xi: f32, steps: u32) -> f32 {
    let start = ll_psa_start(c, xi);
    if steps == 0u || xi < LL_XI_GUARD || xi > 1.0 - LL_XI_GUARD {
        return start.x;
    }
    var tau = start.x;
    var e = ll_psa_eval_half(c, tau, start.y, start.z);
    for (var i = 1u; i < steps; i++) {
        let t = ll_psa_halley_terms(c, xi, e);
        let half = ll_psa_step(0.5 * tau, 0.5 * c.width, t.x, t.y, 1.0);
        tau = 2.0 * half;
        let h = ll_sin_cos(half);
        e = ll_psa_eval_half(c, tau, h.x, h.y);
    }
    let t = ll_psa_halley_terms(c, xi, e);
    return ll_psa_step(tau, c.width, t.x, t.y, 2.0);
}

// τ with G(τ) = 0 to the f32 rounding of the CDF, also in the guard band: Halley steps kept
// inside the bracket of the root, bisection where a step would leave it.
fn ll_psa_solve_converged(c: LlPsaCore, xi: f32) -> f32 {
    var lo = 0.0;
    var hi = c.width;
    var tau = ll_psa_start(c, xi).x;
    for (var i = 0u; i < 24u; i++) {
        let h = ll_sin_cos(0.5 * tau);
        let e = ll_psa_eval_half(c, tau, h.x, h.y);
        let t = ll_psa_halley_terms(c, xi, e);
        lo = select(lo, tau, t.x < 0.0);
        hi = select(hi, tau, t.x > 0.0);
        let next = ll_psa_step(tau, c.width, t.x, t.y, 2.0);
        let inside = next > lo && next < hi;
        let converged = abs(next - tau) <= 2.4e-7 * tau || t.x == 0.0;
        tau = select(0.5 * (lo + hi), next, inside);
        if converged {
            break;
        }
    }
    return select(select(tau, c.width, xi >= 1.0), 0.0, xi <= 0.0);
}

// The exact CDF at τ (clamped to the interval).
fn ll_psa_cdf(c: LlPsaCore, tau: f32) -> f32 {
    let t = clamp(tau, 0.0, c.width);
    let h = ll_sin_cos(0.5 * t);
    let parts = ll_psa_delta_c_parts(c, t, h.x, h.y);
    return clamp((parts.x + parts.y) / c.total, 0.0, 1.0);
}

// Prepare on an already clipped frame with the unit normal n.
fn ll_psa_on_frame(f: LlFrame, n: vec3f) -> LlPsa {
    var p: LlPsa;
    p.arc = ll_arc(f);
    p.n = n;
    p.core = ll_psa_core(dot(n, f.u), dot(n, f.c_hat), p.arc.s_b, p.arc.c_b, p.arc.width);
    p.inv_psa = f.d / p.core.total;
    p.valid = f.valid && p.arc.width > 0.0 && p.core.total > 0.0 && p.inv_psa > 0.0
        && p.inv_psa < 3e38;
    return p;
}

// Prepare for the segment [begin, end], shading point x and normal n (any length > 0).
fn ll_psa_prepare(begin: vec3f, end: vec3f, x: vec3f, n: vec3f) -> LlPsa {
    let nn = normalize(n);
    return ll_psa_on_frame(ll_frame_clip(ll_frame(begin, end, x), nn), nn);
}

// The direction at τ and its density.
fn ll_psa_at(p: LlPsa, tau: f32) -> LlSample {
    let c = p.core;
    let h = ll_sin_cos(0.5 * tau);
    let st = 2.0 * h.x * h.y;
    let ct = 1.0 - 2.0 * h.x * h.x;
    let sc = ll_arc_rotate(p.arc, st, ct);
    let n_dot_w = c.p0 * ct + c.p1 * st;
    let dir = sc.x * p.arc.u + max(sc.y, 0.0) * p.arc.c_hat;
    return LlSample(dir, max(n_dot_w, 0.0) * p.inv_psa * LL_PDF_SCALE);
}

fn ll_psa_sample(p: LlPsa, xi: f32) -> LlSample {
    return ll_psa_at(p, ll_psa_solve(p.core, clamp(xi, 0.0, 1.0), LL_HALLEY_STEPS));
}

// (n·ω)⁺/Ω⊥_R without the support test: the MIS cross density of a sample known to lie on the
// horizon-clipped line (an LTC sample).
fn ll_psa_density_in_support(p: LlPsa, dir: vec3f) -> f32 {
    return max(dot(p.n, dir), 0.0) * p.inv_psa * LL_PDF_SCALE;
}

fn ll_psa_pdf(p: LlPsa, dir: vec3f) -> f32 {
    return select(0.0, ll_psa_density_in_support(p, dir), ll_arc_contains(p.arc, dir));
}

// ξ of a direction in the support (the CDF).
fn ll_psa_inverse(p: LlPsa, dir: vec3f) -> f32 {
    return ll_psa_cdf(p.core, ll_arc_tau(p.arc, dir));
}

// ---------------------------------------------------------------------------------------------
// LTC line sampling: a linearly transformed cosine restricted to the line. A (shading → cosine
// space) maps ω to ω_o = Aω/|Aω|; the line is clipped at the horizon of n and at the lobe's own
// horizon (Aω)_z ≥ 0, transformed, and sampled there by projected solid angle with normal
// (0, 0, 1). Density per radius of the original line:
//   p(ω) = κ |det A| / Ω⊥_o · max(0, (Aω)_z) / |Aω|⁴,  κ = |A⁻ᵀ m|/|m|,
// m the normal of the plane through x and the line (in shading coordinates): the tube of radius R
// maps onto one of radius R/κ, and solid angle maps with |det A|/|Aω|³.

struct LlLtc {
    // The original line restricted to where the density is positive.
    arc: LlArc,
    to_shading: mat3x3f,
    a: mat3x3f,
    // Cosine space → world: shading frame · A⁻¹.
    to_world: mat3x3f,
    transformed: LlPsa,
    kappa: f32,
    // κ |det A| / Ω⊥_o.
    scale: f32,
    valid: bool,
}

// One entry of the GGX table: A (shading → cosine space) and the albedo ρ_s of the lobe (F = 1).
struct LlLtcEntry {
    a: mat3x3f,
    rho: f32,
}

// The shading frame (columns x̂, ŷ, n) for the unit normal n and the unit direction v to the
// viewer.
fn ll_shading_frame(n: vec3f, v: vec3f) -> mat3x3f {
    let t = v - dot(n, v) * n;
    let len = length(t);
    // Any unit vector ⊥ n (Duff et al. 2017) where v ∥ n.
    let sgn = select(-1.0, 1.0, n.z >= 0.0);
    let k = -1.0 / (sgn + n.z);
    let any = vec3f(n.x * n.y * k, sgn + n.y * n.y * k, -n.y);
    let xh = select(any, t / len, len > 1e-7);
    return mat3x3f(xh, cross(n, xh), n);
}

// The inverse of a 3×3 matrix with determinant `det` (columns from cross products).
fn ll_inverse3(m: mat3x3f, det: f32) -> mat3x3f {
    let r = transpose(mat3x3f(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    return r * (1.0 / det);
}

fn ll_ltc_prepare(begin: vec3f, end: vec3f, x: vec3f, shading_frame: mat3x3f, a: mat3x3f)
    -> LlLtc {
    var l: LlLtc;
    let det = determinant(a);
    var norm = 0.0;
    for (var i = 0; i < 3; i++) {
        norm = max(norm, max(abs(a[i].x), max(abs(a[i].y), abs(a[i].z))));
    }
    let conditioned = abs(det) * LL_MAX_ILL_CONDITION > norm * norm * norm;
    let a_inv = ll_inverse3(a, det);
    let n = normalize(shading_frame[2]);
    l.to_shading = transpose(shading_frame);
    l.a = a;
    l.to_world = shading_frame * a_inv;
    let frame = ll_frame(begin, end, x);
    // (A Fᵀ p)_z = (F · row₂(A)) · p: the lobe's horizon as a plane in world space.
    let lobe_normal = shading_frame * vec3f(a[0].z, a[1].z, a[2].z);
    let support = ll_frame_clip(ll_frame_clip(frame, n), lobe_normal);
    l.arc = ll_arc(support);
    let to_cosine = a * l.to_shading;
    let pb = to_cosine * (support.d * support.c_hat + support.l_b * support.u);
    let pe = to_cosine * (support.d * support.c_hat + support.l_e * support.u);
    let up = vec3f(0.0, 0.0, 1.0);
    l.transformed = ll_psa_on_frame(ll_frame_clip(ll_frame(pb, pe, vec3f(0.0)), up), up);
    let m = cross(l.to_shading * frame.u, l.to_shading * frame.c_hat);
    l.kappa = length(transpose(a_inv) * m) / length(m);
    l.scale = l.kappa * abs(det) * l.transformed.inv_psa;
    l.valid = conditioned && det != 0.0 && support.valid && l.transformed.valid
        && l.kappa > 0.0 && l.kappa < 3e38 && l.scale > 0.0 && l.scale < 3e38;
    return l;
}

// The density without the support test (the MIS cross density of a projected-solid-angle
// sample, which lies on the horizon-clipped line): 0 where the lobe is below its own horizon.
fn ll_ltc_density_on_clipped_line(l: LlLtc, dir: vec3f) -> f32 {
    let aw = l.a * (l.to_shading * dir);
    let len2 = dot(aw, aw);
    let p = l.scale * max(aw.z, 0.0) / (len2 * len2);
    return select(0.0, p * LL_PDF_SCALE, len2 > 0.0 && p < 3e38);
}

fn ll_ltc_pdf(l: LlLtc, dir: vec3f) -> f32 {
    return select(0.0, ll_ltc_density_on_clipped_line(l, dir), ll_arc_contains(l.arc, dir));
}

// τ_o of the transformed sampler for ξ (the converged solve in the guard band, where A⁻¹ may
// spread the last 1e-5 of the mass over a wide part of the line).
fn ll_ltc_tau_o(l: LlLtc, xi: f32) -> f32 {
    let core = l.transformed.core;
    if xi < LL_XI_GUARD || xi > 1.0 - LL_XI_GUARD {
        return ll_psa_solve_converged(core, xi);
    }
    return ll_psa_solve(core, xi, LL_HALLEY_STEPS);
}

fn ll_ltc_sample(l: LlLtc, xi_in: f32) -> LlSample {
    let xi = clamp(xi_in, LL_XI_LATTICE_START, LL_XI_LATTICE_END);
    let w_o = ll_psa_at(l.transformed, ll_ltc_tau_o(l, xi)).dir;
    // Mapped back and snapped onto the original support.
    let w = normalize(l.to_world * w_o);
    let dir = ll_arc_direction(l.arc, ll_arc_tau(l.arc, w));
    return LlSample(dir, ll_ltc_density_on_clipped_line(l, dir));
}

// ξ of a direction in the support: the transformed sampler's CDF at its image.
fn ll_ltc_inverse(l: LlLtc, dir: vec3f) -> f32 {
    let w_o = normalize(l.a * (l.to_shading * dir));
    return ll_psa_inverse(l.transformed, w_o);
}

// The MIS technique weight scale Ω⊥_o/κ of the lobe (W_s = ρ_s · Ω⊥_o/κ).
fn ll_ltc_weight_scale(l: LlLtc) -> f32 {
    return 1.0 / (l.transformed.inv_psa * l.kappa);
}

// ---------------------------------------------------------------------------------------------
// The fitted GGX table: records of 8 f32 (a, b, c, d, e, ρ_s, E₁, 0) for an N×N grid, record
// j·N + i for √α = i/(N − 1) and θ_o = j/(N − 1)·π/2, A with rows [[a, 0, b], [0, c, 0],
// [d, 0, e]]; bilinear interpolation with clamp to edge.

// acos(c) for c ∈ [0, 1] (Abramowitz & Stegun 4.4.46, |error| ≤ 2e-8 rad).
fn ll_acos_unit(c: f32) -> f32 {
    var p = -0.0012624911;
    p = p * c + 0.0066700901;
    p = p * c - 0.0170881256;
    p = p * c + 0.0308918810;
    p = p * c - 0.0501743046;
    p = p * c + 0.0889789874;
    p = p * c - 0.2145988016;
    p = p * c + 1.5707963050;
    return sqrt(max(1.0 - c, 0.0)) * p;
}

fn ll_ltc_record(k: u32, lane: u32) -> f32 {
    return ll_ltc_table[8u * k + lane];
}

// Lane `lane` of the records at the four corners, weighted (bilinear interpolation).
fn ll_ltc_lerp(corners: vec4u, w: vec4f, lane: u32) -> f32 {
    return w.x * ll_ltc_record(corners.x, lane) + w.y * ll_ltc_record(corners.y, lane)
        + w.z * ll_ltc_record(corners.z, lane) + w.w * ll_ltc_record(corners.w, lane);
}

// A and ρ_s for roughness α and cos θ_o = n·v.
fn ll_ltc_lookup(alpha: f32, cos_theta_v: f32) -> LlLtcEntry {
    let size = u32(round(sqrt(f32(arrayLength(&ll_ltc_table) / 8u))));
    let last = f32(size - 1u);
    let x = sqrt(clamp(alpha, 0.0, 1.0)) * last;
    let y = min(ll_acos_unit(clamp(cos_theta_v, 0.0, 1.0)) * (2.0 / LL_PI) * last, last);
    let i = min(u32(x), size - 2u);
    let j = min(u32(y), size - 2u);
    let fx = x - f32(i);
    let fy = y - f32(j);
    let base = j * size + i;
    let w = vec4f((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    let corners = vec4u(base, base + 1u, base + size, base + size + 1u);
    var e: LlLtcEntry;
    e.a = mat3x3f(
        vec3f(ll_ltc_lerp(corners, w, 0u), 0.0, ll_ltc_lerp(corners, w, 3u)),
        vec3f(0.0, ll_ltc_lerp(corners, w, 2u), 0.0),
        vec3f(ll_ltc_lerp(corners, w, 1u), 0.0, ll_ltc_lerp(corners, w, 4u)),
    );
    e.rho = ll_ltc_lerp(corners, w, 5u);
    return e;
}

// ---------------------------------------------------------------------------------------------
// MIS weights of a sample of technique s (density p_s) where the other technique has density
// p_o, both per radius; w_s, w_o the technique weights of the weighted heuristics. 0 when both
// densities vanish; the two techniques' weights sum to 1 whenever p_s + p_o > 0.

fn ll_mis_ratio(a: f32, b: f32) -> f32 {
    return select(0.0, clamp(a / b, 0.0, 1.0), b > 0.0);
}

fn ll_mis_balance(p_s: f32, p_o: f32) -> f32 {
    let m = max(p_s, p_o);
    return select(0.0, ll_mis_ratio(p_s / m, p_s / m + p_o / m), m > 0.0);
}

// β = 2.
fn ll_mis_power(p_s: f32, p_o: f32) -> f32 {
    let m = max(p_s, p_o);
    let a = p_s / m;
    let b = p_o / m;
    return select(0.0, ll_mis_ratio(a * a, a * a + b * b), m > 0.0);
}

fn ll_mis_weighted_balance(p_s: f32, p_o: f32, w_s: f32, w_o: f32) -> f32 {
    let m = max(p_s, p_o);
    let num = w_s * (p_s / m);
    let den = num + w_o * (p_o / m);
    let weighted = select(ll_mis_balance(p_s, p_o), ll_mis_ratio(num, den), den > 0.0
        && den < 3e38);
    return select(0.0, weighted, m > 0.0);
}

// The paper's clamped optimal heuristic: (1 − v)·balance + v·weighted balance, v ∈ [0, 1] a
// visibility estimate (0.5 in the paper).
fn ll_mis_clamped_optimal(p_s: f32, p_o: f32, w_s: f32, w_o: f32, v_in: f32) -> f32 {
    let v = clamp(v_in, 0.0, 1.0);
    return (1.0 - v) * ll_mis_balance(p_s, p_o) + v * ll_mis_weighted_balance(p_s, p_o, w_s, w_o);
}

// ---------------------------------------------------------------------------------------------
// Entry points: `certify` answers batches of queries for the certification of these functions,
// `bench` shades a frame of cached shading points. A renderer copies the functions above and
// binds its own LTC table as `ll_ltc_table`.

struct LlParams {
    // certify: 0 clipped, 1 projected solid angle, 2 LTC, 3 the PSA inversion alone, 4 MIS.
    // bench: 0 clipped, 1 projected solid angle, 2 LTC + projected solid angle with MIS.
    mode: u32,
    count: u32,
    // bench: samples per shading point.
    samples: u32,
    // certify: Halley steps of mode 3.
    steps: u32,
    light_begin: vec4f,
    // w: K = radiance × radius.
    light_end: vec4f,
}

@group(0) @binding(0) var<uniform> ll_params: LlParams;
@group(0) @binding(1) var<storage, read> ll_queries: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> ll_answers: array<vec4f>;
@group(0) @binding(3) var<storage, read> ll_ltc_table: array<f32>;

// certify: a query is 9 vec4f, an answer 3.
//   q0 = (begin, ξ), q1 = (end, α), q2 = (x, cos θ_o), q3 = (n, 0), q4 = (view, 0),
//   q5 = (probe direction, 0), q6..q8 = the rows of the LTC matrix A (shading → cosine space).
//   modes 0-2 (clipped, PSA, LTC): a0 = (sample direction, its density), a1 = (ξ of the
//   sample by the inverse, 1 if prepared else 0, pdf of the probe, cross density of the probe),
//   a2 = (LTC: Ω⊥_o/κ, 0, 0, 0).
//   mode 3: q0 = (n_s, n_t, sin φ_b, ξ), q1 = (cos φ_b, Δ, 0, 0) → a0 = (τ, C(φ_e) − C(φ_b),
//   n·ω_b, d(n·ω)/dφ at φ_b).
//   mode 4: q0 = (p_s, p_o, w_s, w_o), q1.x = v → a0 = (balance, power, weighted, clamped).
//   mode 5: the table lookup at α = q1.w, cos θ_o = q2.w → a0 = (a, b, c, d), a1 = (e, ρ_s, 0, 0).
@compute @workgroup_size(64)
fn certify(@builtin(global_invocation_id) gid: vec3u) {
    let k = gid.x;
    if k >= ll_params.count {
        return;
    }
    let q0 = ll_queries[9u * k];
    let q1 = ll_queries[9u * k + 1u];
    let q2 = ll_queries[9u * k + 2u];
    let q3 = ll_queries[9u * k + 3u];
    let q4 = ll_queries[9u * k + 4u];
    let q5 = ll_queries[9u * k + 5u];
    var a0 = vec4f(0.0);
    var a1 = vec4f(0.0);
    var a2 = vec4f(0.0);
    let xi = q0.w;
    switch ll_params.mode {
        case 0u: {
            let c = ll_clipped_prepare(q0.xyz, q1.xyz, q2.xyz, q3.xyz);
            if c.valid {
                let s = ll_clipped_sample(c, xi);
                let probe = ll_clipped_pdf(c, q5.xyz);
                a0 = vec4f(s.dir, s.pdf);
                a1 = vec4f(ll_clipped_inverse(c, s.dir), 1.0, probe, probe);
            }
        }
        case 1u: {
            let p = ll_psa_prepare(q0.xyz, q1.xyz, q2.xyz, q3.xyz);
            if p.valid {
                let s = ll_psa_sample(p, xi);
                a0 = vec4f(s.dir, s.pdf);
                a1 = vec4f(ll_psa_inverse(p, s.dir), 1.0, ll_psa_pdf(p, q5.xyz),
                    ll_psa_density_in_support(p, q5.xyz));
            }
        }
        case 2u: {
            let a = transpose(mat3x3f(ll_queries[9u * k + 6u].xyz, ll_queries[9u * k + 7u].xyz,
                ll_queries[9u * k + 8u].xyz));
            let frame = ll_shading_frame(normalize(q3.xyz), normalize(q4.xyz));
            let l = ll_ltc_prepare(q0.xyz, q1.xyz, q2.xyz, frame, a);
            if l.valid {
                let s = ll_ltc_sample(l, xi);
                a0 = vec4f(s.dir, s.pdf);
                a1 = vec4f(ll_ltc_inverse(l, s.dir), 1.0, ll_ltc_pdf(l, q5.xyz),
                    ll_ltc_density_on_clipped_line(l, q5.xyz));
                a2 = vec4f(ll_ltc_weight_scale(l), 0.0, 0.0, 0.0);
            }
        }
        case 3u: {
            let c = ll_psa_core(q0.x, q0.y, q0.z, q1.x, q1.y);
            a0 = vec4f(ll_psa_solve(c, q0.w, ll_params.steps), c.total, c.p0, c.p1);
        }
        case 4u: {
            a0 = vec4f(ll_mis_balance(q0.x, q0.y), ll_mis_power(q0.x, q0.y),
                ll_mis_weighted_balance(q0.x, q0.y, q0.z, q0.w),
                ll_mis_clamped_optimal(q0.x, q0.y, q0.z, q0.w, q1.x));
        }
        case 5u: {
            let e = ll_ltc_lookup(q1.w, q2.w);
            a0 = vec4f(e.a[0].x, e.a[2].x, e.a[1].y, e.a[0].z);
            a1 = vec4f(e.a[2].z, e.rho, 0.0, 0.0);
        }
        default: {}
    }
    ll_answers[3u * k] = a0;
    ll_answers[3u * k + 1u] = a1;
    ll_answers[3u * k + 2u] = a2;
}

// The k-th of the frame's uniforms of one shading point: a rank-1 lattice (golden ratio) with
// a per-pixel offset from an integer hash.
fn ll_bench_xi(pixel: u32, k: u32) -> f32 {
    var h = pixel * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return fract(f32(h >> 8u) * 5.9604645e-8 + f32(k) * 0.618034);
}

// bench: one invocation per cached shading point (3 vec4f: (x, α), (n, 0), (v, ρ_d)); the
// reflected radiance estimate from the light (segment in the params, K in light_end.w) with
// `samples` samples, written to ll_answers[pixel].x. The diffuse BRDF is ρ_d/π; in mode 2 the
// specular lobe is its LTC (f·cos = ρ_s times the LTC density), each technique weighted by the
// clamped optimal heuristic (v = 0.5). No visibility.
@compute @workgroup_size(64)
fn bench(@builtin(global_invocation_id) gid: vec3u) {
    let pixel = gid.x;
    if pixel >= ll_params.count {
        return;
    }
    let q0 = ll_queries[3u * pixel];
    let q1 = ll_queries[3u * pixel + 1u];
    let q2 = ll_queries[3u * pixel + 2u];
    let x = q0.xyz;
    let n = q1.xyz;
    let rho_d = q2.w;
    let lb = ll_params.light_begin.xyz;
    let le = ll_params.light_end.xyz;
    let big_k = ll_params.light_end.w;
    var sum = 0.0;
    let count = ll_params.samples;
    switch ll_params.mode {
        case 0u: {
            let c = ll_clipped_prepare(lb, le, x, n);
            if c.valid {
                for (var k = 0u; k < count; k++) {
                    let s = ll_clipped_sample(c, ll_bench_xi(pixel, k));
                    sum += rho_d / LL_PI * max(dot(n, s.dir), 0.0) / s.pdf;
                }
            }
        }
        case 1u: {
            let p = ll_psa_prepare(lb, le, x, n);
            if p.valid {
                for (var k = 0u; k < count; k++) {
                    let s = ll_psa_sample(p, ll_bench_xi(pixel, k));
                    sum += rho_d / LL_PI * max(dot(n, s.dir), 0.0) / s.pdf;
                }
            }
        }
        case 2u: {
            let p = ll_psa_prepare(lb, le, x, n);
            let v = q2.xyz;
            let entry = ll_ltc_lookup(q0.w, dot(n, v));
            let l = ll_ltc_prepare(lb, le, x, ll_shading_frame(n, v), entry.a);
            if p.valid {
                let w_d = max(rho_d, 0.01) / p.inv_psa;
                let w_s = select(0.0, entry.rho * ll_ltc_weight_scale(l), l.valid);
                for (var k = 0u; k < count; k++) {
                    let xi = ll_bench_xi(pixel, k);
                    let sd = ll_psa_sample(p, xi);
                    let ps = select(0.0, ll_ltc_density_on_clipped_line(l, sd.dir), l.valid);
                    let fd = rho_d / LL_PI * max(dot(n, sd.dir), 0.0) + entry.rho * ps;
                    sum += fd * ll_mis_clamped_optimal(sd.pdf, ps, w_d, w_s, 0.5) / sd.pdf;
                    if l.valid {
                        let ss = ll_ltc_sample(l, fract(xi + 0.5));
                        let pd = ll_psa_density_in_support(p, ss.dir);
                        let fs = rho_d / LL_PI * max(dot(n, ss.dir), 0.0) + entry.rho * ss.pdf;
                        sum += fs * ll_mis_clamped_optimal(ss.pdf, pd, w_s, w_d, 0.5) / ss.pdf;
                    }
                }
            }
        }
        default: {}
    }
    ll_answers[pixel] = vec4f(big_k * sum / f32(max(count, 1u)), 0.0, 0.0, 0.0);
}
