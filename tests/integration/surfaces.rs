//! The trace, study, bench and output surfaces hardened like the scene inputs (issue 28): nothing
//! lost (an output never overwrites an input; a run's folder is the old complete run or the new
//! one), nothing injected (no control character reaches a job script), nothing unbounded, nothing
//! silently wrong (collected results checked against the manifest; scenes far from the origin), and
//! errors that name what failed. Each class through the command line, as a user meets it.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

use crate::util::{assert_clean_failure, image_bits, render_with, repo_scene, sism};

fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

/// Runs `sism` with `args` then `extra`.
fn sism_plus(dir: &Path, args: &[&str], extra: &[&str]) -> Output {
    let all: Vec<&str> = args.iter().chain(extra).copied().collect();
    sism(dir, &all)
}

fn ok(out: &Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Every file of `dir` (relative name → bytes), sorted: a folder's whole state.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| {
            (
                PathBuf::from(e.file_name()),
                std::fs::read(e.path()).unwrap_or_default(),
            )
        })
        .collect();
    files.sort();
    files
}

/// A two- or three-frame orbit trace of the repository's plate, written into `dir`.
fn plate_trace(dir: &Path, name: &str, frames: &str) -> String {
    let scene = dir.join("plate.toml");
    if !scene.exists() {
        std::fs::copy(repo("scenes/plate.toml"), &scene).unwrap();
    }
    ok(
        &sism(
            dir,
            &[
                "trace",
                "make",
                "orbit",
                "plate.toml",
                "--frames",
                frames,
                "--out",
                name,
            ],
        ),
        "trace make",
    );
    name.to_string()
}

fn trace_run(dir: &Path, trace: &str, out: &str, extra: &[&str]) -> Output {
    let args = [
        "trace",
        "run",
        trace,
        "--algo",
        "shadow-map",
        "--width",
        "32",
        "--height",
        "24",
        "--out",
        out,
        "--quiet",
    ];
    sism_plus(dir, &args, extra)
}

#[test]
fn a_trace_run_never_overwrites_its_reference_and_its_folder_is_one_whole_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t3 = plate_trace(d, "three.trace", "3");
    let t2 = plate_trace(d, "two.trace", "2");
    ok(&trace_run(d, &t3, "ref", &[]), "the reference run");
    let before = snapshot(&d.join("ref"));
    assert!(before.iter().any(|(n, _)| n == Path::new(".sism-complete")));
    // --out is the reference, or inside it: refused before anything is written.
    let out = trace_run(d, &t3, "ref", &["--reference", "ref"]);
    assert_clean_failure(&out, &["--reference", "never writes over its own inputs"]);
    let out = trace_run(d, &t3, "ref/sub", &["--reference", "ref"]);
    assert_clean_failure(&out, &["inside", "--reference"]);
    assert_eq!(snapshot(&d.join("ref")), before, "the reference changed");
    // A run that fails part-way (the reference has frames 0-1 only, this trace 3) leaves the old run.
    ok(&trace_run(d, &t2, "short", &[]), "a two-frame run");
    ok(&trace_run(d, &t3, "run", &[]), "a first run");
    let first = snapshot(&d.join("run"));
    let out = trace_run(d, &t3, "run", &["--reference", "short"]);
    assert_clean_failure(&out, &["frame 2"]);
    assert_eq!(snapshot(&d.join("run")), first, "a failed run changed the folder");
    let stray: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial-") || n.contains(".old-"))
        .collect();
    assert!(stray.is_empty(), "work folders left behind: {stray:?}");
    // A folder without the marker (another tool's, a partial one) is neither trusted nor replaced.
    std::fs::create_dir(d.join("mine")).unwrap();
    std::fs::write(d.join("mine/frame_0000.pfm"), b"not a run").unwrap();
    assert_clean_failure(
        &trace_run(d, &t3, "other", &["--reference", "mine"]),
        &["--reference", "not a complete trace run"],
    );
    assert_clean_failure(&trace_run(d, &t3, "mine", &[]), &["not a complete trace run"]);
    assert_eq!(
        std::fs::read(d.join("mine/frame_0000.pfm")).unwrap(),
        b"not a run"
    );
}

