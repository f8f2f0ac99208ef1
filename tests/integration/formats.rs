//! OpenEXR beside the PFM, and ꟻLIP beside MAE (issue 29), through the command line: what a render
//! writes, what `compare` reads and reports, and what a trace run adds.

use std::path::Path;

use crate::util::{assert_clean_failure, image_bits, sism};

fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

fn ok(out: &std::process::Output, what: &str) -> String {
    assert!(
        out.status.success(),
        "{what} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn render(dir: &Path, algo: &str, out: &str, extra: &[&str]) {
    let scene = repo("scenes/plate.toml");
    let mut args = vec![
        "render", &scene, "--algo", algo, "--width", "96", "--height", "72", "--out", out, "--quiet",
    ];
    args.extend_from_slice(extra);
    ok(&sism(dir, &args), &format!("render {algo}"));
}

/// The `ꟻLIP (mean, LDR)` line's value.
fn flip_of(report: &str) -> f64 {
    report
        .lines()
        .find_map(|l| l.strip_prefix("ꟻLIP (mean, LDR)"))
        .unwrap_or_else(|| panic!("no ꟻLIP line in:\n{report}"))
        .trim()
        .parse()
        .unwrap()
}

#[test]
fn renders_write_exr_that_reads_back_as_the_pfm_and_compare_takes_either() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "reference", "ref", &["--spp", "64"]);
    render(d, "pcss", "pcss", &[]);
    for f in ["visibility.exr", "shaded.exr"] {
        assert!(d.join("ref").join(f).is_file(), "{f} missing");
    }
    // visibility.exr holds the PFM's values bit for bit (NaN misses, -1 facing away included).
    let pfm = sism::output::pfm::read_pfm(&d.join("ref/visibility.pfm")).unwrap();
    let exr = sism::output::exr::read_visibility_exr(&d.join("ref/visibility.exr")).unwrap();
    assert_eq!((pfm.width, pfm.height), (exr.width, exr.height));
    assert_eq!(image_bits(&pfm), image_bits(&exr));
    assert!(
        pfm.values.iter().any(|v| v.is_nan()),
        "the plate's frame has misses"
    );

    // compare: either format on either side gives the same figures; ꟻLIP from the shaded.png
    // beside both inputs equals ꟻLIP from shading with the scene.
    let a = ok(
        &sism(d, &["compare", "ref/visibility.pfm", "pcss/visibility.pfm"]),
        "compare pfm",
    );
    let b = ok(
        &sism(d, &["compare", "ref/visibility.exr", "pcss/visibility.exr"]),
        "compare exr",
    );
    assert_eq!(
        a.lines().take(8).collect::<Vec<_>>(),
        b.lines().take(8).collect::<Vec<_>>()
    );
    let scene = repo("scenes/plate.toml");
    let c = ok(
        &sism(
            d,
            &[
                "compare",
                "ref/visibility.exr",
                "pcss/visibility.pfm",
                "--scene",
                &scene,
                "--json",
            ],
        ),
        "compare --scene",
    );
    let json: serde_json::Value = serde_json::from_str(&c).unwrap();
    let flip = flip_of(&a);
    assert!(
        flip > 0.0 && flip < 0.2,
        "pcss against the reference: ꟻLIP {flip}"
    );
    assert!((json["flip"].as_f64().unwrap() - flip).abs() < 1e-6, "{c}\n{a}");
    // Identical frames: no error at all.
    let same = ok(
        &sism(d, &["compare", "ref/visibility.pfm", "ref/visibility.exr"]),
        "same",
    );
    assert_eq!(flip_of(&same), 0.0);

    // The ꟻLIP heat map, in magma colours.
    ok(
        &sism(
            d,
            &[
                "compare",
                "ref/visibility.pfm",
                "pcss/visibility.pfm",
                "--heatmap",
                "flip.png",
                "--heatmap-metric",
                "flip",
            ],
        ),
        "flip heat map",
    );
    let map = image::open(d.join("flip.png")).unwrap().to_rgb8();
    assert_eq!(map.dimensions(), (96, 72));

    // Bare visibility files (no shaded.png beside them): MAE still, ꟻLIP said to be missing, and a
    // ꟻLIP heat map refused with the reason.
    std::fs::copy(d.join("ref/visibility.exr"), d.join("r.exr")).unwrap();
    std::fs::copy(d.join("pcss/visibility.pfm"), d.join("t.pfm")).unwrap();
    let bare = ok(&sism(d, &["compare", "r.exr", "t.pfm"]), "bare compare");
    assert!(bare.contains("ꟻLIP: not reported"), "{bare}");
    let out = sism(
        d,
        &[
            "compare",
            "r.exr",
            "t.pfm",
            "--heatmap",
            "h.png",
            "--heatmap-metric",
            "flip",
        ],
    );
    assert_clean_failure(&out, &["--heatmap-metric flip", "--scene"]);
}

#[test]
fn corrupt_and_wrong_exr_files_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "shadow-map", "sm", &[]);
    // An RGB image is not a visibility image.
    let out = sism(d, &["compare", "sm/shaded.exr", "sm/visibility.pfm"]);
    assert_clean_failure(&out, &["shaded.exr", "none named `V`"]);
    // Truncated and garbage files name the file and the format.
    let bytes = std::fs::read(d.join("sm/visibility.exr")).unwrap();
    std::fs::write(d.join("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
    let out = sism(d, &["compare", "cut.exr", "sm/visibility.pfm"]);
    assert_clean_failure(&out, &["cut.exr", "OpenEXR"]);
    std::fs::write(d.join("junk.img"), b"GIF89a not a visibility image").unwrap();
    let out = sism(d, &["compare", "junk.img", "sm/visibility.pfm"]);
    assert_clean_failure(&out, &["junk.img", "neither a PFM"]);
}

#[test]
fn trace_runs_write_exr_frames_and_report_flip_against_a_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(repo("scenes/plate.toml"), d.join("plate.toml")).unwrap();
    ok(
        &sism(
            d,
            &[
                "trace",
                "make",
                "orbit",
                "plate.toml",
                "--frames",
                "2",
                "--out",
                "o.trace",
            ],
        ),
        "trace make",
    );
    let run = |algo: &str, out: &str, extra: &[&str]| {
        let mut args = vec![
            "trace", "run", "o.trace", "--algo", algo, "--width", "48", "--height", "36", "--out", out,
            "--quiet",
        ];
        args.extend_from_slice(extra);
        ok(&sism(d, &args), &format!("trace run {algo}"));
    };
    run("reference", "ref", &["--spp", "16"]);
    // The reference's PFMs removed: its EXR frames serve as the reference.
    for k in 0..2 {
        assert!(d.join(format!("ref/frame_{k:04}.exr")).is_file());
        assert!(d.join(format!("ref/frame_{k:04}.shaded.exr")).is_file());
        std::fs::remove_file(d.join(format!("ref/frame_{k:04}.pfm"))).unwrap();
    }
    run("pcss", "pcss", &["--reference", "ref"]);
    let csv = std::fs::read_to_string(d.join("pcss/frames.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|c| *c == "flip").expect("a flip column");
    for line in csv.lines().skip(1) {
        let f: f64 = line.split(',').nth(col).unwrap().parse().unwrap();
        assert!((0.0..=1.0).contains(&f) && f > 0.0, "{csv}");
    }
    let summary = std::fs::read_to_string(d.join("pcss/summary.txt")).unwrap();
    assert!(summary.contains("flip_mean "), "{summary}");
}
