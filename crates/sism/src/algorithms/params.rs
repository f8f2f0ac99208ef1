//! Algorithm parameters: each algorithm declares its parameters ([`ParamSpec`]: key, kind with range,
//! default, description with unit) in its registry entry; users give `key=value` pairs, which are
//! checked against the declarations ([`Params::resolve`]) with errors that name the algorithm, the key
//! and the allowed range.

use std::fmt;

/// What values a parameter takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamKind {
    /// A whole number in `min..=max`.
    Int { min: i64, max: i64 },
    /// An odd whole number in `min..=max` (a kernel side with a centre tap).
    OddInt { min: i64, max: i64 },
    /// An unsigned 64-bit number (seeds), any value.
    U64,
    /// A finite real number in `[min, max]`.
    Float { min: f64, max: f64 },
    /// One of the names.
    Choice(&'static [&'static str]),
}

/// One declared parameter of an algorithm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    /// The key users write (`spp`, `slices`).
    pub key: &'static str,
    pub kind: ParamKind,
    /// The default value, as users would write it; must itself be valid (a test checks).
    pub default: &'static str,
    /// What it sets, with its unit.
    pub description: &'static str,
}

impl ParamSpec {
    /// The allowed values, for help texts and errors: `1..=65536`, `[1, 64]`, `hybrid|fraction`.
    pub fn range(&self) -> String {
        match self.kind {
            ParamKind::Int { min, max } => format!("{min}..={max}"),
            ParamKind::OddInt { min, max } => format!("odd {min}..={max}"),
            ParamKind::U64 => "any u64".into(),
            ParamKind::Float { min, max } => format!("[{min}, {max}]"),
            ParamKind::Choice(names) => names.join("|"),
        }
    }

    /// Parses and checks `text` as a value of this parameter.
    pub fn parse(&self, text: &str) -> Result<ParamValue, String> {
        let t = text.trim();
        match self.kind {
            ParamKind::Int { min, max } => {
                let v: i64 = t.parse().map_err(|_| format!("`{t}` is not a whole number"))?;
                if v < min || v > max {
                    return Err(format!("{v} is out of range {}", self.range()));
                }
                Ok(ParamValue::Int(v))
            }
            ParamKind::OddInt { min, max } => {
                let v: i64 = t.parse().map_err(|_| format!("`{t}` is not a whole number"))?;
                if v < min || v > max || v % 2 == 0 {
                    return Err(format!("{v} is not an odd number in {min}..={max}"));
                }
                Ok(ParamValue::Int(v))
            }
            ParamKind::U64 => t
                .parse::<u64>()
                .map(ParamValue::U64)
                .map_err(|_| format!("`{t}` is not a whole number in 0..={}", u64::MAX)),
            ParamKind::Float { min, max } => {
                let v: f64 = t.parse().map_err(|_| format!("`{t}` is not a number"))?;
                if !v.is_finite() || v < min || v > max {
                    return Err(format!("{v} is out of range {}", self.range()));
                }
                Ok(ParamValue::Float(v))
            }
            ParamKind::Choice(names) => names
                .iter()
                .find(|n| **n == t)
                .map(|n| ParamValue::Choice(n))
                .ok_or_else(|| format!("`{t}` is not one of {}", self.range())),
        }
    }
}

/// A checked parameter value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamValue {
    Int(i64),
    U64(u64),
    Float(f64),
    Choice(&'static str),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::U64(v) => write!(f, "{v}"),
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Choice(v) => write!(f, "{v}"),
        }
    }
}

/// A bad parameter: which algorithm, which key, what is wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("algorithm {algorithm}: parameter `{key}` {message}")]
pub struct ParamError {
    pub algorithm: String,
    pub key: String,
    pub message: String,
}

/// Every declared parameter of one algorithm with its checked value (given or default).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    values: Vec<(&'static str, ParamValue)>,
}

impl Params {
    /// Resolves `given` (`key`, `value` text) against `specs` of `algorithm`: unknown keys, repeated
    /// keys, malformed and out-of-range values are errors; missing keys take their defaults.
    pub fn resolve(
        algorithm: &str,
        specs: &[ParamSpec],
        given: &[(String, String)],
    ) -> Result<Params, ParamError> {
        let err = |key: &str, message: String| ParamError {
            algorithm: algorithm.to_string(),
            key: key.to_string(),
            message,
        };
        for (k, (key, _)) in given.iter().enumerate() {
            if !specs.iter().any(|s| s.key == key) {
                let known: Vec<&str> = specs.iter().map(|s| s.key).collect();
                return Err(err(
                    key,
                    if known.is_empty() {
                        "is unknown: this algorithm takes no parameters".into()
                    } else {
                        format!("is unknown (parameters: {})", known.join(", "))
                    },
                ));
            }
            if given[..k].iter().any(|(earlier, _)| earlier == key) {
                return Err(err(key, "is given twice".into()));
            }
        }
        let mut values = Vec::with_capacity(specs.len());
        for spec in specs {
            let text = given
                .iter()
                .find(|(k, _)| k == spec.key)
                .map_or(spec.default, |(_, v)| v.as_str());
            let value = spec.parse(text).map_err(|m| err(spec.key, m))?;
            values.push((spec.key, value));
        }
        Ok(Params { values })
    }

