//! Machine parameters by name: every numeric and on/off field of a machine file, with its kind and
//! documented range ([`super::config::LIMITS`], [`super::config::REAL_LIMITS`]), read and set by its
//! machine-file name. What `study --set KEY=V1,V2` sweeps and `sensitivity` halves and doubles.
//!
//! Values go through the configuration's own serde form, so a key here is exactly a key of the
//! machine file, and a changed configuration is checked by [`MachineConfig::validate`] like a file.

use super::config::{LIMITS, REAL_LIMITS};
use super::MachineConfig;

/// What values a parameter takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// An integer in `min..=max`.
    Integer {
        /// Least value.
        min: u64,
        /// Largest value.
        max: u64,
    },
    /// A finite real in `[min, max]`.
    Real {
        /// Least value.
        min: f64,
        /// Largest value.
        max: f64,
    },
    /// `true` or `false`.
    Flag,
}

/// One machine-file parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// Its machine-file key (`l2_kb`, `dram_bandwidth_gbs`, ...).
    pub name: &'static str,
    /// Its values.
    pub kind: Kind,
}

/// The on/off fields of a machine file.
const FLAGS: &[&str] = &["separate_ports", "serial_steps", "prefetcher"];

/// Every parameter that can be swept, in machine-file order of [`LIMITS`], [`REAL_LIMITS`], then the
/// flags. Fields fixed by the records (`simd_width`, `line_bytes`: one allowed value) are left out.
pub fn all() -> Vec<Param> {
    let integers = LIMITS
        .iter()
        .filter(|(_, lo, hi)| lo != hi)
        .map(|&(name, min, max)| Param {
            name,
            kind: Kind::Integer { min, max },
        });
    let reals = REAL_LIMITS.iter().map(|&(name, min, max)| Param {
        name,
        kind: Kind::Real { min, max },
    });
    let flags = FLAGS.iter().map(|&name| Param {
        name,
        kind: Kind::Flag,
    });
    integers.chain(reals).chain(flags).collect()
}

/// The valid names, comma-separated (for error messages).
pub fn names() -> String {
    all().iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
}

/// The parameter named `name`; an error naming every valid one otherwise.
pub fn find(name: &str) -> Result<Param, String> {
    all().into_iter().find(|p| p.name == name).ok_or_else(|| {
        let fixed = LIMITS.iter().any(|(n, lo, hi)| *n == name && lo == hi);
        if fixed {
            format!("machine parameter `{name}` is fixed by the recorded kernels and cannot be swept")
        } else {
            format!("unknown machine parameter `{name}`; valid: {}", names())
        }
    })
}

/// The value of `p` in `m`, as the machine file writes it.
pub fn get(m: &MachineConfig, p: &Param) -> String {
    let v = serde_json::to_value(m).expect("a machine serialises");
    match &v[p.name] {
        serde_json::Value::Number(n) => n.to_string(),
        other => other.to_string(),
    }
}

/// The value of numeric `p` in `m` as a real (flags: 0 or 1).
pub fn value(m: &MachineConfig, p: &Param) -> f64 {
    let v = serde_json::to_value(m).expect("a machine serialises");
    match &v[p.name] {
        serde_json::Value::Bool(b) => f64::from(u8::from(*b)),
        other => other.as_f64().unwrap_or(f64::NAN),
    }
}

/// Parses `text` as a value of `p`: an integer, a finite real or `true`/`false`, within range.
pub fn parse(p: &Param, text: &str) -> Result<serde_json::Value, String> {
    let t = text.trim();
    let bad = |what: &str| format!("`{}` = `{t}`: {what}", p.name);
    match p.kind {
        Kind::Integer { min, max } => {
            let v: u64 = t
                .parse()
                .map_err(|_| bad(&format!("not an integer in {min}..={max}")))?;
            if v < min || v > max {
                return Err(bad(&format!("out of range {min}..={max}")));
            }
            Ok(serde_json::Value::from(v))
        }
        Kind::Real { min, max } => {
            let v: f64 = t
                .parse()
                .map_err(|_| bad(&format!("not a number in [{min}, {max}]")))?;
            if !(v.is_finite() && v >= min && v <= max) {
                return Err(bad(&format!("out of range [{min}, {max}]")));
            }
            Ok(serde_json::Value::from(v))
        }
        Kind::Flag => match t {
            "true" => Ok(serde_json::Value::Bool(true)),
            "false" => Ok(serde_json::Value::Bool(false)),
            _ => Err(bad("not `true` or `false`")),
        },
    }
}

/// `m` with `p` set to `v` (from [`parse`]), checked as a machine file is (cache geometry, sizes).
pub fn with(m: &MachineConfig, p: &Param, v: &serde_json::Value) -> Result<MachineConfig, String> {
    let mut json = serde_json::to_value(m).expect("a machine serialises");
    json[p.name] = v.clone();
    let out: MachineConfig = serde_json::from_value(json).map_err(|e| format!("`{}`: {e}", p.name))?;
    out.validate().map_err(|(k, msg)| format!("`{k}` {msg}"))?;
    Ok(out)
}

/// `KEY=V1,V2,...` (a `study --set` argument): the parameter and its values, each checked.
pub fn parse_set(arg: &str) -> Result<(Param, Vec<serde_json::Value>), String> {
    let (key, values) = arg
        .split_once('=')
        .ok_or_else(|| format!("--set `{arg}`: expected KEY=V1,V2,... (keys: {})", names()))?;
    let p = find(key.trim())?;
    let values: Vec<_> = values
        .split(',')
        .filter(|v| !v.trim().is_empty())
        .map(|v| parse(&p, v))
        .collect::<Result<_, _>>()?;
    if values.is_empty() {
        return Err(format!("--set `{arg}`: no value"));
    }
    Ok((p, values))
}

