//! Wavefront OBJ loading, with errors that name the file and line.
//!
//! What is read: `v x y z` (an optional fourth value `w` divides the coordinates, three more are a
//! vertex colour and are ignored) and `f` faces of three or more corners (`i`, `i/t`, `i//n`, `i/t/n`;
//! negative indices are relative to the vertices defined so far; polygons are fanned from their first
//! corner). Everything else — texture coordinates, normals, materials, groups, lines (`l`), points
//! (`p`), comments after `#` — is ignored: visibility needs positions only and face normals are
//! derived. Every malformed line is an error naming its line: a `v` without three finite numbers, a
//! face of fewer than three corners, an index that is zero, not an integer or refers to a vertex not
//! yet defined.
//!
//! Vertex order follows the layout `tobj` (which sism used before) gives with separate indices: each
//! object (`o`/`g` with faces before it) keeps its vertices in the order its faces first use them, and
//! objects follow one another. Edge adjacency and therefore every image depend on that order, so it is
//! kept (renders of the shared meshes are unchanged bit for bit).

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::{Mesh, MAX_TRIANGLES};
use crate::error::InputError;
use crate::input::{read_file, MAX_MESH_BYTES};

/// Loads every triangle of the OBJ file at `path` into one [`Mesh`] (a regular file of at most
/// [`MAX_MESH_BYTES`]).
pub fn load_obj(path: &Path) -> Result<Mesh, InputError> {
    let bytes = read_file(path, "mesh", MAX_MESH_BYTES)?;
    parse_obj(&bytes, path)
}

