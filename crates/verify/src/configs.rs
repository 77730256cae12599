//! Configurations of the sampler suite: a light segment, a shading point with its normal, and
//! (for LTC techniques) a shading frame and the matrix A (shading → cosine space).
//!
//! Seeded random configurations cover the generic case; named edge cases cover the classes of
//! docs/sampler-suite.md (horizon crossing, grazing, nearly parallel to the normal, very short /
//! very long, close to the infinite line, fully clipped, anisotropic LTC with κ ≫ 1).

use glam::{Mat3, Vec3};
use linlight_sampling::rng::Pcg32;
use linlight_sampling::Segment;
use serde::Serialize;

/// The class a configuration belongs to; the command prints one row per technique × class.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ConfigClass {
    Random,
    HorizonCrossing,
    Grazing,
    NearlyParallelToNormal,
    VeryShort,
    VeryLong,
    CloseToLine,
    FullyClipped,
    LtcAnisotropic,
    /// A of the fitted GGX table (`linlight_brdf`) on a grid of (α, θ_o): [`ltc_table_configs`].
    LtcTable,
}

impl ConfigClass {
    pub const ALL: [ConfigClass; 10] = [
        ConfigClass::Random,
        ConfigClass::HorizonCrossing,
        ConfigClass::Grazing,
        ConfigClass::NearlyParallelToNormal,
        ConfigClass::VeryShort,
        ConfigClass::VeryLong,
        ConfigClass::CloseToLine,
        ConfigClass::FullyClipped,
        ConfigClass::LtcAnisotropic,
        ConfigClass::LtcTable,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ConfigClass::Random => "random",
            ConfigClass::HorizonCrossing => "horizon-crossing",
            ConfigClass::Grazing => "grazing",
            ConfigClass::NearlyParallelToNormal => "nearly-parallel-to-normal",
            ConfigClass::VeryShort => "very-short",
            ConfigClass::VeryLong => "very-long",
            ConfigClass::CloseToLine => "close-to-line",
            ConfigClass::FullyClipped => "fully-clipped",
            ConfigClass::LtcAnisotropic => "ltc-anisotropic",
            ConfigClass::LtcTable => "ltc-table",
        }
    }
}

/// One configuration. Vectors are stored as arrays so that the report can serialise them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Config {
    pub name: String,
    pub class: ConfigClass,
    pub begin: [f32; 3],
    pub end: [f32; 3],
    /// Shading point.
    pub x: [f32; 3],
    /// Unit surface normal.
    pub n: [f32; 3],
    /// Unit view direction (upper hemisphere of n): defines the LTC shading frame.
    pub view: [f32; 3],
    /// LTC matrix A in shading-frame coordinates, row-major (shading → cosine space).
    pub a_rows: [[f32; 3]; 3],
}

impl Config {
    pub fn segment(&self) -> Segment {
        Segment::new(Vec3::from(self.begin), Vec3::from(self.end))
    }
    pub fn x(&self) -> Vec3 {
        Vec3::from(self.x)
    }
    pub fn n(&self) -> Vec3 {
        Vec3::from(self.n)
    }
    /// Columns x̂, ŷ, n with x̂ = normalize(v − (n·v)n), ŷ = n × x̂.
    pub fn shading_frame(&self) -> Mat3 {
        let n = self.n();
        let v = Vec3::from(self.view);
        let x = (v - n.dot(v) * n)
            .try_normalize()
            .unwrap_or_else(|| n.any_orthonormal_vector());
        Mat3::from_cols(x, n.cross(x), n)
    }
    /// A as a matrix acting on shading-frame coordinates.
    pub fn a(&self) -> Mat3 {
        Mat3::from_cols_array_2d(&self.a_rows).transpose()
    }
}

fn v3(v: Vec3) -> [f32; 3] {
    v.to_array()
}

/// Isotropic LTC form [[a,0,b],[0,c,0],[d,0,1]] (rows).
fn ltc_rows(a: f32, b: f32, c: f32, d: f32) -> [[f32; 3]; 3] {
    [[a, 0.0, b], [0.0, c, 0.0], [d, 0.0, 1.0]]
}

