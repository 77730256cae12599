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
    let mut obj = ObjReader {
        face_normals,
        ..ObjReader::default()
    };
    for (ln, line) in text.lines().enumerate() {
        obj.line(ln + 1, line)?;
    }
    obj.mesh()
}

/// What the lines read so far declare: positions, normals, the count of texture coordinates,
/// the distinct (v, vt, vn) corners in order of first use, and the triangles over them.
#[derive(Default)]
struct ObjReader {
    /// Whether normals are computed per face (then `vn` lines and corner normals are skipped).
    face_normals: bool,
    v: Vec<DVec3>,
    vn: Vec<DVec3>,
    vt_count: usize,
    /// The number of each distinct corner (1-based v, vt, vn; 0 where absent).
    ids: HashMap<[u32; 3], u32>,
    keys: Vec<[u32; 3]>,
    tris: Vec<[u32; 3]>,
}

impl ObjReader {
    /// Reads line `ln` (1-based) of the file.
    fn line(&mut self, ln: usize, line: &str) -> Result<(), String> {
        let mut tok = line.split_whitespace();
        let Some(head) = tok.next() else {
            return Ok(());
        };
        match head {
            "v" => {
                let p = numbers(tok, 3, ln, line)?;
                self.v.push(DVec3::new(p[0], p[1], p[2]));
            }
            "vn" if !self.face_normals => {
                let n = numbers(tok, 3, ln, line)?;
                self.vn.push(DVec3::new(n[0], n[1], n[2]));
            }
            "vt" => {
                numbers(tok, 2, ln, line)?;
                self.vt_count += 1;
            }
            "f" => {
                let mut corners: Vec<u32> = Vec::new();
                for c in tok {
                    let key = self.corner_key(ln, c)?;
                    let next = self.keys.len() as u32;
                    let keys = &mut self.keys;
                    let id = *self.ids.entry(key).or_insert_with(|| {
                        keys.push(key);
                        next
                    });
                    corners.push(id);
                }
                for k in 2..corners.len() {
                    self.tris.push([corners[0], corners[k - 1], corners[k]]);
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// The (v, vt, vn) indices of face corner `c` ("v", "v/vt", "v//vn" or "v/vt/vn"), each
    /// within what the lines before declared.
    fn corner_key(&self, ln: usize, c: &str) -> Result<[u32; 3], String> {
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
                0 => (self.v.len(), "vertex"),
                1 => (self.vt_count, "texture coordinate"),
                _ => (self.vn.len(), "normal"),
            };
            if slot == 2 && self.face_normals {
                continue; // normals are not read at all
            }
            if i as usize > count {
                return Err(format!("line {ln}: reference to invalid {what} {i}"));
            }
            key[slot] = i as u32;
        }
        Ok(key)
    }

    /// The mesh: one vertex per distinct corner; normals when every corner has one.
    fn mesh(self) -> Result<RawMesh, String> {
        let keys = &self.keys;
        let positions = keys.iter().map(|k| self.v[k[0] as usize - 1]).collect();
        let with_n = keys.iter().filter(|k| k[2] != 0).count();
        let normals = if with_n == 0 {
            None
        } else if with_n < keys.len() {
            return Err("some face corners have normals and others do not".into());
        } else {
            Some(keys.iter().map(|k| self.vn[k[2] as usize - 1]).collect())
        };
        Ok(RawMesh {
            positions,
            normals,
            triangles: self.tris,
        })
    }
}

/// The first `n` numbers after the head of line `ln`: all parsed, present and finite.
fn numbers(
    tok: std::str::SplitWhitespace,
    n: usize,
    ln: usize,
    line: &str,
) -> Result<Vec<f64>, String> {
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
