//! The `host` machine preset: the model describing the CPU sism runs on, built from the host's facts
//! ([`HostFacts`]), so the model's predictions can be checked against measured host times (`sism
//! validate`). This module only turns facts into a configuration; reading them off the operating
//! system is [`crate::host::probe`]'s job, done once by the caller and passed in.
//!
//! The facts (read on Linux; elsewhere the fallbacks below):
//! * cores: the host threads sism may use ([`std::thread::available_parallelism`]); one hardware
//!   thread per modelled core (a host's SMT siblings are separate host threads);
//! * clock: `cpu MHz` of `/proc/cpuinfo` (the nominal or current frequency the kernel reports;
//!   fallback 2.5 GHz). Cycle costs are fitted at this clock by `sism calibrate`, so a wrong clock is
//!   absorbed by the fit and does not bias predicted milliseconds;
//! * caches: `/sys/devices/system/cpu/cpu0/cache/index*/{level,type,size,ways_of_associativity}`.
//!   The L1 data cache and the L2 are private per core, the L3 (if any) is modelled as one cache
//!   shared by all cores. An associativity whose set count is not a power of two (the model's caches
//!   index by bit masks) is lowered to the nearest one that gives a power of two;
//! * the microarchitecture family (`vendor_id`, `cpu family`, `model`), which picks a row of
//!   [`FAMILIES`]: per-instruction-class costs and latencies.
//!
//! The SIMD backend in use decides the vector costs: the AVX-512 backend runs one recorded 16-lane
//! instruction as about one `zmm` instruction; the portable backend runs it as a loop the compiler
//! vectorises to a few 256- or 128-bit instructions (or none), several cycles each. The family table
//! is a documented starting point, from vendors' optimisation guides and public instruction tables
//! (Agner Fog's, uops.info) rounded to what a loop of such instructions sustains; `sism calibrate`
//! replaces its issue and memory figures by figures fitted to microbenchmarks on this host.

use super::config::MachineConfig;

/// Costs of one microarchitecture family (cycles at the host's clock). See the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuFamily {
    /// Short name (`zen4`, `zen5`, `icelake-sp`, `sapphire-rapids`, `generic-x86`).
    pub name: &'static str,
    /// One 16-lane ALU/FMA/load/store on the AVX-512 backend, cycles of issue (2 vector pipes: 0.5;
    /// a double-pumped 512-bit unit: 1).
    pub vector_avx512: f64,
    /// The same on the portable backend (a 16-iteration loop, auto-vectorised to 256-bit at best).
    pub vector_portable: f64,
    /// Latency of a vector add/mul/fma, cycles: the mean over the calibration chain's mix of 3 adds,
    /// 2 muls and 3 FMAs (Zen 5: 2/3/4; Zen 4: 3/3/4; Intel: 4/4/4). The same on every backend: a
    /// 16-lane operation split into 256- or 128-bit halves runs its halves side by side.
    pub vector_latency: f64,
    /// One 16-lane contiguous load or store on the AVX-512 backend (2–3 load ports), cycles.
    pub load_store: f64,
    /// One compress or expand on the AVX-512 backend (a memory-form compress is microcoded), cycles.
    pub compress: f64,
    /// One scalar instruction, cycles (4-wide integer issue: 0.25–0.3).
    pub scalar: f64,
    /// Least cost of one 16-lane gather or scatter, cycles (about a lane per cycle on the AVX-512
    /// backend; scatters are slower, gathers faster, this is their mean).
    pub gather: f64,
    /// One long-latency vector op (div, sqrt, rcp, rsqrt), cycles of throughput at 16 lanes.
    pub transcendental: u32,
    /// One 16-lane fetch-add (emulated per lane with locked adds on x86), cycles.
    pub atomic: u32,
    /// L2 hit latency, cycles.
    pub l2_latency: u32,
    /// L3 hit latency, cycles.
    pub l3_latency: u32,
    /// DRAM latency, ns (a VM's memory, loaded).
    pub dram_latency_ns: f64,
    /// Misses in flight per core that the out-of-order core and its prefetchers overlap.
    pub memory_parallelism: f64,
    /// DRAM bandwidth one core draws, GB/s (the model multiplies by nothing: it is the chip's).
    pub dram_bandwidth_gbs: f64,
    /// Host scheduler cost per task (rayon's work stealing, a task's set-up), cycles.
    pub task_overhead: f64,
    /// Host cost of the join ending a step (rayon's), cycles.
    pub barrier: u32,
    /// Second-level data TLB entries for 4 KiB pages (AMD's and Intel's optimisation guides).
    pub tlb_entries: u32,
    /// Store-buffer entries of one core (the vendors' optimisation guides):
    /// [`MachineConfig::store_buffer_entries`].
    pub store_buffer_entries: u32,
}

