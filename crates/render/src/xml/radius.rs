//! The size of Mitsuba's finite-radius effect per pixel: how far its open cylinder of radius R
//! is from the line limit R → 0 that linlight renders, estimated from the scene alone.
//!
//! The measure (derivation in docs/oracle.md, "Finite radius"): a uniform emitter's irradiance
//! depends only on its outline as seen from the point x. The outline of the tube's side is the
//! line limit's strip of width 2R up to second order in R; what differs at first order is the
//! two open ends. An end seen from the inner side of its plane adds the half-ellipse of outer
//! surface that bulges beyond the strip; an end seen from outside its plane shows its opening
//! (the inner side, which does not emit) over the half-ellipse inside the strip. With radiance
//! L = K/R, end e at distance r_e, cos θ_e between the axis and the direction to it:
//!
//!   ΔE(x) = K·R·(π/2)·Σ_e s_e·|cos θ_e|·max(0, n·ω_e)/r_e²,   s_e = ±1 (inner / outer side),
//!   E(x)  = 2K·∫₀ᴸ sin θ(s)·max(0, n·ω(s))/r(s)² ds   (the line limit),
//!
//! so the relative difference ΔE/E is c(x)·R, c of order 1/length away from the axis (0.3–0.5
//! per unit in a unit box) and large near the axis extension beyond an end, where E vanishes
//! like the distance to the axis while ΔE does not. The largest per-pixel value is therefore at
//! the first surface the axis extension meets: there ΔE and E are averaged over one pixel's
//! footprint. Occlusion is ignored (the estimate is an upper bound of the unoccluded effect).

use crate::bvh::Bvh;
use crate::scene::{Geometry, LinearLight, Scene};
use crate::shapes::{Primitive, Ray};
use glam::DVec3;

/// Above this estimated largest relative per-pixel difference a light gets a warning.
pub const WARN_RELATIVE: f64 = 1e-3;

/// One light's estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct RadiusEffect {
    /// Index into `Scene::lights`.
    pub light: usize,
    /// Estimated largest relative per-pixel difference |ΔE/E| of Mitsuba's finite tube against
    /// the line limit, on the surfaces its axis extension meets.
    pub per_pixel: f64,
    /// Where (the point the axis extension meets), and the sign of ΔE there (< 0: Mitsuba darker).
    pub at: DVec3,
    pub signed: f64,
}

/// Relative first-order difference ΔE/E at point x with normal n, for the segment p0→p1 of
/// radius r; None where the line limit gives no light (E = 0).
pub fn relative_at(x: DVec3, n: DVec3, p0: DVec3, p1: DVec3, r: f64) -> Option<f64> {
    let (de, e) = rim_and_line(x, n, p0, p1, r);
    (e > 0.0).then(|| de / e)
}

/// (ΔE, E) per unit K at x (see the module docs), E in closed form ([`line_irradiance`]).
fn rim_and_line(x: DVec3, n: DVec3, p0: DVec3, p1: DVec3, r: f64) -> (f64, f64) {
    let axis = p1 - p0;
    let a = axis / axis.length();
    let e = line_irradiance(x, n, p0, p1);
    let mut rim = 0.0;
    for (end, outward) in [(p0, -a), (p1, a)] {
        let d = end - x;
        let r2 = d.length_squared();
        if r2 == 0.0 {
            continue;
        }
        let w = d / r2.sqrt();
        let side = if (x - end).dot(outward) < 0.0 {
            1.0
        } else {
            -1.0
        };
        rim += side * w.dot(a).abs() * n.dot(w).max(0.0) / r2;
    }
    (std::f64::consts::FRAC_PI_2 * r * rim, e)
}

