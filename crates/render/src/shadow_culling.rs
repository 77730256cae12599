//! Per-light shadow occluder culling: for each light, the triangles that no shadow ray toward
//! that light can hit are left out of the BVH its shadow rays walk.
//!
//! # The rule (decided once per light when the scene is prepared)
//! Let P be a triangle with plane Π_P, unit normal N̂ (oriented toward the light) and signed
//! distance h_P(x) = N̂·(x − v₀). P is *culled* for light L when
//! 1. both ends of L's segment lie at h_P ≥ 2·(g_P + 8uS) + 10⁻³·|L| (the light is strictly on
//!    the positive side, with the guard margin g_P below, and a margin of 10⁻³ of the segment's
//!    length for shadow-ray targets that overshoot the segment's end in f32) — or, rule 1′,
//!    one end does (the light crosses or touches Π_P; N̂ toward the side that holds more of it)
//!    and the shadow rays' ends are guarded too (below) — and
//! 2. every point of every primitive of the scene (triangle vertices; the bounding-box corners
//!    of spheres, disks and cylinders) lies at h_P ≥ −τ, τ = 10⁻⁵·D (D: the diagonal of the
//!    scene's box grown by 1): shading points lie in the closed positive half-space up to
//!    rounding. Checked on the corners of the primitives' bounding box (sufficient), then,
//!    where they fail and the scene has at most `EXACT_CHECK` primitives, point by point.
//!
//! A segment between two points of the open half-space h_P > 0 does not meet Π_P, so in exact
//! arithmetic no shadow ray toward L meets P. Condition 2 only makes the culling *useful*
//! (shadow rays from shading points behind or on Π_P fall back to the full BVH, see below);
//! correctness rests on the guard alone.
//!
//! # The guard (per shadow ray, the rounding argument)
//! A shadow ray (o, d, t ∈ (0, t_max)) toward L walks L's culled BVH only when its origin passes
//! every culled plane's guard, h_P(o) ≥ g_P + 8uS (u = 2⁻²⁴; S = max(D, the largest |x| of the
//! grown scene box): f32 rounding of origins and targets grows with |x|, not only with D);
//! otherwise it walks the scene's full BVH. Its end o + t_max·d lies within a few u·S of the
//! segment from o to a point of L (the ray stops short of its target by SHADOW_EPSILON of its
//! length; the light's margin covers targets overshooting the segment's end), so both its ends
//! are at h_P ≥ g_P. Under rule 1′ the ray's end ê = o + t_max·d, computed in f32 (within 2u·S of
//! the exact end: ends lie in the grown box), must pass the same guard, h_P(ê) ≥ g_P + 8uS, so
//! that the exact end is at h_P ≥ g_P + 6uS; rays toward the light's part beyond Π_P fail it and
//! walk the full BVH. Möller–Trumbore
//! ([`crate::shapes::intersect_triangle_edges`], with or without fused multiply-adds) computes
//! t = num/det with num ≈ (o − v₀)·N, det ≈ −d·N, N = e₁ × e₂, within E_n ≤ 12u·|o − v₀||e₁||e₂|
//! and E_d ≤ 12u·|e₁||e₂| of their exact values (|d| = 1; a rounded difference, a cross product
//! and a dot product, each term bounded by the norms). If both ends of the ray are at h_P ≥ g_P
//! with
//!   g_P = 64·u·S / sin θ_P    (θ_P: the angle between e₁ and e₂; |N| = |e₁||e₂| sin θ_P),
//! then num has the sign of h_P(o) > 0 and the computed t is ≤ 0 (det ≤ 0), or, when the ray
//! heads toward Π_P, at least (h_P(o)|N| − E_n)/(|d·N| + E_d) > t_max because
//! t_max·|d·N̂| ≤ h_P(o) − h_P(end), or, heading away with a det of the wrong sign
//! (|det| ≤ 2E_d), at least (h_P(o)|N| − E_n)/(2E_d) > t_max. Both need
//! h_P ≥ 12u·(|o − v₀| + 2·t_max)/sin θ_P + O(u²) ≤ 36·u·S/sin θ_P, so g_P has a factor 1.8 to
//! spare (fused multiply-adds only shrink the errors). So P never reports a hit in (0, t_max)
//! for a ray that passes the guard, any-hit over the kept primitives equals any-hit over all
//! (the box tests are conservative, so the tree's shape does not matter), and images are bit
//! for bit those of the full BVH. `tests` checks it on every committed scene, rays from the
//! contact lines included.
//!
//! Triangles of (nearly) one plane share one guard plane: the guard of the group is evaluated in
//! f32 against a threshold raised by the f32 evaluation error and by the largest difference
//! between a member's h_P and the group plane's over the scene box.
//!
//! Shading points on P itself (or coplanar with it) pass when the push-off of the shadow ray's
//! origin, (1 + max|p_i|)·`RAY_EPSILON` toward the target's side (`RAY_EPSILON` = 1500u), is larger
//! than the guard, about (64/sin θ_P + 15)·u·S: on cornell-tube (D ≈ 6.9, right-angled triangles) ≥
//! 8.9·10⁻⁵ against g_P ≈ 3·10⁻⁵. Slivers (sin θ_P ≲ 0.05·S/(1 + |p|)) and points near the world
//! origin of a scene much larger than 1 (S ≫ 1 + |p|) fail it and take the full walk: slower, never
//! wrong. Points within ~g_P of Π_P on other primitives (the edges where walls and boxes touch)
//! fail the guard and take the full walk too. A light culls triangles of at most [`MAX_GUARDS`]
//! planes, and nothing unless it culls at least a third of the primitives (see
//! [`ShadowCulling::new`]).

use crate::bvh::{Bvh, RayLanes, PACKET};
use crate::light::Light;
use crate::shapes::{Primitive, Ray};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// u = 2⁻²⁴, the unit roundoff of f32.
const U: f64 = 1.0 / 16_777_216.0;

