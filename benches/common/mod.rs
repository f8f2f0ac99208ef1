//! What the benches share: the repository's scenes at a bench's image size.

use std::path::Path;

use sism::scene::Scene;

/// `scenes/<name>.toml` at `width` × `height` pixels, or `None` with a note on stderr when it cannot
/// be loaded (a checkout without the shared meshes beside it skips that scene).
pub fn scene(name: &str, width: u32, height: u32) -> Option<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.toml"));
    match Scene::load(&path) {
        Ok(mut s) => {
            s.camera.width = width;
            s.camera.height = height;
            Some(s)
        }
        Err(e) => {
            eprintln!("skipping {name}: {e}");
            None
        }
    }
}