/// E per unit K at x, normal n, of the segment p0→p1: Ω⊥_R = ∫ 2 sin θ·max(0, n·ω)/r² dt,
/// clipped at the tangent plane. With h the distance from x to the line, f̂ the unit vector from
/// x to the line's foot and t = h·tan φ along the unit axis â, the integrand is
/// (2/h)(n·f̂ cos²φ + n·â sin φ cos φ) dφ, so E = (1/h)[n·f̂ (Δφ + Δ(sin φ cos φ)) + n·â Δ(sin²φ)]
/// over the clipped φ range, each difference in a form without cancellation between its ends
/// (the two terms cancel to leading order beyond an end: relative error ~ 1e-16 (t/h)²). 0 on
/// the line itself (h ≤ 1e-12 of the segment's length).
fn line_irradiance(x: DVec3, n: DVec3, p0: DVec3, p1: DVec3) -> f64 {
    let len = (p1 - p0).length();
    let a = (p1 - p0) / len;
    let t_start = (p0 - x).dot(a);
    let foot = p0 - a * t_start - x;
    let h = foot.length();
    if !(h > 1e-12 * len) {
        return 0.0;
    }
    let (n_t, n_s) = (n.dot(foot) / h, n.dot(a));
    // n·ω > 0 ⇔ n_t·h + n_s·t > 0: one end of [t0, t1] may move to t* = −n_t·h/n_s.
    let (mut t0, mut t1) = (t_start, t_start + len);
    if n_s == 0.0 {
        if !(n_t > 0.0) {
            return 0.0;
        }
    } else if n_s > 0.0 {
        t0 = t0.max(-n_t * h / n_s);
    } else {
        t1 = t1.min(-n_t * h / n_s);
    }
    if !(t1 > t0) {
        return 0.0;
    }
    let (q0, q1) = (h * h + t0 * t0, h * h + t1 * t1);
    let d_phi = ((t1 - t0) * h).atan2(h * h + t0 * t1);
    let d_sin_cos = h * (t1 - t0) * (h * h - t0 * t1) / (q0 * q1);
    let d_sin2 = h * h * (t1 - t0) * (t1 + t0) / (q0 * q1);
    ((n_t * (d_phi + d_sin_cos) + n_s * d_sin2) / h).max(0.0)
}

/// Up to this many ray-triangle tests in all (two rays per light), the lights' axis rays test
/// every triangle ([`first_hit`]); beyond, they walk a BVH of the scene's surfaces, so that the
/// cost does not grow as lights × triangles.
const BRUTE_FORCE_TESTS: usize = 1 << 26;

/// How the rays along the lights' axes find the first surface they meet.
enum AxisHits {
    Brute,
    Bvh(Bvh),
}

impl AxisHits {
    fn for_scene(scene: &Scene) -> Self {
        let primitives: usize = (scene.shapes.iter())
            .map(|s| match &s.geometry {
                Geometry::Mesh { indices, .. } => indices.len(),
                _ => 1,
            })
            .sum();
        if 2 * scene.lights.len() * primitives <= BRUTE_FORCE_TESTS {
            AxisHits::Brute
        } else {
            AxisHits::bvh(scene)
        }
    }

    /// A BVH over the surfaces [`first_hit`] tests (cylinders left out).
    fn bvh(scene: &Scene) -> Self {
        let prims = crate::render_scene::primitives(scene)
            .into_iter()
            .filter(|p| !matches!(p, Primitive::Cylinder { .. }))
            .collect();
        AxisHits::Bvh(Bvh::build(prims))
    }

    /// [`first_hit`]'s answer: (t, normal facing the ray); in f32 through the BVH.
    fn first(&self, scene: &Scene, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
        let AxisHits::Bvh(bvh) = self else {
            return first_hit(scene, o, d);
        };
        let ray = Ray {
            o: o.as_vec3(),
            d: d.as_vec3(),
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let hit = bvh.intersect(&ray)?;
        let n = (bvh.primitive(hit.prim).surface_point(&ray, &hit, false).ng).as_dvec3();
        Some((hit.t as f64, if n.dot(d) > 0.0 { -n } else { n }))
    }
}

/// First hit of the ray o + t·d (t > 1e-9) with the scene's surfaces: (t, normal facing the ray).
fn first_hit(scene: &Scene, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    let mut best: Option<(f64, DVec3)> = None;
    let mut take = |t: f64, n: DVec3| {
        if t > 1e-9 && best.is_none_or(|(b, _)| t < b) && n.length_squared() > 0.0 {
            let n = n.normalize();
            best = Some((t, if n.dot(d) > 0.0 { -n } else { n }));
        }
    };
    for s in &scene.shapes {
        match &s.geometry {
            Geometry::Mesh {
                positions, indices, ..
            } => {
                for t in indices {
                    let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
                    let (e1, e2) = (b - a, c - a);
                    let p = d.cross(e2);
                    let det = e1.dot(p);
                    if det.abs() < 1e-300 {
                        continue;
                    }
                    let tv = o - a;
                    let u = tv.dot(p) / det;
                    let q = tv.cross(e1);
                    let v = d.dot(q) / det;
                    if u < 0.0 || v < 0.0 || u + v > 1.0 {
                        continue;
                    }
                    take(e2.dot(q) / det, e1.cross(e2));
                }
            }
            Geometry::Sphere { center, radius } => {
                let (c, r) = (center.as_dvec3(), *radius as f64);
                let oc = o - c;
                let (b, cc) = (oc.dot(d), oc.length_squared() - r * r);
                let disc = b * b - cc;
                if disc >= 0.0 {
                    for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
                        take(t, o + d * t - c);
                    }
                }
            }
            Geometry::Disk { to_world } => {
                let m = to_world.as_dmat4();
                let Some(inv) = (m.determinant() != 0.0).then(|| m.inverse()) else {
                    continue;
                };
                let (lo, ld) = (inv.transform_point3(o), inv.transform_vector3(d));
                if ld.z != 0.0 {
                    let t = -lo.z / ld.z;
                    let p = lo + ld * t;
                    if p.x * p.x + p.y * p.y <= 1.0 {
                        let n = inv.transpose().transform_vector3(DVec3::Z);
                        take(t, n);
                    }
                }
            }
            Geometry::Cylinder { .. } => {}
        }
    }
    best
}