/// One guard plane: a ray from origin o may walk the culled BVH only if n·o ≥ w (in f32).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guard {
    pub n: [f32; 3],
    pub w: f32,
}

impl Guard {
    /// A plane every finite origin passes.
    const PASS: Guard = Guard {
        n: [0.0; 3],
        w: f32::NEG_INFINITY,
    };
}

/// Scenes of at most this many primitives check condition 2 point by point where the box
/// corners do not settle it; larger ones use the box corners only.
const EXACT_CHECK: usize = 4096;

/// Guard planes per light: a triangle whose plane would need more is kept (the packet guard
/// costs ~2 instructions per plane and lane whether used or not).
pub const MAX_GUARDS: usize = 6;

/// A culled shadow BVH, shared by the lights that cull the same triangles with the same
/// guards.
#[derive(Clone, Debug)]
struct ShadowSet {
    /// The kept primitives' BVH (empty: nothing occludes, no walk).
    bvh: Bvh,
    /// The guard planes of the culled triangles, the first `used` of them ([`Guard::PASS`]
    /// after): a fixed number, so that the packet guard is straight-line vector code.
    guards: [Guard; MAX_GUARDS],
    used: usize,
    /// The guard planes of the culled triangles whose plane the light crosses or touches, which
    /// the *end* of a ray (o + t_max·d) must pass too, the first `ends_used` of them.
    ends: [Guard; MAX_GUARDS],
    ends_used: usize,
    /// Indices (into the scene's primitives of finite bounds, in order) and copies of the
    /// culled triangles.
    culled_index: Vec<usize>,
    culled: Vec<Primitive>,
}

/// Per-light shadow BVHs (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct ShadowCulling {
    sets: Vec<ShadowSet>,
    /// Per light: its set, or `None` when it culls nothing (the scene's BVH is walked).
    light_set: Vec<Option<usize>>,
}

/// A triangle's plane in f64: unit normal, a vertex, sin θ between its edges.
#[derive(Clone)]
struct Plane {
    n: DVec3,
    v0: DVec3,
    sin: f64,
}

impl Plane {
    /// The plane of the triangle as the intersection kernels see it (v₀, e₁ = v₁ − v₀ and
    /// e₂ = v₂ − v₀ rounded in f32); `None` when degenerate.
    fn of(v: &[Vec3; 3]) -> Option<Self> {
        let (e1, e2) = ((v[1] - v[0]).as_dvec3(), (v[2] - v[0]).as_dvec3());
        let c = e1.cross(e2);
        let len = c.length();
        let sin = len / (e1.length() * e2.length());
        (len > 0.0 && sin.is_finite() && sin > 0.0).then(|| Self {
            n: c / len,
            v0: v[0].as_dvec3(),
            sin,
        })
    }

    fn h(&self, x: DVec3) -> f64 {
        self.n.dot(x - self.v0)
    }

    fn flipped(&self) -> Self {
        Self {
            n: -self.n,
            v0: self.v0,
            sin: self.sin,
        }
    }
}

/// A triangle that may be culled for some light: condition 2 holds on the `positive` or
/// `negative` side of its plane.
struct Candidate {
    /// Index into the primitives of finite bounds.
    index: usize,
    plane: Plane,
    positive: bool,
    negative: bool,
}

/// Points that bound a primitive: its vertices (triangles) or its box's corners.
fn hull_points(p: &Primitive) -> Vec<DVec3> {
    match p {
        Primitive::Triangle { v, .. } => v.iter().map(|x| x.as_dvec3()).collect(),
        _ => {
            let b = p.bounds();
            corners(b.min.as_dvec3(), b.max.as_dvec3()).to_vec()
        }
    }
}

fn corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    std::array::from_fn(|i| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// The smallest f32 ≥ x.
fn f32_at_least(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) >= x {
        f
    } else {
        f.next_up()
    }
}

/// The extent of a scene for the culling tests, in f64: the primitives' box corners, the box
/// that holds every ray origin (primitives and lights, grown by 1 and by the shadow rays'
/// offset) with its corners, diameter D and largest corner norm, and the margins that bound
/// f32 rounding there.
struct Extent {
    primitive_corners: [DVec3; 8],
    box_corners: [DVec3; 8],
    diameter: f64,
    max_norm: f64,
    /// max(D, largest corner norm): f32 rounding of origins and targets grows with their
    /// distance from the world origin, not only with the scene's size.
    scale: f64,
    /// 10⁻⁵·D, the tolerance of condition 2.
    tau: f64,
    /// 8u·scale.
    slack: f64,
}

