//! The scene as the renderer sees it ([`RenderScene`]): the acceleration structures, the
//! camera, each surface's BSDF, and the lights with their K = radiance × radius and the
//! distribution of the light chosen per light sample, built once from a [`Scene`] and shared by
//! the scalar integrator ([`crate::integrator`]) and the packet renderer ([`crate::packet`]).

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::light::Light;
use crate::light_choice::{LightChoice, LightSelection};
use crate::light_tree::LightTree;
use crate::options::{window, Cylinders, RenderError};
use crate::scene::{Bsdf, Geometry, Scene};
use crate::shadow_culling::ShadowCulling;
use crate::shapes::Primitive;
use crate::tube::Tubes;
use crate::visible_line::VisibleLines;
use glam::Vec3;
use std::sync::Arc;

/// The numbers a camera sample draws first: its film position (x, y in the pixel).
pub const FILM_POSITION_NUMBERS: usize = 2;

/// Everything the integrator needs, prepared from a [`crate::scene::Scene`]. The acceleration
/// structures are shared by its clones and by [`RenderScene::sharing`]'s.
#[derive(Clone, Debug)]
pub struct RenderScene {
    pub camera: Camera,
    pub bvh: Arc<Bvh>,
    /// The shadow BVH of each light ([`crate::shadow_culling`]): shadow rays toward light j
    /// walk `shadows` with `bvh` as the fallback; same answers as `bvh`.
    pub shadows: Arc<ShadowCulling>,
    /// Per `Scene::shapes` entry: its BSDF and flip_normals.
    pub surfaces: Vec<(Bsdf, bool)>,
    /// Per `Scene::shapes` entry: f = ρ/π when its BSDF is Lambertian (`Bsdf::lambertian`), the
    /// integrator's fast path; `None` for glossy BSDFs.
    pub lambert: Vec<Option<Vec3>>,
    /// The lights, in the scene's order.
    pub lights: Vec<Light>,
    /// The distribution of the light chosen per light sample under [`LightSelection::One`].
    pub choice: LightChoice,
    /// The tree that chooses the light per light sample under [`LightSelection::Tree`].
    pub tree: LightTree,
    /// The lights as the camera sees them (empty when the scene hides emitters).
    pub visible: VisibleLines,
    /// Light contributions dropped because they were not finite (reported by the renderer).
    pub dropped: DroppedSamples,
    /// The lights rendered as exact tubes (none under `--cylinders line`; [`crate::tube`]).
    pub tubes: Tubes,
}

/// A count shared by the threads of a render (relaxed: only the total is read, at the end).
#[derive(Debug, Default)]
pub struct DroppedSamples(pub std::sync::atomic::AtomicU64);

impl Clone for DroppedSamples {
    fn clone(&self) -> Self {
        Self(std::sync::atomic::AtomicU64::new(self.get()))
    }
}

