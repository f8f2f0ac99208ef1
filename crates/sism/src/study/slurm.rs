//! A study as a directory replayed by a job array: written by `sism study --backend slurm`, each
//! task replayed by `sism study run DIR --task K`, merged by `sism study collect DIR`.
//!
//! The directory (every path below relative to it):
//!
//! | file | what |
//! |---|---|
//! | `manifest.toml` | format `sism-study 1`: the scene, algorithm, every point (its configuration's name, cores, threads, L2, machine file and that file's checksum, its task), the chunk size, the task count, the checksums of `records.bin` and `machine.toml`, and a checksum of all that |
//! | `records.bin` | the frame's records, counted once (the format `replay` reads) |
//! | `machine.toml` | the base machine, resolved |
//! | `machines/point-NNNN.toml` | each point's resolved machine |
//! | `study.sbatch` | the job array: task K runs `sism study run DIR --task K` |
//! | `jobs.txt` | the job ids submitted, one line each, appended |
//! | `logs/task-K.out` | task K's output (the scheduler writes it) |
//! | `results/task-K.json` | task K's points, tagged with the manifest's checksum (written to a temporary file and renamed, so a killed task leaves no partial result under this name) |
//!
//! Task K holds points `K·chunk .. (K+1)·chunk` (the last task fewer). [`collect`] accepts a result
//! only if its manifest checksum is this manifest's (else it is foreign: another study's, or an
//! older version of this one) and its points are the task's; the merged points go through the same
//! writer as the local backend's ([`super::write_outputs`]), so `study.csv` is the same bytes.
//!
//! The state machine (write → submit → tasks run, fail, time out or vanish → collect, resubmit the
//! missing → collect) sees the scheduler only through [`Scheduler`]; informational lines go to the
//! caller's `notes`, so the command line decides what is printed.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::scheduler::{array_spec, shell_quote, Scheduler};
use super::{write_outputs, Label, Point, Setting};
use crate::error::{bail, ensure};
use crate::machine::records::{checksum, to_bytes};
use crate::machine::sweep;
use crate::machine::{self, CanonicalRecords, MachineConfig};
use crate::output::write_atomic;

/// The manifest format this sism writes and reads.
pub const FORMAT: &str = "sism-study 1";
/// The result-file format this sism writes and reads.
pub const RESULT_FORMAT: &str = "sism-study-result 2";
/// Points per array task unless the caller says otherwise.
pub const DEFAULT_CHUNK: usize = 4;
/// Largest manifest or result file read, bytes.
const MAX_STUDY_FILE_BYTES: u64 = 256 << 20;

/// How a study directory's job array is cut and what its script asks of the scheduler.
#[derive(Clone, Debug)]
pub struct JobOptions {
    /// Points per array task (at least 1).
    pub chunk: usize,
    /// The partition to submit to (`#SBATCH --partition`).
    pub partition: Option<String>,
    /// Time limit of each array task, e.g. `00:10:00` (`#SBATCH --time`).
    pub time: Option<String>,
    /// Extra `#SBATCH` lines, e.g. `--mem=2G`.
    pub sbatch_args: Vec<String>,
    /// Write the directory and its script, do not submit.
    pub dry_run: bool,
    /// The `sism` executable the tasks run (`None`: this process's own, right for the `sism`
    /// command; a caller embedded in another program names the `sism` binary here).
    pub executable: Option<PathBuf>,
}

impl Default for JobOptions {
    fn default() -> JobOptions {
        JobOptions {
            chunk: DEFAULT_CHUNK,
            partition: None,
            time: None,
            sbatch_args: Vec::new(),
            dry_run: false,
            executable: None,
        }
    }
}

impl JobOptions {
    /// Checks the options before any work is done: every value that reaches the job script is one
    /// line (a newline would start a shell command in every task), the partition has no spaces, the
    /// time is a Slurm time.
    pub fn check(&self) -> crate::Result<()> {
        ensure!(
            (1..=sweep::MAX_POINTS).contains(&self.chunk),
            "--chunk {}: points per array task, 1 to {} (a sweep's most points)",
            self.chunk,
            sweep::MAX_POINTS
        );
        let one_line = |flag: &str, v: &str| {
            ensure!(
                !v.trim().is_empty() && !v.contains(['\n', '\r']),
                "{flag} '{}': must be one non-empty line",
                v.escape_debug()
            );
            Ok(())
        };
        if let Some(p) = &self.partition {
            one_line("--partition", p)?;
            ensure!(!p.contains(char::is_whitespace), "--partition '{p}': no spaces");
        }
        if let Some(t) = &self.time {
            one_line("--time", t)?;
            ensure!(
                t.chars().all(|c| c.is_ascii_digit() || c == ':' || c == '-'),
                "--time '{t}': expected a Slurm time such as 00:10:00, 10 or 1-00:00:00"
            );
        }
        for s in &self.sbatch_args {
            one_line("--sbatch-arg", s)?;
        }
        Ok(())
    }
}

/// What a line the state machine reports is: progress and facts, or a problem the user must see.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Note {
    /// What was written, submitted or is being waited for (a quiet caller drops these).
    Info,
    /// A missing or failed task, a watch that gave up: always worth showing.
    Problem,
}

/// What [`prepare`] writes: one counted frame and the machines to replay it on.
pub struct Study<'a> {
    /// The scene file.
    pub scene: &'a Path,
    /// The scene's name and image size, for the plots.
    pub label: &'a Label,
    /// The algorithm's name.
    pub algorithm: &'a str,
    /// Its parameters, `key=value`, space-separated.
    pub params: &'a str,
    /// The base machine as the user named it.
    pub machine: &'a str,
    /// The base machine, resolved.
    pub base: &'a MachineConfig,
    /// Every point's machine, in sweep order.
    pub configs: &'a [MachineConfig],
    /// The other swept parameters (`--set`), in order.
    pub set_keys: &'a [String],
    /// The frame's records.
    pub records: &'a CanonicalRecords,
    /// A sensitivity analysis's factor (`sism sensitivity --backend slurm`): the configurations are
    /// then [`super::sensitivity::plan`]'s for the base and this factor, and `collect` writes the
    /// analysis instead of the study's outputs.
    pub sensitivity_factor: Option<f64>,
}

