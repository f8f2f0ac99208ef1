//! The modelled chip: a Larrabee-style many-core with in-order cores, hardware threads, a 16-wide
//! vector unit, a private L1 and a local L2 subset per core, joined by a bidirectional ring.
//!
//! What is public about Larrabee comes from Seiler et al. 2008, "Larrabee: a many-core x86
//! architecture for visual computing" (SIGGRAPH 2008): in-order x86 cores, 4 hardware threads per
//! core, a 16-wide vector unit, a 32 KB L1 data cache, a 256 KB local subset of the coherent L2 per
//! core, a bidirectional ring 512 bits wide per direction per clock, one vector and one scalar
//! instruction issued per clock (the dual-issue pipeline). Johnson et al. 2009 simulated 24 cores at
//! 1 GHz. Latencies, associativities, DRAM figures and the costs of atomics, barriers, gathers and
//! transcendentals were never published: every such default below is an **assumption**, chosen from
//! contemporary in-order x86 parts (Atom, Pentium) and Larrabee-era GPUs, and labelled as such.
//!
//! A machine file is TOML. It may start from a preset with `base = "larrabee-24"` (the default base
//! when `base` is absent) and override any field; unknown keys are errors that name the key.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::host::HostFacts;

/// Names of the presets, in order (`host` is built at run time from the CPU sism runs on: see
/// [`super::host`]).
pub const PRESETS: &[&str] = &[
    "host",
    "larrabee-8",
    "larrabee-16",
    "larrabee-24",
    "larrabee-32",
    "larrabee-48",
    "larrabee-64",
];

/// Ranges of the integer fields (inclusive), units as on each field. Chosen so that a frame's replay
/// cannot overflow 64-bit cycle counts with records that pass `load_records`' limits: every cost per
/// instruction, line or barrier is at most 2^14 cycles.
pub const LIMITS: &[(&str, u64, u64)] = &[
    ("cores", 1, 4096),
    ("threads_per_core", 1, 64),
    ("simd_width", 16, 16),
    ("vector_issue_per_clock", 1, 16),
    ("scalar_issue_per_clock", 1, 16),
    ("l1_kb", 1, 65_536),
    ("l1_ways", 1, 64),
    ("l1_latency", 0, 10_000),
    ("l2_kb", 1, 1_048_576),
    ("l2_ways", 1, 64),
    ("l2_latency", 0, 10_000),
    ("line_bytes", 64, 64),
    ("ring_hop_latency", 0, 1_000),
    ("ring_bytes_per_clock", 1, 4_096),
    ("atomic_cycles", 1, 10_000),
    ("atomic_conflict_cycles", 0, 10_000),
    ("barrier_cycles", 0, 10_000_000),
    ("gather_cycles_per_line", 0, 10_000),
    ("transcendental_cycles", 1, 10_000),
    ("l3_kb", 0, 1_048_576),
    ("l3_ways", 1, 64),
    ("l3_latency", 0, 10_000),
    ("tlb_entries", 0, 1_000_000),
    ("store_buffer_entries", 0, 65_536),
];

/// Ranges of the real fields (inclusive): `clock_ghz` GHz, `dram_latency_ns` ns, `dram_bandwidth_gbs`
/// GB/s. At the extremes a DRAM miss costs at most 5e6 cycles and a DRAM byte at most 5e3.
pub const REAL_LIMITS: &[(&str, f64, f64)] = &[
    ("clock_ghz", 0.001, 50.0),
    ("dram_latency_ns", 0.0, 100_000.0),
    ("dram_bandwidth_gbs", 0.01, 1_000_000.0),
    ("vector_cycles", 0.01, 10_000.0),
    ("load_store_cycles", 0.01, 10_000.0),
    ("compress_cycles", 0.01, 10_000.0),
    ("scalar_cycles", 0.01, 10_000.0),
    ("scalar_div_cycles", 0.01, 10_000.0),
    ("gather_cycles", 0.01, 10_000.0),
    ("memory_parallelism", 1.0, 64.0),
    ("task_overhead_cycles", 0.0, 10_000_000.0),
    ("latency_scale", 0.0, 100.0),
    ("tlb_miss_cycles", 0.0, 10_000.0),
    ("stream_l2_cycles", 0.0, 10_000.0),
    ("stream_l3_cycles", 0.0, 10_000.0),
    ("stream_dram_cycles", 0.0, 10_000.0),
    ("stream_ramp_share", 0.0, 1.0),
    ("writeback_cycles", 0.0, 10_000.0),
    ("mispredict_cycles", 0.0, 10_000.0),
    ("scalar_float_cycles", 0.0, 10_000.0),
    ("mask_move_cycles", 0.0, 10_000.0),
];

