//! Triangle meshes of the built-in shapes and the object → world step shared by all meshes.

use super::transform::normal_matrix;
use super::{err, SceneError};
use crate::scene::{Geometry, SourceLocation};
use glam::{DMat4, DVec3, Vec3};

/// A mesh in object space as read from a file or generated.
#[derive(Clone, Debug, Default)]
pub struct RawMesh {
    pub positions: Vec<DVec3>,
    /// Per-vertex normals, if the source has them.
    pub normals: Option<Vec<DVec3>>,
    /// Counter-clockwise seen from the side the normal points to.
    pub triangles: Vec<[u32; 3]>,
}

/// `rectangle`: [−1,1]² in the xy-plane, normal +z.
pub fn rectangle() -> RawMesh {
    RawMesh {
        positions: vec![
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
        ],
        normals: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// `cube`: [−1,1]³, four vertices per face carrying that face's outward normal (as Mitsuba's
/// cube, so shading normals equal face normals), two triangles per face wound outward.
pub fn cube() -> RawMesh {
    let mut m = RawMesh {
        normals: Some(Vec::new()),
        ..Default::default()
    };
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            // Tangents u, v with u × v = n, so (±u ± v) corners in this order run
            // counter-clockwise around n.
            let mut u = DVec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let base = m.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.positions.push(n + a * u + b * v);
                m.normals.as_mut().unwrap().push(n);
            }
            m.triangles.push([base, base + 1, base + 2]);
            m.triangles.push([base, base + 2, base + 3]);
        }
    }
    m
}

/// Angle-weighted vertex normals (Thürmer & Wüthrich 1998), Mitsuba's choice for meshes
/// without normals when `face_normals` is false. Vertices of only degenerate triangles get
/// (1, 0, 0) as in Mitsuba; their count is returned.
pub fn smooth_normals(pos: &[DVec3], tris: &[[u32; 3]]) -> (Vec<DVec3>, usize) {
    let mut acc = vec![DVec3::ZERO; pos.len()];
    let mut referenced = vec![false; pos.len()];
    for t in tris {
        let p = [pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]];
        for &i in t {
            referenced[i as usize] = true;
        }
        let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let e1 = p[(k + 1) % 3] - p[k];
            let e2 = p[(k + 2) % 3] - p[k];
            let angle = e1.angle_between(e2);
            if angle.is_finite() {
                acc[t[k] as usize] += n * angle;
            }
        }
    }
    let mut invalid = 0;
    let normals = acc
        .into_iter()
        .zip(referenced)
        .map(|(n, r)| {
            n.try_normalize().unwrap_or_else(|| {
                invalid += r as usize;
                DVec3::X
            })
        })
        .collect();
    (normals, invalid)
}

fn to_f32(v: DVec3, loc: &SourceLocation, what: &str) -> Result<Vec3, SceneError> {
    let f = v.as_vec3();
    if f.is_finite() {
        Ok(f)
    } else {
        err(loc, format!("{what} is not finite in single precision"))
    }
}

/// Object → world: positions by `m`, normals by its inverse transpose (renormalised).
/// Meshes without normals get smooth ones when `smooth_if_missing`; `face_normals` drops them.
/// Returns the geometry and a warning, if any.
pub fn world_mesh(
    raw: RawMesh,
    m: &DMat4,
    face_normals: bool,
    smooth_if_missing: bool,
    loc: &SourceLocation,
) -> Result<(Geometry, Option<String>), SceneError> {
    let n_vert = raw.positions.len();
    if n_vert > u32::MAX as usize {
        return err(loc, "mesh has too many vertices");
    }
    if let Some(t) = raw
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n_vert))
    {
        return err(
            loc,
            format!("mesh face {t:?} refers to a vertex that does not exist"),
        );
    }
    let world: Vec<DVec3> = raw
        .positions
        .iter()
        .map(|p| m.transform_point3(*p))
        .collect();
    let mut warning = None;
    let normals = if face_normals {
        None
    } else if let Some(ns) = raw.normals {
        let Some(nm) = normal_matrix(m) else {
            return err(loc, "to_world is singular");
        };
        let mut out = Vec::with_capacity(ns.len());
        for n in ns {
            match (nm * n).try_normalize() {
                Some(w) => out.push(w),
                None => return err(loc, "mesh contains invalid (zero or non-finite) normals"),
            }
        }
        Some(out)
    } else if smooth_if_missing {
        let (ns, invalid) = smooth_normals(&world, &raw.triangles);
        if invalid > 0 {
            warning = Some(format!(
                "{loc}: {invalid} vertices touch only degenerate triangles; their computed \
                 normal is arbitrary (as in Mitsuba)"
            ));
        }
        Some(ns)
    } else {
        None
    };
    // Reserved exactly (a collect through `Result` would grow by doubling).
    let mut positions = Vec::with_capacity(world.len());
    for p in &world {
        positions.push(to_f32(*p, loc, "vertex position")?);
    }
    let normals = normals.map(|ns| ns.iter().map(|n| n.as_vec3()).collect());
    Ok((
        Geometry::Mesh {
            positions,
            normals,
            indices: raw.triangles,
        },
        warning,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_point_outward() {
        let c = cube();
        assert_eq!(c.triangles.len(), 12);
        let ns = c.normals.as_ref().unwrap();
        for t in &c.triangles {
            let p: Vec<DVec3> = t.iter().map(|&i| c.positions[i as usize]).collect();
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            assert!(n.dot(centroid) > 0.0, "inward triangle {t:?}");
            for &i in t {
                assert!((ns[i as usize] - n).length() < 1e-12);
            }
            for q in &p {
                assert!(q.abs().max_element() == 1.0);
            }
        }
    }

    #[test]
    fn smooth_normals_of_a_tent() {
        // Two triangles meeting at a ridge along y at 90°: ridge normals average to +z.
        let pos = vec![
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(1.0, 0.0, 0.0),
        ];
        let tris = vec![[0, 1, 2], [1, 3, 2]];
        let (ns, invalid) = smooth_normals(&pos, &tris);
        assert_eq!(invalid, 0);
        assert!((ns[1] - DVec3::Z).length() < 1e-12);
        assert!((ns[2] - DVec3::Z).length() < 1e-12);
        let left = DVec3::new(-1.0, 0.0, 1.0).normalize();
        assert!((ns[0] - left).length() < 1e-12);
    }
}
