//! Fits the contact-hardening methods' `distance_power` (Dp) and `distance_multiplier` (Dm) by a grid
//! search that minimises MAE against the ray-traced reference on one scene — by the project's rule
//! scenes/sphere.toml only, so that the figures reported on every other scene are not fitted to them:
//! `cargo run --release --example fit_contact_hardening -- scenes/sphere.toml 320 240`.
//! Prints every variant's best (Dp, Dm) and its MAE; the defaults in `algorithms::gaussian` are these.

use sism::algorithms::{find, Params};
use sism::exec::Exec;
use sism::metrics::compare;
use sism::render::{render, RenderOptions};
use sism::scene::Scene;

fn params(algo: &str, given: &[(&str, String)]) -> anyhow::Result<Params> {
    let a = find(algo).ok_or_else(|| anyhow::anyhow!("no algorithm {algo}"))?;
    let given: Vec<(String, String)> = given.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    Ok(a.params(&given)?)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(
        args.len() >= 2,
        "usage: fit_contact_hardening SCENE.toml [WIDTH HEIGHT]"
    );
    let mut scene = Scene::load(std::path::Path::new(&args[1]))?;
    if args.len() >= 4 {
        scene.camera.width = args[2].parse()?;
        scene.camera.height = args[3].parse()?;
    }
    let options = RenderOptions {
        exec: Exec::Native,
        progress: false,
    };
    let reference = find("reference").expect("registered");
    let truth = render(
        &scene,
        reference,
        &params("reference", &[("spp", "256".into())])?,
        &options,
    )
    .visibility;
    let powers = [0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0];
    let multipliers = [0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0];
    for algo in ["gaussian-pcf", "gaussian-single", "gaussian-multi"] {
        let a = find(algo).expect("registered");
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for &dp in &powers {
            for &dm in &multipliers {
                let p = params(
                    algo,
                    &[
                        ("distance_power", format!("{dp}")),
                        ("distance_multiplier", format!("{dm}")),
                    ],
                )?;
                let v = render(&scene, a, &p, &options).visibility;
                let mae = compare(&truth, &v)?.mae;
                if mae < best.0 {
                    best = (mae, dp, dm);
                }
            }
        }
        println!(
            "{algo}: distance_power={} distance_multiplier={} MAE {:.6}",
            best.1, best.2, best.0
        );
    }
    Ok(())
}