/// Largest modelled cache over all cores (`cores × (l1_kb + l2_kb)`), bytes: the model keeps a tag
/// per line, so this bounds its memory (4 GiB of modelled cache, 512 MiB of tags).
pub const MAX_CACHE_BYTES: u64 = 4 << 30;

/// A configurable Larrabee-style chip. All cycle figures are core clock cycles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineConfig {
    /// Name of the configuration (a preset's name, or the user's).
    pub name: String,
    /// Cores on the ring. Larrabee: 8–48 were discussed (Seiler 2008); the paper simulated 24.
    pub cores: u32,
    /// Hardware threads per core (Seiler 2008: 4). They hide memory latency (see `timing`).
    pub threads_per_core: u32,
    /// Vector lanes, 32-bit each (Seiler 2008: 16). The recorded kernels are 16-wide: must be 16.
    pub simd_width: u32,
    /// Core clock, GHz (Johnson 2009: 1 GHz).
    pub clock_ghz: f64,
    /// Vector instructions issued per clock per core (Seiler 2008: 1, the U pipe).
    pub vector_issue_per_clock: u32,
    /// Scalar (and mask) instructions issued per clock per core, beside the vector one (Seiler 2008:
    /// dual issue, 1).
    pub scalar_issue_per_clock: u32,
    /// L1 data cache per core, KB (Seiler 2008: 32 KB).
    pub l1_kb: u32,
    /// L1 associativity, ways. Assumption: 8 (typical of 32 KB x86 L1D caches of the time).
    pub l1_ways: u32,
    /// L1 hit latency, cycles. Assumption: 0 extra — the in-order pipeline is built around the L1
    /// load-to-use latency, which the issue model already pays.
    pub l1_latency: u32,
    /// Local L2 subset per core, KB (Seiler 2008: 256 KB).
    pub l2_kb: u32,
    /// L2 associativity, ways. Assumption: 8.
    pub l2_ways: u32,
    /// Latency of an L1 miss that hits the local L2 subset, cycles. Assumption: 10 (Seiler 2008 only
    /// says the local subset is fast; Atom's L2 is ~15, Pentium's ~10).
    pub l2_latency: u32,
    /// Cache line, bytes (Seiler 2008: 64). Records hold 64-byte lines: must be 64.
    pub line_bytes: u32,
    /// Latency per ring stop travelled, cycles. Assumption: 2 (one clock per stop each way is the
    /// usual ring design; ×2 for request and reply folded in per hop).
    pub ring_hop_latency: u32,
    /// Ring width per direction, bytes per clock (Seiler 2008: 512 bits = 64 bytes).
    pub ring_bytes_per_clock: u32,
    /// DRAM access latency beyond the ring, ns. Assumption: 100 ns (GDDR5-era GPUs, ~400–600 core
    /// clocks at 1 GHz as seen by a thread in total, of which the DRAM part is ~100 ns).
    pub dram_latency_ns: f64,
    /// DRAM bandwidth of the whole chip, GB/s. Assumption: 128 GB/s (GDDR5 on a 256-bit bus, as on
    /// GPUs of 2009–2010). A step cannot finish before its DRAM traffic has crossed at this rate,
    /// and on a busy chip (a step's tasks on more than one core at once) a line a prefetcher
    /// streams from DRAM costs at least its share of it: busy cores × line bytes over the bytes a
    /// cycle. Hosts: fitted by `sism calibrate` on streaming loads from DRAM on every host thread
    /// at once (on the project's 2-core Zen 4 VM 39–79 GB/s from one calibration to the next, where one
    /// thread alone streams 31–33 GB/s).
    pub dram_bandwidth_gbs: f64,
    /// Cost of one vector atomic (fetch-add) instruction, cycles. Assumption: 8 (a locked RMW on the
    /// L1 line; conflict-free lanes combine in one pass).
    pub atomic_cycles: u32,
    /// Extra cost per conflicting lane of a vector atomic (a lane whose address repeats an earlier
    /// lane), cycles. Assumption: 4 (one serialised pass per conflict).
    pub atomic_conflict_cycles: u32,
    /// Cost of the barrier ending each phase, cycles. Assumption: 2000 (a ring-wide flag
    /// reduction, ~2 µs at 1 GHz, in line with software barriers on many-core x86).
    pub barrier_cycles: u32,
    /// Gather or scatter cost per distinct cache line the instruction touches, cycles (Seiler 2008:
    /// gathers proceed one cache line per clock at best). Assumption: 1.
    pub gather_cycles_per_line: u32,
    /// Issue cost of one transcendental (div, sqrt, rcp, rsqrt) vector instruction, cycles.
    /// Assumption: 4 (an unpipelined multi-cycle op on the VPU).
    pub transcendental_cycles: u32,
    /// Issue cycles one vector ALU or FMA instruction takes before the division by
    /// `vector_issue_per_clock` (0.01–10000). Larrabee: 1. The `host` preset sets what the host's
    /// backend takes for one 16-lane operation (AVX-512 about 0.5–1, the portable backend several).
    #[serde(default = "one")]
    pub vector_cycles: f64,
    /// Issue cycles of one contiguous vector load or store (0.01–10000), before the division by
    /// `vector_issue_per_clock`; cache misses are charged apart. Larrabee: 1.
    #[serde(default = "one")]
    pub load_store_cycles: f64,
    /// Issue cycles of one compress or expand (0.01–10000), before the division by
    /// `vector_issue_per_clock`. Larrabee: 1. Hosts' compress-stores are microcoded (several).
    #[serde(default = "one")]
    pub compress_cycles: f64,
    /// Issue cycles of one scalar or mask instruction before the division by
    /// `scalar_issue_per_clock` (0.01–10000). Larrabee: 1.
    #[serde(default = "one")]
    pub scalar_cycles: f64,
    /// Issue cycles of one counted scalar divide or square root (0.01–10000), not divided by the
    /// issue rate: the divider's occupancy. Its latency is on the task's recorded critical path
    /// (scalars carry chain depths: [`sism_simd::scalar_latency`]). Larrabee: 33, the P54C's
    /// double-precision `FDIV`, which blocks the in-order pipeline for its whole latency (Pentium
    /// Processor Family Developer's Manual; Larrabee's cores derive from it). Hosts: fitted by
    /// `sism calibrate` on four independent divide and square-root chains (the family table's 4
    /// otherwise: `divss`/`sqrtss` reciprocal throughput on Zen 4 and Ice Lake).
    #[serde(default = "scalar_div_default")]
    pub scalar_div_cycles: f64,
    /// Least cost of one gather or scatter instruction, cycles, whatever lines it touches
    /// (0.01–10000; the per-line cost is `gather_cycles_per_line`). Larrabee: 1. Host gathers cost
    /// about a cycle per lane, not per line.
    #[serde(default = "one")]
    pub gather_cycles: f64,
    /// True for an out-of-order host core, whose vector ALUs, load/store ports and integer ALUs
    /// work in parallel: a task's issue cycles are the largest of its vector ALU, load/store and
    /// scalar cycles. False for Larrabee's dual issue: the largest of its vector cycles (loads and
    /// stores included: they issue in the vector pipe) and its scalar cycles.
    #[serde(default)]
    pub separate_ports: bool,
    /// True where a step's tasks run as its host code runs them: a step whose tasks the host runs
    /// one after another on one thread (they share an output buffer: the grid's and the binners'
    /// scatters, the pixel scatters, the tile lists; [`crate::exec::PhaseRecords::serial`]) is
    /// replayed one task after another on one core. Hosts: true (the model times the code the host
    /// runs). Larrabee: false, its cores run those tasks in parallel, as the paper's renderer does,
    /// their shared write positions advanced by the vector fetch-adds the kernels already count.
    #[serde(default)]
    pub serial_steps: bool,
    /// Cache misses one hardware thread keeps in flight (1–64): a task's memory stall is divided by
    /// it before the other threads hide what they can. Larrabee's in-order cores: 1. Out-of-order
    /// hosts with prefetchers overlap many.
    #[serde(default = "one")]
    pub memory_parallelism: f64,
    /// Cost of starting one task on a core, cycles (0–1e7): the host's work-stealing scheduler.
    /// Larrabee: 0 (its software scheduler's cost is inside the kernels' scalar counts).
    #[serde(default)]
    pub task_overhead_cycles: f64,
    /// This machine's cycles per nominal latency cycle (0–100; 0 = latency not modelled): the
    /// factor from the records' critical paths ([`sism_simd::Counters::critical_path`], in the
    /// nominal latencies of [`sism_simd::latency`], e.g. 4 for a float add) to cycles. An
    /// out-of-order core (`separate_ports`) spends on a task at least its critical path; on an
    /// in-order core the part of the critical path beyond the task's issue is a stall, which the
    /// core's other hardware threads hide as they hide memory stalls (see `timing`). Larrabee: 1
    /// (assumption: its vector latencies are the nominal ones; Seiler 2008 gives none). Hosts:
    /// fitted by `sism calibrate` on one dependency chain.
    #[serde(default = "one")]
    pub latency_scale: f64,
    /// TLB entries of one core for 4 KiB pages, counting its second-level TLB (0–1e6; 0 = TLB not
    /// modelled). A task touching more distinct pages than this misses on each page beyond them.
    /// Larrabee: 0 (assumption: its renderer keeps its buffers in the 4 MiB pages its P54C-derived
    /// cores support, so a core's TLB reaches a frame's working set; Seiler 2008 gives no TLB
    /// figures). Hosts: the vendor's second-level data TLB (e.g. Zen 4: 3072, Ice Lake SP: 2048).
    #[serde(default)]
    pub tlb_entries: u32,
    /// Store-buffer entries of one hardware thread (0–65536; 0 = not modelled). A store holds an
    /// entry from issue until its line is in L1 and it has written it, and stores write in order,
    /// so a task whose stores fall `k` to a written line keeps at most `entries / k` written lines
    /// waiting for their misses at once: its write misses overlap that many, at least 1 and at most
    /// `memory_parallelism` (a row of 4-byte fields, 16 stores to a line, overlaps a few; a 64-byte
    /// vector store a line is bounded by `memory_parallelism` alone). Larrabee: 0 (in order, one
    /// miss at a time already). Hosts: the core's store buffer (Intel's Golden Cove and its server
    /// parts 114, Ice Lake 72, Skylake 56; AMD's Zen 4 64, Zen 5 104; from the vendors'
    /// optimisation guides).
    #[serde(default)]
    pub store_buffer_entries: u32,
    /// Cycles of one TLB miss: a page walk whose entries hit in the caches (0–10000). Hosts: about
    /// 30 (the walkers' measured cost with the page-walk caches at work).
    #[serde(default)]
    pub tlb_miss_cycles: f64,
    /// A last-level cache shared by all cores, KB (0 = none, as on Larrabee, whose L2 subsets are the
    /// last level). An L2 miss looks it up before going to DRAM.
    #[serde(default)]
    pub l3_kb: u32,
    /// Shared-cache associativity, ways (used when `l3_kb` > 0).
    #[serde(default = "sixteen")]
    pub l3_ways: u32,
    /// Latency of an L2 miss that hits the shared cache, cycles (used when `l3_kb` > 0).
    #[serde(default)]
    pub l3_latency: u32,
    /// True for a core whose hardware prefetchers follow sequential streams: an L1 miss that
    /// continues one of the task's recent streams of lines ([`super::timing::STREAMS`] streams, a
    /// stride of at most [`super::timing::STREAM_REACH`] lines either way) costs the streaming cost
    /// of the level that serves it (`stream_*_cycles`) instead of its latency. Larrabee: false
    /// (assumption: Seiler 2008 describes software prefetch instructions, not a hardware
    /// prefetcher, and the model's kernels issue none). Hosts: true.
    #[serde(default)]
    pub prefetcher: bool,
    /// Cycles of one prefetched line served by the L2 (0–10000; used with `prefetcher`): what a
    /// line of a sequential stream costs once the prefetcher runs ahead of it, its throughput, not
    /// its latency, and not divided by `memory_parallelism`. Hosts: fitted on streaming loads.
    #[serde(default)]
    pub stream_l2_cycles: f64,
    /// Cycles of one prefetched line served by the shared cache (0–10000; used with `prefetcher`).
    #[serde(default)]
    pub stream_l3_cycles: f64,
    /// Cycles of one prefetched line served by DRAM (0–10000; used with `prefetcher`): about the
    /// line's bytes over one core's streaming bandwidth.
    #[serde(default)]
    pub stream_dram_cycles: f64,
    /// Share of its level's latency that a miss pays while its stream is young (0–1; used with
    /// `prefetcher`): the lines a stream reaches within its first [`super::timing::STREAM_RAMP`]
    /// lines (a 4 KiB page) are fetched before the prefetcher has run far enough ahead, so they
    /// cost this share of a random miss instead of the streaming cost. Hosts: fitted on loads of
    /// runs of 16 consecutive lines at random starts in DRAM (measured on a Zen 4 host: such runs
    /// cost 60–70% of random lines a line, not the 20–40% of a long stream). 1 (the default)
    /// charges young streams as random misses.
    #[serde(default = "one")]
    pub stream_ramp_share: f64,
    /// Cycles a task pays for each dirty line the last level of cache evicts while it runs
    /// (0–10000): the line's write-back to memory, charged as a throughput like a streamed line
    /// (not divided by `memory_parallelism`), on top of the write-allocate miss that brought it in.
    /// Hosts: fitted on streaming stores over an array in DRAM after the streaming loads' cost (on
    /// the Intel Xeon VM such stores take three times as long as loads of the same array: each line
    /// is read for ownership, then written back). Larrabee: 0 (assumption: its write-backs
    /// are absorbed by the ring and the memory controllers' queues; Seiler 2008 gives no figure).
    #[serde(default)]
    pub writeback_cycles: f64,
    /// Cycles one mispredicted branch costs (0–10000): the pipeline refills from the right path.
    /// The counting context predicts every counted conditional branch with a local-history
    /// predictor model (`sism_simd::branch`) and records the misses
    /// (`Counters::branch_mispredicts`). Larrabee: 4 (assumption: its cores descend from the
    /// Pentium's short in-order pipeline, whose penalty is 3–4 cycles; Seiler 2008 gives none);
    /// other threads of the core issue meanwhile. Hosts: fitted on a branch on random data (AMD's
    /// Zen 4 optimisation guide gives a minimum penalty of 11 cycles, typically 13).
    #[serde(default = "mispredict_default")]
    pub mispredict_cycles: f64,
    /// Cycles of the vector unit's issue that one counted scalar float operation
    /// (`Counters::scalar_float`: add, subtract, multiply, min, max) takes on an out-of-order core
    /// (0–10000; with `separate_ports`): x86 cores run scalar float arithmetic on the vector
    /// unit's pipes, so it competes with the vector operations, while it also takes its scalar
    /// issue slot (`scalar_cycles`). Hosts: fitted on vector chains interleaved with scalar float
    /// chains (on a Zen 4 host a scalar float operation adds about a third of a 16-lane one).
    /// In order (Larrabee) scalar floats run on the scalar pipe like any scalar operation and this
    /// is unused (0, the default).
    #[serde(default)]
    pub scalar_float_cycles: f64,
    /// Vector issue cycles one move between lanes and a mask (`Counters::mask_moves`: a compare, a
    /// select, a masked operation, load or store) takes beyond its own class's cost (0–10000).
    /// With mask registers (Larrabee, AVX-512) a compare writes a mask and a masked operation
    /// reads one for free: 0, the default. The portable backend has none: a compare packs 16
    /// lane results into 16 bits and a select spreads them back, several times an add. Hosts:
    /// fitted on the compare/select benchmark after `vector_cycles` is fitted on arithmetic.
    #[serde(default)]
    pub mask_move_cycles: f64,
}

