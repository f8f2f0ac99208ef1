//! SISM end to end against the ray-traced reference, on the analytic plate, a room lit from inside
//! (cube of light views), adversarial scenes and the shared meshes; work skipping and determinism.

use std::path::Path;

use sism::algorithms::reference::{self, ReferenceOptions};
use sism::algorithms::sism::sampled::LightPoints;
use sism::algorithms::sism::{render_scene, Composition, SceneFrame as SismFrame, SismOptions};
use sism::bvh::SceneBvh;
use sism::exec::Exec;
use sism::frame::VisibilityImage;
use sism::metrics::{compare, ErrorReport};
use sism::scene::topology::SceneTopology;
use sism::scene::Scene;

fn load(name: &str, width: u32, height: u32) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let mut s = Scene::load(&path).unwrap();
    s.camera.width = width;
    s.camera.height = height;
    s
}

fn reference(scene: &Scene, spp: u32) -> VisibilityImage {
    let options = ReferenceOptions {
        spp,
        ..Default::default()
    };
    reference::render(scene, &SceneBvh::build(scene), &options).1
}

fn sism_frame(scene: &Scene, composition: Composition) -> SismFrame {
    let options = SismOptions {
        composition,
        ..Default::default()
    };
    render_scene(scene, &SceneTopology::build(scene), &options, Exec::Native)
}

/// Receivers facing away from the light (V = -1).
fn facing_away(f: &SismFrame) -> u64 {
    f.visibility.values.iter().filter(|&&v| v == -1.0).count() as u64
}

/// The frame's visibility values as bits, for exact comparisons.
fn bits(f: &SismFrame) -> Vec<u32> {
    f.visibility.values.iter().map(|v| v.to_bits()).collect()
}

fn score(scene: &Scene, spp: u32, composition: Composition) -> (ErrorReport, SismFrame) {
    let frame = sism_frame(scene, composition);
    let report = compare(&reference(scene, spp), &frame.visibility).unwrap();
    (report, frame)
}

#[test]
fn plate_matches_the_reference() {
    let scene = load("plate.toml", 320, 240);
    let (r, frame) = score(&scene, 1024, Composition::Additive);
    eprintln!("plate: {r:?}");
    assert!(r.compared > 50_000);
    assert!(r.penumbra_pixels > 2_000, "the view shows the penumbra");
    assert!(r.mae <= 0.005, "MAE {}", r.mae);
    assert!(r.p99 <= 0.05, "p99 {}", r.p99);
    // One occluder: the compositions agree (the light-point one falls back to Eq. 4 where its points
    // see no overlap, which is everywhere here).
    for composition in [Composition::Independent, Composition::Sampled] {
        let other = sism_frame(&scene, composition);
        let d = compare(&frame.visibility, &other.visibility).unwrap();
        assert!(d.max < 1e-5, "{composition:?}: {d:?}");
    }
}

#[test]
fn point_light_gives_hard_shadows_and_skips_all_penumbra_work() {
    let mut scene = load("plate.toml", 320, 240);
    scene.light.radius = 0.0;
    let (r, frame) = score(&scene, 1, Composition::Additive);
    eprintln!("plate, point light: {r:?}");
    assert!(r.mae <= 0.002, "MAE {}", r.mae);
    let p = &frame.stats.penumbra;
    assert_eq!(
        (p.silhouettes, p.quads, p.quad_bin_pairs, p.samples_evaluated),
        (0, 0, 0, 0)
    );
    assert!(frame.stats.umbra.samples_tested > 0);
}

#[test]
fn room_lit_from_inside_uses_a_cube_and_matches() {
    let scene = load("room.toml", 192, 192);
    let (r, frame) = score(&scene, 256, Composition::Additive);
    eprintln!("room: {r:?}");
    assert_eq!(frame.stats.grid.light_faces, 6);
    assert!(r.mae <= 0.006, "MAE {}", r.mae);
}

