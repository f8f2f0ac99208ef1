//! Replaying task records on the modelled chip.
//!
//! ## The model (deliberately simple; every rule is here)
//!
//! * **Phases** run one after another; each ends at a barrier costing `barrier_cycles`. Caches stay
//!   warm across phases (a frame is one continuous run).
//! * **Scheduling** (sort-middle): a phase's tasks are dealt in record order, each to the core with
//!   the least busy time so far, ties to the lowest core number (greedy list scheduling; it is
//!   deterministic and never worse than round-robin on unequal tasks). A task runs entirely on one
//!   core; its cache accesses go through that core's caches.
//! * **Issue**: one vector and one scalar instruction per clock (`*_issue_per_clock`), so a task's
//!   issue cycles are `max(vector cycles, scalar cycles)`. Vector cycles: each vector ALU, FMA, load,
//!   store and compress/expand instruction 1 slot (divided by the vector issue rate), each
//!   transcendental `transcendental_cycles`, each gather or scatter `gather_cycles_per_line` per
//!   distinct line it touched (at least 1). Scalar cycles: scalar and mask-register instructions
//!   (declared `scalar` and the counted ALU, branch and memory classes), and `scalar_div_cycles`
//!   per counted scalar divide or square root.
//!   Per class the slot is scaled by a real cost (`vector_cycles`, `load_store_cycles`,
//!   `compress_cycles`, `scalar_cycles`, all 1 on Larrabee), and a gather or scatter costs at least
//!   `gather_cycles`. With `separate_ports` (an out-of-order host) vector ALU work, loads and stores
//!   (vector and scalar, each at `load_store_cycles`), scalar work and the scalar divider issue on
//!   their own ports: `max(vector ALU, load/store, scalar, divider)`.
//! * **Branches**: each counted conditional branch the counting context's predictor model missed
//!   (`branch_mispredicts`) costs `mispredict_cycles`: added to the issue out of order (nothing
//!   overlaps a refill), a stall the core's other threads hide in order (as a chain's, below).
//! * **Dependency chains**: every record carries its task's critical path (the longest chain of
//!   dependent vector operations, recorded as the task ran, in nominal latency cycles), which
//!   `latency_scale` turns into cycles. An out-of-order core (`separate_ports`) spends on a task at
//!   least its critical path: `issue = max(issue bound, chain)`. On an in-order core the chain's
//!   excess over the issue, `max(0, chain − issue)`, is a stall that the core's other hardware
//!   threads hide like a memory stall (below); what they cannot hide counts as issue time.
//! * **Host scheduling**: each task costs `task_overhead_cycles` to start (0 on Larrabee), counted
//!   with the atomics as synchronisation.
//! * **Atomics**: each vector fetch-add costs `atomic_cycles`, plus `atomic_conflict_cycles` per
//!   conflicting lane. They are charged to the "atomics and sync" part of the stack.
//! * **Memory**: the task's recorded line stream is replayed through the core's L1 (private) and L2
//!   (its local subset), write-allocate and write-back. An L1 hit costs `l1_latency`, an L1 miss that
//!   hits L2 `l2_latency`, an L2 miss `MachineConfig::dram_miss_cycles` (L2 + ring hops to a memory
//!   controller + line transfer + DRAM latency). Remote L2 subsets and coherence are not modelled:
//!   a line another core holds is fetched from DRAM. With `l3_kb > 0` (a host's last-level cache)
//!   an L2 miss looks up one cache shared by all cores first (`l3_latency` on a hit; a miss adds
//!   it to the DRAM latency); L2 write-backs are absorbed by it, and its own dirty evictions go to
//!   DRAM. `memory_parallelism` (misses a thread overlaps, 1 on Larrabee) divides a task's stall;
//!   its write misses that take longer than the task needs to fill its store buffer are divided
//!   by no more than the written lines the buffer holds (`store_buffer_entries` over the task's
//!   stores per written line, [`StoreBuffer`]).
//! * **Prefetching** (`prefetcher`, hosts): an access within [`STREAM_REACH`] lines of one of the
//!   task's last [`STREAMS`] stream heads continues that stream ([`LineMapper::map_each`]). When
//!   such an access misses L1, the prefetcher has run ahead of it: it costs the streaming cost of
//!   the level that served it (`stream_l2_cycles`, `stream_l3_cycles`, `stream_dram_cycles`, a
//!   throughput, not divided by `memory_parallelism`) instead of that level's latency, once the
//!   stream has moved by [`STREAM_RAMP`] lines; before that (a young stream) it costs
//!   `stream_ramp_share` of the latency. Random misses keep their latencies.
//! * **Hardware threads hide latency**: with `T` threads per core each running tasks like this one,
//!   a task of `B` busy cycles (issue + atomics) and `S` stall cycles takes `max(B, (B + S) / T)`
//!   of the core's time (the others issue while it waits), i.e. the exposed stall is
//!   `max(0, S − (T − 1)·B) / T`, rounded up. With `T = 1` every stall is exposed. (Its cache
//!   accesses are still replayed task after task: the threads' interleaving is not simulated.)
//! * **A busy chip**: while a step's tasks run on `k` > 1 cores at once (a parallel step of `k`
//!   or more tasks), a line the prefetcher streams from DRAM costs at least `k` lines over the
//!   chip's DRAM bandwidth (`k × line_bytes / (dram_bandwidth_gbs / clock_ghz)`): every busy core
//!   is taken to stream at once. Random misses and shared-cache hits keep their latencies (on the
//!   project's host, random lines from DRAM and the shared cache take as long on both threads at
//!   once as on one; streams from DRAM take from as long to 1.8 times as long, with the moment).
//! * **Write-backs**: each dirty line the last level (L2, or the shared cache) evicts while a task
//!   runs costs that task `writeback_cycles` (0 on Larrabee), a throughput like a streamed line's:
//!   on the host a store stream takes about three times a load stream of the same lines (read for
//!   ownership, then written back), which the misses alone do not show.
//! * **DRAM bandwidth**: a phase cannot finish before its DRAM traffic (L2 fills and write-backs)
//!   has crossed at `dram_bandwidth_gbs`; any excess over the busiest core is memory stall.
//!
//! ## The cycle stack
//!
//! A phase takes `cycles = busiest core + bandwidth excess + barrier`. Its stack is what the average
//! core did during those cycles, in whole cycles so the parts sum exactly to the total:
//! `issue = ⌊Σ issue / cores⌋`, `memory = ⌊Σ exposed stall / cores⌋ + bandwidth excess`,
//! `atomics_sync = ⌊Σ atomics / cores⌋ + barrier`, and `imbalance_idle` the remainder (cores waiting
//! for the busiest one, or with no task at all). The frame's stack is the sum of its phases'.

use sism_simd::{Counters, TaskRecord};

use super::cache::{Cache, LineIds, PAGE_BYTES};
use super::config::MachineConfig;

/// Where a phase's (or frame's) cycles went; the parts sum exactly to [`CycleStack::total`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CycleStack {
    /// Issuing instructions.
    pub issue: u64,
    /// Memory stalls not hidden by other threads, and DRAM bandwidth limits.
    pub memory: u64,
    /// Vector atomics (with conflicts) and the phase-end barrier.
    pub atomics_sync: u64,
    /// Cores idle while the busiest core finishes (load imbalance), or with no work.
    pub imbalance_idle: u64,
}

impl CycleStack {
    /// Sum of the parts.
    pub fn total(&self) -> u64 {
        self.issue
            .saturating_add(self.memory)
            .saturating_add(self.atomics_sync)
            .saturating_add(self.imbalance_idle)
    }
    /// Part names and values, in order.
    pub fn parts(&self) -> [(&'static str, u64); 4] {
        [
            ("issue", self.issue),
            ("memory", self.memory),
            ("atomics_sync", self.atomics_sync),
            ("imbalance_idle", self.imbalance_idle),
        ]
    }
    fn add(&mut self, o: &CycleStack) {
        self.issue = self.issue.saturating_add(o.issue);
        self.memory = self.memory.saturating_add(o.memory);
        self.atomics_sync = self.atomics_sync.saturating_add(o.atomics_sync);
        self.imbalance_idle = self.imbalance_idle.saturating_add(o.imbalance_idle);
    }
}

/// Memory-hierarchy counts of a phase or frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryCounts {
    /// Line accesses replayed (L1 lookups).
    pub accesses: u64,
    /// L1 misses (L2 lookups).
    pub l1_misses: u64,
    /// L2 misses (shared-cache lookups, or DRAM fills over the ring without a shared cache).
    pub l2_misses: u64,
    /// L2 misses that hit the shared last-level cache (0 without one).
    pub l3_hits: u64,
    /// Dirty lines evicted from the last level (L2, or the shared cache) and written back to DRAM.
    pub writebacks: u64,
    /// TLB misses: per task, distinct 4 KiB pages beyond `tlb_entries` (0 when not modelled).
    pub tlb_misses: u64,
    /// 4 KiB pages first touched in the frame by a write ([`TaskPages::fresh`]): the page faults a
    /// cold process would take. Not charged: a replayed frame is a steady-state frame, whose
    /// memory earlier frames mapped (the binary's allocator, mimalloc, keeps freed pages; measured
    /// on the host, warm frames take no page faults).
    pub page_faults: u64,
}

