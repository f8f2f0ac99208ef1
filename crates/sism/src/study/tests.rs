//! The study directory's state machine driven by a fake scheduler: tasks that succeed, fail, time
//! out or vanish, resubmission of exactly the missing ones, foreign results, the scheduler's array
//! limit, and `study.csv` bytes equal to the local backend's.

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Duration;

use super::scheduler::Scheduler;
use super::slurm::{self, CollectOptions, Collected, JobOptions, Note, Study, Submitted};
use super::{run_local, write_outputs, Label};
use crate::exec::Exec;
use crate::machine::sweep::{self, SweepAxes};
use crate::machine::{self, CanonicalRecords, MachineConfig};
use crate::render::{self, RenderOptions};
use crate::scene::Scene;

/// What a task does when the fake scheduler runs it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Behaviour {
    /// Runs for `polls` polls, then writes its result.
    Succeed { polls: u32 },
    /// Runs for `polls` polls, then exits without a result (a crash), leaving a log.
    Fail { polls: u32 },
    /// Runs for ever (until its time limit: never within the test).
    Hang,
    /// Disappears from the queue at once: no result, no log (a node lost).
    Vanish,
}

/// A scheduler of job arrays whose tasks behave as told, advanced one step per `active_tasks` poll.
struct Fake {
    dir: PathBuf,
    /// Behaviour of each task on its n-th submission (the last one repeats).
    plan: BTreeMap<usize, Vec<Behaviour>>,
    state: RefCell<FakeState>,
    max_array: Option<usize>,
}

#[derive(Default)]
struct FakeState {
    next_job: u64,
    /// Every submission: (job id, tasks).
    submissions: Vec<(String, Vec<usize>)>,
    /// Running tasks: (job id, task, behaviour, polls left).
    running: Vec<(String, usize, Behaviour, u32)>,
    /// How often each task was submitted.
    times: BTreeMap<usize, usize>,
}

impl Fake {
    fn new(dir: &Path, plan: &[(usize, &[Behaviour])]) -> Fake {
        Fake {
            dir: dir.to_path_buf(),
            plan: plan.iter().map(|(k, b)| (*k, b.to_vec())).collect(),
            state: RefCell::new(FakeState::default()),
            max_array: None,
        }
    }

    fn behaviour(&self, task: usize, nth: usize) -> Behaviour {
        match self.plan.get(&task) {
            Some(v) => v[nth.min(v.len() - 1)],
            None => Behaviour::Succeed { polls: 1 },
        }
    }

    fn finish(&self, task: usize, b: Behaviour) {
        let log = self.dir.join("logs").join(format!("task-{task}.out"));
        match b {
            Behaviour::Succeed { .. } => {
                let run = slurm::run_task(&self.dir, task).expect("the task runs");
                std::fs::write(&log, format!("task {task}: {}\n", run.span)).unwrap();
            }
            Behaviour::Fail { .. } => {
                std::fs::write(&log, "thread 'main' panicked: out of memory\n").unwrap();
            }
            Behaviour::Hang | Behaviour::Vanish => {}
        }
    }

    fn submissions(&self) -> Vec<(String, Vec<usize>)> {
        self.state.borrow().submissions.clone()
    }
}

impl Scheduler for Fake {
    fn submit(&self, script: &Path, tasks: &[usize], _whole: bool) -> crate::Result<String> {
        assert!(script.is_file(), "the job script exists when submitted");
        let mut st = self.state.borrow_mut();
        st.next_job += 1;
        let id = (1000 + st.next_job).to_string();
        st.submissions.push((id.clone(), tasks.to_vec()));
        for &k in tasks {
            let nth = *st.times.get(&k).unwrap_or(&0);
            st.times.insert(k, nth + 1);
            let b = self.behaviour(k, nth);
            let polls = match b {
                Behaviour::Succeed { polls } | Behaviour::Fail { polls } => polls,
                Behaviour::Hang => u32::MAX,
                Behaviour::Vanish => 0,
            };
            if b != Behaviour::Vanish {
                st.running.push((id.clone(), k, b, polls));
            }
        }
        Ok(id)
    }

