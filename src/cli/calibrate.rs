//! `sism calibrate`: the host preset's costs fitted to microbenchmarks; writes the machine file.

use std::path::{Path, PathBuf};

use sism::host::calibrate;

use super::{create_dir, print_stdout, write_file};

#[derive(clap::Args)]
pub struct Args {
    /// The fitted machine file to write (TOML; use it with `--machine`).
    #[arg(long, default_value = "out/host.toml")]
    out: PathBuf,
    /// Passes over the whole benchmark list (1..=9, `calibrate::MAX_ROUNDS`): each benchmark's host time is the median of
    /// its passes, taken tens of seconds apart, so one slow moment of a shared host does not make
    /// one cost dear. Three passes take about a minute on the project's 2-core VM.
    #[arg(long, default_value_t = calibrate::DEFAULT_ROUNDS)]
    rounds: usize,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    check_rounds("--rounds", a.rounds)?;
    let facts = sism::host::facts();
    let backend = facts.backend;
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        create_dir(dir)?;
    }
    let bar = sism::progress::bar(
        calibrate::calibrate_host_steps(a.rounds),
        "microbenchmarks",
        !a.quiet,
    );
    let fitted = calibrate::calibrate_host(a.rounds, &|what| {
        bar.set_message(what);
        bar.inc(1);
    });
    bar.finish_and_clear();
    write_fit(&fitted, &a.out)?;
    if !a.quiet {
        print_stdout(&format!(
            "{} ({} threads, {} backend, {:.2} GHz)\n{}",
            facts.model_name,
            facts.threads,
            backend.name(),
            facts.clock_ghz,
            fitted.table().trim_end()
        ))?;
        if let Some(p) = &fitted.shared_cache {
            note!("{}", p.describe());
        }
        note!("wrote {}", a.out.display());
    }
    Ok(())
}

/// `rounds` (the value of option `option`) as [`calibrate::calibrate_host`] takes it: 1 to
/// [`calibrate::MAX_ROUNDS`].
pub(super) fn check_rounds(option: &str, rounds: usize) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=calibrate::MAX_ROUNDS).contains(&rounds),
        "{option} {rounds}: must be 1..={}",
        calibrate::MAX_ROUNDS
    );
    Ok(())
}

/// Writes `fitted`'s machine file to `path` after checking the fit in range; returns the file's
/// text. What `sism calibrate` writes, and `sism validate --calibrate-per-scene` per scene.
pub(super) fn write_fit(fitted: &calibrate::Calibration, path: &Path) -> anyhow::Result<String> {
    fitted
        .config
        .validate()
        .map_err(|(k, e)| anyhow::anyhow!("the fitted model is out of range: `{k}` {e}"))?;
    let facts = sism::host::facts();
    let toml = fitted.to_toml(facts, facts.backend.name());
    write_file(path, &toml)?;
    Ok(toml)
}