impl MemoryCounts {
    fn add(&mut self, o: &MemoryCounts) {
        self.accesses += o.accesses;
        self.l1_misses += o.l1_misses;
        self.l2_misses += o.l2_misses;
        self.l3_hits += o.l3_hits;
        self.writebacks += o.writebacks;
        self.tlb_misses += o.tlb_misses;
        self.page_faults += o.page_faults;
    }
    /// L1 misses per access (0 with no access).
    pub fn l1_miss_rate(&self) -> f64 {
        ratio(self.l1_misses, self.accesses)
    }
    /// L2 misses per L2 lookup (0 with no lookup).
    pub fn l2_miss_rate(&self) -> f64 {
        ratio(self.l2_misses, self.l1_misses)
    }
    /// Bytes moved from L2 into L1.
    pub fn l2_to_l1_bytes(&self, line: u32) -> u64 {
        self.l1_misses * line as u64
    }
    /// Bytes moved between DRAM and L2 over the ring (fills and write-backs).
    pub fn dram_bytes(&self, line: u32) -> u64 {
        (self.l2_misses - self.l3_hits + self.writebacks) * line as u64
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

/// Cost of one task on one core (cycles).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TaskCost {
    /// Issue cycles.
    pub issue: u64,
    /// Atomic cycles.
    pub atomics: u64,
    /// Total memory latency of the task's accesses.
    pub stall: u64,
    /// The part of `stall` other hardware threads could not hide.
    pub exposed: u64,
}

impl TaskCost {
    /// Core time of the task.
    pub fn cycles(&self) -> u64 {
        self.issue
            .saturating_add(self.atomics)
            .saturating_add(self.exposed)
    }
}

/// A task's cycles per instruction class, before the issue rule combines them.
struct ClassCycles {
    /// Vector ALU and FMA work and mask moves.
    alu: f64,
    /// Contiguous vector loads and stores.
    mem: f64,
    /// Compress / expand.
    compress: f64,
    /// Transcendentals, gathers and scatters (issued one after another on the vector unit).
    gathers: f64,
    /// Scalar and mask-register instructions (declared and counted ALU, float and branch ones).
    scalar_ops: u64,
    /// The scalar divider's occupancy.
    scalar_div: f64,
}

fn class_cycles(c: &Counters, m: &MachineConfig) -> ClassCycles {
    let alu =
        c.valu.saturating_add(c.fma) as f64 * m.vector_cycles + c.mask_moves as f64 * m.mask_move_cycles;
    let mem = c.load.saturating_add(c.store) as f64 * m.load_store_cycles;
    let compress = c.compress_expand as f64 * m.compress_cycles;
    let gs_lines =
        (c.gather_lines.saturating_add(c.scatter_lines)).saturating_mul(m.gather_cycles_per_line as u64);
    let gs_floor = c.gather.saturating_add(c.scatter) as f64 * m.gather_cycles;
    let gathers = c.transcendental.saturating_mul(m.transcendental_cycles as u64) as f64
        + (gs_lines as f64).max(gs_floor);
    let scalar_ops = c
        .scalar
        .saturating_add(c.mask)
        .saturating_add(c.scalar_alu)
        .saturating_add(c.scalar_float)
        .saturating_add(c.scalar_branch);
    let scalar_div = c.scalar_div as f64 * m.scalar_div_cycles;
    ClassCycles {
        alu,
        mem,
        compress,
        gathers,
        scalar_ops,
        scalar_div,
    }
}

/// A task's issue bounds on an out-of-order core (`separate_ports`), cycles, each rounded up as
/// [`compute_cost`] rounds it: the task issues in the largest of the first five, plus its
/// mispredicts ([`PortBounds::issue`]). Printed per step by `examples/step_counters.rs`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PortBounds {
    /// The vector unit: ALU, FMA, mask moves, compress/expand and scalar floats on its pipes
    /// (over its issue rate), then transcendentals, gathers and scatters.
    pub vector: f64,
    /// The load/store ports: vector and scalar loads and stores.
    pub load_store: f64,
    /// The scalar ALUs.
    pub scalar: f64,
    /// The scalar divider.
    pub divider: f64,
    /// The recorded critical path ([`chain_cycles`]).
    pub chain: f64,
    /// The mispredicted branches ([`mispredict_cycles`]), added: nothing overlaps a refill.
    pub mispredict: f64,
    /// How much less than perfectly the task's port groups overlap, ≥ 1: its windowed nominal
    /// issue ([`sism_simd::Counters::window_issue`]) over the nominal bound of its whole counters
    /// ([`sism_simd::nominal_issue`]). 1 when the classes of work interleave within the window;
    /// up to the number of port groups when they come in stretches the window cannot bridge. The
    /// largest port bound is scaled by it.
    pub window: f64,
}

impl PortBounds {
    /// The task's issue cycles: the largest bound, plus the mispredicts.
    pub fn issue(&self) -> f64 {
        let ports = self
            .vector
            .max(self.load_store)
            .max(self.scalar.max(self.divider));
        (ports * self.window).max(self.chain) + self.mispredict
    }
}

/// [`PortBounds`] of a task's counters on `m` (whether or not `m` has `separate_ports`).
pub fn port_bounds(c: &Counters, m: &MachineConfig) -> PortBounds {
    let k = class_cycles(c, m);
    let vip = m.vector_issue_per_clock as f64;
    // Out of order: a scalar load or store takes a load/store port's slot, as a vector one does,
    // not a scalar ALU's.
    let mem = k.mem + c.scalar_mem as f64 * m.load_store_cycles;
    let scalar_alu = k.scalar_ops as f64 * m.scalar_cycles / m.scalar_issue_per_clock as f64;
    // Scalar float arithmetic also occupies the vector unit's pipes.
    let scalar_float_pipes = c.scalar_float as f64 * m.scalar_float_cycles;
    // The divider works beside the scalar ALUs, and dependent operations wait for each other, so
    // the task takes at least its critical path, however wide the issue. A mispredicted branch
    // refills the pipeline: nothing overlaps it.
    PortBounds {
        vector: ((k.alu + scalar_float_pipes + k.compress) / vip).ceil() + k.gathers,
        load_store: (mem / vip).ceil(),
        scalar: scalar_alu.ceil(),
        divider: k.scalar_div.ceil(),
        chain: chain_cycles(c, m) as f64,
        mispredict: mispredict_cycles(c, m) as f64,
        window: window_factor(c),
    }
}

/// [`PortBounds::window`] of a task's counters: `window_issue / nominal_issue`, at least 1 (and 1
/// for records without windows), at most 4 (the port groups: a stretch's bound never exceeds
/// their sum, so a larger ratio is a corrupt record).
pub fn window_factor(c: &Counters) -> f64 {
    let whole = sism_simd::nominal_issue(c);
    if whole == 0 || c.window_issue == 0 {
        return 1.0;
    }
    (c.window_issue as f64 / whole as f64).clamp(1.0, 4.0)
}

/// Issue and atomic cycles of a task's counters (no memory). Saturating: within the limits of
/// validated configurations and records (`MachineConfig::validate`, `load_records`) nothing
/// saturates, and beyond them a figure sticks at `u64::MAX` instead of wrapping. The real-valued
/// per-class costs (`vector_cycles` and `mask_move_cycles`, `load_store_cycles`, `compress_cycles`,
/// `scalar_cycles`, `gather_cycles`) are summed in `f64` and
/// rounded up once; with Larrabee's costs of 1 every term is an exact integer, so the result is the
/// integer formula's.
pub fn compute_cost(c: &Counters, m: &MachineConfig) -> (u64, u64) {
    let issue = if m.separate_ports {
        port_bounds(c, m).issue()
    } else {
        // In order: scalar loads and stores go down the scalar pipe, and the divider blocks it.
        let k = class_cycles(c, m);
        let vip = m.vector_issue_per_clock as f64;
        let scalar_ops = k.scalar_ops.saturating_add(c.scalar_mem);
        let scalar_alu = scalar_ops as f64 * m.scalar_cycles / m.scalar_issue_per_clock as f64;
        let scalar = (scalar_alu + k.scalar_div).ceil();
        (((k.alu + k.mem + k.compress) / vip).ceil() + k.gathers).max(scalar)
    };
    let atomics = c
        .atomic
        .saturating_mul(m.atomic_cycles as u64)
        .saturating_add(c.atomic_conflicts.saturating_mul(m.atomic_conflict_cycles as u64));
    // `as` saturates a float beyond u64's range.
    (issue.ceil() as u64, atomics)
}

