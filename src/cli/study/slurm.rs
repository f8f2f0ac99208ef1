//! `sism study --backend slurm` and `sism study run|collect|submit DIR`: a sweep written to a study
//! directory and replayed by a Slurm job array.
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
//! | `logs/task-K.out` | task K's output (Slurm writes it) |
//! | `results/task-K.json` | task K's points, tagged with the manifest's checksum (written to a temporary file and renamed, so a killed task leaves no partial result under this name) |
//!
//! Task K holds points `K·chunk .. (K+1)·chunk` (the last task fewer). `collect` accepts a result
//! only if its manifest checksum is this manifest's (else it is foreign: another study's, or an
//! older version of this one) and its points are the task's; the merged points go through the same
//! writer as the local backend's, so `study.csv` is the same bytes.

use std::collections::BTreeSet;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use sism::machine::records::{checksum, to_bytes};
use sism::machine::sweep;
use sism::machine::{self, CanonicalRecords, MachineConfig};

use super::{write_outputs, Label, Point};

/// The manifest format this sism writes and reads.
pub const FORMAT: &str = "sism-study 1";
/// The result-file format this sism writes and reads.
pub const RESULT_FORMAT: &str = "sism-study-result 1";
/// Points per array task unless `--chunk` says otherwise.
pub const DEFAULT_CHUNK: usize = 4;
/// Largest manifest or result file read, bytes.
const MAX_STUDY_FILE_BYTES: u64 = 256 << 20;

/// The Slurm backend's options of `sism study SCENE ... --backend slurm`.
#[derive(clap::Args, Debug, Default)]
pub struct JobArgs {
    /// (slurm) Points per array task [default: 4].
    #[arg(long)]
    chunk: Option<usize>,
    /// (slurm) The partition to submit to (`#SBATCH --partition`).
    #[arg(long)]
    partition: Option<String>,
    /// (slurm) Time limit of each array task, e.g. 00:10:00 (`#SBATCH --time`).
    #[arg(long)]
    time: Option<String>,
    /// (slurm) An extra `#SBATCH` line, e.g. "--mem=2G" (repeatable).
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    sbatch_args: Vec<String>,
    /// (slurm) Write the study directory and its script, do not submit.
    #[arg(long)]
    dry_run: bool,
}

impl JobArgs {
    /// With `--backend local`, the Slurm options are mistakes.
    pub fn reject_for_local(&self) -> anyhow::Result<()> {
        let given: Vec<&str> = [
            ("--chunk", self.chunk.is_some()),
            ("--partition", self.partition.is_some()),
            ("--time", self.time.is_some()),
            ("--sbatch-arg", !self.sbatch_args.is_empty()),
            ("--dry-run", self.dry_run),
        ]
        .into_iter()
        .filter_map(|(f, g)| g.then_some(f))
        .collect();
        anyhow::ensure!(
            given.is_empty(),
            "{} appl{} to --backend slurm only",
            given.join(", "),
            if given.len() == 1 { "ies" } else { "y" }
        );
        Ok(())
    }

    /// Checks the options before any work is done.
    pub fn check(&self, _points: usize) -> anyhow::Result<()> {
        anyhow::ensure!(self.chunk() >= 1, "--chunk must be at least 1");
        let one_line = |flag: &str, v: &str| {
            anyhow::ensure!(
                !v.trim().is_empty() && !v.contains(['\n', '\r']),
                "{flag} '{}': must be one non-empty line",
                v.escape_debug()
            );
            Ok(())
        };
        if let Some(p) = &self.partition {
            one_line("--partition", p)?;
            anyhow::ensure!(!p.contains(char::is_whitespace), "--partition '{p}': no spaces");
        }
        if let Some(t) = &self.time {
            one_line("--time", t)?;
            anyhow::ensure!(
                t.chars().all(|c| c.is_ascii_digit() || c == ':' || c == '-'),
                "--time '{t}': expected a Slurm time such as 00:10:00, 10 or 1-00:00:00"
            );
        }
        for s in &self.sbatch_args {
            one_line("--sbatch-arg", s)?;
        }
        Ok(())
    }

    fn chunk(&self) -> usize {
        self.chunk.unwrap_or(DEFAULT_CHUNK)
    }
}