/// A moderately glossy default A for edge cases not about LTC.
const DEFAULT_A: [[f32; 3]; 3] = [[2.0, 0.0, 0.1], [0.0, 2.0, 0.0], [-0.2, 0.0, 1.0]];

fn unit_vector(rng: &mut Pcg32) -> Vec3 {
    // Uniform on the sphere (Archimedes).
    let z = 2.0 * rng.next_f64() - 1.0;
    let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

fn log_uniform(rng: &mut Pcg32, lo: f64, hi: f64) -> f32 {
    (lo.ln() + rng.next_f64() * (hi.ln() - lo.ln())).exp() as f32
}

fn uniform(rng: &mut Pcg32, lo: f64, hi: f64) -> f32 {
    (lo + rng.next_f64() * (hi - lo)) as f32
}

/// `count` seeded random configurations: shading point in [−1, 1]³, normal uniform on the
/// sphere, first endpoint at a log-uniform distance in [0.2, 5], segment length log-uniform in
/// [0.05, 20] along a uniform direction; a random view in the upper hemisphere and a random
/// invertible isotropic-form A.
pub fn random_configs(seed: u64, count: usize) -> Vec<Config> {
    (0..count)
        .map(|i| {
            let mut rng = Pcg32::new(seed, 0x5eed_0000 + i as u64);
            let x = Vec3::new(
                uniform(&mut rng, -1.0, 1.0),
                uniform(&mut rng, -1.0, 1.0),
                uniform(&mut rng, -1.0, 1.0),
            );
            let n = unit_vector(&mut rng);
            let begin = x + unit_vector(&mut rng) * log_uniform(&mut rng, 0.2, 5.0);
            let end = begin + unit_vector(&mut rng) * log_uniform(&mut rng, 0.05, 20.0);
            let mut view = unit_vector(&mut rng);
            if view.dot(n) < 0.0 {
                view -= 2.0 * view.dot(n) * n;
            }
            let view = (view + 0.05 * n).normalize();
            // a, c log-uniform in [0.3, 10] (A ≈ diag(1/α, 1/α, 1) for GGX roughness α);
            // |b·d| ≤ 0.25 < a keeps det A = c(a − b d) > 0.
            let a_rows = ltc_rows(
                log_uniform(&mut rng, 0.3, 10.0),
                uniform(&mut rng, -0.5, 0.5),
                log_uniform(&mut rng, 0.3, 10.0),
                uniform(&mut rng, -0.5, 0.5),
            );
            Config {
                name: format!("random-{i:03}"),
                class: ConfigClass::Random,
                begin: v3(begin),
                end: v3(end),
                x: v3(x),
                n: v3(n),
                view: v3(view),
                a_rows,
            }
        })
        .collect()
}

struct Edge {
    name: &'static str,
    class: ConfigClass,
    begin: [f32; 3],
    end: [f32; 3],
    n: [f32; 3],
}

const Z: [f32; 3] = [0.0, 0.0, 1.0];

#[rustfmt::skip]
const EDGES: &[Edge] = &[
    // The horizon z = 0 cuts the segment (one endpoint below, one above).
    Edge { name: "crossing-vertical", class: ConfigClass::HorizonCrossing, begin: [1.0, 0.0, -1.0], end: [1.0, 0.0, 1.0], n: Z },
    Edge { name: "crossing-oblique", class: ConfigClass::HorizonCrossing, begin: [0.3, -0.5, -2.0], end: [-0.4, 0.8, 0.6], n: Z },
    Edge { name: "crossing-barely-below", class: ConfigClass::HorizonCrossing, begin: [1.0, 0.0, -1e-4], end: [0.0, 1.0, 1.0], n: Z },
    Edge { name: "crossing-mostly-below", class: ConfigClass::HorizonCrossing, begin: [0.5, 0.5, -3.0], end: [0.5, -0.5, 0.05], n: Z },
    Edge { name: "touching-from-above", class: ConfigClass::HorizonCrossing, begin: [1.0, 0.0, 1.0], end: [-1.0, 0.5, 0.0], n: Z },
    Edge { name: "crossing-tilted-normal", class: ConfigClass::HorizonCrossing, begin: [1.5, -1.5, -1.5], end: [-1.0, 2.0, 1.5], n: [1.0, 1.0, 1.0] },
    // The line lies (nearly) in the tangent plane: n·ω ≈ 0 on the whole segment.
    Edge { name: "grazing-above", class: ConfigClass::Grazing, begin: [-1.0, 1.0, 1e-3], end: [1.0, 1.0, 1e-3], n: Z },
    Edge { name: "grazing-crossing", class: ConfigClass::Grazing, begin: [-1.0, 1.0, -1e-3], end: [1.0, 1.0, 1e-3], n: Z },
    Edge { name: "grazing-long-low", class: ConfigClass::Grazing, begin: [-3.0, 0.5, 1e-5], end: [3.0, 0.5, 2e-5], n: Z },
    Edge { name: "grazing-far", class: ConfigClass::Grazing, begin: [5.0, -2.0, 0.01], end: [5.0, 2.0, 0.01], n: Z },
    // The line is (nearly) parallel to the normal.
    Edge { name: "parallel-close", class: ConfigClass::NearlyParallelToNormal, begin: [0.01, 0.0, 0.5], end: [0.01, 0.0, 3.0], n: Z },
    Edge { name: "parallel-very-close-long", class: ConfigClass::NearlyParallelToNormal, begin: [1e-3, 0.0, 0.1], end: [1e-3, 0.0, 10.0], n: Z },
    Edge { name: "parallel-offset", class: ConfigClass::NearlyParallelToNormal, begin: [0.3, 0.2, 0.5], end: [0.3, 0.2, 2.5], n: Z },
    Edge { name: "parallel-tilted", class: ConfigClass::NearlyParallelToNormal, begin: [0.05, 0.0, 0.2], end: [0.06, 0.01, 4.0], n: Z },
    Edge { name: "parallel-through-horizon", class: ConfigClass::NearlyParallelToNormal, begin: [0.01, 0.0, -0.5], end: [0.01, 0.0, 3.0], n: Z },
    // Very short segments (s-interval of ~1e-2 and ~1e-3).
    Edge { name: "short-1e-2", class: ConfigClass::VeryShort, begin: [0.5, 0.0, 1.0], end: [0.51, 0.0, 1.0], n: Z },
    Edge { name: "short-1e-3", class: ConfigClass::VeryShort, begin: [0.0, 0.0, 1.0], end: [0.0, 1e-3, 1.0], n: Z },
    Edge { name: "short-oblique", class: ConfigClass::VeryShort, begin: [1.0, 0.5, 0.5], end: [1.005_773_5, 0.505_773_5, 0.505_773_5], n: Z },
    Edge { name: "short-crossing", class: ConfigClass::VeryShort, begin: [1.0, 0.0, -2e-3], end: [1.0, 3e-3, 4e-3], n: Z },
    // Very long segments (s-interval close to [−1, 1]).
    Edge { name: "long-symmetric", class: ConfigClass::VeryLong, begin: [-1e4, 0.5, 1.0], end: [1e4, 0.5, 1.0], n: Z },
    Edge { name: "long-one-sided", class: ConfigClass::VeryLong, begin: [0.0, 0.0, 0.5], end: [1e3, 0.0, 0.5], n: Z },
    Edge { name: "long-crossing", class: ConfigClass::VeryLong, begin: [-1e3, 1.0, -1e2], end: [1e3, 1.0, 1e2], n: Z },
    Edge { name: "long-far", class: ConfigClass::VeryLong, begin: [-1e4, 50.0, 3.0], end: [1e4, 50.0, 3.0], n: Z },
    // The shading point is close to the infinite line.
    Edge { name: "close-spanning", class: ConfigClass::CloseToLine, begin: [-1.0, 0.0, 1e-4], end: [1.0, 0.0, 1e-4], n: Z },
    Edge { name: "close-beside", class: ConfigClass::CloseToLine, begin: [0.1, 0.0, 1e-3], end: [1.0, 0.0, 1e-3], n: Z },
    Edge { name: "close-tilted-normal", class: ConfigClass::CloseToLine, begin: [-0.5, 0.0, 1e-3], end: [2.0, 0.0, 1e-3], n: [0.3, 0.2, 1.0] },
    // Nothing above the horizon: every clipped technique must return None (zero contribution).
    Edge { name: "below-parallel", class: ConfigClass::FullyClipped, begin: [-1.0, 0.0, -1.0], end: [1.0, 0.0, -1.0], n: Z },
    Edge { name: "in-plane", class: ConfigClass::FullyClipped, begin: [-1.0, 1.0, 0.0], end: [1.0, 1.0, 0.0], n: Z },
    Edge { name: "below-oblique", class: ConfigClass::FullyClipped, begin: [1.0, 0.0, -2.0], end: [1.0, 1.0, -0.5], n: Z },
    Edge { name: "ends-on-plane", class: ConfigClass::FullyClipped, begin: [1.0, 0.0, -1.0], end: [1.0, 0.0, 0.0], n: Z },
];

/// Named edge cases (shading point at the origin; normals normalised here).
pub fn edge_configs() -> Vec<Config> {
    let mut out: Vec<Config> = EDGES
        .iter()
        .map(|e| Config {
            name: e.name.to_string(),
            class: e.class,
            begin: e.begin,
            end: e.end,
            x: [0.0; 3],
            n: v3(Vec3::from(e.n).normalize()),
            view: normal_view(e.n),
            a_rows: DEFAULT_A,
        })
        .collect();
    out.extend(ltc_anisotropic_configs());
    out
}

/// A view 45° off the normal (its tangent direction defines the LTC x̂ axis).
fn normal_view(n: [f32; 3]) -> [f32; 3] {
    let n = Vec3::from(n).normalize();
    v3((n + n.any_orthonormal_vector()).normalize())
}

/// Strongly anisotropic A: κ = |A⁻ᵀm|/|m| ≫ 1 when A compresses the axis along the plane
/// normal m of the line, κ ≪ 1 when it stretches it.
fn ltc_anisotropic_configs() -> Vec<Config> {
    // Normal Z, view in the xz-plane so that x̂ = (1, 0, 0), ŷ = (0, 1, 0).
    let view = v3(Vec3::new(1.0, 0.0, 1.0).normalize());
    let mk = |name: &str, begin: [f32; 3], end: [f32; 3], a_rows| Config {
        name: name.to_string(),
        class: ConfigClass::LtcAnisotropic,
        begin,
        end,
        x: [0.0; 3],
        n: Z,
        view,
        a_rows,
    };
    vec![
        // Line along ŷ: m ∝ (1, 0, −0.3); A⁻ᵀ = diag(50, 1, 1) gives κ ≈ 48.
        mk(
            "kappa-48",
            [0.3, -1.0, 1.0],
            [0.3, 1.0, 1.0],
            ltc_rows(0.02, 0.0, 1.0, 0.0),
        ),
        // Same with shear terms and a longer line: κ ≫ 1, lobe off the normal.
        mk(
            "kappa-sheared",
            [0.5, -3.0, 0.7],
            [0.2, 2.0, 1.2],
            ltc_rows(0.05, 0.3, 1.5, -0.2),
        ),
        // Line along x̂ crossing the horizon, A compresses ŷ: κ ≈ 20.
        mk(
            "kappa-crossing",
            [-1.0, 0.4, -0.5],
            [1.5, 0.4, 1.0],
            ltc_rows(1.0, 0.0, 0.05, 0.0),
        ),
        // A stretches the plane normal axis: κ ≪ 1.
        mk(
            "kappa-small",
            [0.3, -1.0, 1.0],
            [0.3, 1.0, 1.0],
            ltc_rows(30.0, 0.0, 1.0, 0.0),
        ),
        // Very glossy isotropic lobe (A = diag(50, 50, 1)), light near the reflection direction.
        mk(
            "glossy-sharp",
            [-0.9, -0.5, 1.0],
            [-1.1, 0.5, 1.0],
            ltc_rows(50.0, 0.0, 50.0, 0.0),
        ),
    ]
}

/// GGX roughness α of the fitted-table grid ([`ltc_table_configs`]).
pub const LTC_TABLE_ALPHAS: [f32; 6] = [0.05, 0.1, 0.2, 0.4, 0.7, 1.0];

/// View angles θ_o (degrees from the normal) of the fitted-table grid.
pub const LTC_TABLE_THETAS: [f32; 4] = [0.0, 30.0, 60.0, 80.0];

/// The LTC of the fitted GGX table (`linlight_brdf::ltc::GgxLtcTable::ggx().lookup`, the
/// renderer's lookup) on the grid [`LTC_TABLE_ALPHAS`] × [`LTC_TABLE_THETAS`], each with two
/// lines, normal +z, view (sin θ_o, 0, cos θ_o) (so x̂ = +x, the renderer's frame):
/// `across` — a segment along ŷ through the mirror direction at distance 1.5 (the lobe's peak on
/// the line, above the horizon); `crossing` — a segment in the plane y = 0.3 from below the
/// horizon, behind the viewer, over the normal to the mirror side (clipped at the horizon and,
/// for the sheared lobes of grazing views, at the cosine-space horizon).
pub fn ltc_table_configs() -> Vec<Config> {
    ltc_table_grid().into_iter().map(|(_, c)| c).collect()
}

/// A point of the fitted-table grid: the GGX roughness α and cos θ_o its A was looked up at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GgxPoint {
    pub alpha: f32,
    pub cos_theta_o: f32,
}

