//! The roofline of a simulated frame: per phase and step, the vector lane operations achieved per
//! cycle (the whole chip) against the bytes moved per cycle from the L2 subsets into the L1s and
//! from DRAM, under the machine's ceilings: peak vector issue, the L2-to-L1 fill bandwidth (and the
//! ring's, for lines that cross it) and DRAM bandwidth. A phase far below every roof its intensity
//! allows is limited by something else (latency, atomics and barriers, load imbalance: its cycle
//! stack says which).

use super::{MachineConfig, MachineReport, PhaseReport};

/// The machine's ceilings, per cycle of the whole chip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ceilings {
    /// Peak vector lane operations: cores × vector issue per clock × 16 lanes ÷ cycles per vector
    /// operation.
    pub lane_ops: f64,
    /// L2-to-L1 fill bandwidth, bytes: one line per core per clock (assumption: Seiler 2008's L1
    /// fill path is a line wide; hosts alike).
    pub l2_bytes: f64,
    /// Ring bandwidth, bytes: both directions' width (`ring_bytes_per_clock` × 2); lines that miss
    /// the local L2 subset cross it.
    pub ring_bytes: f64,
    /// DRAM bandwidth, bytes.
    pub dram_bytes: f64,
}

impl Ceilings {
    /// The ceilings of `m`.
    pub fn of(m: &MachineConfig) -> Ceilings {
        Ceilings {
            lane_ops: m.cores as f64 * m.vector_issue_per_clock as f64 * m.simd_width as f64
                / m.vector_cycles.max(1e-9),
            l2_bytes: m.cores as f64 * m.line_bytes as f64,
            ring_bytes: 2.0 * m.ring_bytes_per_clock as f64,
            dram_bytes: m.dram_bytes_per_cycle(),
        }
    }
}

/// One phase or step on the roofline.
#[derive(Clone, Debug, PartialEq)]
pub struct RooflinePoint {
    /// `frame`, a phase (`grid`) or a step (`grid.classify`).
    pub name: String,
    /// True for a phase (or the frame), false for a step.
    pub group: bool,
    /// Cycles.
    pub cycles: u64,
    /// Vector lane operations executed: arithmetic vector instructions (ALU, FMA, div/sqrt and
    /// other transcendentals) times their active lanes.
    pub lane_ops: f64,
    /// Bytes filled into the L1s from the L2 subsets (L1 misses × line).
    pub l2_bytes: f64,
    /// Bytes moved between DRAM and the L2s (fills and write-backs).
    pub dram_bytes: f64,
}

impl RooflinePoint {
    fn of(p: &PhaseReport, group: bool, m: &MachineConfig) -> RooflinePoint {
        RooflinePoint {
            name: p.phase.clone(),
            group,
            cycles: p.cycles,
            lane_ops: lane_ops(p, m),
            l2_bytes: p.memory.l1_misses as f64 * m.line_bytes as f64,
            dram_bytes: p.memory.dram_bytes(m.line_bytes) as f64,
        }
    }

    /// Lane operations per cycle achieved.
    pub fn lane_ops_per_cycle(&self) -> f64 {
        self.lane_ops / self.cycles.max(1) as f64
    }

    /// Lane operations per byte from L2 (∞ with no L2 traffic).
    pub fn l2_intensity(&self) -> f64 {
        self.lane_ops / self.l2_bytes
    }

    /// Lane operations per byte from DRAM (∞ with no DRAM traffic).
    pub fn dram_intensity(&self) -> f64 {
        self.lane_ops / self.dram_bytes
    }

    /// What bounds it: the lowest roof at its intensities (`vector issue`, `L2 bandwidth` or
    /// `DRAM bandwidth`), and the share of that roof it reaches (in [0, 1] up to rounding).
    pub fn bound(&self, c: &Ceilings) -> (&'static str, f64) {
        let roofs = [
            ("vector issue", c.lane_ops),
            ("L2 bandwidth", self.l2_intensity() * c.l2_bytes),
            ("DRAM bandwidth", self.dram_intensity() * c.dram_bytes),
        ];
        // No traffic (0/0 or x/0): that roof is out of reach.
        let (name, roof) = roofs
            .into_iter()
            .map(|(n, r)| (n, if r.is_nan() { f64::INFINITY } else { r }))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or(("vector issue", c.lane_ops));
        (name, self.lane_ops_per_cycle() / roof.max(1e-300))
    }
}

/// The frame, every phase and every step of `r` (phases first, in frame order, then steps).
pub fn points(r: &MachineReport) -> Vec<RooflinePoint> {
    std::iter::once(RooflinePoint::of(&r.frame, true, &r.config))
        .chain(r.groups.iter().map(|p| RooflinePoint::of(p, true, &r.config)))
        .chain(r.phases.iter().map(|p| RooflinePoint::of(p, false, &r.config)))
        .collect()
}