/// `manifest.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`FORMAT`].
    pub format: String,
    /// Checksum of the manifest: of its TOML with this field empty, hex.
    pub checksum: String,
    /// The sism that wrote it.
    pub sism_version: String,
    /// The scene file, absolute.
    pub scene: String,
    /// The scene's name (file stem) and image size, for the plots.
    pub scene_name: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The algorithm's name.
    pub algorithm: String,
    /// Every parameter of the algorithm, `key=value`, space-separated.
    pub params: String,
    /// `--machine` as given.
    pub machine: String,
    /// `machine.toml`'s checksum (the base machine).
    pub machine_checksum: String,
    /// `records.bin`'s size and checksum.
    pub records_bytes: u64,
    /// Checksum of `records.bin`, hex.
    pub records_checksum: String,
    /// Points per array task.
    pub chunk: usize,
    /// Array tasks: ⌈points / chunk⌉.
    pub tasks: usize,
    /// Set for a sensitivity analysis: the factor its plan was made with (see [`Study`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensitivity_factor: Option<f64>,
    /// The points, in sweep order.
    pub point: Vec<ManifestPoint>,
}

/// One point of the sweep in `manifest.toml`: its configuration, array task and machine file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManifestPoint {
    /// Position in the sweep.
    pub index: usize,
    /// The array task that simulates it.
    pub task: usize,
    /// The configuration's name (`<base>-c<cores>-t<threads>-l2<kb>`).
    pub name: String,
    /// Cores.
    pub cores: u32,
    /// Hardware threads per core.
    pub threads: u32,
    /// L2 subset size per core, KB.
    pub l2_kb: u32,
    /// The other swept parameters' values (`--set`), in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub set: Vec<Setting>,
    /// `machines/point-NNNN.toml`.
    pub machine: String,
    /// Its checksum.
    pub machine_checksum: String,
}

/// The keys of a manifest point's other swept parameters.
fn keys_of(p: &ManifestPoint) -> Vec<String> {
    p.set.iter().map(|s| s.key.clone()).collect()
}

/// `results/task-K.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskResult {
    /// [`RESULT_FORMAT`].
    pub format: String,
    /// The checksum of the manifest the task ran.
    pub manifest_checksum: String,
    /// The array task.
    pub task: usize,
    /// Where it ran and how long it took (facts only).
    pub host: String,
    /// Wall time of the task, seconds.
    pub seconds: f64,
    /// The task's points, in sweep order.
    pub points: Vec<Point>,
}

fn hex(bytes: &[u8]) -> String {
    format!("{:016x}", checksum(bytes))
}

impl Manifest {
    /// The checksum of this manifest's content (every field but `checksum`).
    fn content_checksum(&self) -> crate::Result<String> {
        let mut m = self.clone();
        m.checksum.clear();
        let text = toml::to_string(&m).map_err(|e| crate::Error::invalid(format!("study manifest: {e}")))?;
        Ok(hex(text.as_bytes()))
    }

    /// The points array task `task` simulates, in sweep order.
    pub fn points_of(&self, task: usize) -> impl Iterator<Item = &ManifestPoint> {
        self.point.iter().filter(move |p| p.task == task)
    }

    /// `a-b` (or `a`) of the task's point indices.
    pub fn span(&self, task: usize) -> String {
        let first = task * self.chunk;
        let last = ((task + 1) * self.chunk).min(self.point.len()) - 1;
        if first == last {
            format!("point {first}")
        } else {
            format!("points {first}-{last}")
        }
    }
}

/// An error when `dir` holds a Slurm study (its manifest): a local study writing its `records.bin`
/// and `machine.toml` there would break every task still to run.
pub fn refuse_for_local(dir: &Path) -> crate::Result<()> {
    ensure!(
        std::fs::symlink_metadata(manifest_path(dir)).is_err(),
        "--out {} holds a Slurm study ({} exists): a local study there would replace the records its tasks \
         replay; choose another --out (or merge that study with `sism study collect {}`)",
        dir.display(),
        manifest_path(dir).display(),
        dir.display()
    );
    Ok(())
}

/// `manifest.toml` in the study directory `dir`.
pub fn manifest_path(dir: &Path) -> PathBuf {
    dir.join("manifest.toml")
}

/// `results/task-K.json` of array task `task` in the study directory `dir`.
pub fn result_path(dir: &Path, task: usize) -> PathBuf {
    dir.join("results").join(format!("task-{task}.json"))
}

/// `logs/task-K.out`, the log of array task `task` in the study directory `dir`.
pub fn log_path(dir: &Path, task: usize) -> PathBuf {
    dir.join("logs").join(format!("task-{task}.out"))
}

/// Reads and checks `DIR/manifest.toml`: present, TOML, the format this sism reads, every field,
/// the checksum, and the points' assignment to tasks.
pub fn load_manifest(dir: &Path) -> crate::Result<Manifest> {
    let path = manifest_path(dir);
    let p = path.display();
    let text = match crate::input::read_text(&path, "study manifest", MAX_STUDY_FILE_BYTES) {
        Ok(t) => t,
        Err(e) => bail!(
            "{e} ({} is not a study directory written by `sism study SCENE --backend slurm`?)",
            dir.display()
        ),
    };
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| crate::Error::invalid(format!("study manifest {p}: not valid TOML: {}", e.message())))?;
    match table.get("format") {
        None => bail!("study manifest {p}: no `format` key: not a sism study manifest"),
        Some(toml::Value::String(f)) if f == FORMAT => {}
        Some(f) => bail!(
            "study manifest {p}: format {f} is not the one this sism reads (\"{FORMAT}\"): write the study \
             again with this sism, or use the sism that wrote it"
        ),
    }
    let m: Manifest = toml::from_str(&text).map_err(|e| {
        crate::Error::invalid(format!(
            "study manifest {p}: {}",
            e.to_string().trim_end().replace('\n', " ")
        ))
    })?;
    let sum = m.content_checksum()?;
    ensure!(
        m.checksum == sum,
        "study manifest {p}: checksum mismatch (the file says {}, its content gives {sum}): the manifest \
         was edited or is corrupt; write the study again",
        m.checksum
    );
    ensure!(!m.point.is_empty(), "study manifest {p}: no point");
    ensure!(
        m.chunk >= 1,
        "study manifest {p}: chunk {} must be at least 1",
        m.chunk
    );
    ensure!(
        m.tasks == m.point.len().div_ceil(m.chunk),
        "study manifest {p}: {} tasks for {} points of chunk {} (expected {})",
        m.tasks,
        m.point.len(),
        m.chunk,
        m.point.len().div_ceil(m.chunk)
    );
    for (i, pt) in m.point.iter().enumerate() {
        ensure!(
            pt.index == i && pt.task == i / m.chunk,
            "study manifest {p}: point {i} ({}) says index {} task {} (expected index {i} task {})",
            pt.name,
            pt.index,
            pt.task,
            i / m.chunk
        );
        ensure!(
            pt.machine == format!("machines/point-{i:04}.toml"),
            "study manifest {p}: point {i}'s machine file `{}` is not machines/point-{i:04}.toml",
            pt.machine
        );
    }
    Ok(m)
}