#[derive(clap::Args)]
pub struct RunArgs {
    /// The study directory (written by `sism study ... --backend slurm`).
    dir: PathBuf,
    /// The array task to run (Slurm's $SLURM_ARRAY_TASK_ID).
    #[arg(long)]
    task: usize,
    /// Print nothing on success.
    #[arg(long)]
    quiet: bool,
}

#[derive(clap::Args)]
pub struct CollectArgs {
    /// The study directory.
    dir: PathBuf,
    /// Wait while the array runs, with a progress bar of points done, until every point is done,
    /// no task of the study's jobs is pending or running any more, or --timeout.
    #[arg(long)]
    watch: bool,
    /// Seconds between polls of results/ and squeue under --watch.
    #[arg(long, default_value_t = 5.0)]
    interval: f64,
    /// Stop watching after this many seconds (default: no limit).
    #[arg(long)]
    timeout: Option<f64>,
    /// Submit the tasks that have no valid result and are not pending or running (an array of only
    /// those ids), then collect (with --watch: wait for them).
    #[arg(long)]
    resubmit: bool,
    /// With --resubmit: print the sbatch command, do not submit.
    #[arg(long, requires = "resubmit")]
    dry_run: bool,
    /// Last lines of a missing task's log to show.
    #[arg(long, default_value_t = 5)]
    log_lines: usize,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

#[derive(clap::Args)]
pub struct SubmitArgs {
    /// The study directory.
    dir: PathBuf,
    /// Only the tasks without a valid result that are not pending or running.
    #[arg(long)]
    missing: bool,
    /// Print the sbatch command, do not submit.
    #[arg(long)]
    dry_run: bool,
}

/// What `sism study SCENE --backend slurm` hands to [`prepare_and_submit`].
pub struct Study<'a> {
    pub scene: &'a Path,
    pub label: &'a Label,
    pub algorithm: &'a str,
    pub params: &'a str,
    pub machine: &'a str,
    pub base: &'a MachineConfig,
    pub configs: &'a [MachineConfig],
    pub records: &'a CanonicalRecords,
}

/// `manifest.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    /// [`FORMAT`].
    format: String,
    /// Checksum of the manifest: of its TOML with this field empty, hex.
    checksum: String,
    /// The sism that wrote it.
    sism_version: String,
    /// The scene file, absolute.
    scene: String,
    /// The scene's name (file stem) and image size, for the plots.
    scene_name: String,
    width: u32,
    height: u32,
    algorithm: String,
    /// Every parameter of the algorithm, `key=value`, space-separated.
    params: String,
    /// `--machine` as given.
    machine: String,
    /// `machine.toml`'s checksum (the base machine).
    machine_checksum: String,
    /// `records.bin`'s size and checksum.
    records_bytes: u64,
    records_checksum: String,
    /// Points per array task.
    chunk: usize,
    /// Array tasks: ⌈points / chunk⌉.
    tasks: usize,
    /// The points, in sweep order.
    point: Vec<ManifestPoint>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestPoint {
    index: usize,
    task: usize,
    name: String,
    cores: u32,
    threads: u32,
    l2_kb: u32,
    /// `machines/point-NNNN.toml`.
    machine: String,
    /// Its checksum.
    machine_checksum: String,
}

/// `results/task-K.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TaskResult {
    /// [`RESULT_FORMAT`].
    format: String,
    /// The checksum of the manifest the task ran.
    manifest_checksum: String,
    task: usize,
    /// Where it ran and how long it took (facts only).
    host: String,
    seconds: f64,
    points: Vec<Point>,
}

fn hex(bytes: &[u8]) -> String {
    format!("{:016x}", checksum(bytes))
}

impl Manifest {
    /// The checksum of this manifest's content (every field but `checksum`).
    fn content_checksum(&self) -> String {
        let mut m = self.clone();
        m.checksum.clear();
        hex(toml::to_string(&m).expect("plain struct serialises").as_bytes())
    }

    fn points_of(&self, task: usize) -> impl Iterator<Item = &ManifestPoint> {
        self.point.iter().filter(move |p| p.task == task)
    }

    /// `a-b` (or `a`) of the task's point indices.
    fn span(&self, task: usize) -> String {
        let first = task * self.chunk;
        let last = ((task + 1) * self.chunk).min(self.point.len()) - 1;
        if first == last {
            format!("point {first}")
        } else {
            format!("points {first}-{last}")
        }
    }
}