    fn active_tasks(&self, jobs: &BTreeSet<String>, _tasks: usize) -> Option<Vec<(usize, String)>> {
        // One poll: every running task gets one step nearer its end.
        let finished: Vec<(usize, Behaviour)> = {
            let mut st = self.state.borrow_mut();
            for r in st.running.iter_mut() {
                r.3 = r.3.saturating_sub(1);
            }
            let (done, still): (Vec<_>, Vec<_>) = st.running.drain(..).partition(|r| r.3 == 0);
            st.running = still;
            done.into_iter().map(|r| (r.1, r.2)).collect()
        };
        for (k, b) in finished {
            self.finish(k, b);
        }
        let st = self.state.borrow();
        Some(
            st.running
                .iter()
                .filter(|r| jobs.contains(&r.0))
                .map(|r| (r.1, r.0.clone()))
                .collect(),
        )
    }

    fn max_array_size(&self) -> Option<usize> {
        self.max_array
    }

    fn submit_command(&self, script: &Path, tasks: &[usize], _whole: bool) -> Vec<String> {
        vec![
            "fake-submit".into(),
            format!("--array={}", super::scheduler::array_spec(tasks)),
            script.display().to_string(),
        ]
    }
}

/// One tiny counted frame and a 5-point core sweep around larrabee-24. (Counted once per process:
/// without the binary's line-aligned allocator two counts of a frame may touch other cache lines.)
fn frame() -> &'static (Scene, CanonicalRecords, MachineConfig, Vec<MachineConfig>) {
    static FRAME: std::sync::OnceLock<(Scene, CanonicalRecords, MachineConfig, Vec<MachineConfig>)> =
        std::sync::OnceLock::new();
    FRAME.get_or_init(count_frame)
}

fn count_frame() -> (Scene, CanonicalRecords, MachineConfig, Vec<MachineConfig>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/plate.toml");
    let mut scene = Scene::load(&path).expect("the plate scene loads");
    scene.camera.width = 32;
    scene.camera.height = 24;
    let algo = crate::algorithms::find("sism").unwrap();
    let params = algo.params(&[]).unwrap();
    let r = render::render(
        &scene,
        algo,
        &params,
        &RenderOptions {
            exec: Exec::Counting,
            progress: false,
        },
    );
    let records = machine::canonical(&r.records);
    let base = MachineConfig::preset("larrabee-24").unwrap();
    let configs = sweep::configurations(
        &base,
        &SweepAxes {
            cores: vec![1, 2, 4, 8, 16],
            threads: vec![],
            l2_kb: vec![],
            ..Default::default()
        },
    )
    .unwrap();
    (scene, records, base, configs)
}

fn label() -> Label {
    Label {
        name: "plate".into(),
        width: 32,
        height: 24,
    }
}

/// A study directory of `frame()` in `dir`, chunk 2 (3 tasks: 2, 2 and 1 points).
fn prepare(dir: &Path) -> slurm::Manifest {
    let (scene, records, base, configs) = frame();
    let study = Study {
        scene: &scene.source,
        label: &label(),
        algorithm: "sism",
        params: "",
        machine: "larrabee-24",
        base,
        configs,
        set_keys: &[],
        records,
        sensitivity_factor: None,
    };
    let job = JobOptions {
        chunk: 2,
        ..Default::default()
    };
    let (_, m) = slurm::prepare(dir, &study, &job, &mut |_, _| {}).expect("the directory is written");
    assert_eq!(m.tasks, 3);
    m
}

fn no_sleep(_: Duration) {}

/// Collects with `options`, returning the outcome and every note.
fn collect(
    fake: &Fake,
    dir: &Path,
    options: &CollectOptions,
) -> (crate::Result<Collected>, Vec<(Note, String)>) {
    let mut notes = Vec::new();
    let r = slurm::collect(fake, dir, options, &no_sleep, &mut |k, l| {
        notes.push((k, l.to_string()))
    });
    (r, notes)
}

fn watching() -> CollectOptions {
    CollectOptions {
        watch: true,
        interval: 1.0,
        timeout: Some(60.0),
        ..Default::default()
    }
}

