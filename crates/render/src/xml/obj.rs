//! Wavefront OBJ reader with Mitsuba's conventions: a vertex is a distinct (v, vt, vn) index
//! triple, numbered in order of first use; polygons become fans (v0, v_{k−1}, v_k); `vn` is
//! read only when face normals are not requested; lines other than v/vn/vt/f are ignored.
//! Relative (negative) indices are not supported (Mitsuba rejects them too).

use super::shapes::RawMesh;
use glam::DVec3;
use std::collections::HashMap;

/// The triangles the `f` lines of an OBJ file make (a polygon of n corners is n − 2), counted
/// without building the mesh: what [`parse_obj`] would produce from a well-formed file.
pub fn counted_triangles(path: &std::path::Path) -> Result<u64, String> {
    let data =
        linlight_imagefile::input::read_capped(path, linlight_imagefile::input::MAX_BINARY_BYTES)?;
    Ok(data
        .split(|&b| b == b'\n')
        .filter_map(|line| {
            let mut tok = line
                .split(u8::is_ascii_whitespace)
                .filter(|t| !t.is_empty());
            (tok.next() == Some(b"f".as_slice())).then(|| (tok.count() as u64).saturating_sub(2))
        })
        .sum())
}

/// Parses OBJ text. Errors are "line N: message".
pub fn parse_obj(text: &str, face_normals: bool) -> Result<RawMesh, String> {
    let mut v: Vec<DVec3> = Vec::new();
    let mut vn: Vec<DVec3> = Vec::new();
    let mut vt_count = 0usize;
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut keys: Vec<[u32; 3]> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();

    for (ln, line) in text.lines().enumerate() {
        let ln = ln + 1;
        let mut tok = line.split_whitespace();
        let Some(head) = tok.next() else { continue };
        let floats = |tok: std::str::SplitWhitespace, n: usize| -> Result<Vec<f64>, String> {
            let vals: Vec<f64> = tok
                .take(n)
                .map(|t| t.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("line {ln}: could not parse '{}'", line.trim()))?;
            if vals.len() < n {
                return Err(format!(
                    "line {ln}: expected {n} numbers in '{}'",
                    line.trim()
                ));
            }
            if vals.iter().any(|x| !x.is_finite()) {
                return Err(format!("line {ln}: non-finite number in '{}'", line.trim()));
            }
            Ok(vals)
        };
        match head {
            "v" => {
                let p = floats(tok, 3)?;
                v.push(DVec3::new(p[0], p[1], p[2]));
            }
            "vn" if !face_normals => {
                let n = floats(tok, 3)?;
                vn.push(DVec3::new(n[0], n[1], n[2]));
            }
            "vt" => {
                floats(tok, 2)?;
                vt_count += 1;
            }
            "f" => {
                let mut corners: Vec<u32> = Vec::new();
                for c in tok {
                    let mut key = [0u32; 3];
                    for (slot, part) in c.split('/').enumerate() {
                        if slot >= 3 {
                            return Err(format!("line {ln}: malformed face corner '{c}'"));
                        }
                        if part.is_empty() {
                            if slot == 0 {
                                return Err(format!("line {ln}: malformed face corner '{c}'"));
                            }
                            continue;
                        }
                        let i: i64 = part
                            .parse()
                            .map_err(|_| format!("line {ln}: malformed face corner '{c}'"))?;
                        if i <= 0 {
                            return Err(format!(
                                "line {ln}: index {i} in '{c}' is not supported (indices \
                                 start at 1; relative indices are not supported)"
                            ));
                        }
                        let (count, what) = match slot {
                            0 => (v.len(), "vertex"),
                            1 => (vt_count, "texture coordinate"),
                            _ => (vn.len(), "normal"),
                        };
                        if slot == 2 && face_normals {
                            continue; // normals are not read at all
                        }
                        if i as usize > count {
                            return Err(format!("line {ln}: reference to invalid {what} {i}"));
                        }
                        key[slot] = i as u32;
                    }
                    let next = keys.len() as u32;
                    let id = *ids.entry(key).or_insert_with(|| {
                        keys.push(key);
                        next
                    });
                    corners.push(id);
                }
                for k in 2..corners.len() {
                    tris.push([corners[0], corners[k - 1], corners[k]]);
                }
            }
            _ => {}
        }
    }

    let positions = keys.iter().map(|k| v[k[0] as usize - 1]).collect();
    let with_n = keys.iter().filter(|k| k[2] != 0).count();
    let normals = if with_n == 0 {
        None
    } else if with_n < keys.len() {
        return Err("some face corners have normals and others do not".into());
    } else {
        Some(keys.iter().map(|k| vn[k[2] as usize - 1]).collect())
    };
    Ok(RawMesh {
        positions,
        normals,
        triangles: tris,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_becomes_fan_and_vertices_deduplicate() {
        let m = parse_obj(
            "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 3 4\n",
            false,
        )
        .unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
        assert!(m.normals.is_none());
    }

    #[test]
    fn normals_key_splits_vertices() {
        let t =
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 2\nf 1//1 2//1 3//1\nf 1//2 3//2 2//2\n";
        let m = parse_obj(t, false).unwrap();
        assert_eq!(m.positions.len(), 6);
        let n = m.normals.unwrap();
        assert_eq!(n[3], DVec3::new(0.0, 0.0, 2.0));
        // With face normals the vn indices are ignored and positions are shared.
        let m = parse_obj(t, true).unwrap();
        assert_eq!(m.positions.len(), 3);
        assert!(m.normals.is_none());
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(parse_obj("v 0 0\n", false).unwrap_err().contains("line 1"));
        assert!(parse_obj("v 0 0 0\nf 1 2 3\n", false)
            .unwrap_err()
            .contains("invalid vertex 2"));
        assert!(parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -3\n", false).is_err());
        assert!(parse_obj("v nan 0 0\n", false).is_err());
        assert!(
            parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2 3\n", false)
                .unwrap_err()
                .contains("some face corners")
        );
    }
}