/// The task's critical path in this machine's cycles (`critical_path × latency_scale`, rounded up).
pub fn chain_cycles(c: &Counters, m: &MachineConfig) -> u64 {
    (c.critical_path as f64 * m.latency_scale).ceil() as u64
}

/// The task's mispredicted branches in this machine's cycles (`branch_mispredicts ×
/// mispredict_cycles`, rounded up).
pub fn mispredict_cycles(c: &Counters, m: &MachineConfig) -> u64 {
    (c.branch_mispredicts as f64 * m.mispredict_cycles).ceil() as u64
}

/// Latency cycles that `hits` misses of a level `lat` cycles away pay: all but the `streamed` ones
/// (a throughput, charged apart), and the `young` streams' ones `share` of it.
#[inline]
fn paid_latency(hits: u64, streamed: u64, young: u64, share: f64, lat: u64) -> f64 {
    ((hits - streamed - young) as f64 + young as f64 * share) * lat as f64
}

/// What a task's store buffer does to its write misses ([`StoreBuffer::of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StoreBuffer {
    /// Written lines the thread waits for at once: at least 1, at most `memory_parallelism`.
    pub parallelism: f64,
    /// Cycles the task takes, at its own pace, to issue as many stores as the buffer holds: a
    /// write miss that returns sooner never fills it, and overlaps as a read miss does.
    pub fill_cycles: f64,
}

impl StoreBuffer {
    /// The store buffer of a task of `counters` and `issue` cycles whose writes missed L1
    /// `write_misses` times on `m`. The task issues `k` = (vector stores + scalar stores +
    /// scattered lines) / `write_misses` stores to a written line, and its store buffer
    /// (`store_buffer_entries`) holds `entries / k` such lines. `None` when the store buffer is not
    /// modelled (0), the core overlaps no misses, or nothing missed.
    pub fn of(counters: &Counters, write_misses: u64, issue: u64, m: &MachineConfig) -> Option<StoreBuffer> {
        let stores = counters
            .store
            .saturating_add(counters.scalar_stores)
            .saturating_add(counters.scatter_lines);
        if m.store_buffer_entries == 0 || m.memory_parallelism <= 1.0 || write_misses == 0 || stores == 0 {
            return None;
        }
        let entries = m.store_buffer_entries as f64;
        let per_line = (stores as f64 / write_misses as f64).max(1.0);
        Some(StoreBuffer {
            parallelism: (entries / per_line).clamp(1.0, m.memory_parallelism),
            fill_cycles: entries * issue as f64 / stores as f64,
        })
    }
}

/// The exposed part of `stall` for a task of `busy` cycles on a core of `threads` threads.
pub fn exposed_stall(stall: u64, busy: u64, threads: u32) -> u64 {
    let t = threads.max(1) as u64;
    stall.saturating_sub((t - 1).saturating_mul(busy)).div_ceil(t)
}

/// What one phase took on the machine.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhaseReport {
    /// Phase name.
    pub phase: String,
    /// Tasks replayed.
    pub tasks: u64,
    /// Cycles from the phase's start to the end of its barrier.
    pub cycles: u64,
    /// `cycles` at the clock, ms.
    pub ms: f64,
    /// Where the cycles went.
    pub stack: CycleStack,
    /// Busy cycles of each core (sum of its tasks' times).
    pub core_busy: Vec<u64>,
    /// Core and time of each task, in record order.
    pub schedule: Vec<(u32, u64)>,
    /// Sum of the tasks' counters.
    pub counters: Counters,
    /// Cache behaviour.
    pub memory: MemoryCounts,
    /// DRAM bandwidth bound of the phase, cycles.
    pub dram_bound: u64,
}

impl PhaseReport {
    /// Average fraction of the vector lanes active per vector instruction.
    pub fn lane_utilisation(&self) -> f64 {
        self.counters.lane_utilisation()
    }
}

/// One core: its caches and what it has done in the current phase.
struct Core {
    l1: Cache,
    l2: Cache,
}

/// One task's replay: the core the schedule gave it, what its lines did in that core's caches, its
/// pages ([`CacheOutcomes`]).
#[derive(Clone, Copy, Debug)]
struct TaskOutcome {
    core: u32,
    tally: LineTally,
    pages: TaskPages,
}

/// What every task of a frame's replay did in the caches ([`simulate_frame_recorded`]), to time the
/// same records again on a machine that differs only in its costs ([`simulate_recorded`]): the
/// calibration's fit predicts each benchmark hundreds of times with costs moving and caches fixed,
/// and replaying its lines each time was most of a calibration's time.
#[derive(Clone, Debug)]
pub struct CacheOutcomes {
    /// The configuration's fields the replay's outcomes depend on ([`replay_geometry`]).
    geometry: [u64; 9],
    /// Every task's outcome, tasks in frame order.
    tasks: Vec<TaskOutcome>,
}

/// The fields of `m` that decide what a replay's lines do (which core runs a task also depends on
/// the costs: [`simulate_recorded`] checks that per task): cores, one-core serial steps, and each
/// cache's size, ways and line.
fn replay_geometry(m: &MachineConfig) -> [u64; 9] {
    [
        m.cores as u64,
        m.serial_steps as u64,
        m.l1_kb as u64,
        m.l1_ways as u64,
        m.l2_kb as u64,
        m.l2_ways as u64,
        m.l3_kb as u64,
        m.l3_ways as u64,
        m.line_bytes as u64,
    ]
}

/// A task's cache outcomes so far (its lines arrive in chunks).
#[derive(Clone, Copy, Debug, Default)]
struct LineTally {
    accesses: u64,
    l1_hits: u64,
    l2_hits: u64,
    l2_misses: u64,
    /// L2 misses that hit the shared cache (0 without one).
    l3_hits: u64,
    /// Dirty lines the last level evicted (L2 without a shared cache, else the shared cache).
    writebacks: u64,
    /// Of the L2 hits, the L3 hits and the DRAM fills: those that continued a stream of the
    /// task's lines past its first [`STREAM_RAMP`] ([`LineMapper::map`]'s stream bit), which a
    /// prefetcher covers.
    streamed: [u64; 3],
    /// The same for lines of a young stream (within its first [`STREAM_RAMP`] lines).
    young: [u64; 3],
    /// Writes that missed L1: the written lines the task's stores waited for.
    write_misses: u64,
    /// Of the L1 misses, the writes', as the fields above count all of them: L2 hits, shared-cache
    /// hits, DRAM fills (levels 0, 1, 2), and of each the streamed and the young streams' lines.
    write_levels: WriteLevels,
}

/// A task's write misses by the level that served them ([`LineTally::write_levels`]).
#[derive(Clone, Copy, Debug, Default)]
struct WriteLevels {
    hits: [u64; 3],
    streamed: [u64; 3],
    young: [u64; 3],
}

impl WriteLevels {
    /// Counts a write miss served by `level` (0 L2, 1 shared cache, 2 DRAM) when `write` is 1.
    #[inline(always)]
    fn add(&mut self, level: usize, write: u64, stream: u64, young: u64) {
        self.hits[level] += write;
        self.streamed[level] += write & stream;
        self.young[level] += write & young;
    }
}

impl LineTally {
    /// Replays `lines` (ids from [`LineMapper::map`]) through `core`'s caches.
    #[inline]
    fn replay(&mut self, core: &mut Core, mut l3: Option<&mut Cache>, lines: &[u32]) {
        for &a in lines {
            let (id, write) = (a >> 3, a & 1 == 1);
            // An established stream's line, or a young one's.
            let (stream, young) = ((a >> 2 & 1) as u64, (a >> 1 & 1) as u64);
            if core.l1.access(id, write).hit {
                self.l1_hits += 1;
                continue;
            }
            let w = write as u64;
            self.write_misses += w;
            let r = core.l2.access(id, write);
            if r.hit {
                self.l2_hits += 1;
                self.streamed[0] += stream;
                self.young[0] += young;
                self.write_levels.add(0, w, stream, young);
                continue;
            }
            self.l2_misses += 1;
            match l3.as_deref_mut() {
                // L2 write-backs land in the shared cache (not modelled as accesses of their own).
                Some(l3) => {
                    let r3 = l3.access(id, write);
                    self.l3_hits += r3.hit as u64;
                    let level = if r3.hit { 1 } else { 2 };
                    self.streamed[level] += stream;
                    self.young[level] += young;
                    self.write_levels.add(level, w, stream, young);
                    self.writebacks += r3.writeback as u64;
                }
                None => {
                    self.streamed[2] += stream;
                    self.young[2] += young;
                    self.write_levels.add(2, w, stream, young);
                    self.writebacks += r.writeback as u64;
                }
            }
        }
        self.accesses += lines.len() as u64;
    }
}