/// [`ltc_table_configs`] with the (α, cos θ_o) of each (for implementations that look A up
/// in their own copy of the table: the external protocol's version 2).
pub fn ltc_table_grid() -> Vec<(GgxPoint, Config)> {
    let table = linlight_brdf::ltc::GgxLtcTable::ggx();
    let mut out = Vec::new();
    for alpha in LTC_TABLE_ALPHAS {
        for theta_deg in LTC_TABLE_THETAS {
            let theta = theta_deg.to_radians();
            let view = Vec3::new(theta.sin(), 0.0, theta.cos());
            let (a, _rho) = table.lookup(alpha, view.z);
            let a_rows = a.transpose().to_cols_array_2d();
            let mirror = 1.5 * Vec3::new(-view.x, 0.0, view.z);
            let lines = [
                ("across", mirror - Vec3::Y, mirror + Vec3::Y),
                (
                    "crossing",
                    Vec3::new(1.5, 0.3, -0.5),
                    Vec3::new(-2.0, 0.3, 1.2),
                ),
            ];
            for (line, begin, end) in lines {
                let point = GgxPoint {
                    alpha,
                    cos_theta_o: view.z,
                };
                out.push((
                    point,
                    Config {
                        name: format!("ggx-a{alpha:.2}-t{theta_deg:02.0}-{line}"),
                        class: ConfigClass::LtcTable,
                        begin: v3(begin),
                        end: v3(end),
                        x: [0.0; 3],
                        n: Z,
                        view: v3(view),
                        a_rows,
                    },
                ));
            }
        }
    }
    out
}