fn write(path: &Path, bytes: &[u8]) -> crate::Result<()> {
    write_atomic(path, bytes)
}

fn mkdir(path: &Path) -> crate::Result<()> {
    std::fs::create_dir_all(path).map_err(|e| crate::Error::create_dir(path, e))
}

/// Removes the files in `dir` whose names `stale` picks (results, logs and machine files of an
/// earlier study written to the same directory); how many.
fn remove_stale(dir: &Path, stale: impl Fn(&str) -> bool) -> crate::Result<usize> {
    let mut n = 0;
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(0);
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if stale(&name) && e.path().is_file() {
            std::fs::remove_file(e.path()).map_err(|err| crate::Error::Io {
                what: "cannot remove stale",
                path: e.path(),
                error: err,
            })?;
            n += 1;
        }
    }
    Ok(n)
}

/// Writes the study directory for `s` into `out` (which must exist): records, machines, manifest and
/// job script, after removing an earlier study's results there. Returns the directory (absolute)
/// and its manifest; submitting is [`submit`]'s.
pub fn prepare(
    out: &Path,
    s: &Study,
    job: &JobOptions,
    notes: &mut dyn FnMut(Note, &str),
) -> crate::Result<(PathBuf, Manifest)> {
    job.check()?;
    ensure!(
        s.configs.len() <= sweep::MAX_POINTS,
        "the sweep has {} points; at most {} are accepted",
        s.configs.len(),
        sweep::MAX_POINTS
    );
    let dir = std::fs::canonicalize(out).map_err(|e| crate::Error::Io {
        what: "cannot resolve",
        path: out.to_path_buf(),
        error: e,
    })?;
    // Everything is built and checked in memory first (the machine files reading back, the manifest,
    // the job script's values), so that a bad option fails before an earlier study in `dir` is
    // touched.
    let records = to_bytes(s.records);
    let base = s.base.to_toml();
    let chunk = job.chunk;
    let mut points = Vec::with_capacity(s.configs.len());
    let mut machine_files = Vec::with_capacity(s.configs.len());
    for (i, c) in s.configs.iter().enumerate() {
        let text = c.to_toml();
        // The replay must see exactly this configuration: check that the file reads back as it.
        let back = MachineConfig::from_toml(&text, &c.name).map_err(|e| {
            crate::Error::invalid(format!(
                "point {i} ({}): its machine file does not read back: {e}",
                c.name
            ))
        })?;
        ensure!(
            &back == c,
            "point {i} ({}): its machine file does not read back as the same configuration",
            c.name
        );
        let rel = format!("machines/point-{i:04}.toml");
        points.push(ManifestPoint {
            index: i,
            task: i / chunk,
            name: c.name.clone(),
            cores: c.cores,
            threads: c.threads_per_core,
            l2_kb: c.l2_kb,
            set: super::settings(c, s.set_keys),
            machine: rel.clone(),
            machine_checksum: hex(text.as_bytes()),
        });
        machine_files.push((rel, text));
    }
    let scene = std::fs::canonicalize(s.scene).unwrap_or_else(|_| s.scene.to_path_buf());
    let mut m = Manifest {
        format: FORMAT.into(),
        checksum: String::new(),
        sism_version: env!("CARGO_PKG_VERSION").into(),
        scene: scene.display().to_string(),
        scene_name: s.label.name.clone(),
        width: s.label.width,
        height: s.label.height,
        algorithm: s.algorithm.into(),
        params: s.params.into(),
        machine: s.machine.into(),
        machine_checksum: hex(base.as_bytes()),
        records_bytes: records.len() as u64,
        records_checksum: hex(&records),
        chunk,
        tasks: points.len().div_ceil(chunk),
        sensitivity_factor: s.sensitivity_factor,
        point: points,
    };
    m.checksum = m.content_checksum()?;
    let manifest_text = format!(
        "# sism study manifest: written by `sism study --backend slurm`, read by `sism study run|collect|submit`.\n\
         # Do not edit: the checksum covers every value below.\n{}",
        toml::to_string(&m).map_err(|e| crate::Error::invalid(format!("study manifest: {e}")))?
    );
    let script = sbatch_script(&dir, &m, job)?;
    // Now the directory: an earlier study's files go, the new ones come.
    for sub in ["machines", "results", "logs"] {
        mkdir(&dir.join(sub))?;
    }
    let stale = remove_stale(&dir.join("results"), |n| {
        n.starts_with("task-") || n.starts_with(".task-")
    })? + remove_stale(&dir.join("logs"), |n| n.starts_with("task-"))?
        + remove_stale(&dir.join("machines"), |n| n.starts_with("point-"))?
        + remove_stale(&dir, |n| {
            [
                "study.csv",
                "speedup.png",
                "phases.png",
                "roofline.md",
                "roofline.png",
                "report.html",
                "sensitivity.csv",
                "sensitivity.md",
                "sensitivity.png",
            ]
            .contains(&n)
        })?;
    if stale > 0 {
        notes(
            Note::Info,
            &format!("removed {stale} files of an earlier study in {}", dir.display()),
        );
    }
    write(&dir.join("records.bin"), &records)?;
    write(&dir.join("machine.toml"), base.as_bytes())?;
    for (rel, text) in &machine_files {
        write(&dir.join(rel), text.as_bytes())?;
    }
    write_atomic(&manifest_path(&dir), manifest_text.as_bytes())?;
    write(&dir.join("study.sbatch"), script.as_bytes())?;
    notes(
        Note::Info,
        &format!(
            "wrote {}: {} points in {} array tasks of up to {chunk}",
            dir.display(),
            m.point.len(),
            m.tasks
        ),
    );
    Ok((dir, m))
}