/// The chip during a frame's replay: per-core caches (warm across phases) and the line-id map.
pub struct Machine<'a> {
    config: &'a MachineConfig,
    cores: Vec<Core>,
    /// The shared last-level cache, when the configuration has one (`l3_kb` > 0).
    l3: Option<Cache>,
    ids: LineMapper,
    dram_miss: u64,
}

impl<'a> Machine<'a> {
    /// A cold chip.
    pub fn new(config: &'a MachineConfig) -> Machine<'a> {
        let cores = (0..config.cores)
            .map(|_| Core {
                l1: Cache::new(config.l1_kb as u64 * 1024, config.l1_ways, config.line_bytes),
                l2: Cache::new(config.l2_kb as u64 * 1024, config.l2_ways, config.line_bytes),
            })
            .collect();
        let l3 = (config.l3_kb > 0)
            .then(|| Cache::new(config.l3_kb as u64 * 1024, config.l3_ways, config.line_bytes));
        Machine {
            config,
            cores,
            l3,
            ids: LineMapper::default(),
            // With a shared cache, a DRAM miss first misses it.
            dram_miss: config.dram_miss_cycles()
                + if config.l3_kb > 0 {
                    config.l3_latency as u64
                } else {
                    0
                },
        }
    }

    /// Runs `task` on `core`: replays its lines through the core's caches.
    pub fn run_task(&mut self, core: usize, task: &TaskRecord, mem: &mut MemoryCounts) -> TaskCost {
        let mut tally = LineTally::default();
        let mut chunk = Vec::new();
        let ids = &mut self.ids;
        let (cores, l3) = (&mut self.cores, &mut self.l3);
        let pages = ids.map(task, false, &mut chunk, |lines| {
            tally.replay(&mut cores[core], l3.as_mut(), lines);
        });
        self.finish(&task.counters, &tally, pages, 1, mem)
    }

    /// The cost of a task of `counters` whose lines were replayed into `tally`, and its memory
    /// counts added to `mem`. `busy`: the cores running the step's tasks at the same time (1 when
    /// the task has the chip to itself); they share DRAM's bandwidth.
    fn finish(
        &self,
        counters: &Counters,
        tally: &LineTally,
        pages: TaskPages,
        busy: u32,
        mem: &mut MemoryCounts,
    ) -> TaskCost {
        let m = self.config;
        // A streamed DRAM line: the prefetcher's throughput, or on a busy chip at least this
        // core's share of the chip's bandwidth (every busy core streaming at once).
        let stream_dram = if busy > 1 {
            m.stream_dram_cycles
                .max(busy as f64 * m.line_bytes as f64 / m.dram_bytes_per_cycle())
        } else {
            m.stream_dram_cycles
        };
        let (issue, atomics) = compute_cost(counters, m);
        // The host scheduler's cost of starting the task counts as synchronisation.
        let atomics = atomics.saturating_add(m.task_overhead_cycles.ceil() as u64);
        // In order: the chain's excess over the issue stalls this thread; the core's other threads
        // issue meanwhile. What they cannot hide is the core executing the chain: issue time.
        let issue = if m.separate_ports {
            issue
        } else {
            // A mispredicted branch stalls this thread like a chain (Larrabee's threads issue in
            // turn, so the others fill the refill).
            let wait = chain_cycles(counters, m)
                .saturating_sub(issue)
                .saturating_add(mispredict_cycles(counters, m));
            issue.saturating_add(exposed_stall(
                wait,
                issue.saturating_add(atomics),
                m.threads_per_core,
            ))
        };
        let (l1_lat, l2_lat) = (m.l1_latency as u64, m.l2_latency as u64);
        let dram_misses = tally.l2_misses - tally.l3_hits;
        mem.accesses += tally.accesses;
        mem.l1_misses += tally.accesses - tally.l1_hits;
        mem.l2_misses += tally.l2_misses;
        mem.l3_hits += tally.l3_hits;
        mem.writebacks += tally.writebacks;
        let tlb_misses = if m.tlb_entries > 0 {
            pages.distinct.saturating_sub(m.tlb_entries as u64)
        } else {
            0
        };
        mem.tlb_misses += tlb_misses;
        mem.page_faults += pages.fresh;
        // Page walks: the walker's time, neither overlapped with other misses nor hidden by other
        // threads.
        let paging = (tlb_misses as f64 * m.tlb_miss_cycles).ceil() as u64;
        // With a prefetcher, the misses that continue a stream cost their level's streaming
        // throughput; the others their latency.
        // A young stream's misses pay `stream_ramp_share` of their latency (in f64 and rounded up:
        // the share is not an integer).
        let (streamed, young) = if m.prefetcher {
            (tally.streamed, tally.young)
        } else {
            ([0; 3], [0; 3])
        };
        let share = m.stream_ramp_share;
        let level = |hits: u64, k: usize, lat: u64| paid_latency(hits, streamed[k], young[k], share, lat);
        let latency = (tally.l1_hits.saturating_mul(l1_lat)).saturating_add(
            (level(tally.l2_hits, 0, l2_lat)
                + level(tally.l3_hits, 1, m.l3_latency as u64)
                + level(dram_misses, 2, self.dram_miss))
            .ceil() as u64,
        );
        // A dirty line the last level evicts is written back: a throughput, as a streamed line.
        let streaming = (streamed[0] as f64 * m.stream_l2_cycles
            + streamed[1] as f64 * m.stream_l3_cycles
            + streamed[2] as f64 * stream_dram
            + tally.writebacks as f64 * m.writeback_cycles)
            .ceil() as u64;
        let stall = latency.saturating_add(streaming);
        // Misses a thread overlaps (out-of-order cores) divide its latency before other hardware
        // threads hide what they can; a stream's cost is a throughput already. Write misses slower
        // than the store buffer fills overlap no more than it holds written lines
        // ([`StoreBuffer`]).
        let overlapped = if m.memory_parallelism > 1.0 {
            // The writes' part of `latency`, priced as `level` prices all misses.
            let (w, streams) = (&tally.write_levels, m.prefetcher as u64);
            let write_level = |k: usize, lat: u64| {
                paid_latency(
                    w.hits[k],
                    streams * w.streamed[k],
                    streams * w.young[k],
                    share,
                    lat,
                )
            };
            // Write misses of the levels slower than the buffer fills wait in it, as many at once
            // as it holds lines; the others overlap as reads.
            let (blocking, parallelism) = match StoreBuffer::of(counters, tally.write_misses, issue, m) {
                Some(b) => {
                    let slow = |lat: u64| lat as f64 > b.fill_cycles;
                    let mut blocking = 0.0;
                    for (k, lat) in [(0, l2_lat), (1, m.l3_latency as u64), (2, self.dram_miss)] {
                        if slow(lat) {
                            blocking += write_level(k, lat);
                        }
                    }
                    (blocking, b.parallelism)
                }
                None => (0.0, m.memory_parallelism),
            };
            let others = (latency as f64 - blocking).max(0.0);
            (others / m.memory_parallelism + blocking / parallelism).ceil() as u64
        } else {
            latency
        }
        .saturating_add(streaming);
        let exposed = exposed_stall(overlapped, issue.saturating_add(atomics), m.threads_per_core)
            .saturating_add(paging);
        TaskCost {
            issue,
            atomics,
            stall,
            exposed,
        }
    }

    /// Replays one phase: schedules its tasks, then the barrier.
    pub fn run_phase(&mut self, phase: &str, tasks: &[TaskRecord]) -> PhaseReport {
        let step = Step::parallel(phase, tasks);
        let mut ids = std::mem::take(&mut self.ids);
        let mut chunk = Vec::new();
        let r = self.run_phase_with(
            step,
            |task, replay| ids.map(task, false, &mut chunk, replay),
            None,
        );
        self.ids = ids;
        r
    }

    /// [`Machine::run_phase`] with each task's line ids supplied by `mapped(task, replay)`, which
    /// calls `replay` with the task's ids ([`LineMapper::map`]'s encoding) chunk by chunk, in order
    /// and returns the task's pages (tasks
    /// are asked for in record order). The pipelined replay ([`simulate_frame`]) maps lines on
    /// another thread. Each task's outcome is also pushed to `record` when given.
    fn run_phase_with(
        &mut self,
        step: Step<'_>,
        mut mapped: impl FnMut(&TaskRecord, &mut dyn FnMut(&[u32])) -> TaskPages,
        mut record: Option<&mut Vec<TaskOutcome>>,
    ) -> PhaseReport {
        self.run_phase_outcomes(step, |core, task, cores, l3| {
            let mut tally = LineTally::default();
            let pages = mapped(task, &mut |lines| {
                tally.replay(&mut cores[core], l3.as_mut(), lines)
            });
            let outcome = TaskOutcome {
                core: core as u32,
                tally,
                pages,
            };
            if let Some(r) = record.as_deref_mut() {
                r.push(outcome);
            }
            Some(outcome)
        })
        .expect("a replay gives every task's outcome")
    }

    /// [`Machine::run_phase_with`] with each task's cache outcome given by `outcome(core, task,
    /// cores, l3)` for the core the schedule picked: a replay of its lines through the caches, or
    /// one recorded earlier ([`simulate_recorded`]). `None` from `outcome` (a recorded outcome of
    /// another core: the schedule went another way) ends the phase with `None`.
    fn run_phase_outcomes(
        &mut self,
        step: Step<'_>,
        mut outcome: impl FnMut(usize, &TaskRecord, &mut [Core], &mut Option<Cache>) -> Option<TaskOutcome>,
    ) -> Option<PhaseReport> {
        let (phase, tasks) = (step.name, step.tasks);
        let m = self.config;
        let n = m.cores as usize;
        // Tasks the host ran one after another: one core runs them all, in order.
        let one_core = step.serial && m.serial_steps;
        // Cores running the step's tasks at once (they share DRAM's bandwidth).
        let busy_cores = if one_core {
            1
        } else {
            n.min(tasks.len()).max(1) as u32
        };
        let mut busy = vec![0u64; n];
        let (mut issue, mut exposed, mut atomics) = (0u64, 0u64, 0u64);
        let mut memory = MemoryCounts::default();
        let mut counters = Counters::default();
        let mut schedule = Vec::with_capacity(tasks.len());
        for task in tasks {
            // Least busy core, ties to the lowest index.
            let core = if one_core {
                0
            } else {
                (0..n).min_by_key(|&i| (busy[i], i)).expect("at least one core")
            };
            let TaskOutcome { tally, pages, .. } = outcome(core, task, &mut self.cores, &mut self.l3)?;
            let cost = self.finish(&task.counters, &tally, pages, busy_cores, &mut memory);
            busy[core] = busy[core].saturating_add(cost.cycles());
            schedule.push((core as u32, cost.cycles()));
            issue = issue.saturating_add(cost.issue);
            exposed = exposed.saturating_add(cost.exposed);
            atomics = atomics.saturating_add(cost.atomics);
            counters += task.counters;
        }
        let busiest = busy.iter().copied().max().unwrap_or(0);
        let dram_bound = (memory.dram_bytes(m.line_bytes) as f64 / m.dram_bytes_per_cycle()).ceil() as u64;
        let bw_excess = dram_bound.saturating_sub(busiest);
        let barrier = m.barrier_cycles as u64;
        let cycles = busiest.saturating_add(bw_excess).saturating_add(barrier);
        let cores = n as u64;
        let mut stack = CycleStack {
            issue: issue / cores,
            memory: exposed / cores + bw_excess,
            atomics_sync: atomics / cores + barrier,
            imbalance_idle: 0,
        };
        // The average core's parts never exceed the busiest core's time (each is a share of the
        // summed core time, which is at most cores × busiest), so the rest is ≥ 0.
        stack.imbalance_idle = cycles.saturating_sub(stack.total());
        Some(PhaseReport {
            phase: phase.to_string(),
            tasks: tasks.len() as u64,
            cycles,
            ms: m.ms(cycles),
            stack,
            core_busy: busy,
            schedule,
            counters,
            memory,
            dram_bound,
        })
    }
}

/// Sequential streams a task's prefetcher follows ([`LineMapper::map_each`]). Assumption: 16, the
/// streams the L2 stream prefetchers of current x86 cores track (Intel's optimisation manual: 32
/// streams, one forward and one backward per 4 KiB page; AMD's Zen guides give no count).
pub const STREAMS: usize = 16;
// The follower's masks are u32 and its oldest-stream search halves the table.
const _: () = assert!(STREAMS.is_power_of_two() && STREAMS <= 32);

/// Lines either way within which an access continues a stream: a stride of up to 4 lines (256
/// bytes) is followed, as a stride prefetcher does.
pub const STREAM_REACH: u64 = 4;

// Blocks of `LineAlloc` lie more than this far apart, so no stream runs from one into another
// because the allocator placed them side by side in one run and not in the next.
const _: () = assert!(STREAM_REACH <= sism_simd::GAP_LINES as u64);

/// Lines a stream covers before the prefetcher has run far enough ahead of it: the lines it
/// reaches within its first 64 lines (a 4 KiB page, within which hardware prefetchers train) cost
/// `stream_ramp_share` of their level's latency, the later ones the streaming cost. Assumption,
/// with the share fitted: on the project's Zen 4 host, runs of 2, 4, 16 and 64 consecutive lines at
/// random starts in DRAM cost 72%, 70%, 63% and 57% of random lines a line, 256-line runs 43%.
pub const STREAM_RAMP: u8 = 64;

/// Chunks of line ids mapped ahead of the cache replay; with [`CHUNK_LINES`] per chunk, the
/// pipeline holds at most a few MB whatever the records claim.
const PIPELINE_DEPTH: usize = 16;

/// Line ids per chunk handed from the mapping thread to the cache replay.
pub const CHUNK_LINES: usize = 1 << 16;

/// One step's records as the replay takes them.
#[derive(Clone, Copy, Debug)]
pub struct Step<'a> {
    /// `phase.step`.
    pub name: &'a str,
    /// The step's tasks, in record order.
    pub tasks: &'a [TaskRecord],
    /// The host ran the tasks one after another ([`crate::exec::PhaseRecords::serial`]): a machine
    /// with `serial_steps` runs them on one core.
    pub serial: bool,
    /// The tasks' lines are first-touch ids with their stream states, as a records file holds them
    /// ([`crate::exec::PhaseRecords::first_touch`]); false: line addresses, as recorded.
    pub first_touch: bool,
}