#[test]
fn trace_make_writes_only_traces_that_run_and_never_over_its_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(repo("scenes/plate.toml"), d.join("plate.toml")).unwrap();
    let scene_before = std::fs::read(d.join("plate.toml")).unwrap();
    let out = sism(
        d,
        &["trace", "make", "orbit", "plate.toml", "--out", "plate.toml"],
    );
    assert_clean_failure(&out, &["plate.toml", "scene file"]);
    assert_eq!(std::fs::read(d.join("plate.toml")).unwrap(), scene_before);
    // An amount that turns the eye into NaN.
    let out = sism(
        d,
        &[
            "trace",
            "make",
            "orbit",
            "plate.toml",
            "--amount",
            "1e38",
            "--out",
            "n.trace",
        ],
    );
    assert_clean_failure(&out, &["--amount", "frame"]);
    assert!(!d.join("n.trace").exists());
    // A scene path a trace line cannot hold; one with spaces it can.
    std::fs::create_dir(d.join("a b")).unwrap();
    std::fs::copy(repo("scenes/plate.toml"), d.join("a b/x#1.toml")).unwrap();
    let out = sism(d, &["trace", "make", "walk", "a b/x#1.toml", "--out", "h.trace"]);
    assert_clean_failure(&out, &["#"]);
    std::fs::copy(repo("scenes/plate.toml"), d.join("a b/p.toml")).unwrap();
    ok(
        &sism(
            d,
            &[
                "trace",
                "make",
                "walk",
                "a b/p.toml",
                "--frames",
                "2",
                "--out",
                "s.trace",
            ],
        ),
        "a scene path with a space",
    );
    ok(&trace_run(d, "s.trace", "s", &[]), "running it");
}

#[test]
fn trace_parsing_is_bounded_and_linear() {
    let scene = repo_scene("plate.toml", 16, 12);
    // Many moves carried over many frames: refused by count, not by memory.
    let mut text = String::from("sism-trace 1\nscene plate.toml\nframe\n");
    for i in 0..50_000 {
        text += &format!("mesh {i} 0 0 0\n");
    }
    text += &"frame\n".repeat(100);
    let e = sism::trace::parse_over(&text, Path::new("big.trace"), &scene).unwrap_err();
    assert!(e.message.contains("mesh moves"), "{e}");
    // Many statements in one frame: parsed in about linear time (quadratic took minutes).
    let mut text = String::from("sism-trace 1\nscene plate.toml\nframe\n");
    for i in 0..200_000 {
        text += &format!("mesh {} 0 {i} 0\n", i % 100_000);
    }
    let t0 = Instant::now();
    let t = sism::trace::parse_over(&text, Path::new("many.trace"), &scene).unwrap();
    assert_eq!(t.frames[0].mesh_moves.len(), 100_000);
    assert!(t0.elapsed() < Duration::from_secs(20), "{:?}", t0.elapsed());
    // The moves name meshes the plate does not have: the check says which.
    let e = sism::trace::check(&t, &scene).unwrap_err();
    assert!(e.contains("mesh 2"), "{e}");
}

fn slurm_study(dir: &Path, scene: &str, out: &str, extra: &[&str]) -> Output {
    let args = [
        "study",
        scene,
        "--backend",
        "slurm",
        "--dry-run",
        "--cores",
        "1,2,4",
        "--chunk",
        "2",
        "--width",
        "24",
        "--height",
        "16",
        "--out",
        out,
        "--quiet",
    ];
    sism_plus(dir, &args, extra)
}

#[test]
fn studies_refuse_injection_overlap_and_results_that_are_not_the_manifests() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A newline in the scene's name would put a shell command into every array task.
    let evil = "a\ntouch INJECTED\n.toml";
    std::fs::copy(repo("scenes/plate.toml"), d.join(evil)).unwrap();
    std::fs::create_dir(d.join("evil")).unwrap();
    assert_clean_failure(&slurm_study(d, evil, "evil", &[]), &["control character"]);
    assert!(!d.join("evil/study.sbatch").exists());
    // A study with results; re-created with a bad option, it keeps them.
    std::fs::create_dir(d.join("st")).unwrap();
    let plate = repo("scenes/plate.toml");
    ok(&slurm_study(d, &plate, "st", &[]), "the study");
    ok(
        &sism(d, &["study", "run", "st", "--task", "0", "--quiet"]),
        "task 0",
    );
    ok(
        &sism(d, &["study", "run", "st", "--task", "1", "--quiet"]),
        "task 1",
    );
    let results = snapshot(&d.join("st/results"));
    let out = slurm_study(d, &plate, "st", &["--chunk", "18446744073709551615"]);
    assert_clean_failure(&out, &["--chunk"]);
    assert_eq!(
        snapshot(&d.join("st/results")),
        results,
        "a refused re-creation removed results"
    );
    // A local study pointed at it would replace the records its tasks replay.
    let records = std::fs::read(d.join("st/records.bin")).unwrap();
    let out = sism(
        d,
        &[
            "study", &plate, "--cores", "1", "--width", "24", "--height", "16", "--out", "st", "--quiet",
        ],
    );
    assert_clean_failure(&out, &["Slurm study"]);
    assert_eq!(std::fs::read(d.join("st/records.bin")).unwrap(), records);
    // A result whose point is another configuration (or has no steps) is refused, not merged.
    let path = d.join("st/results/task-1.json");
    let good = std::fs::read_to_string(&path).unwrap();
    for (field, value) in [("cores", serde_json::json!(7)), ("steps", serde_json::json!([]))] {
        let mut v: serde_json::Value = serde_json::from_str(&good).unwrap();
        v["points"][0][field] = value;
        std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
        let out = sism(d, &["study", "collect", "st", "--quiet"]);
        assert_clean_failure(&out, &["task 1", "1 of 3 points missing"]);
        assert!(!d.join("st/study.csv").exists());
    }
    std::fs::write(&path, &good).unwrap();
    ok(&sism(d, &["study", "collect", "st", "--quiet"]), "collect");
    // A records file of another size is refused before it is read.
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(d.join("st/records.bin"))
        .unwrap();
    f.set_len(8 << 30).unwrap();
    assert_clean_failure(
        &sism(d, &["study", "run", "st", "--task", "0", "--quiet"]),
        &["records.bin was replaced", "8589934592 bytes"],
    );
}