/// One object of the file being read: its vertices in first-use order and its triangles.
#[derive(Default)]
struct Object {
    /// File vertex index → this object's vertex.
    local: HashMap<u32, u32>,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl Object {
    fn vertex(&mut self, file_index: u32, all: &[Vec3]) -> u32 {
        *self.local.entry(file_index).or_insert_with(|| {
            self.positions.push(all[file_index as usize]);
            (self.positions.len() - 1) as u32
        })
    }
}

/// Parses OBJ `bytes` as the file `path` (for messages).
pub fn parse_obj(bytes: &[u8], path: &Path) -> Result<Mesh, InputError> {
    let err = |line: usize, message: String| InputError::Obj {
        path: path.into(),
        line: Some(line),
        message,
    };
    let mut all: Vec<Vec3> = Vec::new();
    let mut mesh = Mesh {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        ..Mesh::default()
    };
    let mut object = Object::default();
    let flush = |object: &mut Object, mesh: &mut Mesh| {
        let base = mesh.positions.len() as u32;
        mesh.positions.append(&mut object.positions);
        mesh.triangles
            .extend(object.triangles.drain(..).map(|t| t.map(|i| base + i)));
        object.local.clear();
    };
    let mut corners: Vec<u32> = Vec::new();
    for (k, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let number = k + 1;
        let text =
            std::str::from_utf8(raw).map_err(|_| err(number, "line is not valid UTF-8 text".into()))?;
        let text = text.split('#').next().unwrap_or("");
        let mut words = text.split_whitespace();
        match words.next() {
            Some("v") => {
                let values: Vec<&str> = words.collect();
                if !matches!(values.len(), 3 | 4 | 6) {
                    return Err(err(
                        number,
                        format!(
                            "vertex has {} values, expected x y z (and an optional w, or r g b)",
                            values.len()
                        ),
                    ));
                }
                let mut xyz = [0f32; 3];
                for (c, x) in values[..3].iter().zip(&mut xyz) {
                    *x = match c.parse::<f32>() {
                        Ok(v) if v.is_finite() => v,
                        Ok(_) => {
                            return Err(err(number, format!("vertex coordinate `{c}` is NaN or infinite")))
                        }
                        Err(_) => {
                            return Err(err(number, format!("vertex coordinate `{c}` is not a number")))
                        }
                    };
                }
                if values.len() == 4 {
                    let w: f32 = values[3]
                        .parse()
                        .map_err(|_| err(number, format!("vertex w `{}` is not a number", values[3])))?;
                    if w == 0.0 || !w.is_finite() {
                        return Err(err(
                            number,
                            format!("vertex w is {w}: must be finite and non-zero"),
                        ));
                    }
                    for x in &mut xyz {
                        *x /= w;
                    }
                    if !xyz.iter().all(|x| x.is_finite()) {
                        return Err(err(number, "vertex coordinate divided by w is infinite".into()));
                    }
                }
                all.push(Vec3::from(xyz));
            }
            Some("f") => {
                corners.clear();
                for corner in words {
                    let index = corner.split('/').next().unwrap_or("");
                    let i: i64 = index
                        .parse()
                        .map_err(|_| err(number, format!("face index `{index}` is not an integer")))?;
                    let n = all.len() as i64;
                    let resolved = match i {
                        0 => return Err(err(number, "face index 0 (OBJ indices start at 1)".into())),
                        i if i > 0 && i <= n => i - 1,
                        i if i < 0 && i >= -n => n + i,
                        _ => {
                            return Err(err(
                                number,
                                format!("face index {i} out of bounds: {n} vertices defined so far"),
                            ))
                        }
                    };
                    corners.push(resolved as u32);
                }
                if corners.len() < 3 {
                    return Err(err(
                        number,
                        format!("face has {} vertices, expected at least 3", corners.len()),
                    ));
                }
                if mesh.triangles.len() + object.triangles.len() + corners.len() - 2 > MAX_TRIANGLES {
                    return Err(err(
                        number,
                        format!("more than {MAX_TRIANGLES} triangles in one mesh"),
                    ));
                }
                let a = object.vertex(corners[0], &all);
                let mut b = object.vertex(corners[1], &all);
                for &c in &corners[2..] {
                    let c = object.vertex(c, &all);
                    object.triangles.push([a, b, c]);
                    b = c;
                }
            }
            // A new object or group ends the current one (as tobj splits models).
            Some("o") | Some("g") if !object.triangles.is_empty() => flush(&mut object, &mut mesh),
            _ => {}
        }
    }
    flush(&mut object, &mut mesh);
    if mesh.triangles.is_empty() {
        return Err(InputError::EmptyMesh { path: path.into() });
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Mesh, InputError> {
        parse_obj(text.as_bytes(), Path::new("t.obj"))
    }

    fn line_of(e: InputError) -> (Option<usize>, String) {
        match e {
            InputError::Obj { line, message, .. } => (line, message),
            other => panic!("{other}"),
        }
    }

    #[test]
    fn every_bad_line_is_named() {
        for (text, line, needle) in [
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
                5,
                "out of bounds",
            ),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "2 vertices"),
            ("v 0 0\n", 1, "2 values"),
            ("v 0 0 x\n", 1, "not a number"),
            ("v 0 0 inf\n", 1, "NaN or infinite"),
            ("v 0 0 1 0\n", 1, "w is 0"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "index 0"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", 4, "not an integer"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n", 4, "out of bounds"),
        ] {
            let (l, m) = line_of(parse(text).unwrap_err());
            assert_eq!(l, Some(line), "{text:?}: {m}");
            assert!(m.contains(needle), "{text:?}: {m}");
        }
        assert!(matches!(
            parse("v 0 0 0\n# nothing\n"),
            Err(InputError::EmptyMesh { .. })
        ));
        let (l, m) = line_of(parse_obj(b"v 0 0 0\nv \xff\n", Path::new("t.obj")).unwrap_err());
        assert_eq!((l, m.contains("UTF-8")), (Some(2), true));
    }

    #[test]
    fn polygons_fan_negative_indices_comments_and_object_order() {
        let m =
            parse("# header\nv 0 0 0\nv 1 0 0 # trailing\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\nl 1 2\n").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        // Two objects: each keeps its vertices in first-use order; w divides.
        let m = parse("v 0 0 0\nv 2 0 0 2\nv 0 1 0\no a\nf 3 2 1\no b\nf 1 2 3\n").unwrap();
        assert_eq!(m.positions[0], Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(m.positions[1], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(m.positions[3], Vec3::ZERO);
    }
}
