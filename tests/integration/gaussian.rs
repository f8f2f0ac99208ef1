//! Contact-hardening soft shadows (`gaussian-pcf`, `gaussian-single`, `gaussian-multi`): what the
//! method promises, counted against native, and its parameters' errors.

use std::path::Path;

use sism::exec::Exec;
use sism::scene::Scene;

use crate::util::{assert_clean_failure, image_bits as bits, render_with as run, repo_scene, sism};

const VARIANTS: [&str; 3] = ["gaussian-pcf", "gaussian-single", "gaussian-multi"];

fn plate(width: u32, height: u32) -> Scene {
    repo_scene("plate.toml", width, height)
}

/// Without dilation a pixel the hard test lights is never darkened, and every receiver's value lies in
/// [0, 1]; counted frames equal native ones.
#[test]
fn lit_pixels_stay_lit_and_values_stay_in_range() {
    let scene = plate(96, 72);
    let hard = run(&scene, "shadow-map", &[], Exec::Native).visibility;
    for algo in VARIANTS {
        for skip in ["no", "yes"] {
            let r = run(&scene, algo, &[("umbra_skip", skip)], Exec::Native);
            let v = &r.visibility.values;
            let mut darkened_lit = 0;
            for (&h, &g) in hard.values.iter().zip(v) {
                if h.is_nan() || h < 0.0 {
                    continue;
                }
                assert!((0.0..=1.0).contains(&g), "{algo}: {g}");
                if h == 1.0 && g < 1.0 {
                    darkened_lit += 1;
                }
            }
            assert_eq!(darkened_lit, 0, "{algo} umbra_skip={skip}");
            let soft = v.iter().filter(|&&g| g > 0.0 && g < 1.0).count();
            assert!(soft > 20, "{algo}: a penumbra forms ({soft} pixels)");
        }
        let counted = run(&scene, algo, &[], Exec::Counting);
        let native = run(&scene, algo, &[], Exec::Native);
        assert_eq!(bits(&native.visibility), bits(&counted.visibility), "{algo}");
    }
}

/// The penumbra widens as the occluder rises: a plate raised step by step over the ground.
#[test]
fn penumbra_grows_with_occluder_height() {
    for algo in VARIANTS {
        let mut widths = Vec::new();
        for h in [0.2f32, 0.6, 1.2] {
            let text = format!(
                "[[quad]]\ncorner = [-5.0, 0.0, 5.0]\nedge_u = [10.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -10.0]\n\
                 [[quad]]\ncorner = [-0.6, {h}, 0.6]\nedge_u = [1.2, 0.0, 0.0]\nedge_v = [0.0, 0.0, -1.2]\n\
                 [camera]\neye = [0.0, 4.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nfov_y_deg = 50.0\nwidth = 128\nheight = 96\n\
                 [light]\ncenter = [0.3, 4.0, 0.2]\nradius = 0.5\n"
            );
            let scene = Scene::from_toml(&text, Path::new("/virtual/raised-plate.toml")).unwrap();
            let r = run(&scene, algo, &[], Exec::Native);
            let soft = r
                .visibility
                .values
                .iter()
                .filter(|&&g| g > 0.0 && g < 1.0)
                .count();
            widths.push(soft);
        }
        eprintln!("{algo}: penumbra pixels {widths:?}");
        assert!(
            widths[0] < widths[1] && widths[1] < widths[2],
            "{algo}: {widths:?}"
        );
    }
}

#[test]
fn bad_parameters_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let plate = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plate.toml");
    let plate = plate.to_str().unwrap();
    let render = |algo: &str, param: &str| {
        sism(
            dir.path(),
            &[
                "render", plate, "--algo", algo, "--param", param, "--out", "o", "--quiet", "--width", "16",
                "--height", "12",
            ],
        )
    };
    for (algo, param, needles) in [
        ("gaussian-pcf", "distance_power=0", &["`distance_power`"][..]),
        ("gaussian-single", "distance_power=-1", &["`distance_power`"]),
        ("gaussian-multi", "passes=0", &["`passes`", "1..=10"]),
        ("gaussian-multi", "passes=1000", &["`passes`", "1..=10"]),
        ("gaussian-multi", "kernel=8", &["`kernel`", "odd"]),
        ("gaussian-multi", "kernel=21", &["`kernel`"]),
        ("gaussian-multi", "taps=65", &["`taps`"]),
        (
            "gaussian-pcf",
            "distance_multiplier=nan",
            &["`distance_multiplier`"],
        ),
    ] {
        assert_clean_failure(&render(algo, param), needles);
    }
}
