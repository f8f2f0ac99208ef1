//! Revectorization-based shadow mapping (`smsr`, `rsmss`, `rpcf-smsr`, `rpcf-rsmss`) on real renders:
//! no light leaks into a closed box, and the error against the point-light reference at map sides
//! 512–4096 beside the plain shadow map's and PCF's. (The visibility functions themselves are checked
//! against an independent transcription in `tests/rbsm_oracle.rs`, the kernel against them in the
//! module's unit tests.)

use std::path::Path;

use glam::Vec3;
use sism::exec::Exec;
use sism::metrics::compare;
use sism::render::RenderResult;
use sism::scene::Scene;

const FAMILY: [&str; 7] = [
    "shadow-map",
    "pcf",
    "pcss",
    "smsr",
    "rsmss",
    "rpcf-smsr",
    "rpcf-rsmss",
];

fn run(scene: &Scene, algorithm: &str, given: &[(&str, &str)]) -> RenderResult {
    crate::util::render_with(scene, algorithm, given, Exec::Native)
}

/// The closed box `[-2, 2] × [0, 2] × [-2, 2]` (six quads), the camera inside it, a point light
/// outside above one corner.
const BOX_LO: Vec3 = Vec3::new(-2.0, 0.0, -2.0);
const BOX_HI: Vec3 = Vec3::new(2.0, 2.0, 2.0);
const BOX_EYE: Vec3 = Vec3::new(0.0, 1.0, 1.5);
const BOX_LOOK_AT: Vec3 = Vec3::new(0.0, 0.6, -1.0);
const BOX_FOV_DEG: f32 = 100.0;
const BOX_W: u32 = 320;
const BOX_H: u32 = 240;