/// Side of one pixel's footprint at distance `dist` from the camera (at the image centre).
fn pixel_size(scene: &Scene, dist: f64) -> f64 {
    let s = &scene.sensor;
    let aspect = s.film.width as f64 / s.film.height as f64;
    let fov_x = s.fov_axis.horizontal_fov(s.fov_deg as f64, aspect);
    2.0 * (0.5 * fov_x).to_radians().tan() * dist / s.film.width.max(1) as f64
}

/// The estimate for one light: at each point where its axis, extended beyond an end, first
/// meets a surface, the ratio of ΔE and E each averaged over that pixel's footprint (9 × 9
/// points in the surface's plane); and the point values at sample points of every surface
/// (for lights whose axis meets nothing). The largest in magnitude.
fn effect(
    scene: &Scene,
    hits: &AxisHits,
    points: &[SurfaceSample],
    index: usize,
    light: &LinearLight,
) -> Option<RadiusEffect> {
    let mut best = None;
    for candidate in beyond_the_ends(scene, hits, index, light) {
        keep_larger(&mut best, candidate);
    }
    for candidate in off_the_axis(points, index, light) {
        keep_larger(&mut best, candidate);
    }
    best
}

/// `candidate` in `best` when it is larger in magnitude (or `best` is empty).
fn keep_larger(best: &mut Option<RadiusEffect>, candidate: RadiusEffect) {
    if best
        .as_ref()
        .is_none_or(|b| candidate.per_pixel > b.per_pixel)
    {
        *best = Some(candidate);
    }
}

/// At each point where the light's axis, extended beyond an end, first meets a surface: the
/// ratio of ΔE and E averaged over that pixel's footprint (at least 20 R wide), at most 100 %
/// darker.
fn beyond_the_ends(
    scene: &Scene,
    hits: &AxisHits,
    index: usize,
    light: &LinearLight,
) -> Vec<RadiusEffect> {
    let (p0, p1) = (light.begin.as_dvec3(), light.end.as_dvec3());
    let r = light.radius as f64;
    let a = (p1 - p0).normalize();
    let eye = scene
        .sensor
        .to_world
        .transform_point3(glam::Vec3::ZERO)
        .as_dvec3();
    let mut out = Vec::new();
    for (end, dir) in [(p1, a), (p0, -a)] {
        let Some((t, n)) = hits.first(scene, end, dir) else {
            continue;
        };
        let x = end + dir * t;
        // Within a few radii of the axis the first-order picture does not hold: the footprint
        // is at least 20 R wide.
        let side = pixel_size(scene, (x - eye).length()).max(20.0 * r);
        let (u, v) = n.any_orthonormal_pair();
        let (mut de, mut e) = (0.0, 0.0);
        const K: usize = 9;
        for i in 0..K {
            for j in 0..K {
                let fu = ((i as f64 + 0.5) / K as f64 - 0.5) * side;
                let fv = ((j as f64 + 0.5) / K as f64 - 0.5) * side;
                let (d1, e1) = rim_and_line(x + u * fu + v * fv, n, p0, p1, r);
                de += d1;
                e += e1;
            }
        }
        if !(e > 0.0) {
            continue;
        }
        // Mitsuba's irradiance is not negative: at most 100 % darker.
        let signed = (de / e).max(-1.0);
        out.push(RadiusEffect {
            light: index,
            per_pixel: signed.abs(),
            at: x,
            signed,
        });
    }
    out
}