fn manifest_path(dir: &Path) -> PathBuf {
    dir.join("manifest.toml")
}

fn result_path(dir: &Path, task: usize) -> PathBuf {
    dir.join("results").join(format!("task-{task}.json"))
}

fn log_path(dir: &Path, task: usize) -> PathBuf {
    dir.join("logs").join(format!("task-{task}.out"))
}

/// Reads and checks `DIR/manifest.toml`: present, TOML, the format this sism reads, every field,
/// the checksum, and the points' assignment to tasks.
fn load_manifest(dir: &Path) -> anyhow::Result<Manifest> {
    let path = manifest_path(dir);
    let p = path.display();
    let text = match sism::input::read_text(&path, "study manifest", MAX_STUDY_FILE_BYTES) {
        Ok(t) => t,
        Err(e) => anyhow::bail!(
            "{e} ({} is not a study directory written by `sism study SCENE --backend slurm`?)",
            dir.display()
        ),
    };
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("study manifest {p}: not valid TOML: {}", e.message()))?;
    match table.get("format") {
        None => anyhow::bail!("study manifest {p}: no `format` key: not a sism study manifest"),
        Some(toml::Value::String(f)) if f == FORMAT => {}
        Some(f) => anyhow::bail!(
            "study manifest {p}: format {f} is not the one this sism reads (\"{FORMAT}\"): write the study \
             again with this sism, or use the sism that wrote it"
        ),
    }
    let m: Manifest = toml::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "study manifest {p}: {}",
            e.to_string().trim_end().replace('\n', " ")
        )
    })?;
    let sum = m.content_checksum();
    anyhow::ensure!(
        m.checksum == sum,
        "study manifest {p}: checksum mismatch (the file says {}, its content gives {sum}): the manifest \
         was edited or is corrupt; write the study again",
        m.checksum
    );
    anyhow::ensure!(!m.point.is_empty(), "study manifest {p}: no point");
    anyhow::ensure!(
        m.chunk >= 1,
        "study manifest {p}: chunk {} must be at least 1",
        m.chunk
    );
    anyhow::ensure!(
        m.tasks == m.point.len().div_ceil(m.chunk),
        "study manifest {p}: {} tasks for {} points of chunk {} (expected {})",
        m.tasks,
        m.point.len(),
        m.chunk,
        m.point.len().div_ceil(m.chunk)
    );
    for (i, pt) in m.point.iter().enumerate() {
        anyhow::ensure!(
            pt.index == i && pt.task == i / m.chunk,
            "study manifest {p}: point {i} ({}) says index {} task {} (expected index {i} task {})",
            pt.name,
            pt.index,
            pt.task,
            i / m.chunk
        );
        anyhow::ensure!(
            pt.machine == format!("machines/point-{i:04}.toml"),
            "study manifest {p}: point {i}'s machine file `{}` is not machines/point-{i:04}.toml",
            pt.machine
        );
    }
    Ok(m)
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that a
/// reader never sees a partial file under `path`.
fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let name = path.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    };
    write().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow::anyhow!("cannot write {}: {e}", path.display())
    })
}

fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    std::fs::write(path, bytes).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))
}

fn mkdir(path: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(path).map_err(|e| anyhow::anyhow!("cannot create folder {}: {e}", path.display()))
}

/// Removes the files in `dir` whose names `stale` picks (results, logs and machine files of an
/// earlier study written to the same directory); how many.
fn remove_stale(dir: &Path, stale: impl Fn(&str) -> bool) -> anyhow::Result<usize> {
    let mut n = 0;
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(0);
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if stale(&name) && e.path().is_file() {
            std::fs::remove_file(e.path())
                .map_err(|err| anyhow::anyhow!("cannot remove stale {}: {err}", e.path().display()))?;
            n += 1;
        }
    }
    Ok(n)
}

/// `'text'` for a POSIX shell.
fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-=:,+@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// `0-3,5,7-8`: task ids compressed into Slurm's array syntax.
fn array_spec(tasks: &[usize]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        out.push(if j > i + 1 {
            format!("{}-{}", tasks[i], tasks[j])
        } else if j == i + 1 {
            format!("{},{}", tasks[i], tasks[j])
        } else {
            tasks[i].to_string()
        });
        i = j + 1;
    }
    out.join(",")
}