#[test]
fn facing_away_receivers_and_empty_bins_cost_nothing() {
    let scene = load("sphere.toml", 160, 120);
    let frame = sism_frame(&scene, Composition::Additive);
    let s = &frame.stats;
    let away = facing_away(&frame);
    assert!(away > 0, "the sphere's dark side faces away");
    assert_eq!(s.grid.samples, frame.eye.pixels_covered - away);
    assert!(s.grid.occupied_bins < s.grid.bins, "some bins are empty");
    // Closed meshes: only light-facing triangles count.
    assert!(s.umbra.triangles_back_facing > 0);
    // Distributions: ordered quantiles; every occupied cell holds a sample; shadows cross occluders.
    let [p50, p90, p99, max] = s.grid.samples_per_cell;
    assert!(
        1 <= p50 && p50 <= p90 && p90 <= p99 && p99 <= max,
        "{:?}",
        s.grid.samples_per_cell
    );
    let [d50, d90, d99, dmax] = s.umbra.depth_complexity;
    assert!(
        d50 <= d90 && d90 <= d99 && d99 <= dmax && dmax >= 1,
        "{:?}",
        s.umbra.depth_complexity
    );
    assert!(s.umbra.depth_complexity_mean > 0.0 && s.umbra.depth_complexity_mean <= dmax as f64);
}

#[test]
fn same_bits_for_any_thread_count_and_for_both_compositions_run_twice() {
    let scene = load("sphere.toml", 160, 120);
    for composition in [
        Composition::Additive,
        Composition::Independent,
        Composition::Sampled,
    ] {
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| sism_frame(&scene, composition))
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(bits(&a), bits(&b), "{composition:?}");
        assert_eq!(
            a.stats.penumbra.samples_evaluated,
            b.stats.penumbra.samples_evaluated
        );
        assert_eq!(a.stats.umbra.samples_tested, b.stats.umbra.samples_tested);
    }
}

/// Every receiver value is a finite number in [0, 1] (or -1 for facing away); misses are NaN.
fn assert_well_formed(frame: &SismFrame, what: &str) {
    for (v, r) in frame.visibility.values.iter().zip(&frame.receivers.pixels) {
        match r {
            None => assert!(v.is_nan(), "{what}: a miss holds {v}"),
            Some(_) => assert!(*v == -1.0 || (0.0..=1.0).contains(v), "{what}: V = {v}"),
        }
    }
}

fn inline_scene(body: &str, light: &str) -> Scene {
    let text = format!(
        "{body}\n[camera]\neye = [0.0, 3.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nfov_y_deg = 50.0\nwidth = 96\nheight = 72\n{light}"
    );
    Scene::from_toml(&text, Path::new("/virtual/adversarial.toml")).unwrap()
}

const GROUND: &str =
    "[[quad]]\ncorner = [-5.0, 0.0, 5.0]\nedge_u = [10.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -10.0]\n";

#[test]
fn adversarial_scenes_stay_well_formed_and_close() {
    let cases = [
        // Occluder coplanar with the receiver (a quad lying on the ground) and one touching it.
        (
            format!("{GROUND}[[quad]]\ncorner = [-0.5, 0.0, 0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -1.0]\n[[box]]\nmin = [1.0, 0.0, -0.5]\nmax = [1.6, 0.8, 0.1]\n"),
            "[light]\ncenter = [0.5, 3.0, 0.5]\nradius = 0.4\n",
            0.02,
        ),
        // A tiny light: nearly hard shadows.
        (
            format!("{GROUND}[[box]]\nmin = [-0.5, 0.5, -0.5]\nmax = [0.5, 0.7, 0.5]\n"),
            "[light]\ncenter = [0.3, 3.0, 0.2]\nradius = 0.0005\n",
            0.01,
        ),
        // A huge light, larger than the occluder and near it.
        (
            format!("{GROUND}[[box]]\nmin = [-0.5, 0.5, -0.5]\nmax = [0.5, 0.7, 0.5]\n"),
            "[light]\ncenter = [0.0, 2.5, 0.0]\nradius = 1.5\n",
            0.03,
        ),
        // A light almost touching the occluder.
        (
            format!("{GROUND}[[box]]\nmin = [-0.5, 0.5, -0.5]\nmax = [0.5, 0.7, 0.5]\n"),
            "[light]\ncenter = [0.0, 0.9, 0.0]\nradius = 0.19\n",
            0.03,
        ),
        // Receivers behind the light (the light between camera and ground, receivers all around).
        (
            format!("{GROUND}[[sphere]]\ncenter = [0.8, 0.4, 0.0]\nradius = 0.3\n"),
            "[light]\ncenter = [0.0, 0.5, 0.2]\nradius = 0.1\n",
            0.03,
        ),
    ];
    for (k, (body, light, bound)) in cases.iter().enumerate() {
        let scene = inline_scene(body, light);
        for composition in [
            Composition::Additive,
            Composition::Independent,
            Composition::Sampled,
        ] {
            let (r, frame) = score(&scene, 256, composition);
            assert_well_formed(&frame, &format!("case {k}"));
            eprintln!(
                "adversarial case {k} {composition:?}: {} px, {} penumbra px, MAE {:.4} p99 {:.4}",
                r.compared, r.penumbra_pixels, r.mae, r.p99
            );
            assert!(r.compared > 3000, "case {k}: the view shows the scene");
            assert!(
                r.mae <= *bound,
                "case {k} {composition:?}: MAE {} > {bound}",
                r.mae
            );
        }
    }
}