    /// The defaults of `specs`.
    pub fn defaults(algorithm: &str, specs: &[ParamSpec]) -> Result<Params, ParamError> {
        Self::resolve(algorithm, specs, &[])
    }

    fn get(&self, key: &str) -> ParamValue {
        self.values
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| *v)
            .unwrap_or_else(|| panic!("parameter `{key}` is not declared by this algorithm"))
    }

    /// An integer parameter (declared [`ParamKind::Int`]).
    pub fn int(&self, key: &str) -> i64 {
        match self.get(key) {
            ParamValue::Int(v) => v,
            other => panic!("parameter `{key}` is {other:?}, not an integer"),
        }
    }

    /// A [`ParamKind::U64`] parameter.
    pub fn u64(&self, key: &str) -> u64 {
        match self.get(key) {
            ParamValue::U64(v) => v,
            other => panic!("parameter `{key}` is {other:?}, not a u64"),
        }
    }

    /// A real parameter (declared [`ParamKind::Float`]).
    pub fn float(&self, key: &str) -> f64 {
        match self.get(key) {
            ParamValue::Float(v) => v,
            other => panic!("parameter `{key}` is {other:?}, not a number"),
        }
    }

    /// A choice parameter (declared [`ParamKind::Choice`]).
    pub fn choice(&self, key: &str) -> &'static str {
        match self.get(key) {
            ParamValue::Choice(v) => v,
            other => panic!("parameter `{key}` is {other:?}, not a choice"),
        }
    }

    /// `key=value` for every parameter, space-separated (for facts and labels).
    pub fn describe(&self) -> String {
        self.values
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The parameters and values, in declaration order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, ParamValue)> + '_ {
        self.values.iter().copied()
    }
}

/// Splits `key=value` (whitespace around either trimmed); the error says what was expected.
pub fn split_pair(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() && !v.trim().is_empty() => {
            Ok((k.trim().to_string(), v.trim().to_string()))
        }
        _ => Err(format!("`{text}` is not of the form key=value")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPECS: &[ParamSpec] = &[
        ParamSpec {
            key: "n",
            kind: ParamKind::Int { min: 1, max: 33 },
            default: "3",
            description: "taps",
        },
        ParamSpec {
            key: "w",
            kind: ParamKind::Float { min: 0.0, max: 2.0 },
            default: "0.5",
            description: "width, world units",
        },
        ParamSpec {
            key: "mode",
            kind: ParamKind::Choice(&["a", "b"]),
            default: "a",
            description: "mode",
        },
    ];

    fn given(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn defaults_and_overrides() {
        let p = Params::defaults("t", SPECS).unwrap();
        assert_eq!((p.int("n"), p.float("w"), p.choice("mode")), (3, 0.5, "a"));
        let p = Params::resolve("t", SPECS, &given(&[("mode", "b"), ("n", "33")])).unwrap();
        assert_eq!((p.int("n"), p.choice("mode")), (33, "b"));
        assert_eq!(p.describe(), "n=33 w=0.5 mode=b");
    }

    #[test]
    fn errors_name_algorithm_key_and_range() {
        for (pairs, needle) in [
            (vec![("n", "0")], "`n` 0 is out of range 1..=33"),
            (vec![("n", "x")], "`n` `x` is not a whole number"),
            (vec![("w", "nan")], "`w` NaN is out of range"),
            (vec![("w", "inf")], "`w` inf is out of range"),
            (vec![("mode", "c")], "`mode` `c` is not one of a|b"),
            (vec![("zz", "1")], "`zz` is unknown (parameters: n, w, mode)"),
            (vec![("n", "2"), ("n", "3")], "`n` is given twice"),
        ] {
            let e = Params::resolve("t", SPECS, &given(&pairs))
                .unwrap_err()
                .to_string();
            assert!(e.contains("algorithm t") && e.contains(needle), "{e}");
        }
    }

    #[test]
    fn pairs_split() {
        assert_eq!(split_pair(" a = 1 ").unwrap(), ("a".into(), "1".into()));
        for bad in ["a", "=1", "a=", ""] {
            assert!(split_pair(bad).is_err(), "{bad}");
        }
    }
}