fn one() -> f64 {
    1.0
}
fn mispredict_default() -> f64 {
    4.0
}
fn scalar_div_default() -> f64 {
    13.0
}
fn sixteen() -> u32 {
    16
}

impl MachineConfig {
    /// A Larrabee preset by name (`larrabee-8/16/24/32/48/64`). The `host` preset needs the host's
    /// facts: [`MachineConfig::host`], or [`MachineConfig::resolve`] with them.
    pub fn preset(name: &str) -> Option<MachineConfig> {
        let cores = match name {
            "larrabee-8" => 8,
            "larrabee-16" => 16,
            "larrabee-24" => 24,
            "larrabee-32" => 32,
            "larrabee-48" => 48,
            "larrabee-64" => 64,
            _ => return None,
        };
        Some(MachineConfig {
            name: name.to_string(),
            cores,
            ..MachineConfig::larrabee_24()
        })
    }

    /// The paper's chip: 24 cores at 1 GHz.
    pub fn larrabee_24() -> MachineConfig {
        MachineConfig {
            name: "larrabee-24".into(),
            cores: 24,
            threads_per_core: 4,
            simd_width: 16,
            clock_ghz: 1.0,
            vector_issue_per_clock: 1,
            scalar_issue_per_clock: 1,
            l1_kb: 32,
            l1_ways: 8,
            l1_latency: 0,
            l2_kb: 256,
            l2_ways: 8,
            l2_latency: 10,
            line_bytes: 64,
            ring_hop_latency: 2,
            ring_bytes_per_clock: 64,
            dram_latency_ns: 100.0,
            dram_bandwidth_gbs: 128.0,
            atomic_cycles: 8,
            atomic_conflict_cycles: 4,
            barrier_cycles: 2000,
            gather_cycles_per_line: 1,
            transcendental_cycles: 4,
            vector_cycles: 1.0,
            load_store_cycles: 1.0,
            compress_cycles: 1.0,
            scalar_cycles: 1.0,
            scalar_div_cycles: 33.0,
            gather_cycles: 1.0,
            separate_ports: false,
            serial_steps: false,
            memory_parallelism: 1.0,
            task_overhead_cycles: 0.0,
            latency_scale: 1.0,
            tlb_entries: 0,
            store_buffer_entries: 0,
            tlb_miss_cycles: 0.0,
            l3_kb: 0,
            l3_ways: 16,
            l3_latency: 0,
            prefetcher: false,
            stream_l2_cycles: 0.0,
            stream_l3_cycles: 0.0,
            stream_dram_cycles: 0.0,
            stream_ramp_share: 1.0,
            writeback_cycles: 0.0,
            mispredict_cycles: 4.0,
            scalar_float_cycles: 0.0,
            mask_move_cycles: 0.0,
        }
    }

