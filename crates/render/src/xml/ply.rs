//! Stanford PLY reader: `ascii`, `binary_little_endian` and `binary_big_endian`. Reads vertex
//! `x y z` (and `nx ny nz` unless face normals are requested) and face `vertex_indices` (or
//! `vertex_index`); other properties and elements are skipped. Polygons become fans
//! (Mitsuba itself accepts only triangles here).

use super::shapes::RawMesh;
use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug)]
enum Property {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Reads scalars from the body, in ASCII or binary.
struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    fn read(&mut self, t: Scalar) -> Result<f64, String> {
        if self.format == Format::Ascii {
            while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let start = self.pos;
            while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if start == self.pos {
                return Err("unexpected end of file".into());
            }
            let tok = std::str::from_utf8(&self.data[start..self.pos]).unwrap_or("?");
            return tok
                .parse::<f64>()
                .map_err(|_| format!("could not parse number '{tok}'"));
        }
        let n = t.size();
        let Some(b) = self.data.get(self.pos..self.pos + n) else {
            return Err("unexpected end of file".into());
        };
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => a[0] as i8 as f64,
            Scalar::U8 => a[0] as f64,
            Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }

    fn at_end(&self) -> bool {
        match self.format {
            Format::Ascii => self.data[self.pos..]
                .iter()
                .all(|b| b.is_ascii_whitespace()),
            _ => self.pos == self.data.len(),
        }
    }
}

fn parse_header(data: &[u8]) -> Result<(Format, Vec<Element>, usize), String> {
    let mut pos = 0;
    let mut next_line = || -> Option<&str> {
        if pos >= data.len() {
            return None;
        }
        let end = data[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(data.len(), |i| pos + i);
        let line = std::str::from_utf8(&data[pos..end]).ok();
        pos = (end + 1).min(data.len());
        Some(line.unwrap_or("\u{fffd}").trim())
    };
    if next_line() != Some("ply") {
        return Err("not a PLY file (missing 'ply' magic)".into());
    }
    let mut format = None;
    let mut elems: Vec<Element> = Vec::new();
    loop {
        let Some(line) = next_line() else {
            return Err("header has no 'end_header'".into());
        };
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _ver] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(format!("unsupported PLY format '{f}'")),
                })
            }
            ["element", name, count] => elems.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| format!("bad element count '{count}'"))?,
                props: Vec::new(),
            }),
            ["property", "list", ct, it, name] => {
                let (Some(ct), Some(it)) = (Scalar::parse(ct), Scalar::parse(it)) else {
                    return Err(format!("unsupported property types in '{line}'"));
                };
                let Some(e) = elems.last_mut() else {
                    return Err("property before any element".into());
                };
                e.props.push(Property::List(name.to_string(), ct, it));
            }
            ["property", ty, name] => {
                let Some(ty) = Scalar::parse(ty) else {
                    return Err(format!("unsupported property type in '{line}'"));
                };
                let Some(e) = elems.last_mut() else {
                    return Err("property before any element".into());
                };
                e.props.push(Property::Scalar(name.to_string(), ty));
            }
            ["end_header"] => break,
            _ => return Err(format!("malformed header line '{line}'")),
        }
    }
    let Some(format) = format else {
        return Err("header has no 'format' line".into());
    };
    Ok((format, elems, pos))
}

/// The face count a PLY file's header declares, from its first 64 KiB (an error when the
/// header is not there or is malformed). A face is at least one triangle.
pub fn declared_faces(path: &std::path::Path) -> Result<u64, String> {
    use std::io::Read;
    linlight_imagefile::input::regular_file_len(path, linlight_imagefile::input::MAX_BINARY_BYTES)?;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(64 << 10).read_to_end(&mut head))
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let (_, elems, _) = parse_header(&head)?;
    Ok(elems
        .iter()
        .filter(|e| e.name == "face")
        .map(|e| e.count as u64)
        .sum())
}

