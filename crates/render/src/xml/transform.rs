//! `<transform name="to_world">` with `translate`, `rotate`, `scale`, `matrix`, `lookat`, composed
//! as Mitsuba does: every later operation is applied after the earlier ones, M ← M_op · M.
//! Everything is f64; the loader converts to f32 once, when it writes the IR.

use super::tree::Elem;
use super::values::{parse_f64, parse_list, parse_vec3_exact, parse_xyz};
use super::{err, SceneError};
use glam::{DMat3, DMat4, DVec3, DVec4};

/// Composes the children of a `<transform>` element.
pub fn parse_transform(e: &Elem) -> Result<DMat4, SceneError> {
    e.check_attrs(&["name"])?;
    let mut m = DMat4::IDENTITY;
    for op in &e.children {
        let m_op = parse_op(op)?;
        m = m_op * m;
    }
    if !m.is_finite() {
        return err(&e.loc, "transform is not finite");
    }
    Ok(m)
}

fn parse_op(op: &Elem) -> Result<DMat4, SceneError> {
    match op.tag.as_str() {
        "translate" => {
            op.check_attrs(&["x", "y", "z", "value"])?;
            Ok(DMat4::from_translation(parse_xyz(op, 0.0)?))
        }
        "scale" => {
            op.check_attrs(&["x", "y", "z", "value"])?;
            Ok(DMat4::from_scale(parse_xyz(op, 1.0)?))
        }
        "rotate" => {
            op.check_attrs(&["x", "y", "z", "value", "angle"])?;
            let axis = parse_xyz(op, 0.0)?;
            let angle = match op.attr("angle") {
                Some(a) => parse_f64(a, &op.loc, "<rotate> angle")?,
                None => return err(&op.loc, "<rotate> needs an 'angle' (degrees)"),
            };
            // Mitsuba applies Rodrigues' formula to the axis as written, without normalising it:
            // a non-unit axis gives a non-rigid matrix there. Refuse rather than differ.
            let len = axis.length();
            if (len - 1.0).abs() > 1e-3 {
                return err(
                    &op.loc,
                    format!(
                        "<rotate> axis ({}, {}, {}) must have unit length (Mitsuba does not \
                         normalise it)",
                        axis.x, axis.y, axis.z
                    ),
                );
            }
            Ok(rotation(axis, angle.to_radians()))
        }
        "matrix" => {
            op.check_attrs(&["value"])?;
            let Some(v) = op.attr("value") else {
                return err(&op.loc, "<matrix> needs a 'value' with 16 (or 9) numbers");
            };
            let l = parse_list(v, &op.loc, "<matrix>")?;
            match l.len() {
                // Row-major in the file; glam is column-major, hence the transpose.
                16 => Ok(DMat4::from_cols_slice(&l).transpose()),
                9 => Ok(DMat4::from_mat3(DMat3::from_cols_slice(&l).transpose())),
                n => err(&op.loc, format!("<matrix> needs 16 or 9 numbers (got {n})")),
            }
        }
        "lookat" => {
            op.check_attrs(&["origin", "target", "up"])?;
            let get = |k: &str| match op.attr(k) {
                Some(v) => parse_vec3_exact(v, &op.loc, &format!("<lookat> {k}")),
                None => err(&op.loc, format!("<lookat> needs '{k}'")),
            };
            let origin = get("origin")?;
            let target = get("target")?;
            let up = match op.attr("up") {
                Some(_) => get("up")?,
                None => DVec3::ZERO,
            };
            match look_at(origin, target, up) {
                Some(m) => Ok(m),
                None => err(
                    &op.loc,
                    "invalid lookat transformation (origin equals target, or up is parallel to \
                     the view direction)",
                ),
            }
        }
        other => err(
            &op.loc,
            format!(
                "unexpected <{other}> inside <transform> (supported: translate, rotate, scale, \
                 matrix, lookat)"
            ),
        ),
    }
}

/// Rotation by `angle` radians about `axis` (right-handed), Rodrigues' formula with the axis
/// used as given (Mitsuba's convention; callers ensure it is unit length).
pub fn rotation(axis: DVec3, angle: f64) -> DMat4 {
    let (s, c) = angle.sin_cos();
    let k = 1.0 - c;
    let (x, y, z) = (axis.x, axis.y, axis.z);
    let m = DMat3::from_cols(
        DVec3::new(x * x * k + c, y * x * k + z * s, z * x * k - y * s),
        DVec3::new(x * y * k - z * s, y * y * k + c, z * y * k + x * s),
        DVec3::new(x * z * k + y * s, y * z * k - x * s, z * z * k + c),
    );
    DMat4::from_mat3(m)
}

