//! Chi-square goodness of fit of a line sampler (docs/sampler-suite.md).
//!
//! Domain: φ = asin s ∈ [φ_begin, φ_end] of the sampler's `support()`, cut into M equal bins.
//! The ends are φ = atan2(l, d) in f64 of the support's l-interval (the segment, or its
//! horizon-clipped part, as the f32 frame states it), *not* asin of the frame's stored f32
//! s_begin, s_end: near |s| → 1 those are rounded by up to ε/4, which moves an end by
//! ε/(4 cos φ) in φ (1e-5 rad for ℓ/d ≈ 300) and for ℓ/d ≳ 3000 rounds s_end to 1 (φ_end to
//! π/2, the whole rest of the infinite line). An f32 direction resolves φ to ~ε absolute
//! everywhere, so the segment's interval is representable and is what every density must
//! integrate to 1 over. A sample's φ is atan2(u·ω, ĉ·ω), which keeps the angular precision of
//! the f32 direction where asin(u·ω) would not.
//! The probability of bin i is ∫_bin p_R(ω(φ)) · (2/d) cos φ dφ (dΩ_R = (2/d) ds, ds = cos φ dφ),
//! integrated in f64 by adaptive Gauss–Legendre with the sampler's own `pdf`, the quantity under
//! test. ω(φ) = sin φ·u + cos φ·ĉ is built in f64 and cast to f32 for the call.

use crate::quadrature::Adaptive;
use glam::{DVec3, Vec3};
use linlight_sampling::{LineFrame, LineSampler};
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::ops::Range;

/// A sample is outside the support when its s = u·ω lies more than this outside
/// [s_begin, s_end] (≈ 8 f32 ulps at 1) *and* its φ more than [`SUPPORT_TOLERANCE_PHI`] outside
/// [φ_begin, φ_end]; samples within either tolerance are assigned to the end bins.
pub const SUPPORT_TOLERANCE_S: f64 = 1e-6;
pub const SUPPORT_TOLERANCE_PHI: f64 = 1e-6;

/// A sample must point at the line: unit length and in the plane through x and the line, on the
/// side of the line (components checked in f64 against these tolerances).
pub const DIRECTION_TOLERANCE: f64 = 1e-4;

/// Resolution of the test in s for N samples: cells are merged with their neighbours until a
/// cell spans at least this much of s. Samples are f32 directions; near |s| → 1 consecutive
/// representable s are ε/2 apart and a φ-bin can be narrower than that, so counts per bin would
/// measure the f32 grid, not the sampler. A cell boundary misplaces at most (ε/2)/width of the
/// cell's mass, N·m·ε/(2·width) samples against a standard deviation √(N·m) ≥ … of its count;
/// width = 1.28·ε·√N keeps that below 0.4 standard deviations for every cell mass m ≤ 1
/// (256 ε at N = 40 000, 1280 ε ≈ 1.5e-4 at N = 10⁶).
pub fn s_resolution(samples: usize) -> f64 {
    1.28 * f32::EPSILON as f64 * (samples as f64).sqrt()
}

/// Samples are counted in bins this many times finer than the fine χ² test's cells, so that the
/// coarse test's cells of equal probability can be formed from them.
pub const COUNTING_SUBDIVISION: usize = 5;

/// Pooled bins must reach this expected count.
pub const MIN_EXPECTED: f64 = 5.0;

/// M equal bins in φ over a frame's interval.
#[derive(Clone, Debug)]
pub struct PhiBinning {
    u: DVec3,
    c_hat: DVec3,
    /// 2/d: dΩ_R/ds.
    two_over_d: f64,
    s_begin: f64,
    s_end: f64,
    phi_begin: f64,
    phi_end: f64,
    bins: usize,
    /// (sin, cos) of the M + 1 edges: a direction with plane coordinates (a, b) = (u·ω, ĉ·ω)
    /// lies at or past edge k iff a·cos φ_k − b·sin φ_k ≥ 0 (the sign of sin(φ − φ_k)).
    edge_sin_cos: Vec<(f64, f64)>,
    /// u × ĉ: the normal of the plane of the line and the shading point.
    plane_normal: DVec3,
    /// Where the bin search starts, if the edge test is monotone in k for every direction with
    /// b ≥ 0 (see [`StartTable`]).
    start: Option<StartTable>,
}