/// The triangle mesh of a PLY file (`data`: the whole file): positions, per-vertex normals
/// (when the vertices have nx, ny, nz and `face_normals` is off) and the faces fanned into
/// triangles.
pub fn parse_ply(data: &[u8], face_normals: bool) -> Result<RawMesh, String> {
    let (format, elems, body_start) = parse_header(data)?;
    let mut body = Body {
        data: &data[body_start..],
        pos: 0,
        format,
    };
    let mut mesh = RawMesh {
        positions: Vec::new(),
        normals: None,
        triangles: Vec::new(),
    };
    let mut normals: Vec<DVec3> = Vec::new();
    let mut has_normals = false;
    let mut n_vertices = None;
    let mut saw_faces = false;
    for e in &elems {
        // Cap the reservation by what the file could possibly hold.
        let cap = e.count.min(data.len());
        match e.name.as_str() {
            "vertex" => {
                has_normals = !face_normals && e.has_normals();
                mesh.positions.reserve(cap);
                let normals = has_normals.then_some(&mut normals);
                read_vertices(&mut body, e, &mut mesh.positions, normals)?;
                n_vertices = Some(e.count);
            }
            "face" => {
                let Some(nv) = n_vertices else {
                    return Err("face element before vertex element".into());
                };
                mesh.triangles.reserve(cap);
                read_faces(&mut body, e, nv, &mut mesh.triangles)?;
                saw_faces = true;
            }
            _ if e.props.is_empty() => {} // nothing to read, however large the count
            _ => skip_element(&mut body, e)?,
        }
    }
    if n_vertices.is_none() {
        return Err("no vertex element".into());
    }
    if !saw_faces {
        return Err("no face element".into());
    }
    if !body.at_end() {
        return Err("invalid file -- trailing content".into());
    }
    mesh.normals = has_normals.then_some(normals);
    Ok(mesh)
}

impl Element {
    /// The index of scalar property `name`.
    fn scalar(&self, name: &str) -> Option<usize> {
        (self.props.iter()).position(|p| matches!(p, Property::Scalar(m, _) if m == name))
    }

    /// Whether the element has the scalar properties nx, ny and nz.
    fn has_normals(&self) -> bool {
        ["nx", "ny", "nz"].iter().all(|n| self.scalar(n).is_some())
    }
}

/// Reads the vertex element `e`: each vertex's position into `positions` (an error when one
/// is not finite or x, y or z is missing), and its normal into `normals` when given (the
/// caller has checked that nx, ny and nz exist).
fn read_vertices(
    body: &mut Body,
    e: &Element,
    positions: &mut Vec<DVec3>,
    mut normals: Option<&mut Vec<DVec3>>,
) -> Result<(), String> {
    let (Some(x), Some(y), Some(z)) = (e.scalar("x"), e.scalar("y"), e.scalar("z")) else {
        return Err("vertex element lacks x, y or z".into());
    };
    let nidx = [e.scalar("nx"), e.scalar("ny"), e.scalar("nz")].map(Option::unwrap_or_default);
    let mut vals = vec![0.0; e.props.len()];
    for vertex in 0..e.count {
        for (k, p) in e.props.iter().enumerate() {
            vals[k] = match p {
                Property::Scalar(_, t) => body.read(*t)?,
                Property::List(_, ct, it) => {
                    let n = body.read(*ct)?;
                    for _ in 0..list_len(n)? {
                        body.read(*it)?;
                    }
                    0.0
                }
            };
        }
        let p = DVec3::new(vals[x], vals[y], vals[z]);
        if !p.is_finite() {
            return Err(format!(
                "vertex {vertex} of {} has a non-finite position ({}, {}, {}) (counted from 0)",
                e.count, p.x, p.y, p.z
            ));
        }
        positions.push(p);
        if let Some(normals) = normals.as_deref_mut() {
            normals.push(DVec3::new(vals[nidx[0]], vals[nidx[1]], vals[nidx[2]]));
        }
    }
    Ok(())
}

