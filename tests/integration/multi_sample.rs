//! `light-samples`: the uniform multi-sample baseline against the ray-traced reference, counted
//! against native.

use sism::exec::Exec;
use sism::metrics::compare;

use crate::util::{image_bits as bits, render_with as run, repo_scene as load};

/// On the plate the error falls as the lattice grows, and at the paper's 289 points it is within
/// 0.01 MAE of a 1024-spp reference.
#[test]
fn light_samples_converge_to_the_reference_on_the_plate() {
    let scene = load("plate.toml", 128, 96);
    let truth = run(&scene, "reference", &[("spp", "1024")], Exec::Native).visibility;
    let mae = |side: &str| {
        let r = run(
            &scene,
            "light-samples",
            &[("samples_per_side", side), ("map_size", "1024")],
            Exec::Native,
        );
        assert_eq!(
            r.stats.get("light_points.used"),
            Some(side.parse::<f64>().unwrap().powi(2))
        );
        compare(&truth, &r.visibility).unwrap().mae
    };
    let (m16, m64, m289) = (mae("4"), mae("8"), mae("17"));
    eprintln!("light-samples MAE: N=16 {m16}, N=64 {m64}, N=289 {m289}");
    assert!(m289 < m64 && m64 < m16, "{m16} {m64} {m289}");
    assert!(m289 < 0.01, "{m289}");
}

/// One light point at the centre is the plain shadow map's hard test (same maps, same lookups);
/// counted equals native, and every phase is timed by the machine model.
#[test]
fn one_point_is_the_shadow_map_and_counted_equals_native() {
    let scene = load("plate.toml", 64, 48);
    let given = [
        ("samples_per_side", "1"),
        ("map_size", "512"),
        ("bias_slope", "1.5"),
    ];
    let one = run(&scene, "light-samples", &given, Exec::Native);
    let hard = run(&scene, "shadow-map", &[("map_size", "512")], Exec::Native);
    assert_eq!(bits(&one.visibility), bits(&hard.visibility));
    for visibility in ["hard", "rsmss"] {
        let given = [
            ("samples_per_side", "3"),
            ("map_size", "512"),
            ("visibility", visibility),
        ];
        let native = run(&scene, "light-samples", &given, Exec::Native);
        let counted = run(&scene, "light-samples", &given, Exec::Counting);
        assert_eq!(
            bits(&native.visibility),
            bits(&counted.visibility),
            "{visibility}"
        );
        let mut groups: Vec<&str> = counted.records.iter().map(|p| p.group()).collect();
        groups.dedup();
        assert_eq!(groups, ["eye_pass", "light_samples", "light_points"]);
        assert!(!counted
            .stats
            .stats
            .iter()
            .any(|s| s.name.starts_with("machine.untimed")));
    }
}

/// With refinement forced everywhere, the adaptive method renders every lattice point once, all at
/// level 4 with equal weights: the uniform mean of `light-samples` at 289 on the same points.
#[test]
fn forced_refinement_is_the_uniform_mean_over_the_lattice() {
    let scene = load("plate.toml", 96, 72);
    let common = [("map_size", "512"), ("bias_slope", "4"), ("visibility", "hard")];
    let uniform = run(&scene, "light-samples", &common, Exec::Native);
    let mut given = common.to_vec();
    given.push(("force_refine", "yes"));
    let forced = run(&scene, "rb-adaptive", &given, Exec::Native);
    assert_eq!(forced.stats.get("adaptive.samples_used"), Some(289.0));
    // Every node of levels 0..=3 evaluated and refined: 1 + 4 + 16 + 64.
    for (level, nodes) in [(0, 1.0), (1, 4.0), (2, 16.0), (3, 64.0)] {
        assert_eq!(
            forced.stats.get(&format!("adaptive.nodes_refined.l{level}")),
            Some(nodes)
        );
    }
    let worst = uniform
        .visibility
        .values
        .iter()
        .zip(&forced.visibility.values)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(worst < 1e-5, "largest difference {worst}");
}

/// The adaptive method uses fewer samples than the uniform 289 where penumbrae are narrow, stays
/// close to the uniform mean's error, and runs the same counted as native.
#[test]
fn adaptive_sampling_saves_samples_and_counted_equals_native() {
    let scene = load("plate.toml", 96, 72);
    let truth = run(&scene, "reference", &[("spp", "1024")], Exec::Native).visibility;
    let given = [("map_size", "512")];
    let adaptive = run(&scene, "rb-adaptive", &given, Exec::Native);
    let used = adaptive.stats.get("adaptive.samples_used").unwrap();
    let uniform = run(&scene, "light-samples", &given, Exec::Native);
    let (ea, eu) = (
        compare(&truth, &adaptive.visibility).unwrap().mae,
        compare(&truth, &uniform.visibility).unwrap().mae,
    );
    eprintln!("rb-adaptive: {used} samples, MAE {ea}; light-samples 289: MAE {eu}");
    assert!((4.0..289.0).contains(&used), "{used}");
    assert!(ea < 0.01, "{ea}");
    let counted = run(&scene, "rb-adaptive", &given, Exec::Counting);
    assert_eq!(bits(&adaptive.visibility), bits(&counted.visibility));
    assert_eq!(counted.stats.get("adaptive.samples_used"), Some(used));
    assert!(!counted
        .stats
        .stats
        .iter()
        .any(|s| s.name.starts_with("machine.untimed")));
}
