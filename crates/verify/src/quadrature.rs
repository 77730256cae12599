//! Gauss–Legendre quadrature in f64, fixed and adaptive.
//!
//! The chi-square suite integrates sampler densities (evaluated in f32) over intervals of
//! φ = asin s. Densities may jump inside an interval (LTC: horizon clip inside the support), so
//! the adaptive rule bisects where a panel and its two halves disagree. The acceptance test is
//! relative to the panel's own |f| integral, which keeps f32 evaluation noise (~1e-7 relative)
//! from forcing endless refinement, and a depth cap bounds the work spent at a jump.

/// Nodes and weights of the n-point Gauss–Legendre rule on [−1, 1].
#[derive(Clone, Debug)]
pub struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    /// The n-point rule (n ≥ 1), nodes found by Newton's method on P_n from the Chebyshev guess.
    pub fn new(n: usize) -> Self {
        let n = n.max(1);
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        let nf = n as f64;
        for i in 0..n.div_ceil(2) {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                // (p1, p0) = (P_n, P_{n−1}), also for n = 1.
                dp = nf * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            nodes[i] = -x;
            nodes[n - 1 - i] = x;
            weights[i] = w;
            weights[n - 1 - i] = w;
        }
        if n % 2 == 1 {
            // The middle node is exactly 0 (Newton may leave ~1e-17).
            nodes[n / 2] = 0.0;
        }
        Self { nodes, weights }
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// ∫_a^b f and ∫_a^b |f| with this rule.
    pub fn integrate(&self, a: f64, b: f64, f: &mut impl FnMut(f64) -> f64) -> Panel {
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        let (mut value, mut abs) = (0.0, 0.0);
        for (x, w) in self.nodes.iter().zip(&self.weights) {
            let y = f(mid + half * x);
            value += w * y;
            abs += w * y.abs();
        }
        Panel { value: value * half, abs: abs * half.abs() }
    }
}

/// Result of a quadrature rule on one interval.
#[derive(Clone, Copy, Debug, Default)]
pub struct Panel {
    pub value: f64,
    pub abs: f64,
}

/// Adaptive Gauss–Legendre integration: bisect until a panel's two halves agree with it, twice
/// in a row.
#[derive(Clone, Debug)]
pub struct Adaptive {
    rule: GaussLegendre,
    /// Accept a panel when |halves − whole| ≤ `relative` · ∫|f| over the panel.
    pub relative: f64,
    /// Maximum bisection depth below the starting interval.
    pub max_depth: u32,
}

/// Result of an adaptive integration: value, ∫|f|, number of f evaluations and whether every
/// panel met the tolerance before the depth cap.
#[derive(Clone, Copy, Debug, Default)]
pub struct AdaptiveResult {
    pub value: f64,
    pub abs: f64,
    pub evaluations: usize,
    pub converged: bool,
}

impl Adaptive {
    /// `nodes`-point rule per panel.
    pub fn new(nodes: usize, relative: f64, max_depth: u32) -> Self {
        Self { rule: GaussLegendre::new(nodes), relative, max_depth }
    }

    pub fn nodes(&self) -> usize {
        self.rule.len()
    }

    /// ∫_a^b f. The first panel is [a, b] itself.
    pub fn integrate(&self, a: f64, b: f64, f: &mut impl FnMut(f64) -> f64) -> AdaptiveResult {
        let whole = self.rule.integrate(a, b, f);
        let mut out = AdaptiveResult {
            value: 0.0,
            abs: 0.0,
            evaluations: self.rule.len(),
            converged: true,
        };
        self.refine(a, b, whole, 0, false, f, &mut out);
        out
    }

    fn refine(
        &self,
        a: f64,
        b: f64,
        whole: Panel,
        depth: u32,
        parent_agreed: bool,
        f: &mut impl FnMut(f64) -> f64,
        out: &mut AdaptiveResult,
    ) {
        let m = 0.5 * (a + b);
        let left = self.rule.integrate(a, m, f);
        let right = self.rule.integrate(m, b, f);
        out.evaluations += 2 * self.rule.len();
        let value = left.value + right.value;
        let abs = left.abs + right.abs;
        let agree = (value - whole.value).abs() <= self.relative * abs;
        // Panels of (nearly) zero width cannot be split further in f64.
        let splittable = m > a && m < b;
        // Accept only after two consecutive levels agree: at a jump, a panel and its halves can
        // agree by coincidence (the rule's error depends on where the jump sits), two levels
        // in a row practically never.
        if (agree && parent_agreed) || !splittable || depth >= self.max_depth {
            out.value += value;
            out.abs += abs;
            out.converged &= agree || !splittable;
            return;
        }
        self.refine(a, m, left, depth + 1, agree, f, out);
        self.refine(m, b, right, depth + 1, agree, f, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rule_is_exact_for_polynomials_up_to_degree_2n_minus_1() {
        for n in 1..=12 {
            let gl = GaussLegendre::new(n);
            let wsum: f64 = gl.weights.iter().sum();
            assert!((wsum - 2.0).abs() < 1e-13, "n={n}: Σw = {wsum}");
            for k in 0..(2 * n) {
                let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
                let got = gl.integrate(-1.0, 1.0, &mut |x: f64| x.powi(k as i32)).value;
                assert!((got - exact).abs() < 1e-13, "n={n} k={k}: {got} vs {exact}");
            }
            // Degree 2n is not integrated exactly (the rule has no more accuracy than claimed).
            let k = 2 * n;
            let exact = 2.0 / (k as f64 + 1.0);
            let got = gl.integrate(-1.0, 1.0, &mut |x: f64| x.powi(k as i32)).value;
            assert!((got - exact).abs() > 1e-12, "n={n}: degree {k} exact?");
        }
    }

    #[test]
    fn known_eight_point_node() {
        let gl = GaussLegendre::new(8);
        assert!((gl.nodes[7] - 0.960_289_856_497_536_2).abs() < 1e-15);
        assert!((gl.weights[7] - 0.101_228_536_290_376_26).abs() < 1e-15);
    }

    #[test]
    fn adaptive_handles_a_jump() {
        // Step at an irrational point: 1 on [0, 1/√2), 3 on [1/√2, 1].
        let jump = std::f64::consts::FRAC_1_SQRT_2;
        let q = Adaptive::new(8, 1e-9, 60);
        let r = q.integrate(0.0, 1.0, &mut |x: f64| if x < jump { 1.0 } else { 3.0 });
        let exact = jump + 3.0 * (1.0 - jump);
        assert!((r.value - exact).abs() < 1e-9, "{} vs {exact}", r.value);
        // One chain of panels per level: far fewer evaluations than uniform refinement.
        assert!(r.evaluations < 4000, "{}", r.evaluations);
    }

    #[test]
    fn adaptive_smooth_function_converges_at_once() {
        let q = Adaptive::new(8, 1e-9, 30);
        let r = q.integrate(0.0, 1.0, &mut |x: f64| x.cos());
        assert!((r.value - 1f64.sin()).abs() < 1e-14);
        assert!(r.converged);
        // Whole, halves, quarters.
        assert_eq!(r.evaluations, 8 + 16 + 32);
    }
}
