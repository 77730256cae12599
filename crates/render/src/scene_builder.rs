//! Building scenes in code (tests, benchmarks): quads, boxes, diffuse shapes, a look-at sensor.

use crate::scene::{
    Bsdf, Film, FovAxis, Geometry, Integrator, LinearLight, Rgb, Scene, Sensor, Shape,
    SourceLocation,
};
use crate::xml::look_at;
use glam::Vec3;

/// Quad a-b-c-d (in order around its boundary) as two triangles whose normal is
/// (b − a) × (c − a).
pub fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Geometry {
    Geometry::Mesh {
        positions: vec![a, b, c, d],
        normals: None,
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// Axis-aligned box with outward normals (12 triangles).
pub fn cuboid(min: Vec3, max: Vec3) -> Geometry {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let center = 0.5 * (min + max);
    for axis in 0..3 {
        for side in [0, 1] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: usize, b: usize| {
                let mut p = min;
                p[axis] = if side == 0 { min[axis] } else { max[axis] };
                p[u] = if a == 0 { min[u] } else { max[u] };
                p[v] = if b == 0 { min[v] } else { max[v] };
                p
            };
            let mut q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
            let n = (q[1] - q[0]).cross(q[2] - q[0]);
            if n.dot(q[0] - center) < 0.0 {
                q.reverse();
            }
            let base = positions.len() as u32;
            positions.extend_from_slice(&q);
            indices.push([base, base + 1, base + 2]);
            indices.push([base, base + 2, base + 3]);
        }
    }
    Geometry::Mesh {
        positions,
        normals: None,
        indices,
    }
}

/// The square [−half, half]² of the plane z = 0, normal +z, diffuse with reflectance `rho`: the
/// floor of the tests' and benchmarks' scenes.
pub fn floor(half: f32, rho: Rgb) -> Shape {
    let v = Vec3::new;
    diffuse(
        quad(
            v(-half, -half, 0.),
            v(half, -half, 0.),
            v(half, half, 0.),
            v(-half, half, 0.),
        ),
        rho,
    )
}

pub fn diffuse(geometry: Geometry, reflectance: Rgb) -> Shape {
    Shape {
        geometry,
        bsdf: Bsdf::Diffuse { reflectance },
        flip_normals: false,
        location: SourceLocation::default(),
    }
}

pub fn light(begin: Vec3, end: Vec3, k: Rgb) -> LinearLight {
    LinearLight {
        begin,
        end,
        radius: 0.0,
        radiance_times_radius: k,
        sampling_weight: 1.0,
        location: SourceLocation::default(),
    }
}

/// Perspective sensor at `origin` looking at `target`, fov along x, box-filtered film.
pub fn sensor(
    origin: Vec3,
    target: Vec3,
    up: Vec3,
    fov_x_deg: f32,
    width: u32,
    height: u32,
) -> Sensor {
    Sensor {
        to_world: look_at(origin.as_dvec3(), target.as_dvec3(), up.as_dvec3())
            .expect("sensor: origin equals target, or up is parallel to the view direction")
            .as_mat4(),
        fov_deg: fov_x_deg,
        fov_axis: FovAxis::X,
        principal_point_offset_x: 0.0,
        principal_point_offset_y: 0.0,
        near_clip: 0.01,
        far_clip: 10_000.0,
        film: Film {
            width,
            height,
            crop: None,
        },
        sample_count: 4,
        seed: 0,
    }
}

pub fn scene(sensor: Sensor, shapes: Vec<Shape>, lights: Vec<LinearLight>) -> Scene {
    Scene {
        sensor,
        integrator: Integrator {
            hide_emitters: true,
            emitter_samples: 1,
        },
        shapes,
        lights,
        sha256: String::new(),
        warnings: Vec::new(),
    }
}

/// A Cornell-box-like room (1 × 1 × 1, open toward −y where the camera stands), two boxes and a
/// linear light under the ceiling.
pub fn cornell_box(width: u32, height: u32) -> Scene {
    let v = Vec3::new;
    let white = [0.75, 0.75, 0.75];
    let shapes = vec![
        diffuse(
            quad(v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)),
            white,
        ), // floor
        diffuse(
            quad(v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)),
            white,
        ), // ceiling
        diffuse(
            quad(v(0., 1., 0.), v(1., 1., 0.), v(1., 1., 1.), v(0., 1., 1.)),
            white,
        ), // back
        diffuse(
            quad(v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)),
            [0.63, 0.06, 0.05],
        ),
        diffuse(
            quad(v(1., 0., 0.), v(1., 0., 1.), v(1., 1., 1.), v(1., 1., 0.)),
            [0.14, 0.45, 0.09],
        ),
        diffuse(cuboid(v(0.15, 0.45, 0.0), v(0.45, 0.8, 0.6)), white),
        diffuse(cuboid(v(0.55, 0.15, 0.0), v(0.85, 0.45, 0.3)), white),
    ];
    let lights = vec![light(v(0.3, 0.5, 0.95), v(0.7, 0.6, 0.95), [3.0, 2.8, 2.5])];
    let cam = sensor(
        v(0.5, -1.4, 0.5),
        v(0.5, 0.5, 0.5),
        Vec3::Z,
        40.0,
        width,
        height,
    );
    scene(cam, shapes, lights)
}
