//! The lights of a pass over the lights, in lanes: which light each lane samples (every lane
//! the same one under `--lights every`, its chosen one under `one` and `tree`) with its K (or
//! K/p) and segment, the lanes' numbers, and the batch kernels' light samples.

use super::shading::ShadingLanes;
use super::{Context, Lanes3};
use crate::light_choice::LightSelection;
use crate::render_scene::{k_over_probability, RenderScene};
use glam::Vec3;
use linlight_sampling::batch::{self, LineProblems, LineSamples};
use linlight_sampling::{Segment, Technique};
use linlight_simd::{get3, splat3, Aligned, PACKET_LANES};

/// A light's values for the lanes that sample it: K (K_j/p_j when the lanes choose one light:
/// [`k_over_probability`], the scalar path's operation) at 0..3, its segment's begin at 3..6
/// and end at 6..9.
pub(super) type LightRow = [f32; 9];

/// The [`LightRow`] of light j with K = `k`.
fn light_row(segment: &Segment, k: Vec3) -> LightRow {
    let mut row = [0.0; 9];
    for (c, v) in [k, segment.begin, segment.end].iter().enumerate() {
        row[3 * c..3 * c + 3].copy_from_slice(&v.to_array());
    }
    row
}

/// The [`LightRow`] of every light of `rs` chosen with its probability (K/p).
pub(super) fn light_rows(rs: &RenderScene) -> Vec<LightRow> {
    (0..rs.lights.len())
        .map(|j| {
            light_row(
                &rs.lights[j].0,
                k_over_probability(&rs.lights, &rs.choice, j),
            )
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
    /// Lane k's light segment and K.
    #[inline(always)]
    pub(super) fn of<'s>(&self, rs: &'s RenderScene, k: usize) -> (&'s Segment, Vec3) {
        (&rs.lights[self.light[k] as usize].0, get3(self.k(), k))
    }

    /// Each lane's K.
    #[inline(always)]
    pub(super) fn k(&self) -> &Lanes3 {
        self.row3(0)
    }

    /// Rows 3·i … 3·i + 2 (0: K, 1: segment begin, 2: segment end).
    #[inline(always)]
    pub(super) fn row3(&self, i: usize) -> &Lanes3 {
        // Three whole rows (i is a constant after inlining): the conversion cannot fail.
        self.rows[3 * i..3 * i + 3].try_into().expect("three rows")
    }
}

/// The light samples of a packet for one [`LightLanes`], as the packet kernels return them
/// (direction, density, distance to the line along the direction; `mask`: lanes with a
/// sample), on cache lines ([`Aligned`]).
pub(super) type SampleLanes = Aligned<LineSamples<PACKET_LANES>>;

impl<'a> Context<'a> {
    /// The lights of pass `walk` over the lights and their numbers, `number(d)` being
    /// dimension d of the lanes (only the batch lanes' ξ when `batch`, the scalar lanes' when
    /// `scalar`): light `walk` in every lane, ξ of dimension 2 + `walk` for the batch lanes and
    /// 2 + `walk` or (2 + 2·`walk`, 3 + 2·`walk`) for the scalar lanes (`every`); or (`one`,
    /// `tree`) each lane's light chosen by its ξ_c (dimension 2; the scalar path's
    /// `choose_light` on the lanes, `tree` from the lane's shading point) with K/p, and its
    /// numbers from dimension 3 on.
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
        // First dimension of the light's numbers, and how many a scalar lane draws per light.
        let (first, scalar_per_light) = match (one, self.combination) {
            (false, None) => (2 + walk, 1),
            (false, Some(_)) => (2 + 2 * walk, 2),
            (true, None) => (3, 1),
            (true, Some(_)) => (3, 2),
        };
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
        } else if one {
            number(3)
        } else {
            number(2 + walk)
        };
        if !one {
            let (segment, k) = &rs.lights[walk];
            return LightLanes {
                uniform: Some(walk),
                light: [walk as u32; PACKET_LANES],
                rows: light_row(segment, *k).map(|v| [v; PACKET_LANES]),
                xi,
                scalar_xi,
            };
        }
        if self.opts.lights == LightSelection::Tree {
            // Each shaded lane's light from its shading point, lane by lane (the scalar path's
            // `choose_light`); the other lanes sample nothing.
            let xi_c = number(2);
            let mut light = [0u32; PACKET_LANES];
            let mut rows = [[0.0f32; PACKET_LANES]; 9];
            let mut m = shading.active;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let (j, kp) = rs.choose_light(
                    LightSelection::Tree,
                    get3(&shading.p, k),
                    get3(&shading.n, k),
                    xi_c[k],
                );
                light[k] = j as u32;
                for (r, v) in light_row(&rs.lights[j].0, kp).into_iter().enumerate() {
                    rows[r][k] = v;
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
        let (light, rows) = rs.choice.pick_rows(&number(2), &self.light_rows);
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
                let segment = &self.rs.lights[j].0;
                (splat3(segment.begin), splat3(segment.end))
            }
            None => (*lights.row3(1), *lights.row3(2)),
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