impl<'a> Step<'a> {
    /// A step whose tasks ran in parallel, their lines as recorded.
    pub fn parallel(name: &'a str, tasks: &'a [TaskRecord]) -> Step<'a> {
        Step {
            name,
            tasks,
            serial: false,
            first_touch: false,
        }
    }

    /// The step's tasks, each with whether its lines are first-touch ids ([`Step::first_touch`]).
    fn tasks(&self) -> impl Iterator<Item = (&'a TaskRecord, bool)> {
        let first_touch = self.first_touch;
        self.tasks.iter().map(move |t| (t, first_touch))
    }
}

/// Replays a whole frame (phases in order) on a cold chip, in two pipelined stages: one thread
/// decodes each task's line stream and maps it to first-touch ids (record order), handing them over
/// in chunks of [`CHUNK_LINES`]; the calling thread schedules the tasks and replays the ids through
/// the caches. Both stages run in record order, so the result is the same as
/// [`Machine::run_phase`] phase after phase, whatever the host's threads.
pub fn simulate_frame(config: &MachineConfig, phases: &[Step<'_>]) -> Vec<PhaseReport> {
    simulate_frame_with(config, phases, |_, _| {})
}

/// [`simulate_frame`], also handing `lines` every task's mapped lines (as [`LineMapper::map`] gives
/// them), chunk by chunk in frame order, with `true` on a task's last chunk: what the records file's
/// first-touch form is made of ([`crate::machine::simulate_canonical`]). `lines` runs on the
/// calling thread, the cache simulation's, beside the mapping thread (the pipeline's slow stage).
pub fn simulate_frame_with(
    config: &MachineConfig,
    phases: &[Step<'_>],
    lines: impl FnMut(&[u32], bool),
) -> Vec<PhaseReport> {
    simulate_pipelined(config, phases, lines, None, FOLLOW_HERE_QUEUED)
}

/// [`simulate_frame`], also giving what every task did in the caches, for timing the same records
/// on machines that differ only in costs ([`simulate_recorded`]).
pub fn simulate_frame_recorded(
    config: &MachineConfig,
    phases: &[Step<'_>],
) -> (Vec<PhaseReport>, CacheOutcomes) {
    let mut tasks = Vec::new();
    let reports = simulate_pipelined(config, phases, |_, _| {}, Some(&mut tasks), FOLLOW_HERE_QUEUED);
    let outcomes = CacheOutcomes {
        geometry: replay_geometry(config),
        tasks,
    };
    (reports, outcomes)
}

/// The reports [`simulate_frame`] gives for `config` and `phases`, from `outcomes` recorded by
/// [`simulate_frame_recorded`] of the same `phases` on a configuration of the same caches and
/// cores, without replaying a line; `None` where they cannot say: another geometry, other tasks, or
/// a task the schedule now gives another core than it did (costs decide the schedule, and the
/// caches' contents then differ).
pub fn simulate_recorded(
    config: &MachineConfig,
    phases: &[Step<'_>],
    outcomes: &CacheOutcomes,
) -> Option<Vec<PhaseReport>> {
    let total: usize = phases.iter().map(|p| p.tasks.len()).sum();
    if outcomes.geometry != replay_geometry(config) || outcomes.tasks.len() != total {
        return None;
    }
    let mut machine = Machine::new(config);
    let mut recorded = outcomes.tasks.iter();
    phases
        .iter()
        .map(|&step| {
            machine.run_phase_outcomes(step, |core, _, _, _| {
                let o = recorded.next()?;
                (o.core as usize == core).then_some(*o)
            })
        })
        .collect()
}

/// [`simulate_frame_with`], pushing each task's outcome to `record` when given; the mapping thread
/// follows a task's streams itself when at least `follow_here_queued` chunks wait
/// ([`FOLLOW_HERE_QUEUED`]; tests force either side).
fn simulate_pipelined(
    config: &MachineConfig,
    phases: &[Step<'_>],
    mut lines: impl FnMut(&[u32], bool),
    mut record: Option<&mut Vec<TaskOutcome>>,
    follow_here_queued: usize,
) -> Vec<PhaseReport> {
    let mut machine = Machine::new(config);
    let mut ids = std::mem::take(&mut machine.ids);
    std::thread::scope(|scope| {
        // A message is a chunk of a task's accesses ([`LineMapper::map_unfollowed`]) and, with the
        // task's last chunk, its pages. The mapping thread decodes and maps to first-touch ids,
        // which must go in frame order; this thread replays. Following a task's streams (a third
        // to a half of the work, measured on japanese-maple) depends on that task alone, so either
        // thread may do it, with the same states: the mapping thread follows a task's streams
        // itself while chunks wait for this thread, and leaves them to this thread while it
        // waits for chunks.
        let (full_tx, full_rx) =
            crossbeam::channel::bounded::<(MappedChunk, Option<TaskPages>)>(PIPELINE_DEPTH);
        let (empty_tx, empty_rx) = crossbeam::channel::unbounded::<MappedChunk>();
        scope.spawn(move || {
            for (task, first_touch) in phases.iter().flat_map(|p| p.tasks()) {
                let follow_here = !first_touch && full_tx.len() >= follow_here_queued;
                let followed = first_touch || follow_here;
                let mut streams = StreamFollower::default();
                let mut buf = empty_rx.try_recv().unwrap_or_default();
                buf.clear(followed);
                let mut alive = true;
                let pages = ids.map_unfollowed(task, first_touch, |id, line| {
                    buf.ids.push(id | streams.follow_unless(!follow_here, line) << 1);
                    if !followed {
                        buf.lines.push(line);
                    }
                    if buf.ids.len() == CHUNK_LINES && alive {
                        let mut next = empty_rx.try_recv().unwrap_or_default();
                        next.clear(followed);
                        alive = full_tx.send((std::mem::replace(&mut buf, next), None)).is_ok();
                    }
                });
                if !alive || full_tx.send((buf, Some(pages))).is_err() {
                    return;
                }
            }
        });
        let mut streams = StreamFollower::default();
        phases
            .iter()
            .map(|&step| {
                machine.run_phase_with(
                    step,
                    |_, replay| loop {
                        let (mut chunk, pages) = full_rx.recv().expect("the mapping thread maps every task");
                        if !chunk.followed {
                            streams.follow_chunk(&mut chunk.ids, &chunk.lines);
                        }
                        replay(&chunk.ids);
                        lines(&chunk.ids, pages.is_some());
                        // Hand the buffer back for reuse (the mapper may have finished).
                        let _ = empty_tx.send(chunk);
                        if let Some(pages) = pages {
                            // Each task starts with no stream.
                            streams = StreamFollower::default();
                            break pages;
                        }
                    },
                    record.as_deref_mut(),
                )
            })
            .collect()
    })
}

/// Chunks waiting for the replay's calling thread at which its mapping thread follows the next
/// task's streams itself ([`simulate_pipelined`]).
const FOLLOW_HERE_QUEUED: usize = 2;

/// A chunk of a task's accesses as the replay's mapping thread hands them on
/// ([`LineMapper::map_unfollowed`]): ids with their stream states, or without them and with the
/// line addresses a [`StreamFollower`] needs.
#[derive(Default)]
struct MappedChunk {
    /// `id << 3 | stream << 1 | is_write`, the stream state 0 unless `followed`.
    ids: Vec<u32>,
    /// The accesses' line addresses, for the stream follower (empty when `followed`).
    lines: Vec<u64>,
    /// The ids carry their stream states (the records did, or the mapping thread followed them).
    followed: bool,
}

impl MappedChunk {
    /// Empties the chunk for a task whose ids will (`followed`) or will not carry their states.
    fn clear(&mut self, followed: bool) {
        self.ids.clear();
        self.lines.clear();
        self.followed = followed;
    }
}

/// A frame's line streams decoded once into first-touch ids (`id << 3 | stream << 2 | young << 1 | is_write`, as
/// [`LineMapper::map`] gives them) with each task's pages, for re-timing the same records on many machines without decoding
/// them again ([`simulate_decoded`]). Holds 4 bytes per line access.
pub struct DecodedLines {
    /// Every task's ids, tasks in frame order.
    ids: Vec<u32>,
    /// Task `k`'s ids are `ids[offsets[k]..offsets[k + 1]]` (tasks in frame order; starts at 0).
    offsets: Vec<usize>,
    /// Task `k`'s pages.
    pages: Vec<TaskPages>,
}

impl DecodedLines {
    /// Decodes every task of `phases` (frame order) with [`LineMapper::map`], as a replay does.
    pub fn decode(phases: &[Step<'_>]) -> DecodedLines {
        let total: u64 = phases
            .iter()
            .flat_map(|p| p.tasks.iter())
            .map(|t| t.lines.len())
            .sum();
        let mut ids = Vec::with_capacity(total as usize);
        let mut offsets = vec![0];
        let (mut map, mut chunk) = (LineMapper::default(), Vec::new());
        let mut pages = Vec::new();
        for (task, first_touch) in phases.iter().flat_map(|p| p.tasks()) {
            pages.push(map.map(task, first_touch, &mut chunk, |c| ids.extend_from_slice(c)));
            offsets.push(ids.len());
        }
        DecodedLines { ids, offsets, pages }
    }
}

/// [`simulate_frame`] from lines decoded once ([`DecodedLines::decode`] of the same `phases`): the
/// same reports, without decoding the streams again.
pub fn simulate_decoded(
    config: &MachineConfig,
    phases: &[Step<'_>],
    lines: &DecodedLines,
) -> Vec<PhaseReport> {
    let mut machine = Machine::new(config);
    let mut task = lines.offsets.windows(2).zip(&lines.pages);
    phases
        .iter()
        .map(|&step| {
            machine.run_phase_with(
                step,
                |_, replay| {
                    let (span, pages) = task.next().expect("one span per task of the same phases");
                    for chunk in lines.ids[span[0]..span[1]].chunks(CHUNK_LINES) {
                        replay(chunk);
                    }
                    *pages
                },
                None,
            )
        })
        .collect()
}

/// What a task's line stream says about 4 KiB pages ([`PAGE_BYTES`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TaskPages {
    /// Distinct pages the task touched (its TLB footprint).
    pub distinct: u64,
    /// Pages first touched in the frame by this task, with a write: memory the frame allocated,
    /// whose first touch would be a page fault in a cold process (data a frame only reads, such as
    /// the scene, was allocated before it). Counted, not charged ([`MemoryCounts::page_faults`]).
    pub fresh: u64,
}

/// Maps recorded lines to first-touch ids ([`LineIds`], over the whole frame, so tasks must be
/// mapped in frame order) and tallies each task's pages.
#[derive(Default)]
pub struct LineMapper {
    ids: LineIds,
    /// Per page of first-touch ids (dense: page `p` holds ids `64p..64p+63`), the last task that
    /// touched it ([`LineMapper::task`]; 0: none): a task's distinct pages are counted by an array
    /// store per page change, not a hash-set insert.
    page_task: Vec<u32>,
    /// The number of the task being mapped (1 for the first).
    task: u32,
}

/// Lines of a [`PAGE_BYTES`] page (a constant, so that the per-access divisions are shifts).
const LINES_PER_PAGE: u32 = (PAGE_BYTES / 64) as u32;

impl LineMapper {
    /// Decodes `task`'s line stream as `id << 3 | established_stream << 2 | young_stream << 1 |
    /// is_write`, calling `replay` with chunks of at most [`CHUNK_LINES`] ids (`chunk` is the
    /// buffer); returns the task's pages. `first_touch`: the lines are first-touch ids with their
    /// stream states ([`canonical_line`]), as a records file holds them, else line addresses.
    pub fn map(
        &mut self,
        task: &TaskRecord,
        first_touch: bool,
        chunk: &mut Vec<u32>,
        mut replay: impl FnMut(&[u32]),
    ) -> TaskPages {
        chunk.clear();
        let pages = self.map_each(task, first_touch, |id| {
            chunk.push(id);
            if chunk.len() == CHUNK_LINES {
                replay(chunk);
                chunk.clear();
            }
        });
        replay(chunk);
        chunk.clear();
        pages
    }

    /// [`LineMapper::map`] one id at a time.
    ///
    /// Pages are blocks of 64 consecutive first-touch ids ([`PAGE_BYTES`] of memory in the order
    /// the frame first touched it), not of process addresses: where a buffer falls relative to the
    /// host's page boundaries changes from run to run, and the counts must not.
    ///
    /// Streams are followed on addresses ([`StreamFollower`]; first-touch ids would make any first
    /// pass look sequential). Lines that are already first-touch ids carry the state the
    /// addresses gave when they were saved.
    pub fn map_each(&mut self, task: &TaskRecord, first_touch: bool, mut each: impl FnMut(u32)) -> TaskPages {
        let mut streams = StreamFollower::default();
        self.map_unfollowed(task, first_touch, |id, line| {
            each(id | streams.follow_unless(first_touch, line) << 1)
        })
    }

    /// [`LineMapper::map_each`] without following streams: `each` gets every access's `id << 3 |
    /// stream << 1 | is_write` with the stream state only where the records carry it
    /// (`first_touch`; else 0), and the line's address, which a [`StreamFollower`] of the task
    /// ([`StreamFollower::follow_unless`]) turns into the state. The replay's pipeline follows a
    /// task's streams on whichever of its two threads is less busy (`simulate_pipelined`):
    /// following them had been most of the mapping thread's time, the pipeline's slow stage, while
    /// the cache simulation's thread waited most of its own.
    pub fn map_unfollowed(
        &mut self,
        task: &TaskRecord,
        first_touch: bool,
        mut each: impl FnMut(u32, u64),
    ) -> TaskPages {
        let mut pages = TaskPages::default();
        let mut last_page = u32::MAX;
        self.task = self.task.wrapping_add(1);
        if self.task == 0 {
            // Wrapped (2^32 tasks): forget every stamp so none is mistaken for this task's.
            self.page_task.fill(0);
            self.task = 1;
        }
        let task_number = self.task;
        // A plain loop over the decoder (not a callback): its state stays in registers and
        // nothing is called per access.
        for (line, write) in task.lines.iter() {
            let (key, stream) = if first_touch {
                // At most 2 (a records file's lines are checked as it loads).
                let (id, stream) = canonical_parts(line);
                (id, stream.min(2))
            } else {
                (line, 0)
            };
            let before = self.ids.len();
            let id = self.ids.id(key);
            // The first line of a page, touched first by a write: fresh memory.
            pages.fresh += (self.ids.len() > before && id.is_multiple_of(LINES_PER_PAGE) && write) as u64;
            let page = id / LINES_PER_PAGE;
            if page != last_page {
                last_page = page;
                let p = page as usize;
                if p >= self.page_task.len() {
                    self.page_task.resize((p + 1).next_power_of_two(), 0);
                }
                pages.distinct += (self.page_task[p] != task_number) as u64;
                self.page_task[p] = task_number;
            }
            each(id << 3 | stream << 1 | write as u32, line);
        }
        pages
    }
}

/// A records file's line: first-touch id `id` with the stream state `stream` its address gave
/// ([`StreamFollower::follow`]).
#[inline]
pub fn canonical_line(id: u32, stream: u32) -> u64 {
    (id as u64) << 2 | stream as u64
}

/// A records file's line split back into its first-touch id and stream state
/// ([`canonical_line`]'s inverse; the state is 3 only in a corrupt file, which loading refuses).
#[inline]
pub fn canonical_parts(line: u64) -> (u64, u32) {
    (line >> 2, (line & 3) as u32)
}

/// The sequential streams a task's prefetcher follows, on line addresses: the task's last
/// [`STREAMS`] stream heads are kept, and an access within [`STREAM_REACH`] lines of one of them,
/// either way, continues that stream and moves its head (state 1 while the stream has moved by
/// fewer than [`STREAM_RAMP`] lines, 2 after); any other access starts a stream in place of the
/// least recently used one. A uniform shift of the addresses changes nothing; two buffers the
/// allocator happened to place end to end can continue one stream across the seam, as a hardware
/// prefetcher would. One per task (each task starts with no stream).
pub struct StreamFollower {
    /// Stream heads (line addresses); `u64::MAX / 2` is never near a real line.
    heads: [u64; STREAMS],
    /// Lines each stream has moved by (saturating): young below `STREAM_RAMP`.
    moves: [u8; STREAMS],
    /// The access count at each stream's last use: a new stream replaces the least recently used
    /// one (a prefetcher keeps the streams it is following; round-robin replacement would restart
    /// a busy stream every 16 stray accesses, young again).
    used: [u64; STREAMS],
    /// The stream the last access continued or started.
    last: usize,
    /// Accesses so far.
    clock: u64,
}

impl Default for StreamFollower {
    fn default() -> Self {
        StreamFollower {
            heads: [u64::MAX / 2; STREAMS],
            moves: [0; STREAMS],
            used: [0; STREAMS],
            last: 0,
            clock: 0,
        }
    }
}

impl StreamFollower {
    /// [`StreamFollower::follow`] of `line`, or 0 without following when `skip` (the records carry
    /// the state, [`LineMapper::map_unfollowed`], or another thread follows it).
    #[inline(always)]
    pub fn follow_unless(&mut self, skip: bool, line: u64) -> u32 {
        if skip {
            0
        } else {
            self.follow(line)
        }
    }

    /// Follows `lines` (a chunk of a task's accesses, in order), adding each one's state to its
    /// id (`ids[k] |= state << 1`, [`LineMapper::map_unfollowed`]'s encoding). Not inlined: a loop
    /// of its own keeps the follower's state out of the caller's closures, whose captures the
    /// compiler reloads on every access.
    #[inline(never)]
    pub fn follow_chunk(&mut self, ids: &mut [u32], lines: &[u64]) {
        let mut s = core::mem::take(self);
        for (id, &line) in ids.iter_mut().zip(lines) {
            *id |= s.follow(line) << 1;
        }
        *self = s;
    }

    /// The next access's line: 0 if it is no new line of a stream (a new stream, or the same line
    /// again), 1 if a young stream's, 2 if an established stream's.
    #[inline(always)]
    pub fn follow(&mut self, line: u64) -> u32 {
        let clock = self.clock;
        self.clock += 1;
        let (heads, moves, used) = (&mut self.heads, &mut self.moves, &mut self.used);
        // The heads within reach (the line itself included), as a bit mask: a branch-free loop
        // the compiler vectorises, since the mapper does this for every access.
        let within = |h: u64| line.wrapping_sub(h).wrapping_add(STREAM_REACH) <= 2 * STREAM_REACH;
        // Most accesses continue the stream the last one did: tried first.
        let mut near = (within(heads[self.last]) as u32) << self.last;
        if near == 0 {
            for (k, &h) in heads.iter().enumerate() {
                near |= (within(h) as u32) << k;
            }
        }
        if near != 0 {
            // The stream found moves to the line; the same line again is no new line of its
            // stream.
            let k = near.trailing_zeros() as usize;
            self.last = k;
            used[k] = clock;
            let moved = heads[k] != line;
            heads[k] = line;
            let state = if !moved {
                0
            } else if moves[k] < STREAM_RAMP {
                1
            } else {
                2
            };
            moves[k] = moves[k].saturating_add(moved as u8);
            state
        } else {
            let victim = oldest_stream(used);
            heads[victim] = line;
            moves[victim] = 0;
            used[victim] = clock;
            self.last = victim;
            0
        }
    }
}

/// The least recently used of the streams whose last uses are `used`, the lowest index among
/// equals (streams never used yet, in order): what a scan keeping the running minimum's index
/// finds. Not that scan: it is a chain of dependent selects, 16 long, on every new stream (a fifth
/// of the replay's mapping time, measured on japanese-maple). A tree of minima, then the first
/// stream holding it.
#[inline(always)]
fn oldest_stream(used: &[u64; STREAMS]) -> usize {
    let mut m = *used;
    let mut half = STREAMS;
    while half > 1 {
        half /= 2;
        for k in 0..half {
            m[k] = m[k].min(m[k + half]);
        }
    }
    let mut holding = 0u32;
    for (k, &u) in used.iter().enumerate() {
        holding |= ((u == m[0]) as u32) << k;
    }
    holding.trailing_zeros() as usize
}

/// The frame's totals from its phases: cycles, stack, counters and memory counts summed; the
/// schedule left empty.
pub fn frame_total(phases: &[PhaseReport], config: &MachineConfig) -> PhaseReport {
    let mut f = PhaseReport {
        phase: "frame".into(),
        core_busy: vec![0; config.cores as usize],
        ..Default::default()
    };
    for p in phases {
        add_phase(&mut f, p);
    }
    f.ms = config.ms(f.cycles);
    f
}

/// Adds phase `p` into the total `f` (cycles, tasks, stack, counters, memory, DRAM bound, per-core
/// busy time; not `ms` and not the schedule).
pub fn add_phase(f: &mut PhaseReport, p: &PhaseReport) {
    f.tasks += p.tasks;
    f.cycles = f.cycles.saturating_add(p.cycles);
    f.stack.add(&p.stack);
    f.counters += p.counters;
    f.memory.add(&p.memory);
    f.dram_bound += p.dram_bound;
    for (a, b) in f.core_busy.iter_mut().zip(&p.core_busy) {
        *a = a.saturating_add(*b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sism_simd::LineStream;

    #[test]
    fn the_oldest_stream_is_the_one_a_scan_finds() {
        // The scan the follower first used. The records, and so every counter and golden checksum,
        // depend on the tree picking the same stream every time.
        let scan = |used: &[u64; STREAMS]| {
            let mut victim = 0;
            for k in 1..STREAMS {
                if used[k] < used[victim] {
                    victim = k;
                }
            }
            victim
        };
        // Last-use clocks as the follower holds them (distinct, with never-used streams at 0),
        // and from a narrow range (many ties anywhere in the table).
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for step in 0..200_000u64 {
            let mut used = [0u64; STREAMS];
            for u in &mut used {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                *u = match step % 3 {
                    0 => x % 4,
                    1 => x >> 1,
                    _ if x.is_multiple_of(3) => 0,
                    _ => x >> 1,
                };
            }
            assert_eq!(oldest_stream(&used), scan(&used), "{used:?}");
        }
    }

    #[test]
    fn either_thread_of_the_pipeline_follows_the_same_streams() {
        // Tasks of sequential runs, strides and scattered lines, one longer than a chunk.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let tasks: Vec<TaskRecord> = (0..6u64)
            .map(|t| {
                let n = if t == 2 {
                    CHUNK_LINES as u64 * 2 + 777
                } else {
                    5000 + 900 * t
                };
                let lines = LineStream::encode((0..n).map(|i| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    let line = match i % 5 {
                        0 | 1 => 1_000_000 * (t + 1) + i,
                        2 => 50_000_000 + 3 * i,
                        _ => x % 4_000_000,
                    };
                    (line, x.is_multiple_of(7))
                }));
                TaskRecord {
                    kind: 0,
                    counters: Counters {
                        valu: 10,
                        vector_ops: 10,
                        ..Default::default()
                    },
                    lines,
                }
            })
            .collect();
        let config = MachineConfig::larrabee_24();
        let steps = [Step::parallel("a", &tasks[..4]), Step::parallel("b", &tasks[4..])];
        let run = |queued| {
            let mut mapped = Vec::new();
            let reports =
                simulate_pipelined(&config, &steps, |c, _| mapped.extend_from_slice(c), None, queued);
            (reports, mapped)
        };
        // Every task followed by the mapping thread, then every task by the calling thread.
        let (mapper, mapper_lines) = run(0);
        let (caller, caller_lines) = run(usize::MAX);
        assert_eq!(mapper_lines, caller_lines);
        assert!(
            mapper_lines.iter().any(|id| (id >> 1) & 3 == 2),
            "some lines continue streams"
        );
        assert_eq!(format!("{mapper:?}"), format!("{caller:?}"));
        // The same as the unpipelined replay, step after step.
        let mut machine = Machine::new(&config);
        let serial: Vec<_> = steps.iter().map(|s| machine.run_phase(s.name, s.tasks)).collect();
        assert_eq!(format!("{caller:?}"), format!("{serial:?}"));
    }

    #[test]
    fn exposed_stall_hand_cases() {
        // One thread: everything exposed.
        assert_eq!(exposed_stall(100, 10, 1), 100);
        // Four threads, 10 busy: 30 cycles hidden by the other three, (100 - 30) / 4 = 17.5 → 18.
        assert_eq!(exposed_stall(100, 10, 4), 18);
        // Enough issue to hide everything.
        assert_eq!(exposed_stall(100, 40, 4), 0);
    }

    #[test]
    fn the_store_buffer_bounds_write_misses_by_stores_per_line() {
        let mut m = MachineConfig::larrabee_24();
        // Larrabee: not modelled (no entries, and one miss at a time already).
        let fields = Counters {
            scalar_stores: 1600,
            ..Default::default()
        };
        assert_eq!(StoreBuffer::of(&fields, 100, 1000, &m), None);
        m.memory_parallelism = 16.0;
        m.store_buffer_entries = 112;
        // 16 scalar stores a written line: 112 / 16 = 7 lines in flight; 112 stores take 70 of
        // the task's 1000 cycles.
        let b = StoreBuffer::of(&fields, 100, 1000, &m).expect("modelled");
        assert_eq!(b.parallelism, 7.0);
        assert_eq!(b.fill_cycles, 70.0);
        let parallelism = |c: Counters, write_misses: u64| {
            StoreBuffer::of(&c, write_misses, 1000, &m)
                .expect("modelled")
                .parallelism
        };
        // One 64-byte vector store a line: bounded by the misses a thread keeps in flight.
        let lines = Counters {
            store: 100,
            ..Default::default()
        };
        assert_eq!(parallelism(lines, 100), 16.0);
        // Stores far apart from their misses: at least one line.
        let sparse = Counters {
            scalar_stores: 100_000,
            ..Default::default()
        };
        assert_eq!(parallelism(sparse, 10), 1.0);
        // Nothing missed: nothing to bound.
        assert_eq!(StoreBuffer::of(&fields, 0, 1000, &m), None);
    }

    #[test]
    fn compute_cost_hand_case() {
        let m = MachineConfig::larrabee_24();
        let c = Counters {
            valu: 10,
            fma: 5,
            transcendental: 2,
            gather: 1,
            gather_lines: 3,
            scalar: 30,
            atomic: 2,
            atomic_conflicts: 3,
            ..Default::default()
        };
        // vector: 15 + 2*4 + 3*1 = 26; scalar 30 → issue 30. atomics 2*8 + 3*4 = 28.
        assert_eq!(compute_cost(&c, &m), (30, 28));
    }

    #[test]
    fn the_critical_path_bounds_an_out_of_order_task() {
        let mut m = MachineConfig::larrabee_24();
        m.separate_ports = true;
        let mut c = Counters {
            valu: 8,
            fma: 4,
            ..Default::default()
        };
        // Throughput only: 12 issue cycles.
        assert_eq!(compute_cost(&c, &m).0, 12);
        // A 36-cycle chain at scale 1, then at 0.5.
        c.critical_path = 36;
        assert_eq!(compute_cost(&c, &m).0, 36);
        m.latency_scale = 0.5;
        assert_eq!(compute_cost(&c, &m).0, 18);
        m.latency_scale = 0.25;
        assert_eq!(compute_cost(&c, &m).0, 12);
    }

    #[test]
    fn in_order_threads_hide_the_chain_beyond_the_issue() {
        let mut m = MachineConfig::larrabee_24();
        let counters = Counters {
            valu: 10,
            critical_path: 100,
            ..Default::default()
        };
        let task = TaskRecord {
            counters,
            ..Default::default()
        };
        let mut mem = MemoryCounts::default();
        // Four threads: 90 cycles of waiting, 30 hidden by the others' issue, (90 − 30) / 4 = 15.
        m.threads_per_core = 4;
        assert_eq!(Machine::new(&m).run_task(0, &task, &mut mem).issue, 25);
        // One thread: the whole chain.
        m.threads_per_core = 1;
        assert_eq!(Machine::new(&m).run_task(0, &task, &mut mem).issue, 100);
    }
}