/// A guess of a direction's bin from its pseudo-angle x = a/(|a| + b) (b > 0; monotone in φ,
/// dx/dφ ∈ [1/2, 1] · its value at φ = 0, so cells of equal x hold about equally many bins):
/// `first[g]` is the number of inner edges whose own x lies below cell g of a uniform grid over
/// [x(φ_begin), x(φ_end)]. The guess only decides where the exact edge test starts; the bin is
/// still the number of inner edges the direction lies at or past, found by stepping to where
/// that test changes — the same bin as the binary search wherever the test is monotone in k.
///
/// Monotone: the computed a·cos φ_k − b·sin φ_k has the sign of r·sin(φ − θ_k) (θ_k the angle
/// of the rounded (sin, cos) of edge k, r = |(a, b)| ≈ 1) unless |r·sin(φ − θ_k)| is below its
/// rounding error, ~4e-16. For b ≥ 0 and every edge at least [`MIN_EDGE_GAP`] from ±π/2,
/// |φ − θ_k| ≤ π − 1e-12, so that happens only for φ within ~1e-15 of θ_k; with consecutive
/// edges at least [`MIN_EDGE_GAP`] apart it happens for at most one k, next to the sign change:
/// the computed sequence of tests is monotone. Otherwise (b < 0, or a binning whose edges are
/// closer than that) the lookup keeps the binary search.
#[derive(Clone, Debug)]
struct StartTable {
    x_begin: f64,
    /// Cells per unit of x.
    scale: f64,
    first: Vec<u32>,
}

/// Smallest gap between consecutive bin edges (and between an edge and ±π/2), in radians, for
/// which [`StartTable`] is used.
const MIN_EDGE_GAP: f64 = 1e-12;

/// Cells of the start table per bin.
const START_CELLS_PER_BIN: usize = 16;

/// |(|w| − 1)| ≤ [`DIRECTION_TOLERANCE`] for a finite w, with the square root only near the
/// bounds: |w|² inside the squared bounds by a relative margin of 1e-9 (far above the rounding
/// of |w|² and of the square root) decides the same as the square root would.
#[inline]
fn unit_within_tolerance(w: DVec3) -> bool {
    const LOW: f64 = (1.0 - DIRECTION_TOLERANCE) * (1.0 - DIRECTION_TOLERANCE) * (1.0 + 1e-9);
    const HIGH: f64 = (1.0 + DIRECTION_TOLERANCE) * (1.0 + DIRECTION_TOLERANCE) * (1.0 - 1e-9);
    let len2 = w.length_squared();
    (len2 > LOW && len2 < HIGH) || (w.length() - 1.0).abs() <= DIRECTION_TOLERANCE
}

/// The pseudo-angle a/(|a| + b) of a direction with b > 0 (monotone in φ = atan2(a, b)).
#[inline]
fn pseudo_angle(a: f64, b: f64) -> f64 {
    a / (a.abs() + b)
}

/// Where a sampled direction falls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BinLookup {
    Bin(usize),
    /// s outside the support by more than [`SUPPORT_TOLERANCE_S`].
    OutsideSupport,
    /// Not a unit direction toward the line (or not finite).
    NotTowardLine,
}

impl PhiBinning {
    pub fn new(frame: &LineFrame, bins: usize) -> Self {
        let d = frame.d as f64;
        let phi_begin = (frame.l_begin as f64).atan2(d);
        let phi_end = (frame.l_end as f64).atan2(d);
        Self {
            u: frame.u.as_dvec3(),
            c_hat: frame.c_hat.as_dvec3(),
            two_over_d: 2.0 / d,
            s_begin: phi_begin.sin(),
            s_end: phi_end.sin(),
            phi_begin,
            phi_end,
            bins: bins.max(1),
            edge_sin_cos: Vec::new(),
            plane_normal: frame.u.as_dvec3().cross(frame.c_hat.as_dvec3()),
            start: None,
        }
        .with_edge_directions()
    }

