//! The GGX LTC table: storage, file format and the renderer's bilinear lookup.
//!
//! Texel mapping (Peters' `ltc_table.c`, texture coordinate √α·(N−1)/N + ½/N with a
//! clamp-to-edge bilinear sampler): the N×N grid points are the texel centres,
//! x_i = √α = i/(N−1) and y_j = θ_o = j/(N−1) · π/2, so the continuous texel coordinates of a
//! query are (√α·(N−1), θ_o·(N−1)/(π/2)), clamped to [0, N−1]. Column 0 (√α = 0) is fitted at
//! Mitsuba's α = 1e-4 and the last row (θ_o = π/2) at θ_o = 1.57 (see [`super::fit`]).
//!
//! Clamp range: α is clamped to [0, 1] and cos θ_o to [0, 1] before the lookup (NaN counts as
//! 0). α below (1/(N−1))² ≈ 2.5e-4 interpolates between column 0 (fitted at α = 1e-4) and
//! column 1 (α ≈ 2.5e-4): Mitsuba's smallest α = 1e-4 (√α = 0.01) reads 37 % column 0 and 63 %
//! column 1, smaller α more of column 0. Since the sampler and its density use the same
//! interpolated A, such approximations cost variance only.
//!
//! Conditioning: the lobe of a small α seen at grazing angles is a needle (width ~2α vertically
//! and ~2α·cos θ_o across), so A is nearly singular there. In the committed table four entries
//! of the last row (√α ≤ 3/63, θ_o = 1.57) have ‖A‖³/det A between 2e7 and 8e9, beyond the
//! 1e7 up to which `LtcLine::prepare` accepts a matrix (it returns `None`: the caller samples
//! the diffuse technique only); every other entry is below 1e7 (largest 8e6).
//!
//! File format (all little-endian): the 8 bytes `LTCGGX01`; five u32: N, then the fit settings
//! (fit samples, albedo samples, error samples, Nelder–Mead budget); then N² records of seven
//! f32 `a, b, c, d, e, ρ_s, E₁`, record j·N + i for √α column i and θ_o row j.

use glam::{Mat3, Vec3};
use std::f32::consts::FRAC_2_PI;
use std::fmt;
use std::sync::OnceLock;

/// Grid sizes and sample counts of a fit (`fit::fit_table`), recorded in the table it made. The
/// defaults make the committed table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitSettings {
    /// Grid points per axis (√α and θ_o).
    pub size: usize,
    /// Stratified samples per axis per technique (LTC and BRDF) of the fit objective.
    pub fit_samples: usize,
    /// Stratified visible-normal samples per axis for ρ_s and the average direction.
    pub albedo_samples: usize,
    /// Stratified samples per axis per technique of the reported error E₁.
    pub error_samples: usize,
    /// Nelder–Mead budget (objective evaluations) per entry.
    pub max_evaluations: usize,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            size: 64,
            fit_samples: 32,
            albedo_samples: 256,
            error_samples: 100,
            max_evaluations: 1000,
        }
    }
}

const MAGIC: &[u8; 8] = b"LTCGGX01";
const HEADER_LEN: usize = 8 + 5 * 4;
const RECORD_FLOATS: usize = 7;
/// In memory a record is padded to 8 lanes so that interpolation vectorises.
type Lanes = [f32; 8];

/// The committed table (fitted by `linlight fit-ltc` with the default settings).
static GGX_BYTES: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/data/ggx_ltc.bin"));
/// Path of the committed table relative to the repository root.
pub const COMMITTED_PATH: &str = "crates/brdf/data/ggx_ltc.bin";

/// One grid point: A = M⁻¹ (shading → cosine space) with rows [[a, 0, b], [0, c, 0], [d, 0, e]],
/// normalised so that max(|a|, |b|, |c|, |d|, |e|) = 1; the albedo ρ_s = ∫ f cos dω of the GGX
/// lobe with F ≡ 1; and the fit's relative L1 error E₁ (diagnostic, not interpolated by
/// [`GgxLtcTable::lookup`]).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct LtcEntry {
    pub a: f32,
    pub b: f32,
    pub c: f32,
    pub d: f32,
    pub e: f32,
    pub rho: f32,
    pub error: f32,
}

impl LtcEntry {
    /// A as a glam matrix (shading → cosine space), for
    /// `linlight_sampling::ltc::LtcLine::prepare`.
    #[inline]
    pub fn matrix(&self) -> Mat3 {
        Mat3::from_cols(
            Vec3::new(self.a, 0.0, self.d),
            Vec3::new(0.0, self.c, 0.0),
            Vec3::new(self.b, 0.0, self.e),
        )
    }

