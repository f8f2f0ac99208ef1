//! `sism study --backend slurm`: the study directory, its job array on a real Slurm, `study run`,
//! `study collect` (missing, foreign and corrupt results, resubmission) and the errors of bad study
//! directories. The tests that submit need a Slurm that answers (`.ci/slurm-up.sh` starts a single-node one):
//! without it they fail under `CI=true` and report themselves skipped elsewhere.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::util::{assert_clean_failure, sism};

/// The small scene every study here sweeps (inline geometry, 64×48: a frame counts in milliseconds).
fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/sphere.toml")
        .display()
        .to_string()
}

/// `study SCENE` over 6 points (cores 1,2,4 × threads 1,2) into `out`, with `extra` options.
fn study(dir: &Path, out: &str, cores: &str, extra: &[&str]) -> Output {
    let scene = scene();
    let mut args = vec![
        "study",
        &scene,
        "--width",
        "64",
        "--height",
        "48",
        "--cores",
        cores,
        "--threads",
        "1,2",
        "--machine",
        "larrabee-24",
        "--out",
        out,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    sism(dir, &args)
}

fn ok(out: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{what} failed:\n{stderr}");
    stderr
}

fn read(path: PathBuf) -> Vec<u8> {
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Whether a Slurm controller answers here (`sinfo` succeeds: a client is installed and its
/// controller is up). Without one: under `CI=true` a failure, else a skip (false).
fn slurm_available() -> bool {
    let found = std::process::Command::new("sinfo")
        .arg("--noheader")
        .output()
        .is_ok_and(|o| o.status.success());
    if found {
        return true;
    }
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("CI=true but no Slurm answers (sinfo failed): .ci/slurm-up.sh should have started one");
    }
    eprintln!("skipped: no Slurm controller answers (sinfo failed; `bash .ci/slurm-up.sh` starts one)");
    false
}

/// The local backend's outputs of the 6-point sweep, in `dir/local`.
fn local_study(dir: &Path) -> PathBuf {
    ok(&study(dir, "local", "1,2,4", &[]), "local study");
    dir.join("local")
}

/// (a) A 12-point sweep (cores × threads × an `--set` parameter) submitted to Slurm and collected
/// with --watch writes the local backend's study.csv, byte for byte (and the same plots, roofline
/// and report).
#[test]
fn slurm_array_gives_the_local_study() {
    if !slurm_available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    // Any machine parameter swept (`--set`) goes through the array too: 12 points.
    let set = ["--set", "atomic_cycles=8,16"];
    ok(&study(dir, "local", "1,2,4", &set), "local study");
    let local = dir.join("local");
    ok(
        &study(
            dir,
            "slurm",
            "1,2,4",
            &["--backend", "slurm", "--chunk", "2", set[0], set[1]],
        ),
        "slurm study",
    );
    let s = dir.join("slurm");
    let jobs = String::from_utf8(read(s.join("jobs.txt"))).unwrap();
    assert_eq!(jobs.lines().count(), 1, "one job submitted: {jobs}");
    assert!(jobs.contains("array=0-5"), "{jobs}");
    let manifest = String::from_utf8(read(s.join("manifest.toml"))).unwrap();
    assert!(manifest.contains("key = \"atomic_cycles\""), "{manifest}");
    let out = sism(
        dir,
        &[
            "study",
            "collect",
            "slurm",
            "--watch",
            "--interval",
            "0.2",
            "--timeout",
            "60",
            "--quiet",
        ],
    );
    ok(&out, "collect --watch");
    assert_eq!(
        String::from_utf8(read(s.join("study.csv"))).unwrap(),
        String::from_utf8(read(local.join("study.csv"))).unwrap(),
        "study.csv: slurm == local"
    );
    // The roofline of the base point and the report come from the collected points as from the
    // local ones.
    for f in [
        "speedup.png",
        "phases.png",
        "roofline.md",
        "roofline.png",
        "report.html",
    ] {
        assert!(read(s.join(f)) == read(local.join(f)), "{f}: slurm == local");
    }
    let csv = String::from_utf8(read(s.join("study.csv"))).unwrap();
    assert!(
        csv.starts_with("cores,threads,l2_kb,atomic_cycles,phase,"),
        "{csv}"
    );
    for k in 0..6 {
        let log = String::from_utf8(read(s.join(format!("logs/task-{k}.out")))).unwrap();
        assert!(
            log.contains(&format!("task {k}: points")),
            "task {k}'s log: {log}"
        );
    }
}

/// (a') `sensitivity --backend slurm`: the analysis's replays as a job array; `study collect` writes
/// the local analysis's sensitivity.csv and sensitivity.md byte for byte, its chart and its report.
#[test]
fn slurm_array_gives_the_local_sensitivity() {
    if !slurm_available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene();
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "sensitivity",
            &scene,
            "--width",
            "64",
            "--height",
            "48",
            "--machine",
            "larrabee-16",
            "--out",
            out,
            "--quiet",
        ];
        args.extend_from_slice(extra);
        sism(dir, &args)
    };
    ok(&run("local", &[]), "local sensitivity");
    ok(
        &run("slurm", &["--backend", "slurm", "--chunk", "16"]),
        "slurm sensitivity",
    );
    let s = dir.join("slurm");
    let manifest = String::from_utf8(read(s.join("manifest.toml"))).unwrap();
    assert!(manifest.contains("sensitivity_factor = 2.0"), "{manifest}");
    let out = sism(
        dir,
        &[
            "study",
            "collect",
            "slurm",
            "--watch",
            "--interval",
            "0.2",
            "--timeout",
            "120",
        ],
    );
    ok(&out, "collect --watch");
    let printed = String::from_utf8_lossy(&out.stdout);
    assert!(
        printed.contains("This frame is limited by"),
        "collect prints the verdict: {printed}"
    );
    let local = dir.join("local");
    for f in [
        "sensitivity.csv",
        "sensitivity.md",
        "sensitivity.png",
        "report.html",
    ] {
        assert!(read(s.join(f)) == read(local.join(f)), "{f}: slurm == local");
    }
    // A sensitivity directory is not a study: no study.csv.
    assert!(!s.join("study.csv").exists());
    // Options of the Slurm backend are refused with the local one.
    let bad = run("bad", &["--chunk", "2"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--backend slurm"));
}

/// (b) A task killed half way (tasks 1 and 4 never finished; task 1 left a partial temporary file)
/// is reported missing with its log; the resubmission runs only those, then collect succeeds with
/// the local study.csv.
#[test]
fn killed_tasks_are_reported_and_rerun_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let local = local_study(dir);
    ok(
        &study(
            dir,
            "s",
            "1,2,4",
            &["--backend", "slurm", "--chunk", "1", "--dry-run"],
        ),
        "dry-run study",
    );
    let s = dir.join("s");
    for k in [0, 2, 3, 5] {
        ok(
            &sism(dir, &["study", "run", "s", "--task", &k.to_string(), "--quiet"]),
            "study run",
        );
    }
    // Task 1 was killed while writing its result: a partial temporary file and its log remain.
    std::fs::write(s.join("results/.task-1.json.tmp-4242"), "{\"format\":\"sism-stu").unwrap();
    std::fs::write(
        s.join("logs/task-1.out"),
        "replaying...\nslurmstepd: error: *** JOB 7 CANCELLED ***\n",
    )
    .unwrap();
    let out = sism(dir, &["study", "collect", "s", "--quiet"]);
    assert_clean_failure(
        &out,
        &[
            "2 of 6 points missing, in tasks 1,4",
            "task 1 (point 1): missing",
            "logs/task-1.out ends:",
            "| slurmstepd: error: *** JOB 7 CANCELLED ***",
            "task 4 (point 4): missing",
            "no log",
            "--task K",
        ],
    );
    assert!(!s.join("study.csv").exists(), "no study.csv from a partial study");
    let dry = sism(dir, &["study", "collect", "s", "--resubmit", "--dry-run"]);
    let dry_out = String::from_utf8_lossy(&dry.stdout);
    ok(&dry, "collect --resubmit --dry-run");
    assert!(dry_out.contains("--array=1,4"), "{dry_out}");
    // Modification times of the finished tasks' results.
    let finished_mtimes = || -> Vec<_> {
        [0, 2, 3, 5]
            .iter()
            .map(|k| {
                std::fs::metadata(s.join(format!("results/task-{k}.json")))
                    .unwrap()
                    .modified()
                    .unwrap()
            })
            .collect()
    };
    let kept = finished_mtimes();
    if slurm_available() {
        let out = sism(
            dir,
            &[
                "study",
                "collect",
                "s",
                "--resubmit",
                "--watch",
                "--interval",
                "0.2",
                "--timeout",
                "60",
                "--quiet",
            ],
        );
        ok(&out, "collect --resubmit --watch");
        let jobs = String::from_utf8(read(s.join("jobs.txt"))).unwrap();
        assert!(jobs.contains("array=1,4"), "{jobs}");
        // Only the resubmitted tasks ran under Slurm.
        for k in [0, 2, 3, 5] {
            assert!(
                !s.join(format!("logs/task-{k}.out")).exists(),
                "task {k} not rerun"
            );
        }
        let log4 = String::from_utf8(read(s.join("logs/task-4.out"))).unwrap();
        assert!(log4.contains("task 4: point 4"), "{log4}");
    } else {
        // By hand: the tasks the error named.
        for k in [1, 4] {
            ok(
                &sism(dir, &["study", "run", "s", "--task", &k.to_string(), "--quiet"]),
                "study run",
            );
        }
        ok(&sism(dir, &["study", "collect", "s", "--quiet"]), "collect");
    }
    let again = finished_mtimes();
    assert_eq!(kept, again, "finished tasks' results are not rewritten");
    assert_eq!(
        String::from_utf8(read(s.join("study.csv"))).unwrap(),
        String::from_utf8(read(local.join("study.csv"))).unwrap(),
        "study.csv after the rerun == local"
    );
}

/// (c) Bad study directories: absent, corrupt, edited or other-format manifests, task indices out
/// of range, corrupt records, edited machine files, foreign and corrupt results. Each a clear error
/// naming the file, exit code 1, no panic.
#[test]
fn bad_study_directories_give_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    ok(
        &study(dir, "a", "1,2,4", &["--backend", "slurm", "--dry-run"]),
        "study a",
    );
    let a = dir.join("a");
    let manifest = std::fs::read_to_string(a.join("manifest.toml")).unwrap();
    let run = |d: &str, task: &str| sism(dir, &["study", "run", d, "--task", task, "--quiet"]);

    // Absent.
    std::fs::create_dir(dir.join("empty")).unwrap();
    assert_clean_failure(&run("empty", "0"), &["manifest.toml", "not a study directory"]);
    assert_clean_failure(
        &sism(dir, &["study", "collect", "empty"]),
        &["manifest.toml", "not a study directory"],
    );
    // Corrupt (not TOML), edited (checksum), another format version.
    let cases = [
        (
            "corrupt",
            manifest.replacen("[[point]]", "[[point]\n", 1),
            vec!["manifest.toml", "not valid TOML"],
        ),
        (
            "edited",
            manifest.replacen("cores = 4", "cores = 8", 1),
            vec!["manifest.toml", "checksum mismatch", "edited or is corrupt"],
        ),
        (
            "format",
            manifest.replace("format = \"sism-study 1\"", "format = \"sism-study 2\""),
            vec!["manifest.toml", "\"sism-study 2\"", "not the one this sism reads"],
        ),
        (
            "noformat",
            manifest.replace("format = \"sism-study 1\"", ""),
            vec!["manifest.toml", "no `format`"],
        ),
    ];
    for (name, text, needles) in cases {
        assert_ne!(text, manifest, "test setup: {name} changes the manifest");
        let d = dir.join(name);
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("manifest.toml"), text).unwrap();
        assert_clean_failure(&run(name, "0"), &needles);
        assert_clean_failure(&sism(dir, &["study", "collect", name]), &needles);
    }
    // A task out of range.
    assert_clean_failure(&run("a", "2"), &["--task 2", "out of range", "2 tasks (0-1)"]);
    // An edited machine file, then corrupt records.
    let m0 = a.join("machines/point-0000.toml");
    let machine = std::fs::read_to_string(&m0).unwrap();
    std::fs::write(&m0, machine.replacen("cores = 1", "cores = 3", 1)).unwrap();
    assert_clean_failure(
        &run("a", "0"),
        &["point-0000.toml", "checksum", "edited or replaced"],
    );
    std::fs::write(&m0, &machine).unwrap();
    let records = read(a.join("records.bin"));
    let mut bad = records.clone();
    let mid = bad.len() / 2;
    bad[mid] ^= 0x5a;
    std::fs::write(a.join("records.bin"), &bad).unwrap();
    assert_clean_failure(&run("a", "0"), &["records file", "records.bin"]);
    std::fs::write(a.join("records.bin"), &records[..records.len() / 3]).unwrap();
    assert_clean_failure(&run("a", "0"), &["records.bin", "bytes, but the manifest's are"]);
    std::fs::write(a.join("records.bin"), &records).unwrap();
    ok(&run("a", "0"), "task 0 after the repairs");

    // A foreign result: task 1 of another study (different cores) copied in.
    ok(
        &study(dir, "b", "1,2,8", &["--backend", "slurm", "--dry-run"]),
        "study b",
    );
    ok(&run("b", "1"), "study b's task 1");
    std::fs::copy(dir.join("b/results/task-1.json"), a.join("results/task-1.json")).unwrap();
    assert_clean_failure(
        &sism(dir, &["study", "collect", "a"]),
        &[
            "task 1 (points 4-5): foreign result rejected",
            "results/task-1.json was written for another study",
            "in tasks 1",
        ],
    );
    // A corrupt result.
    std::fs::write(
        a.join("results/task-1.json"),
        "{\"format\": \"sism-study-result 1\",",
    )
    .unwrap();
    assert_clean_failure(
        &sism(dir, &["study", "collect", "a"]),
        &["task 1 (points 4-5): failed", "task-1.json", "not valid JSON"],
    );
    // Repaired, the study collects.
    ok(&run("a", "1"), "task 1");
    ok(&sism(dir, &["study", "collect", "a", "--quiet"]), "collect a");
    assert!(a.join("study.csv").is_file());
}

