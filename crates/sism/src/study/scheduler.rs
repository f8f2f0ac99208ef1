//! Where a study directory's array tasks run: a [`Scheduler`] submits an array of task ids, says
//! which tasks of its jobs are still pending or running, and what array indices it accepts.
//! [`Slurm`] does it with `sbatch`, `squeue` and `scontrol`; [`Local`] runs the tasks at once in
//! this process (no cluster needed). The study's state machine ([`super::slurm`]) sees only the
//! trait, so its tests drive it with a scheduler of their own.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicU64, Ordering};

/// A batch scheduler of job arrays.
pub trait Scheduler {
    /// Submits the job script `script` of a study directory as an array of the task ids `tasks`
    /// (ascending; `whole`: they are all of the script's tasks); returns the job id (decimal digits).
    fn submit(&self, script: &Path, tasks: &[usize], whole: bool) -> crate::Result<String>;

    /// The tasks of the jobs `jobs` that are still pending or running, by task id, with their job
    /// id; `None` when the scheduler cannot say (its client is missing or failed).
    fn active_tasks(&self, jobs: &BTreeSet<String>, tasks: usize) -> Option<Vec<(usize, String)>>;

    /// The largest array index + 1 the scheduler accepts, if it limits it.
    fn max_array_size(&self) -> Option<usize>;

    /// The command line [`Scheduler::submit`] would run (for a dry run).
    fn submit_command(&self, script: &Path, tasks: &[usize], whole: bool) -> Vec<String>;
}

/// Slurm, through its command-line clients on `PATH`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Slurm;

impl Slurm {
    fn sbatch_args(script: &Path, tasks: &[usize], all: bool) -> Vec<String> {
        let mut args = vec!["--parsable".to_string()];
        if !all {
            args.push(format!("--array={}", array_spec(tasks)));
        }
        args.push(script.display().to_string());
        args
    }
}

impl Scheduler for Slurm {
    fn submit(&self, script: &Path, tasks: &[usize], whole: bool) -> crate::Result<String> {
        let args = Slurm::sbatch_args(script, tasks, whole);
        let dir = script.parent().unwrap_or(Path::new("."));
        let out = match Command::new("sbatch").args(&args).output() {
            Ok(o) => o,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(crate::Error::External(format!(
                    "sbatch not found on PATH: is Slurm's client installed here? The study directory {d} is \
                     written: submit it from a machine with Slurm (`sism study submit {d}`), or run its tasks \
                     here with `sism study run {d} --task K` for K in {}",
                    array_spec(tasks),
                    d = dir.display(),
                )))
            }
            Err(e) => return Err(crate::Error::External(format!("cannot run sbatch: {e}"))),
        };
        if !out.status.success() {
            return Err(crate::Error::External(format!(
                "sbatch {} failed ({}): {}",
                args.join(" "),
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            )));
        }
        let stdout = String::from_utf8_lossy(&out.stdout);
        let id = stdout.trim().split(';').next().unwrap_or("").trim().to_string();
        if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
            return Err(crate::Error::External(format!(
                "sbatch printed no job id (stdout: {:?})",
                stdout.trim()
            )));
        }
        Ok(id)
    }

    fn active_tasks(&self, jobs: &BTreeSet<String>, tasks: usize) -> Option<Vec<(usize, String)>> {
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
        Some(parse_squeue(&String::from_utf8_lossy(&out.stdout), jobs, tasks))
    }

    fn max_array_size(&self) -> Option<usize> {
        let out = Command::new("scontrol").args(["show", "config"]).output().ok()?;
        if !out.status.success() {
            return None;
        }
        parse_max_array_size(&String::from_utf8_lossy(&out.stdout))
    }

    fn submit_command(&self, script: &Path, tasks: &[usize], whole: bool) -> Vec<String> {
        std::iter::once("sbatch".to_string())
            .chain(Slurm::sbatch_args(script, tasks, whole))
            .collect()
    }
}

/// The tasks of `jobs` that `squeue -h -r -o "%F %K %T"`'s output holds as not finished.
pub fn parse_squeue(text: &str, jobs: &BTreeSet<String>, tasks: usize) -> Vec<(usize, String)> {
    let mut active = Vec::new();
    for line in text.lines() {
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
    active
}

/// `MaxArraySize` from the text of `scontrol show config`.
pub fn parse_max_array_size(config: &str) -> Option<usize> {
    config.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "MaxArraySize")
            .then(|| v.trim().parse().ok())
            .flatten()
    })
}

/// Runs each submitted task at once, in this process, one after the other (`sism study run`'s
/// work): a study directory completed without a cluster. Its jobs are never pending.
#[derive(Debug, Default)]
pub struct Local {
    next_job: AtomicU64,
}

impl Scheduler for Local {
    fn submit(&self, script: &Path, tasks: &[usize], _whole: bool) -> crate::Result<String> {
        let dir = script.parent().unwrap_or(Path::new("."));
        for &k in tasks {
            super::slurm::run_task(dir, k)?;
        }
        Ok((self.next_job.fetch_add(1, Ordering::Relaxed) + 1).to_string())
    }

    fn active_tasks(&self, _jobs: &BTreeSet<String>, _tasks: usize) -> Option<Vec<(usize, String)>> {
        Some(Vec::new())
    }

    fn max_array_size(&self) -> Option<usize> {
        None
    }

    fn submit_command(&self, script: &Path, tasks: &[usize], _whole: bool) -> Vec<String> {
        let dir = script.parent().unwrap_or(Path::new(".")).display().to_string();
        tasks
            .iter()
            .map(|k| format!("sism study run {} --task {k}", shell_quote(&dir)))
            .collect()
    }
}

/// `'text'` for a POSIX shell.
pub fn shell_quote(s: &str) -> String {
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
pub fn array_spec(tasks: &[usize]) -> String {
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
    fn squeue_lines_name_active_tasks() {
        let jobs: BTreeSet<String> = ["12".to_string()].into();
        let text = "12 0 RUNNING\n12 1 COMPLETED\n13 2 RUNNING\n12 [3-4] PENDING\nbad line\n";
        assert_eq!(
            parse_squeue(text, &jobs, 5),
            vec![
                (0, "12".into()),
                (0, "12".into()),
                (1, "12".into()),
                (2, "12".into()),
                (3, "12".into()),
                (4, "12".into())
            ]
        );
    }

    #[test]
    fn shell_quoting() {
        assert_eq!(shell_quote("/a/b-c_d.e"), "/a/b-c_d.e");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
    }
}