impl Extent {
    /// The extent of the primitives `finite` (non-empty, finite bounds) and `lights`.
    fn new(finite: &[&Primitive], lights: &[Light]) -> Self {
        // The primitives' box; with the lights and grown by 1 it holds every ray origin.
        let (mut plo, mut phi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in finite {
            let b = p.bounds();
            plo = plo.min(b.min.as_dvec3());
            phi = phi.max(b.max.as_dvec3());
        }
        let (mut lo, mut hi) = (plo, phi);
        for l in lights {
            for x in [l.segment.begin.as_dvec3(), l.segment.end.as_dvec3()] {
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
        // Grown so that it also holds every shadow ray's origin, which the integrator pushes
        // off its surface by (1 + max|p|)·RAY_EPSILON.
        let far = lo.abs().max(hi.abs()).length();
        let grow = (1.0 + 1e-3 * (hi - lo).max_element())
            .max(2.0 * (1.0 + far) * crate::ray_offset::RAY_EPSILON as f64);
        let (lo, hi) = (lo - grow, hi + grow);
        let box_corners = corners(lo, hi);
        let diameter = (hi - lo).length();
        let max_norm = box_corners.iter().map(|c| c.length()).fold(0.0, f64::max);
        let scale = diameter.max(max_norm);
        Self {
            primitive_corners: corners(plo, phi),
            box_corners,
            diameter,
            max_norm,
            scale,
            tau: 1e-5 * diameter,
            slack: 8.0 * U * scale,
        }
    }
}

/// The triangles of `finite` that some light may cull: condition 2 does not depend on the
/// light, only on which side of the plane it lies, so it is decided once per triangle, on
/// each side. The lights then scan these candidates only (in a large scene, the few planes
/// that bound it).
fn candidates(finite: &[&Primitive], extent: &Extent) -> Vec<Candidate> {
    // Condition 2 is checked on the primitives' box corners (enough: every point lies in the
    // box and h is affine), and where they fail on every hull point when the scene is small
    // (O(triangles²) per light).
    let points: Vec<DVec3> = if finite.len() <= EXACT_CHECK {
        finite.iter().flat_map(|p| hull_points(p)).collect()
    } else {
        Vec::new()
    };
    let tau = extent.tau;
    finite
        .par_iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let Primitive::Triangle { v, .. } = p else {
                return None;
            };
            let pl = Plane::of(v)?;
            // The flipped plane's h is exactly −h (negation is exact), so each side's
            // condition is one bound on h.
            let all_above =
                |xs: &[DVec3], bound: f64, sign: f64| xs.iter().all(|&x| sign * pl.h(x) >= bound);
            let side = |sign: f64| {
                all_above(&extent.primitive_corners, -tau, sign)
                    || (!points.is_empty() && all_above(&points, -tau, sign))
            };
            let (positive, negative) = (side(1.0), side(-1.0));
            (positive || negative).then_some(Candidate {
                index: i,
                plane: pl,
                positive,
                negative,
            })
        })
        .collect()
}

/// A guard plane of [`culled_by`]: the plane, the threshold on h over it, and whether ray
/// ends must pass it too (rule 1′).
type Group = (Plane, f64, bool);

/// The candidates the light `a`–`b` culls (indices into the primitives of finite bounds, in
/// order) and their guard planes, at most [`MAX_GUARDS`].
fn culled_by(
    (a, b): (DVec3, DVec3),
    candidates: &[Candidate],
    extent: &Extent,
) -> (Vec<usize>, Vec<Group>) {
    let mut culled_index = Vec::new();
    let mut groups: Vec<Group> = Vec::new();
    for c in candidates {
        // The side that holds more of the light (the side of both ends where rule 1 holds).
        let (pl, below_ok) = if c.plane.h(a) + c.plane.h(b) < 0.0 {
            (c.plane.flipped(), c.negative)
        } else {
            (c.plane.clone(), c.positive)
        };
        let g = 64.0 * U * extent.scale / pl.sin;
        // Beyond 2·(g + slack), a margin of 10⁻³ of the segment's length: a shadow ray's
        // target (p + dist·ω from the sampler, in f32) can overshoot the segment's end where ω
        // is nearly along the line.
        let clear = 2.0 * (g + extent.slack) + 1e-3 * (b - a).length();
        let light_clear = pl.h(a) >= clear && pl.h(b) >= clear;
        // Rule 1′: part of the light clear of the plane, the ray ends guarded too.
        let ends = !light_clear;
        let useful = pl.h(a).max(pl.h(b)) >= clear;
        // The group whose plane differs from this one by at most 10⁻⁶·D over the scene box
        // (affine: the maximum is at a corner), or a new one if there is room: a triangle with
        // no guard plane left is kept.
        let dev = |q: &Plane| {
            (extent.box_corners.iter())
                .map(|&c| (pl.h(c) - q.h(c)).abs())
                .fold(0.0, f64::max)
        };
        let group = groups
            .iter()
            .position(|(q, _, _)| dev(q) <= 1e-6 * extent.diameter);
        let guarded = group.is_some() || groups.len() < MAX_GUARDS;
        if !(useful && guarded && below_ok) {
            continue;
        }
        let need = g + extent.slack;
        culled_index.push(c.index);
        match group {
            Some(k) => {
                groups[k].1 = groups[k].1.max(need + dev(&groups[k].0));
                groups[k].2 |= ends;
            }
            None => groups.push((pl, need, ends)),
        }
    }
    (culled_index, groups)
}

/// The f32 guards of `groups` ([`Guard::PASS`] after them) for points (ray origins and ends)
/// of norm ≤ `max_norm`.
fn guards_of<'a>(groups: impl Iterator<Item = &'a Group>, max_norm: f64) -> [Guard; MAX_GUARDS] {
    let mut guards = [Guard::PASS; MAX_GUARDS];
    for (g, (q, need, _)) in guards.iter_mut().zip(groups) {
        // h_q(o) = n·o − n·v₀; the f32 n·o is within 7u·max|o| of the exact one (n rounded to
        // f32, three products and two sums).
        let c = q.n.dot(q.v0);
        *g = Guard {
            n: q.n.as_vec3().to_array(),
            w: f32_at_least(c + need + 7.0 * U * max_norm + 1e-12 * max_norm),
        };
    }
    guards
}

/// A light's guards: those of ray origins and those of ray ends, each with its count.
struct Guards {
    origins: ([Guard; MAX_GUARDS], usize),
    ends: ([Guard; MAX_GUARDS], usize),
}