#[test]
fn every_task_succeeding_gives_the_local_backends_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    let m = prepare(&dir);
    let fake = Fake::new(&dir, &[(1, &[Behaviour::Succeed { polls: 3 }])]);
    let s = slurm::submit(&fake, &dir, &m, None, false).unwrap();
    assert!(matches!(s, Submitted::Job { ref tasks, .. } if tasks == "0-2"));
    let (r, notes) = collect(&fake, &dir, &watching());
    let Collected::Complete(points) = r.unwrap() else {
        panic!("not complete: {notes:?}")
    };
    assert_eq!(points.len(), 5);
    assert!(points.windows(2).all(|w| w[0].index < w[1].index));
    // The local backend on the same frame and machines writes the same study.csv.
    let (_, records, base, configs) = frame();
    let local = tempfile::tempdir().unwrap();
    let local_points = run_local(records, configs, &[], || ());
    write_outputs(local.path(), &label(), base, &local_points, &|p| {
        Ok(configs[p.index].clone())
    })
    .unwrap();
    let slurm_csv = std::fs::read_to_string(dir.join("study.csv")).unwrap();
    let local_csv = std::fs::read_to_string(local.path().join("study.csv")).unwrap();
    assert!(
        slurm_csv == local_csv,
        "study.csv differs:\n{slurm_csv}\n---\n{local_csv}"
    );
    assert!(dir.join("speedup.png").is_file() && dir.join("phases.png").is_file());
    // The roofline of the base point too, from the collected rows as from the local ones.
    let roofline = |d: &std::path::Path| std::fs::read_to_string(d.join("roofline.md")).unwrap();
    assert_eq!(roofline(&dir), roofline(local.path()));
    assert!(roofline(&dir).contains("| **frame** |"));
    assert!(dir.join("report.html").is_file() && dir.join("roofline.png").is_file());
}

#[test]
fn failed_and_vanished_tasks_are_named_then_resubmitted_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    let m = prepare(&dir);
    let fake = Fake::new(
        &dir,
        &[
            (
                0,
                &[Behaviour::Fail { polls: 2 }, Behaviour::Succeed { polls: 1 }],
            ),
            (2, &[Behaviour::Vanish, Behaviour::Succeed { polls: 2 }]),
        ],
    );
    slurm::submit(&fake, &dir, &m, None, false).unwrap();
    let (r, notes) = collect(&fake, &dir, &watching());
    let e = r.unwrap_err().to_string();
    assert!(e.contains("3 of 5 points missing, in tasks 0,2"), "{e}");
    let problems: Vec<&str> = notes
        .iter()
        .filter(|(k, _)| *k == Note::Problem)
        .map(|(_, l)| l.as_str())
        .collect();
    assert_eq!(problems.len(), 2, "{problems:?}");
    assert!(problems[0].starts_with("task 0 (points 0-1): missing") && problems[0].contains("out of memory"));
    assert!(problems[1].starts_with("task 2 (point 4): missing") && problems[1].contains("no log"));
    // A resubmission without waiting names the missing tasks only.
    let (r, _) = collect(
        &fake,
        &dir,
        &CollectOptions {
            resubmit: true,
            ..Default::default()
        },
    );
    assert!(matches!(r.unwrap(), Collected::Resubmitted(Submitted::Job { ref tasks, .. }) if tasks == "0,2"));
    assert_eq!(fake.submissions()[1].1, vec![0, 2]);
    // Waiting for them completes the study; jobs.txt holds both submissions.
    let (r, notes) = collect(&fake, &dir, &watching());
    assert!(
        matches!(r.unwrap(), Collected::Complete(ref p) if p.len() == 5),
        "{notes:?}"
    );
    assert_eq!(slurm::job_ids(&dir).unwrap().len(), 2);
    // Nothing is left to resubmit.
    let mut notes = Vec::new();
    let s = slurm::submit_study(&fake, &dir, true, false, &mut |_, l| notes.push(l.to_string())).unwrap();
    assert!(
        s.is_none() && notes[0].starts_with("nothing to submit: 3 of 3 tasks"),
        "{notes:?}"
    );
}