/// `value` when it may go into the job script: no control character (a newline in a comment or an
/// `#SBATCH` line would start a shell command in every array task; quoting does not help a comment).
/// `what` names it in the error.
fn script_value<'a>(what: &str, value: &'a str) -> crate::Result<&'a str> {
    ensure!(
        !value.chars().any(char::is_control),
        "{what} {:?} holds a control character (a newline, a tab, …), which a job script cannot carry \
         safely: rename it",
        value
    );
    Ok(value)
}

/// `study.sbatch`: the job array over every task of `m`.
fn sbatch_script(dir: &Path, m: &Manifest, job: &JobOptions) -> crate::Result<String> {
    let exe = match &job.executable {
        Some(e) => std::fs::canonicalize(e).map_err(|err| crate::Error::Io {
            what: "cannot find the sism executable",
            path: e.clone(),
            error: err,
        })?,
        None => std::env::current_exe()
            .and_then(std::fs::canonicalize)
            .map_err(|e| {
                crate::Error::External(format!(
                    "cannot find this sism's executable for the job script: {e}"
                ))
            })?,
    };
    let d = script_value("the study directory", &dir.display().to_string())?.to_string();
    let exe_text = script_value("the sism executable's path", &exe.display().to_string())?.to_string();
    let scene_name = script_value("the scene's name", &m.scene_name)?;
    let machine = script_value("--machine", &m.machine)?;
    ensure!(
        !d.contains(char::is_whitespace),
        "the study directory {d} has a space in its path, which #SBATCH lines cannot hold: choose another --out"
    );
    let mut s = format!(
        "#!/bin/sh\n\
         # sism study: {} points of {} on {} in {} array tasks of up to {} points.\n\
         # Written by `sism study --backend slurm`; submit with `sism study submit {d}` (or sbatch).\n\
         #SBATCH --job-name=sism-study\n\
         #SBATCH --array=0-{}\n\
         #SBATCH --output={d}/logs/task-%a.out\n\
         #SBATCH --chdir={d}\n\
         #SBATCH --ntasks=1\n",
        m.point.len(),
        scene_name,
        machine,
        m.tasks,
        m.chunk,
        m.tasks - 1,
    );
    if let Some(p) = &job.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &job.time {
        s += &format!("#SBATCH --time={t}\n");
    }
    for a in &job.sbatch_args {
        let a = a.trim();
        let a = a.strip_prefix("#SBATCH").map(str::trim).unwrap_or(a);
        s += &format!("#SBATCH {a}\n");
    }
    s += &format!(
        "\n# One replay thread per CPU Slurm gives the task (add --sbatch-arg=--cpus-per-task=N for more).\n\
         export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\"\n\
         exec {} study run {} --task \"$SLURM_ARRAY_TASK_ID\"\n",
        shell_quote(&exe_text),
        shell_quote(&d)
    );
    Ok(s)
}

/// What [`submit`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Submitted {
    /// The array went to the scheduler as this job id, with these tasks (array syntax).
    Job {
        /// The scheduler's job id.
        id: String,
        /// The tasks, in array syntax (`0-3,5`).
        tasks: String,
    },
    /// A dry run: the tasks and the command that would have submitted them.
    DryRun {
        /// The tasks, in array syntax.
        tasks: String,
        /// The command line, shell-quoted.
        command: String,
    },
}

/// Submits the study's array (all of it, or only `tasks`) through `scheduler` and appends the job id
/// to `jobs.txt`; `dry_run`: says what it would submit instead.
pub fn submit(
    scheduler: &dyn Scheduler,
    dir: &Path,
    m: &Manifest,
    tasks: Option<&[usize]>,
    dry_run: bool,
) -> crate::Result<Submitted> {
    let script = dir.join("study.sbatch");
    ensure!(
        script.is_file(),
        "{} is missing: write the study again with `sism study SCENE --backend slurm`",
        script.display()
    );
    let all: Vec<usize> = (0..m.tasks).collect();
    let (list, whole) = match tasks {
        Some(t) => (t, false),
        None => (&all[..], true),
    };
    let spec = array_spec(list);
    // Slurm refuses array indices at or past its MaxArraySize (1001 by default): say what to do.
    let highest = list.iter().max().copied().unwrap_or(0);
    if let Some(max) = scheduler.max_array_size() {
        ensure!(
            highest < max,
            "this study's array reaches task {highest}, but the cluster's MaxArraySize is {max} \
             (indices 0..{max}): write it again with a larger --chunk (at least {}), or ask the \
             administrators to raise MaxArraySize",
            m.point.len().div_ceil(max.max(1))
        );
    }
    if dry_run {
        let line: Vec<String> = scheduler
            .submit_command(&script, list, whole)
            .iter()
            .map(|a| shell_quote(a))
            .collect();
        return Ok(Submitted::DryRun {
            tasks: spec,
            command: line.join(" "),
        });
    }
    let id = scheduler.submit(&script, list, whole)?;
    let jobs = dir.join("jobs.txt");
    let when = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    // Only a regular file is appended to (opening a FIFO to write would wait for a reader forever).
    if let Ok(meta) = std::fs::metadata(&jobs) {
        ensure!(
            meta.is_file(),
            "{} is a {}, not a regular file: remove it",
            jobs.display(),
            crate::input::kind_of(&meta)
        );
    }
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&jobs)
        .map_err(|e| crate::Error::write(&jobs, e))?;
    writeln!(f, "{id} array={spec} submitted={when}").map_err(|e| crate::Error::write(&jobs, e))?;
    Ok(Submitted::Job { id, tasks: spec })
}

