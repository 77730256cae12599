//! The shading points of a packet's camera hits, in lanes: surface points, the normal of the
//! side that reflects, f = ρ/π on Lambertian lanes, the shading frames or scalar shading
//! points of glossy lanes.

use super::triangles::{select_lanes, Triangles};
use super::Lanes3;
use crate::bvh::{PacketHits, RayLanes};
use crate::hooks::SceneBsdf;
use crate::method::Method;
use crate::render_scene::{reflecting_normal, RenderScene};
use crate::scene::Bsdf;
use crate::shading::{shading_frame, ShadingPoint};
use crate::shapes::Primitive;
use glam::Vec3;
use linlight_simd::{get3, set3, Aligned, PACKET_LANES};
use std::mem::MaybeUninit;

/// The shading points of a packet, lane k from camera sample k (structure of arrays). Lanes
/// outside `active` (no hit, or a surface that does not reflect toward the camera) hold zeros.
///
/// The lane arrays come first and the struct is aligned to 64 bytes, so that every array
/// starts a cache line (see [`Aligned`]).
#[repr(C, align(64))]
pub(super) struct ShadingLanes<'a> {
    pub(super) p: Lanes3,
    /// Geometric normal (offsets shadow-ray origins).
    pub(super) ng: Lanes3,
    /// Normal of the side that reflects ([`reflecting_normal`]).
    pub(super) n: Lanes3,
    /// f = ρ/π on Lambertian lanes (zero on the others and outside `active`).
    pub(super) lambert: Lanes3,
    /// The shading frames of all lanes ([`shading_frame`], computed at once where
    /// `glossy_mask` ≠ 0): columns x̂, ŷ (n is `n`), and v = (v_x, 0, v_z) as [v_x, v_z].
    pub(super) frame_x: Lanes3,
    pub(super) frame_y: Lanes3,
    pub(super) v: [[f32; PACKET_LANES]; 2],
    pub(super) active: u32,
    /// The active lanes on non-Lambertian surfaces: `glossy[k]` is the scalar path's shading
    /// point of lane k there (its BSDF is evaluated lane by lane), `None` elsewhere and where
    /// the lanes sample in a batch kernel (they need only the frames below).
    pub(super) glossy_mask: u32,
    pub(super) glossy: [Option<ShadingPoint<'a>>; PACKET_LANES],
    /// The BSDF of the lanes in `glossy_mask` (`None` everywhere when `one_bsdf` is set).
    pub(super) bsdf: [Option<&'a Bsdf>; PACKET_LANES],
    /// The BSDF of every lane in `glossy_mask`, when all hit lanes lie on one glossy shape.
    pub(super) one_bsdf: Option<&'a Bsdf>,
}

impl Default for ShadingLanes<'_> {
    /// No active lane: zeros everywhere.
    #[inline(always)]
    fn default() -> Self {
        Self {
            active: 0,
            p: [[0.0; PACKET_LANES]; 3],
            ng: [[0.0; PACKET_LANES]; 3],
            n: [[0.0; PACKET_LANES]; 3],
            lambert: [[0.0; PACKET_LANES]; 3],
            glossy_mask: 0,
            glossy: [None; PACKET_LANES],
            bsdf: [None; PACKET_LANES],
            one_bsdf: None,
            frame_x: [[0.0; PACKET_LANES]; 3],
            frame_y: [[0.0; PACKET_LANES]; 3],
            v: [[0.0; PACKET_LANES]; 2],
        }
    }
}

/// The shading points of the lanes that hit a surface reflecting toward the camera: the
/// scalar integrator's `surface_point` and `reflecting_normal`. A glossy lane gets the scalar
/// path's [`ShadingPoint`] when `points` names the method (sampled lane by lane), else its
/// shading frame, which only `glossy_contributions` (batch kernels) reads. Written into `out`
/// (which holds [`ShadingLanes::default`]) in place: returned by value, the struct is copied.
///
#[inline(always)]
pub(super) fn shading_points<'a>(
    rs: &'a RenderScene,
    points: Option<Method>,
    rays: &RayLanes,
    hits: &PacketHits,
    out: &mut ShadingLanes<'a>,
) {
    let mut hit = HitSurfaces::default();
    hit_surfaces(rs, rays, hits, &mut hit);
    // One shape under every hit lane: Lambertian, or glossy where the lanes need no scalar
    // ShadingPoint (`points` = None: batch techniques, which read the frames).
    let uniform_shape = hit
        .one_shape
        .filter(|&s| rs.lambert[s as usize].is_some() || points.is_none());
    if let Some(shape) = uniform_shape {
        one_shape_lanes(rs, shape as usize, rays, hits, &hit, out);
    } else {
        lane_by_lane(rs, points, rays, hits, &hit, out);
    }
    // With `points` the glossy lanes are sampled lane by lane (their ShadingPoint has the
    // frame) or not in a batch at all: the frames would not be read.
    if out.glossy_mask != 0 && points.is_none() {
        shading_frames(
            rays,
            &out.n,
            (&mut out.frame_x, &mut out.frame_y, &mut out.v),
        );
    }
}