    /// The `host` preset for `facts` (see [`super::host`]).
    pub fn host(facts: &HostFacts) -> MachineConfig {
        super::host::host_preset_from(facts, facts.backend)
    }

    /// A preset by name (`host` with `host`'s facts), with the host's facts when it is `host`.
    fn preset_with(name: &str, host: Option<&HostFacts>) -> Result<MachineConfig, String> {
        if name == "host" {
            return host.map(MachineConfig::host).ok_or_else(|| {
                "the `host` preset needs the host's facts (probed by the caller: sism::host::resolve_machine)"
                    .to_string()
            });
        }
        MachineConfig::preset(name)
            .ok_or_else(|| format!("\"{name}\" is not a preset (presets: {})", PRESETS.join(", ")))
    }

    /// A preset name, or else a TOML machine file; `host` gives the facts the `host` preset (or a
    /// file based on it) is built from (`None`: such a machine is an error).
    pub fn resolve(preset_or_file: &str, host: Option<&HostFacts>) -> crate::Result<MachineConfig> {
        if preset_or_file == "host" || MachineConfig::preset(preset_or_file).is_some() {
            return MachineConfig::preset_with(preset_or_file, host).map_err(crate::Error::invalid);
        }
        let path = Path::new(preset_or_file);
        if !path.exists() {
            crate::error::bail!(
                "machine `{preset_or_file}` is neither a preset ({}) nor an existing file",
                PRESETS.join(", ")
            );
        }
        MachineConfig::load(path, host)
    }