/// The family table. Zen 4 double-pumps 512-bit operations; Zen 5 and Intel's server cores have two
/// full 512-bit pipes.
pub const FAMILIES: &[CpuFamily] = &[
    CpuFamily {
        name: "zen5",
        vector_avx512: 0.6,
        vector_portable: 4.0,
        vector_latency: 3.0,
        load_store: 0.5,
        compress: 4.0,
        scalar: 0.3,
        gather: 8.0,
        transcendental: 6,
        atomic: 64,
        l2_latency: 14,
        l3_latency: 50,
        dram_latency_ns: 110.0,
        memory_parallelism: 8.0,
        dram_bandwidth_gbs: 30.0,
        task_overhead: 2000.0,
        barrier: 10_000,
        tlb_entries: 4096,
        store_buffer_entries: 104,
    },
    CpuFamily {
        name: "zen4",
        vector_avx512: 1.0,
        vector_portable: 4.0,
        vector_latency: 3.4,
        load_store: 0.5,
        compress: 4.0,
        scalar: 0.3,
        gather: 10.0,
        transcendental: 8,
        atomic: 64,
        l2_latency: 14,
        l3_latency: 50,
        dram_latency_ns: 110.0,
        memory_parallelism: 8.0,
        dram_bandwidth_gbs: 30.0,
        task_overhead: 2000.0,
        barrier: 10_000,
        tlb_entries: 3072,
        store_buffer_entries: 64,
    },
    CpuFamily {
        name: "sapphire-rapids",
        vector_avx512: 0.6,
        vector_portable: 4.0,
        vector_latency: 4.0,
        load_store: 0.5,
        compress: 4.0,
        scalar: 0.3,
        gather: 8.0,
        transcendental: 8,
        atomic: 64,
        l2_latency: 16,
        l3_latency: 70,
        dram_latency_ns: 120.0,
        memory_parallelism: 8.0,
        dram_bandwidth_gbs: 25.0,
        task_overhead: 2000.0,
        barrier: 10_000,
        tlb_entries: 2048,
        store_buffer_entries: 114,
    },
    CpuFamily {
        name: "icelake-sp",
        vector_avx512: 0.7,
        vector_portable: 4.0,
        vector_latency: 4.0,
        load_store: 0.5,
        compress: 4.0,
        scalar: 0.3,
        gather: 8.0,
        transcendental: 8,
        atomic: 64,
        l2_latency: 14,
        l3_latency: 70,
        dram_latency_ns: 120.0,
        memory_parallelism: 8.0,
        dram_bandwidth_gbs: 20.0,
        task_overhead: 2000.0,
        barrier: 10_000,
        tlb_entries: 1536,
        store_buffer_entries: 72,
    },
    CpuFamily {
        name: "generic-x86",
        vector_avx512: 1.0,
        vector_portable: 5.0,
        vector_latency: 4.0,
        load_store: 0.5,
        compress: 4.0,
        scalar: 0.35,
        gather: 12.0,
        transcendental: 10,
        atomic: 80,
        l2_latency: 14,
        l3_latency: 60,
        dram_latency_ns: 120.0,
        memory_parallelism: 6.0,
        dram_bandwidth_gbs: 20.0,
        task_overhead: 2000.0,
        barrier: 10_000,
        tlb_entries: 1536,
        store_buffer_entries: 56,
    },
];