#[test]
fn a_hanging_task_ends_the_watch_at_the_timeout_and_is_not_resubmitted() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    let m = prepare(&dir);
    let fake = Fake::new(&dir, &[(1, &[Behaviour::Hang])]);
    slurm::submit(&fake, &dir, &m, None, false).unwrap();
    let (r, notes) = collect(
        &fake,
        &dir,
        &CollectOptions {
            timeout: Some(10.0),
            ..watching()
        },
    );
    let e = r.unwrap_err().to_string();
    assert!(e.contains("2 of 5 points missing, in tasks 1"), "{e}");
    assert!(
        notes
            .iter()
            .any(|(k, l)| *k == Note::Problem && l.starts_with("watch: timed out")),
        "{notes:?}"
    );
    assert!(
        notes
            .iter()
            .any(|(_, l)| l.contains("pending or running as job 1001")),
        "{notes:?}"
    );
    // It is still running: a resubmission leaves it alone.
    let (r, notes) = collect(
        &fake,
        &dir,
        &CollectOptions {
            resubmit: true,
            ..Default::default()
        },
    );
    assert!(r.is_err());
    assert!(notes
        .iter()
        .any(|(_, l)| l == "nothing to resubmit: tasks 1 are pending or running"));
    assert_eq!(fake.submissions().len(), 1);
}

#[test]
fn foreign_and_corrupt_results_are_rejected_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    let m = prepare(&dir);
    for k in 0..m.tasks {
        slurm::run_task(&dir, k).unwrap();
    }
    // Task 1's result from another study, task 2's cut short.
    let r1 = dir.join("results/task-1.json");
    let text = std::fs::read_to_string(&r1)
        .unwrap()
        .replace(&m.checksum, "00000000deadbeef");
    std::fs::write(&r1, text).unwrap();
    let r2 = dir.join("results/task-2.json");
    let bytes = std::fs::read(&r2).unwrap();
    std::fs::write(&r2, &bytes[..bytes.len() / 2]).unwrap();
    let fake = Fake::new(&dir, &[]);
    let (r, notes) = collect(&fake, &dir, &CollectOptions::default());
    assert!(r.unwrap_err().to_string().contains("in tasks 1,2"));
    assert!(notes
        .iter()
        .any(|(_, l)| l.contains("task 1 (points 2-3): foreign result rejected")));
    assert!(notes
        .iter()
        .any(|(_, l)| l.contains("task 2 (point 4): failed") && l.contains("not valid JSON")));
    assert!(
        !dir.join("study.csv").exists(),
        "no study.csv from partial results"
    );
}

#[test]
fn the_schedulers_array_limit_and_dry_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    let m = prepare(&dir);
    let mut fake = Fake::new(&dir, &[]);
    fake.max_array = Some(2);
    let e = slurm::submit(&fake, &dir, &m, None, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("MaxArraySize is 2") && e.contains("--chunk (at least 3)"),
        "{e}"
    );
    fake.max_array = None;
    let s = slurm::submit(&fake, &dir, &m, Some(&[1, 2]), true).unwrap();
    assert_eq!(
        s,
        Submitted::DryRun {
            tasks: "1,2".into(),
            command: format!("fake-submit --array=1,2 {}/study.sbatch", dir.display()),
        }
    );
    assert!(fake.submissions().is_empty() && !dir.join("jobs.txt").exists());
    // A bad interval is refused before anything is done.
    let (r, _) = collect(
        &fake,
        &dir,
        &CollectOptions {
            interval: f64::INFINITY,
            ..Default::default()
        },
    );
    assert!(r.unwrap_err().to_string().contains("--interval"));
}

#[test]
fn the_local_scheduler_completes_a_directory_without_a_cluster() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    prepare(&dir);
    let local = super::scheduler::Local::default();
    let s = slurm::submit_study(&local, &dir, false, false, &mut |_, _| {}).unwrap();
    assert!(matches!(s, Some(Submitted::Job { .. })));
    let mut notes = Vec::new();
    let r = slurm::collect(
        &local,
        &dir,
        &CollectOptions::default(),
        &no_sleep,
        &mut |_, l| notes.push(l.to_string()),
    );
    assert!(
        matches!(r.unwrap(), Collected::Complete(ref p) if p.len() == 5),
        "{notes:?}"
    );
}