/// Runs `args`, killed after `limit`: the output, or None if it hung.
fn run_with_deadline(dir: &Path, args: &[&str], limit: Duration) -> Option<Output> {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_sism"))
        .args(args)
        .current_dir(dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while start.elapsed() < limit {
        if child.try_wait().unwrap().is_some() {
            return Some(child.wait_with_output().unwrap());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

#[cfg(unix)]
#[test]
fn collect_never_hangs_on_special_files_or_a_missing_squeue() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("st")).unwrap();
    ok(
        &slurm_study(d, &repo("scenes/plate.toml"), "st", &[]),
        "the study",
    );
    ok(
        &sism(d, &["study", "run", "st", "--task", "0", "--quiet"]),
        "task 0",
    );
    let mkfifo = |p: PathBuf| {
        std::process::Command::new("mkfifo")
            .arg(p)
            .status()
            .is_ok_and(|s| s.success())
    };
    if !mkfifo(d.join("st/logs/task-1.out")) {
        eprintln!("skipping: mkfifo unavailable");
        return;
    }
    let limit = Duration::from_secs(60);
    // Task 1 is missing and its log is a FIFO: reported by kind, not read.
    let out = run_with_deadline(d, &["study", "collect", "st"], limit).expect("collect hung on a FIFO log");
    assert_clean_failure(&out, &["is a FIFO, not a regular file"]);
    std::fs::remove_file(d.join("st/logs/task-1.out")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("st/logs/task-1.out")).unwrap();
    let out = run_with_deadline(d, &["study", "collect", "st"], limit).expect("collect hung on /dev/zero");
    assert_clean_failure(&out, &["is a device"]);
    // The job list a FIFO: an error naming it.
    assert!(mkfifo(d.join("st/jobs.txt")));
    let out =
        run_with_deadline(d, &["study", "collect", "st"], limit).expect("collect hung on a FIFO job list");
    assert_clean_failure(&out, &["jobs.txt", "FIFO"]);
    std::fs::remove_file(d.join("st/jobs.txt")).unwrap();
    // --watch with jobs on record but no squeue: says so and stops.
    std::fs::write(d.join("st/jobs.txt"), "4242 array=1 submitted=1\n").unwrap();
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_sism"));
    cmd.args(["study", "collect", "st", "--watch", "--interval", "0.05"])
        .current_dir(d)
        .env("PATH", d.join("no-such-bin"));
    let out = cmd.output().unwrap();
    assert_clean_failure(&out, &["cannot ask Slurm", "--timeout"]);
    // A result that is a link loop is not "missing".
    std::os::unix::fs::symlink("loop-b", d.join("st/results/task-1.json")).unwrap();
    std::os::unix::fs::symlink("task-1.json", d.join("st/results/loop-b")).unwrap();
    let out = sism(d, &["study", "collect", "st"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("symbolic links") && !stderr.contains("missing: no"),
        "{stderr}"
    );
}

#[test]
fn counts_that_size_allocations_are_bounded_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plate = repo("scenes/plate.toml");
    let many: String = (1..=200).map(|i| i.to_string()).collect::<Vec<_>>().join(",");
    let out = sism(
        d,
        &[
            "study",
            &plate,
            "--cores",
            &many,
            "--threads",
            &many,
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            "s",
        ],
    );
    assert_clean_failure(&out, &["200 × 200", "at most"]);
    let out = sism(
        d,
        &[
            "bench",
            &plate,
            "--repeats",
            "4000000000",
            "--width",
            "8",
            "--height",
            "8",
        ],
    );
    assert_clean_failure(&out, &["--repeats"]);
    for bad in ["NaN", "inf", "-1"] {
        let out = sism(
            d,
            &[
                "bench",
                &plate,
                &format!("--sim-budget-ms={bad}"),
                "--width",
                "8",
                "--height",
                "8",
            ],
        );
        assert_clean_failure(&out, &["--sim-budget-ms"]);
    }
}

#[cfg(unix)]
#[test]
fn outputs_replace_only_regular_files_and_failures_name_what_failed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plate = repo("scenes/plate.toml");
    ok(
        &sism(
            d,
            &[
                "render",
                &plate,
                "--algo",
                "shadow-map",
                "--width",
                "16",
                "--height",
                "12",
                "--out",
                "r",
                "--quiet",
            ],
        ),
        "render",
    );
    // A heat map "written" to a device would replace the device node (as root): refused.
    let out = sism(
        d,
        &[
            "compare",
            "r/visibility.pfm",
            "r/visibility.pfm",
            "--heatmap",
            "/dev/null",
        ],
    );
    assert_clean_failure(&out, &["/dev/null", "not a regular file"]);
    assert!(Path::new("/dev/null").exists());
    // A compare whose heat map is its own input.
    let out = sism(
        d,
        &[
            "compare",
            "r/visibility.pfm",
            "r/visibility.pfm",
            "--heatmap",
            "r/visibility.pfm",
        ],
    );
    assert_clean_failure(&out, &["visibility.pfm", "never writes over its own inputs"]);
    // stdout that cannot be written is named as stdout.
    if let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_sism"))
            .args(["compare", "r/visibility.pfm", "r/visibility.pfm"])
            .current_dir(d)
            .stdout(full)
            .output()
            .unwrap();
        assert_clean_failure(&out, &["stdout"]);
    }
}