/// The paper's sanity configuration: the segment (−1, 0, 1)–(1, 0, 1) above the origin, normal
/// +z, whose projected solid angle per radius is Ω⊥_R = 1 + π/2.
pub fn paper_sanity() -> Config {
    Config {
        name: "paper-sanity".to_string(),
        class: ConfigClass::Random,
        begin: [-1.0, 0.0, 1.0],
        end: [1.0, 0.0, 1.0],
        x: [0.0; 3],
        n: Z,
        view: normal_view(Z),
        a_rows: DEFAULT_A,
    }
}

/// A small fixed set for tests outside the suite (the closed-form ground truth): the paper's
/// sanity configuration, two edge cases of the suite (a horizon crossing, a tilted normal) and
/// three generic shapes (shading point off the origin, a long segment, a segment nearly
/// parallel to the normal).
pub fn reference_configs() -> Vec<Config> {
    let edge = |name: &str| {
        edge_configs()
            .into_iter()
            .find(|c| c.name == name)
            .unwrap_or_else(|| panic!("no edge configuration {name}"))
    };
    let generic = |name: &str, begin: [f32; 3], end: [f32; 3], x: [f32; 3], n: [f32; 3]| {
        let n = v3(Vec3::from(n).normalize());
        Config {
            name: name.to_string(),
            class: ConfigClass::Random,
            begin,
            end,
            x,
            n,
            view: normal_view(n),
            a_rows: DEFAULT_A,
        }
    };
    vec![
        paper_sanity(),
        edge("crossing-oblique"),
        edge("crossing-tilted-normal"),
        generic(
            "offset-point",
            [2.0, 1.0, 3.0],
            [-1.0, 2.5, 2.2],
            [0.4, -0.3, 0.2],
            [0.2, 0.3, 1.0],
        ),
        generic("long", [-30.0, 0.5, 1.0], [40.0, 0.5, 1.5], [0.0; 3], Z),
        generic(
            "near-parallel",
            [0.2, 0.1, 0.5],
            [0.25, 0.1, 3.0],
            [0.0; 3],
            Z,
        ),
    ]
}