/// Writes the study directory for `s` into `out` and, unless `--dry-run`, submits its array.
pub fn prepare_and_submit(out: &Path, s: &Study, job: &JobArgs, quiet: bool) -> anyhow::Result<()> {
    let dir =
        std::fs::canonicalize(out).map_err(|e| anyhow::anyhow!("cannot resolve {}: {e}", out.display()))?;
    for sub in ["machines", "results", "logs"] {
        mkdir(&dir.join(sub))?;
    }
    let stale = remove_stale(&dir.join("results"), |n| {
        n.starts_with("task-") || n.starts_with(".task-")
    })? + remove_stale(&dir.join("logs"), |n| n.starts_with("task-"))?
        + remove_stale(&dir.join("machines"), |n| n.starts_with("point-"))?
        + remove_stale(&dir, |n| ["study.csv", "speedup.png", "phases.png"].contains(&n))?;
    if stale > 0 && !quiet {
        eprintln!("removed {stale} files of an earlier study in {}", dir.display());
    }
    let records = to_bytes(s.records);
    write(&dir.join("records.bin"), &records)?;
    let base = s.base.to_toml();
    write(&dir.join("machine.toml"), base.as_bytes())?;
    let chunk = job.chunk();
    let mut points = Vec::with_capacity(s.configs.len());
    for (i, c) in s.configs.iter().enumerate() {
        let text = c.to_toml();
        // The replay must see exactly this configuration: check that the file reads back as it.
        let back = MachineConfig::from_toml(&text, &c.name).map_err(|e| {
            anyhow::anyhow!("point {i} ({}): its machine file does not read back: {e}", c.name)
        })?;
        anyhow::ensure!(
            &back == c,
            "point {i} ({}): its machine file does not read back as the same configuration",
            c.name
        );
        let rel = format!("machines/point-{i:04}.toml");
        write(&dir.join(&rel), text.as_bytes())?;
        points.push(ManifestPoint {
            index: i,
            task: i / chunk,
            name: c.name.clone(),
            cores: c.cores,
            threads: c.threads_per_core,
            l2_kb: c.l2_kb,
            machine: rel,
            machine_checksum: hex(text.as_bytes()),
        });
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
        point: points,
    };
    m.checksum = m.content_checksum();
    let text = format!(
        "# sism study manifest: written by `sism study --backend slurm`, read by `sism study run|collect|submit`.\n\
         # Do not edit: the checksum covers every value below.\n{}",
        toml::to_string(&m).expect("plain struct serialises")
    );
    write_atomic(&manifest_path(&dir), text.as_bytes())?;
    let script = sbatch_script(&dir, &m, job)?;
    write(&dir.join("study.sbatch"), script.as_bytes())?;
    if !quiet {
        eprintln!(
            "wrote {}: {} points in {} array tasks of up to {chunk}",
            dir.display(),
            m.point.len(),
            m.tasks
        );
    }
    if job.dry_run {
        if !quiet {
            eprintln!(
                "dry run: not submitted; submit with `sism study submit {0}` (or `sbatch {0}/study.sbatch`), \
                 then `sism study collect {0} --watch`",
                dir.display()
            );
        }
        return Ok(());
    }
    submit(&dir, &m, None, false, quiet)
}

/// `study.sbatch`: the job array over every task of `m`.
fn sbatch_script(dir: &Path, m: &Manifest, job: &JobArgs) -> anyhow::Result<String> {
    let exe = std::env::current_exe()
        .and_then(std::fs::canonicalize)
        .context("cannot find this sism's executable for the job script")?;
    let d = dir.display().to_string();
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
        m.scene_name,
        m.machine,
        m.tasks,
        m.chunk,
        m.tasks - 1,
    );
    anyhow::ensure!(
        !d.contains(char::is_whitespace),
        "the study directory {d} has a space in its path, which #SBATCH lines cannot hold: choose another --out"
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
        shell_quote(&exe.display().to_string()),
        shell_quote(&d)
    );
    Ok(s)
}