    fn to_lanes(self) -> Lanes {
        [
            self.a, self.b, self.c, self.d, self.e, self.rho, self.error, 0.0,
        ]
    }

    fn from_lanes(f: Lanes) -> Self {
        let [a, b, c, d, e, rho, error, _] = f;
        Self {
            a,
            b,
            c,
            d,
            e,
            rho,
            error,
        }
    }
}

/// Why a table file was rejected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TableError(pub String);

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for TableError {}

/// The LTC table of the GGX lobe (F ≡ 1) over (√α, θ_o).
#[derive(Clone, Debug, PartialEq)]
pub struct GgxLtcTable {
    settings: FitSettings,
    /// `lanes[j * size + i]`, i the √α column, j the θ_o row.
    lanes: Vec<Lanes>,
}

impl GgxLtcTable {
    /// The committed table, parsed once.
    pub fn ggx() -> &'static GgxLtcTable {
        static TABLE: OnceLock<GgxLtcTable> = OnceLock::new();
        TABLE.get_or_init(|| {
            Self::from_bytes(GGX_BYTES)
                .unwrap_or_else(|e| panic!("the committed {COMMITTED_PATH} is invalid: {e}"))
        })
    }

    /// A table from its entries (`settings.size`² of them, row-major with √α fastest).
    pub fn from_entries(settings: FitSettings, entries: Vec<LtcEntry>) -> Result<Self, TableError> {
        if settings.size < 2 {
            return Err(TableError(format!(
                "the grid needs at least 2 points per axis (got {})",
                settings.size
            )));
        }
        if entries.len() != settings.size * settings.size {
            return Err(TableError(format!(
                "{} entries for a {n}×{n} grid",
                entries.len(),
                n = settings.size
            )));
        }
        for (k, e) in entries.iter().enumerate() {
            let (i, j) = (k % settings.size, k / settings.size);
            let floats = e.to_lanes();
            if !floats.iter().all(|x| x.is_finite()) {
                return Err(TableError(format!(
                    "entry (√α {i}, θ {j}) is not finite: {e:?}"
                )));
            }
            let max = floats[..5].iter().fold(0.0f32, |m, x| m.max(x.abs()));
            let det = e.c * (e.a * e.e - e.b * e.d);
            if !((max - 1.0).abs() <= 1e-6 && det > 0.0) {
                return Err(TableError(format!(
                    "entry (√α {i}, θ {j}) is not a normalised A with det A > 0: {e:?}"
                )));
            }
            if !((0.0..=1.0 + 1e-4).contains(&e.rho) && (0.0..=2.0).contains(&e.error)) {
                return Err(TableError(format!(
                    "entry (√α {i}, θ {j}): ρ_s = {} outside [0, 1] or E₁ = {} outside [0, 2]",
                    e.rho, e.error
                )));
            }
        }
        Ok(Self {
            settings,
            lanes: entries.iter().map(|e| e.to_lanes()).collect(),
        })
    }

    /// Parse the file format described in the module documentation.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, TableError> {
        if bytes.len() < HEADER_LEN || &bytes[..8] != MAGIC {
            return Err(TableError(
                "not a GGX LTC table (expected the 8-byte magic LTCGGX01 and a 28-byte header)"
                    .into(),
            ));
        }
        let word = |k: usize| {
            let o = 8 + 4 * k;
            u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]) as usize
        };
        let settings = FitSettings {
            size: word(0),
            fit_samples: word(1),
            albedo_samples: word(2),
            error_samples: word(3),
            max_evaluations: word(4),
        };
        let n = settings.size;
        let expected = n
            .checked_mul(n)
            .and_then(|c| c.checked_mul(4 * RECORD_FLOATS))
            .and_then(|c| c.checked_add(HEADER_LEN));
        if expected != Some(bytes.len()) {
            return Err(TableError(format!(
                "a {n}×{n} table has {} bytes, the file has {}",
                expected.map_or("too many".to_string(), |e| e.to_string()),
                bytes.len()
            )));
        }
        let entries = bytes[HEADER_LEN..]
            .chunks_exact(4 * RECORD_FLOATS)
            .map(|r| {
                let mut f = [0.0f32; 8];
                for (k, x) in f.iter_mut().take(RECORD_FLOATS).enumerate() {
                    *x = f32::from_le_bytes([r[4 * k], r[4 * k + 1], r[4 * k + 2], r[4 * k + 3]]);
                }
                LtcEntry::from_lanes(f)
            })
            .collect();
        Self::from_entries(settings, entries)
    }

    /// The file format described in the module documentation.
    pub fn to_bytes(&self) -> Vec<u8> {
        let s = &self.settings;
        let mut out = Vec::with_capacity(HEADER_LEN + self.lanes.len() * 4 * RECORD_FLOATS);
        out.extend_from_slice(MAGIC);
        for w in [
            s.size,
            s.fit_samples,
            s.albedo_samples,
            s.error_samples,
            s.max_evaluations,
        ] {
            out.extend_from_slice(&(w as u32).to_le_bytes());
        }
        for lanes in &self.lanes {
            for x in &lanes[..RECORD_FLOATS] {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out
    }

    /// Grid points per axis.
    pub fn size(&self) -> usize {
        self.settings.size
    }

    /// The settings the table was fitted with.
    pub fn settings(&self) -> &FitSettings {
        &self.settings
    }

    /// The stored grid point of √α column `i_alpha`, θ_o row `j_theta`.
    pub fn entry(&self, i_alpha: usize, j_theta: usize) -> LtcEntry {
        LtcEntry::from_lanes(self.lanes[j_theta * self.settings.size + i_alpha])
    }

    /// Continuous texel coordinates (√α column, θ_o row), each in [0, N−1], of a query (see the
    /// module documentation for the mapping and the clamps). θ_o = acos(cos θ_o) by
    /// [`acos_unit`] (error ≤ 3e-7 rad, i.e. ≤ 1.2e-5 texels).
    #[inline]
    pub fn texel_coordinates(&self, alpha: f32, cos_theta_v: f32) -> (f32, f32) {
        let last = (self.settings.size - 1) as f32;
        // Clamped to [0, 1], NaN to 0.
        let unit = |t: f32| if t > 0.0 { t.min(1.0) } else { 0.0 };
        let x = unit(alpha).sqrt() * last;
        // θ·(2/π) ≥ 1 in f32 at cos θ_o = 0, so the last row is reached exactly.
        let y = (acos_unit(unit(cos_theta_v)) * FRAC_2_PI * last).min(last);
        (x, y)
    }

    /// Bilinear interpolation of the entries (E₁ included) at continuous texel coordinates
    /// (clamped to [0, N−1]; NaN counts as 0).
    #[inline]
    pub fn interpolate(&self, x: f32, y: f32) -> LtcEntry {
        let last = (self.settings.size - 1) as f32;
        let clamp = |t: f32| if t > 0.0 { t.min(last) } else { 0.0 };
        LtcEntry::from_lanes(self.interpolate_lanes(clamp(x), clamp(y)))
    }

    /// Bilinear interpolation at texel coordinates already in [0, N−1].
    #[inline]
    fn interpolate_lanes(&self, x: f32, y: f32) -> Lanes {
        let n = self.settings.size;
        // x, y ∈ [0, N−1], so `as` truncates toward the floor (i32: one instruction).
        let i = (x as i32 as usize).min(n - 2);
        let j = (y as i32 as usize).min(n - 2);
        let (fx, fy) = (x - i as f32, y - j as f32);
        let base = j * n + i;
        let (e00, e10, e01, e11) = (
            &self.lanes[base],
            &self.lanes[base + 1],
            &self.lanes[base + n],
            &self.lanes[base + n + 1],
        );
        // (1 − t)·a + t·b is exact at t = 0 and t = 1: texel centres return the stored bits.
        let (w00, w10, w01, w11) = (
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        );
        let mut out = [0.0f32; 8];
        for k in 0..8 {
            out[k] = w00 * e00[k] + w10 * e10[k] + w01 * e01[k] + w11 * e11[k];
        }
        out
    }

    /// A (shading → cosine space, for `LtcLine::prepare`) and ρ_s for roughness `alpha` and
    /// the view's cos θ_o = n·v. The shading frame that goes with A has columns x̂, ŷ, n with
    /// x̂ = normalize(v − (n·v)n) (any x̂ ⊥ n when v ∥ n) and ŷ = n × x̂. No allocation.
    #[inline]
    pub fn lookup(&self, alpha: f32, cos_theta_v: f32) -> (Mat3, f32) {
        let (x, y) = self.texel_coordinates(alpha, cos_theta_v);
        let e = LtcEntry::from_lanes(self.interpolate_lanes(x, y));
        (e.matrix(), e.rho)
    }
}

/// acos(c) for c ∈ [0, 1] by Abramowitz & Stegun 4.4.46: √(1 − c) · Σ a_k c^k (k ≤ 7),
/// |error| ≤ 2e-8 rad in exact arithmetic; ≤ 3e-7 rad evaluated in f32 (tested). About 20
/// instructions instead of libm's ~50: the lookup runs once per shading point.
#[inline]
pub fn acos_unit(c: f32) -> f32 {
    // a₀ = 1.5707963050 rounds to the same f32 as π/2.
    const A: [f32; 8] = [
        std::f32::consts::FRAC_PI_2,
        -0.214_598_8,
        0.088_978_99,
        -0.050_174_303,
        0.030_891_88,
        -0.017_088_126,
        0.006_670_09,
        -0.001_262_491_1,
    ];
    let mut p = A[7];
    for k in (0..7).rev() {
        p = p * c + A[k];
    }
    (1.0 - c).max(0.0).sqrt() * p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ltc::fit::{check_columns, grid_alpha, grid_theta, CHECK_BOUNDS};
    use crate::ltc::test_support::{integrate_sphere, lobe_moments_by_quadrature};
    use crate::ltc::Ltc;
    use std::f32::consts::FRAC_PI_2;

    fn table() -> &'static GgxLtcTable {
        GgxLtcTable::ggx()
    }

    #[test]
    fn committed_table_is_the_default_fit() {
        let t = table();
        assert_eq!(*t.settings(), FitSettings::default());
        assert_eq!(t.size(), 64);
        assert_eq!(t.to_bytes(), GGX_BYTES);
    }

    #[test]
    fn lookup_at_texel_centres_returns_the_stored_entries() {
        let t = table();
        let n = t.size();
        let last = (n - 1) as f32;
        for j in 0..n {
            for i in 0..n {
                let stored = t.entry(i, j);
                assert_eq!(t.interpolate(i as f32, j as f32), stored, "({i}, {j})");
                // Through the public mapping: α = (i/(N−1))², cos θ_o = cos(j/(N−1)·π/2). The
                // f32 rounding of √ and acos moves the texel coordinate by < 2e-3 (measured
                // 1e-4), and neighbours differ by < 0.1, so the lookup is within 2e-4.
                let alpha = (i as f32 / last).powi(2);
                let cos = (j as f32 / last * FRAC_PI_2).cos();
                let (x, y) = t.texel_coordinates(alpha, cos);
                assert!(
                    (x - i as f32).abs() < 2e-3 && (y - j as f32).abs() < 2e-3,
                    "({i}, {j}): texel ({x}, {y})"
                );
                let (a, rho) = t.lookup(alpha, cos);
                let diff = (a - stored.matrix()).to_cols_array();
                assert!(
                    diff.iter().all(|d| d.abs() < 2e-4) && (rho - stored.rho).abs() < 2e-4,
                    "({i}, {j}): {a:?} {rho} vs {stored:?}"
                );
            }
        }
    }

    #[test]
    fn lookup_is_bilinear_between_texel_centres() {
        let t = table();
        for (i, j) in [(0usize, 0usize), (10, 40), (62, 62), (31, 5)] {
            let e = t.interpolate(i as f32 + 0.5, j as f32 + 0.25);
            let (e00, e10, e01, e11) = (
                t.entry(i, j),
                t.entry(i + 1, j),
                t.entry(i, j + 1),
                t.entry(i + 1, j + 1),
            );
            let expected = 0.75 * 0.5 * (e00.rho + e10.rho) + 0.25 * 0.5 * (e01.rho + e11.rho);
            assert!((e.rho - expected).abs() < 1e-6);
            let expected = 0.75 * 0.5 * (e00.b + e10.b) + 0.25 * 0.5 * (e01.b + e11.b);
            assert!((e.b - expected).abs() < 1e-6);
        }
    }

    #[test]
    fn lookup_clamps_its_inputs_and_never_returns_nan() {
        let t = table();
        let n = t.size() - 1;
        let m = |i: usize, j: usize| (t.entry(i, j).matrix(), t.entry(i, j).rho);
        assert_eq!(t.lookup(0.0, 1.0), m(0, 0));
        assert_eq!(t.lookup(-1.0, 1.0), m(0, 0));
        assert_eq!(t.lookup(f32::NAN, 2.0), m(0, 0));
        assert_eq!(t.lookup(1.0, 1.0), m(n, 0));
        assert_eq!(t.lookup(7.0, 1.0), m(n, 0));
        assert_eq!(t.lookup(1.0, 0.0), m(n, n));
        assert_eq!(t.lookup(1.0, -0.3), m(n, n));
        assert_eq!(t.lookup(1.0, f32::NAN), m(n, n));
        for alpha in [0.0, 1e-6, 1e-4, 0.3, 1.0, f32::INFINITY] {
            for cos in [-1.0, 0.0, 1e-7, 0.5, 1.0, f32::NEG_INFINITY] {
                let (a, rho) = t.lookup(alpha, cos);
                assert!(a.is_finite() && rho.is_finite() && a.determinant() > 0.0);
            }
        }
    }

    #[test]
    fn malformed_files_are_rejected() {
        let good = GGX_BYTES.to_vec();
        assert!(GgxLtcTable::from_bytes(&good).is_ok());
        assert!(GgxLtcTable::from_bytes(&good[..good.len() - 4]).is_err());
        assert!(GgxLtcTable::from_bytes(b"LTCGGX0").is_err());
        let mut magic = good.clone();
        magic[0] = b'X';
        assert!(GgxLtcTable::from_bytes(&magic).is_err());
        // A record's first float (a) set to NaN, then to 2 (no longer normalised).
        for bad in [f32::NAN, 2.0] {
            let mut b = good.clone();
            b[HEADER_LEN..HEADER_LEN + 4].copy_from_slice(&bad.to_le_bytes());
            let e = GgxLtcTable::from_bytes(&b).unwrap_err();
            assert!(e.0.contains("(√α 0, θ 0)"), "{e}");
        }
        // A huge size in the header must not allocate or panic.
        let mut b = good.clone();
        b[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(GgxLtcTable::from_bytes(&b).is_err());
    }

    /// ρ_s of the committed table (f32) against Gauss–Legendre quadrature of ∫ ggx_cos dω over
    /// half-vectors ([`lobe_moments_by_quadrature`], accurate to ~1e-8), on an 8×8 sub-grid
    /// that includes the corners (α = 1e-4 and 1, θ_o = 0 and 1.57). Bound 1e-4 relative
    /// (measured ≤ 4.2e-5).
    #[test]
    fn albedo_matches_independent_quadrature() {
        let t = table();
        let n = t.size();
        let mut worst = 0.0f64;
        for j in (0..n).step_by(9) {
            for i in (0..n).step_by(9) {
                let (alpha, theta) = (grid_alpha(i, n), grid_theta(j, n));
                let (rho, _) = lobe_moments_by_quadrature(alpha, theta, false);
                let stored = t.entry(i, j).rho as f64;
                let relative = (stored - rho).abs() / rho;
                worst = worst.max(relative);
                assert!(
                    relative < 1e-4,
                    "(√α {i}, θ {j}): table ρ_s {stored} vs quadrature {rho}"
                );
            }
        }
        println!("largest relative ρ_s error {worst:.2e}");
    }

    /// ∫ D_LTC dω = 1 by quadrature for table matrices (f32 A as stored, so also the
    /// normalisation and rounding). Entries chosen to span α and θ_o with lobe aspect ratios the
    /// polar quadrature resolves (≤ ~10; the grazing small-α entries are needles).
    #[test]
    fn table_lobes_are_normalised() {
        let t = table();
        for (i, j) in [
            (0, 0),
            (5, 20),
            (10, 40),
            (30, 10),
            (30, 50),
            (45, 63),
            (63, 0),
            (63, 63),
        ] {
            let ltc = Ltc::from_a(t.entry(i, j).matrix().as_dmat3()).unwrap();
            let total = integrate_sphere(&ltc);
            assert!(
                (total - 1.0).abs() < 1e-6,
                "(√α {i}, θ {j}): ∫ D_LTC = {total}"
            );
        }
    }

    /// The `linlight fit-ltc --check` test on two α columns (all θ_o): a fresh fit agrees with
    /// the committed table within [`CHECK_BOUNDS`] (bit-identical on the machine that made it).
    #[test]
    fn committed_table_matches_a_fresh_fit() {
        let deviations = check_columns(table(), &[63, 40], &|| {});
        assert_eq!(deviations.len(), 2 * table().size());
        for d in &deviations {
            assert!(d.within(&CHECK_BOUNDS), "{d:?}");
        }
    }

    #[test]
    fn acos_approximation_is_f32_accurate() {
        let mut worst = 0.0f64;
        for k in 0..=100_000 {
            let c = k as f32 / 100_000.0;
            let err = (acos_unit(c) as f64 - (c as f64).acos()).abs();
            worst = worst.max(err);
        }
        assert!(worst < 3e-7, "{worst}");
        assert_eq!(acos_unit(1.0), 0.0);
    }
}