    /// Reads a machine TOML file (see the module documentation).
    pub fn load(path: &Path, host: Option<&HostFacts>) -> crate::Result<MachineConfig> {
        let text = crate::input::read_text(path, "machine file", crate::input::MAX_TEXT_BYTES)?;
        let default_name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "custom".into());
        MachineConfig::from_toml_with(&text, &default_name, host)
            .map_err(|e| crate::Error::invalid(format!("machine file {}: {e}", path.display())))
    }

    /// Parses machine TOML text; `default_name` names the result when the text has no `name`.
    /// Errors name the offending key.
    pub fn from_toml(text: &str, default_name: &str) -> Result<MachineConfig, String> {
        MachineConfig::from_toml_with(text, default_name, None)
    }

    /// [`MachineConfig::from_toml`], with the host's facts for a file whose `base` is `host`.
    pub fn from_toml_with(
        text: &str,
        default_name: &str,
        host: Option<&HostFacts>,
    ) -> Result<MachineConfig, String> {
        let mut user: toml::Table = toml::from_str(text).map_err(|e| e.to_string().trim_end().to_string())?;
        let base_name = match user.remove("base") {
            None => "larrabee-24".to_string(),
            Some(toml::Value::String(s)) => s,
            Some(v) => {
                return Err(format!(
                    "`base` must be a preset name string, not {}",
                    v.type_str()
                ))
            }
        };
        let base = match MachineConfig::preset(&base_name) {
            Some(b) => b,
            None if base_name == "host" => {
                MachineConfig::preset_with(&base_name, host).map_err(|e| format!("`base` = \"host\": {e}"))?
            }
            None => {
                return Err(format!(
                    "`base` = \"{base_name}\" is not a preset (presets: {})",
                    PRESETS.join(", ")
                ))
            }
        };
        let mut merged = toml::Table::try_from(&base).map_err(|e| e.to_string())?;
        merged.insert("name".into(), toml::Value::String(default_name.into()));
        for (key, value) in user {
            let Some(slot) = merged.get(&key) else {
                let known: Vec<&str> = merged.keys().map(|k| k.as_str()).collect();
                return Err(format!(
                    "unknown key `{key}` (known keys: base, {})",
                    known.join(", ")
                ));
            };
            let value = match (slot, value) {
                (toml::Value::Float(_), toml::Value::Integer(i)) => toml::Value::Float(i as f64),
                (toml::Value::Integer(_), toml::Value::Integer(i)) if i < 0 || i > u32::MAX as i64 => {
                    return Err(format!("`{key}` = {i} is out of range (0..=4294967295)"));
                }
                (s, v) if s.type_str() != v.type_str() => {
                    return Err(format!(
                        "`{key}` must be {} {}, not {}",
                        if s.type_str() == "integer" { "an" } else { "a" },
                        s.type_str(),
                        v.type_str()
                    ));
                }
                (_, v) => v,
            };
            merged.insert(key, value);
        }
        let config: MachineConfig = merged
            .try_into()
            .map_err(|e: toml::de::Error| e.to_string().trim_end().to_string())?;
        config.validate().map_err(|(key, msg)| format!("`{key}` {msg}"))?;
        Ok(config)
    }

    /// Checks every value against its documented range ([`LIMITS`], [`REAL_LIMITS`]); on failure
    /// returns the key and what is wrong. Within these ranges the model's arithmetic cannot overflow
    /// (see `timing`), and its caches fit in [`MAX_CACHE_BYTES`].
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for &(key, lo, hi) in LIMITS {
            let v = self.integer(key);
            if v < lo || v > hi {
                return Err((key, format!("= {v} is out of range {lo}..={hi}")));
            }
        }
        for &(key, lo, hi) in REAL_LIMITS {
            let v = self.real(key);
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err((key, format!("= {v} is out of range [{lo}, {hi}]")));
            }
        }
        if self.simd_width != 16 {
            return Err((
                "simd_width",
                format!(
                    "= {}: the recorded kernels are 16-wide, so it must be 16",
                    self.simd_width
                ),
            ));
        }
        if self.line_bytes != 64 {
            return Err((
                "line_bytes",
                format!(
                    "= {}: the records hold 64-byte lines, so it must be 64",
                    self.line_bytes
                ),
            ));
        }
        let l3 = (self.l3_kb > 0).then_some(("l3", self.l3_kb, self.l3_ways));
        for (key, kb, ways) in [("l1", self.l1_kb, self.l1_ways), ("l2", self.l2_kb, self.l2_ways)]
            .into_iter()
            .chain(l3)
        {
            let lines = kb as u64 * 1024 / self.line_bytes as u64;
            if !lines.is_multiple_of(ways as u64) || !(lines / ways as u64).is_power_of_two() {
                return Err((
                    match key {
                        "l1" => "l1_kb",
                        "l2" => "l2_kb",
                        _ => "l3_kb",
                    },
                    format!(
                        "= {kb} with {ways} ways gives {} sets: the sets must be a power of two",
                        lines as f64 / ways as f64
                    ),
                ));
            }
        }
        let cache_bytes =
            self.cores as u64 * (self.l1_kb as u64 + self.l2_kb as u64) * 1024 + self.l3_kb as u64 * 1024;
        if cache_bytes > MAX_CACHE_BYTES {
            return Err((
                "l2_kb",
                format!(
                    "with l1_kb = {} and {} cores gives {} MiB of modelled cache; at most {} MiB",
                    self.l1_kb,
                    self.cores,
                    cache_bytes >> 20,
                    MAX_CACHE_BYTES >> 20
                ),
            ));
        }
        Ok(())
    }

    /// The integer field `key` (one of [`LIMITS`]).
    fn integer(&self, key: &str) -> u64 {
        (match key {
            "cores" => self.cores,
            "threads_per_core" => self.threads_per_core,
            "simd_width" => self.simd_width,
            "vector_issue_per_clock" => self.vector_issue_per_clock,
            "scalar_issue_per_clock" => self.scalar_issue_per_clock,
            "l1_kb" => self.l1_kb,
            "l1_ways" => self.l1_ways,
            "l1_latency" => self.l1_latency,
            "l2_kb" => self.l2_kb,
            "l2_ways" => self.l2_ways,
            "l2_latency" => self.l2_latency,
            "line_bytes" => self.line_bytes,
            "ring_hop_latency" => self.ring_hop_latency,
            "ring_bytes_per_clock" => self.ring_bytes_per_clock,
            "atomic_cycles" => self.atomic_cycles,
            "atomic_conflict_cycles" => self.atomic_conflict_cycles,
            "barrier_cycles" => self.barrier_cycles,
            "gather_cycles_per_line" => self.gather_cycles_per_line,
            "transcendental_cycles" => self.transcendental_cycles,
            "l3_kb" => self.l3_kb,
            "l3_ways" => self.l3_ways,
            "l3_latency" => self.l3_latency,
            "tlb_entries" => self.tlb_entries,
            "store_buffer_entries" => self.store_buffer_entries,
            _ => unreachable!("not an integer field: {key}"),
        }) as u64
    }

    /// The real field `key` (one of [`REAL_LIMITS`]).
    fn real(&self, key: &str) -> f64 {
        match key {
            "clock_ghz" => self.clock_ghz,
            "dram_latency_ns" => self.dram_latency_ns,
            "dram_bandwidth_gbs" => self.dram_bandwidth_gbs,
            "vector_cycles" => self.vector_cycles,
            "load_store_cycles" => self.load_store_cycles,
            "compress_cycles" => self.compress_cycles,
            "scalar_cycles" => self.scalar_cycles,
            "scalar_div_cycles" => self.scalar_div_cycles,
            "gather_cycles" => self.gather_cycles,
            "memory_parallelism" => self.memory_parallelism,
            "task_overhead_cycles" => self.task_overhead_cycles,
            "latency_scale" => self.latency_scale,
            "tlb_miss_cycles" => self.tlb_miss_cycles,
            "stream_l2_cycles" => self.stream_l2_cycles,
            "stream_l3_cycles" => self.stream_l3_cycles,
            "stream_dram_cycles" => self.stream_dram_cycles,
            "stream_ramp_share" => self.stream_ramp_share,
            "writeback_cycles" => self.writeback_cycles,
            "mispredict_cycles" => self.mispredict_cycles,
            "scalar_float_cycles" => self.scalar_float_cycles,
            "mask_move_cycles" => self.mask_move_cycles,
            _ => unreachable!("not a real field: {key}"),
        }
    }

    /// The resolved configuration as TOML (what `machine.toml` holds), with a header comment.
    pub fn to_toml(&self) -> String {
        format!(
            "# Resolved sism machine configuration. Units: see sism::machine::config::MachineConfig.\n\
             # Latencies and costs are assumptions (Larrabee's were never published).\n{}",
            toml::to_string(self).expect("plain struct serialises")
        )
    }

    /// Core cycles per nanosecond.
    pub fn cycles_per_ns(&self) -> f64 {
        self.clock_ghz
    }
    /// Milliseconds of `cycles` at the clock.
    pub fn ms(&self, cycles: u64) -> f64 {
        cycles as f64 / (self.clock_ghz * 1e6)
    }
    /// Average ring stops between a core and a memory controller: a bidirectional ring of `cores`
    /// stops has mean distance `cores / 4` (assumption: controllers spread evenly, at least 1 stop).
    pub fn ring_hops(&self) -> u32 {
        (self.cores / 4).max(1)
    }
    /// Latency of an access that misses the L2 and goes over the ring to DRAM, cycles.
    pub fn dram_miss_cycles(&self) -> u64 {
        self.l2_latency as u64
            + self.ring_hops() as u64 * self.ring_hop_latency as u64
            + (self.line_bytes as u64).div_ceil(self.ring_bytes_per_clock as u64)
            + (self.dram_latency_ns * self.clock_ghz).round() as u64
    }
    /// DRAM bytes per core cycle.
    pub fn dram_bytes_per_cycle(&self) -> f64 {
        self.dram_bandwidth_gbs / self.clock_ghz
    }
}

impl Default for MachineConfig {
    fn default() -> Self {
        MachineConfig::larrabee_24()
    }
}