/// The cluster's `MaxArraySize` from `scontrol show config` (None when scontrol is absent or
/// does not say).
fn max_array_size() -> Option<usize> {
    let out = Command::new("scontrol").args(["show", "config"]).output().ok()?;
    if !out.status.success() {
        return None;
    }
    parse_max_array_size(&String::from_utf8_lossy(&out.stdout))
}

/// `MaxArraySize` from the text of `scontrol show config`.
fn parse_max_array_size(config: &str) -> Option<usize> {
    config.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "MaxArraySize")
            .then(|| v.trim().parse().ok())
            .flatten()
    })
}

/// Submits the study's array (all of it, or only `tasks`) with `sbatch`; appends the job id to
/// `jobs.txt`. `dry_run`: prints the command instead.
fn submit(
    dir: &Path,
    m: &Manifest,
    tasks: Option<&[usize]>,
    dry_run: bool,
    quiet: bool,
) -> anyhow::Result<()> {
    let script = dir.join("study.sbatch");
    anyhow::ensure!(
        script.is_file(),
        "{} is missing: write the study again with `sism study SCENE --backend slurm`",
        script.display()
    );
    let spec = match tasks {
        Some(t) => array_spec(t),
        None => array_spec(&(0..m.tasks).collect::<Vec<_>>()),
    };
    let mut args = vec!["--parsable".to_string()];
    if tasks.is_some() {
        args.push(format!("--array={spec}"));
    }
    args.push(script.display().to_string());
    // Slurm refuses array indices at or past its MaxArraySize (1001 by default): say what to do.
    let highest = tasks
        .and_then(|t| t.iter().max().copied())
        .unwrap_or(m.tasks.saturating_sub(1));
    if let Some(max) = max_array_size() {
        anyhow::ensure!(
            highest < max,
            "this study's array reaches task {highest}, but the cluster's MaxArraySize is {max} \
             (indices 0..{max}): write it again with a larger --chunk (at least {}), or ask the \
             administrators to raise MaxArraySize",
            m.point.len().div_ceil(max.max(1))
        );
    }
    if dry_run {
        let line: Vec<String> = std::iter::once("sbatch".to_string())
            .chain(args.iter().map(|a| shell_quote(a)))
            .collect();
        super::print_stdout(&format!("dry run: would submit tasks {spec}: {}", line.join(" ")))?;
        return Ok(());
    }
    let out = match Command::new("sbatch").args(&args).output() {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => anyhow::bail!(
            "sbatch not found on PATH: is Slurm's client installed here? The study directory {} is \
             written: submit it from a machine with Slurm (`sism study submit {}`), or run its tasks \
             here with `sism study run {} --task K` for K in 0..{}",
            dir.display(),
            dir.display(),
            dir.display(),
            m.tasks
        ),
        Err(e) => anyhow::bail!("cannot run sbatch: {e}"),
    };
    anyhow::ensure!(
        out.status.success(),
        "sbatch {} failed ({}): {}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stderr).trim()
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let id = stdout.trim().split(';').next().unwrap_or("").trim().to_string();
    anyhow::ensure!(
        !id.is_empty() && id.chars().all(|c| c.is_ascii_digit()),
        "sbatch printed no job id (stdout: {:?})",
        stdout.trim()
    );
    let jobs = dir.join("jobs.txt");
    let when = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&jobs)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", jobs.display()))?;
    writeln!(f, "{id} array={spec} submitted={when}")
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", jobs.display()))?;
    if !quiet {
        eprintln!(
            "submitted job {id}: tasks {spec}; follow with `sism study collect {} --watch`",
            dir.display()
        );
    }
    Ok(())
}

