//! `sism calibrate`: the host preset's costs fitted to microbenchmarks; writes the machine file.

use std::path::PathBuf;

use sism::host::calibrate::{self, BENCHES};
use sism::machine::host::valid_ways;
use sism::machine::MachineConfig;

use super::{create_dir, print_stdout, write_file};

#[derive(clap::Args)]
pub struct Args {
    /// The fitted machine file to write (TOML; use it with `--machine`).
    #[arg(long, default_value = "out/host.toml")]
    out: PathBuf,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let facts = sism::host::facts();
    let backend = facts.backend;
    let mut start = MachineConfig::host(facts);
    // The shared cache's capacity as this guest gets it (other tenants share it): the model's, and
    // the size of the shared-cache benchmarks below.
    if !a.quiet {
        note!("measuring the shared cache's usable capacity");
    }
    let shared = sism::host::shared_cache::probe(start.l2_kb, start.l3_kb);
    if let Some(kb) = shared.as_ref().and_then(|p| p.effective_kb) {
        // A power of two of at least twice the L2: some associativity up to the reported one keeps
        // the sets a power of two.
        start.l3_ways = valid_ways(kb, start.l3_ways).unwrap_or(1);
        start.l3_kb = kb;
    }
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        create_dir(dir)?;
    }
    let bar = sism::progress::bar(BENCHES.len() as u64, "microbenchmarks", !a.quiet);
    let measured: Vec<_> = BENCHES
        .iter()
        .map(|b| {
            bar.set_message(b.name);
            let m = calibrate::measure(b, &start);
            bar.inc(1);
            m
        })
        .collect();
    bar.finish_and_clear();
    let mut fitted = calibrate::fit(&start, &measured);
    fitted.shared_cache = shared;
    fitted
        .config
        .validate()
        .map_err(|(k, e)| anyhow::anyhow!("the fitted model is out of range: `{k}` {e}"))?;
    write_file(&a.out, &fitted.to_toml(facts, backend.name()))?;
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