/// The same points from a study's point (its rows carry the lane operations and bytes), so that a
/// study, local or collected from Slurm, draws the roofline of its base machine's point.
pub fn points_of_study(p: &crate::study::Point) -> Vec<RooflinePoint> {
    let of = |r: &crate::study::Row, group: bool| RooflinePoint {
        name: r.phase.clone(),
        group,
        cycles: r.cycles,
        lane_ops: r.lane_ops,
        l2_bytes: r.bytes_l2 as f64,
        dram_bytes: r.bytes_dram as f64,
    };
    std::iter::once(of(&p.frame, true))
        .chain(p.groups.iter().map(|r| of(r, true)))
        .chain(p.steps.iter().map(|r| of(r, false)))
        .collect()
}

/// The vector lane operations of a phase: arithmetic vector instructions (ALU, FMA, div/sqrt and
/// other transcendentals) times their active lanes.
pub fn lane_ops(p: &PhaseReport, m: &MachineConfig) -> f64 {
    let c = &p.counters;
    (c.valu + c.fma + c.transcendental) as f64 * c.lane_utilisation() * m.simd_width as f64
}

/// The table (markdown) of `r`: see [`table_of`].
pub fn table(r: &MachineReport) -> String {
    table_of(&r.config, &points(r))
}

/// The table (markdown): per point its cycles, lane operations per cycle, bytes per cycle from L2
/// and DRAM, intensities, the bounding roof and the share of it reached, under `m`'s ceilings.
pub fn table_of(m: &MachineConfig, points: &[RooflinePoint]) -> String {
    let c = Ceilings::of(m);
    let mut t = format!(
        "Ceilings of {} (per cycle, whole chip): {:.1} vector lane operations, {:.0} bytes from L2 \
         ({:.0} over the ring), {:.2} bytes from DRAM.\n\n\
         | phase / step | cycles | lane ops/cycle | L2 bytes/cycle | DRAM bytes/cycle | ops/L2 byte | ops/DRAM byte | bound | of roof |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        m.name, c.lane_ops, c.l2_bytes, c.ring_bytes, c.dram_bytes
    );
    for p in points {
        let per = |x: f64| x / p.cycles.max(1) as f64;
        let (bound, share) = p.bound(&c);
        let name = if p.group {
            format!("**{}**", p.name)
        } else {
            p.name.clone()
        };
        t += &format!(
            "| {name} | {} | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {bound} | {:.0}% |\n",
            p.cycles,
            p.lane_ops_per_cycle(),
            per(p.l2_bytes),
            per(p.dram_bytes),
            p.l2_intensity(),
            p.dram_intensity(),
            100.0 * share
        );
    }
    t
}

/// Writes `roofline.md` (the ceilings and [`table`]) and `roofline.png` into `out`; `title` names
/// the frame in the plot.
pub fn write(out: &std::path::Path, title: &str, r: &MachineReport) -> crate::Result<()> {
    write_points(out, title, &r.config, &points(r))
}

/// Writes `roofline.md` and `roofline.png` of `points` (the frame first, as [`points`] gives them)
/// under `m`'s ceilings into `out`.
pub fn write_points(
    out: &std::path::Path,
    title: &str,
    m: &MachineConfig,
    points: &[RooflinePoint],
) -> crate::Result<()> {
    crate::output::write_atomic(&out.join("roofline.md"), table_of(m, points).as_bytes())?;
    crate::output::plots::roofline::roofline(&out.join("roofline.png"), title, m, points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_is_the_lowest_roof_at_the_points_intensity() {
        let c = Ceilings {
            lane_ops: 384.0,
            l2_bytes: 1536.0,
            ring_bytes: 128.0,
            dram_bytes: 128.0,
        };
        let p = |lane_ops: f64, l2: f64, dram: f64| RooflinePoint {
            name: "p".into(),
            group: true,
            cycles: 1000,
            lane_ops,
            l2_bytes: l2,
            dram_bytes: dram,
        };
        // 1 op per DRAM byte: the DRAM roof is 128 ops/cycle, below the issue peak.
        let (b, share) = p(64_000.0, 1000.0, 64_000.0).bound(&c);
        assert_eq!(b, "DRAM bandwidth");
        assert!((share - 0.5).abs() < 1e-12, "{share}");
        // No memory traffic: only the issue roof.
        let (b, share) = p(384_000.0, 0.0, 0.0).bound(&c);
        assert_eq!((b, share), ("vector issue", 1.0));
    }
}
