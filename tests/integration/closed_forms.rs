//! The reference against closed forms: a half-plane occluder edge (V is a circular-segment fraction), a
//! regular-polygon occluder coaxial with the light, fully lit and fully occluded points.
//!
//! Each single estimate must lie within 3 standard errors of the exact value, with the binomial
//! standard error `sqrt(V(1-V)/N)` of N independent samples — an upper bound for our stratified
//! estimator. The pooled signed error over many points and seeds must also be within 3 of *its*
//! empirical standard errors of zero: that finds a bias far smaller than any single estimate shows.

use std::path::Path;

use glam::Vec3;
use sism::algorithms::reference::receiver_visibility;
use sism::bvh::SceneBvh;
use sism::frame::Receiver;
use sism::sampling::{Rng, Strata};
use sism::scene::Scene;

const SPP: u32 = 256;
const SEEDS: u64 = 8;

fn scene(body: &str, light_center: Vec3, radius: f32) -> Scene {
    let text = format!(
        "{body}\n[camera]\neye = [0.0, 5.0, 9.0]\nlook_at = [0.0, 0.0, 0.0]\nfov_y_deg = 40.0\nwidth = 8\nheight = 8\n\
         [light]\ncenter = [{}, {}, {}]\nradius = {radius}\n",
        light_center.x, light_center.y, light_center.z
    );
    Scene::from_toml(&text, Path::new("/virtual/closed_form.toml")).unwrap()
}

/// Estimates V at `p` (normal +y) with `SPP` samples and the given seed.
fn estimate(bvh: &SceneBvh, scene: &Scene, p: Vec3, seed: u64) -> f32 {
    let r = Receiver {
        position: p,
        normal: Vec3::Y,
    };
    let mut rng = Rng::new(seed, 0);
    receiver_visibility(bvh, &scene.light, &r, &Strata::new(SPP), &mut rng).0
}

/// Checks every estimate against its exact value and the pooled bias; returns the largest |error|.
fn check(cases: &[(Vec3, f64)], bvh: &SceneBvh, scene: &Scene) -> f64 {
    let mut errors = Vec::new();
    for &(p, exact) in cases {
        for seed in 0..SEEDS {
            let v = estimate(bvh, scene, p, seed) as f64;
            let se = (exact * (1.0 - exact) / SPP as f64).sqrt();
            let err = v - exact;
            // 2e-6 absorbs f32 rounding where the exact value is 0 or 1 (se = 0).
            assert!(
                err.abs() <= 3.0 * se + 2e-6,
                "p = {p}, seed {seed}: V = {v}, exact {exact}, 3 SE = {}",
                3.0 * se
            );
            errors.push(err);
        }
    }
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let sd = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(
        mean.abs() <= 3.0 * sd / n.sqrt() + 1e-6,
        "pooled bias {mean} vs SE {}",
        sd / n.sqrt()
    );
    errors.iter().fold(0.0, |m, e| m.max(e.abs()))
}

/// Fraction of the disk of radius `r` beyond a chord at distance `d` from its centre.
fn segment_fraction(d: f64, r: f64) -> f64 {
    let a = (d / r).clamp(-1.0, 1.0);
    (a.acos() - a * (1.0 - a * a).sqrt()) / std::f64::consts::PI
}

#[test]
fn half_plane_edge_gives_circular_segment() {
    // Occluder: the half-plane x < 0 at height 1 (a 50 m quad); receivers on the ground y = 0.
    let c = Vec3::new(0.3, 3.0, 0.2);
    let radius = 0.5;
    let s = scene(
        "[[quad]]\ncorner = [-20.0, 0.0, 20.0]\nedge_u = [40.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -40.0]\n\
         [[quad]]\ncorner = [-50.0, 1.0, 25.0]\nedge_u = [50.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -50.0]\n",
        c,
        radius,
    );
    let bvh = SceneBvh::build(&s);
    let cd = c.as_dvec3();
    let mut cases = Vec::new();
    for k in 0..41 {
        let p = Vec3::new(-0.45 + 0.6 * k as f32 / 40.0, 0.0, -0.3 + 0.015 * k as f32);
        let pd = p.as_dvec3();
        // Plane through p and the edge line (x = 0, y = 1, along z); its distance to c gives the chord.
        let edge_point = glam::DVec3::new(0.0, 1.0, 0.0);
        let m = glam::DVec3::Z.cross(edge_point - pd).normalize();
        let delta = (cd - pd).dot(m).abs();
        let d = delta / (1.0 - (delta / (cd - pd).length()).powi(2)).sqrt();
        // The centre ray crosses y = 1 at x < 0: the disk centre is occluded.
        let crossing = pd + (cd - pd) * ((1.0 - pd.y) / (cd.y - pd.y));
        let seg = segment_fraction(d, radius as f64);
        let exact = if crossing.x < 0.0 { seg } else { 1.0 - seg };
        cases.push((p, exact));
    }
    let in_penumbra = cases.iter().filter(|(_, v)| *v > 0.05 && *v < 0.95).count();
    assert!(
        in_penumbra > 20,
        "cases cover the penumbra: {in_penumbra} of {}",
        cases.len()
    );
    let worst = check(&cases, &bvh, &s);
    eprintln!(
        "half-plane: largest |error| {worst:.4} over {} estimates",
        cases.len() as u64 * SEEDS
    );
}

