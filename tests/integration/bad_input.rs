//! Every kind of bad input gets a clear error naming what and where, and exit code 1 — never a panic.

use std::path::Path;

use crate::util::{assert_clean_failure, sism, CAMERA_AND_LIGHT, TRIANGLE_OBJ};

/// Writes `scene.toml` (and `mesh.obj` when given) into a fresh folder and renders it.
fn render_scene(scene: &str, obj: Option<&str>) -> (tempfile::TempDir, std::process::Output) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), scene).unwrap();
    if let Some(obj) = obj {
        std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
    }
    let out = sism(
        dir.path(),
        &["render", "scene.toml", "--out", "o", "--spp", "1", "--quiet"],
    );
    (dir, out)
}

fn scene_with_mesh() -> String {
    format!("[[mesh]]\npath = \"mesh.obj\"\n{CAMERA_AND_LIGHT}")
}

/// The scene with one `key = value` line of the camera or light replaced.
fn scene_with(line_from: &str, line_to: &str) -> String {
    let s = scene_with_mesh();
    assert!(s.contains(line_from), "test setup: `{line_from}` not in scene");
    s.replacen(line_from, line_to, 1)
}

#[test]
fn a_good_scene_renders() {
    let (dir, out) = render_scene(&scene_with_mesh(), Some(TRIANGLE_OBJ));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in [
        "visibility.pfm",
        "visibility.png",
        "shaded.png",
        "stats.json",
        "stats.txt",
    ] {
        assert!(dir.path().join("o").join(f).is_file(), "{f} written");
    }
}

#[test]
fn missing_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = sism(dir.path(), &["render", "nope.toml", "--quiet"]);
    assert_clean_failure(&out, &["nope.toml", "cannot read"]);
}

#[test]
fn unreadable_scene_file() {
    // A folder where a file is expected cannot be read (root reads any file, so permissions won't do).
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scene.toml")).unwrap();
    let out = sism(dir.path(), &["render", "scene.toml", "--quiet"]);
    assert_clean_failure(&out, &["scene.toml", "is a directory, not a regular file"]);
}

#[test]
fn missing_mesh_file() {
    let (_d, out) = render_scene(&scene_with_mesh(), None);
    assert_clean_failure(&out, &["mesh.obj", "cannot read"]);
}

#[test]
fn malformed_obj_face() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 two 3\n";
    let (_d, out) = render_scene(&scene_with_mesh(), Some(obj));
    assert_clean_failure(&out, &["mesh.obj", "line 5"]);
}

#[test]
fn malformed_obj_vertex() {
    let obj = "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n";
    let (_d, out) = render_scene(&scene_with_mesh(), Some(obj));
    assert_clean_failure(&out, &["mesh.obj", "line 2"]);
}

#[test]
fn obj_face_index_out_of_bounds() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
    let (_d, out) = render_scene(&scene_with_mesh(), Some(obj));
    assert_clean_failure(&out, &["mesh.obj", "line 4", "out of bounds"]);
}

#[test]
fn obj_nan_coordinate() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n";
    let (_d, out) = render_scene(&scene_with_mesh(), Some(obj));
    assert_clean_failure(&out, &["mesh.obj", "line 3", "NaN or infinite"]);
}

#[test]
fn obj_infinite_coordinate() {
    let obj = "v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n";
    let (_d, out) = render_scene(&scene_with_mesh(), Some(obj));
    assert_clean_failure(&out, &["mesh.obj", "line 2", "NaN or infinite"]);
}

#[test]
fn obj_with_no_triangles() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n";
    let (_d, out) = render_scene(&scene_with_mesh(), Some(obj));
    assert_clean_failure(&out, &["mesh.obj", "no triangles"]);
}

#[test]
fn unknown_toml_key() {
    let scene = scene_with("fov_y_deg = 45.0", "fov_y_deg = 45.0\nfocal_length = 35.0");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "unknown field `focal_length`", "line"]);
}

#[test]
fn mistyped_toml_value() {
    let scene = scene_with("width = 32", "width = \"32\"");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "width", "line"]);
}

#[test]
fn malformed_toml_syntax() {
    let scene = scene_with("[light]", "[light");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "line"]);
}

