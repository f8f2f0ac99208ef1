//! Wavefront OBJ loading through `tobj`, with errors that name the file and line.
//!
//! `tobj` does the parsing and triangulation (polygons are fanned, negative indices are relative, several
//! objects and groups are merged into one mesh). Its errors carry no line number, so when it fails — or
//! when it succeeds but a coordinate is NaN or infinite — a second, cheap scan of the text finds the first
//! offending line. The scan runs only on the error path, so good files are parsed once.

use std::io::BufRead;
use std::path::Path;

use glam::Vec3;

use super::Mesh;
use crate::error::InputError;

/// Loads every triangle of the OBJ file at `path` into one [`Mesh`]. Materials, texture coordinates and
/// normals in the file are ignored: visibility needs positions only and face normals are derived.
pub fn load_obj(path: &Path) -> Result<Mesh, InputError> {
    let file = std::fs::File::open(path).map_err(|e| InputError::io(path, e))?;
    let mut reader = std::io::BufReader::new(file);
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials never matter to shadows; a missing .mtl must not fail the load.
    let loaded = tobj::load_obj_buf(&mut reader, &options, |_| Ok((Vec::new(), Default::default())));
    let (models, _) = match loaded {
        Ok(ok) => ok,
        Err(err) => return Err(locate_obj_error(path, &err.to_string())),
    };

    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = positions.len() as u32;
        for p in m.positions.chunks_exact(3) {
            let v = Vec3::new(p[0], p[1], p[2]);
            if !v.is_finite() {
                return Err(locate_obj_error(path, "vertex coordinate is NaN or infinite"));
            }
            positions.push(v);
        }
        let n = (m.positions.len() / 3) as u32;
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i >= n) {
                return Err(locate_obj_error(path, "face vertex index out of bounds"));
            }
            triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if triangles.is_empty() {
        return Err(InputError::EmptyMesh { path: path.into() });
    }
    Ok(Mesh {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        positions,
        triangles,
    })
}

/// Re-reads `path` to find the first line that explains `what` (tobj's message or ours). Returns an
/// [`InputError::Obj`] with that line, or with no line when the scan finds nothing wrong.
fn locate_obj_error(path: &Path, what: &str) -> InputError {
    let line = std::fs::File::open(path)
        .ok()
        .and_then(|f| first_bad_line(std::io::BufReader::new(f)));
    match line {
        Some((line, detail)) => InputError::Obj {
            path: path.into(),
            line: Some(line),
            message: detail,
        },
        None => InputError::Obj {
            path: path.into(),
            line: None,
            message: what.to_string(),
        },
    }
}

/// Scans OBJ text for the first line that is malformed: a `v` without three finite numbers, an `f` with
/// fewer than three vertices, or an index that is zero, unparsable or outside the vertices defined so
/// far. Returns the 1-based line number and what is wrong with it.
fn first_bad_line(reader: impl BufRead) -> Option<(usize, String)> {
    let mut vertex_count: i64 = 0;
    for (number, line) in reader.lines().enumerate() {
        let number = number + 1;
        let Ok(line) = line else {
            return Some((number, "line is not valid UTF-8 text".into()));
        };
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let coords: Vec<&str> = words.collect();
                if coords.len() < 3 {
                    return Some((
                        number,
                        format!("vertex has {} coordinates, expected 3", coords.len()),
                    ));
                }
                for c in &coords[..3] {
                    match c.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        Ok(_) => {
                            return Some((number, format!("vertex coordinate `{c}` is NaN or infinite")))
                        }
                        Err(_) => return Some((number, format!("vertex coordinate `{c}` is not a number"))),
                    }
                }
                vertex_count += 1;
            }
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return Some((
                        number,
                        format!("face has {} vertices, expected at least 3", corners.len()),
                    ));
                }
                for corner in corners {
                    let index = corner.split('/').next().unwrap_or("");
                    match index.parse::<i64>() {
                        Ok(0) => return Some((number, "face index 0 (OBJ indices start at 1)".into())),
                        Ok(i) if i > vertex_count || -i > vertex_count => {
                            return Some((
                                number,
                                format!(
                                    "face index {i} out of bounds: {vertex_count} vertices defined so far"
                                ),
                            ))
                        }
                        Ok(_) => {}
                        Err(_) => return Some((number, format!("face index `{index}` is not an integer"))),
                    }
                }
            }
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_finds_first_bad_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n";
        let (line, msg) = first_bad_line(text.as_bytes()).unwrap();
        assert_eq!(line, 5);
        assert!(msg.contains("out of bounds"), "{msg}");
    }

    #[test]
    fn scan_accepts_negative_indices_and_comments() {
        let text = "# header\nv 0 0 0\nv 1 0 0 # trailing\nv 0 1 0\nf -3 -2 -1\n";
        assert_eq!(first_bad_line(text.as_bytes()), None);
    }
}
