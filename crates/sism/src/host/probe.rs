//! Reading the host's facts off the operating system: `/proc/cpuinfo`, `/sys`'s cache topology, the
//! thread count and the SIMD backend selected (`SISM_SIMD` or the best available). The machine model
//! never does this itself: a caller probes once ([`crate::host::facts`]) and passes the facts in.

use std::path::Path;

use crate::machine::host::HostFacts;

/// Reads the host's facts (see the module docs); every missing file falls back to a documented
/// default.
pub fn probe() -> HostFacts {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        cpuinfo
            .lines()
            .find(|l| l.split(':').next().map(str::trim) == Some(key))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().to_string())
    };
    let mhz = field("cpu MHz")
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|m| m.is_finite() && (100.0..=20_000.0).contains(m));
    let threads = std::thread::available_parallelism()
        .map(|n| n.get() as u32)
        .unwrap_or(1)
        .clamp(1, 4096);
    HostFacts {
        model_name: field("model name").unwrap_or_else(|| "unknown".into()),
        vendor: field("vendor_id").unwrap_or_default(),
        family: field("cpu family").and_then(|v| v.parse().ok()).unwrap_or(0),
        model: field("model").and_then(|v| v.parse().ok()).unwrap_or(0),
        clock_ghz: mhz.map(|m| m / 1000.0).unwrap_or(2.5),
        threads,
        threads_per_core: read_siblings(Path::new(
            "/sys/devices/system/cpu/cpu0/topology/thread_siblings_list",
        ))
        .clamp(1, threads),
        caches: read_caches(Path::new("/sys/devices/system/cpu/cpu0/cache")),
        backend: sism_simd::selected_backend(),
    }
}

/// Hardware threads of cpu0's core: the CPUs its `thread_siblings_list` names (`0`, `0,64`,
/// `0-1`); 1 when the file is missing or unreadable.
fn read_siblings(path: &Path) -> u32 {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    parse_cpu_list(text.trim()).unwrap_or(1).max(1)
}

/// The number of CPUs in a `/sys` CPU list (`0-3,8,10-11` → 7); `None` when malformed.
fn parse_cpu_list(s: &str) -> Option<u32> {
    let mut n = 0u32;
    for part in s.split(',') {
        n = n.checked_add(match part.split_once('-') {
            Some((a, b)) => {
                b.trim()
                    .parse::<u32>()
                    .ok()?
                    .checked_sub(a.trim().parse::<u32>().ok()?)?
                    + 1
            }
            None => {
                part.trim().parse::<u32>().ok()?;
                1
            }
        })?;
    }
    Some(n)
}

/// The data and unified caches under `dir` (`index*/`), as (level, KB, ways), sorted by level.
fn read_caches(dir: &Path) -> Vec<(u32, u32, u32)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for e in entries.flatten() {
        let p = e.path();
        if !p
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("index"))
        {
            continue;
        }
        let read = |f: &str| {
            std::fs::read_to_string(p.join(f))
                .unwrap_or_default()
                .trim()
                .to_string()
        };
        if read("type") == "Instruction" || read("coherency_line_size") != "64" {
            continue;
        }
        let (Ok(level), Some(kb), Ok(ways)) = (
            read("level").parse::<u32>(),
            parse_kb(&read("size")),
            read("ways_of_associativity").parse::<u32>(),
        ) else {
            continue;
        };
        out.push((level, kb, ways.max(1)));
    }
    out.sort();
    out.dedup_by_key(|c| c.0);
    out
}

/// `48K`, `1024K`, `32M` → KB.
fn parse_kb(s: &str) -> Option<u32> {
    let (num, mul) = match s.as_bytes().last()? {
        b'K' => (&s[..s.len() - 1], 1),
        b'M' => (&s[..s.len() - 1], 1024),
        b'G' => (&s[..s.len() - 1], 1024 * 1024),
        _ => (s, 1),
    };
    num.parse::<u32>().ok()?.checked_mul(mul)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cache_sizes_parse() {
        assert_eq!(parse_kb("48K"), Some(48));
        assert_eq!(parse_kb("32M"), Some(32 * 1024));
        assert_eq!(parse_kb("512"), Some(512));
        assert_eq!(parse_kb("junk"), None);
        assert_eq!(parse_kb(""), None);
    }

    #[test]
    fn cpu_lists_parse() {
        assert_eq!(parse_cpu_list("0"), Some(1));
        assert_eq!(parse_cpu_list("0,64"), Some(2));
        assert_eq!(parse_cpu_list("0-1"), Some(2));
        assert_eq!(parse_cpu_list("0-3,8,10-11"), Some(7));
        assert_eq!(parse_cpu_list("3-1"), None);
        assert_eq!(parse_cpu_list(""), None);
        assert_eq!(parse_cpu_list("x"), None);
    }

    #[test]
    fn this_host_gives_a_valid_preset() {
        let f = probe();
        assert!(f.threads >= 1);
        assert!(f.clock_ghz > 0.0 && f.clock_ghz.is_finite());
        let m = crate::host::resolve_machine("host").expect("host is a preset");
        m.validate().expect("valid");
        assert!(m.cores >= 1);
    }
}