    fn with_edge_directions(mut self) -> Self {
        self.edge_sin_cos = (0..=self.bins).map(|i| self.edge(i).sin_cos()).collect();
        self.start = self.start_table();
        self
    }

    /// The [`StartTable`], if its preconditions hold (at least two bins, edges at least
    /// [`MIN_EDGE_GAP`] apart and from ±π/2, every edge direction with b > 0).
    fn start_table(&self) -> Option<StartTable> {
        let edges = self.edges();
        let half_pi = std::f64::consts::FRAC_PI_2;
        let spaced = edges.windows(2).all(|e| e[1] - e[0] >= MIN_EDGE_GAP)
            && edges.iter().all(|e| half_pi - e.abs() >= MIN_EDGE_GAP);
        if self.bins < 2 || !spaced || self.edge_sin_cos.iter().any(|&(_, c)| c <= 0.0) {
            return None;
        }
        let x: Vec<f64> = self
            .edge_sin_cos
            .iter()
            .map(|&(s, c)| pseudo_angle(s, c))
            .collect();
        let (x_begin, x_end) = (x[0], x[self.bins]);
        let cells = self.bins * START_CELLS_PER_BIN;
        let scale = cells as f64 / (x_end - x_begin);
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        // Inner edges 1..M − 1 below the lower boundary of each cell.
        let mut first = Vec::with_capacity(cells);
        let mut k = 0usize;
        for g in 0..cells {
            let lower = x_begin + g as f64 / scale;
            while k + 1 < self.bins && x[k + 1] < lower {
                k += 1;
            }
            first.push(k as u32);
        }
        Some(StartTable {
            x_begin,
            scale,
            first,
        })
    }

    /// φ_begin, φ_end.
    pub fn phi_range(&self) -> (f64, f64) {
        (self.phi_begin, self.phi_end)
    }

    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Lower edge of bin i (i = M gives φ_end).
    pub fn edge(&self, i: usize) -> f64 {
        if i >= self.bins {
            return self.phi_end;
        }
        self.phi_begin + (self.phi_end - self.phi_begin) * (i as f64 / self.bins as f64)
    }

    /// s at the lower edge of bin i.
    pub fn s_edge(&self, i: usize) -> f64 {
        self.edge(i).sin()
    }

    /// Consecutive cells merged until each spans ≥ `resolution` in s (a remainder below it
    /// joins the previous cell; a support narrower than it is one cell).
    pub fn at_resolution(&self, cells: &[Range<usize>], resolution: f64) -> Vec<Range<usize>> {
        let mut out: Vec<Range<usize>> = Vec::new();
        let (Some(first), Some(last)) = (cells.first(), cells.last()) else {
            return out;
        };
        let mut start = first.start;
        for c in cells {
            if self.s_edge(c.end) - self.s_edge(start) >= resolution {
                out.push(start..c.end);
                start = c.end;
            }
        }
        if start < last.end {
            match out.last_mut() {
                Some(prev) => prev.end = last.end,
                None => out.push(start..last.end),
            }
        }
        out
    }

    /// Every bin its own cell, then merged to `resolution`.
    pub fn resolution_groups(&self, resolution: f64) -> Vec<Range<usize>> {
        self.at_resolution(&runs(self.bins, 1), resolution)
    }

    /// ω(φ) in f64, cast to f32.
    pub fn direction(&self, phi: f64) -> Vec3 {
        (phi.sin() * self.u + phi.cos() * self.c_hat).as_vec3()
    }

    /// dΩ_R/dφ = (2/d) cos φ.
    pub fn jacobian(&self, phi: f64) -> f64 {
        self.two_over_d * phi.cos()
    }