fn closed_box() -> Scene {
    let quad = |c: [f32; 3], u: [f32; 3], v: [f32; 3]| {
        format!("[[quad]]\ncorner = {c:?}\nedge_u = {u:?}\nedge_v = {v:?}\n")
    };
    let text = [
        quad([-2.0, 0.0, 2.0], [4.0, 0.0, 0.0], [0.0, 0.0, -4.0]),
        quad([-2.0, 2.0, 2.0], [4.0, 0.0, 0.0], [0.0, 0.0, -4.0]),
        quad([-2.0, 0.0, 2.0], [4.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        quad([-2.0, 0.0, -2.0], [4.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        quad([-2.0, 0.0, -2.0], [0.0, 0.0, 4.0], [0.0, 2.0, 0.0]),
        quad([2.0, 0.0, -2.0], [0.0, 0.0, 4.0], [0.0, 2.0, 0.0]),
        format!(
            "[camera]\neye = {:?}\nlook_at = {:?}\nfov_y_deg = {BOX_FOV_DEG:?}\nwidth = {BOX_W}\n\
             height = {BOX_H}\n[light]\ncenter = [3.0, 6.0, 2.0]\nradius = 0.0\n",
            BOX_EYE.to_array(),
            BOX_LOOK_AT.to_array()
        ),
    ]
    .concat();
    Scene::from_toml(&text, Path::new("/virtual/closed-box.toml")).unwrap()
}

/// Distance from the point of the box's inside that pixel `(i, j)` sees to the nearest box edge
/// (the camera convention of docs/CONTRACTS.md; the eye is inside, so the ray leaves the box once).
fn distance_to_box_edge(i: u32, j: u32) -> f32 {
    let f = (BOX_LOOK_AT - BOX_EYE).normalize();
    let r = f.cross(Vec3::Y).normalize();
    let u = r.cross(f);
    let t = (BOX_FOV_DEG.to_radians() * 0.5).tan();
    let a = BOX_W as f32 / BOX_H as f32;
    let d = (f
        + ((2.0 * (i as f32 + 0.5) / BOX_W as f32 - 1.0) * t * a) * r
        + ((1.0 - 2.0 * (j as f32 + 0.5) / BOX_H as f32) * t) * u)
        .normalize();
    let exit = |k: usize| {
        let bound = if d[k] > 0.0 { BOX_HI[k] } else { BOX_LO[k] };
        if d[k] == 0.0 {
            f32::INFINITY
        } else {
            (bound - BOX_EYE[k]) / d[k]
        }
    };
    let (k, t_hit) = (0..3)
        .map(|k| (k, exit(k)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let p = BOX_EYE + d * t_hit;
    (0..3)
        .filter(|&m| m != k)
        .map(|m| (p[m] - BOX_LO[m]).min(BOX_HI[m] - p[m]))
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn no_light_leaks_into_a_closed_box() {
    // Every receiver inside is in the roof's shadow. The depth bias lets light through where a wall
    // meets the roof (a strip a few texels wide, wider for the revectorization family's polygon-offset
    // bias); anywhere farther from an edge a lit receiver is a leak of the method itself.
    let scene = closed_box();
    for size in ["512", "2048"] {
        let strip = 100.0 / size.parse::<f32>().unwrap();
        for algorithm in FAMILY {
            let r = run(&scene, algorithm, &[("map_size", size)]);
            let (mut deep, mut leaks, mut strip_lit) = (0usize, Vec::new(), 0usize);
            for (n, &v) in r.visibility.values.iter().enumerate() {
                if v.is_nan() || v < 0.0 {
                    continue; // facing away from the light
                }
                let (i, j) = (n as u32 % BOX_W, n as u32 / BOX_W);
                if distance_to_box_edge(i, j) > strip {
                    deep += 1;
                    if v > 0.0 {
                        leaks.push((i, j, v));
                    }
                } else if v > 0.0 {
                    strip_lit += 1;
                }
            }
            eprintln!("{algorithm} map {size}: {deep} receivers, {strip_lit} lit in the edge strip");
            assert!(deep > 20_000, "{algorithm}: {deep} receivers away from the edges");
            assert!(
                leaks.is_empty(),
                "{algorithm} map {size}: {} lit receivers inside the box, e.g. {:?}",
                leaks.len(),
                &leaks[..leaks.len().min(5)]
            );
        }
    }
}

fn load(name: &str, width: u32, height: u32) -> Scene {
    let mut s = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap();
    s.camera.width = width;
    s.camera.height = height;
    s.light.radius = 0.0;
    s
}

#[test]
fn revectorization_against_the_point_light_reference_at_every_map_side() {
    // The claims, checked where they hold and reported where they do not: RPCF over RSMSS
    // taps has less error than PCF 3×3 over the sides on curved silhouettes (within 5% on the plate's straight edges); SMSR, which only darkens, grows every shadow by
    // about half a texel (the revectorized edge runs through the outer corners of the boundary
    // texels), so its error is the plain map's or more — the paper's claim of less error fails here.
    // RSMSS against the plain map is reported, not asserted: which one wins depends on the scene
    // and the side.
    let mut table = String::new();
    for name in ["plate.toml", "stanford-bunny.toml", "palm.toml"] {
        let scene = load(name, 400, 300);
        let truth = run(&scene, "reference", &[("spp", "1")]).visibility;
        let mut first: Option<[f64; 6]> = None;
        let mut sums = (0.0, 0.0);
        for size in ["512", "1024", "2048", "4096"] {
            let mae = |algorithm: &str| {
                compare(&truth, &run(&scene, algorithm, &[("map_size", size)]).visibility)
                    .unwrap()
                    .mae
            };
            let e = ["shadow-map", "smsr", "rsmss", "pcf", "rpcf-smsr", "rpcf-rsmss"].map(mae);
            table += &format!("{name} {size}: shadow-map {:.5} smsr {:.5} rsmss {:.5} pcf {:.5} rpcf-smsr {:.5} rpcf-rsmss {:.5}\n", e[0], e[1], e[2], e[3], e[4], e[5]);
            let [plain, smsr, _, pcf, _, rpcf_rsmss] = e;
            assert!(
                smsr >= plain * 0.98,
                "{name} {size}: smsr {smsr} plain {plain}\n{table}"
            );
            // Per side the two are within a few percent.
            assert!(
                rpcf_rsmss <= pcf * 1.05,
                "{name} {size}: rpcf-rsmss {rpcf_rsmss} pcf {pcf}\n{table}"
            );
            sums.0 += pcf;
            sums.1 += rpcf_rsmss;
            first.get_or_insert(e);
            if size == "4096" {
                // Every method converges as the map grows.
                for (k, (&a, &b)) in first.unwrap().iter().zip(&e).enumerate() {
                    assert!(b < 0.8 * a, "{name}: method {k} {a} at 512, {b} at 4096\n{table}");
                }
            }
        }
        // On straight edges (the plate) a box filter of the staircase is already the exact blur and
        // RPCF's smoothed taps add a little: it loses there by 1–4%. Curved silhouettes are where
        // revectorization pays.
        assert!(
            name == "plate.toml" || sums.1 < sums.0,
            "{name}: rpcf-rsmss {} pcf {} summed over the sides\n{table}",
            sums.1,
            sums.0
        );
    }
    eprint!("{table}");
}