impl ShadowCulling {
    /// The culled shadow BVH of each light, from the scene's primitives. A light that culls
    /// fewer than a third of the primitives culls none (its shadow rays walk the scene's BVH):
    /// the guard would cost more than the walk saves.
    pub fn new(prims: &[Primitive], lights: &[Light]) -> Self {
        let finite: Vec<&Primitive> = prims
            .iter()
            .filter(|p| {
                let b = p.bounds();
                b.min.is_finite() && b.max.is_finite()
            })
            .collect();
        if finite.is_empty() {
            return Self::default();
        }
        let extent = Extent::new(&finite, lights);
        let candidates = candidates(&finite, &extent);
        let mut out = Self::default();
        for l in lights {
            let ends = (l.segment.begin.as_dvec3(), l.segment.end.as_dvec3());
            let (culled_index, groups) = culled_by(ends, &candidates, &extent);
            // A light gets a culled set only when it drops at least a third of the finite
            // primitives: below that the guard test of every shadow ray costs more than the
            // shorter walk saves (instructions per sample, docs/performance.md).
            if culled_index.is_empty() || 3 * culled_index.len() < finite.len() {
                out.light_set.push(None);
                continue;
            }
            let guards = guards_of(groups.iter(), extent.max_norm);
            let ends = guards_of(groups.iter().filter(|g| g.2), extent.max_norm);
            let ends_used = groups.iter().filter(|g| g.2).count();
            let guards = Guards {
                origins: (guards, groups.len()),
                ends: (ends, ends_used),
            };
            out.add_light(culled_index, guards, &finite);
        }
        out
    }

    /// Adds a light that culls the primitives `culled_index` of `finite` with `guards`: the set
    /// of an earlier light with the same culled primitives and guards, or a new set.
    fn add_light(&mut self, culled_index: Vec<usize>, guards: Guards, finite: &[&Primitive]) {
        let Guards {
            origins: (guards, used),
            ends: (ends, ends_used),
        } = guards;
        let same = |t: &ShadowSet| {
            t.culled_index == culled_index
                && (t.used, t.ends_used) == (used, ends_used)
                && (t.guards, t.ends) == (guards, ends)
        };
        if let Some(k) = self.sets.iter().position(same) {
            self.light_set.push(Some(k));
            return;
        }
        // The copies of the kept primitives are made only for a new set.
        let mut culled = Vec::with_capacity(culled_index.len());
        let mut kept = Vec::with_capacity(finite.len() - culled_index.len());
        let mut next = culled_index.iter().peekable();
        for (i, p) in finite.iter().enumerate() {
            if next.next_if_eq(&&i).is_some() {
                culled.push((*p).clone());
            } else {
                kept.push((*p).clone());
            }
        }
        self.light_set.push(Some(self.sets.len()));
        self.sets.push(ShadowSet {
            bvh: Bvh::build(kept),
            guards,
            used,
            ends,
            ends_used,
            culled_index,
            culled,
        });
    }

    fn set(&self, j: usize) -> Option<&ShadowSet> {
        self.light_set
            .get(j)
            .copied()
            .flatten()
            .map(|k| &self.sets[k])
    }

    /// The triangles culled for light `j` (none for an unknown light).
    pub fn culled(&self, j: usize) -> &[Primitive] {
        self.set(j).map_or(&[], |t| &t.culled)
    }

    /// The guard planes of light `j`'s culled BVH (of ray origins; those of ray ends are a
    /// subset: [`Self::end_guards`]).
    pub fn guards(&self, j: usize) -> &[Guard] {
        self.set(j).map_or(&[], |t| &t.guards[..t.used])
    }

    /// The guard planes that the ends of light `j`'s shadow rays must pass (rule 1′).
    pub fn end_guards(&self, j: usize) -> &[Guard] {
        self.set(j).map_or(&[], |t| &t.ends[..t.ends_used])
    }

    /// Whether shadow ray `ray` toward light `j` walks the light's culled BVH.
    pub fn walks_culled(&self, j: usize, ray: &Ray) -> bool {
        self.set(j).is_some_and(|t| t.admits(ray))
    }

    /// Whether shadow ray `ray` toward light `j` meets a primitive of the scene: the answer of
    /// `full.occluded(ray)`, by the light's culled BVH where the ray passes its guard.
    #[inline]
    pub fn occluded(&self, full: &Bvh, j: usize, ray: &Ray) -> bool {
        match self.set(j) {
            Some(t) if t.admits(ray) => !t.bvh.is_empty() && t.bvh.occluded(ray),
            _ => full.occluded(ray),
        }
    }

    /// [`Self::occluded`] for the lanes of `mask`, lane k toward light `light[k]` (or every
    /// lane toward `uniform` when given): one packet walk of each culled BVH (lights that cull
    /// the same triangles share one) for its lanes that pass the guard, one walk of `full` for
    /// the others. The same bits as `full.occluded_lanes(rays, mask)`.
    #[inline(always)]
    pub fn occluded_lanes(
        &self,
        full: &Bvh,
        light: &[u32; PACKET],
        uniform: Option<usize>,
        rays: &RayLanes,
        mask: u32,
    ) -> u32 {
        if self.sets.is_empty() || mask == 0 {
            return full.occluded_lanes(rays, mask);
        }
        let mut rest = mask;
        let mut occluded = 0;
        for (s, t) in self.sets.iter().enumerate() {
            let lanes = match uniform {
                Some(u) => {
                    if self.light_set.get(u).copied().flatten() == Some(s) {
                        rest
                    } else {
                        0
                    }
                }
                None => {
                    let mut m = 0u32;
                    for (k, &l) in light.iter().enumerate() {
                        let on = self.light_set.get(l as usize).copied().flatten() == Some(s);
                        m |= (on as u32) << k;
                    }
                    m & rest
                }
            };
            if lanes == 0 {
                continue;
            }
            let mut safe = lanes & passes_lanes(&t.guards, t.used, &rays.o);
            if t.ends_used > 0 && safe != 0 {
                safe &= passes_lanes(&t.ends, t.ends_used, &ray_ends(rays));
            }
            if safe != 0 {
                if !t.bvh.is_empty() {
                    occluded |= t.bvh.occluded_lanes(rays, safe);
                }
                rest &= !safe;
            }
        }
        if rest != 0 {
            occluded |= full.occluded_lanes(rays, rest);
        }
        occluded
    }
}

