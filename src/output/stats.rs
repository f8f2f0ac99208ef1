//! Run statistics in gem5 style: every counter has a name, a value, a unit and a description, written
//! as `stats.txt` (one counter a line) and `stats.json`.

use std::path::Path;

use serde::Serialize;

/// One named counter or measurement.
#[derive(Clone, Debug, Serialize)]
pub struct Stat {
    pub name: String,
    pub value: f64,
    pub unit: String,
    pub description: String,
}

/// An ordered list of statistics plus free-form facts about the run (scene, algorithm, machine).
#[derive(Clone, Debug, Default, Serialize)]
pub struct StatsReport {
    pub facts: Vec<(String, String)>,
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
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        let json = serde_json::json!({
            "facts": self.facts.iter()
                .map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone())))
                .collect::<serde_json::Map<_, _>>(),
            "stats": self.stats.iter().map(|s| (s.name.clone(), serde_json::json!({
                "value": s.value, "unit": s.unit, "description": s.description
            }))).collect::<serde_json::Map<_, _>>(),
        });
        std::fs::write(
            dir.join("stats.json"),
            serde_json::to_string_pretty(&json)? + "\n",
        )?;
        std::fs::write(dir.join("stats.txt"), self.to_text())?;
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
