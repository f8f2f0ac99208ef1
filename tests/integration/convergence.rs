//! The reference converges: error against a high-sample render falls at least about as 1/sqrt(spp)
//! (stratification makes it fall faster on edges), and renders do not depend on the host thread count.

use std::path::Path;

use sism::algorithms::reference::{self, ReferenceOptions};
use sism::bvh::SceneBvh;
use sism::metrics::compare;
use sism::scene::Scene;

fn small_plate() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plate.toml");
    let mut s = Scene::load(&path).unwrap();
    s.camera.width = 128;
    s.camera.height = 96;
    s
}

fn render(scene: &Scene, bvh: &SceneBvh, spp: u32, seed: u64) -> sism::frame::VisibilityImage {
    let options = ReferenceOptions {
        spp,
        seed,
        progress: false,
        ..Default::default()
    };
    reference::render(scene, bvh, &options).1
}

#[test]
fn error_falls_as_samples_grow() {
    let scene = small_plate();
    let bvh = SceneBvh::build(&scene);
    let truth = render(&scene, &bvh, 4096, 1_000);
    let spps = [4u32, 16, 64, 256];
    let rmse: Vec<f64> = spps
        .iter()
        .map(|&spp| compare(&truth, &render(&scene, &bvh, spp, 7)).unwrap().rmse)
        .collect();
    // Least-squares slope of log RMSE against log spp.
    let xs: Vec<f64> = spps.iter().map(|&s| (s as f64).ln()).collect();
    let ys: Vec<f64> = rmse.iter().map(|e| e.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / 4.0, ys.iter().sum::<f64>() / 4.0);
    let slope = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
        / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    eprintln!("RMSE by spp {spps:?}: {rmse:?}; log-log slope {slope:.3}");
    for w in rmse.windows(2) {
        assert!(w[1] < w[0], "error must fall with more samples: {rmse:?}");
    }
    // 1/sqrt(spp) is a slope of -0.5; stratified samples on a straight edge reach about -0.75.
    assert!((-1.0..=-0.4).contains(&slope), "slope {slope}");
}

#[test]
fn same_image_for_any_thread_count() {
    let scene = small_plate();
    let bvh = SceneBvh::build(&scene);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&scene, &bvh, 16, 3))
    };
    let (one, many) = (run(1), run(3));
    let bits =
        |img: &sism::frame::VisibilityImage| img.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&one), bits(&many));
}