impl DroppedSamples {
    pub fn get(&self) -> u64 {
        self.0.load(std::sync::atomic::Ordering::Relaxed)
    }
    #[cold]
    pub(crate) fn add_many(&self, count: u64) {
        self.0
            .fetch_add(count, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The normal of the side of a surface that reflects toward the viewer (`wi`: unit, pointing
/// away from the surface): the shading normal `ns`, its negation for a `twosided` BSDF seen from
/// below, or `None` when the viewer is behind a one-sided BSDF (or exactly in the tangent plane),
/// where Mitsuba's eval is zero.
#[inline]
pub fn reflecting_normal(bsdf: &Bsdf, ns: Vec3, wi: Vec3) -> Option<Vec3> {
    let c = ns.dot(wi);
    if c > 0.0 {
        Some(ns)
    } else if c < 0.0 && bsdf.is_two_sided() {
        Some(-ns)
    } else {
        None
    }
}

/// The Lambertian lobe seen from direction `wi`: the normal of the side that reflects and the
/// albedo, or `None` when nothing reflects toward the viewer or the BSDF is not Lambertian.
pub fn diffuse_lobe(bsdf: &Bsdf, ns: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    let n = reflecting_normal(bsdf, ns, wi)?;
    Some((n, bsdf.lambertian()?.as_vec3()))
}

impl RenderScene {
    /// Whether light samples choose one light ([`LightSelection::One`] or
    /// [`LightSelection::Tree`] with two or more lights); otherwise every light is sampled (with
    /// one light they are the same).
    #[inline]
    pub fn chooses_one(&self, selection: LightSelection) -> bool {
        selection != LightSelection::Every && self.lights.len() > 1
    }

    /// The light chosen by ξ_c at shading point `x` (unit normal `n`, the reflecting side's)
    /// when [`Self::chooses_one`]: its index and its K/p (the same operations on both render
    /// paths).
    #[inline]
    pub fn choose_light(
        &self,
        selection: LightSelection,
        x: Vec3,
        n: Vec3,
        xi: f32,
    ) -> (usize, Vec3) {
        if selection == LightSelection::Tree {
            let (j, pmf) = self.tree.sample(x, n, xi);
            (j, self.lights[j].k_over_pmf(pmf))
        } else {
            let (j, _) = self.choice.pick(xi);
            (j, self.k_over_probability(j))
        }
    }

    /// K_j/p_j of light j under [`LightSelection::One`] (the same operation on both render
    /// paths).
    #[inline(always)]
    pub fn k_over_probability(&self, j: usize) -> Vec3 {
        self.lights[j].k_over_probability(self.choice.inverse_probability(j))
    }

    /// The dimension of ξ_c, the number that chooses the light of the first light sample
    /// when [`Self::chooses_one`] (the first after the film position's
    /// [`FILM_POSITION_NUMBERS`]).
    pub const LIGHT_CHOICE_DIMENSION: usize = FILM_POSITION_NUMBERS;

    /// The dimension of the first number of light `walk` (`every`: the lights one after the
    /// other, `numbers` per iteration of one light) or of the chosen light (after ξ_c) in the
    /// first light sample of a camera sample that reaches a reflecting surface: where the
    /// order in which [`crate::integrator::radiance`] draws (film position, then
    /// `sum_over_light_samples`) puts it. The packet renderer reads its lanes' numbers here.
    #[inline(always)]
    pub fn light_dimension(&self, selection: LightSelection, walk: usize, numbers: usize) -> usize {
        if self.chooses_one(selection) {
            Self::LIGHT_CHOICE_DIMENSION + 1
        } else {
            FILM_POSITION_NUMBERS + numbers * walk
        }
    }

    /// Numbers a camera sample draws for its film position and, when it reaches a reflecting
    /// surface (`shaded`: `Some` of the numbers per iteration of one light),
    /// [`Self::light_numbers`]; those of the lines the camera sees ([`crate::visible_line`])
    /// follow.
    #[inline(always)]
    pub fn camera_sample_numbers(
        &self,
        selection: LightSelection,
        light_samples: u32,
        shaded: Option<usize>,
    ) -> usize {
        FILM_POSITION_NUMBERS
            + shaded.map_or(0, |numbers| {
                self.light_numbers(selection, light_samples, numbers)
            })
    }

    /// Numbers a camera sample that reaches a reflecting surface draws for its lights, with
    /// `numbers` per iteration of one light (1 on Lambertian surfaces).
    pub fn light_numbers(
        &self,
        selection: LightSelection,
        light_samples: u32,
        numbers: usize,
    ) -> usize {
        let samples = light_samples as usize;
        if self.chooses_one(selection) {
            samples * (1 + numbers)
        } else {
            samples * self.lights.len() * numbers
        }
    }
}

impl RenderScene {
    /// Acceleration structure, camera and lights of a scene, its cylinders as lines.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        Self::with_cylinders(scene, Cylinders::Line)
    }

    /// [`RenderScene::new`] with the lights' cylinders rendered as `cylinders` says.
    pub fn with_cylinders(scene: &Scene, cylinders: Cylinders) -> Result<Self, RenderError> {
        window(scene)?;
        let camera = camera(scene)?;
        let prims = primitives(scene);
        let lights: Vec<Light> = scene.lights.iter().map(Light::of).collect();
        let shadows = Arc::new(ShadowCulling::new(&prims, &lights));
        let bvh = Arc::new(Bvh::build(prims));
        Ok(Self::around(scene, cylinders, camera, lights, bvh, shadows))
    }

    /// The render scene of `scene`, the scene this one was built from or that scene with
    /// another crop window, with `cylinders`: this one's acceleration structures, shared, and
    /// the rest (the lights, tubes and visible lines, and a count of dropped samples of its own)
    /// anew. Equal to [`RenderScene::with_cylinders`]`(scene, cylinders)`.
    pub fn sharing(&self, scene: &Scene, cylinders: Cylinders) -> Result<Self, RenderError> {
        debug_assert!(
            scene.shapes.len() == self.surfaces.len() && scene.lights.len() == self.lights.len(),
            "a render scene shared with another scene"
        );
        window(scene)?;
        let lights = scene.lights.iter().map(Light::of).collect();
        let (bvh, shadows) = (Arc::clone(&self.bvh), Arc::clone(&self.shadows));
        Ok(Self::around(
            scene,
            cylinders,
            camera(scene)?,
            lights,
            bvh,
            shadows,
        ))
    }

    /// The render scene of `scene` with `cylinders` around its acceleration structures.
    fn around(
        scene: &Scene,
        cylinders: Cylinders,
        camera: Camera,
        lights: Vec<Light>,
        bvh: Arc<Bvh>,
        shadows: Arc<ShadowCulling>,
    ) -> Self {
        let tubes = Tubes::new(scene, cylinders);
        // The integrator flips the shading frame toward the viewer only for a `twosided` at the
        // top (the loader allows it nowhere else); one nested in a blend would be shaded as
        // one-sided from below.
        debug_assert!(
            scene.shapes.iter().all(|s| !nested_two_sided(&s.bsdf)),
            "twosided is supported only as the outermost BSDF"
        );
        let visible = if scene.integrator.hide_emitters {
            VisibleLines::default()
        } else {
            // Tubes are seen by the camera's own rays.
            let lines: Vec<Light> = (lights.iter().enumerate())
                .filter(|(j, _)| tubes.get(*j).is_none())
                .map(|(_, l)| *l)
                .collect();
            VisibleLines::new(&camera, &lines)
        };
        let weights: Vec<f32> = scene.lights.iter().map(|l| l.sampling_weight).collect();
        Self {
            tree: LightTree::new(&lights),
            tubes,
            visible,
            dropped: Default::default(),
            camera,
            shadows,
            bvh,
            surfaces: (scene.shapes.iter())
                .map(|s| (s.bsdf.clone(), s.flip_normals))
                .collect(),
            lambert: (scene.shapes.iter())
                .map(|s| {
                    (s.bsdf.lambertian()).map(|rho| rho.as_vec3() * std::f32::consts::FRAC_1_PI)
                })
                .collect(),
            lights,
            choice: LightChoice::new(&weights),
        }
    }
}

/// The camera of a scene's sensor.
fn camera(scene: &Scene) -> Result<Camera, RenderError> {
    Camera::new(&scene.sensor).ok_or_else(|| {
        RenderError::Scene(
            "unusable perspective sensor (field of view outside (0°, 180°) or singular \
             to_world)"
                .into(),
        )
    })
}

/// The primitives of a scene's shapes, in the shapes' order: a mesh's triangles (those with
/// an index out of range skipped), and the spheres, disks (with an invertible finite
/// transform) and cylinders (of positive finite length and non-zero radius).
pub(crate) fn primitives(scene: &Scene) -> Vec<Primitive> {
    // Reserved exactly: grown by pushes, the largest allocation of a large scene would be
    // copied on the way and reserve up to twice its size.
    let count = (scene.shapes.iter())
        .map(|s| match &s.geometry {
            Geometry::Mesh { indices, .. } => indices.len(),
            _ => 1,
        })
        .sum();
    let mut prims = Vec::with_capacity(count);
    for (i, shape) in scene.shapes.iter().enumerate() {
        let s = i as u32;
        match &shape.geometry {
            Geometry::Mesh {
                positions,
                normals,
                indices,
            } => {
                let normals = normals.as_ref().filter(|n| n.len() == positions.len());
                for tri in indices {
                    let [Some(a), Some(b), Some(c)] = tri.map(|k| positions.get(k as usize)) else {
                        continue; // out-of-range index (the loader should have rejected it)
                    };
                    let n = normals.map(|n| tri.map(|k| n[k as usize]));
                    prims.push(Primitive::Triangle {
                        v: [*a, *b, *c],
                        n,
                        shape: s,
                    });
                }
            }
            Geometry::Sphere { center, radius } => prims.push(Primitive::Sphere {
                center: *center,
                radius: radius.abs(),
                shape: s,
            }),
            Geometry::Disk { to_world } => {
                let det = to_world.determinant();
                if det != 0.0 && det.is_finite() {
                    prims.push(Primitive::disk(to_world.inverse(), s));
                }
            }
            Geometry::Cylinder { p0, p1, radius } => {
                let axis = *p1 - *p0;
                let length = axis.length();
                if length > 0.0 && length.is_finite() && *radius != 0.0 {
                    prims.push(Primitive::Cylinder {
                        p0: *p0,
                        axis: axis / length,
                        length,
                        radius: radius.abs(),
                        shape: s,
                    });
                }
            }
        }
    }
    prims
}

/// Whether a `twosided` occurs below the top of `bsdf`.
fn nested_two_sided(bsdf: &Bsdf) -> bool {
    fn any(b: &Bsdf) -> bool {
        match b {
            Bsdf::TwoSided(_) => true,
            Bsdf::Blend(blend) => blend.bsdfs.iter().any(any),
            _ => false,
        }
    }
    match bsdf {
        Bsdf::TwoSided(inner) => any(inner),
        b => any(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_and_two_sided_lobes() {
        let d = Bsdf::Diffuse {
            reflectance: [0.5; 3],
        };
        assert!(diffuse_lobe(&d, Vec3::Z, Vec3::Z).is_some());
        assert!(diffuse_lobe(&d, Vec3::Z, -Vec3::Z).is_none());
        let t = Bsdf::TwoSided(Box::new(d));
        assert_eq!(diffuse_lobe(&t, Vec3::Z, -Vec3::Z).unwrap().0, -Vec3::Z);
    }
}
