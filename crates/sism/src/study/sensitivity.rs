//! Sensitivity: which machine parameter moves the frame. One counted frame is replayed on the base
//! machine and, for every parameter that applies to it ([`params::applies`]), on the base with that
//! parameter divided and multiplied by a factor (2 by default) — the records decoded once for all of
//! them ([`crate::machine::sweep::run`]). The parameters are ranked by how far either change moves the frame; the
//! same is done per phase; the verdict names what limits the frame (the change that speeds it most).
//!
//! Outputs: `sensitivity.csv` (every parameter, direction, value, and the frame's and each phase's
//! ms and change), `sensitivity.md` (the ranked table, then the verdict as its last lines) and
//! `sensitivity.png` (a tornado chart of the frame's changes).

use std::path::Path;

use super::{Label, Point};
use crate::machine::params::{self, Param};
use crate::machine::{CanonicalRecords, MachineConfig};

/// Changes smaller than this share of the frame (or phase) are reported as not mattering.
pub const NEGLIGIBLE: f64 = 0.01;

/// The replays a sensitivity analysis needs: the base first, then each parameter's two changes.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The factor each parameter is divided and multiplied by (> 1).
    pub factor: f64,
    /// The configurations: `configs[0]` is the base.
    pub configs: Vec<MachineConfig>,
    /// Per parameter: the indices into `configs` of its divided and multiplied machines (`None`
    /// where it cannot move that way: at its range's bound, or a change the machine refuses).
    pub params: Vec<(Param, Option<usize>, Option<usize>)>,
}

/// The plan for `base` and `factor` (finite, > 1): an error naming the factor otherwise.
pub fn plan(base: &MachineConfig, factor: f64) -> crate::Result<Plan> {
    crate::error::ensure!(
        factor.is_finite() && factor > 1.0 && factor <= 1e3,
        "--factor {factor}: expected a number in (1, 1000]"
    );
    let mut configs = vec![base.clone()];
    let mut out = Vec::new();
    for p in params::all().into_iter().filter(|p| params::applies(base, p)) {
        let mut side = |f: f64| {
            params::scaled(base, &p, f).map(|mut m| {
                m.name = format!("{}-{}{}", base.name, p.name, params::get(&m, &p));
                configs.push(m);
                configs.len() - 1
            })
        };
        let (lo, hi) = (side(1.0 / factor), side(factor));
        if lo.is_some() || hi.is_some() {
            out.push((p, lo, hi));
        }
    }
    Ok(Plan {
        factor,
        configs,
        params: out,
    })
}

/// One changed machine's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Side {
    /// The parameter's value on this machine.
    pub value: String,
    /// The frame, ms.
    pub frame_ms: f64,
    /// Each phase of the base point, ms (in the base's phase order).
    pub phase_ms: Vec<f64>,
}

/// One parameter's effect.
#[derive(Clone, Debug, PartialEq)]
pub struct Effect {
    /// The machine-file key.
    pub key: &'static str,
    /// Its value on the base machine.
    pub base_value: String,
    /// Divided by the factor.
    pub low: Option<Side>,
    /// Multiplied by the factor.
    pub high: Option<Side>,
}