/// The job ids in `jobs.txt` (none if it is absent).
fn job_ids(dir: &Path) -> BTreeSet<String> {
    std::fs::read_to_string(dir.join("jobs.txt"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|id| id.chars().all(|c| c.is_ascii_digit()))
        .map(str::to_string)
        .collect()
}

/// The array tasks of `jobs` that Slurm still holds as pending or running (`squeue`), by task id,
/// with the job id; `None` when squeue is absent or fails (unknown).
fn active_tasks(jobs: &BTreeSet<String>, tasks: usize) -> Option<Vec<(usize, String)>> {
    if jobs.is_empty() {
        return Some(Vec::new());
    }
    let out = Command::new("squeue")
        .args(["-h", "-r", "-o", "%F %K %T"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let mut active = Vec::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        let [job, task, state] = f[..] else { continue };
        if !jobs.contains(job) || matches!(state, "COMPLETED" | "FAILED" | "CANCELLED" | "TIMEOUT") {
            continue;
        }
        if let Ok(t) = task.parse::<usize>() {
            active.push((t, job.to_string()));
        } else {
            // A whole array not split into tasks yet: all of them.
            active.extend((0..tasks).map(|t| (t, job.to_string())));
        }
    }
    Some(active)
}

/// Runs one array task: replays its points on their machines and writes `results/task-K.json`.
pub fn run_task(a: RunArgs) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let dir = &a.dir;
    let m = load_manifest(dir)?;
    anyhow::ensure!(
        a.task < m.tasks,
        "--task {}: out of range: {} has {} tasks (0-{})",
        a.task,
        manifest_path(dir).display(),
        m.tasks,
        m.tasks - 1
    );
    let points: Vec<&ManifestPoint> = m.points_of(a.task).collect();
    let mut configs = Vec::with_capacity(points.len());
    for p in &points {
        let path = dir.join(&p.machine);
        let text = sism::input::read_text(&path, "machine file", sism::input::MAX_TEXT_BYTES)?;
        anyhow::ensure!(
            hex(text.as_bytes()) == p.machine_checksum,
            "machine file {}: its checksum {} is not the manifest's {}: the file was edited or replaced",
            path.display(),
            hex(text.as_bytes()),
            p.machine_checksum
        );
        let c = MachineConfig::from_toml(&text, &p.name)
            .map_err(|e| anyhow::anyhow!("machine file {}: {e}", path.display()))?;
        anyhow::ensure!(
            c.name == p.name && c.cores == p.cores && c.threads_per_core == p.threads && c.l2_kb == p.l2_kb,
            "machine file {}: not the manifest's point {} ({})",
            path.display(),
            p.index,
            p.name
        );
        configs.push(c);
    }
    let path = dir.join("records.bin");
    let bytes = sism::input::read_file(&path, "records file", sism::input::MAX_RECORDS_BYTES)?;
    let records = machine::parse_records(&bytes)
        .map_err(|e| anyhow::anyhow!("records file {}: {e}", path.display()))?;
    anyhow::ensure!(
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
        task: a.task,
        host: std::fs::read_to_string("/proc/sys/kernel/hostname")
            .map(|h| h.trim().to_string())
            .unwrap_or_default(),
        seconds: t0.elapsed().as_secs_f64(),
        points: swept
            .iter()
            .zip(&points)
            .map(|(s, p)| Point::new(p.index, s))
            .collect(),
    };
    let out = result_path(dir, a.task);
    mkdir(out.parent().expect("results/"))?;
    let json = serde_json::to_vec(&result).expect("plain struct serialises");
    write_atomic(&out, &json)?;
    if !a.quiet {
        eprintln!(
            "task {}: {} in {:.2} s: wrote {}",
            a.task,
            m.span(a.task),
            t0.elapsed().as_secs_f64(),
            out.display()
        );
    }
    Ok(())
}

/// What a task's result file holds.
#[derive(Debug)]
enum Status {
    Done(Vec<Point>),
    /// No result file.
    Missing,
    /// Written for another manifest (its checksum).
    Foreign(String),
    /// Unreadable or not this task's (what is wrong).
    Bad(String),
}

fn read_result(dir: &Path, m: &Manifest, task: usize) -> Status {
    let path = result_path(dir, task);
    if !path.exists() {
        return Status::Missing;
    }
    let bytes = match sism::input::read_file(&path, "task result", MAX_STUDY_FILE_BYTES) {
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
    Status::Done(r.points)
}

/// The last `n` lines of `path` (at most its last 64 KB), if it can be read.
fn tail(path: &Path, n: usize) -> Option<Vec<String>> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = std::fs::File::open(path).ok()?;
    let len = f.metadata().ok()?.len();
    f.seek(SeekFrom::Start(len.saturating_sub(64 << 10))).ok()?;
    let mut b = Vec::new();
    f.read_to_end(&mut b).ok()?;
    let text = String::from_utf8_lossy(&b);
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    Some(lines[lines.len().saturating_sub(n)..].to_vec())
}

/// Task ids without a valid result among `statuses`.
fn incomplete(statuses: &[Status]) -> Vec<usize> {
    statuses
        .iter()
        .enumerate()
        .filter(|(_, s)| !matches!(s, Status::Done(_)))
        .map(|(k, _)| k)
        .collect()
}

fn scan(dir: &Path, m: &Manifest) -> Vec<Status> {
    (0..m.tasks).map(|k| read_result(dir, m, k)).collect()
}

/// The incomplete tasks that Slurm does not hold as pending or running.
fn resubmittable(dir: &Path, m: &Manifest, statuses: &[Status]) -> (Vec<usize>, Vec<usize>) {
    let active = active_tasks(&job_ids(dir), m.tasks).unwrap_or_default();
    incomplete(statuses)
        .into_iter()
        .partition(|k| !active.iter().any(|(t, _)| t == k))
}

/// `sism study submit DIR [--missing] [--dry-run]`.
pub fn submit_cmd(a: SubmitArgs) -> anyhow::Result<()> {
    let m = load_manifest(&a.dir)?;
    let dir = std::fs::canonicalize(&a.dir).unwrap_or(a.dir.clone());
    if !a.missing {
        return submit(&dir, &m, None, a.dry_run, false);
    }
    let statuses = scan(&dir, &m);
    let (missing, active) = resubmittable(&dir, &m, &statuses);
    if missing.is_empty() {
        eprintln!(
            "nothing to submit: {} of {} tasks have results{}",
            m.tasks - active.len(),
            m.tasks,
            if active.is_empty() {
                String::new()
            } else {
                format!(", tasks {} are pending or running", array_spec(&active))
            }
        );
        return Ok(());
    }
    submit(&dir, &m, Some(&missing), a.dry_run, false)
}

/// `sism study collect DIR`: see [`CollectArgs`].
pub fn collect(a: CollectArgs) -> anyhow::Result<()> {
    let m = load_manifest(&a.dir)?;
    let dir = std::fs::canonicalize(&a.dir).unwrap_or(a.dir.clone());
    anyhow::ensure!(
        a.interval.is_finite() && a.interval > 0.0,
        "--interval {}: must be a positive number of seconds",
        a.interval
    );
    if let Some(t) = a.timeout {
        anyhow::ensure!(
            t.is_finite() && t >= 0.0,
            "--timeout {t}: must be a number of seconds"
        );
    }
    if a.resubmit {
        let statuses = scan(&dir, &m);
        let (missing, active) = resubmittable(&dir, &m, &statuses);
        if missing.is_empty() {
            if !active.is_empty() && !a.quiet {
                eprintln!(
                    "nothing to resubmit: tasks {} are pending or running",
                    array_spec(&active)
                );
            }
        } else {
            submit(&dir, &m, Some(&missing), a.dry_run, a.quiet)?;
            if a.dry_run {
                return Ok(());
            }
            if !a.watch {
                if !a.quiet {
                    eprintln!(
                        "collect again when they are done (`sism study collect {} --watch` waits)",
                        dir.display()
                    );
                }
                return Ok(());
            }
        }
    }
    if a.watch {
        watch(&dir, &m, a.interval, a.timeout, a.quiet);
    }
    let statuses = scan(&dir, &m);
    report_strays(&dir, &m, a.quiet);
    let missing = incomplete(&statuses);
    if !missing.is_empty() {
        let active = active_tasks(&job_ids(&dir), m.tasks).unwrap_or_default();
        let mut points = 0;
        for &k in &missing {
            points += m.points_of(k).count();
            let result = result_path(&dir, k);
            let what = match &statuses[k] {
                Status::Missing => format!("missing: no {}", result.display()),
                Status::Foreign(c) => format!(
                    "foreign result rejected: {} was written for another study (manifest checksum {c}, this \
                     study's is {})",
                    result.display(),
                    m.checksum
                ),
                Status::Bad(e) => format!("failed: {}: {e}", result.display()),
                Status::Done(_) => unreachable!(),
            };
            let mut s = format!("task {k} ({}): {what}", m.span(k));
            if let Some((_, job)) = active.iter().find(|(t, _)| *t == k) {
                s += &format!("; pending or running as job {job}");
            }
            let log = log_path(&dir, k);
            match tail(&log, a.log_lines) {
                Some(lines) if lines.is_empty() => s += &format!("\n  log {}: empty", log.display()),
                Some(lines) => {
                    s += &format!("\n  log {} ends:", log.display());
                    for l in lines {
                        s += &format!("\n  | {l}");
                    }
                }
                None => s += &format!("\n  no log {} (not run by Slurm yet)", log.display()),
            }
            eprintln!("{s}");
        }
        let spec = array_spec(&missing);
        anyhow::bail!(
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
    let base_text = sism::input::read_text(&base_path, "machine file", sism::input::MAX_TEXT_BYTES)?;
    anyhow::ensure!(
        hex(base_text.as_bytes()) == m.machine_checksum,
        "machine file {}: its checksum is not the manifest's: the file was edited or replaced",
        base_path.display()
    );
    let base = MachineConfig::from_toml(&base_text, "base")
        .map_err(|e| anyhow::anyhow!("machine file {}: {e}", base_path.display()))?;
    let label = Label {
        name: m.scene_name.clone(),
        width: m.width,
        height: m.height,
    };
    write_outputs(&dir, &label, &base, &points, a.quiet)
}

/// Notes files in results/ that are no task's result (a task killed while writing leaves its
/// temporary file).
fn report_strays(dir: &Path, m: &Manifest, quiet: bool) {
    if quiet {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir.join("results")) else {
        return;
    };
    let names: BTreeSet<String> = (0..m.tasks).map(|k| format!("task-{k}.json")).collect();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !names.contains(&name) {
            eprintln!(
                "note: ignored {} (not a task's result: a partial write of a killed task?)",
                e.path().display()
            );
        }
    }
}

/// Polls results/ (and squeue) every `interval` seconds, with a progress bar of points done, until
/// every point is done, no task of the study's jobs is pending or running, or `timeout`.
fn watch(dir: &Path, m: &Manifest, interval: f64, timeout: Option<f64>, quiet: bool) {
    let total = m.point.len() as u64;
    let bar = sism::progress::bar(total, "points done", !quiet);
    let text = !quiet && !std::io::stderr().is_terminal();
    let start = Instant::now();
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
        let active = active_tasks(&job_ids(dir), m.tasks);
        if done < total && active.as_ref().is_some_and(|a| a.is_empty()) {
            // The last task may have finished between the two looks.
            done = count(&mut done_tasks);
        }
        bar.set_position(done);
        if text && done != shown {
            eprintln!("points done: {done}/{total}");
            shown = done;
        }
        if done == total {
            break;
        }
        if active.as_ref().is_some_and(|a| a.is_empty()) {
            if !quiet {
                bar.suspend(|| {
                    eprintln!("watch: no task of the study's jobs is pending or running, {done}/{total} points done")
                });
            }
            break;
        }
        if timeout.is_some_and(|t| start.elapsed().as_secs_f64() >= t) {
            bar.suspend(|| {
                eprintln!(
                    "watch: timed out after {:.1} s with {done}/{total} points done",
                    start.elapsed().as_secs_f64()
                )
            });
            break;
        }
        std::thread::sleep(Duration::from_secs_f64(interval));
    }
    bar.finish_and_clear();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_specs_compress_runs() {
        assert_eq!(array_spec(&[0, 1, 2, 3, 4, 5]), "0-5");
        assert_eq!(array_spec(&[1, 4]), "1,4");
        assert_eq!(array_spec(&[1, 2, 4, 6, 7, 8]), "1,2,4,6-8");
        assert_eq!(array_spec(&[3]), "3");
    }

    #[test]
    fn max_array_size_is_read_from_scontrol() {
        let config = "Configuration data as of 2026-12-02T14:00:00\nMailProg                = /bin/mail\n\
                      MaxArraySize            = 1001\nMaxJobCount             = 10000\n";
        assert_eq!(parse_max_array_size(config), Some(1001));
        assert_eq!(parse_max_array_size("MaxJobCount = 5\n"), None);
        assert_eq!(parse_max_array_size("MaxArraySize = lots\n"), None);
    }

    #[test]
    fn shell_quoting() {
        assert_eq!(shell_quote("/a/b-c_d.e"), "/a/b-c_d.e");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
    }
}