    /// φ = atan2(u·ω, ĉ·ω) of a direction in f64 (the angular precision of the f32 direction,
    /// where asin(u·ω) would lose it near |s| → 1).
    pub fn phi_of(&self, dir: Vec3) -> f64 {
        let w = dir.as_dvec3();
        w.dot(self.u).atan2(w.dot(self.c_hat))
    }

    /// The bin of a sampled direction.
    #[inline]
    pub fn lookup(&self, dir: Vec3) -> BinLookup {
        let w = dir.as_dvec3();
        if !w.is_finite()
            || !unit_within_tolerance(w)
            || w.dot(self.plane_normal).abs() > DIRECTION_TOLERANCE
            || w.dot(self.c_hat) < -DIRECTION_TOLERANCE
        {
            return BinLookup::NotTowardLine;
        }
        let (a, b) = (w.dot(self.u), w.dot(self.c_hat));
        let outside_s =
            a < self.s_begin - SUPPORT_TOLERANCE_S || a > self.s_end + SUPPORT_TOLERANCE_S;
        if outside_s {
            // Rare: only then is φ itself needed.
            let phi = a.atan2(b);
            let outside_phi = phi < self.phi_begin - SUPPORT_TOLERANCE_PHI
                || phi > self.phi_end + SUPPORT_TOLERANCE_PHI;
            if outside_phi {
                return BinLookup::OutsideSupport;
            }
        }
        // The bin is the number of inner edges the direction lies at or past (by the sign of
        // sin(φ − φ_k), no atan2): the same bin as ⌊(φ − φ_b)/(φ_e − φ_b)·M⌋ up to f64
        // rounding; directions before the first edge or past the last go to the end bins.
        let inner = &self.edge_sin_cos[1..self.bins];
        let past = |k: usize| {
            let (sin, cos) = inner[k];
            a * cos - b * sin >= 0.0
        };
        match &self.start {
            Some(t) if b > 0.0 => {
                // Where the (monotone) test changes sign, from the table's guess.
                let cell = ((pseudo_angle(a, b) - t.x_begin) * t.scale).max(0.0) as usize;
                let mut k = t.first[cell.min(t.first.len() - 1)] as usize;
                while k < inner.len() && past(k) {
                    k += 1;
                }
                while k > 0 && !past(k - 1) {
                    k -= 1;
                }
                BinLookup::Bin(k)
            }
            _ => BinLookup::Bin(self.search(a, b)),
        }
    }

    /// The number of inner edges that (a, b) lies at or past, by binary search (correct for any
    /// direction where the edge test is monotone in k; the reference of the table lookup).
    fn search(&self, a: f64, b: f64) -> usize {
        let inner = &self.edge_sin_cos[1..self.bins];
        let (mut lo, mut size) = (0usize, inner.len());
        while size > 0 {
            let half = size / 2;
            let (sin, cos) = inner[lo + half];
            let past = a * cos - b * sin >= 0.0;
            lo = if past { lo + half + 1 } else { lo };
            size = if past { size - half - 1 } else { half };
        }
        lo
    }

    /// The M + 1 bin edges in φ.
    pub fn edges(&self) -> Vec<f64> {
        (0..=self.bins).map(|i| self.edge(i)).collect()
    }

    /// ∫_bin p_R dΩ_R for every bin (probability masses under the sampler's own pdf).
    pub fn masses(&self, sampler: &dyn LineSampler, quad: &Adaptive) -> Masses {
        let mut non_finite = false;
        let mut f = |phi: f64| {
            let p = sampler.pdf(self.direction(phi)) as f64;
            if !p.is_finite() {
                non_finite = true;
                return 0.0;
            }
            p * self.jacobian(phi)
        };
        let r = quad.integrate_partition(&self.edges(), &mut f);
        let mut mass = r.parts;
        if non_finite {
            mass.iter_mut().for_each(|m| *m = f64::NAN);
        }
        Masses {
            mass,
            converged: r.converged && !non_finite,
            evaluations: r.evaluations,
        }
    }
}

