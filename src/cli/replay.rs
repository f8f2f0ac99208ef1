//! `sism replay`: saved task records re-timed on another machine.

use std::path::PathBuf;

use anyhow::Context;

use sism::machine;
use sism::stats::StatsReport;

use super::{create_dir, print_stdout};

#[derive(clap::Args)]
pub struct Args {
    /// Records file (records.bin of `render --machine` or `study`).
    records: PathBuf,
    /// A preset (larrabee-8/16/24/32/48/64) or a machine TOML file.
    #[arg(long, default_value = "larrabee-24")]
    machine: String,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/replay")]
    out: PathBuf,
    /// Print nothing.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let config = super::resolve_machine(&a.machine).context("--machine")?;
    let records = machine::load_records(&a.records)?;
    let report = machine::simulate(&records, &config);
    create_dir(&a.out)?;
    let mut stats = StatsReport::default();
    stats.fact("records", a.records.display());
    report.add_to(&mut stats);
    stats.write(&a.out)?;
    machine::write_config(&a.out, &config)?;
    if !a.quiet {
        print_stdout(report.to_table().trim_end())?;
        note!("wrote {}", a.out.display());
    }
    Ok(())
}