/// `m` with numeric `p` multiplied by `factor` (integers rounded; at least one step away from the
/// base value; clamped into the range); `None` when it cannot move (a flag, or already at the
/// bound it would move towards) or the result is not a valid machine.
pub fn scaled(m: &MachineConfig, p: &Param, factor: f64) -> Option<MachineConfig> {
    let base = value(m, p);
    let v = match p.kind {
        Kind::Flag => return None,
        Kind::Integer { min, max } => {
            let mut x = (base * factor).round();
            // Small integers (1 thread, 0 latency) still move by at least one.
            if x == base {
                x = if factor > 1.0 { base + 1.0 } else { base - 1.0 };
            }
            let x = x.clamp(min as f64, max as f64);
            if x == base {
                return None;
            }
            serde_json::Value::from(x as u64)
        }
        Kind::Real { min, max } => {
            let x = (base * factor).clamp(min, max);
            if x == base {
                return None;
            }
            serde_json::Value::from(x)
        }
    };
    with(m, p, &v).ok()
}

/// Whether `p` changes anything the model computes for `m`: the shared cache's fields only with a
/// shared cache, the streaming costs only with a prefetcher, the TLB's miss cost only with a TLB,
/// the out-of-order-only `memory_parallelism` and `latency_scale` on any machine (both apply to
/// in-order cores too), the clock always (it converts DRAM's nanoseconds).
pub fn applies(m: &MachineConfig, p: &Param) -> bool {
    match p.name {
        "l3_ways" | "l3_latency" | "stream_l3_cycles" => m.l3_kb > 0,
        "stream_l2_cycles" | "stream_dram_cycles" | "stream_ramp_share" => m.prefetcher,
        "tlb_miss_cycles" => m.tlb_entries > 0,
        // Zero means "none": doubling nothing is nothing.
        "l3_kb" | "tlb_entries" | "store_buffer_entries" | "task_overhead_cycles" => value(m, p) > 0.0,
        _ => !matches!(p.kind, Kind::Flag),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_reads_and_sets_through_the_machine_file() {
        let m = MachineConfig::larrabee_24();
        for p in all() {
            let text = get(&m, &p);
            let v = parse(&p, &text).unwrap_or_else(|e| panic!("{e}"));
            let same = with(&m, &p, &v).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(same, m, "{}", p.name);
        }
        let l2 = find("l2_kb").unwrap();
        let m2 = with(&m, &l2, &parse(&l2, "512").unwrap()).unwrap();
        assert_eq!(m2.l2_kb, 512);
        let bw = find("dram_bandwidth_gbs").unwrap();
        assert_eq!(scaled(&m, &bw, 2.0).unwrap().dram_bandwidth_gbs, 256.0);
        assert_eq!(scaled(&m, &bw, 0.5).unwrap().dram_bandwidth_gbs, 64.0);
        let t = find("threads_per_core").unwrap();
        assert_eq!(scaled(&m, &t, 0.5).unwrap().threads_per_core, 2);
        // l1_latency 0: halving cannot move it, doubling moves it to 1.
        let l1 = find("l1_latency").unwrap();
        assert!(scaled(&m, &l1, 0.5).is_none());
        assert_eq!(scaled(&m, &l1, 2.0).unwrap().l1_latency, 1);
    }

    #[test]
    fn bad_keys_and_values_name_what_is_valid() {
        let e = find("l2_size").unwrap_err();
        assert!(
            e.contains("unknown machine parameter `l2_size`") && e.contains("l2_kb"),
            "{e}"
        );
        assert!(find("simd_width").unwrap_err().contains("fixed"));
        let e = parse_set("cores=1,x").unwrap_err();
        assert!(e.contains("`cores` = `x`") && e.contains("1..=4096"), "{e}");
        assert!(parse_set("cores=0").unwrap_err().contains("out of range"));
        assert!(parse_set("clock_ghz=NaN").unwrap_err().contains("out of range"));
        assert!(parse_set("clock_ghz").unwrap_err().contains("KEY=V1,V2"));
        assert!(parse_set("prefetcher=yes")
            .unwrap_err()
            .contains("`true` or `false`"));
        assert!(parse_set("cores=").unwrap_err().contains("no value"));
        // A value in its own range that makes the machine invalid (4096 cores of 1 GiB L2).
        let m = MachineConfig::larrabee_24();
        let l2 = find("l2_kb").unwrap();
        let big = with(&m, &l2, &parse(&l2, "1048576").unwrap());
        assert!(big.is_err(), "{big:?}");
    }

    #[test]
    fn what_applies_follows_the_machine() {
        let lrb = MachineConfig::larrabee_24();
        let applies_to = |m: &MachineConfig, name| applies(m, &find(name).unwrap());
        assert!(!applies_to(&lrb, "l3_latency") && !applies_to(&lrb, "stream_l2_cycles"));
        assert!(applies_to(&lrb, "dram_bandwidth_gbs") && applies_to(&lrb, "cores"));
        assert!(!applies_to(&lrb, "prefetcher"));
        let mut host = lrb.clone();
        host.l3_kb = 32_768;
        host.prefetcher = true;
        assert!(applies_to(&host, "l3_latency") && applies_to(&host, "stream_dram_cycles"));
    }
}