/// Point values ΔE/E at the surfaces' sample points that lie beside the light (between the
/// planes through its ends), with the normal turned towards the light's middle.
fn off_the_axis(points: &[SurfaceSample], index: usize, light: &LinearLight) -> Vec<RadiusEffect> {
    let (p0, p1) = (light.begin.as_dvec3(), light.end.as_dvec3());
    let r = light.radius as f64;
    let a = (p1 - p0).normalize();
    let mid = 0.5 * (p0 + p1);
    let len = (p1 - p0).length();
    let mut out = Vec::new();
    for (x, n) in points.iter().map(|p| p.facing(mid)) {
        // Beyond an end the pixel means above apply (point values grow without bound there).
        let along = (x - p0).dot(a);
        let Some(n) = n.try_normalize().filter(|_| (0.0..=len).contains(&along)) else {
            continue;
        };
        let n = if n.dot(mid - x) < 0.0 { -n } else { n };
        if let Some(rel) = relative_at(x, n, p0, p1, r) {
            out.push(RadiusEffect {
                light: index,
                per_pixel: rel.abs(),
                at: x,
                signed: rel,
            });
        }
    }
    out
}

/// A surface sample point with an (unnormalised) normal, or a sphere whose point is the one
/// facing the light.
#[derive(Clone, Copy, Debug)]
enum SurfaceSample {
    Point(DVec3, DVec3),
    Sphere(DVec3, f64),
}

impl SurfaceSample {
    fn facing(&self, towards: DVec3) -> (DVec3, DVec3) {
        match *self {
            SurfaceSample::Point(x, n) => (x, n),
            SurfaceSample::Sphere(c, r) => {
                let to = (towards - c).normalize_or_zero();
                (c + to * r, to)
            }
        }
    }
}

/// The surfaces' sample points, the same for every light (the first 4·[`OFF_AXIS_POINTS`]):
/// triangle centroids, about OFF_AXIS_POINTS per mesh; each sphere; disk centres.
fn surface_points(scene: &Scene) -> Vec<SurfaceSample> {
    let mut points = Vec::new();
    for s in &scene.shapes {
        match &s.geometry {
            Geometry::Mesh {
                positions, indices, ..
            } => {
                let step = (indices.len() / OFF_AXIS_POINTS).max(1);
                for t in indices.iter().step_by(step) {
                    let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
                    points.push(SurfaceSample::Point(
                        (a + b + c) / 3.0,
                        (b - a).cross(c - a),
                    ));
                }
            }
            Geometry::Sphere { center, radius } => {
                points.push(SurfaceSample::Sphere(center.as_dvec3(), *radius as f64));
            }
            Geometry::Disk { to_world } => {
                let m = to_world.as_dmat4();
                let n = m.inverse().transpose().transform_vector3(DVec3::Z);
                points.push(SurfaceSample::Point(m.transform_point3(DVec3::ZERO), n));
            }
            Geometry::Cylinder { .. } => {}
        }
        if points.len() >= 4 * OFF_AXIS_POINTS {
            break;
        }
    }
    points.truncate(4 * OFF_AXIS_POINTS);
    points
}

/// Sample points per mesh for the off-axis part of [`effect`].
const OFF_AXIS_POINTS: usize = 512;

/// Every light's estimate (lights whose axis meets no surface have none).
pub fn effects(scene: &Scene) -> Vec<RadiusEffect> {
    effects_with(scene, &AxisHits::for_scene(scene))
}

fn effects_with(scene: &Scene, hits: &AxisHits) -> Vec<RadiusEffect> {
    use rayon::prelude::*;
    let points = surface_points(scene);
    scene
        .lights
        .par_iter()
        .enumerate()
        .filter_map(|(i, l)| effect(scene, hits, &points, i, l))
        .collect()
}

