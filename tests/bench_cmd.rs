//! `sism bench`: the library's measurement and the command's files on the plate at a tiny size, and
//! the CLI's errors.

use std::path::{Path, PathBuf};
use std::process::Output;

use sism::bench::{self, CSV_HEADER};

/// Size of the plots the commands draw, pixels.
const PLOT_SIZE: (u32, u32) = (1000, 700);

fn plate() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plate.toml")
}

fn sism(dir: &Path, args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_sism"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the sism binary runs")
}

/// Exit code 1 (the main error path, not clap's 2 and not a panic) and every needle in stderr.
fn assert_clean_failure(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "must not panic:\n{stderr}");
    assert_eq!(out.status.code(), Some(1), "exit code; stderr:\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "stderr should mention `{n}`:\n{stderr}");
    }
}

#[test]
fn bench_on_the_plate_writes_table_json_plot_and_truth() {
    let dir = tempfile::tempdir().unwrap();
    let plate = plate();
    let plate = plate.to_str().unwrap();
    let args = |out: &str, extra: &[&str]| {
        let mut a = vec![
            "bench",
            plate,
            "--out",
            out,
            "--quiet",
            "--width",
            "64",
            "--height",
            "48",
            "--repeats",
            "1",
        ];
        a.extend_from_slice(extra);
        a.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = sism(dir.path(), &a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        o
    };
    let algos = ["--algos", "reference,sism,sism-independent,sism-sampled"];
    run(args(
        "bench",
        &["--spp-list", "16,4", "--truth-spp", "256", algos[0], algos[1]],
    ));
    let out = dir.path().join("bench");

    // CSV: the header, the reference's sweep in ascending spp, then the three SISM compositions.
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    let rows: Vec<Vec<&str>> = lines[1..].iter().map(|l| l.split(',').collect()).collect();
    let keys: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(
        keys,
        [
            ("reference", "4"),
            ("reference", "16"),
            ("sism", "-"),
            ("sism-independent", "-"),
            ("sism-sampled", "-"),
        ],
        "{csv}"
    );
    let col = |name: &str| CSV_HEADER.split(',').position(|c| c == name).unwrap();
    let value = |row: usize, name: &str| -> f64 { rows[row][col(name)].parse().unwrap() };
    for row in 0..rows.len() {
        assert!(value(row, "median_ms") > 0.0, "{csv}");
        assert!(value(row, "compared") > 1000.0, "{csv}");
    }

    // The reference converges; SISM is close to the truth on the plate.
    assert!(
        value(1, "mae") < value(0, "mae"),
        "MAE must fall with spp:\n{csv}"
    );
    assert!(value(1, "rmse") < value(0, "rmse"), "{csv}");
    for (row, name) in [(2, "sism"), (3, "sism-independent"), (4, "sism-sampled")] {
        assert!(value(row, "mae") < 0.01, "{name} MAE on the plate:\n{csv}");
    }

    // ꟻLIP of the shaded views: in [0, 1] for every row, falling with the reference's spp, small
    // where SISM is close.
    for row in 0..rows.len() {
        let f = value(row, "flip");
        assert!((0.0..=1.0).contains(&f), "flip {f}:\n{csv}");
    }
    assert!(
        value(1, "flip") < value(0, "flip"),
        "ꟻLIP must fall with spp:\n{csv}"
    );
    assert!(value(2, "flip") < 0.05, "sism's ꟻLIP on the plate:\n{csv}");

    // JSON parses and carries the rows and the truth's settings.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 5);
    assert_eq!(json["truth"]["spp"], 256);
    assert_eq!(json["rows"][0]["times_ms"].as_array().unwrap().len(), 1);
    assert!((json["rows"][2]["error"]["mae"].as_f64().unwrap() - value(2, "mae")).abs() < 1e-6);
    assert!((json["rows"][2]["error"]["flip"].as_f64().unwrap() - value(2, "flip")).abs() < 1e-6);

    // The plot decodes at its size; the truth's images are there.
    let png = image::open(out.join("bench.png")).expect("bench.png decodes");
    assert_eq!((png.width(), png.height()), PLOT_SIZE);
    for f in ["visibility.pfm", "visibility.png", "shaded.png", "stats.json"] {
        assert!(out.join("truth").join(f).is_file(), "truth/{f} missing");
    }

    // --truth: the same truth from its PFM gives the same errors without rendering it again.
    let truth = out.join("truth/visibility.pfm");
    run(args(
        "again",
        &[
            "--spp-list",
            "4",
            "--truth",
            truth.to_str().unwrap(),
            algos[0],
            algos[1],
        ],
    ));
    let again: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("again/bench.json")).unwrap()).unwrap();
    assert!(again["truth"]["spp"].is_null());
    assert_eq!(again["rows"].as_array().unwrap().len(), 4); // one reference setting, three SISM
    assert_eq!(again["rows"][0]["error"]["mae"], json["rows"][0]["error"]["mae"]);
}

