//! Times a step on a fresh rayon pool after (or without) a counted frame, as `validate` runs it:
//! `pool_probe SCENE ALGO STEP THREADS COUNTED(0|1)`.
use sism::algorithms::PreparedScene;
use sism::exec::Exec;
use sism::render::{render_prepared, RenderOptions};

#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut scene = sism::scene::Scene::load(std::path::Path::new(&a[1])).unwrap();
    scene.camera.width = 1600;
    scene.camera.height = 1200;
    let algo = sism::algorithms::find(&a[2]).unwrap();
    let params = algo.params(&[]).unwrap();
    let threads: usize = a[4].parse().unwrap();
    let prepared = PreparedScene::new(&scene);
    let opts = |exec| RenderOptions {
        exec,
        progress: false,
    };
    if a[5] == "1" {
        let r = render_prepared(&prepared, algo, &params, &opts(Exec::Counting));
        drop(r);
    }
    let run = || {
        for _ in 0..6 {
            let r = render_prepared(&prepared, algo, &params, &opts(Exec::Native));
            println!(
                "{} {:.2} ms",
                a[3],
                r.stats.get(&format!("time.{}", a[3])).unwrap_or(-1.0)
            );
        }
    };
    // 0: the global pool (RAYON_NUM_THREADS).
    if threads == 0 {
        run();
    } else {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(run);
    }
}