/// The job ids in `jobs.txt` (none if it is absent). Read as every input is (a regular file of at
/// most [`MAX_STUDY_FILE_BYTES`]): a FIFO or a link to a device is an error, not a hang.
pub fn job_ids(dir: &Path) -> crate::Result<BTreeSet<String>> {
    let path = dir.join("jobs.txt");
    if std::fs::symlink_metadata(&path).is_err_and(|e| e.kind() == std::io::ErrorKind::NotFound) {
        return Ok(BTreeSet::new());
    }
    let text = crate::input::read_text(&path, "job list", MAX_STUDY_FILE_BYTES)?;
    Ok(text
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|id| id.chars().all(|c| c.is_ascii_digit()))
        .map(str::to_string)
        .collect())
}

/// What one task's run did.
#[derive(Clone, Debug)]
pub struct TaskRun {
    /// `point a` or `points a-b`.
    pub span: String,
    /// Wall time, seconds.
    pub seconds: f64,
    /// The result file written.
    pub result: PathBuf,
}

/// Point `p`'s machine file in the study directory `dir`, checked against the manifest (checksum,
/// name, cores, threads, L2 and the swept values).
fn point_machine(dir: &Path, p: &ManifestPoint) -> crate::Result<MachineConfig> {
    let path = dir.join(&p.machine);
    let text = crate::input::read_text(&path, "machine file", crate::input::MAX_TEXT_BYTES)?;
    ensure!(
        hex(text.as_bytes()) == p.machine_checksum,
        "machine file {}: its checksum {} is not the manifest's {}: the file was edited or replaced",
        path.display(),
        hex(text.as_bytes()),
        p.machine_checksum
    );
    let c = MachineConfig::from_toml(&text, &p.name)
        .map_err(|e| crate::Error::invalid(format!("machine file {}: {e}", path.display())))?;
    ensure!(
        c.name == p.name
            && c.cores == p.cores
            && c.threads_per_core == p.threads
            && c.l2_kb == p.l2_kb
            && super::settings(&c, &keys_of(p)) == p.set,
        "machine file {}: not the manifest's point {} ({})",
        path.display(),
        p.index,
        p.name
    );
    Ok(c)
}

/// Runs one array task of the study in `dir`: replays its points on their machines (checked against
/// the manifest's checksums) and writes `results/task-K.json`.
pub fn run_task(dir: &Path, task: usize) -> crate::Result<TaskRun> {
    let t0 = Instant::now();
    let m = load_manifest(dir)?;
    ensure!(
        task < m.tasks,
        "--task {}: out of range: {} has {} tasks (0-{})",
        task,
        manifest_path(dir).display(),
        m.tasks,
        m.tasks - 1
    );
    let points: Vec<&ManifestPoint> = m.points_of(task).collect();
    let configs = points
        .iter()
        .map(|p| point_machine(dir, p))
        .collect::<crate::Result<Vec<_>>>()?;
    let path = dir.join("records.bin");
    // The size the manifest expects, before reading: a replaced (say sparse, huge) file is refused
    // without being read.
    let on_disk = std::fs::metadata(&path).map_err(|e| crate::Error::Io {
        what: "cannot read",
        path: path.clone(),
        error: e,
    })?;
    ensure!(
        on_disk.len() == m.records_bytes,
        "records file {}: {} bytes, but the manifest's are {}: records.bin was replaced",
        path.display(),
        on_disk.len(),
        m.records_bytes
    );
    let bytes = crate::input::read_file(
        &path,
        "records file",
        m.records_bytes.min(crate::input::MAX_RECORDS_BYTES),
    )?;
    let records = machine::parse_records(&bytes)
        .map_err(|e| crate::Error::invalid(format!("records file {}: {e}", path.display())))?;
    ensure!(
        bytes.len() as u64 == m.records_bytes && hex(&bytes) == m.records_checksum,
        "records file {}: {} bytes with checksum {}, but the manifest's are {} bytes with checksum {}: \
         records.bin was replaced",
        path.display(),
        bytes.len(),
        hex(&bytes),
        m.records_bytes,
        m.records_checksum
    );
    drop(bytes);
    let swept = sweep::run(&records, &configs, || ());
    let result = TaskResult {
        format: RESULT_FORMAT.into(),
        manifest_checksum: m.checksum.clone(),
        task,
        host: std::fs::read_to_string("/proc/sys/kernel/hostname")
            .map(|h| h.trim().to_string())
            .unwrap_or_default(),
        seconds: t0.elapsed().as_secs_f64(),
        points: swept
            .iter()
            .zip(&points)
            .map(|(s, p)| Point::new(p.index, s, &keys_of(p)))
            .collect(),
    };
    let out = result_path(dir, task);
    mkdir(out.parent().expect("results/"))?;
    let json = serde_json::to_vec(&result).expect("plain struct serialises");
    write_atomic(&out, &json)?;
    Ok(TaskRun {
        span: m.span(task),
        seconds: t0.elapsed().as_secs_f64(),
        result: out,
    })
}

/// What a task's result file holds.
#[derive(Debug)]
pub enum Status {
    /// A valid result: the task's points.
    Done(Vec<Point>),
    /// No result file.
    Missing,
    /// Written for another manifest (its checksum).
    Foreign(String),
    /// Unreadable or not this task's (what is wrong).
    Bad(String),
}

