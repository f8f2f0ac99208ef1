//! Algorithm parameters: each algorithm declares its parameters ([`ParamSpec`]: key, kind with range,
//! default, description with unit) in its registry entry; users give `key=value` pairs, which are
//! checked against the declarations ([`Params::resolve`]) with errors that name the algorithm, the key
//! and the allowed range.

use std::fmt;

/// What values a parameter takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamKind {
    /// A whole number in `min..=max`.
    Int {
        /// Smallest allowed value.
        min: i64,
        /// Largest allowed value.
        max: i64,
    },
    /// An odd whole number in `min..=max` (a kernel side with a centre tap).
    OddInt {
        /// Smallest allowed value.
        min: i64,
        /// Largest allowed value.
        max: i64,
    },
    /// An unsigned 64-bit number (seeds), any value.
    U64,
    /// A finite real number in `[min, max]`.
    Float {
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// One of the names.
    Choice(&'static [&'static str]),
}

/// One declared parameter of an algorithm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    /// The key users write (`spp`, `slices`).
    pub key: &'static str,
    /// What values it takes, with their range.
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
    /// A whole number (kinds [`ParamKind::Int`] and [`ParamKind::OddInt`]).
    Int(i64),
    /// An unsigned 64-bit number (kind [`ParamKind::U64`]).
    U64(u64),
    /// A finite real number (kind [`ParamKind::Float`]).
    Float(f64),
    /// One of the declared names (kind [`ParamKind::Choice`]).
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
    /// The algorithm's name.
    pub algorithm: String,
    /// The parameter's key.
    pub key: String,
    /// What is wrong with the value, with the allowed range.
    pub message: String,
}

/// A parameter read as an `i64`: a [`ParamSpec`] of kind [`ParamKind::Int`] or [`ParamKind::OddInt`]
/// (any other kind does not compile: the check runs in const evaluation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntParam {
    spec: ParamSpec,
}

/// A parameter read as a `u64`: a [`ParamSpec`] of kind [`ParamKind::U64`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct U64Param {
    spec: ParamSpec,
}

/// A parameter read as an `f64`: a [`ParamSpec`] of kind [`ParamKind::Float`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloatParam {
    spec: ParamSpec,
}

/// A parameter read as a `T`: a [`ParamSpec`] of kind [`ParamKind::Choice`] and the value of each
/// name, in the same order, so that code matches on `T` instead of comparing names it could misspell.
#[derive(Debug, PartialEq)]
pub struct ChoiceParam<T: 'static> {
    spec: ParamSpec,
    values: &'static [T],
}

impl<T> Clone for ChoiceParam<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for ChoiceParam<T> {}

impl IntParam {
    /// Wraps `spec`, whose kind must be [`ParamKind::Int`] or [`ParamKind::OddInt`] (checked in const
    /// evaluation).
    pub const fn new(spec: ParamSpec) -> IntParam {
        assert!(
            matches!(spec.kind, ParamKind::Int { .. } | ParamKind::OddInt { .. }),
            "an IntParam's kind is Int or OddInt"
        );
        IntParam { spec }
    }
}

impl U64Param {
    /// Wraps `spec`, whose kind must be [`ParamKind::U64`] (checked in const evaluation).
    pub const fn new(spec: ParamSpec) -> U64Param {
        assert!(matches!(spec.kind, ParamKind::U64), "a U64Param's kind is U64");
        U64Param { spec }
    }
}

impl FloatParam {
    /// Wraps `spec`, whose kind must be [`ParamKind::Float`] (checked in const evaluation).
    pub const fn new(spec: ParamSpec) -> FloatParam {
        assert!(
            matches!(spec.kind, ParamKind::Float { .. }),
            "a FloatParam's kind is Float"
        );
        FloatParam { spec }
    }
}

impl<T> ChoiceParam<T> {
    /// `values[i]` is what name `i` of the spec's choices reads as.
    pub const fn new(spec: ParamSpec, values: &'static [T]) -> ChoiceParam<T> {
        match spec.kind {
            ParamKind::Choice(names) => assert!(
                !names.is_empty() && names.len() == values.len(),
                "a ChoiceParam has one value per name"
            ),
            _ => panic!("a ChoiceParam's kind is Choice"),
        }
        ChoiceParam { spec, values }
    }
}

/// The declaration and its variants, shared by the typed parameters.
macro_rules! typed_param_spec {
    ($($name:ident$(<$t:ident>)?),*) => {$(
        impl$(<$t>)? $name$(<$t>)? {
            /// The declaration, for an algorithm's parameter list.
            pub const fn spec(&self) -> ParamSpec {
                self.spec
            }

            /// The same parameter with another default (valid: the registry's test parses it).
            pub const fn with_default(self, default: &'static str) -> Self {
                let mut p = self;
                p.spec.default = default;
                p
            }

            /// The same parameter with another description.
            pub const fn with_description(self, description: &'static str) -> Self {
                let mut p = self;
                p.spec.description = description;
                p
            }
        }
    )*};
}

typed_param_spec!(IntParam, U64Param, FloatParam, ChoiceParam<T>);

/// A typed parameter: what [`Params::get`] reads through.
pub trait TypedParam {
    /// What a read gives.
    type Value;
    /// The declaration whose key is read.
    fn declaration(&self) -> &ParamSpec;
    /// `value` as this parameter's type, if it is of its kind.
    fn decode(&self, value: ParamValue) -> Option<Self::Value>;
    /// The last resort when even the default does not decode: the lowest allowed value.
    fn lowest(&self) -> Self::Value;
}

