//! The lights of a pass over the lights, in lanes: which light each lane samples (every lane
//! the same one under `--lights every`, its chosen one under `one` and `tree`) with its K (or
//! K/p) and segment, the lanes' numbers, and the batch kernels' light samples.

use super::shading::ShadingLanes;
use super::{Context, Lanes3};
use crate::light::{inverse_pmf, Light, LightRow, ROW_BEGIN, ROW_END, ROW_K};
use crate::light_choice::LightSelection;
use crate::render_scene::RenderScene;
use glam::Vec3;
use linlight_sampling::batch::{self, LineProblems, LineSamples};
use linlight_sampling::Technique;
use linlight_simd::{get3, splat3, Aligned, PACKET_LANES};

/// The [`LightRow`] of every light of `rs` for a lane that chooses it: with K/p under
/// `selection` `one` (p its probability), with K otherwise (`tree` scales it by each lane's
/// 1/p).
pub(super) fn light_rows(rs: &RenderScene, selection: LightSelection) -> Vec<LightRow> {
    (rs.lights.iter().enumerate())
        .map(|(j, light)| match selection {
            LightSelection::One => light.row(rs.k_over_probability(j)),
            _ => light.row(light.k()),
        })
        .collect()
}

/// The light each lane samples in one pass over the lights: the light's index, its
/// [`LightRow`] in lanes (`rows[r][k]`: value r of lane k's light — K, divided by the lane's
/// choice probability when one light is chosen, and the segment) and the lane's numbers —
/// `xi` for the batch lanes (one per light), `scalar_xi` for the lanes sampled with the scalar
/// code (one, or two for LTC and MIS on non-Lambertian surfaces; the second is 0 otherwise);
/// `uniform`: the light of every lane, when they share one (`every`).
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
pub(super) struct LightLanes {
    pub(super) rows: [[f32; PACKET_LANES]; 9],
    pub(super) light: [u32; PACKET_LANES],
    pub(super) xi: [f32; PACKET_LANES],
    pub(super) scalar_xi: [[f32; PACKET_LANES]; 2],
    pub(super) uniform: Option<usize>,
}

impl LightLanes {
    /// Lane k's light and its K (K/p when chosen).
    #[inline(always)]
    pub(super) fn of<'s>(&self, rs: &'s RenderScene, k: usize) -> (&'s Light, Vec3) {
        (&rs.lights[self.light[k] as usize], get3(self.k(), k))
    }

    /// Each lane's K.
    #[inline(always)]
    pub(super) fn k(&self) -> &Lanes3 {
        self.row3(ROW_K)
    }

    /// Rows `at` … `at` + 2 ([`ROW_K`], [`ROW_BEGIN`] or [`ROW_END`]).
    #[inline(always)]
    pub(super) fn row3(&self, at: usize) -> &Lanes3 {
        // Three whole rows (at is a constant after inlining): the conversion cannot fail.
        self.rows[at..at + 3].try_into().expect("three rows")
    }
}

/// The light samples of a packet for one [`LightLanes`], as the packet kernels return them
/// (direction, density, distance to the line along the direction; `mask`: lanes with a
/// sample), on cache lines ([`Aligned`]).
pub(super) type SampleLanes = Aligned<LineSamples<PACKET_LANES>>;