#[test]
fn shared_scenes_within_measured_bounds() {
    if crate::util::shared_scenes().is_none() {
        return;
    }
    // Bounds are the figures measured at this size (see the closing notes) with a margin: they pin
    // regressions. The paper's additive composition darkens overlapping foliage (C = 0); the
    // light-point composition removes that and is held to 0.03 on the foliage.
    for (name, composition, bound) in [
        ("stanford-bunny.toml", Composition::Additive, 0.006),
        ("palm.toml", Composition::Independent, 0.025),
        ("palm.toml", Composition::Sampled, 0.012),
        ("japanese-maple.toml", Composition::Sampled, 0.02), // tighter than the 0.03 asked
        ("cornell-box.toml", Composition::Additive, 0.02),
    ] {
        let scene = load(name, 200, 150);
        let (r, frame) = score(&scene, 256, composition);
        assert_well_formed(&frame, name);
        eprintln!(
            "{name} {composition:?}: MAE {:.4} p99 {:.4} penumbra MAE {:.4}",
            r.mae, r.p99, r.penumbra_mae
        );
        assert!(r.mae <= bound, "{name}: MAE {} > {bound}", r.mae);
    }
}

#[test]
fn counting_execution_gives_the_same_bits_and_records_every_phase() {
    let scene = load("sphere.toml", 128, 96);
    for composition in [
        Composition::Additive,
        Composition::Independent,
        Composition::Sampled,
    ] {
        let native = sism_frame(&scene, composition);
        let options = SismOptions {
            composition,
            ..Default::default()
        };
        let counted = render_scene(&scene, &SceneTopology::build(&scene), &options, Exec::Counting);
        assert_eq!(bits(&native), bits(&counted), "{composition:?}");
        assert!(native.log.records().is_empty());
        let mut phases: Vec<&str> = counted.log.records().iter().map(|p| p.group()).collect();
        phases.dedup();
        assert_eq!(
            phases,
            [
                "eye_pass",
                "light_samples",
                "grid",
                "umbra",
                "silhouettes",
                "penumbra",
                "resolve"
            ],
            "{composition:?}"
        );
        let steps: Vec<&str> = counted.log.records().iter().map(|p| p.phase.as_str()).collect();
        let kernel = match composition {
            Composition::Additive => "penumbra.eq3",
            Composition::Sampled => "penumbra.light_points",
            Composition::Independent => "penumbra.fused",
        };
        assert!(steps.contains(&kernel), "{composition:?}: {steps:?}");
        for p in counted.log.records() {
            assert!(!p.tasks.is_empty(), "{}", p.phase);
            let instructions: u64 = p.tasks.iter().map(|t| t.counters.instructions()).sum();
            assert!(instructions > 0, "{}", p.phase);
        }
    }
}

/// With open planar occluders the outline is the same from every light point, so the light-point
/// composition has no approximation left: each pixel's visibility must be the share of its light
/// points that a ray from the receiver reaches unblocked — ray-cast here to the very same points.
#[test]
fn light_point_counts_equal_ray_casts_to_the_same_points() {
    use sism::algorithms::sism::sampled::LightPointEstimator;
    // The plain point fraction (the default estimator adds the analytic mean, see below).
    let options = SismOptions {
        composition: Composition::Sampled,
        light_point_estimator: LightPointEstimator::Fraction,
        ..Default::default()
    };
    let scene = overlapping_plates();
    let frame = render_scene(&scene, &SceneTopology::build(&scene), &options, Exec::Native);
    check_against_brute_force_rays(
        &scene,
        &frame.visibility,
        &frame.receivers,
        LightPoints::default(),
        0,
    );
}