/// The status of task `task`'s result file.
pub fn read_result(dir: &Path, m: &Manifest, task: usize) -> Status {
    let path = result_path(dir, task);
    // Missing only when nothing is there: a link loop or an unreadable folder is a failure to say.
    match std::fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Status::Missing,
        Err(e) => return Status::Bad(format!("cannot read it: {e}")),
        Ok(_) => {}
    }
    let bytes = match crate::input::read_file(&path, "task result", MAX_STUDY_FILE_BYTES) {
        Ok(b) => b,
        Err(e) => return Status::Bad(e.to_string()),
    };
    // The format and the manifest checksum first, so that another version's or study's file is named
    // as such rather than as a field error.
    let loose: serde_json::Value = match serde_json::from_slice(&bytes) {
        Ok(v) => v,
        Err(e) => return Status::Bad(format!("not valid JSON: {e}")),
    };
    if loose.get("format").and_then(|f| f.as_str()) != Some(RESULT_FORMAT) {
        return Status::Bad(format!(
            "format {} is not \"{RESULT_FORMAT}\"",
            loose.get("format").map_or("(none)".into(), |f| f.to_string())
        ));
    }
    match loose.get("manifest_checksum").and_then(|c| c.as_str()) {
        Some(c) if c == m.checksum => {}
        Some(c) => return Status::Foreign(c.to_string()),
        None => return Status::Bad("no manifest_checksum".into()),
    }
    let r: TaskResult = match serde_json::from_value(loose) {
        Ok(r) => r,
        Err(e) => return Status::Bad(e.to_string()),
    };
    if r.task != task {
        return Status::Bad(format!("holds task {}, not {task}", r.task));
    }
    let want: Vec<(usize, &str)> = m.points_of(task).map(|p| (p.index, p.name.as_str())).collect();
    let got: Vec<(usize, &str)> = r.points.iter().map(|p| (p.index, p.name.as_str())).collect();
    if want != got {
        return Status::Bad(format!("holds points {got:?}, not the task's {want:?}"));
    }
    for (p, mp) in r.points.iter().zip(m.points_of(task)) {
        if let Err(e) = check_point(p, mp) {
            return Status::Bad(format!("point {}: {e}", p.index));
        }
    }
    Status::Done(r.points)
}

/// Whether the result point `p` is the replay of the manifest's point `mp`: the same configuration
/// (cores, threads, L2), and a well-formed timing: at least one step, every figure finite and not
/// negative, the frame's cycles at least any step's. A file edited, copied from another study or
/// written by a broken task is refused rather than merged into `study.csv`.
fn check_point(p: &Point, mp: &ManifestPoint) -> Result<(), String> {
    if (p.cores, p.threads, p.l2_kb) != (mp.cores, mp.threads, mp.l2_kb) {
        return Err(format!(
            "cores {} threads {} L2 {} KB, but the manifest's point is cores {} threads {} L2 {} KB",
            p.cores, p.threads, p.l2_kb, mp.cores, mp.threads, mp.l2_kb
        ));
    }
    if p.set != mp.set {
        let show = |s: &[Setting]| {
            s.iter()
                .map(|s| format!("{}={}", s.key, s.value))
                .collect::<Vec<_>>()
                .join(" ")
        };
        return Err(format!(
            "{}, but the manifest's point has {}",
            show(&p.set),
            show(&mp.set)
        ));
    }
    if p.steps.is_empty() {
        return Err("no steps".into());
    }
    if !(p.clock_ghz.is_finite() && p.clock_ghz > 0.0) {
        return Err(format!("clock {} GHz", p.clock_ghz));
    }
    for row in p.steps.iter().chain(&p.groups).chain([&p.frame]) {
        let figures = [row.ms, row.lane_utilisation, row.l1_miss_rate, row.l2_miss_rate];
        if figures.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(format!(
                "{}: a figure is not a finite, non-negative number",
                row.phase
            ));
        }
        if row.cycles > p.frame.cycles {
            return Err(format!(
                "{}: {} cycles, more than the frame's {}",
                row.phase, row.cycles, p.frame.cycles
            ));
        }
    }
    Ok(())
}

/// The last `n` lines of the log at `path` (of its last 64 KiB), or the line to print instead: no
/// log yet, or a log that is not a regular file (a FIFO or a link to a device would block or never
/// end; only its kind is reported).
fn tail(path: &Path, n: usize) -> Result<Vec<String>, String> {
    use std::io::{Read, Seek, SeekFrom};
    let p = path.display();
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(format!("no log {p} (not run by Slurm yet)"))
        }
        Err(e) => return Err(format!("log {p}: cannot read it: {e}")),
    };
    if !meta.is_file() {
        return Err(format!(
            "log {p} is a {}, not a regular file: not read",
            crate::input::kind_of(&meta)
        ));
    }
    let read = || -> std::io::Result<Vec<u8>> {
        let mut f = std::fs::File::open(path)?;
        f.seek(SeekFrom::Start(meta.len().saturating_sub(64 << 10)))?;
        let mut b = Vec::new();
        f.take(64 << 10).read_to_end(&mut b)?;
        Ok(b)
    };
    let b = read().map_err(|e| format!("log {p}: cannot read it: {e}"))?;
    let text = String::from_utf8_lossy(&b);
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    Ok(lines[lines.len().saturating_sub(n)..].to_vec())
}

/// Task ids without a valid result among `statuses`.
pub fn incomplete(statuses: &[Status]) -> Vec<usize> {
    statuses
        .iter()
        .enumerate()
        .filter(|(_, s)| !matches!(s, Status::Done(_)))
        .map(|(k, _)| k)
        .collect()
}

/// Every task's status, in task order.
pub fn scan(dir: &Path, m: &Manifest) -> Vec<Status> {
    (0..m.tasks).map(|k| read_result(dir, m, k)).collect()
}

/// The incomplete tasks the scheduler does not hold as pending or running, and those it does.
pub fn resubmittable(
    scheduler: &dyn Scheduler,
    dir: &Path,
    m: &Manifest,
    statuses: &[Status],
) -> crate::Result<(Vec<usize>, Vec<usize>)> {
    let active = scheduler
        .active_tasks(&job_ids(dir)?, m.tasks)
        .unwrap_or_default();
    Ok(incomplete(statuses)
        .into_iter()
        .partition(|k| !active.iter().any(|(t, _)| t == k)))
}

/// What `collect` is asked to do.
#[derive(Clone, Debug)]
pub struct CollectOptions {
    /// Wait while the array runs until every point is done, no task of the study's jobs is pending
    /// or running any more, or `timeout`.
    pub watch: bool,
    /// Seconds between polls under `watch` (positive, finite).
    pub interval: f64,
    /// Stop watching after this many seconds.
    pub timeout: Option<f64>,
    /// First submit the tasks that have no valid result and are not pending or running.
    pub resubmit: bool,
    /// With `resubmit`: say what would be submitted, submit nothing.
    pub dry_run: bool,
    /// Last lines of a missing task's log to show.
    pub log_lines: usize,
    /// Draw a progress bar of points done under `watch`.
    pub progress: bool,
    /// Also report "points done: a/b" as notes when the count changes (for logs, where no bar is
    /// drawn).
    pub progress_lines: bool,
}