impl ShadowSet {
    /// Whether `ray` may walk this set's BVH: its origin passes every guard, and its end
    /// o + t_max·d (f32) every end guard.
    #[inline]
    fn admits(&self, ray: &Ray) -> bool {
        passes(&self.guards, ray.o)
            && (self.ends_used == 0 || passes(&self.ends, ray_end(ray.o, ray.d, ray.t_max)))
    }
}

/// The end o + t_max·d of a ray, in f32 (not fused: within 2u·S of the exact end).
#[inline(always)]
fn ray_end(o: Vec3, d: Vec3, t_max: f32) -> Vec3 {
    Vec3::new(o.x + t_max * d.x, o.y + t_max * d.y, o.z + t_max * d.z)
}

/// [`ray_end`] of every lane.
#[inline(always)]
fn ray_ends(rays: &RayLanes) -> [[f32; PACKET]; 3] {
    let mut e = [[0.0; PACKET]; 3];
    for (a, e) in e.iter_mut().enumerate() {
        let (o, d) = (&rays.o[a], &rays.d[a]);
        for (k, e) in e.iter_mut().enumerate() {
            *e = o[k] + rays.t_max[k] * d[k];
        }
    }
    e
}

/// Whether point `o` passes every guard.
#[inline]
fn passes(guards: &[Guard; MAX_GUARDS], o: Vec3) -> bool {
    guards
        .iter()
        .all(|g| g.n[0] * o.x + g.n[1] * o.y + g.n[2] * o.z >= g.w)
}

/// The lanes whose point (ray origin or end) passes the first `used` guards (the others pass
/// every point).
#[inline(always)]
fn passes_lanes(guards: &[Guard; MAX_GUARDS], used: usize, points: &[[f32; PACKET]; 3]) -> u32 {
    // A constant number of planes per call: straight-line vector code.
    match used {
        0 => u32::MAX,
        1 => passes_first::<1>(guards, points),
        2 => passes_first::<2>(guards, points),
        3 => passes_first::<3>(guards, points),
        4 => passes_first::<4>(guards, points),
        5 => passes_first::<5>(guards, points),
        _ => passes_first::<MAX_GUARDS>(guards, points),
    }
}