/// The family of a CPU from `/proc/cpuinfo`'s vendor, family and model numbers.
pub fn family_of(vendor: &str, family: u32, model: u32) -> &'static CpuFamily {
    let name = match (vendor, family, model) {
        ("AuthenticAMD", 26, _) => "zen5",
        ("AuthenticAMD", 25, m) if m >= 0x10 => "zen4",
        ("GenuineIntel", 6, 143 | 207 | 173 | 174) => "sapphire-rapids",
        ("GenuineIntel", 6, 106 | 108 | 125 | 126) => "icelake-sp",
        _ => "generic-x86",
    };
    FAMILIES
        .iter()
        .find(|f| f.name == name)
        .expect("every name is in the table")
}

/// What was read off the host.
#[derive(Clone, Debug, PartialEq)]
pub struct HostFacts {
    /// `model name` of `/proc/cpuinfo` (or `unknown`).
    pub model_name: String,
    /// `vendor_id` of `/proc/cpuinfo` (empty when missing).
    pub vendor: String,
    /// `cpu family` of `/proc/cpuinfo` (0 when missing).
    pub family: u32,
    /// `model` of `/proc/cpuinfo` (0 when missing).
    pub model: u32,
    /// Clock, GHz.
    pub clock_ghz: f64,
    /// Host threads sism may use.
    pub threads: u32,
    /// Hardware threads per physical core among them (SMT siblings in `/sys`; 1 without SMT).
    pub threads_per_core: u32,
    /// Caches: (level, size KB, ways), data and unified only, in level order.
    pub caches: Vec<(u32, u32, u32)>,
    /// The SIMD backend this process runs its kernels on (it decides the vector costs).
    pub backend: sism_simd::BackendKind,
}

#[cfg(test)]
impl HostFacts {
    /// The project's Intel Xeon VM (Emerald Rapids, family 6 model 207, 2 threads without SMT,
    /// 2.1 GHz, AVX-512) with `caches` (level, KB, ways): the tests' stand-in for a probed host.
    pub(crate) fn xeon_vm(caches: Vec<(u32, u32, u32)>) -> HostFacts {
        HostFacts {
            model_name: "test".into(),
            vendor: "GenuineIntel".into(),
            family: 6,
            model: 207,
            clock_ghz: 2.1,
            threads: 2,
            threads_per_core: 1,
            caches,
            backend: sism_simd::BackendKind::Avx512,
        }
    }
}

/// The most ways ≤ `ways` for which a cache of `kb` KB with 64-byte lines has a power-of-two
/// number of sets (the model's caches index by masks). `None` when the size is not a multiple of a
/// line or no associativity works.
pub fn valid_ways(kb: u32, ways: u32) -> Option<u32> {
    let lines = kb as u64 * 1024 / 64;
    if lines == 0 {
        return None;
    }
    (1..=ways.clamp(1, 64))
        .rev()
        .find(|&w| lines.is_multiple_of(w as u64) && (lines / w as u64).is_power_of_two())
}

