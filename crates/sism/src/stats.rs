//! Run statistics in gem5 style: every counter has a name, a value, a unit and a description, written
//! as `stats.txt` (one counter a line) and `stats.json`.
//!
//! Counters are declared where they are counted, as pbrt-v4 and gem5 do: a stage's stats struct is
//! written with [`declare_stats!`], which gives every field its row (name, unit, description) beside
//! the field itself, and an implementation of [`StatRows`] that emits them in declaration order.

use std::path::Path;

use serde::Serialize;

/// One named counter or measurement.
#[derive(Clone, Debug, Serialize)]
pub struct Stat {
    /// Dotted name, e.g. `rbsm.fragments`.
    pub name: String,
    /// The value, in `unit`.
    pub value: f64,
    /// Unit, e.g. `fragments` or `ms`.
    pub unit: String,
    /// What it counts or measures.
    pub description: String,
}

/// An ordered list of statistics plus free-form facts about the run (scene, algorithm, machine).
#[derive(Clone, Debug, Default, Serialize)]
pub struct StatsReport {
    /// Facts as `(name, value)`, in the order added.
    pub facts: Vec<(String, String)>,
    /// The statistics, in the order added.
    pub stats: Vec<Stat>,
}

impl StatsReport {
    /// Adds a fact such as `("algorithm", "reference")`.
    pub fn fact(&mut self, name: &str, value: impl ToString) -> &mut Self {
        self.facts.push((name.to_string(), value.to_string()));
        self
    }

    /// Adds a counter.
    pub fn stat(&mut self, name: &str, value: f64, unit: &str, description: &str) -> &mut Self {
        self.stats.push(Stat {
            name: name.into(),
            value,
            unit: unit.into(),
            description: description.into(),
        });
        self
    }

    /// Runs `f` and prefixes the names of the rows it adds with `prefix.`.
    pub fn prefixed(&mut self, prefix: &str, f: impl FnOnce(&mut StatsReport)) -> &mut Self {
        let start = self.stats.len();
        f(self);
        for s in &mut self.stats[start..] {
            s.name = format!("{prefix}.{}", s.name);
        }
        self
    }

    /// Adds the rows of a [`StatRows`] struct.
    pub fn rows(&mut self, rows: &impl StatRows) -> &mut Self {
        rows.rows(self);
        self
    }

    /// Looks a counter up by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.stats.iter().find(|s| s.name == name).map(|s| s.value)
    }

    /// The `stats.txt` text: facts as `# name: value`, then `name value unit # description`.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for (k, v) in &self.facts {
            out += &format!("# {k}: {v}\n");
        }
        let width = self.stats.iter().map(|s| s.name.len()).max().unwrap_or(0);
        for s in &self.stats {
            out += &format!(
                "{:<width$} {:>16} {:<10} # {}\n",
                s.name,
                fmt_value(s.value),
                s.unit,
                s.description
            );
        }
        out
    }

    /// Writes `stats.txt` and `stats.json` into `dir`.
    pub fn write(&self, dir: &Path) -> crate::Result<()> {
        let json = serde_json::json!({
            "facts": self.facts.iter()
                .map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone())))
                .collect::<serde_json::Map<_, _>>(),
            "stats": self.stats.iter().map(|s| (s.name.clone(), serde_json::json!({
                "value": s.value, "unit": s.unit, "description": s.description
            }))).collect::<serde_json::Map<_, _>>(),
        });
        let json_path = dir.join("stats.json");
        let text = serde_json::to_string_pretty(&json).expect("a JSON value serialises") + "\n";
        crate::output::write_atomic(&json_path, text.as_bytes())?;
        let text_path = dir.join("stats.txt");
        crate::output::write_atomic(&text_path, self.to_text().as_bytes())?;
        Ok(())
    }
}

fn fmt_value(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:.6}")
    }
}

/// A value that becomes statistics rows: a count, a measurement, a distribution.
pub trait StatValue {
    /// Adds this value's rows under `name`.
    fn emit(&self, name: &str, unit: &str, description: &str, out: &mut StatsReport);
}

impl StatValue for u64 {
    fn emit(&self, name: &str, unit: &str, description: &str, out: &mut StatsReport) {
        out.stat(name, *self as f64, unit, description);
    }
}

impl StatValue for f64 {
    fn emit(&self, name: &str, unit: &str, description: &str, out: &mut StatsReport) {
        out.stat(name, *self, unit, description);
    }
}

/// Names of the quantiles of a [`Dist`], in order.
pub const QUANTILES: [&str; 4] = ["p50", "p90", "p99", "max"];

/// A distribution as `[p50, p90, p99, max]` (nearest rank; see [`percentiles`]): rows
/// `<name>.p50` ... `<name>.max`.
pub type Dist = [u64; 4];

impl StatValue for Dist {
    fn emit(&self, name: &str, unit: &str, description: &str, out: &mut StatsReport) {
        for (q, v) in QUANTILES.iter().zip(self) {
            out.stat(&format!("{name}.{q}"), *v as f64, unit, description);
        }
    }
}

/// `[p50, p90, p99, max]` of `values` (nearest rank; zeros when empty).
pub fn percentiles(values: impl Iterator<Item = u64>) -> Dist {
    let mut v: Vec<u64> = values.collect();
    if v.is_empty() {
        return [0; 4];
    }
    v.sort_unstable();
    let at = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    [at(0.5), at(0.9), at(0.99), v[v.len() - 1]]
}

/// A struct whose fields are statistics: it adds its rows to a report.
pub trait StatRows {
    /// Adds every row, in declaration order.
    fn rows(&self, out: &mut StatsReport);
}

/// Declares a stats struct: each field with its row beside it, `field: type => ("name", "unit",
/// "description")`, or `=> nested` for a field that is itself a [`StatRows`] struct, or `=> skip` for
/// one that is not reported. Generates the struct (with the given attributes) and its [`StatRows`].
///
/// ```
/// sism::declare_stats! {
///     /// Counters of a stage.
///     #[derive(Clone, Copy, Debug, Default)]
///     pub struct StageStats {
///         /// Items read.
///         pub items: u64 => ("stage.items", "items", "items read"),
///     }
/// }
/// let mut out = sism::stats::StatsReport::default();
/// sism::stats::StatRows::rows(&StageStats { items: 3 }, &mut out);
/// assert_eq!(out.get("stage.items"), Some(3.0));
/// ```
#[macro_export]
macro_rules! declare_stats {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                $fvis:vis $field:ident : $ty:ty => $row:tt
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $( $(#[$fmeta])* $fvis $field: $ty, )*
        }
        impl $crate::stats::StatRows for $name {
            fn rows(&self, out: &mut $crate::stats::StatsReport) {
                $( $crate::declare_stats!(@row out, self.$field, $row); )*
            }
        }
    };
    (@row $out:ident, $value:expr, nested) => {
        $crate::stats::StatRows::rows(&$value, $out)
    };
    (@row $out:ident, $value:expr, skip) => {
        let _ = &$value;
    };
    (@row $out:ident, $value:expr, ($stat:expr, $unit:expr, $desc:expr)) => {
        $crate::stats::StatValue::emit(&$value, $stat, $unit, $desc, $out)
    };
}
