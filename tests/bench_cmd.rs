//! `sism bench`: the library entry point on the plate at a tiny size, and the CLI's errors.

use std::path::{Path, PathBuf};
use std::process::Output;

use sism::bench_cmd::{self, BenchOptions, CSV_HEADER, PLOT_SIZE};

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
    let out = dir.path().join("bench");
    let options = BenchOptions {
        out: out.clone(),
        spp_list: vec![16, 4],
        truth_spp: 256,
        truth: None,
        width: Some(64),
        height: Some(48),
        repeats: 1,
        progress: false,
    };
    let report = bench_cmd::bench(&plate(), &options).unwrap();
    assert_eq!((report.width, report.height), (64, 48));

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
    assert!(value(2, "mae") < 0.01, "sism MAE on the plate:\n{csv}");
    assert!(
        value(3, "mae") < 0.01,
        "sism-independent MAE on the plate:\n{csv}"
    );
    assert!(value(4, "mae") < 0.01, "sism-sampled MAE on the plate:\n{csv}");
    // The report and the CSV agree.
    assert!((report.rows[2].error.mae - value(2, "mae")).abs() < 1e-6);

    // JSON parses and carries the rows and the truth's settings.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 5);
    assert_eq!(json["truth"]["spp"], 256);
    assert_eq!(json["rows"][0]["times_ms"].as_array().unwrap().len(), 1);

    // The plot decodes at its size; the truth's images are there.
    let png = image::open(out.join("bench.png")).expect("bench.png decodes");
    assert_eq!((png.width(), png.height()), PLOT_SIZE);
    for f in ["visibility.pfm", "visibility.png", "shaded.png", "stats.json"] {
        assert!(out.join("truth").join(f).is_file(), "truth/{f} missing");
    }

    // --truth: the same truth from its PFM gives the same errors without rendering it again.
    let options = BenchOptions {
        out: dir.path().join("again"),
        spp_list: vec![4],
        truth: Some(out.join("truth/visibility.pfm")),
        ..options
    };
    let again = bench_cmd::bench(&plate(), &options).unwrap();
    assert_eq!(again.truth.spp, None);
    assert_eq!(again.rows.len(), 4); // one reference setting and the three SISM compositions
    assert_eq!(again.rows[0].error.mae, report.rows[0].error.mae);
}

#[test]
fn truth_of_another_size_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let truth = dir.path().join("truth.pfm");
    sism::output::pfm::write_pfm(&truth, &sism::frame::VisibilityImage::filled(8, 8, 1.0)).unwrap();
    let options = BenchOptions {
        out: dir.path().join("bench"),
        truth: Some(truth),
        width: Some(16),
        height: Some(12),
        progress: false,
        ..BenchOptions::default()
    };
    let e = format!("{:#}", bench_cmd::bench(&plate(), &options).unwrap_err());
    assert!(
        e.contains("--truth") && e.contains("8x8") && e.contains("16x12"),
        "{e}"
    );
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