impl TypedParam for IntParam {
    type Value = i64;
    fn declaration(&self) -> &ParamSpec {
        &self.spec
    }
    fn decode(&self, value: ParamValue) -> Option<i64> {
        match value {
            ParamValue::Int(v) => Some(v),
            _ => None,
        }
    }
    fn lowest(&self) -> i64 {
        match self.spec.kind {
            ParamKind::Int { min, .. } | ParamKind::OddInt { min, .. } => min,
            _ => 0,
        }
    }
}

impl TypedParam for U64Param {
    type Value = u64;
    fn declaration(&self) -> &ParamSpec {
        &self.spec
    }
    fn decode(&self, value: ParamValue) -> Option<u64> {
        match value {
            ParamValue::U64(v) => Some(v),
            _ => None,
        }
    }
    fn lowest(&self) -> u64 {
        0
    }
}

impl TypedParam for FloatParam {
    type Value = f64;
    fn declaration(&self) -> &ParamSpec {
        &self.spec
    }
    fn decode(&self, value: ParamValue) -> Option<f64> {
        match value {
            ParamValue::Float(v) => Some(v),
            _ => None,
        }
    }
    fn lowest(&self) -> f64 {
        match self.spec.kind {
            ParamKind::Float { min, .. } => min,
            _ => 0.0,
        }
    }
}

impl<T: Copy> TypedParam for ChoiceParam<T> {
    type Value = T;
    fn declaration(&self) -> &ParamSpec {
        &self.spec
    }
    fn decode(&self, value: ParamValue) -> Option<T> {
        let (ParamValue::Choice(name), ParamKind::Choice(names)) = (value, self.spec.kind) else {
            return None;
        };
        let i = names.iter().position(|n| *n == name)?;
        self.values.get(i).copied()
    }
    fn lowest(&self) -> T {
        self.values[0]
    }
}

/// Every declared parameter of one algorithm with its checked value (given or default).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    values: Vec<(&'static str, ParamKind, ParamValue)>,
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
            values.push((spec.key, spec.kind, value));
        }
        Ok(Params { values })
    }

    /// The defaults of `specs`.
    pub fn defaults(algorithm: &str, specs: &[ParamSpec]) -> Result<Params, ParamError> {
        Self::resolve(algorithm, specs, &[])
    }

    /// The value of `param`, which the algorithm declares (same key and kind). A parameter it does not
    /// declare is a bug the registry's tests catch (debug assertion); in a release build the read
    /// gives `param`'s default rather than fail a render.
    pub fn get<P: TypedParam>(&self, param: &P) -> P::Value {
        let spec = param.declaration();
        let declared = self
            .values
            .iter()
            .find(|(key, kind, _)| *key == spec.key && *kind == spec.kind);
        debug_assert!(
            declared.is_some(),
            "parameter `{}` ({}) is not declared by this algorithm",
            spec.key,
            spec.range()
        );
        declared
            .and_then(|&(_, _, v)| param.decode(v))
            .or_else(|| spec.parse(spec.default).ok().and_then(|v| param.decode(v)))
            .unwrap_or_else(|| param.lowest())
    }

    /// `key=value` for every parameter, space-separated (for facts and labels).
    pub fn describe(&self) -> String {
        self.values
            .iter()
            .map(|(k, _, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The parameters and values, in declaration order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, ParamValue)> + '_ {
        self.values.iter().map(|&(k, _, v)| (k, v))
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

    const N: IntParam = IntParam::new(ParamSpec {
        key: "n",
        kind: ParamKind::Int { min: 1, max: 33 },
        default: "3",
        description: "taps",
    });
    const W: FloatParam = FloatParam::new(ParamSpec {
        key: "w",
        kind: ParamKind::Float { min: 0.0, max: 2.0 },
        default: "0.5",
        description: "width, world units",
    });
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Mode {
        A,
        B,
    }
    const MODE: ChoiceParam<Mode> = ChoiceParam::new(
        ParamSpec {
            key: "mode",
            kind: ParamKind::Choice(&["a", "b"]),
            default: "a",
            description: "mode",
        },
        &[Mode::A, Mode::B],
    );
    const SPECS: &[ParamSpec] = &[N.spec(), W.spec(), MODE.spec()];

    fn given(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn defaults_and_overrides() {
        let p = Params::defaults("t", SPECS).unwrap();
        assert_eq!((p.get(&N), p.get(&W), p.get(&MODE)), (3, 0.5, Mode::A));
        let p = Params::resolve("t", SPECS, &given(&[("mode", "b"), ("n", "33")])).unwrap();
        assert_eq!((p.get(&N), p.get(&MODE)), (33, Mode::B));
        assert_eq!(p.describe(), "n=33 w=0.5 mode=b");
    }

    /// A read of a parameter the algorithm does not declare (or declares with another kind) is a
    /// debug assertion; a release build reads the parameter's default instead of failing.
    #[test]
    #[cfg_attr(debug_assertions, should_panic(expected = "is not declared"))]
    fn undeclared_reads_fall_back_to_the_default() {
        let p = Params::resolve("t", &SPECS[..1], &given(&[("n", "7")])).unwrap();
        assert_eq!(p.get(&W), 0.5);
        let other_kind = IntParam::new(ParamSpec {
            kind: ParamKind::Int { min: 0, max: 9 },
            ..N.spec()
        });
        assert_eq!(p.get(&other_kind), 3);
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