/// The lanes (all [`PACKET`] computed) whose point passes guards 0..N.
#[inline(always)]
fn passes_first<const N: usize>(guards: &[Guard; MAX_GUARDS], points: &[[f32; PACKET]; 3]) -> u32 {
    let [ox, oy, oz] = points;
    // Lane masks as u32 words (0 or !0): the loop runs on vector registers.
    let mut ok = [u32::MAX; PACKET];
    for g in &guards[..N] {
        let [nx, ny, nz] = g.n;
        for k in 0..PACKET {
            let s = nx * ox[k] + ny * oy[k] + nz * oz[k];
            ok[k] &= if s >= g.w { u32::MAX } else { 0 };
        }
    }
    let mut m = 0u32;
    for (k, &b) in ok.iter().enumerate() {
        m |= (b & 1) << k;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray_offset::shadow_ray_to;
    use crate::render_scene::RenderScene;
    use crate::shapes::SurfacePoint;
    use linlight_sampling::rng::Pcg32;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3], shape: u32) -> Primitive {
        Primitive::Triangle {
            v: [a.into(), b.into(), c.into()],
            n: None,
            shape,
        }
    }

    /// The rectangle a–b–c–d as two triangles.
    fn quad(a: [f32; 3], b: [f32; 3], c: [f32; 3], d: [f32; 3], shape: u32) -> [Primitive; 2] {
        [tri(a, b, c, shape), tri(a, c, d, shape)]
    }

    fn floor_z(z: f32, shape: u32) -> [Primitive; 2] {
        quad(
            [-1., -1., z],
            [1., -1., z],
            [1., 1., z],
            [-1., 1., z],
            shape,
        )
    }

    fn wall_y(y: f32, shape: u32) -> [Primitive; 2] {
        quad([-1., y, 0.], [1., y, 0.], [1., y, 2.], [-1., y, 2.], shape)
    }

    /// Lights of unit K along the segments `ends`.
    fn lines(ends: &[(Vec3, Vec3)]) -> Vec<Light> {
        (ends.iter())
            .map(|&(a, b)| Light::new(linlight_sampling::Segment::new(a, b), Vec3::ONE))
            .collect()
    }

    fn culled_shapes(c: &ShadowCulling, j: usize) -> Vec<u32> {
        let mut s: Vec<u32> = c.culled(j).iter().map(|p| p.shape()).collect();
        s.dedup();
        s
    }

    #[test]
    fn walls_enclosing_the_light_are_culled_occluders_between_are_kept() {
        let mut prims = Vec::new();
        prims.extend(floor_z(0.0, 0));
        prims.extend(wall_y(1.0, 1));
        // A small occluder between floor and light: the floor lies below its plane.
        prims.push(tri([-0.2, -0.2, 0.5], [0.2, -0.2, 0.5], [0.0, 0.2, 0.5], 2));
        let light = (Vec3::new(-0.5, 0.0, 1.5), Vec3::new(0.5, 0.0, 1.5));
        let c = ShadowCulling::new(&prims, &lines(&[light]));
        assert_eq!(culled_shapes(&c, 0), vec![0, 1]);
        assert_eq!(c.culled(0).len(), 4);
    }

    #[test]
    fn a_wall_with_a_point_behind_it_is_kept() {
        let mut prims = Vec::new();
        prims.extend(floor_z(0.0, 0));
        prims.extend(wall_y(1.0, 1));
        // Behind the back wall (y > 1): a shading point there could be shadowed by the wall.
        // It is itself culled: everything lies on the light's side of its plane y = 1.5.
        prims.push(tri([0.0, 1.5, 0.0], [0.5, 1.5, 0.0], [0.0, 1.5, 0.5], 2));
        let light = (Vec3::new(-0.5, 0.0, 1.5), Vec3::new(0.5, 0.0, 1.5));
        let c = ShadowCulling::new(&prims, &lines(&[light]));
        assert_eq!(culled_shapes(&c, 0), vec![0, 2]);
    }

    #[test]
    fn a_light_crossing_or_touching_the_plane_culls_it_with_end_guards() {
        let prims: Vec<Primitive> = floor_z(0.0, 0).into();
        let crossing = (Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.0, 0.0, 0.5));
        let touching = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0));
        let grazing = (Vec3::new(0.0, 0.0, 1e-6), Vec3::new(1.0, 0.0, 1e-6));
        let above = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        let c = ShadowCulling::new(&prims, &lines(&[crossing, touching, grazing, above]));
        for j in [0, 1] {
            assert_eq!(
                (c.culled(j).len(), c.end_guards(j).len()),
                (2, 1),
                "light {j}"
            );
        }
        assert!(c.culled(2).is_empty());
        assert_eq!((c.culled(3).len(), c.end_guards(3).len()), (2, 0));
        // From above the floor toward the crossing light's part above it: the culled walk;
        // toward its part below (through the floor), or to the plane: the full BVH.
        let full = Bvh::build(prims.clone());
        let toward = |z: f32| {
            let o = Vec3::new(0.5, 0.25, 0.25);
            let d = Vec3::new(0.0, 0.0, z) - o;
            Ray {
                o,
                d: d.normalize(),
                t_min: 0.0,
                t_max: d.length() * (1.0 - 1e-3),
            }
        };
        assert!(c.walks_culled(0, &toward(0.4)) && !c.occluded(&full, 0, &toward(0.4)));
        assert!(!c.walks_culled(0, &toward(-0.4)) && c.occluded(&full, 0, &toward(-0.4)));
    }

    #[test]
    fn everything_culled_means_no_walk_and_the_guard_falls_back_below_the_plane() {
        let prims: Vec<Primitive> = floor_z(0.0, 0).into();
        let full = Bvh::build(prims.clone());
        let c = ShadowCulling::new(
            &prims,
            &lines(&[(Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0))]),
        );
        assert_eq!(c.culled(0).len(), 2);
        let up = |z: f32| Ray {
            o: Vec3::new(0.1, 0.2, z),
            d: Vec3::Z,
            t_min: 0.0,
            t_max: 1.0 - z,
        };
        // Above the floor: the empty culled set answers without a walk.
        assert!(c.walks_culled(0, &up(0.5)) && !c.occluded(&full, 0, &up(0.5)));
        // Below it (no shading point lies there, but a ray may): the full BVH answers.
        assert!(!c.walks_culled(0, &up(-0.5)) && c.occluded(&full, 0, &up(-0.5)));
        // On the plane, within the guard: the full BVH.
        assert!(!c.walks_culled(0, &up(0.0)));
        assert!(!c.walks_culled(0, &up(1e-5)));
    }

    /// The closed box [−1, 1]² × [0, 2] as six quads, shapes 0–5: floor, ceiling, walls
    /// x = −1, x = 1, y = −1, y = 1.
    fn closed_box() -> Vec<Primitive> {
        let wall_x =
            |x: f32, shape| quad([x, -1., 0.], [x, 1., 0.], [x, 1., 2.], [x, -1., 2.], shape);
        [
            floor_z(0.0, 0),
            floor_z(2.0, 1),
            wall_x(-1.0, 2),
            wall_x(1.0, 3),
            wall_y(-1.0, 4),
            wall_y(1.0, 5),
        ]
        .concat()
    }

    /// The shadow rays the renderer casts — toward `p + dist·ω` with ω and dist from every
    /// technique's sampler (`single_sample`), not toward exact points of the segment — in a
    /// closed box whose wall y = 1 the light's end nearly touches: the light runs along y
    /// toward that wall and ends as close to it as still lets the wall be culled. Shading
    /// points on the opposite wall near the line's extension see the light end-on, where the
    /// sampled distance (d / ĉ·ω) is ill-conditioned and targets overshoot the segment's end;
    /// others on the wall y = 1 around the light's end and on the walls near it. Every ray
    /// answers as the full BVH, and no culled triangle reports a hit for a ray that walks the
    /// culled BVH. (Targets overshoot the end by ~10⁻⁶ here, well inside the light's margin; a
    /// `distance_to_line` 0.3 % too long fails the test, the committed-scene test passes it.)
    /// The same with the light's end on the wall (gap 0), which rule 1′ culls with end guards.
    #[test]
    fn sampler_built_shadow_rays_near_a_wall_the_light_nearly_touches() {
        let prims = closed_box();
        let full = Bvh::build(prims.clone());
        let light = |gap: f32| (Vec3::new(0.0, -0.5, 1.0), Vec3::new(0.0, 1.0 - gap, 1.0));
        // Culled by rule 1 (no end guard).
        let wall_culled = |gap: f32| {
            let c = ShadowCulling::new(&prims, &lines(&[light(gap)]));
            c.culled(0).iter().any(|p| p.shape() == 5) && c.end_guards(0).is_empty()
        };
        // The smallest gap (to a relative 10⁻⁴) at which rule 1 culls the wall y = 1.
        let (mut lo, mut hi) = (0.0f32, 0.5f32);
        assert!(!wall_culled(lo) && wall_culled(hi));
        while hi - lo > 1e-4 * hi {
            let mid = 0.5 * (lo + hi);
            if wall_culled(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        for (gap, rule_1) in [(hi, true), (0.0, false)] {
            let (begin, end) = light(gap);
            sampler_built_rays(&prims, &full, (begin, end), rule_1);
        }
    }

    /// [`sampler_built_shadow_rays_near_a_wall_the_light_nearly_touches`] for the light
    /// `begin`–`end`, which culls every wall (by rule 1 alone if `rule_1`).
    fn sampler_built_rays(
        prims: &[Primitive],
        full: &Bvh,
        (begin, end): (Vec3, Vec3),
        rule_1: bool,
    ) {
        use crate::shading::single_sample;
        use linlight_sampling::{Segment, Technique};
        let sh = ShadowCulling::new(prims, &lines(&[(begin, end)]));
        assert_eq!(culled_shapes(&sh, 0), vec![0, 1, 2, 3, 4, 5]);
        let segment = Segment::new(begin, end);
        let mut rng = Pcg32::new(0x5eed, 7);
        // (point, geometric normal toward the box's inside, shape).
        let mut points: Vec<(Vec3, Vec3, u32)> = Vec::new();
        for i in 0..4000 {
            // Log-uniform distance r ∈ [10⁻⁷, 10⁻¹] from the line's axis (x = 0, z = 1).
            let r = 10f32.powf(-7.0 + 6.0 * rng.next_f32());
            let phi = std::f32::consts::TAU * rng.next_f32();
            let (dx, dz) = (r * phi.cos(), r * phi.sin());
            match i % 4 {
                // The opposite wall around the line's extension: the light seen end-on.
                0 | 1 => points.push((Vec3::new(dx, -1.0, 1.0 + dz), Vec3::Y, 4)),
                // The wall y = 1 around the light's end.
                2 => points.push((Vec3::new(dx, 1.0, 1.0 + dz), -Vec3::Y, 5)),
                // The floor and the side walls within r of the wall y = 1.
                _ => {
                    let u = 2.0 * rng.next_f32() - 1.0;
                    let y = 1.0 - r;
                    points.push(match (i / 4) % 3 {
                        0 => (Vec3::new(u, y, 0.0), Vec3::Z, 0),
                        1 => (Vec3::new(-1.0, y, 1.0 + u), Vec3::X, 2),
                        _ => (Vec3::new(1.0, y, 1.0 + u), -Vec3::X, 3),
                    });
                }
            }
        }
        let (mut rays, mut walked_culled, mut overshoot, mut diffs, mut culled_hits) =
            (0u64, 0u64, 0u64, 0u64, 0u64);
        let mut farthest = 0.0f32;
        for &(p, ng, shape) in &points {
            let sp = SurfacePoint {
                p,
                ng,
                ns: ng,
                shape,
            };
            for technique in Technique::ALL {
                let Some(sampler) = technique.prepare(&segment, p, ng) else {
                    continue;
                };
                for i in 0..8 {
                    let xi = match i {
                        0 => 0.0,
                        1 => 1.0,
                        2 => 1.0 - f32::EPSILON / 2.0,
                        _ => rng.next_f32(),
                    };
                    let Some(sample) = single_sample(&sampler, ng, xi) else {
                        continue;
                    };
                    // The integrator's target (`radiance`'s `visible`, the packet renderer's
                    // `shadow_rays`).
                    let target = p + sample.dist * sample.w;
                    let Some(ray) = shadow_ray_to(&sp, target) else {
                        continue;
                    };
                    rays += 1;
                    overshoot += (target.y > end.y) as u64;
                    farthest = farthest.max(target.y - end.y);
                    diffs += (sh.occluded(full, 0, &ray) != full.occluded(&ray)) as u64;
                    if sh.walks_culled(0, &ray) {
                        walked_culled += 1;
                        culled_hits += sh
                            .culled(0)
                            .iter()
                            .filter(|p| p.intersect(&ray).is_some())
                            .count() as u64;
                    }
                }
            }
        }
        let report = format!(
            "light end at y = {}: {rays} rays, {walked_culled} walked the culled BVH, {overshoot} \
             targets beyond the light's end (by up to {farthest:e}); differences {diffs}, culled hits \
             {culled_hits}",
            end.y
        );
        eprintln!("{report}");
        assert_eq!((diffs, culled_hits), (0, 0), "{report}");
        // Not vacuous: most rays take the culled walk, and targets do overshoot.
        if rule_1 {
            assert!(walked_culled * 2 > rays && overshoot > 100, "{report}");
        }
    }

    fn nudge(x: f32, steps: i32) -> f32 {
        let mut y = x;
        for _ in 0..steps.abs() {
            y = if steps > 0 {
                y.next_up()
            } else {
                y.next_down()
            };
        }
        y
    }

    /// Every committed scene, every light: shadow rays from shading points on every primitive
    /// (random barycentrics, the vertices and edges — where walls and boxes touch — nudged by
    /// up to 3 ulp, and the closest hits of random rays) to the light's ends and random points
    /// of it. The culled BVH answers exactly as the full one (scalar and packet walks, lanes of
    /// one light and of mixed lights), and no culled triangle reports a hit for a ray that
    /// walks the culled BVH.
    #[test]
    fn culled_walks_answer_as_the_full_bvh_on_every_committed_scene() {
        let mut report = Vec::new();
        for path in crate::test_scenes::committed() {
            let scene = crate::xml::load_scene(&path, &[]).unwrap();
            let rs = RenderScene::new(&scene).unwrap();
            let (bvh, sh) = (&rs.bvh, &rs.shadows);
            let prims: Vec<Primitive> = (0..bvh.len())
                .map(|i| bvh.primitive(i as u32).clone())
                .collect();
            let mut rng = Pcg32::new(0x5eed, path.as_os_str().len() as u64);
            let mut points: Vec<SurfacePoint> = Vec::new();
            let point = |v: [Vec3; 3], b1: f32, b2: f32, shape: u32| {
                let b0 = 1.0 - b1 - b2;
                let ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                SurfacePoint {
                    p: b0 * v[0] + b1 * v[1] + b2 * v[2],
                    ng,
                    ns: ng,
                    shape,
                }
            };
            // Points on each triangle: random, on its edges, its vertices nudged.
            let per_triangle = (20_000 / prims.len().max(1)).clamp(8, 400);
            for p in &prims {
                let Primitive::Triangle { v, shape, .. } = *p else {
                    continue;
                };
                for i in 0..per_triangle {
                    let (mut b1, mut b2) = (rng.next_f32(), rng.next_f32());
                    if b1 + b2 > 1.0 {
                        (b1, b2) = (1.0 - b1, 1.0 - b2);
                    }
                    match i % 4 {
                        0 => b1 = 0.0,
                        1 => b2 = 0.0,
                        2 => b2 = 1.0 - b1,
                        _ => {}
                    }
                    points.push(point(v, b1, b2, shape));
                }
                for (b1, b2) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
                    let sp = point(v, b1, b2, shape);
                    for s in [-3, -1, 0, 1, 3] {
                        for a in 0..3 {
                            let mut q = sp;
                            q.p[a] = nudge(q.p[a], s);
                            points.push(q);
                        }
                    }
                }
            }
            // Closest hits of random rays through the scene (spheres, disks included).
            let (lo, hi) = prims
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), p| {
                    let b = p.bounds();
                    (l.min(b.min), h.max(b.max))
                });
            for _ in 0..4000 {
                let at = |r: &mut Pcg32| {
                    lo + (hi - lo) * Vec3::new(r.next_f32(), r.next_f32(), r.next_f32())
                };
                let (o, t) = (at(&mut rng), at(&mut rng));
                let ray = Ray {
                    o,
                    d: (t - o).normalize(),
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                if let Some(hit) = bvh.intersect(&ray) {
                    points.push(bvh.primitive(hit.prim).surface_point(&ray, &hit, false));
                }
            }
            let (mut rays, mut diffs, mut culled_hits, mut walked_culled) =
                (0u64, 0u64, 0u64, 0u64);
            let mut lanes = RayLanes::default();
            let mut lights = [0u32; PACKET];
            let mut expect = 0u32;
            let mut filled = 0usize;
            let mut packet_diffs = 0u64;
            // The packet walks against the full BVH's packet walk. Returns (differences, lanes
            // where the full packet walk differs from the full scalar walk: rounding of the
            // existing kernels, not asserted here).
            let flush = |lanes: &RayLanes, lights: &[u32; PACKET], scalar: u32, n: usize| {
                let mask = ((1u64 << n) - 1) as u32;
                let expect = bvh.occluded_lanes(lanes, mask);
                let mut d = (sh.occluded_lanes(bvh, lights, None, lanes, mask) != expect) as u64;
                if lights.iter().take(n).all(|&l| l == lights[0]) {
                    let got = sh.occluded_lanes(bvh, lights, Some(lights[0] as usize), lanes, mask);
                    d += (got != expect) as u64;
                }
                (d, (expect ^ scalar).count_ones() as u64)
            };
            let mut packet_vs_scalar = 0u64;
            for sp in &points {
                for (j, Light { segment, .. }) in rs.lights.iter().enumerate() {
                    for i in 0..6 {
                        let s = match i {
                            0 => 0.0,
                            1 => 1.0,
                            _ => rng.next_f32(),
                        };
                        let target = segment.begin + s * (segment.end - segment.begin);
                        let Some(ray) = shadow_ray_to(sp, target) else {
                            continue;
                        };
                        rays += 1;
                        let full = bvh.occluded(&ray);
                        diffs += (sh.occluded(bvh, j, &ray) != full) as u64;
                        if sh.walks_culled(j, &ray) {
                            walked_culled += 1;
                            culled_hits += sh
                                .culled(j)
                                .iter()
                                .filter(|p| p.intersect(&ray).is_some())
                                .count() as u64;
                        }
                        lanes.set(filled, &ray);
                        // Alternate lanes' lights when there are several: mixed packets.
                        lights[filled] = j as u32;
                        expect |= (full as u32) << filled;
                        filled += 1;
                        if filled == PACKET {
                            let (d, ps) = flush(&lanes, &lights, expect, filled);
                            (packet_diffs, packet_vs_scalar) =
                                (packet_diffs + d, packet_vs_scalar + ps);
                            (filled, expect) = (0, 0);
                        }
                    }
                }
            }
            if filled > 0 {
                let (d, ps) = flush(&lanes, &lights, expect, filled);
                (packet_diffs, packet_vs_scalar) = (packet_diffs + d, packet_vs_scalar + ps);
            }
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            let kept: Vec<String> = (0..rs.lights.len())
                .map(|j| {
                    format!(
                        "{} ({} guards)",
                        prims.len() - sh.culled(j).len(),
                        sh.guards(j).len()
                    )
                })
                .collect();
            report.push(format!(
                "{name}: {} primitives, kept per light {kept:?}; {rays} rays, {walked_culled} \
                 walked the culled BVH; differences {diffs}, packet {packet_diffs}, culled hits \
                 {culled_hits} (full packet vs full scalar walk: {packet_vs_scalar})",
                prims.len()
            ));
            assert_eq!(
                (diffs, packet_diffs, culled_hits),
                (0, 0, 0),
                "{}",
                report.last().unwrap()
            );
            if name == "cornell-tube" {
                // Not vacuous: the five walls are culled and most rays take the culled walk.
                // Walls (8 triangles), floor (2) and the boxes' bottoms (4, in the floor's plane).
                assert_eq!(sh.culled(0).len(), 14, "{}", report.last().unwrap());
                assert!(walked_culled * 2 > rays, "{}", report.last().unwrap());
            }
        }
        eprintln!("{}", report.join("\n"));
    }
}