/// Probability masses of the bins.
#[derive(Clone, Debug)]
pub struct Masses {
    pub mass: Vec<f64>,
    /// False if the quadrature missed its error target within its budget, or the pdf returned
    /// a non-finite value (then every mass is NaN).
    pub converged: bool,
    pub evaluations: usize,
}

impl Masses {
    /// ∫ p_R dΩ_R over the whole support (should be 1).
    pub fn total(&self) -> f64 {
        self.mass.iter().sum()
    }
}

/// `bins` bins in consecutive runs of `per` (the last may be shorter).
pub fn runs(bins: usize, per: usize) -> Vec<Range<usize>> {
    let per = per.max(1);
    (0..bins.div_ceil(per))
        .map(|i| i * per..((i + 1) * per).min(bins))
        .collect()
}

/// Consecutive cells merged into about `k` cells of equal probability: a cell closes where the
/// cumulative mass first reaches j/k of the total (j = 1, 2, …); a remainder joins the last.
/// The cells depend only on the density under test, not on the samples.
pub fn equal_mass_cells(cells: &[Range<usize>], mass: &[f64], k: usize) -> Vec<Range<usize>> {
    let total: f64 = mass.iter().sum();
    let mut out: Vec<Range<usize>> = Vec::new();
    let (Some(first), Some(last)) = (cells.first(), cells.last()) else {
        return out;
    };
    let (mut start, mut cumulative, mut j) = (first.start, 0.0, 1);
    for c in cells {
        cumulative += mass[c.clone()].iter().sum::<f64>();
        if cumulative >= total * j as f64 / k.max(1) as f64 {
            out.push(start..c.end);
            start = c.end;
            while j < k && cumulative >= total * j as f64 / k as f64 {
                j += 1;
            }
        }
    }
    if start < last.end {
        match out.last_mut() {
            Some(prev) => prev.end = last.end,
            None => out.push(start..last.end),
        }
    }
    out
}

/// [`pooled_chi_square`] of the counts and expectations N·mass summed over `cells`.
pub fn grouped_chi_square(
    observed: &[u64],
    mass: &[f64],
    samples: f64,
    cells: &[Range<usize>],
) -> Chi2Outcome {
    let o: Vec<u64> = cells
        .iter()
        .map(|c| observed[c.clone()].iter().sum())
        .collect();
    let e: Vec<f64> = cells
        .iter()
        .map(|c| mass[c.clone()].iter().sum::<f64>() * samples)
        .collect();
    pooled_chi_square(&o, &e)
}

/// Outcome of the pooled chi-square test.
#[derive(Clone, Debug, Serialize)]
pub struct Chi2Outcome {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Number of cells after pooling.
    pub cells: usize,
    /// Samples that fell into bins of zero expected count (any is an immediate failure: then
    /// `p_value` is 0).
    pub zero_bin_samples: u64,
}

