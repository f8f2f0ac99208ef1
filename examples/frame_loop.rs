//! Renders the same SISM frame repeatedly and prints each frame's per-phase host times: a steady-state
//! view (buffers freed by one frame are reused by the next) for profiling, e.g.
//! `perf record -g target/release/examples/frame_loop scenes/plate.toml 1600 1200 10`.

use sism::algorithms::sism::{render_scene, Composition, SismOptions};
use sism::exec::Exec;
use sism::scene::topology::SceneTopology;
use sism::scene::Scene;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(
        args.len() >= 2,
        "usage: frame_loop SCENE.toml [WIDTH HEIGHT [FRAMES [additive|independent|sampled]]]"
    );
    let mut scene = Scene::load(std::path::Path::new(&args[1]))?;
    if args.len() >= 4 {
        scene.camera.width = args[2].parse()?;
        scene.camera.height = args[3].parse()?;
    }
    let frames: usize = args.get(4).map(|s| s.parse()).transpose()?.unwrap_or(5);
    let composition = match args.get(5).map(String::as_str) {
        None | Some("additive") => Composition::Additive,
        Some("independent") => Composition::Independent,
        Some("sampled") => Composition::Sampled,
        Some(other) => anyhow::bail!("unknown composition {other}"),
    };
    let topo = SceneTopology::build(&scene);
    let options = SismOptions {
        composition,
        ..Default::default()
    };
    for k in 0..frames {
        let frame = render_scene(&scene, &topo, &options, Exec::Native);
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        let mut line = format!("frame {k}:");
        for t in frame.log.times() {
            line += &format!(" {} {:.1} |", t.name, ms(t.host));
        }
        println!("{line} total {:.1} ms", ms(frame.log.total()));
    }
    Ok(())
}