/// The warning of a render of `scene` under `--cylinders line` about the lights whose estimated
/// per-pixel effect ([`effects`]) exceeds [`WARN_RELATIVE`]: none, the one light with its
/// expected relative error, or, for several lights, one message with their count and the
/// largest effect (a ceiling of 64 equal tubes is one warning, not 64).
pub fn line_limit_warnings(scene: &Scene) -> Vec<String> {
    let over: Vec<RadiusEffect> = effects(scene)
        .into_iter()
        .filter(|e| e.per_pixel > WARN_RELATIVE)
        .collect();
    let Some(worst) = over
        .iter()
        .max_by(|a, b| a.per_pixel.total_cmp(&b.per_pixel))
    else {
        return Vec::new();
    };
    let which = if over.len() == 1 {
        describe(scene, worst)
    } else {
        format!(
            "{} lights{}, the largest effect {}",
            over.len(),
            radius_range(over.iter().map(|e| scene.lights[e.light].radius)),
            describe(scene, worst)
        )
    };
    let cylinders = if over.len() == 1 {
        "Mitsuba's finite open cylinder differs"
    } else {
        "Mitsuba's finite open cylinders differ"
    };
    vec![format!(
        "{which}: {cylinders} from the R → 0 limit rendered here (--cylinders line) by more \
         than {} % per pixel there, which compare can detect; --cylinders exact renders the \
         tube itself, and a smaller radius (same K = radiance × radius) shrinks the difference \
         in proportion (docs/oracle.md)",
        100.0 * WARN_RELATIVE
    )]
}

/// " (R = 0.0001 each)" or " (R from 0.001 to 0.01)".
fn radius_range(radii: impl Iterator<Item = f32>) -> String {
    let (lo, hi) = radii.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), r| {
        (lo.min(r), hi.max(r))
    });
    if lo == hi {
        format!(" (R = {lo} each)")
    } else {
        format!(" (R from {lo} to {hi})")
    }
}

