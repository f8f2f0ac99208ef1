//! OBJ features the loader must handle: polygons, several objects, negative indices, no normals,
//! per-mesh transforms.

use std::path::Path;

use glam::Vec3;
use sism::scene::{load_obj, Scene};

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn polygons_objects_and_negative_indices() {
    let dir = tempfile::tempdir().unwrap();
    let text = "\
# a quad, a pentagon with relative indices, and a triangle in a second object; no normals anywhere
o first
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
f 1 2 3 4
v 0 0 1
v 1 0 1
v 1.5 0.5 1
v 1 1 1
v 0 1 1
f -5 -4 -3 -2 -1
o second
v 5 0 0
v 6 0 0
v 5 1 0
f 10 11 12
";
    let mesh = load_obj(&write(dir.path(), "m.obj", text)).unwrap();
    assert_eq!(mesh.triangles.len(), 2 + 3 + 1);
    assert_eq!(mesh.positions.len(), 12);
    // Every triangle is a real one (fan triangulation of convex polygons leaves no degenerate ones).
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t);
        assert!((b - a).cross(c - a).length() > 1e-6);
    }
    // The pentagon's triangles all lie in z = 1; the last triangle uses the second object's vertices.
    assert!(mesh.corners(2).iter().all(|p| p.z == 1.0));
    assert_eq!(mesh.corners(5)[0], Vec3::new(5.0, 0.0, 0.0));
}

#[test]
fn mesh_transform_applies_scale_rotation_translation() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "t.obj", "v 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n");
    let scene_text = format!(
        "[[mesh]]\npath = \"t.obj\"\nscale = 2.0\nrotate_y_deg = 90.0\ntranslate = [10.0, 0.0, 0.0]\n{}",
        crate::util::CAMERA_AND_LIGHT
    );
    let scene = Scene::from_toml(&scene_text, &write(dir.path(), "s.toml", "")).unwrap();
    let p = scene.meshes[0].positions[0];
    // (1,0,0) scaled to (2,0,0), turned 90 degrees about +y to (0,0,-2), moved to (10,0,-2).
    assert!((p - Vec3::new(10.0, 0.0, -2.0)).length() < 1e-5, "{p}");
}

#[test]
fn a_missing_material_library_is_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = load_obj(&write(
        dir.path(),
        "m.obj",
        "mtllib nowhere.mtl\nusemtl x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    ));
    assert_eq!(mesh.unwrap().triangles.len(), 1);
}