#[test]
fn missing_camera_table() {
    let scene = "[[mesh]]\npath = \"mesh.obj\"\n[light]\ncenter = [0.0, 4.0, 0.0]\nradius = 0.3\n";
    let (_d, out) = render_scene(scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "camera"]);
}

#[test]
fn scene_without_geometry() {
    let (_d, out) = render_scene(CAMERA_AND_LIGHT, None);
    assert_clean_failure(&out, &["scene.toml", "at least one"]);
}

#[test]
fn zero_width() {
    let (_d, out) = render_scene(&scene_with("width = 32", "width = 0"), Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "camera.width", "is 0"]);
}

#[test]
fn zero_height() {
    let (_d, out) = render_scene(&scene_with("height = 24", "height = 0"), Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "camera.height", "is 0"]);
}

#[test]
fn absurd_side() {
    let (_d, out) = render_scene(&scene_with("height = 24", "height = 1000000"), Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["camera.height", "1000000"]);
}

#[test]
fn buffers_would_not_fit_in_memory() {
    let scene = scene_with("width = 32", "width = 30000").replacen("height = 24", "height = 30000", 1);
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["camera.width", "30000x30000", "memory"]);
}

#[test]
fn absurd_size_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), scene_with_mesh()).unwrap();
    std::fs::write(dir.path().join("mesh.obj"), TRIANGLE_OBJ).unwrap();
    let out = sism(dir.path(), &["render", "scene.toml", "--width", "0", "--quiet"]);
    assert_clean_failure(&out, &["--width", "is 0"]);
}

#[test]
fn negative_light_radius() {
    let (_d, out) = render_scene(&scene_with("radius = 0.3", "radius = -0.3"), Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "light.radius", "-0.3"]);
}

#[test]
fn look_at_equals_eye() {
    let scene = scene_with("look_at = [0.0, 0.0, 0.0]", "look_at = [0.0, 2.0, 4.0]");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "camera.look_at", "equals camera.eye"]);
}

#[test]
fn up_parallel_to_view() {
    let scene = scene_with("fov_y_deg = 45.0", "up = [0.0, -2.0, -4.0]\nfov_y_deg = 45.0");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "camera.up", "parallel"]);
}

#[test]
fn nan_in_scene_file() {
    let scene = scene_with("eye = [0.0, 2.0, 4.0]", "eye = [nan, 2.0, 4.0]");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "camera.eye", "finite"]);
}

#[test]
fn infinite_light_center() {
    let scene = scene_with("center = [0.0, 4.0, 0.0]", "center = [0.0, inf, 0.0]");
    let (_d, out) = render_scene(&scene, Some(TRIANGLE_OBJ));
    assert_clean_failure(&out, &["scene.toml", "light.center", "finite"]);
}

#[test]
fn compare_rejects_size_mismatch_and_bad_pfm() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, w: u32, h: u32| {
        let img = sism::frame::VisibilityImage::filled(w, h, 0.5);
        sism::output::pfm::write_pfm(&d.join(name), &img).unwrap();
    };
    write("a.pfm", 4, 3);
    write("b.pfm", 3, 4);
    std::fs::write(d.join("bad.pfm"), b"P6\n4 3\n255\n").unwrap();
    assert_clean_failure(
        &sism(d, &["compare", "a.pfm", "b.pfm"]),
        &["differ in size", "4x3", "3x4"],
    );
    assert_clean_failure(&sism(d, &["compare", "a.pfm", "bad.pfm"]), &["bad.pfm", "magic"]);
    assert_clean_failure(
        &sism(d, &["compare", "a.pfm", "missing.pfm"]),
        &["missing.pfm", "cannot read"],
    );
    let ok = sism(d, &["compare", "a.pfm", "a.pfm"]);
    assert!(ok.status.success());
    assert!(String::from_utf8_lossy(&ok.stdout).contains("MAE                  0.000000"));
}

#[test]
fn library_errors_name_the_key() {
    // The same checks through the library API, for callers that do not use the CLI.
    let scene = scene_with("radius = 0.3", "radius = -1.0");
    let err = sism::scene::Scene::from_toml(&scene, Path::new("/virtual/scene.toml")).unwrap_err();
    assert!(
        matches!(err, sism::error::InputError::InvalidValue { ref key, .. } if key == "light.radius"),
        "{err}"
    );
}