/// A scene moved far from the origin: every coordinate + `offset`, rendered as the original.
fn translated_plate(offset: f64) -> sism::scene::Scene {
    let text = std::fs::read_to_string(repo("scenes/plate.toml")).unwrap();
    let mut value: toml::Table = toml::from_str(&text).unwrap();
    let shift = |v: &mut toml::Value| {
        for x in v.as_array_mut().unwrap() {
            *x = toml::Value::Float(x.as_float().unwrap() + offset);
        }
    };
    for q in value["quad"].as_array_mut().unwrap() {
        shift(q.get_mut("corner").unwrap());
    }
    shift(value["camera"].get_mut("eye").unwrap());
    shift(value["camera"].get_mut("look_at").unwrap());
    shift(value["light"].get_mut("center").unwrap());
    value["camera"]["width"] = toml::Value::Integer(48);
    value["camera"]["height"] = toml::Value::Integer(36);
    sism::scene::Scene::from_toml(&toml::to_string(&value).unwrap(), Path::new("far.toml")).unwrap()
}

/// Scenes far from the origin render as they do at it: the scene is rebased (its look-at point
/// becomes the origin, in f64) before its coordinates become f32. Tolerance: MAE ≤ 1e-3 and at
/// most 0.5% of pixels changing class (receiver, missed, facing away), from 1e3 to 1e7 units.
#[test]
fn scenes_far_from_the_origin_match_the_scene_at_it() {
    let near = repo_scene("plate.toml", 48, 36);
    let at = |s: &sism::scene::Scene, algo: &str| {
        let given: &[(&str, &str)] = if algo == "reference" {
            &[("spp", "64")]
        } else {
            &[]
        };
        render_with(s, algo, given, sism::exec::Exec::Native).visibility
    };
    for algo in ["reference", "sism", "shadow-map", "pcss"] {
        let want = at(&near, algo);
        for offset in [1e3, 1e5, 3e5, 1e7] {
            let far = translated_plate(offset);
            let got = at(&far, algo);
            let class = |v: f32| {
                if v.is_nan() {
                    0
                } else if v < 0.0 {
                    1
                } else {
                    2
                }
            };
            let changed = want
                .values
                .iter()
                .zip(&got.values)
                .filter(|(a, b)| class(**a) != class(**b))
                .count();
            assert!(
                changed * 200 <= want.values.len(),
                "{algo} at {offset:e}: {changed} pixels change class"
            );
            let e = sism::metrics::compare(&want, &got).unwrap();
            assert!(e.mae <= 1e-3, "{algo} at {offset:e}: MAE {}", e.mae);
        }
    }
    // At the origin nothing moves: the shipped scenes keep their exact images.
    assert_eq!(near.origin, [0.0; 3]);
    let again = repo_scene("plate.toml", 48, 36);
    assert_eq!(image_bits(&at(&near, "sism")), image_bits(&at(&again, "sism")));
}
