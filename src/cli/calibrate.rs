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
    let fitted = calibrate_sound(a.rounds, &bar, "");
    bar.finish_and_clear();
    let fitted = fitted?;
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

/// Calibrations [`calibrate_sound`] makes before it gives up on a failed fit: the moments of a
/// shared host that fail one (a neighbour's burst while the shared-cache probe reads DRAM) pass
/// within minutes.
const FIT_ATTEMPTS: usize = 3;

/// [`calibrate::calibrate_host`] with `rounds` passes, measured and fitted again while the fit
/// fails ([`calibrate::Calibration::unsound_fits`]), up to [`FIT_ATTEMPTS`] times; an error naming
/// the benchmarks the last fit missed when none is sound, so that no model of a failed fit is
/// written or used. A fit that misses what the one before it missed, by the same factors
/// ([`calibrate::Calibration::repeats_misses`]), is used with a warning: the host's moment does not
/// repeat itself, the model's limits do. `bar` counts one calibration's steps
/// ([`calibrate::calibrate_host_steps`]) and is wound back for another; its messages start with
/// `label`.
pub(super) fn calibrate_sound(
    rounds: usize,
    bar: &sism::progress::Bar,
    label: &str,
) -> anyhow::Result<calibrate::Calibration> {
    let start = bar.position();
    let mut why = String::new();
    let mut earlier = Vec::new();
    for attempt in 1..=FIT_ATTEMPTS {
        bar.set_position(start);
        let fitted = calibrate::calibrate_host(rounds, &|what| {
            bar.set_message(format!("{label}{what}"));
            bar.inc(1);
        });
        let unsound = fitted.unsound_fits();
        if unsound.is_empty() {
            return Ok(fitted);
        }
        let misses: Vec<String> = unsound
            .iter()
            .map(|(name, ratio)| format!("`{name}` predicted at {ratio:.2}× its measurement"))
            .collect();
        // The same misses twice: the model's limit on this host, not its moment (the table in
        // the machine file shows them).
        if fitted.repeats_misses(&earlier) {
            bar.suspend(|| {
                note!(
                    "warning: the calibration missed the same benchmarks by the same factor twice ({}): the model cannot describe them on this host; using the fit",
                    misses.join(", ")
                )
            });
            return Ok(fitted);
        }
        earlier = unsound;
        let probe = fitted
            .shared_cache
            .as_ref()
            .map(|p| format!("; {}", p.describe()))
            .unwrap_or_default();
        why = format!("{}{probe}", misses.join(", "));
        if attempt < FIT_ATTEMPTS {
            bar.suspend(|| {
                note!(
                    "warning: the calibration's fit failed ({why}): the host's moment was too noisy; \
                     measuring again (attempt {} of {FIT_ATTEMPTS})",
                    attempt + 1
                )
            });
        }
    }
    anyhow::bail!(
        "the calibration's fit failed {FIT_ATTEMPTS} times (last: {why}); a fitted benchmark off by more \
         than {}× means the host was too noisy to measure (other tenants' load) or this host's model \
         cannot describe it: try again later",
        calibrate::FIT_LIMIT
    )
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