#[test]
fn library_bench_measures_every_candidate_against_one_truth() {
    let mut scene = sism::scene::Scene::load(&plate()).unwrap();
    scene.camera.width = 48;
    scene.camera.height = 36;
    let only = ["reference", "sism", "shadow-map", "pcss"].map(String::from);
    let candidates = bench::candidates(&[("spp", vec!["4".into()])], Some(&only)).unwrap();
    let (truth, info) = bench::render_truth(&scene, 64, false).unwrap();
    let report = bench::bench_scene(&scene, &candidates, &truth.visibility, info, 2, false, None).unwrap();
    assert_eq!(report.rows.len(), candidates.len());
    for r in &report.rows {
        assert_eq!(r.times_ms.len(), 2);
        assert!(r.median_ms > 0.0 && r.error.compared > 500, "{r:?}");
    }
    assert_eq!(report.rows[0].params, "spp=4 seed=0");
    // A truth of another size is an error naming both sizes.
    let small = sism::frame::VisibilityImage::filled(8, 8, 1.0);
    let info = bench::TruthInfo {
        spp: None,
        seed: None,
        file: None,
        time_ms: None,
    };
    let e = bench::bench_scene(&scene, &candidates, &small, info, 1, false, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("8x8") && e.contains("48x36"), "{e}");
}

#[test]
fn truth_of_another_size_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let truth = dir.path().join("truth.pfm");
    sism::output::pfm::write_pfm(&truth, &sism::frame::VisibilityImage::filled(8, 8, 1.0)).unwrap();
    let plate = plate();
    let out = sism(
        dir.path(),
        &[
            "bench",
            plate.to_str().unwrap(),
            "--quiet",
            "--truth",
            truth.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "12",
        ],
    );
    assert_clean_failure(&out, &["--truth", "8x8", "16x12"]);
}

#[test]
fn cli_rejects_bad_input_with_exit_code_1() {
    let dir = tempfile::tempdir().unwrap();
    let plate = plate();
    let plate = plate.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "bench", plate, "--out", "o", "--quiet", "--width", "8", "--height", "6",
        ];
        args.extend_from_slice(extra);
        sism(dir.path(), &args)
    };
    assert_clean_failure(&run(&["--spp-list", "4,x,16"]), &["--spp-list", "'x'"]);
    assert_clean_failure(&run(&["--spp-list", "4,0"]), &["--spp-list", "0 spp"]);
    assert_clean_failure(&run(&["--spp-list", ""]), &["--spp-list"]);
    assert_clean_failure(&run(&["--truth-spp", "0"]), &["--truth-spp"]);
    assert_clean_failure(&run(&["--repeats", "0"]), &["--repeats"]);
    assert_clean_failure(&run(&["--truth", "nope.pfm"]), &["--truth", "nope.pfm"]);
    assert_clean_failure(
        &sism(dir.path(), &["bench", "missing.toml", "--quiet"]),
        &["missing.toml"],
    );
}

#[test]
fn cli_bench_prints_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let plate = plate();
    let out = sism(
        dir.path(),
        &[
            "bench",
            plate.to_str().unwrap(),
            "--out",
            "o",
            "--quiet",
            "--width",
            "32",
            "--height",
            "24",
            "--spp-list",
            "4",
            "--truth-spp",
            "16",
            "--repeats",
            "2",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("penumbra MAE") && stdout.contains("sism"),
        "{stdout}"
    );
    assert!(dir.path().join("o/bench.csv").is_file());
}