/// The surface points of a packet's hits, before the side that reflects is chosen (zeros in
/// the other lanes).
#[derive(Default)]
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
struct HitSurfaces {
    p: Lanes3,
    ng: Lanes3,
    /// Shading normal (the geometric one where the primitive has none).
    ns: Lanes3,
    /// The shape of each hit lane.
    shape_of: [u32; PACKET_LANES],
    /// The shape every hit lane lies on, if one (and there is a hit).
    one_shape: Option<u32>,
}

/// `Primitive::surface_point` of every hit lane with the `flip_normals` of its shape. The hit
/// lanes are taken a primitive at a time (a packet's sixteen samples of one or two pixels hit
/// few primitives): its lanes found by comparing the primitive index on all lanes at once, its
/// shape and triangle written into them by selects (lane by lane in groups of at most
/// `SMALL_GROUP` lanes, as lane-by-lane stores of every hit lane's vertices would stall the
/// first vector load after them: store forwarding); the triangle lanes' points are then
/// computed all at once ([`Triangles::surface_points`]), other primitives' lane by lane.
/// Written into `out` (which holds [`HitSurfaces::default`]) in place.
#[inline(always)]
fn hit_surfaces(rs: &RenderScene, rays: &RayLanes, hits: &PacketHits, out: &mut HitSurfaces) {
    // The triangle lanes' arrays are locals of their own: as fields of `Triangles` built
    // uninitialised, LLVM merges them with its zeroed fields into one `memset`.
    let (mut tri_v, mut tri_n) = (
        Aligned(MaybeUninit::uninit()),
        Aligned(MaybeUninit::uninit()),
    );
    let mut tri = Triangles::new(&mut tri_v, &mut tri_n);
    let (mut first_shape, mut one_shape) = (None, true);
    let mut m = hits.mask;
    while m != 0 {
        let i = hits.prim[m.trailing_zeros() as usize];
        let mut group = 0u32;
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            group |= ((hits.prim[k] == i) as u32) << k;
        }
        group &= m;
        m &= !group;
        let prim = rs.bvh.primitive(i);
        let shape = prim.shape();
        one_shape &= *first_shape.get_or_insert(shape) == shape;
        select_lanes(&mut out.shape_of, group, shape);
        let flip = rs.surfaces[shape as usize].1;
        match prim {
            Primitive::Triangle { v, n, .. } => tri.set(group, v, n.as_ref(), flip),
            _ => {
                let mut g = group;
                while g != 0 {
                    let k = g.trailing_zeros() as usize;
                    g &= g - 1;
                    let Some(hit) = hits.get(k) else { continue };
                    let sp = prim.surface_point(&rays.get(k), &hit, flip);
                    set3(&mut out.p, k, sp.p);
                    set3(&mut out.ng, k, sp.ng);
                    set3(&mut out.ns, k, sp.ns);
                }
            }
        }
    }
    if tri.mask != 0 {
        tri.surface_points(hits, &mut out.p, &mut out.ng, &mut out.ns);
    }
    out.one_shape = first_shape.filter(|_| one_shape);
}

