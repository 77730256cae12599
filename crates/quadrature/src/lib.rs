//! Gauss–Legendre quadrature in f64, fixed and adaptive.
//!
//! Its own crate so that the ground truths built on it (the LTC moments of linlight-brdf's
//! tests, the line integrals of `linlight ground_truth`, the chi-square suite of linlight-verify)
//! depend on nothing of the code they check.
//!
//! The chi-square suite integrates sampler densities (evaluated in f32) over intervals of
//! φ = asin s. Densities may jump inside an interval (LTC: horizon clip inside the support), so
//! the adaptive rule bisects where a panel and its two halves disagree. The acceptance test is
//! relative to the panel's own |f| integral, which keeps f32 evaluation noise (~1e-7 relative)
//! from forcing endless refinement, and a depth cap bounds the work spent at a jump.

/// Nodes and weights of a quadrature rule on [−1, 1] (Gauss–Legendre by default).
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

    /// (node, weight) pairs on [−1, 1]: for integrating several functions on the same nodes.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.nodes.iter().copied().zip(self.weights.iter().copied())
    }

    /// ∫_a^b f and ∫_a^b |f| with this rule.
    pub fn integrate(&self, a: f64, b: f64, f: &mut impl FnMut(f64) -> f64) -> Panel {
        self.integrate_batch(a, b, &mut one_at_a_time(f))
    }

    /// [`GaussLegendre::integrate`] of a batch integrand: `f(ts, ys)` sets ys\[i\] = f(ts\[i\])
    /// for up to [`BATCH`] nodes at a time, in node order. The same nodes and sums.
    pub fn integrate_batch(&self, a: f64, b: f64, f: &mut impl FnMut(&[f64], &mut [f64])) -> Panel {
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        let (mut value, mut abs) = (0.0, 0.0);
        let (mut ts, mut ys) = ([0.0; BATCH], [0.0; BATCH]);
        for (nodes, weights) in self.nodes.chunks(BATCH).zip(self.weights.chunks(BATCH)) {
            let n = nodes.len();
            for (t, x) in ts.iter_mut().zip(nodes) {
                *t = mid + half * x;
            }
            f(&ts[..n], &mut ys[..n]);
            for (w, y) in weights.iter().zip(&ys[..n]) {
                value += w * y;
                abs += w * y.abs();
            }
        }
        Panel {
            value: value * half,
            abs: abs * half.abs(),
        }
    }
}

/// Nodes per call of a batch integrand ([`GaussLegendre::integrate_batch`]).
pub const BATCH: usize = 16;

/// A batch integrand that evaluates `f` node by node.
fn one_at_a_time(f: &mut impl FnMut(f64) -> f64) -> impl FnMut(&[f64], &mut [f64]) + '_ {
    |ts, ys| {
        for (t, y) in ts.iter().zip(ys) {
            *y = f(*t);
        }
    }
}