/// The cost-aware penumbra: bins that cast rays to their light points instead of evaluating Eq. 3
/// (here nearly every bin with a quad: `ray_evaluations=1`) give the same points' answer, natively and counted
/// alike, and say how many samples took that path. With 64 light points: the cost-aware choice's
/// constants were measured with them (with more points fewer parts find rays cheaper).
#[test]
fn bins_that_cast_rays_give_the_light_points_answer() {
    let scene = overlapping_plates();
    let run = |exec| {
        crate::util::render_with(
            &scene,
            "sism-sampled",
            &[
                ("ray_evaluations", "1"),
                ("estimator", "fraction"),
                ("ray_refine_points", "0"),
                ("light_points", "64"),
            ],
            exec,
        )
    };
    let native = run(Exec::Native);
    let counted = run(Exec::Counting);
    assert_eq!(native.visibility.values.len(), counted.visibility.values.len());
    for (a, b) in native.visibility.values.iter().zip(&counted.visibility.values) {
        assert_eq!(a.to_bits(), b.to_bits(), "counted = native");
    }
    let ray_samples = native.stats.get("penumbra.ray_samples").unwrap();
    let evaluated = native.stats.get("penumbra.samples_evaluated").unwrap();
    eprintln!("ray samples {ray_samples}, Eq. 3 evaluations {evaluated}");
    assert!(
        ray_samples > 500.0,
        "the penumbra's bins cast rays: {ray_samples} samples"
    );
    // Only probed parts cast, and the probes walked the BVH.
    let stat = |k: &str| native.stats.get(k).unwrap();
    assert!(stat("penumbra.ray_parts_probed") >= stat("penumbra.ray_parts"));
    assert!(stat("penumbra.ray_probe_work") > 0.0);
    // The receivers of the same eye pass.
    let receivers = render_scene(
        &scene,
        &SceneTopology::build(&scene),
        &SismOptions::default(),
        Exec::Native,
    )
    .receivers;
    check_against_brute_force_rays(&scene, &native.visibility, &receivers, LightPoints::P64, 0);
}

/// The ray-cast samples whose rays to their light points (the default 128) disagree cast
/// `ray_refine_points` more (another spiral, turned): their visibility is the lit share of all
/// `128 + n` points; samples whose rays agree keep that answer and cast no more. Natively and counted
/// alike; the counters add up.
#[test]
fn ray_cast_samples_that_disagree_add_the_refinement_rays() {
    let scene = overlapping_plates();
    let refine = 96usize;
    let run = |exec| {
        crate::util::render_with(
            &scene,
            "sism-sampled",
            &[
                ("ray_evaluations", "1"),
                ("estimator", "fraction"),
                ("ray_refine_points", &refine.to_string()),
                ("ray_parts", "all"),
            ],
            exec,
        )
    };
    let native = run(Exec::Native);
    let counted = run(Exec::Counting);
    for (a, b) in native.visibility.values.iter().zip(&counted.visibility.values) {
        assert_eq!(a.to_bits(), b.to_bits(), "counted = native");
    }
    let stat = |k: &str| native.stats.get(k).unwrap();
    let (samples, refined, agreed) = (
        stat("penumbra.ray_samples"),
        stat("penumbra.ray_samples_refined"),
        stat("penumbra.ray_refinements_skipped"),
    );
    eprintln!(
        "ray samples {samples}, refined {refined}, agreed {agreed}, rays {}",
        stat("penumbra.rays_cast")
    );
    assert!(refined > 200.0, "penumbra samples refined: {refined}");
    assert!(agreed > 200.0, "lit or hidden samples not refined: {agreed}");
    assert!(refined + agreed <= samples);
    // Every refined sample cast its refinement's rays on top of at most one per light point (none
    // below the horizon here: the plates lie above the ground, the light above them).
    let points = LightPoints::default().get() as f64;
    assert!(stat("penumbra.rays_cast") <= points * samples + refine as f64 * refined);
    assert!(stat("penumbra.rays_cast") >= refine as f64 * refined);
    let receivers = render_scene(
        &scene,
        &SceneTopology::build(&scene),
        &SismOptions::default(),
        Exec::Native,
    )
    .receivers;
    check_against_brute_force_rays(
        &scene,
        &native.visibility,
        &receivers,
        LightPoints::default(),
        refine,
    );
}

