//! Linearly transformed cosines (LTC) for the GGX lobe: the distribution, the fitter and the
//! committed table that the renderer's LTC line sampler (`linlight_sampling::ltc::LtcLine`)
//! reads.
//!
//! - **Lobe**: the GGX lobe with Fresnel F ≡ 1, cosine included, as Mitsuba's `roughconductor`
//!   evaluates it (separable Smith G1): [`ggx_cos`](crate::microfacet::ggx_cos). Fresnel and
//!   colour enter the albedo, not the shape.
//! - **Measure**: D_LTC ([`distribution`]) is a density per solid angle on the unit sphere,
//!   ∫ D_LTC dω = 1; the table approximates f cos ≈ ρ_s · D_LTC with ρ_s = ∫ f cos dω.
//! - **Frame**: shading coordinates with columns x̂, ŷ, n: n the shading normal,
//!   x̂ = normalize(v − (n·v)n) toward the viewer (any x̂ ⊥ n when v ∥ n), ŷ = n × x̂. The view
//!   is then v = (sin θ_o, 0, cos θ_o) and the lobe is symmetric in y.
//! - **Matrix**: A = M⁻¹ maps shading space to cosine space, rows [[a, 0, b], [0, c, 0],
//!   [d, 0, e]], normalised so that its largest |entry| is 1 (D_LTC does not depend on the
//!   scale of A); det A > 0.
//! - **Texel mapping and clamps**: see [`table`]: grid points at √α = i/(N−1),
//!   θ_o = j/(N−1)·π/2 (texel centres), bilinear, clamped at the edges; N = 64.
//! - **Fit**: see [`fit`] (Heitz et al. 2016, deterministic, f64) and `linlight fit-ltc`.
//!
//! Using the table (one lookup per shading point):
//!
//! ```
//! use linlight_brdf::ltc::GgxLtcTable;
//! let table = GgxLtcTable::ggx(); // &'static, parsed once
//! let (a, rho_s) = table.lookup(0.1, 0.8); // α, cos θ_o = n·v
//! // `a` goes to LtcLine::prepare(segment, x, shading_frame, a) with the frame above;
//! // the specular MIS weight uses k_s · rho_s.
//! assert!(a.determinant() > 0.0 && rho_s > 0.0 && rho_s <= 1.0);
//! ```

pub mod distribution;
pub mod fit;
pub mod nelder_mead;
pub mod table;
#[cfg(test)]
mod test_support;

pub use distribution::Ltc;
pub use fit::{fit_table, FittedEntry, FittedTable};
pub use table::{FitSettings, GgxLtcTable, LtcEntry, TableError};
