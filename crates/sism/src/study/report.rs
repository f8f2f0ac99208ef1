//! `report.html` of a study and of a sensitivity analysis: the tables (sortable) and the plots the
//! command wrote beside it ([`crate::output::report`]).

use std::path::Path;

use super::sensitivity::{self, Sensitivity};
use super::{speedup, Label, Point};
use crate::machine::roofline::{self, RooflinePoint};
use crate::machine::MachineConfig;
use crate::output::report::Report;

/// `report.html` of a study in `out`: the points (frame, speedup, cycle stack), the plots, and the
/// roofline of `table_point` (on `machine`).
pub(super) fn write_study(
    out: &Path,
    label: &Label,
    base: &MachineConfig,
    points: &[Point],
    table_point: &Point,
    machine: &MachineConfig,
    roof: &[RooflinePoint],
) -> crate::Result<()> {
    let mut r = Report::new(&format!(
        "Study of {} {}x{} around {}",
        label.name, label.width, label.height, base.name
    ));
    r.paragraph(&format!(
        "One counted frame replayed on {} machines; click a column's header to sort by it. \
         Files beside this page: `study.csv` (every step of every point), `records.bin`, `machine.toml`.",
        points.len()
    ));
    let keys: Vec<String> = points
        .first()
        .map_or(Vec::new(), |p| p.set.iter().map(|s| s.key.clone()).collect());
    let mut header: Vec<String> = ["cores", "threads", "l2_kb"].map(String::from).to_vec();
    header.extend(keys.iter().map(|k| format!("`{k}`")));
    header.extend(
        [
            "frame ms",
            "speedup",
            "issue %",
            "memory %",
            "atomics+sync %",
            "imbalance %",
            "slowest phase",
        ]
        .map(String::from),
    );
    let rows: Vec<Vec<String>> = points
        .iter()
        .map(|p| {
            let mut row = vec![p.cores.to_string(), p.threads.to_string(), p.l2_kb.to_string()];
            row.extend(p.set.iter().map(|s| s.value.clone()));
            let total: u64 = p.frame.stack.parts().iter().map(|x| x.1).sum::<u64>().max(1);
            row.push(format!("{:.3}", p.frame.ms));
            row.push(format!("{:.2}", speedup(points, p)));
            for (_, v) in p.frame.stack.parts() {
                row.push(format!("{:.1}", 100.0 * v as f64 / total as f64));
            }
            row.push(p.groups.iter().max_by_key(|g| g.cycles).map_or("–".into(), |g| {
                format!(
                    "{} ({:.0}%)",
                    g.phase,
                    100.0 * g.cycles as f64 / p.frame.cycles.max(1) as f64
                )
            }));
            row
        })
        .collect();
    r.heading(2, "Points").table(&header, &rows);
    r.heading(2, "Plots")
        .figure("speedup.png", "Frame speedup over the fewest cores")
        .figure("phases.png", &format!("Phases of {}", table_point.name))
        .figure("roofline.png", &format!("Roofline of {}", table_point.name));
    r.heading(2, &format!("Roofline of {}", table_point.name))
        .markdown(&roofline::table_of(machine, roof), 3);
    r.write(&out.join("report.html"))
}

/// `report.html` of a sensitivity analysis in `out`: the verdict, the ranked table, the tornado chart.
pub fn write_sensitivity(out: &Path, label: &Label, s: &Sensitivity) -> crate::Result<()> {
    let mut r = Report::new(&format!(
        "Sensitivity of {} {}x{} on {}",
        label.name, label.width, label.height, s.machine
    ));
    r.paragraph(&format!(
        "Each machine parameter that applies was divided and multiplied by {} and the frame replayed \
         (base frame {:.3} ms). Files beside this page: `sensitivity.csv`, `sensitivity.md`.",
        s.factor, s.base_ms
    ));
    r.heading(2, "What limits the frame");
    for line in sensitivity::verdict(s).lines().filter(|l| !l.trim().is_empty()) {
        r.paragraph(line);
    }
    r.figure(
        "sensitivity.png",
        "How far each parameter moves the frame (tornado chart)",
    );
    r.heading(2, "Every parameter, most influential first")
        .markdown(&sensitivity::table(s), 3);
    r.write(&out.join("report.html"))
}