/// The n-point Gauss–Lobatto rule on [−1, 1] (n ≥ 3): both endpoints and the roots of
/// P'_{n−1}; exact for polynomials of degree 2n − 3.
pub fn gauss_lobatto(n: usize) -> GaussLegendre {
    let n = n.max(3);
    let m = n - 1; // P_m
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    let legendre = |x: f64| {
        // (P_m, P_{m−1}) at x.
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=m {
            let kf = k as f64;
            let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
            p0 = p1;
            p1 = p2;
        }
        (p1, p0)
    };
    let mf = m as f64;
    nodes[0] = -1.0;
    nodes[n - 1] = 1.0;
    for i in 1..=(n - 2).div_ceil(2) {
        // Interior nodes: roots of P_m', start from the Chebyshev–Gauss–Lobatto points.
        let mut x = -(std::f64::consts::PI * i as f64 / mf).cos();
        for _ in 0..100 {
            let (p, q) = legendre(x);
            // P_m' = m (x P_m − P_{m−1}) / (x² − 1); P_m'' from Legendre's equation.
            let d1 = mf * (x * p - q) / (x * x - 1.0);
            let d2 = (2.0 * x * d1 - mf * (mf + 1.0) * p) / (1.0 - x * x);
            let dx = d1 / d2;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        nodes[i] = x;
        nodes[n - 1 - i] = -x;
    }
    if n % 2 == 1 {
        nodes[n / 2] = 0.0;
    }
    for (x, w) in nodes.iter().zip(weights.iter_mut()) {
        let p = legendre(*x).0;
        *w = 2.0 / (mf * (mf + 1.0) * p * p);
    }
    GaussLegendre { nodes, weights }
}

/// Result of a quadrature rule on one interval.
#[derive(Clone, Copy, Debug, Default)]
pub struct Panel {
    pub value: f64,
    pub abs: f64,
}

/// Globally adaptive Gauss–Legendre integration over a partition (QUADPACK-style): every panel
/// carries the Gauss–Legendre estimate of its two halves and the error estimate
/// |halves − Lobatto(whole)|; the panel
/// with the largest error estimate is bisected until the summed error estimate falls below
/// max(`relative`·|∫f|, `noise`·∫|f|) or the evaluation budget is spent.
///
/// The noise term is the f32 floor: a density evaluated in f32 has relative rounding ~ε per
/// value, so two rules on the same panel can differ by a few ε·∫|f| whatever the panel size;
/// refining below that measures rounding, not the integral. A jump inside a panel keeps its
/// error estimate large until the panel around it is tiny, so refinement concentrates there.
/// The whole-panel rule is Gauss–Lobatto because it sees the panel's endpoints: with two
/// Gauss–Legendre rules a jump in the gaps next to a panel end or the midpoint is missed by
/// both (their estimates then agree exactly, a structural coincidence the tests demonstrated).
/// It has an odd number of nodes so that it also sees the midpoint, where the halves meet.
#[derive(Clone, Debug)]
pub struct Adaptive {
    rule: GaussLegendre,
    check: GaussLegendre,
    pub relative: f64,
    pub noise: f64,
    pub max_evaluations: usize,
}

/// Result of an adaptive integration over a partition.
#[derive(Clone, Debug, Default)]
pub struct AdaptiveResult {
    /// ∫ f over each interval of the partition.
    pub parts: Vec<f64>,
    pub value: f64,
    pub abs: f64,
    /// Summed error estimate at the end.
    pub error: f64,
    pub evaluations: usize,
    /// Whether the error target was met within the budget.
    pub converged: bool,
    /// The final panels [a, b] (unordered); `value` is the sum over them of the rule applied to
    /// both halves [a, m], [m, b]. Lets a caller integrate related functions (e.g. the channels of
    /// a colour whose sum drove the refinement) on the same nodes.
    pub panels: Vec<[f64; 2]>,
}

struct Pending {
    a: f64,
    b: f64,
    part: usize,
    left: Panel,
    right: Panel,
    error: f64,
}

impl PartialEq for Pending {
    fn eq(&self, o: &Self) -> bool {
        self.error == o.error
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Pending {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.error.total_cmp(&o.error)
    }
}

impl Adaptive {
    /// `nodes`-point rule per panel; relative error target; f32 noise floor 8ε.
    pub fn new(nodes: usize, relative: f64) -> Self {
        Self {
            rule: GaussLegendre::new(nodes),
            check: gauss_lobatto(nodes | 1),
            relative,
            noise: 8.0 * f32::EPSILON as f64,
            max_evaluations: 400_000,
        }
    }

    pub fn nodes(&self) -> usize {
        self.rule.len()
    }

    fn pending(
        &self,
        a: f64,
        b: f64,
        part: usize,
        f: &mut impl FnMut(&[f64], &mut [f64]),
    ) -> Pending {
        let whole = self.check.integrate_batch(a, b, f);
        let m = 0.5 * (a + b);
        let left = self.rule.integrate_batch(a, m, f);
        let right = self.rule.integrate_batch(m, b, f);
        let error = (left.value + right.value - whole.value).abs();
        // NaN estimates are refined first (and keep the result unconverged).
        let error = if error.is_nan() { f64::INFINITY } else { error };
        Pending {
            a,
            b,
            part,
            left,
            right,
            error,
        }
    }

    /// ∫ f over each interval \[edges\[i\], edges\[i+1\]\].
    pub fn integrate_partition(
        &self,
        edges: &[f64],
        f: &mut impl FnMut(f64) -> f64,
    ) -> AdaptiveResult {
        self.integrate_partition_batch(edges, &mut one_at_a_time(f))
    }

    /// [`Adaptive::integrate_partition`] of a batch integrand ([`GaussLegendre::integrate_batch`]).
    pub fn integrate_partition_batch(
        &self,
        edges: &[f64],
        f: &mut impl FnMut(&[f64], &mut [f64]),
    ) -> AdaptiveResult {
        let parts_n = edges.len().saturating_sub(1);
        let mut heap = std::collections::BinaryHeap::with_capacity(4 * parts_n);
        let mut evaluations = 0;
        let per_panel = self.check.len() + 2 * self.rule.len();
        for i in 0..parts_n {
            heap.push(self.pending(edges[i], edges[i + 1], i, f));
            evaluations += per_panel;
        }
        let mut converged = false;
        loop {
            let (mut value, mut abs, mut error) = (0.0, 0.0, 0.0);
            for p in &heap {
                value += p.left.value + p.right.value;
                abs += p.left.abs + p.right.abs;
                error += p.error;
            }
            if error <= (self.relative * value.abs()).max(self.noise * abs) {
                converged = true;
                break;
            }
            if evaluations >= self.max_evaluations {
                break;
            }
            let Some(p) = heap.pop() else { break };
            let m = 0.5 * (p.a + p.b);
            if !(m > p.a && m < p.b) {
                // Cannot be split in f64: keep it with zero error so the loop moves on.
                heap.push(Pending { error: 0.0, ..p });
                continue;
            }
            heap.push(self.pending(p.a, m, p.part, f));
            heap.push(self.pending(m, p.b, p.part, f));
            evaluations += 2 * per_panel;
        }
        let mut out = AdaptiveResult {
            parts: vec![0.0; parts_n],
            evaluations,
            converged,
            ..Default::default()
        };
        for p in heap {
            out.panels.push([p.a, p.b]);
            out.parts[p.part] += p.left.value + p.right.value;
            out.abs += p.left.abs + p.right.abs;
            out.error += p.error;
        }
        out.value = out.parts.iter().sum();
        out
    }

    /// ∫_a^b f.
    pub fn integrate(&self, a: f64, b: f64, f: &mut impl FnMut(f64) -> f64) -> AdaptiveResult {
        self.integrate_partition(&[a, b], f)
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
                let exact = if k % 2 == 1 {
                    0.0
                } else {
                    2.0 / (k as f64 + 1.0)
                };
                let got = gl
                    .integrate(-1.0, 1.0, &mut |x: f64| x.powi(k as i32))
                    .value;
                assert!((got - exact).abs() < 1e-13, "n={n} k={k}: {got} vs {exact}");
            }
            // Degree 2n is not integrated exactly (the rule has no more accuracy than claimed).
            let k = 2 * n;
            let exact = 2.0 / (k as f64 + 1.0);
            let got = gl
                .integrate(-1.0, 1.0, &mut |x: f64| x.powi(k as i32))
                .value;
            assert!((got - exact).abs() > 1e-12, "n={n}: degree {k} exact?");
        }
    }

    #[test]
    fn lobatto_rule() {
        for n in 3..=10 {
            let gl = gauss_lobatto(n);
            assert_eq!(gl.nodes[0], -1.0);
            assert_eq!(gl.nodes[n - 1], 1.0);
            // Endpoint weight 2/(n(n−1)).
            assert!((gl.weights[0] - 2.0 / (n * (n - 1)) as f64).abs() < 1e-14);
            for k in 0..=(2 * n - 3) {
                let exact = if k % 2 == 1 {
                    0.0
                } else {
                    2.0 / (k as f64 + 1.0)
                };
                let got = gl
                    .integrate(-1.0, 1.0, &mut |x: f64| x.powi(k as i32))
                    .value;
                assert!((got - exact).abs() < 1e-13, "n={n} k={k}: {got} vs {exact}");
            }
        }
    }

    #[test]
    fn jumps_anywhere_are_resolved() {
        // Jumps just inside a panel end and next to the midpoint, where two Gauss–Legendre
        // rules are blind; and a sweep of positions.
        let mut q = Adaptive::new(8, 1e-12);
        q.noise = 0.0;
        let mut positions = vec![0.004, 0.996, 0.5 + 0.009, 0.5 - 0.009, 0.5 + 1e-7];
        positions.extend((1..50).map(|i| i as f64 / 50.0 + 1e-3 * (i as f64).sin()));
        for jump in positions {
            let r = q.integrate(0.0, 1.0, &mut |x: f64| if x < jump { 1.0 } else { 3.0 });
            let exact = jump + 3.0 * (1.0 - jump);
            assert!(
                (r.value - exact).abs() < 1e-10,
                "jump at {jump}: {} vs {exact}: {r:?}",
                r.value
            );
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
        let mut q = Adaptive::new(8, 1e-12);
        q.noise = 0.0; // exact integrand
        let r = q.integrate(0.0, 1.0, &mut |x: f64| if x < jump { 1.0 } else { 3.0 });
        let exact = jump + 3.0 * (1.0 - jump);
        assert!(r.converged);
        assert!((r.value - exact).abs() < 1e-11, "{} vs {exact}", r.value);
        // Refinement concentrates at the jump: far fewer evaluations than uniform refinement.
        assert!(r.evaluations < 4000, "{}", r.evaluations);
    }

    #[test]
    fn adaptive_smooth_function_converges_at_once() {
        let q = Adaptive::new(8, 1e-12);
        let r = q.integrate(0.0, 1.0, &mut |x: f64| x.cos());
        assert!((r.value - 1f64.sin()).abs() < 1e-14);
        assert!(r.converged);
        // Whole (9-point Lobatto) and halves only.
        assert_eq!(r.evaluations, 9 + 16);
    }

    #[test]
    fn final_panels_reproduce_the_value() {
        // A peak that forces refinement; re-integrating on the returned panels (rule on both
        // halves) gives the value back, and the panels tile the interval.
        let q = Adaptive::new(8, 1e-10);
        let f = |x: f64| 1.0 / (1e-3 + (x - 0.3) * (x - 0.3));
        let r = q.integrate_partition(&[0.0, 0.5, 1.0], &mut |x| f(x));
        assert!(
            r.converged && r.panels.len() > 4,
            "{} panels",
            r.panels.len()
        );
        let gl = GaussLegendre::new(8);
        let mut again = 0.0;
        let mut length = 0.0;
        for [a, b] in &r.panels {
            length += b - a;
            let m = 0.5 * (a + b);
            for (lo, hi) in [(*a, m), (m, *b)] {
                let (h, c) = (0.5 * (hi - lo), 0.5 * (lo + hi));
                again += gl.points().map(|(x, w)| w * h * f(c + h * x)).sum::<f64>();
            }
        }
        assert!(
            (again - r.value).abs() <= 1e-13 * r.value,
            "{again} vs {}",
            r.value
        );
        assert!((length - 1.0).abs() < 1e-15);
    }

    #[test]
    fn partition_parts_and_noise_floor() {
        // f32-rounded integrand: converges at the noise floor instead of refining forever.
        let q = Adaptive::new(8, 1e-12);
        let edges: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
        let r = q.integrate_partition(&edges, &mut |x: f64| ((3.0 * x).exp() as f32) as f64);
        assert!(r.converged);
        assert!(r.evaluations < 10_000, "{}", r.evaluations);
        let exact = ((3.0f64).exp() - 1.0) / 3.0;
        assert!((r.value - exact).abs() < 1e-6 * exact);
        for i in 0..10 {
            let e = ((3.0 * edges[i + 1]).exp() - (3.0 * edges[i]).exp()) / 3.0;
            assert!((r.parts[i] - e).abs() < 1e-6 * e);
        }
    }
}