/// Reads the face element `e` (vertex indices below `nv`) and fans each face into
/// `triangles`.
fn read_faces(
    body: &mut Body,
    e: &Element,
    nv: usize,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
    let li = e.props.iter().position(
        |p| matches!(p, Property::List(n, _, _) if n == "vertex_indices" || n == "vertex_index"),
    );
    let Some(li) = li else {
        return Err("face element lacks vertex_indices/vertex_index".into());
    };
    let mut corners: Vec<u32> = Vec::new();
    for _ in 0..e.count {
        for (k, p) in e.props.iter().enumerate() {
            match p {
                Property::Scalar(_, t) => {
                    body.read(*t)?;
                }
                Property::List(_, ct, it) => {
                    let n = list_len(body.read(*ct)?)?;
                    corners.clear();
                    for _ in 0..n {
                        let i = body.read(*it)?;
                        if k == li {
                            if !(i >= 0.0 && i.fract() == 0.0 && i < nv as f64) {
                                return Err(format!("face refers to invalid vertex {i}"));
                            }
                            corners.push(i as u32);
                        }
                    }
                    if k == li {
                        if corners.len() < 3 {
                            return Err(format!("face with {} vertices", corners.len()));
                        }
                        for j in 2..corners.len() {
                            triangles.push([corners[0], corners[j - 1], corners[j]]);
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// Reads past an element the mesh does not use.
fn skip_element(body: &mut Body, e: &Element) -> Result<(), String> {
    for _ in 0..e.count {
        for p in &e.props {
            match p {
                Property::Scalar(_, t) => {
                    body.read(*t)?;
                }
                Property::List(_, ct, it) => {
                    let n = list_len(body.read(*ct)?)?;
                    for _ in 0..n {
                        body.read(*it)?;
                    }
                }
            }
        }
    }
    Ok(())
}

fn list_len(n: f64) -> Result<usize, String> {
    if n >= 0.0 && n.fract() == 0.0 && n < 1e9 {
        Ok(n as usize)
    } else {
        Err(format!("invalid list length {n}"))
    }
}

/// Writes a PLY file (test helper): triangles or polygons, optional normals.
#[cfg(test)]
pub fn write_ply(
    format: &str,
    pos: &[[f32; 3]],
    normals: Option<&[[f32; 3]]>,
    faces: &[Vec<u32>],
) -> Vec<u8> {
    let mut h = format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        pos.len()
    );
    if normals.is_some() {
        h += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    h += &format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        faces.len()
    );
    let mut out = h.into_bytes();
    for (i, p) in pos.iter().enumerate() {
        let mut vals = p.to_vec();
        if let Some(n) = normals {
            vals.extend_from_slice(&n[i]);
        }
        for v in vals {
            match format {
                "ascii" => out.extend(format!("{v} ").bytes()),
                "binary_little_endian" => out.extend(v.to_le_bytes()),
                _ => out.extend(v.to_be_bytes()),
            }
        }
        if format == "ascii" {
            out.push(b'\n');
        }
    }
    for f in faces {
        match format {
            "ascii" => {
                out.extend(format!("{}", f.len()).bytes());
                for i in f {
                    out.extend(format!(" {i}").bytes());
                }
                out.push(b'\n');
            }
            fmt => {
                out.push(f.len() as u8);
                for &i in f {
                    let i = i as i32;
                    if fmt == "binary_little_endian" {
                        out.extend(i.to_le_bytes());
                    } else {
                        out.extend(i.to_be_bytes());
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_formats_agree() {
        let pos = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.5],
            [0.0, 1.0, 0.0],
        ];
        let nrm = [[0.0, 0.0, 1.0]; 4];
        let faces = vec![vec![0, 1, 2, 3]];
        for fmt in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let m = parse_ply(&write_ply(fmt, &pos, Some(&nrm), &faces), false).unwrap();
            assert_eq!(m.positions[2], DVec3::new(1.0, 1.0, 0.5), "{fmt}");
            assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]], "{fmt}");
            assert_eq!(m.normals.as_ref().unwrap()[3], DVec3::Z, "{fmt}");
            let m = parse_ply(&write_ply(fmt, &pos, Some(&nrm), &faces), true).unwrap();
            assert!(m.normals.is_none());
            let m = parse_ply(&write_ply(fmt, &pos, None, &faces), false).unwrap();
            assert!(m.normals.is_none());
        }
    }

    #[test]
    fn broken_files_are_errors() {
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.5]];
        let good = write_ply("binary_little_endian", &pos, None, &[vec![0, 1, 2]]);
        assert!(parse_ply(&good[..good.len() - 1], false)
            .unwrap_err()
            .contains("end of file"));
        let mut extra = good.clone();
        extra.push(0);
        assert!(parse_ply(&extra, false).unwrap_err().contains("trailing"));
        let bad = write_ply("ascii", &pos, None, &[vec![0, 1, 7]]);
        assert!(parse_ply(&bad, false)
            .unwrap_err()
            .contains("invalid vertex 7"));
        assert!(parse_ply(b"ply\nformat ascii 1.0\n", false).is_err());
        // Every truncation of a valid file is an error, never a panic.
        for fmt in ["ascii", "binary_little_endian"] {
            let f = write_ply(fmt, &pos, Some(&pos), &[vec![0, 1, 2], vec![2, 1, 0]]);
            for n in 0..f.len() {
                let r = parse_ply(&f[..n], false);
                // ASCII may end inside the last number, which still parses.
                assert!(
                    r.is_err() || (fmt == "ascii" && n + 3 >= f.len()),
                    "{fmt} {n}"
                );
            }
        }
        let huge = b"ply\nformat ascii 1.0\nelement junk 1000000000000\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
        assert!(parse_ply(huge, false).unwrap().triangles.is_empty());
        assert!(parse_ply(b"hello", false).is_err());
    }
}