/// "light at FILE:L:C (R = 0.001): up to 3.1 % per pixel (Mitsuba darker) near (1, 0.24,
/// 1.6)".
pub fn describe(scene: &Scene, e: &RadiusEffect) -> String {
    let l = &scene.lights[e.light];
    format!(
        "light at {} (R = {}): up to {:.2} % per pixel (Mitsuba {}) near ({:.3}, {:.3}, {:.3})",
        l.location,
        l.radius,
        100.0 * e.per_pixel,
        if e.signed < 0.0 { "darker" } else { "brighter" },
        e.at.x,
        e.at.y,
        e.at.z
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cornell-tube geometry (a 2-unit box, the tube 0.9 × 0.4 at z = 1.6).
    fn tube() -> (DVec3, DVec3) {
        (DVec3::new(-0.45, -0.4, 1.6), DVec3::new(0.45, 0.0, 1.6))
    }

    /// E by the midpoint rule on `m` pieces of t (the reference of the closed form).
    fn line_irradiance_midpoint(x: DVec3, n: DVec3, p0: DVec3, p1: DVec3, m: usize) -> f64 {
        let (len, a) = ((p1 - p0).length(), (p1 - p0).normalize());
        let mut e = 0.0;
        for i in 0..m {
            let d = p0 + a * (len * (i as f64 + 0.5) / m as f64) - x;
            let r2 = d.length_squared();
            let w = d / r2.sqrt();
            e += w.cross(a).length() * n.dot(w).max(0.0) / r2;
        }
        e * 2.0 * len / m as f64
    }

    /// The closed form of E agrees with a fine midpoint rule, at points around the cornell
    /// tube (beside it, beyond its ends, with the tangent plane crossing it) and on its axis
    /// extension, where E vanishes. The midpoint rule's error on 2¹⁸ pieces is below 1e-6 at
    /// these distances (≥ 0.05 from the line).
    #[test]
    fn line_irradiance_is_the_integral() {
        let (p0, p1) = tube();
        let (mut checked, mut crossing) = (0, 0);
        for i in 0..9 {
            for j in 0..9 {
                let x = DVec3::new(
                    -1.5 + 0.37 * i as f64,
                    -1.0 + 0.29 * j as f64,
                    0.4 * (i % 5) as f64,
                );
                let n = DVec3::new(0.3 * (j as f64 - 4.0), 0.2 * (i as f64 - 4.0), 1.0).normalize();
                let h = (x - p0).reject_from((p1 - p0).normalize()).length();
                if h < 0.05 {
                    continue;
                }
                let closed = line_irradiance(x, n, p0, p1);
                let midpoint = line_irradiance_midpoint(x, n, p0, p1, 1 << 18);
                assert!(
                    (closed - midpoint).abs() <= 1e-6 * midpoint.abs().max(1e-3),
                    "x {x} n {n}: closed {closed}, midpoint {midpoint}"
                );
                checked += 1;
                crossing += usize::from((n.dot(p0 - x) > 0.0) != (n.dot(p1 - x) > 0.0));
            }
        }
        assert!(
            checked > 60 && crossing > 5,
            "{checked} points, {crossing} clipped"
        );
        let a = (p1 - p0).normalize();
        assert_eq!(line_irradiance(p1 + a, -a, p0, p1), 0.0);
        assert_eq!(line_irradiance(0.5 * (p0 + p1), DVec3::Z, p0, p1), 0.0);
    }

    /// The BVH's first hits give the brute force's estimates, on every committed scene.
    #[test]
    fn axis_hits_by_bvh_are_the_brute_forces() {
        let mut compared = 0;
        for path in crate::test_scenes::committed() {
            let scene = crate::xml::load_scene(&path, &[]).unwrap();
            let brute = effects_with(&scene, &AxisHits::Brute);
            let bvh = effects_with(&scene, &AxisHits::bvh(&scene));
            assert_eq!(brute.len(), bvh.len(), "{}", path.display());
            for (b, v) in brute.iter().zip(&bvh) {
                assert_eq!(b.light, v.light);
                let tol = 1e-4 * b.per_pixel.abs().max(1e-3);
                assert!(
                    (b.signed - v.signed).abs() <= tol,
                    "{}: {b:?} {v:?}",
                    path.display()
                );
                compared += 1;
            }
        }
        assert!(compared >= 10, "{compared}");
    }

    /// Away from the axis the coefficient c = ΔE/(E·R) is of the measured size: |c| ≤ 0.42 per
    /// scene unit was measured on unit-scale scenes; on the floor and back wall of the box the
    /// estimate's largest |c| is 1.1 per unit (an overestimate within 3×: no occlusion, point
    /// values rather than pixel means).
    #[test]
    fn off_axis_coefficient_is_of_the_measured_size() {
        let (p0, p1) = tube();
        let mut worst: f64 = 0.0;
        for i in 0..15 {
            for j in 0..15 {
                let (u, v) = (-0.9 + 0.12 * i as f64, -0.9 + 0.12 * j as f64);
                let floor = relative_at(DVec3::new(u, v, 0.0), DVec3::Z, p0, p1, 1.0);
                let back = relative_at(DVec3::new(u, 1.0, 1.0 + v), -DVec3::Y, p0, p1, 1.0);
                for c in [floor, back].into_iter().flatten() {
                    worst = worst.max(c.abs());
                }
            }
        }
        assert!(
            worst > 0.42 / 3.0 && worst < 3.0 * 0.42,
            "largest |c| = {worst}"
        );
    }

    /// Near the axis extension the effect is of the measured size: at R = 1e-3 Mitsuba is 3–4 %
    /// darker per pixel there. Averaged over a 64-px pixel's footprint (0.054 units) where the
    /// axis meets the wall x = 1, the estimate is darker by a few percent (it overestimates by
    /// up to 2.5×: the measured value is a bound of the estimate's accuracy, kept in the test).
    #[test]
    fn axis_extension_effect_is_of_the_measured_size() {
        let (p0, p1) = tube();
        let a = (p1 - p0).normalize();
        let x = p1 + a * ((1.0 - p1.x) / a.x);
        let n = -DVec3::X;
        let side = 0.054;
        let (mut de, mut e) = (0.0, 0.0);
        for i in 0..21 {
            for j in 0..21 {
                let p = x + DVec3::new(
                    0.0,
                    side * (i as f64 / 20.0 - 0.5),
                    side * (j as f64 / 20.0 - 0.5),
                );
                let (d1, e1) = rim_and_line(p, n, p0, p1, 1e-3);
                de += d1;
                e += e1;
            }
        }
        let rel = de / e;
        assert!(rel < -0.03 && rel > -0.10, "per pixel {rel}");
    }
}