/// The suite's configuration set: `random` seeded configurations followed by the edge cases.
pub fn suite_configs(seed: u64, random: usize) -> Vec<Config> {
    let mut v = random_configs(seed, random);
    v.extend(edge_configs());
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_sampling::LineFrame;

    #[test]
    fn deterministic_and_finite() {
        let a = suite_configs(7, 50);
        let b = suite_configs(7, 50);
        assert_eq!(a, b);
        assert_ne!(random_configs(7, 3), random_configs(8, 3));
        for c in &a {
            assert!((c.n().length() - 1.0).abs() < 1e-5, "{}", c.name);
            assert!(c.a().determinant().abs() > 1e-6, "{}", c.name);
            let f = c.shading_frame();
            assert!(
                (f.x_axis.dot(f.z_axis)).abs() < 1e-5 && (f.y_axis.length() - 1.0).abs() < 1e-5
            );
            assert!(Vec3::from(c.view).dot(c.n()) > 0.0, "{}", c.name);
        }
    }

    /// The grid carries the table's A (in the renderer's frame: x̂ toward the viewer) and every
    /// line sees the lobe: the LTC sampler prepares on each configuration.
    #[test]
    fn ltc_table_grid_uses_the_fitted_table() {
        let grid = ltc_table_configs();
        assert_eq!(
            grid.len(),
            2 * LTC_TABLE_ALPHAS.len() * LTC_TABLE_THETAS.len()
        );
        let table = linlight_brdf::ltc::GgxLtcTable::ggx();
        for c in &grid {
            let v = Vec3::from(c.view);
            assert_eq!(c.a(), table.lookup(alpha_of(&c.name), v.z).0);
            let f = c.shading_frame();
            assert!(f.x_axis.dot(v) >= 0.0 && (f.z_axis - Vec3::Z).length() < 1e-6);
            assert!(
                linlight_sampling::ltc::LtcLine::prepare(&c.segment(), c.x(), f, c.a()).is_some(),
                "{}",
                c.name
            );
        }
    }

    fn alpha_of(name: &str) -> f32 {
        name["ggx-a".len()..]
            .split('-')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    }

    #[test]
    fn edge_cases_are_what_their_class_says() {
        for c in edge_configs() {
            let n = c.n();
            let frame = LineFrame::new(&c.segment(), c.x()).expect(&c.name);
            let clipped = frame.clip_to_horizon(n);
            let h = |p: [f32; 3]| n.dot(Vec3::from(p) - c.x());
            match c.class {
                ConfigClass::FullyClipped => assert!(clipped.is_none(), "{}", c.name),
                ConfigClass::HorizonCrossing => {
                    assert!(h(c.begin).min(h(c.end)) <= 0.0 && h(c.begin).max(h(c.end)) > 0.0);
                    assert!(clipped.is_some(), "{}", c.name);
                }
                ConfigClass::Grazing => {
                    let u = (Vec3::from(c.end) - Vec3::from(c.begin)).normalize();
                    assert!(
                        u.dot(n).abs() < 2e-3 && h(c.begin).abs() < 0.02,
                        "{}",
                        c.name
                    )
                }
                ConfigClass::NearlyParallelToNormal => {
                    let u = (Vec3::from(c.end) - Vec3::from(c.begin)).normalize();
                    assert!(u.dot(n) > 0.99, "{}", c.name)
                }
                ConfigClass::VeryShort => {
                    assert!(frame.s_end - frame.s_begin < 0.02, "{}", c.name)
                }
                ConfigClass::VeryLong => {
                    assert!(frame.l_end - frame.l_begin > 100.0 * frame.d, "{}", c.name)
                }
                ConfigClass::CloseToLine => assert!(frame.d <= 1e-3 * 1.0001, "{}", c.name),
                ConfigClass::LtcAnisotropic | ConfigClass::Random | ConfigClass::LtcTable => {}
            }
        }
    }
}