impl Effect {
    /// The largest change of the frame either way, as a share of the base frame (≥ 0).
    pub fn swing(&self, base_ms: f64) -> f64 {
        [&self.low, &self.high]
            .into_iter()
            .flatten()
            .map(|s| (s.frame_ms / base_ms - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// The largest change of phase `k` either way, as a share of the base phase.
    pub fn phase_swing(&self, k: usize, base_ms: f64) -> f64 {
        [&self.low, &self.high]
            .into_iter()
            .flatten()
            .map(|s| (s.phase_ms[k] / base_ms.max(1e-12) - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// The change that speeds the frame most: (side, "halving"/"doubling"-style word, gain as a
    /// share of the base frame), if any speeds it at all.
    pub fn best_gain(&self, base_ms: f64, factor: f64) -> Option<(&Side, String, f64)> {
        let word = |up: bool| match (up, factor == 2.0) {
            (true, true) => "doubling".to_string(),
            (false, true) => "halving".to_string(),
            (true, false) => format!("multiplying by {factor}"),
            (false, false) => format!("dividing by {factor}"),
        };
        [(self.low.as_ref(), false), (self.high.as_ref(), true)]
            .into_iter()
            .filter_map(|(s, up)| s.map(|s| (s, word(up), 1.0 - s.frame_ms / base_ms)))
            .filter(|(_, _, g)| *g > 0.0)
            .max_by(|a, b| a.2.total_cmp(&b.2))
    }
}

/// A finished analysis.
#[derive(Clone, Debug, PartialEq)]
pub struct Sensitivity {
    /// The factor.
    pub factor: f64,
    /// The base machine's name.
    pub machine: String,
    /// The base frame, ms.
    pub base_ms: f64,
    /// The base point's phases and their ms.
    pub phases: Vec<(String, f64)>,
    /// Every parameter, most influential first (by [`Effect::swing`]; ties by name).
    pub effects: Vec<Effect>,
}

/// The analysis from the plan's points (`points[i]` replayed on `plan.configs[i]`).
pub fn analyse(plan: &Plan, points: &[Point]) -> crate::Result<Sensitivity> {
    crate::error::ensure!(
        points.len() == plan.configs.len() && !points.is_empty(),
        "sensitivity: {} points for {} machines",
        points.len(),
        plan.configs.len()
    );
    let base = &points[0];
    let phases: Vec<(String, f64)> = base.groups.iter().map(|g| (g.phase.clone(), g.ms)).collect();
    let side = |i: Option<usize>, p: &Param| {
        i.map(|i| {
            let q = &points[i];
            Side {
                value: params::get(&plan.configs[i], p),
                frame_ms: q.frame.ms,
                phase_ms: phases
                    .iter()
                    .map(|(name, _)| q.groups.iter().find(|g| &g.phase == name).map_or(0.0, |g| g.ms))
                    .collect(),
            }
        })
    };
    let mut effects: Vec<Effect> = plan
        .params
        .iter()
        .map(|(p, lo, hi)| Effect {
            key: p.name,
            base_value: params::get(&plan.configs[0], p),
            low: side(*lo, p),
            high: side(*hi, p),
        })
        .collect();
    let base_ms = base.frame.ms.max(1e-12);
    effects.sort_by(|a, b| {
        b.swing(base_ms)
            .total_cmp(&a.swing(base_ms))
            .then(a.key.cmp(b.key))
    });
    Ok(Sensitivity {
        factor: plan.factor,
        machine: plan.configs[0].name.clone(),
        base_ms,
        phases,
        effects,
    })
}

/// Replays `records` on the plan's machines in this process (`on_point` after each).
pub fn run_local(
    records: &CanonicalRecords,
    plan: &Plan,
    on_point: impl Fn() + Sync,
) -> crate::Result<Sensitivity> {
    let points = super::run_local(records, &plan.configs, &[], on_point);
    analyse(plan, &points)
}

fn pct(x: f64) -> String {
    format!("{:+.1}%", 100.0 * x)
}

/// The ranked table (markdown): per parameter its base value, the frame with it divided and
/// multiplied, and the phase it moves most.
pub fn table(s: &Sensitivity) -> String {
    let f = s.factor;
    let mut t = format!(
        "| parameter | base | ÷{f} | frame | ×{f} | frame | swing | phase moved most |\n|---|---|---|---|---|---|---|---|\n"
    );
    for e in &s.effects {
        let cell = |side: &Option<Side>| match side {
            Some(x) => (
                x.value.clone(),
                format!("{:.3} ms ({})", x.frame_ms, pct(x.frame_ms / s.base_ms - 1.0)),
            ),
            None => ("–".into(), "–".into()),
        };
        let (lv, lf) = cell(&e.low);
        let (hv, hf) = cell(&e.high);
        let most = (0..s.phases.len())
            .map(|k| (k, e.phase_swing(k, s.phases[k].1)))
            .filter(|(k, _)| s.phases[*k].1 >= NEGLIGIBLE * s.base_ms)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|(_, w)| *w >= NEGLIGIBLE)
            .map_or("–".to_string(), |(k, w)| {
                format!("{} (±{:.0}%)", s.phases[k].0, 100.0 * w)
            });
        t += &format!(
            "| `{}` | {} | {} | {} | {} | {} | {:.1}% | {} |\n",
            e.key,
            e.base_value,
            lv,
            lf,
            hv,
            hf,
            100.0 * e.swing(s.base_ms),
            most
        );
    }
    t
}

/// The verdict in words: what limits the frame (the change that speeds it most, the clock aside:
/// a faster clock speeds everything but DRAM's nanoseconds), the runners-up, what limits each phase
/// of at least 10% of the frame, and what does not matter.
pub fn verdict(s: &Sensitivity) -> String {
    let gains: Vec<(&Effect, &Side, String, f64)> = {
        let mut g: Vec<_> = s
            .effects
            .iter()
            .filter(|e| e.key != "clock_ghz")
            .filter_map(|e| {
                e.best_gain(s.base_ms, s.factor)
                    .map(|(side, w, g)| (e, side, w, g))
            })
            .filter(|x| x.3 >= NEGLIGIBLE)
            .collect();
        g.sort_by(|a, b| b.3.total_cmp(&a.3).then(a.0.key.cmp(b.0.key)));
        g
    };
    let mut out = String::new();
    match gains.first() {
        Some((e, side, word, g)) => {
            out += &format!(
                "This frame is limited by `{}`: {} it ({} → {}) makes the frame {:.1}% faster ({:.3} → {:.3} ms).",
                e.key,
                word,
                e.base_value,
                side.value,
                100.0 * g,
                s.base_ms,
                side.frame_ms
            );
            let next: Vec<String> = gains
                .iter()
                .skip(1)
                .take(3)
                .map(|(e, _, w, g)| format!("{w} `{}` {:.1}%", e.key, 100.0 * g))
                .collect();
            if !next.is_empty() {
                out += &format!(" Next: {}.", next.join("; "));
            }
        }
        None => {
            out += &format!(
                "No parameter changed by ×{0} or ÷{0} speeds this frame by {1:.0}% or more: it is limited by its work itself.",
                s.factor,
                100.0 * NEGLIGIBLE
            )
        }
    }
    out.push('\n');
    for (k, (phase, ms)) in s.phases.iter().enumerate() {
        if *ms < 0.1 * s.base_ms {
            continue;
        }
        let best = s
            .effects
            .iter()
            .filter(|e| e.key != "clock_ghz")
            .flat_map(|e| {
                [(&e.low, false), (&e.high, true)]
                    .into_iter()
                    .filter_map(move |(side, up)| side.as_ref().map(|x| (e, x, up)))
            })
            .map(|(e, x, up)| (e, x, up, 1.0 - x.phase_ms[k] / ms.max(1e-12)))
            .filter(|x| x.3 >= NEGLIGIBLE)
            .max_by(|a, b| a.3.total_cmp(&b.3).then(b.0.key.cmp(a.0.key)));
        out += &match best {
            Some((e, x, up, g)) => format!(
                "Phase `{phase}` ({:.0}% of the frame) is limited by `{}`: {} it ({} → {}) makes it {:.1}% faster.\n",
                100.0 * ms / s.base_ms,
                e.key,
                if up { "raising" } else { "lowering" },
                e.base_value,
                x.value,
                100.0 * g
            ),
            None => format!(
                "Phase `{phase}` ({:.0}% of the frame): no parameter speeds it by {:.0}% or more.\n",
                100.0 * ms / s.base_ms,
                100.0 * NEGLIGIBLE
            ),
        };
    }
    let flat: Vec<&str> = s
        .effects
        .iter()
        .filter(|e| e.swing(s.base_ms) < NEGLIGIBLE)
        .map(|e| e.key)
        .collect();
    if !flat.is_empty() {
        out += &format!(
            "Within ±{:.0}% of the frame either way: {}.\n",
            100.0 * NEGLIGIBLE,
            flat.join(", ")
        );
    }
    out
}

/// `sensitivity.csv`: per parameter and direction (`base` once) the value and, for the frame and
/// each phase, the ms and the change from the base.
pub fn csv(s: &Sensitivity) -> String {
    let mut t = String::from("parameter,direction,value,phase,ms,change\n");
    t += &format!("base,base,,frame,{:.6},0\n", s.base_ms);
    for (name, ms) in &s.phases {
        t += &format!("base,base,,{name},{ms:.6},0\n");
    }
    for e in &s.effects {
        for (dir, side) in [("divided", &e.low), ("multiplied", &e.high)] {
            let Some(x) = side else { continue };
            t += &format!(
                "{},{dir},{},frame,{:.6},{:.6}\n",
                e.key,
                x.value,
                x.frame_ms,
                x.frame_ms / s.base_ms - 1.0
            );
            for (k, (name, ms)) in s.phases.iter().enumerate() {
                let change = if *ms > 0.0 { x.phase_ms[k] / ms - 1.0 } else { 0.0 };
                t += &format!(
                    "{},{dir},{},{name},{:.6},{change:.6}\n",
                    e.key, x.value, x.phase_ms[k]
                );
            }
        }
    }
    t
}

/// Writes `sensitivity.csv`, `sensitivity.md`, `sensitivity.png` and `report.html` into `out`.
pub fn write_outputs(out: &Path, label: &Label, s: &Sensitivity) -> crate::Result<()> {
    crate::output::write_atomic(&out.join("sensitivity.csv"), csv(s).as_bytes())?;
    let md = format!(
        "# Sensitivity of {} {}x{} on {} (each parameter ÷{f} and ×{f}; base frame {:.3} ms)\n\n{}\n{}",
        label.name,
        label.width,
        label.height,
        s.machine,
        s.base_ms,
        table(s),
        verdict(s),
        f = s.factor
    );
    crate::output::write_atomic(&out.join("sensitivity.md"), md.as_bytes())?;
    crate::output::plots::sensitivity::tornado(&out.join("sensitivity.png"), label, s)?;
    super::report::write_sensitivity(out, label, s)
}
