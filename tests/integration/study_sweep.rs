//! `sism study --set KEY=V1,V2` (any machine parameter swept, the cross product or one at a time)
//! and `sism sensitivity` (each parameter halved and doubled, ranked, the verdict), end to end on
//! a small scene.

use std::path::Path;
use std::process::Output;

use crate::util::{assert_clean_failure, sism};

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/sphere.toml")
        .display()
        .to_string()
}

fn ok(out: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{what} failed:\n{stderr}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn study(dir: &Path, out: &str, extra: &[&str]) -> Output {
    let scene = scene();
    let mut args = vec![
        "study",
        &scene,
        "--width",
        "64",
        "--height",
        "48",
        "--machine",
        "larrabee-24",
        "--out",
        out,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    sism(dir, &args)
}

/// `study.csv`'s frame rows: (header, rows as column → value maps).
fn frame_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .filter(|r: &std::collections::BTreeMap<String, String>| r["phase"] == "frame")
        .collect()
}

#[test]
fn set_sweeps_any_machine_parameter_in_every_combination() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    ok(
        &study(
            dir,
            "set",
            &[
                "--cores",
                "1,8",
                "--set",
                "dram_bandwidth_gbs=0.01,128",
                "--set",
                "atomic_cycles=8,800",
            ],
        ),
        "study --set",
    );
    let rows = frame_rows(&dir.join("set/study.csv"));
    assert_eq!(rows.len(), 2 * 2 * 2, "cores × bandwidth × atomics");
    let header = std::fs::read_to_string(dir.join("set/study.csv")).unwrap();
    assert!(
        header.starts_with("cores,threads,l2_kb,dram_bandwidth_gbs,atomic_cycles,phase,"),
        "{}",
        header.lines().next().unwrap()
    );
    let cycles = |cores: &str, bw: &str, at: &str| -> u64 {
        let r = rows
            .iter()
            .find(|r| r["cores"] == cores && r["dram_bandwidth_gbs"] == bw && r["atomic_cycles"] == at)
            .unwrap_or_else(|| panic!("no point cores {cores} bw {bw} atomics {at}: {rows:?}"));
        r["cycles"].parse().unwrap()
    };
    // Each swept value reaches the model: less bandwidth and dearer atomics never make the frame
    // faster, and at 0.01 GB/s against 128 the frame is slower (its DRAM traffic is bound).
    for cores in ["1", "8"] {
        for at in ["8", "800"] {
            assert!(
                cycles(cores, "0.01", at) > cycles(cores, "128.0", at),
                "bandwidth, {cores} cores"
            );
        }
        for bw in ["0.01", "128.0"] {
            assert!(
                cycles(cores, bw, "800") >= cycles(cores, bw, "8"),
                "atomics, {cores} cores"
            );
        }
    }
    // Speedup is over 1 core at the same other values.
    let speedup_1 = rows
        .iter()
        .filter(|r| r["cores"] == "1")
        .all(|r| r["frame_speedup"].parse::<f64>().unwrap() == 1.0);
    assert!(speedup_1);
}

#[test]
fn one_at_a_time_varies_each_axis_alone_around_the_base() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    ok(
        &study(
            dir,
            "oat",
            &["--one-at-a-time", "--cores", "8", "--set", "l2_latency=5,40"],
        ),
        "study --one-at-a-time",
    );
    let rows = frame_rows(&dir.join("oat/study.csv"));
    let points: Vec<(String, String)> = rows
        .iter()
        .map(|r| (r["cores"].clone(), r["l2_latency"].clone()))
        .collect();
    assert_eq!(
        points,
        [("24", "10"), ("8", "10"), ("24", "5"), ("24", "40")].map(|(a, b)| (a.to_string(), b.to_string())),
        "the base, then each value alone"
    );
}

#[test]
fn bad_set_arguments_are_refused_with_the_valid_names() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["--set", "l2_size=1"],
            &[
                "unknown machine parameter `l2_size`",
                "l2_kb",
                "dram_bandwidth_gbs",
            ],
        ),
        (
            &["--set", "dram_bandwidth_gbs=fast"],
            &["`dram_bandwidth_gbs` = `fast`", "not a number"],
        ),
        (
            &["--set", "atomic_cycles=0"],
            &["`atomic_cycles` = `0`", "out of range 1..=10000"],
        ),
        (&["--set", "cores=4"], &["use --cores"]),
        (&["--set", "simd_width=8"], &["fixed"]),
        (
            &["--set", "ring_hop_latency=1", "--set", "ring_hop_latency=2"],
            &["given twice"],
        ),
    ];
    for (extra, needles) in cases {
        let out = study(dir, "bad", extra);
        assert_clean_failure(&out, needles);
    }
    assert!(
        !dir.join("bad/study.csv").exists(),
        "nothing written for a refused sweep"
    );
}

