//! The paper-scale workloads and `sism table2`: its groups add up to the simulated frame, and the
//! command writes its table beside the paper's rows.

use sism::machine::MachineConfig;
use sism::table2::{self, Row};

use crate::util::{repo_scene, sism};

/// Eye pass + data structures + hard + soft + other is the simulated frame, for soft and hard light;
/// the shadow total excludes the eye pass; a point light has no soft shadow kernel.
#[test]
fn table2_groups_sum_to_the_simulated_frame() {
    let algo = sism::algorithms::find("sism").unwrap();
    let params = algo.params(&[]).unwrap();
    for radius in [0.5f32, 0.0] {
        let mut scene = repo_scene("sphere.toml", 96, 72);
        scene.light.radius = radius;
        let r = sism::render::render_on_machine(&scene, algo, &params, &MachineConfig::larrabee_24(), false);
        let row = Row::new("sphere", &r.report, &r.result.stats, 96, 72);
        let sum = row.eye_ms + row.data_structures_ms + row.hard_ms + row.soft_ms + row.other_ms;
        assert!(
            (sum - row.frame_ms).abs() <= 1e-9 * row.frame_ms,
            "groups {sum} ms, frame {} ms",
            row.frame_ms
        );
        let phases: f64 = r.report.groups.iter().map(|g| g.ms).sum();
        assert!((phases - row.frame_ms).abs() <= 1e-9 * row.frame_ms);
        assert!(row.eye_ms > 0.0 && row.data_structures_ms > 0.0 && row.hard_ms > 0.0);
        assert!((row.shadow_ms() - (row.frame_ms - row.eye_ms)).abs() <= 1e-9 * row.frame_ms);
        let shares = row.share(row.data_structures_ms)
            + row.share(row.hard_ms)
            + row.share(row.soft_ms)
            + row.share(row.other_ms);
        assert!((shares - 100.0).abs() < 1e-6, "{shares}");
        assert_eq!(row.hard, radius == 0.0);
        if radius == 0.0 {
            assert_eq!(row.silhouettes, 0);
        } else {
            assert!(row.soft_ms > 0.0 && row.silhouettes > 0);
        }
    }
}

/// The paper's rows are matched by name and by hard or soft light, and printed under the measured row.
#[test]
fn table2_prints_the_paper_beside_the_measured_rows() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sphere.toml"))
            .unwrap()
            .replace("width = 640", "width = 64")
            .replace("height = 480", "height = 48")
            .replace("../../shared", "../../../shared");
    for name in ["fern", "palm-hard", "palm"] {
        let body = if name == "palm-hard" {
            // The light's radius is the file's last `radius` (the sphere's comes first).
            let at = text.rfind("radius = 0.6").unwrap();
            format!(
                "{}radius = 0.0{}",
                &text[..at],
                &text[at + "radius = 0.6".len()..]
            )
        } else {
            text.clone()
        };
        std::fs::write(dir.path().join(format!("{name}.toml")), body).unwrap();
    }
    let out = sism(
        dir.path(),
        &[
            "table2",
            "fern.toml",
            "palm-hard.toml",
            "palm.toml",
            "--quiet",
            "--out",
            "t",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let md = std::fs::read_to_string(dir.path().join("t/table2.md")).unwrap();
    assert!(
        md.contains("| fern (sism) |") && md.contains("| fern (paper) | 212K | 13K | 800×600 | 6.4 ms (9%)")
    );
    assert!(md.contains("| palm-hard (sism) |") && md.contains("| palm (paper) | 44K | -- |"));
    // The soft palm has no paper row (the paper's palm is hard only).
    assert_eq!(md.matches("(paper)").count(), 2, "{md}");
    let csv = std::fs::read_to_string(dir.path().join("t/table2.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
    assert!(csv.lines().nth(1).unwrap().ends_with(",6.4,3.6,55,15"), "{csv}");
    assert_eq!(table2::PAPER.len(), 4);
}

/// A trace of identical frames has zero flicker for every deterministic algorithm (all of them: the
/// ray tracers' jitter is a function of seed and pixel), and `trace run` writes its files.
#[test]
fn identical_frames_have_zero_flicker() {
    use sism::trace;
    let scene = repo_scene("plate.toml", 32, 24);
    let text = "sism-trace 1\nscene plate.toml\nframe\nframe\nframe\n";
    let t = trace::parse(
        text,
        std::path::Path::new("same.trace"),
        &trace::initial_frame(&scene),
    )
    .unwrap();
    assert_eq!(t.frames.len(), 3);
    for algo in sism::algorithms::REGISTRY {
        let params = algo.params(&[]).unwrap();
        let frames: Vec<_> = t
            .frames
            .iter()
            .map(|f| {
                let s = trace::apply(&scene, f).unwrap();
                sism::render::render(&s, algo, &params, &Default::default()).visibility
            })
            .collect();
        for k in 1..frames.len() {
            let mut v = trace::flicker_values(&frames[k - 1], &frames[k], Some((&frames[0], &frames[0])));
            assert!(!v.is_empty(), "{}", algo.name);
            assert_eq!(trace::summarize(&mut v), (0.0, 0.0), "{} frame {k}", algo.name);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plate.toml"),
        dir.path().join("plate.toml"),
    )
    .unwrap();
    std::fs::write(dir.path().join("same.trace"), text).unwrap();
    let out = sism(
        dir.path(),
        &[
            "trace",
            "run",
            "same.trace",
            "--algo",
            "pcss",
            "--width",
            "32",
            "--height",
            "24",
            "--quiet",
            "--out",
            "o",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(dir.path().join("o/frames.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
    let summary = std::fs::read_to_string(dir.path().join("o/summary.txt")).unwrap();
    assert!(summary.contains("flicker_mean 0.000000"), "{summary}");
    assert!(dir.path().join("o/frames.png").is_file() && dir.path().join("o/frame_0002.pfm").is_file());
    // A bad trace names its line.
    std::fs::write(
        dir.path().join("bad.trace"),
        "sism-trace 1\nscene plate.toml\nframe\nlight 0 0 0 x\n",
    )
    .unwrap();
    let out = sism(
        dir.path(),
        &["trace", "run", "bad.trace", "--quiet", "--out", "b"],
    );
    crate::util::assert_clean_failure(&out, &["bad.trace:4", "`x` is not a number"]);
}