#[test]
fn coaxial_polygon_occluder() {
    // A regular 48-gon of circumradius 0.2 at height 2 under a light of radius 0.5 at height 4. From an
    // axis point at height y it projects to a centred 48-gon of circumradius 0.2 (4 - y) / (2 - y) on the
    // light's disk, so V = 1 - area(48-gon) / (pi r^2) while the polygon fits inside the disk.
    let (segments, a, radius) = (48u32, 0.2f64, 0.5f64);
    let s = scene(
        &format!("[[disk]]\ncenter = [0.0, 2.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nradius = {a}\nsegments = {segments}\n"),
        Vec3::new(0.0, 4.0, 0.0),
        radius as f32,
    );
    let bvh = SceneBvh::build(&s);
    let n = segments as f64;
    let polygon_area = |rho: f64| 0.5 * n * (std::f64::consts::TAU / n).sin() * rho * rho;
    let mut cases = Vec::new();
    for y in [0.0f64, 0.25, 0.5, 0.75, 0.9] {
        let rho = a * (4.0 - y) / (2.0 - y);
        let inradius = rho * (std::f64::consts::PI / n).cos();
        let exact = if rho <= radius {
            1.0 - polygon_area(rho) / (std::f64::consts::PI * radius * radius)
        } else if inradius >= radius {
            0.0
        } else {
            continue; // the polygon's corners poke out of the disk: no simple closed form
        };
        cases.push((Vec3::new(0.0, y as f32, 0.0), exact));
    }
    assert!(cases.len() >= 4);
    assert!(cases.iter().any(|&(_, v)| v == 0.0), "one case is fully occluded");
    check(&cases, &bvh, &s);
}

#[test]
fn fully_lit_and_fully_occluded_points() {
    // A 2 m box hovering over the ground, light of radius 0.4 above it.
    let s = scene(
        "[[quad]]\ncorner = [-20.0, 0.0, 20.0]\nedge_u = [40.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -40.0]\n\
         [[box]]\nmin = [-1.0, 1.0, -1.0]\nmax = [1.0, 1.5, 1.0]\n",
        Vec3::new(0.0, 5.0, 0.0),
        0.4,
    );
    let bvh = SceneBvh::build(&s);
    for seed in 0..SEEDS {
        // Under the box centre, the whole disk is hidden; far to the side, nothing is.
        assert_eq!(estimate(&bvh, &s, Vec3::new(0.0, 0.0, 0.0), seed), 0.0);
        assert_eq!(estimate(&bvh, &s, Vec3::new(0.3, 0.0, -0.2), seed), 0.0);
        assert_eq!(estimate(&bvh, &s, Vec3::new(8.0, 0.0, 0.0), seed), 1.0);
        assert_eq!(estimate(&bvh, &s, Vec3::new(-6.0, 0.0, 5.0), seed), 1.0);
        // The box's own top face sees the whole light.
        assert_eq!(estimate(&bvh, &s, Vec3::new(0.2, 1.5, 0.1), seed), 1.0);
    }
}

#[test]
fn point_light_gives_hard_shadows() {
    let s = scene(
        "[[quad]]\ncorner = [-20.0, 0.0, 20.0]\nedge_u = [40.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -40.0]\n\
         [[quad]]\ncorner = [-50.0, 1.0, 25.0]\nedge_u = [50.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -50.0]\n",
        Vec3::new(0.0, 3.0, 0.0),
        0.0,
    );
    let bvh = SceneBvh::build(&s);
    // The shadow edge on the ground lies at x = 0 (light straight above the occluder edge).
    for x in [-0.5f32, -0.05, -0.01] {
        assert_eq!(estimate(&bvh, &s, Vec3::new(x, 0.0, 0.0), 0), 0.0, "x = {x}");
    }
    for x in [0.01f32, 0.05, 0.5] {
        assert_eq!(estimate(&bvh, &s, Vec3::new(x, 0.0, 0.0), 0), 1.0, "x = {x}");
    }
}