/// Three overlapping tilted plates at different heights (their shadows overlap) over the ground.
fn overlapping_plates() -> Scene {
    let plates = "[[quad]]\ncorner = [-0.8, 0.8, 0.6]\nedge_u = [1.0, 0.1, 0.0]\nedge_v = [0.1, 0.0, -1.0]\n\
                  [[quad]]\ncorner = [-0.3, 1.2, 0.3]\nedge_u = [0.9, -0.2, 0.2]\nedge_v = [-0.1, 0.1, -0.9]\n\
                  [[quad]]\ncorner = [-0.5, 0.5, -0.1]\nedge_u = [0.7, 0.0, -0.3]\nedge_v = [0.3, 0.05, -0.6]\n";
    inline_scene(
        &format!("{GROUND}{plates}"),
        "[light]\ncenter = [0.2, 3.0, 0.1]\nradius = 0.8\n",
    )
}

/// Every pixel's visibility is the share of its light points a brute-force ray test finds unblocked
/// (one point may flip on an edge within rounding); with `refine` > 0, of its `n_points` points and, where
/// those disagree, its `refine` refinement points too (a pixel of a part that evaluated Eq. 3, which
/// has no refinement, may then differ: at most 2% of the pixels).
fn check_against_brute_force_rays(
    scene: &Scene,
    visibility: &VisibilityImage,
    receivers: &sism::frame::Receivers,
    n_points: LightPoints,
    refine: usize,
) {
    use glam::Vec3;
    use sism::algorithms::sism::sampled::{light_point_offsets, refine_point_offsets};
    let light_points = n_points.get();
    let tris: Vec<[Vec3; 3]> = scene.triangles().collect();
    let c = Vec3::from(scene.light.center);
    let r = scene.light.radius;
    let blocked = |p: Vec3, q: Vec3| {
        tris.iter().any(|t| {
            // Moller-Trumbore on the segment p -> q, ignoring hits at the receiver itself.
            let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], q - p);
            let h = d.cross(e2);
            let det = e1.dot(h);
            if det.abs() < 1e-12 {
                return false;
            }
            let f = 1.0 / det;
            let s = p - t[0];
            let u = f * s.dot(h);
            let qv = s.cross(e1);
            let v = f * d.dot(qv);
            let tt = f * e2.dot(qv);
            (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && tt > 1e-4 && tt < 1.0
        })
    };
    let (mut pixels, mut partial, mut off, mut sum_diff) = (0usize, 0usize, 0usize, 0.0f64);
    for (pixel, (v, rcv)) in visibility.values.iter().zip(&receivers.pixels).enumerate() {
        let Some(rcv) = rcv else { continue };
        if *v < 0.0 {
            continue;
        }
        let offsets = light_point_offsets(rcv.position - c, pixel as u32, n_points);
        let mut lit = offsets
            .iter()
            .filter(|o| !blocked(rcv.position, c + **o * r))
            .count();
        let mut points = light_points;
        if refine > 0 && lit > 0 && lit < light_points {
            let more = refine_point_offsets(rcv.position - c, pixel as u32, refine);
            lit += more
                .iter()
                .filter(|o| !blocked(rcv.position, c + **o * r))
                .count();
            points += refine;
        }
        let expected = lit as f32 / points as f32;
        pixels += 1;
        partial += usize::from(points > light_points || (lit > 0 && lit < light_points));
        let diff = (v - expected).abs();
        sum_diff += diff as f64;
        // One point may flip where it lies on an edge's boundary within rounding.
        off += usize::from(diff > 1.5 / points as f32);
    }
    eprintln!(
        "{pixels} pixels, {partial} in penumbra, {off} off by more than one point, mean |diff| {:.5}",
        sum_diff / pixels as f64
    );
    assert!(partial > 500, "the view shows overlapping penumbrae ({partial})");
    let (off_share, mean_diff) = if refine == 0 { (0.001, 1e-3) } else { (0.02, 2e-3) };
    assert!(
        off as f64 <= off_share * pixels as f64,
        "{off} of {pixels} pixels differ by more than one light point"
    );
    assert!(sum_diff / (pixels as f64) < mean_diff);
}
