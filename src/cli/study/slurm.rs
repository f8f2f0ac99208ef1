//! `sism study --backend slurm` and `sism study run|collect|submit DIR`: the flags, and what is
//! printed. The study directory, its tasks and the collect state machine are the library's
//! ([`sism::study::slurm`]); the scheduler is Slurm's clients ([`sism::study::scheduler::Slurm`]).

use std::io::IsTerminal;
use std::path::PathBuf;

use sism::study::scheduler::Slurm;
use sism::study::slurm::{
    self, CollectOptions, Collected, JobOptions, Note, Study, Submitted, DEFAULT_CHUNK,
};

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

    /// The library's job options.
    pub fn options(&self) -> JobOptions {
        JobOptions {
            chunk: self.chunk.unwrap_or(DEFAULT_CHUNK),
            partition: self.partition.clone(),
            time: self.time.clone(),
            sbatch_args: self.sbatch_args.clone(),
            dry_run: self.dry_run,
            executable: None,
        }
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

/// Prints the state machine's notes on stderr (only problems when `quiet`).
fn notes(quiet: bool) -> impl FnMut(Note, &str) {
    move |kind, line| {
        if !quiet || kind == Note::Problem {
            note!("{line}");
        }
    }
}

/// Prints what [`slurm::submit`] did.
fn report_submitted(s: &Submitted, dir: &std::path::Path, quiet: bool) -> anyhow::Result<()> {
    match s {
        Submitted::DryRun { tasks, command } => {
            super::print_stdout(&format!("dry run: would submit tasks {tasks}: {command}"))
        }
        Submitted::Job { id, tasks } => {
            if !quiet {
                note!(
                    "submitted job {id}: tasks {tasks}; follow with `sism study collect {} --watch`",
                    dir.display()
                );
            }
            Ok(())
        }
    }
}

/// Writes the study directory for `s` into `out` and, unless `--dry-run`, submits its array.
pub fn prepare_and_submit(
    out: &std::path::Path,
    s: &Study,
    job: &JobArgs,
    quiet: bool,
) -> anyhow::Result<()> {
    let options = job.options();
    let (dir, m) = slurm::prepare(out, s, &options, &mut notes(quiet))?;
    if options.dry_run {
        if !quiet {
            note!(
                "dry run: not submitted; submit with `sism study submit {0}` (or `sbatch {0}/study.sbatch`), \
                 then `sism study collect {0} --watch`",
                dir.display()
            );
        }
        return Ok(());
    }
    let submitted = slurm::submit(&Slurm, &dir, &m, None, false)?;
    report_submitted(&submitted, &dir, quiet)
}

/// `sism study run DIR --task K`.
pub fn run_task(a: RunArgs) -> anyhow::Result<()> {
    let run = slurm::run_task(&a.dir, a.task)?;
    if !a.quiet {
        note!(
            "task {}: {} in {:.2} s: wrote {}",
            a.task,
            run.span,
            run.seconds,
            run.result.display()
        );
    }
    Ok(())
}

/// `sism study submit DIR [--missing] [--dry-run]`.
pub fn submit_cmd(a: SubmitArgs) -> anyhow::Result<()> {
    let dir = std::fs::canonicalize(&a.dir).unwrap_or(a.dir.clone());
    match slurm::submit_study(&Slurm, &a.dir, a.missing, a.dry_run, &mut notes(false))? {
        Some(s) => report_submitted(&s, &dir, false),
        None => Ok(()),
    }
}

/// `sism study collect DIR`: see [`CollectArgs`].
pub fn collect(a: CollectArgs) -> anyhow::Result<()> {
    let options = CollectOptions {
        watch: a.watch,
        interval: a.interval,
        timeout: a.timeout,
        resubmit: a.resubmit,
        dry_run: a.dry_run,
        log_lines: a.log_lines,
        progress: !a.quiet,
        progress_lines: !a.quiet && !std::io::stderr().is_terminal(),
    };
    let sleep = |d: std::time::Duration| std::thread::sleep(d);
    match slurm::collect(&Slurm, &a.dir, &options, &sleep, &mut notes(a.quiet))? {
        Collected::Complete(points) => {
            if !a.quiet {
                super::print_stdout(&sism::study::table(&points))?;
                let dir = std::fs::canonicalize(&a.dir).unwrap_or(a.dir.clone());
                note!("wrote {}", dir.display());
            }
            Ok(())
        }
        Collected::Sensitivity(s) => {
            if !a.quiet {
                super::print_stdout(&sism::study::sensitivity::table(&s))?;
                super::print_stdout(sism::study::sensitivity::verdict(&s).trim_end())?;
                let dir = std::fs::canonicalize(&a.dir).unwrap_or(a.dir.clone());
                note!("wrote {}", dir.display());
            }
            Ok(())
        }
        Collected::DryRun(s) => report_submitted(&s, &a.dir, a.quiet),
        Collected::Resubmitted(_) => Ok(()),
    }
}