#[test]
fn sensitivity_ranks_the_parameters_and_names_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene();
    let out = sism(
        dir,
        &[
            "sensitivity",
            &scene,
            "--width",
            "64",
            "--height",
            "48",
            "--machine",
            "larrabee-24",
            "--out",
            "sens",
        ],
    );
    let stdout = ok(&out, "sensitivity");
    assert!(stdout.contains("This frame is limited by `"), "{stdout}");
    let md = std::fs::read_to_string(dir.join("sens/sensitivity.md")).unwrap();
    assert!(
        md.contains("| parameter | base | ÷2 | frame | ×2 | frame |"),
        "{md}"
    );
    assert!(md.contains("This frame is limited by `"), "{md}");
    let png = std::fs::read(dir.join("sens/sensitivity.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "a PNG");
    let csv = std::fs::read_to_string(dir.join("sens/sensitivity.csv")).unwrap();
    let frame = |param: &str, dir_: &str| -> f64 {
        csv.lines()
            .find(|l| l.starts_with(&format!("{param},{dir_},")) && l.contains(",frame,"))
            .unwrap_or_else(|| panic!("{param} {dir_}: {csv}"))
            .split(',')
            .nth(4)
            .unwrap()
            .parse()
            .unwrap()
    };
    let base = frame("base", "base");
    // The model's direction of every lever that must help or hurt.
    // (A 64×48 frame is too small for cores to matter: its barriers and serial steps dominate.
    // Fewer threads per core hide less latency.)
    assert!(frame("threads_per_core", "divided") > base, "fewer threads hurt");
    assert!(
        frame("scalar_cycles", "multiplied") > base,
        "slower scalar issue hurts"
    );
    assert!(
        frame("dram_latency_ns", "multiplied") >= base,
        "slower DRAM never helps"
    );
    assert!(frame("clock_ghz", "multiplied") < base, "a faster clock helps");
    // Ranked: the table's swings do not increase down the table.
    let swings: Vec<f64> = md
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            l.split('|')
                .nth(7)
                .unwrap()
                .trim()
                .trim_end_matches('%')
                .parse()
                .unwrap()
        })
        .collect();
    assert!(swings.len() > 10, "{md}");
    assert!(swings.windows(2).all(|w| w[0] >= w[1]), "{swings:?}");
    // Parameters that do not apply to Larrabee (no shared cache, no prefetcher) are not listed.
    assert!(
        !md.contains("`l3_latency`") && !md.contains("`stream_l2_cycles`"),
        "{md}"
    );
    let bad = sism(dir, &["sensitivity", &scene, "--factor", "1", "--out", "bad"]);
    assert_clean_failure(&bad, &["--factor 1", "(1, 1000]"]);
}

#[test]
fn render_on_a_machine_writes_the_roofline() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene();
    let out = sism(
        dir,
        &[
            "render",
            &scene,
            "--algo",
            "sism",
            "--width",
            "64",
            "--height",
            "48",
            "--machine",
            "larrabee-24",
            "--roofline",
            "--out",
            "r",
            "--quiet",
        ],
    );
    ok(&out, "render --machine --roofline");
    let md = std::fs::read_to_string(dir.join("r/roofline.md")).unwrap();
    assert!(
        md.starts_with("Ceilings of larrabee-24 (per cycle, whole chip): 384.0 vector lane operations"),
        "{md}"
    );
    let frame = md
        .lines()
        .find(|l| l.starts_with("| **frame** |"))
        .unwrap_or_else(|| panic!("{md}"));
    let cells: Vec<&str> = frame.split('|').map(str::trim).collect();
    let ops: f64 = cells[3].parse().unwrap();
    assert!(
        ops > 0.0 && ops <= 384.0,
        "achieved lane ops per cycle within the peak: {frame}"
    );
    assert!(
        ["vector issue", "L2 bandwidth", "DRAM bandwidth"].contains(&cells[8]),
        "a named roof: {frame}"
    );
    assert!(std::fs::read(dir.join("r/roofline.png"))
        .unwrap()
        .starts_with(b"\x89PNG"));
    // Without --machine there is no roofline to draw.
    let bad = sism(dir, &["render", &scene, "--roofline", "--out", "r2"]);
    assert!(!bad.status.success(), "--roofline needs --machine");
}