impl Default for CollectOptions {
    fn default() -> CollectOptions {
        CollectOptions {
            watch: false,
            interval: 5.0,
            timeout: None,
            resubmit: false,
            dry_run: false,
            log_lines: 5,
            progress: false,
            progress_lines: false,
        }
    }
}

/// How `collect` ended.
#[derive(Debug)]
pub enum Collected {
    /// Every point was there: `study.csv` and the plots are written; the points, in sweep order.
    Complete(Vec<Point>),
    /// Every point of a sensitivity analysis was there: its files are written.
    Sensitivity(Box<super::sensitivity::Sensitivity>),
    /// The missing tasks were resubmitted and not waited for: collect again later.
    Resubmitted(Submitted),
    /// A dry run of the resubmission.
    DryRun(Submitted),
}

/// Merges the study in `dir` (see [`CollectOptions`]): resubmits and waits if asked, then writes
/// `study.csv`, `speedup.png` and `phases.png` from every task's result, or fails naming every
/// missing, failed or foreign task with the end of its log. `sleep` waits between polls (a test
/// passes one that does not sleep).
pub fn collect(
    scheduler: &dyn Scheduler,
    dir: &Path,
    options: &CollectOptions,
    sleep: &dyn Fn(Duration),
    notes: &mut dyn FnMut(Note, &str),
) -> crate::Result<Collected> {
    let m = load_manifest(dir)?;
    let dir = &std::fs::canonicalize(dir).unwrap_or(dir.to_path_buf());
    ensure!(
        options.interval.is_finite() && options.interval > 0.0 && options.interval <= 1e6,
        "--interval {}: must be a positive number of seconds (at most 1e6)",
        options.interval
    );
    if let Some(t) = options.timeout {
        ensure!(
            t.is_finite() && t >= 0.0,
            "--timeout {t}: must be a number of seconds"
        );
    }
    if options.resubmit {
        let statuses = scan(dir, &m);
        let (missing, active) = resubmittable(scheduler, dir, &m, &statuses)?;
        if missing.is_empty() {
            if !active.is_empty() {
                notes(
                    Note::Info,
                    &format!(
                        "nothing to resubmit: tasks {} are pending or running",
                        array_spec(&active)
                    ),
                );
            }
        } else {
            let s = submit(scheduler, dir, &m, Some(&missing), options.dry_run)?;
            if options.dry_run {
                return Ok(Collected::DryRun(s));
            }
            if let Submitted::Job { id, tasks } = &s {
                notes(
                    Note::Info,
                    &format!(
                        "submitted job {id}: tasks {tasks}; follow with `sism study collect {} --watch`",
                        dir.display()
                    ),
                );
            }
            if !options.watch {
                notes(
                    Note::Info,
                    &format!(
                        "collect again when they are done (`sism study collect {} --watch` waits)",
                        dir.display()
                    ),
                );
                return Ok(Collected::Resubmitted(s));
            }
        }
    }
    if options.watch {
        watch(scheduler, dir, &m, options, sleep, notes)?;
    }
    let statuses = scan(dir, &m);
    report_strays(dir, &m, notes);
    let missing = incomplete(&statuses);
    if !missing.is_empty() {
        let active = scheduler
            .active_tasks(&job_ids(dir)?, m.tasks)
            .unwrap_or_default();
        let mut points = 0;
        for &k in &missing {
            points += m.points_of(k).count();
            let result = result_path(dir, k);
            let what = match &statuses[k] {
                Status::Missing => format!("missing: no {}", result.display()),
                Status::Foreign(c) => format!(
                    "foreign result rejected: {} was written for another study (manifest checksum {c}, this \
                     study's is {})",
                    result.display(),
                    m.checksum
                ),
                Status::Bad(e) => format!("failed: {}: {e}", result.display()),
                Status::Done(_) => unreachable!("incomplete tasks are not done"),
            };
            let mut s = format!("task {k} ({}): {what}", m.span(k));
            if let Some((_, job)) = active.iter().find(|(t, _)| *t == k) {
                s += &format!("; pending or running as job {job}");
            }
            let log = log_path(dir, k);
            match tail(&log, options.log_lines) {
                Ok(lines) if lines.is_empty() => s += &format!("\n  log {}: empty", log.display()),
                Ok(lines) => {
                    s += &format!("\n  log {} ends:", log.display());
                    for l in lines {
                        s += &format!("\n  | {l}");
                    }
                }
                Err(line) => s += &format!("\n  {line}"),
            }
            notes(Note::Problem, &s);
        }
        let spec = array_spec(&missing);
        bail!(
            "{points} of {} points missing, in tasks {spec}: rerun them with `sism study collect {d} \
             --resubmit --watch` (Slurm), or by hand with `sism study run {d} --task K` for K in {spec}",
            m.point.len(),
            d = dir.display()
        );
    }
    let mut points: Vec<Point> = statuses
        .into_iter()
        .flat_map(|s| match s {
            Status::Done(p) => p,
            _ => Vec::new(),
        })
        .collect();
    points.sort_by_key(|p| p.index);
    let base_path = dir.join("machine.toml");
    let base_text = crate::input::read_text(&base_path, "machine file", crate::input::MAX_TEXT_BYTES)?;
    ensure!(
        hex(base_text.as_bytes()) == m.machine_checksum,
        "machine file {}: its checksum is not the manifest's: the file was edited or replaced",
        base_path.display()
    );
    let base = MachineConfig::from_toml(&base_text, "base")
        .map_err(|e| crate::Error::invalid(format!("machine file {}: {e}", base_path.display())))?;
    let label = Label {
        name: m.scene_name.clone(),
        width: m.width,
        height: m.height,
    };
    if let Some(factor) = m.sensitivity_factor {
        // The plan again, from the base machine and the factor: it must be the manifest's machines.
        let plan = super::sensitivity::plan(&base, factor)?;
        ensure!(
            plan.configs.len() == m.point.len()
                && plan
                    .configs
                    .iter()
                    .zip(&m.point)
                    .all(|(c, p)| hex(c.to_toml().as_bytes()) == p.machine_checksum),
            "study manifest {}: its machines are not the sensitivity plan of machine.toml with factor              {factor} (written by another sism?)",
            manifest_path(dir).display()
        );
        let s = super::sensitivity::analyse(&plan, &points)?;
        super::sensitivity::write_outputs(dir, &label, &s)?;
        return Ok(Collected::Sensitivity(Box::new(s)));
    }
    let machine_of = |p: &Point| {
        let mp = m
            .point
            .iter()
            .find(|q| q.index == p.index)
            .ok_or_else(|| crate::Error::invalid(format!("point {} is not in the manifest", p.index)))?;
        point_machine(dir, mp)
    };
    write_outputs(dir, &label, &base, &points, &machine_of)?;
    Ok(Collected::Complete(points))
}