/// The `host` preset for `facts`, with the vector costs of `backend` (usually `facts.backend`).
pub fn host_preset_from(facts: &HostFacts, backend: sism_simd::BackendKind) -> MachineConfig {
    let fam = family_of(&facts.vendor, facts.family, facts.model);
    // A cache whose reported size has no associativity with power-of-two sets (Intel's shared
    // caches often do not: 300 MiB of 20 ways is 245,760 sets) is modelled at the largest power of
    // two below it, not dropped: dropping it left such a host with no shared cache, and its
    // calibration sized the "DRAM" benchmarks to fit in it.
    let cache = |level: u32, default: (u32, u32)| {
        facts
            .caches
            .iter()
            .find(|c| c.0 == level)
            .and_then(|&(_, kb, ways)| {
                valid_ways(kb, ways).map(|w| (kb, w)).or_else(|| {
                    let pow2 = 1u32 << kb.checked_ilog2()?;
                    valid_ways(pow2, ways).map(|w| (pow2, w))
                })
            })
            .unwrap_or(default)
    };
    let (l1_kb, l1_ways) = cache(1, (32, 8));
    let (l2_kb, l2_ways) = cache(2, (1024, 16));
    // No shared cache the OS reports: none modelled.
    let (l3_kb, l3_ways) = cache(3, (0, 16));
    // The portable backend compiled for AVX2 runs a 16-lane op as two 256-bit ones at best; for the
    // baseline target (SSE2) as four 128-bit ones or a scalar loop.
    use sism_simd::BackendKind;
    let (vector, slow) = match backend {
        // AVX2 runs a vector as two 256-bit operations: as one AVX-512 operation on cores that split
        // those in two (Zen 4), up to twice it elsewhere; `sism calibrate` measures it.
        BackendKind::Avx512 | BackendKind::Avx2 => (fam.vector_avx512, 1),
        BackendKind::PortableAvx2 => (fam.vector_portable * 0.5, 2),
        BackendKind::Portable => (fam.vector_portable, 4),
    };
    // A line over one core's share of DRAM's bandwidth, cycles: where streamed loads and
    // write-backs start before `sism calibrate` fits each.
    let dram_line_cycles = 64.0 / fam.dram_bandwidth_gbs * facts.clock_ghz;
    MachineConfig {
        name: "host".into(),
        // SMT siblings are one modelled core with that many threads.
        cores: facts.threads.div_ceil(facts.threads_per_core.max(1)),
        threads_per_core: facts.threads_per_core.clamp(1, facts.threads.max(1)),
        simd_width: 16,
        clock_ghz: facts.clock_ghz,
        vector_issue_per_clock: 1,
        scalar_issue_per_clock: 1,
        l1_kb,
        l1_ways,
        l1_latency: 0,
        l2_kb,
        l2_ways,
        l2_latency: fam.l2_latency,
        line_bytes: 64,
        ring_hop_latency: 0,
        ring_bytes_per_clock: 64,
        dram_latency_ns: fam.dram_latency_ns,
        dram_bandwidth_gbs: fam.dram_bandwidth_gbs * facts.threads.min(8) as f64,
        atomic_cycles: fam.atomic,
        atomic_conflict_cycles: 0,
        barrier_cycles: fam.barrier,
        // Host gathers cost per lane (the `gather_cycles` floor), not per line.
        gather_cycles_per_line: 0,
        transcendental_cycles: fam.transcendental * slow,
        vector_cycles: vector,
        load_store_cycles: fam.load_store * slow as f64,
        compress_cycles: fam.compress * slow as f64,
        scalar_cycles: fam.scalar,
        // The divider's occupancy per divide or square root (`divss` 3.5, `sqrtss` ~5 cycles of
        // reciprocal throughput on Zen 4 and Ice Lake): its latency is on the recorded chains.
        scalar_div_cycles: 4.0,
        gather_cycles: fam.gather * (1.0 + 0.25 * (slow - 1) as f64),
        separate_ports: true,
        // The host runs its serial steps serially (see the field).
        serial_steps: true,
        memory_parallelism: fam.memory_parallelism,
        task_overhead_cycles: fam.task_overhead,
        tlb_entries: fam.tlb_entries,
        store_buffer_entries: fam.store_buffer_entries,
        // A page walk with the page-walk caches at work (assumption, for every family).
        tlb_miss_cycles: 30.0,
        // The family's float add latency against the nominal one the records are measured in.
        latency_scale: fam.vector_latency / sism_simd::latency::ARITH as f64,
        l3_kb,
        l3_ways,
        l3_latency: if l3_kb > 0 { fam.l3_latency } else { 0 },
        // Stream prefetchers (every family here has L1 and L2 stream prefetchers): a prefetched
        // line costs its level's throughput. Starting points, replaced by `sism calibrate`: L2
        // about 32 bytes a cycle, the shared cache half that, DRAM a line over one core's share.
        prefetcher: true,
        stream_l2_cycles: 1.0,
        stream_l3_cycles: 2.0,
        stream_dram_cycles: dram_line_cycles,
        // A young stream's misses (its first 4 KiB): starting point, fitted by `sism calibrate`.
        stream_ramp_share: 0.6,
        // A dirty line written back: starting point (as a streamed load), fitted by `sism calibrate`
        // on streaming stores.
        writeback_cycles: dram_line_cycles,
        // A mispredicted branch: starting point (Zen 4's typical penalty, AMD's optimisation
        // guide), fitted by `sism calibrate` on a branch on random data.
        mispredict_cycles: 13.0,
        // A scalar float operation on the vector pipes: starting point (one 256-bit pipe slot, a
        // 16-lane AVX-512 operation taking two: half its cost), fitted by `sism calibrate` on
        // vector chains interleaved with scalar float chains.
        scalar_float_cycles: fam.vector_avx512 / 2.0,
        // A compare or select beyond an add's cost: nothing with mask registers; fitted by `sism
        // calibrate` on the compare/select benchmark (the portable backend's are dear).
        mask_move_cycles: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ways_made_valid() {
        assert_eq!(valid_ways(48, 12), Some(12)); // 768 lines / 12 = 64 sets
        assert_eq!(valid_ways(1024, 16), Some(16));
        assert_eq!(valid_ways(1280, 20), Some(20)); // 20480 / 20 = 1024
        assert_eq!(valid_ways(1536, 12), Some(12)); // 24576 / 12 = 2048
        assert_eq!(valid_ways(36 * 1024, 12), Some(9)); // 589824 / 9 = 65536
        assert_eq!(valid_ways(0, 8), None);
    }

    #[test]
    fn presets_for_both_backends_and_families_validate() {
        for (vendor, family, model) in [
            ("AuthenticAMD", 26, 2),
            ("AuthenticAMD", 25, 17),
            ("GenuineIntel", 6, 143),
            ("GenuineIntel", 6, 106),
            ("Other", 0, 0),
        ] {
            for caches in [
                vec![],
                vec![(1, 48, 12), (2, 1024, 16), (3, 32768, 16)],
                vec![(1, 37, 7), (2, 1000, 9)],
            ] {
                let facts = HostFacts {
                    model_name: "test".into(),
                    vendor: vendor.into(),
                    family,
                    model,
                    clock_ghz: 2.6,
                    threads: 2,
                    threads_per_core: 2,
                    caches,
                    backend: sism_simd::BackendKind::Portable,
                };
                for b in [
                    sism_simd::BackendKind::Portable,
                    sism_simd::BackendKind::PortableAvx2,
                    sism_simd::BackendKind::Avx2,
                    sism_simd::BackendKind::Avx512,
                ] {
                    let m = host_preset_from(&facts, b);
                    m.validate()
                        .unwrap_or_else(|(k, e)| panic!("{vendor} {b:?}: {k} {e}"));
                    // Two SMT siblings: one core with two threads.
                    assert!(m.separate_ports && m.cores == 1 && m.threads_per_core == 2);
                }
            }
        }
        assert_eq!(family_of("AuthenticAMD", 26, 2).name, "zen5");
        assert_eq!(family_of("GenuineIntel", 6, 143).name, "sapphire-rapids");
    }

    #[test]
    fn a_shared_cache_without_power_of_two_sets_is_modelled_at_the_power_of_two_below() {
        // The Emerald Rapids VM's /sys: 48 KiB of 12 ways, 2 MiB of 16, 300 MiB of 20 ways.
        let facts = HostFacts::xeon_vm(vec![(1, 48, 12), (2, 2048, 16), (3, 307_200, 20)]);
        let m = host_preset_from(&facts, sism_simd::BackendKind::Avx512);
        m.validate().unwrap();
        assert_eq!((m.l1_kb, m.l1_ways), (48, 12));
        assert_eq!((m.l2_kb, m.l2_ways), (2048, 16));
        // 256 MiB: 4 Mi lines, 16 ways of 2^18 sets.
        assert_eq!((m.l3_kb, m.l3_ways), (262_144, 16));
        assert!(m.l3_latency > 0);
    }

    #[test]
    fn the_host_preset_needs_facts() {
        assert!(MachineConfig::preset("host").is_none());
        let e = MachineConfig::resolve("host", None).unwrap_err().to_string();
        assert!(e.contains("host"), "{e}");
    }
}