/// (d) --dry-run writes the job array (the right --array range, the partition, time limit and extra
/// #SBATCH lines, logs per task, the command) and submits nothing; Slurm options need the Slurm
/// backend.
#[test]
fn dry_run_writes_the_array_script() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let out = study(
        dir,
        "s",
        "1,2,4",
        &[
            "--backend",
            "slurm",
            "--dry-run",
            "--chunk",
            "4",
            "--partition",
            "debug",
            "--time",
            "00:05:00",
            "--sbatch-arg",
            "--mem=100M",
            "--sbatch-arg",
            "#SBATCH --comment=sism-test",
        ],
    );
    ok(&out, "dry-run study");
    let s = std::fs::canonicalize(dir.join("s")).unwrap();
    let script = String::from_utf8(read(s.join("study.sbatch"))).unwrap();
    let exe = std::fs::canonicalize(env!("CARGO_BIN_EXE_sism")).unwrap();
    for line in [
        "#!/bin/sh".to_string(),
        "#SBATCH --array=0-1".to_string(),
        format!("#SBATCH --output={}/logs/task-%a.out", s.display()),
        "#SBATCH --partition=debug".to_string(),
        "#SBATCH --time=00:05:00".to_string(),
        "#SBATCH --mem=100M".to_string(),
        "#SBATCH --comment=sism-test".to_string(),
        format!(
            "exec {} study run {} --task \"$SLURM_ARRAY_TASK_ID\"",
            exe.display(),
            s.display()
        ),
    ] {
        assert!(
            script.lines().any(|l| l == line),
            "study.sbatch lacks `{line}`:\n{script}"
        );
    }
    assert!(!s.join("jobs.txt").exists(), "a dry run submits nothing");
    let manifest = std::fs::read_to_string(s.join("manifest.toml")).unwrap();
    for l in ["format = \"sism-study 1\"", "chunk = 4", "tasks = 2"] {
        assert!(
            manifest.lines().any(|m| m == l),
            "manifest lacks `{l}`:\n{manifest}"
        );
    }
    assert_eq!(manifest.matches("[[point]]").count(), 6);
    for i in 0..6 {
        assert!(
            s.join(format!("machines/point-{i:04}.toml")).is_file(),
            "point {i}'s machine"
        );
    }
    for f in ["records.bin", "machine.toml"] {
        assert!(s.join(f).is_file(), "{f}");
    }
    // One point per task: six tasks; the submit command of a dry run.
    ok(
        &study(
            dir,
            "one",
            "1,2,4",
            &["--backend", "slurm", "--dry-run", "--chunk", "1"],
        ),
        "chunk 1",
    );
    let script = String::from_utf8(read(dir.join("one/study.sbatch"))).unwrap();
    assert!(script.lines().any(|l| l == "#SBATCH --array=0-5"), "{script}");
    let dry = sism(dir, &["study", "submit", "one", "--dry-run"]);
    ok(&dry, "submit --dry-run");
    assert!(String::from_utf8_lossy(&dry.stdout).contains("sbatch --parsable"));
    // Slurm options without the Slurm backend, and bad ones.
    assert_clean_failure(
        &study(dir, "l", "1,2,4", &["--chunk", "2", "--dry-run"]),
        &["--chunk, --dry-run apply to --backend slurm only"],
    );
    assert_clean_failure(
        &study(dir, "c", "1,2,4", &["--backend", "slurm", "--chunk", "0"]),
        &["--chunk 0: points per array task, 1 to"],
    );
    assert_clean_failure(
        &study(dir, "t", "1,2,4", &["--backend", "slurm", "--time", "soon"]),
        &["--time 'soon'"],
    );
}
