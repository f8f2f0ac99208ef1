//! Diagnoses SISM's worst pixels against a reference image: for a few pixels whose error exceeds a
//! threshold, prints the receiver, the reference at that point (4096 samples), a brute-force umbra
//! count and penumbra sum over every silhouette edge, and each non-zero edge term.
//!
//! `cargo run --release --example debug_pixel -- SCENE.toml REFERENCE.pfm [THRESHOLD]`
//! (the scene is rendered at the reference image's size).

use std::path::Path;

use sism::algorithms::sism::silhouettes::silhouettes;
use sism::algorithms::sism::{occlusion::edge_term_scalar, render_scene, SismOptions};
use sism::exec::Exec;
use sism::scene::topology::SceneTopology;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(
        args.len() >= 3,
        "usage: debug_pixel SCENE.toml REFERENCE.pfm [THRESHOLD]"
    );
    let mut scene = sism::scene::Scene::load(Path::new(&args[1]))?;
    let reference = sism::output::pfm::read_pfm(Path::new(&args[2]))?;
    let threshold: f32 = args.get(3).map(|t| t.parse()).transpose()?.unwrap_or(0.3);
    scene.camera.width = reference.width;
    scene.camera.height = reference.height;
    let topo = SceneTopology::build(&scene);
    let frame = render_scene(&scene, &topo, &SismOptions::default(), Exec::Native);
    let bvh = sism::bvh::SceneBvh::build(&scene);
    let c = scene.light.center();
    let silhouettes = silhouettes(&topo, c);
    let worst = frame
        .visibility
        .values
        .iter()
        .zip(&reference.values)
        .enumerate()
        .filter(|(_, (&v, &r))| r >= 0.0 && v >= 0.0 && (v - r).abs() > threshold)
        .take(4);
    for (i, (&v, &r)) in worst {
        let rec = frame.receivers.pixels[i].expect("a receiver value has a receiver");
        let p = rec.position;
        let mut rng = sism::sampling::Rng::new(1, 2);
        let strata = sism::sampling::Strata::new(4096);
        let (at_p, _) =
            sism::algorithms::reference::receiver_visibility(&bvh, &scene.light, &rec, &strata, &mut rng);
        let to_light = c - p;
        let umbra = (0..topo.triangles.len())
            .filter(|&t| topo.counts(t, c))
            .filter(|&t| {
                let dir = to_light.normalize();
                bvh_free_crossing(&topo.triangles[t], p, dir, to_light.length())
            })
            .count();
        let q = (p - c).to_array();
        let terms: Vec<(usize, f32)> = silhouettes
            .iter()
            .enumerate()
            .map(|(k, e)| (k, edge_term_scalar(q, e, scene.light.radius)))
            .filter(|(_, t)| *t != 0.0)
            .collect();
        let sum: f32 = terms.iter().map(|(_, t)| t).sum();
        println!(
            "pixel {i}: p = {p}, n = {}; reference image {r}, reference at p {at_p}, sism {v}; \
             brute force: umbra {umbra}, penumbra {sum}",
            rec.normal
        );
        for (k, t) in terms {
            let e = &silhouettes[k];
            println!("    edge {:?} -> {:?} (n_tri {}): {t}", e.a, e.b, e.n_tri);
        }
    }
    Ok(())
}

/// Möller–Trumbore: does the open segment from `p` along unit `dir` (length `len`) cross `tri`?
fn bvh_free_crossing(tri: &[glam::Vec3; 3], p: glam::Vec3, dir: glam::Vec3, len: f32) -> bool {
    let (e1, e2) = (tri[1] - tri[0], tri[2] - tri[0]);
    let h = dir.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-12 {
        return false;
    }
    let f = 1.0 / a;
    let s = p - tri[0];
    let u = f * s.dot(h);
    let q = s.cross(e1);
    let v = f * dir.dot(q);
    let t = f * e2.dot(q);
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 1e-4 * len && t < len
}
