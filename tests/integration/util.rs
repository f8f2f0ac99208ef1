//! Helpers shared by the integration tests.

use std::path::{Path, PathBuf};
use std::process::Output;

/// Runs the `sism` binary with `args` in `dir`.
pub fn sism(dir: &Path, args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_sism"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the sism binary runs")
}

/// Asserts that `out` is a clean failure: non-zero exit, no panic, and stderr mentions every `needle`.
pub fn assert_clean_failure(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr:\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "must not panic:\n{stderr}");
    assert_eq!(out.status.code(), Some(1), "exit code; stderr:\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "stderr should mention `{n}`:\n{stderr}");
    }
}

/// The repository's shared scene folder (`../shared/scenes` beside the repo), when present.
/// Outside CI a checkout without it skips the tests that need it; in CI (`CI` set) it must exist.
pub fn shared_scenes() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    if dir.is_dir() {
        Some(dir)
    } else if std::env::var_os("CI").is_some() {
        panic!("{} is missing: CI must provide ../shared", dir.display());
    } else {
        eprintln!("skipping: {} not found", dir.display());
        None
    }
}

/// A minimal valid camera and light block to append to test scenes.
pub const CAMERA_AND_LIGHT: &str = r#"
[camera]
eye = [0.0, 2.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_y_deg = 45.0
width = 32
height = 24

[light]
center = [0.0, 4.0, 0.0]
radius = 0.3
"#;

/// A unit triangle OBJ.
pub const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// Renders `scene` with the registered `algorithm` and the `given` parameters (checked; the rest at
/// their defaults), executed as `exec`.
pub fn render_with(
    scene: &sism::scene::Scene,
    algorithm: &str,
    given: &[(&str, &str)],
    exec: sism::exec::Exec,
) -> sism::render::RenderResult {
    let algo = sism::algorithms::find(algorithm).unwrap();
    let given: Vec<(String, String)> = given
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    sism::render::render(
        scene,
        algo,
        &algo.params(&given).unwrap(),
        &sism::render::RenderOptions {
            exec,
            progress: false,
        },
    )
}

/// The repository scene `scenes/NAME`, rendered at `width × height`.
pub fn repo_scene(name: &str, width: u32, height: u32) -> sism::scene::Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let mut s = sism::scene::Scene::load(&path).unwrap();
    s.camera.width = width;
    s.camera.height = height;
    s
}

/// An image's values as bits, for bit-for-bit comparisons.
pub fn image_bits(v: &sism::frame::VisibilityImage) -> Vec<u32> {
    v.values.iter().map(|x| x.to_bits()).collect()
}