/// χ² of observed counts against expected counts (expected\[i\] = N · mass\[i\], not rescaled: a
/// density that integrates to 1.01 shifts every expectation). Bins with expected 0 are dropped;
/// a sample in one forces p = 0. The remaining bins are sorted by expectation (ascending) and
/// pooled until each cell expects ≥ [`MIN_EXPECTED`]; a remainder below it joins the last cell.
/// dof = cells − 1, p = P(χ²_dof ≥ statistic).
pub fn pooled_chi_square(observed: &[u64], expected: &[f64]) -> Chi2Outcome {
    assert_eq!(observed.len(), expected.len());
    let mut zero_bin_samples = 0;
    let mut bins: Vec<(f64, u64)> = Vec::with_capacity(expected.len());
    for (&o, &e) in observed.iter().zip(expected) {
        if e > 0.0 {
            bins.push((e, o));
        } else {
            zero_bin_samples += o;
        }
    }
    bins.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut cells: Vec<(f64, u64)> = Vec::new();
    let mut acc = (0.0, 0u64);
    for (e, o) in bins {
        acc.0 += e;
        acc.1 += o;
        if acc.0 >= MIN_EXPECTED {
            cells.push(acc);
            acc = (0.0, 0);
        }
    }
    if acc.0 > 0.0 || acc.1 > 0 {
        match cells.last_mut() {
            Some(last) => {
                last.0 += acc.0;
                last.1 += acc.1;
            }
            None => cells.push(acc),
        }
    }
    let statistic: f64 = cells.iter().map(|&(e, o)| (o as f64 - e).powi(2) / e).sum();
    let dof = cells.len().saturating_sub(1);
    let p_value = if zero_bin_samples > 0 || !statistic.is_finite() {
        0.0
    } else if dof == 0 {
        1.0
    } else {
        ChiSquared::new(dof as f64)
            .map(|d| d.sf(statistic))
            .unwrap_or(0.0)
    };
    Chi2Outcome {
        statistic,
        dof,
        p_value,
        cells: cells.len(),
        zero_bin_samples,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::suite::Settings;
    use linlight_sampling::philox::CounterRng;
    use linlight_sampling::solid_angle::SolidAngle;
    use linlight_sampling::Segment;

    #[test]
    fn pooling_reaches_five_and_keeps_totals() {
        let expected = [0.5, 1.0, 2.0, 3.0, 10.0, 20.0, 0.0, 1.5];
        let observed = [1, 0, 3, 2, 11, 19, 0, 2];
        let r = pooled_chi_square(&observed, &expected);
        // Sorted, zero dropped: 0.5+1+1.5+2 = 5 → cell (6 observed); 3+10 → cell; 20 → cell.
        assert_eq!(r.cells, 3);
        assert_eq!(r.dof, 2);
        let s = (6.0f64 - 5.0).powi(2) / 5.0 + (13.0f64 - 13.0).powi(2) / 13.0 + 1.0 / 20.0;
        assert!((r.statistic - s).abs() < 1e-12);
        assert!(r.p_value > 0.5);
    }

    #[test]
    fn remainder_joins_the_last_cell_and_zero_bins_fail() {
        let r = pooled_chi_square(&[5, 5, 1], &[6.0, 6.0, 1.0]);
        assert_eq!(r.cells, 2);
        let r = pooled_chi_square(&[5, 5, 1], &[6.0, 6.0, 0.0]);
        assert_eq!(r.zero_bin_samples, 1);
        assert_eq!(r.p_value, 0.0);
    }

    #[test]
    fn p_value_is_the_upper_tail() {
        // 11 cells with expected 100 and observed 100 ± 10 alternating (one at 100):
        // χ² = 10 · 100/100 = 10 on 10 dof; P(χ²₁₀ ≥ 10) = 0.44049.
        let observed = [110, 90, 110, 90, 110, 90, 110, 90, 110, 90, 100];
        let r = pooled_chi_square(&observed, &[100.0; 11]);
        assert_eq!(r.dof, 10);
        assert!((r.statistic - 10.0).abs() < 1e-12);
        assert!((r.p_value - 0.440_493).abs() < 1e-5, "{}", r.p_value);
    }

    #[test]
    fn solid_angle_masses_are_uniform_in_s() {
        let seg = Segment::new(Vec3::new(-1.0, 0.3, 1.0), Vec3::new(2.0, -0.2, 0.5));
        let s = SolidAngle::prepare(&seg, Vec3::ZERO, Vec3::Z).unwrap();
        let f = *s.support();
        let b = PhiBinning::new(&f, 11);
        let m = b.masses(&s, &Adaptive::new(8, 1e-9));
        assert!((m.total() - 1.0).abs() < 1e-6, "{}", m.total());
        for i in 0..11 {
            let ds = b.edge(i + 1).sin() - b.edge(i).sin();
            let want = ds / (f.s_end - f.s_begin) as f64;
            assert!(
                (m.mass[i] - want).abs() < 1e-6,
                "bin {i}: {} vs {want}",
                m.mass[i]
            );
        }
    }

    #[test]
    fn resolution_groups_cover_all_bins() {
        // Wide support: every bin is its own group.
        let seg = Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        let f = *SolidAngle::prepare(&seg, Vec3::ZERO, Vec3::Z)
            .unwrap()
            .support();
        let g = PhiBinning::new(&f, 51).resolution_groups(s_resolution(40_000));
        assert_eq!(g.len(), 51);
        // Far along a nearly parallel line (s ∈ [0.9998, 0.999994]): bins are merged.
        let seg = Segment::new(Vec3::new(0.01, 0.0, 0.5), Vec3::new(0.01, 0.0, 3.0));
        let f = *SolidAngle::prepare(&seg, Vec3::ZERO, Vec3::Z)
            .unwrap()
            .support();
        let b = PhiBinning::new(&f, 51);
        let g = b.resolution_groups(s_resolution(40_000));
        assert!(g.len() > 1 && g.len() < 51, "{}", g.len());
        assert_eq!(g.first().unwrap().start, 0);
        assert_eq!(g.last().unwrap().end, 51);
        for w in g.windows(2) {
            assert_eq!(w[0].end, w[1].start);
        }
        for r in &g {
            assert!(b.s_edge(r.end) - b.s_edge(r.start) >= s_resolution(40_000));
        }
    }

    #[test]
    fn runs_and_equal_mass_cells_partition_the_bins() {
        assert_eq!(runs(11, 5), vec![0..5, 5..10, 10..11]);
        assert_eq!(runs(10, 5), vec![0..5, 5..10]);
        let unit = runs(10, 1);
        // Equal masses: 10 bins into 5 cells of 2.
        let cells = equal_mass_cells(&unit, &[0.1; 10], 5);
        assert_eq!(cells, vec![0..2, 2..4, 4..6, 6..8, 8..10]);
        // One bin holds most of the mass: it closes several quantiles at once.
        let mass = [0.05, 0.05, 0.7, 0.05, 0.05, 0.05, 0.05];
        let cells = equal_mass_cells(&runs(7, 1), &mass, 4);
        assert_eq!(cells.first().unwrap().start, 0);
        assert_eq!(cells.last().unwrap().end, 7);
        for w in cells.windows(2) {
            assert_eq!(w[0].end, w[1].start);
        }
        assert!(cells.contains(&(0..3)), "{cells:?}");
    }

    /// Every frame of the suite (each configuration's line, whole and clipped to its horizon),
    /// at the counting and the fine binning.
    fn suite_binnings() -> Vec<PhiBinning> {
        let configs = crate::configs::suite_configs(Settings::default().seed, 40);
        let mut out = Vec::new();
        for c in configs.iter().chain(&crate::configs::ltc_table_configs()) {
            let Some(frame) = LineFrame::new(&c.segment(), c.x()) else {
                continue;
            };
            let clipped = frame.clip_to_horizon(c.n().normalize());
            for f in [Some(frame), clipped].into_iter().flatten() {
                for bins in [255, 51] {
                    out.push(PhiBinning::new(&f, bins));
                }
            }
        }
        out
    }

    /// The lookup's bin is the binary search's: the start table only decides where the exact
    /// edge test starts. Checked on random directions over (and beyond) the support, on the
    /// f32 directions of every bin edge and their neighbours one f32 ulp away in each
    /// component, and at the ends' support tolerances.
    #[test]
    fn lookup_equals_the_binary_search() {
        let binnings = suite_binnings();
        let with_table = binnings.iter().filter(|b| b.start.is_some()).count();
        assert!(with_table > binnings.len() / 2, "{with_table}");
        let mut rng = CounterRng::new(7, [9, 0, 0]);
        let mut checked = 0usize;
        for b in &binnings {
            let (pb, pe) = b.phi_range();
            let mut dirs = Vec::new();
            for _ in 0..2000 {
                let t = rng.next_f32() as f64 * 1.2 - 0.1;
                dirs.push(b.direction(pb + t * (pe - pb)));
            }
            for k in 0..=b.bins() {
                let d = b.direction(b.edge(k));
                dirs.push(d);
                for i in 0..3 {
                    for step in [f32::next_up, f32::next_down] {
                        let mut e = d;
                        e[i] = step(e[i]);
                        dirs.push(e);
                    }
                }
            }
            for phi in [
                pb - SUPPORT_TOLERANCE_PHI,
                pe + SUPPORT_TOLERANCE_PHI,
                pb - 0.5 * SUPPORT_TOLERANCE_PHI,
                pe + 0.5 * SUPPORT_TOLERANCE_PHI,
            ] {
                dirs.push(b.direction(phi));
            }
            for dir in dirs {
                if let BinLookup::Bin(k) = b.lookup(dir) {
                    let w = dir.as_dvec3();
                    let (a, bb) = (w.dot(b.u), w.dot(b.c_hat));
                    assert_eq!(k, b.search(a, bb), "{dir:?} in {:?}", b.phi_range());
                    checked += 1;
                }
            }
        }
        assert!(checked > binnings.len() * 2000, "{checked}");
    }

    /// The squared-length shortcut decides as |(|w| − 1)| ≤ tolerance does, around both bounds.
    #[test]
    fn unit_check_equals_the_square_root() {
        let mut rng = CounterRng::new(3, [1, 0, 0]);
        for bound in [1.0 - DIRECTION_TOLERANCE, 1.0 + DIRECTION_TOLERANCE, 1.0] {
            for i in 0..20_000 {
                let v = DVec3::new(
                    rng.next_f32() as f64 - 0.5,
                    rng.next_f32() as f64 - 0.5,
                    rng.next_f32() as f64 - 0.5,
                )
                .normalize();
                // Lengths from 1e-3 relative down to a few ulps around the bound.
                let rel = (rng.next_f32() as f64 - 0.5) * 10f64.powi(-3 - (i % 14));
                let w = v * (bound * (1.0 + rel));
                let want = (w.length() - 1.0).abs() <= DIRECTION_TOLERANCE;
                assert_eq!(unit_within_tolerance(w), want, "{w:?}");
            }
        }
    }

    #[test]
    fn lookup_rejects_directions_off_the_line() {
        let seg = Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        let s = SolidAngle::prepare(&seg, Vec3::ZERO, Vec3::Z).unwrap();
        let b = PhiBinning::new(s.support(), 51);
        let mut rng = CounterRng::new(1, [2, 0, 0]);
        for _ in 0..1000 {
            // The edge search gives the bin of ⌊(φ − φ_b)/(φ_e − φ_b)·M⌋.
            let dir = s.sample(rng.next_f32());
            let (pb, pe) = b.phi_range();
            let x = ((b.phi_of(dir) - pb) / (pe - pb) * 51.0).clamp(0.0, 50.0) as usize;
            assert_eq!(b.lookup(dir), BinLookup::Bin(x));
        }
        assert_eq!(
            b.lookup(Vec3::new(0.0, 1.0, 1.0).normalize()),
            BinLookup::NotTowardLine
        );
        assert_eq!(
            b.lookup(Vec3::new(0.0, 0.0, -1.0)),
            BinLookup::NotTowardLine
        );
        assert_eq!(b.lookup(Vec3::new(0.0, 0.0, 2.0)), BinLookup::NotTowardLine);
        assert_eq!(
            b.lookup(Vec3::new(1.0, 0.0, 0.1).normalize()),
            BinLookup::OutsideSupport
        );
        assert_eq!(b.lookup(Vec3::new(0.0, 0.0, 1.0)), BinLookup::Bin(25));
        assert_eq!(b.lookup(Vec3::NAN), BinLookup::NotTowardLine);
    }
}