/// The lanes of a packet whose hits all lie on `shape` (Lambertian, or glossy sampled in a
/// batch kernel): `reflecting_normal` and the stores of [`lane_by_lane`] on all lanes at once.
/// Lane k is active where n_s·ω_i > 0 (n = n_s) or, on a two-sided BSDF, n_s·ω_i < 0
/// (n = −n_s), with ω_i = −d and the dot product in glam's order (the same bits); the other
/// lanes keep their zeros (a glossy shape's lanes keep `lambert` at zero).
#[inline(always)]
fn one_shape_lanes<'a>(
    rs: &'a RenderScene,
    shape: usize,
    rays: &RayLanes,
    hits: &PacketHits,
    hit: &HitSurfaces,
    out: &mut ShadingLanes<'a>,
) {
    let (p, ng, ns) = (&hit.p, &hit.ng, &hit.ns);
    let bsdf = &rs.surfaces[shape].0;
    let two_sided = bsdf.is_two_sided();
    let lambert = rs.lambert[shape];
    let f = lambert.unwrap_or(Vec3::ZERO).to_array();
    let mut active = 0u32;
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let wi = [-rays.d[0][k], -rays.d[1][k], -rays.d[2][k]];
        let c = ns[0][k] * wi[0] + ns[1][k] * wi[1] + ns[2][k] * wi[2];
        let front = c > 0.0;
        let on = (hits.mask >> k & 1 == 1) & (front | ((c < 0.0) & two_sided));
        active |= (on as u32) << k;
        for a in 0..3 {
            let n = if front { ns[a][k] } else { -ns[a][k] };
            out.p[a][k] = if on { p[a][k] } else { 0.0 };
            out.ng[a][k] = if on { ng[a][k] } else { 0.0 };
            out.n[a][k] = if on { n } else { 0.0 };
            out.lambert[a][k] = if on { f[a] } else { 0.0 };
        }
    }
    out.active = active;
    // Written with `glossy_mask` in this branch-free step: lane by lane, the stores of `n`
    // would stall the frames' vector loads after them (store forwarding).
    if lambert.is_none() {
        out.glossy_mask = active;
        out.one_bsdf = Some(bsdf);
    }
}

/// The hit lanes one by one, each on its own shape: `reflecting_normal`, and on glossy
/// surfaces the BSDF and, when `points` names the method, the scalar path's shading point.
#[inline(always)]
fn lane_by_lane<'a>(
    rs: &'a RenderScene,
    points: Option<Method>,
    rays: &RayLanes,
    hits: &PacketHits,
    hit: &HitSurfaces,
    out: &mut ShadingLanes<'a>,
) {
    let mut m = hits.mask;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        let shape = hit.shape_of[k] as usize;
        let wi = -get3(&rays.d, k);
        let bsdf = &rs.surfaces[shape].0;
        let Some(n) = reflecting_normal(bsdf, get3(&hit.ns, k), wi) else {
            continue;
        };
        out.active |= 1 << k;
        let pk = get3(&hit.p, k);
        set3(&mut out.p, k, pk);
        set3(&mut out.ng, k, get3(&hit.ng, k));
        set3(&mut out.n, k, n);
        match rs.lambert[shape] {
            Some(f) => set3(&mut out.lambert, k, f),
            None => {
                // The scalar integrator's shading point (its n() is `n`, bit for bit).
                out.glossy_mask |= 1 << k;
                out.bsdf[k] = Some(bsdf);
                if let Some(method) = points {
                    out.glossy[k] = Some(glossy_point(method, bsdf, pk, n, wi));
                }
            }
        }
    }
}

/// The scalar path's shading frames (`ShadingPoint::new`) at normals `n` seen along the rays,
/// all lanes at once (branch-free): columns x̂ and ŷ, and v = (v_x, 0, v_z) as [v_x, v_z].
#[inline(always)]
fn shading_frames(
    rays: &RayLanes,
    n: &Lanes3,
    (frame_x, frame_y, v): (&mut Lanes3, &mut Lanes3, &mut [[f32; PACKET_LANES]; 2]),
) {
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let (frame, vk) = shading_frame(get3(n, k), -get3(&rays.d, k));
        set3(frame_x, k, frame.x_axis);
        set3(frame_y, k, frame.y_axis);
        // f32 values (dot products of f32 vectors), exactly.
        (v[0][k], v[1][k]) = (vk.x as f32, vk.z as f32);
    }
}

/// The scalar integrator's shading point; not inlined, as [`Context::scalar_samples`].
#[inline(never)]
fn glossy_point(method: Method, bsdf: &Bsdf, p: Vec3, n: Vec3, wi: Vec3) -> ShadingPoint<'_> {
    ShadingPoint::for_method(&SceneBsdf, method, bsdf, p, n, wi)
}