impl<'a> Context<'a> {
    /// The lights of pass `walk` over the lights and their numbers, `number(d)` being
    /// dimension d of the lanes (only the batch lanes' ξ when `batch`, the scalar lanes' when
    /// `scalar`), at the dimensions [`RenderScene::light_dimension`] gives (one number per
    /// light for the batch lanes, one or two for the scalar lanes): light `walk` in every lane
    /// (`every`); or (`one`, `tree`) each lane's light chosen by its ξ_c
    /// ([`RenderScene::LIGHT_CHOICE_DIMENSION`]; the scalar path's `choose_light` on the lanes,
    /// `tree` from the lane's shading point) with K/p.
    #[inline(always)]
    pub(super) fn light_lanes(
        &self,
        walk: usize,
        one: bool,
        number: &impl Fn(usize) -> [f32; PACKET_LANES],
        shading: &ShadingLanes,
        batch: bool,
        scalar: bool,
    ) -> LightLanes {
        let rs = self.rs;
        let selection = self.opts.lights;
        debug_assert_eq!(one, rs.chooses_one(selection));
        // A scalar lane draws one number per light, or two (the two-technique methods).
        let scalar_per_light = if self.combination.is_some() { 2 } else { 1 };
        let first = rs.light_dimension(selection, walk, scalar_per_light);
        let zero = [0.0; PACKET_LANES];
        let scalar_xi = if !scalar {
            [zero; 2]
        } else if scalar_per_light == 1 {
            [number(first), zero]
        } else {
            [number(first), number(first + 1)]
        };
        // Batch lanes draw one number per light.
        let xi = if !batch {
            zero
        } else {
            number(rs.light_dimension(selection, walk, 1))
        };
        if !one {
            let light = &rs.lights[walk];
            return LightLanes {
                uniform: Some(walk),
                light: [walk as u32; PACKET_LANES],
                rows: light.row(light.k()).map(|v| [v; PACKET_LANES]),
                xi,
                scalar_xi,
            };
        }
        if selection == LightSelection::Tree {
            // Every lane's light from its shading point, the lanes walking the tree together
            // (the scalar path's `choose_light` per lane, bit for bit); the lanes without a
            // shading point sample nothing.
            let xi_c = number(RenderScene::LIGHT_CHOICE_DIMENSION);
            let (chosen, pmf) = rs
                .tree
                .sample_lanes(self.isa, &shading.p, &shading.n, &xi_c);
            // Each lane's row with K/p as `Light::k_over_pmf` takes it, all lanes at once; zero
            // in the lanes without a shading point.
            let mut rows = [[0.0f32; PACKET_LANES]; 9];
            for (k, &j) in chosen.iter().enumerate() {
                for (rows, &v) in rows.iter_mut().zip(&self.light_rows[j as usize]) {
                    rows[k] = v;
                }
            }
            let mut scale = [0.0f32; PACKET_LANES];
            for (s, &p) in scale.iter_mut().zip(&pmf) {
                *s = inverse_pmf(p);
            }
            for rows in &mut rows[ROW_K..ROW_K + 3] {
                for (v, &s) in rows.iter_mut().zip(&scale) {
                    *v *= s;
                }
            }
            let mut on = [0u32; PACKET_LANES];
            let mut light = [0u32; PACKET_LANES];
            for k in 0..PACKET_LANES {
                on[k] = (shading.active >> k & 1).wrapping_neg();
                light[k] = chosen[k] & on[k];
            }
            for rows in &mut rows {
                for (v, &m) in rows.iter_mut().zip(&on) {
                    *v = f32::from_bits(v.to_bits() & m);
                }
            }
            return LightLanes {
                uniform: None,
                light,
                rows,
                xi,
                scalar_xi,
            };
        }
        // Each lane's light, its K/p and segment, all lanes at once.
        let xi_c = number(RenderScene::LIGHT_CHOICE_DIMENSION);
        let (light, rows) = rs.choice.pick_rows(&xi_c, &self.light_rows);
        LightLanes {
            uniform: None,
            light,
            rows,
            xi,
            scalar_xi,
        }
    }

    /// The sampling problems of the packet's lanes for [`Self::light_samples`]'s packet kernels.
    /// Lanes without a shading point have a zero normal: no contribution.
    #[inline(always)]
    fn packet_input(
        &self,
        lights: &LightLanes,
        shading: &ShadingLanes,
    ) -> LineProblems<PACKET_LANES> {
        let (begin, end) = match lights.uniform {
            Some(j) => {
                let segment = self.rs.lights[j].segment();
                (splat3(segment.begin), splat3(segment.end))
            }
            None => (*lights.row3(ROW_BEGIN), *lights.row3(ROW_END)),
        };
        LineProblems {
            begin,
            end,
            x: shading.p,
            n: shading.n,
            xi: lights.xi,
        }
    }

    /// One sample of lane k's light `lights.light[k]` with ξ = `lights.xi[k]` for every lane
    /// with a shading point (the lanes of `lanes` and with a sample in the result's `mask`).
    #[inline(always)]
    pub(super) fn light_samples(
        &self,
        lights: &LightLanes,
        shading: &ShadingLanes,
        lanes: u32,
    ) -> SampleLanes {
        let technique = self.technique;
        debug_assert!(self.batch, "{technique:?} has no batch kernel");
        let input = self.packet_input(lights, shading);
        let mut out = Aligned(match technique {
            Technique::ProjectedSolidAngle => {
                batch::sample_projected_solid_angle_packet(self.isa, &input)
            }
            Technique::ClippedSolidAngle => {
                batch::sample_clipped_solid_angle_packet(self.isa, &input)
            }
            Technique::Li2018 => batch::sample_li2018_with(self.isa, &input).0,
            _ => unreachable!("{technique:?} has no batch kernel (has_batch_kernel)"),
        });
        out.mask &= lanes;
        out
    }
}
