//! `light-samples`: the uniform multi-sample baseline against the ray-traced reference, counted
//! against native.

use std::path::Path;

use sism::exec::Exec;
use sism::frame::VisibilityImage;
use sism::metrics::compare;
use sism::scene::Scene;

use crate::util::render_with as run;

fn load(name: &str, width: u32, height: u32) -> Scene {
    let mut s = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap();
    s.camera.width = width;
    s.camera.height = height;
    s
}

fn bits(v: &VisibilityImage) -> Vec<u32> {
    v.values.iter().map(|x| x.to_bits()).collect()
}

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