/// Submits the tasks without a valid result that the scheduler does not hold as pending or running
/// (`missing_only`), or the whole array. `None` when there was nothing to submit (with a note).
pub fn submit_study(
    scheduler: &dyn Scheduler,
    dir: &Path,
    missing_only: bool,
    dry_run: bool,
    notes: &mut dyn FnMut(Note, &str),
) -> crate::Result<Option<Submitted>> {
    let m = load_manifest(dir)?;
    let dir = &std::fs::canonicalize(dir).unwrap_or(dir.to_path_buf());
    if !missing_only {
        return submit(scheduler, dir, &m, None, dry_run).map(Some);
    }
    let statuses = scan(dir, &m);
    let (missing, active) = resubmittable(scheduler, dir, &m, &statuses)?;
    if missing.is_empty() {
        notes(
            Note::Info,
            &format!(
                "nothing to submit: {} of {} tasks have results{}",
                m.tasks - active.len(),
                m.tasks,
                if active.is_empty() {
                    String::new()
                } else {
                    format!(", tasks {} are pending or running", array_spec(&active))
                }
            ),
        );
        return Ok(None);
    }
    submit(scheduler, dir, &m, Some(&missing), dry_run).map(Some)
}

/// Notes files in results/ that are no task's result (a task killed while writing leaves its
/// temporary file).
fn report_strays(dir: &Path, m: &Manifest, notes: &mut dyn FnMut(Note, &str)) {
    let Ok(entries) = std::fs::read_dir(dir.join("results")) else {
        return;
    };
    let names: BTreeSet<String> = (0..m.tasks).map(|k| format!("task-{k}.json")).collect();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !names.contains(&name) {
            notes(
                Note::Info,
                &format!(
                    "note: ignored {} (not a task's result: a partial write of a killed task?)",
                    e.path().display()
                ),
            );
        }
    }
}

/// Polls results/ (and the scheduler) every `interval` seconds, with a progress bar of points done,
/// until every point is done, no task of the study's jobs is pending or running, or the timeout.
/// When the scheduler cannot say which tasks are active (no `squeue`, or it fails), the end of the
/// tasks cannot be seen: without a timeout the watch stops at once, saying so; with one it waits for
/// results only, until the timeout.
fn watch(
    scheduler: &dyn Scheduler,
    dir: &Path,
    m: &Manifest,
    options: &CollectOptions,
    sleep: &dyn Fn(Duration),
    notes: &mut dyn FnMut(Note, &str),
) -> crate::Result<()> {
    let jobs = job_ids(dir)?;
    let mut blind_noted = false;
    let total = m.point.len() as u64;
    let bar = crate::progress::bar(total, "points done", options.progress);
    let start = Instant::now();
    let mut polls = 0u64;
    let mut done_tasks = vec![false; m.tasks];
    let mut shown = u64::MAX;
    let count = |done_tasks: &mut Vec<bool>| -> u64 {
        for (k, d) in done_tasks.iter_mut().enumerate() {
            if !*d {
                *d = matches!(read_result(dir, m, k), Status::Done(_));
            }
        }
        (0..m.tasks)
            .filter(|&k| done_tasks[k])
            .map(|k| m.points_of(k).count() as u64)
            .sum()
    };
    loop {
        let mut done = count(&mut done_tasks);
        let active = scheduler.active_tasks(&jobs, m.tasks);
        if active.is_none() && !blind_noted {
            blind_noted = true;
            let what = "watch: cannot ask Slurm which of the study's tasks are pending or running (squeue \
                        missing or failing)";
            match options.timeout {
                None => {
                    bar.suspend(|| {
                        notes(
                            Note::Problem,
                            &format!(
                                "{what}, so the end of the tasks cannot be seen: not watching (give \
                                      --timeout to wait for results without squeue)"
                            ),
                        )
                    });
                    break;
                }
                Some(t) => bar.suspend(|| {
                    notes(
                        Note::Problem,
                        &format!("{what}: waiting for results only, up to --timeout {t} s"),
                    )
                }),
            }
        }
        if done < total && active.as_ref().is_some_and(|a| a.is_empty()) {
            // The last task may have finished between the two looks.
            done = count(&mut done_tasks);
        }
        bar.set_position(done);
        if options.progress_lines && done != shown {
            notes(Note::Info, &format!("points done: {done}/{total}"));
            shown = done;
        }
        if done == total {
            break;
        }
        if active.as_ref().is_some_and(|a| a.is_empty()) {
            bar.suspend(|| {
                notes(
                    Note::Info,
                    &format!(
                    "watch: no task of the study's jobs is pending or running, {done}/{total} points done"
                ),
                )
            });
            break;
        }
        // The timeout counts both the wall clock and the polls' nominal intervals, so a scheduler
        // that never settles ends the watch even when `sleep` does not really wait.
        let waited = start.elapsed().as_secs_f64().max(polls as f64 * options.interval);
        if options.timeout.is_some_and(|t| waited >= t) {
            bar.suspend(|| {
                notes(
                    Note::Problem,
                    &format!("watch: timed out after {waited:.1} s with {done}/{total} points done"),
                )
            });
            break;
        }
        sleep(Duration::from_secs_f64(options.interval));
        polls += 1;
    }
    bar.finish_and_clear();
    Ok(())
}