/// Camera-to-world with columns (left, up', forward, origin), left = normalize(up × forward),
/// up' = forward × left. A zero `up` picks the first tangent of Mitsuba's `coordinate_system`
/// (Duff et al. 2017) of the forward direction. `None` when degenerate.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let up = if up.length_squared() == 0.0 {
        coordinate_system_s(dir)
    } else {
        up
    };
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    let m = DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        DVec4::new(origin.x, origin.y, origin.z, 1.0),
    );
    m.is_finite().then_some(m)
}

/// First tangent of the orthonormal basis of Duff et al. (JCGT 2017) around unit `n`, with
/// sign(0) = +1 as in Dr.Jit.
fn coordinate_system_s(n: DVec3) -> DVec3 {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(sign * n.x * n.x * a + 1.0, sign * b, -sign * n.x)
}

/// The 3×3 part scales every direction by the same factor (a similarity: rotation, reflection,
/// uniform scale). Returns that factor.
pub fn uniform_scale(m: &DMat4) -> Option<f64> {
    let a = DMat3::from_mat4(*m);
    let g = a.transpose() * a; // = s² I for a similarity
    let s2 = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
    if s2 <= 0.0 || !s2.is_finite() {
        return None;
    }
    let tol = 1e-6 * s2;
    let off = [g.x_axis.y, g.x_axis.z, g.y_axis.z];
    let diag = [g.x_axis.x, g.y_axis.y, g.z_axis.z];
    if off.iter().any(|v| v.abs() > tol) || diag.iter().any(|v| (v - s2).abs() > tol) {
        return None;
    }
    Some(s2.sqrt())
}

/// Normal transform: inverse transpose of the 3×3 part (`None` if singular).
pub fn normal_matrix(m: &DMat4) -> Option<DMat3> {
    let a = DMat3::from_mat4(*m);
    let det = a.determinant();
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    Some(a.inverse().transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn rotation_is_right_handed() {
        let r = rotation(DVec3::Z, 90f64.to_radians());
        assert!(close(r.transform_vector3(DVec3::X), DVec3::Y));
        let r = rotation(DVec3::X, 90f64.to_radians());
        assert!(close(r.transform_vector3(DVec3::Y), DVec3::Z));
        let r = rotation(DVec3::Y, 90f64.to_radians());
        assert!(close(r.transform_vector3(DVec3::Z), DVec3::X));
    }

    #[test]
    fn look_at_axes() {
        // Forward +z, up +y: left = up × forward = +x.
        let m = look_at(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(1.0, 2.0, 10.0),
            DVec3::Y,
        )
        .unwrap();
        assert!(close(m.x_axis.truncate(), DVec3::X));
        assert!(close(m.y_axis.truncate(), DVec3::Y));
        assert!(close(m.z_axis.truncate(), DVec3::Z));
        assert!(close(m.w_axis.truncate(), DVec3::new(1.0, 2.0, 3.0)));
        // Looking down −z with up +y: left = y × (−z) = −x.
        let m = look_at(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), DVec3::Y).unwrap();
        assert!(close(m.x_axis.truncate(), -DVec3::X));
        assert!(look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_none());
        assert!(look_at(DVec3::ZERO, DVec3::Y, DVec3::Y).is_none());
    }

    #[test]
    fn coordinate_system_is_orthonormal() {
        for n in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::new(0.3, -0.4, 0.5).normalize(),
            DVec3::new(-0.1, 0.9, -0.2).normalize(),
        ] {
            let s = coordinate_system_s(n);
            assert!((s.length() - 1.0).abs() < 1e-12);
            assert!(s.dot(n).abs() < 1e-12);
        }
        assert!(close(coordinate_system_s(DVec3::Z), DVec3::X));
    }

    #[test]
    fn uniform_scale_detection() {
        let m = DMat4::from_scale(DVec3::splat(2.0)) * rotation(DVec3::X, 0.3);
        assert!((uniform_scale(&m).unwrap() - 2.0).abs() < 1e-12);
        assert!(uniform_scale(&DMat4::from_scale(DVec3::new(1.0, 2.0, 1.0))).is_none());
        assert!(uniform_scale(&DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))).is_some());
    }
}
