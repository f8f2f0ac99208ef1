//! The real meshes of ../shared/scenes load with the counts their README states, and the repo's scene
//! files for them load and render.

use sism::scene::{load_obj, Scene};

use crate::util::shared_scenes;

#[test]
fn shared_meshes_load_with_documented_triangle_counts() {
    let Some(dir) = shared_scenes() else { return };
    // Counts after triangulation, from ../shared/scenes/README.md.
    for (file, triangles) in [
        ("palm/palm.obj", 43_323usize),
        ("stanford-bunny/stanford-bunny.obj", 69_451),
        ("cornell-box/CornellBox-Original.obj", 36),
    ] {
        let mesh = load_obj(&dir.join(file)).unwrap();
        assert_eq!(mesh.triangles.len(), triangles, "{file}");
        assert!(mesh.positions.iter().all(|p| p.is_finite()));
    }
}

#[test]
fn repo_scene_files_load() {
    if shared_scenes().is_none() {
        return;
    }
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut loaded = 0;
    for entry in std::fs::read_dir(&scenes).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(scene.triangle_count() > 0);
            loaded += 1;
        }
    }
    assert!(loaded >= 3, "found {loaded} scene files");
}
