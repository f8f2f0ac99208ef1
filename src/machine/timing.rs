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
//!   distinct line it touched (at least 1). Scalar cycles: scalar and mask-register instructions.
//! * **Atomics**: each vector fetch-add costs `atomic_cycles`, plus `atomic_conflict_cycles` per
//!   conflicting lane. They are charged to the "atomics and sync" part of the stack.
//! * **Memory**: the task's recorded line stream is replayed through the core's L1 (private) and L2
//!   (its local subset), write-allocate and write-back. An L1 hit costs `l1_latency`, an L1 miss that
//!   hits L2 `l2_latency`, an L2 miss `MachineConfig::dram_miss_cycles` (L2 + ring hops to a memory
//!   controller + line transfer + DRAM latency). Remote L2 subsets and coherence are not modelled:
//!   a line another core holds is fetched from DRAM.
//! * **Hardware threads hide latency**: with `T` threads per core each running tasks like this one,
//!   a task of `B` busy cycles (issue + atomics) and `S` stall cycles takes `max(B, (B + S) / T)`
//!   of the core's time (the others issue while it waits), i.e. the exposed stall is
//!   `max(0, S − (T − 1)·B) / T`, rounded up. With `T = 1` every stall is exposed. (Its cache
//!   accesses are still replayed task after task: the threads' interleaving is not simulated.)
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

use super::cache::{Cache, LineIds};
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
        self.issue + self.memory + self.atomics_sync + self.imbalance_idle
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
        self.issue += o.issue;
        self.memory += o.memory;
        self.atomics_sync += o.atomics_sync;
        self.imbalance_idle += o.imbalance_idle;
    }
}

/// Memory-hierarchy counts of a phase or frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryCounts {
    /// Line accesses replayed (L1 lookups).
    pub accesses: u64,
    /// L1 misses (L2 lookups).
    pub l1_misses: u64,
    /// L2 misses (DRAM fills over the ring).
    pub l2_misses: u64,
    /// Dirty lines evicted from L2 (written back to DRAM).
    pub writebacks: u64,
}

impl MemoryCounts {
    fn add(&mut self, o: &MemoryCounts) {
        self.accesses += o.accesses;
        self.l1_misses += o.l1_misses;
        self.l2_misses += o.l2_misses;
        self.writebacks += o.writebacks;
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
        (self.l2_misses + self.writebacks) * line as u64
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
        self.issue + self.atomics + self.exposed
    }
}

/// Issue and atomic cycles of a task's counters (no memory).
pub fn compute_cost(c: &Counters, m: &MachineConfig) -> (u64, u64) {
    let plain = c.valu + c.fma + c.load + c.store + c.compress_expand;
    let gs_lines = (c.gather_lines + c.scatter_lines) * m.gather_cycles_per_line as u64;
    let vector = plain.div_ceil(m.vector_issue_per_clock as u64)
        + c.transcendental * m.transcendental_cycles as u64
        + gs_lines.max(c.gather + c.scatter);
    let scalar = (c.scalar + c.mask).div_ceil(m.scalar_issue_per_clock as u64);
    let atomics = c.atomic * m.atomic_cycles as u64 + c.atomic_conflicts * m.atomic_conflict_cycles as u64;
    (vector.max(scalar), atomics)
}

/// The exposed part of `stall` for a task of `busy` cycles on a core of `threads` threads.
pub fn exposed_stall(stall: u64, busy: u64, threads: u32) -> u64 {
    let t = threads.max(1) as u64;
    stall.saturating_sub((t - 1) * busy).div_ceil(t)
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

/// The chip during a frame's replay: per-core caches (warm across phases) and the line-id map.
pub struct Machine<'a> {
    config: &'a MachineConfig,
    cores: Vec<Core>,
    ids: LineIds,
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
        Machine {
            config,
            cores,
            ids: LineIds::new(),
            dram_miss: config.dram_miss_cycles(),
        }
    }

    /// Runs `task` on `core`: replays its lines through the core's caches.
    pub fn run_task(&mut self, core: usize, task: &TaskRecord, mem: &mut MemoryCounts) -> TaskCost {
        let mut accesses = Vec::new();
        map_lines(&mut self.ids, task, &mut accesses);
        self.run_mapped(core, &task.counters, &accesses, mem)
    }

    /// Runs a task of counters `counters` whose line stream is already mapped to ids ([`map_lines`])
    /// on `core`.
    fn run_mapped(
        &mut self,
        core: usize,
        counters: &Counters,
        accesses: &[u32],
        mem: &mut MemoryCounts,
    ) -> TaskCost {
        let m = self.config;
        let (issue, atomics) = compute_cost(counters, m);
        let c = &mut self.cores[core];
        let (l1_lat, l2_lat) = (m.l1_latency as u64, m.l2_latency as u64);
        // Hits counted in the loop, misses summed from the counts after it.
        let (mut l1_hits, mut l2_hits, mut l2_misses, mut writebacks) = (0u64, 0u64, 0u64, 0u64);
        for &a in accesses {
            let (id, write) = (a >> 1, a & 1 == 1);
            if c.l1.access(id, write).hit {
                l1_hits += 1;
                continue;
            }
            let r = c.l2.access(id, write);
            writebacks += r.writeback as u64;
            if r.hit {
                l2_hits += 1;
            } else {
                l2_misses += 1;
            }
        }
        let n = accesses.len() as u64;
        mem.accesses += n;
        mem.l1_misses += n - l1_hits;
        mem.l2_misses += l2_misses;
        mem.writebacks += writebacks;
        let stall = l1_hits * l1_lat + l2_hits * l2_lat + l2_misses * self.dram_miss;
        let exposed = exposed_stall(stall, issue + atomics, m.threads_per_core);
        TaskCost {
            issue,
            atomics,
            stall,
            exposed,
        }
    }

    /// Replays one phase: schedules its tasks, then the barrier.
    pub fn run_phase(&mut self, phase: &str, tasks: &[TaskRecord]) -> PhaseReport {
        let mut ids = std::mem::take(&mut self.ids);
        let r = self.run_phase_with(phase, tasks, |task, out| map_lines(&mut ids, task, out));
        self.ids = ids;
        r
    }

    /// [`Machine::run_phase`] with each task's accesses supplied by `mapped(task, out)`, which puts
    /// them into `out` as [`map_lines`] does (tasks are asked for in record order). The pipelined
    /// replay ([`simulate_frame`]) maps lines on another thread.
    fn run_phase_with(
        &mut self,
        phase: &str,
        tasks: &[TaskRecord],
        mut mapped: impl FnMut(&TaskRecord, &mut Vec<u32>),
    ) -> PhaseReport {
        let m = self.config;
        let n = m.cores as usize;
        let mut busy = vec![0u64; n];
        let (mut issue, mut exposed, mut atomics) = (0u64, 0u64, 0u64);
        let mut memory = MemoryCounts::default();
        let mut counters = Counters::default();
        let mut schedule = Vec::with_capacity(tasks.len());
        let mut accesses = Vec::new();
        for task in tasks {
            // Least busy core, ties to the lowest index.
            let core = (0..n).min_by_key(|&i| (busy[i], i)).expect("at least one core");
            mapped(task, &mut accesses);
            let cost = self.run_mapped(core, &task.counters, &accesses, &mut memory);
            busy[core] += cost.cycles();
            schedule.push((core as u32, cost.cycles()));
            issue += cost.issue;
            exposed += cost.exposed;
            atomics += cost.atomics;
            counters += task.counters;
        }
        let busiest = busy.iter().copied().max().unwrap_or(0);
        let dram_bound = (memory.dram_bytes(m.line_bytes) as f64 / m.dram_bytes_per_cycle()).ceil() as u64;
        let bw_excess = dram_bound.saturating_sub(busiest);
        let barrier = m.barrier_cycles as u64;
        let cycles = busiest + bw_excess + barrier;
        let cores = n as u64;
        let mut stack = CycleStack {
            issue: issue / cores,
            memory: exposed / cores + bw_excess,
            atomics_sync: atomics / cores + barrier,
            imbalance_idle: 0,
        };
        stack.imbalance_idle = cycles - stack.total();
        PhaseReport {
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
        }
    }
}

/// Tasks mapped ahead of the cache replay (bounds the memory held by the pipeline: a task's buffer
/// is 4 bytes per line access, a few MB for the largest tasks).
const PIPELINE_DEPTH: usize = 16;

/// Replays a whole frame (phases in order) on a cold chip, in two pipelined stages: one thread
/// decodes each task's line stream and maps it to first-touch ids (record order), the calling thread
/// schedules the tasks and replays the ids through the caches. Both stages run in record order, so
/// the result is the same as [`Machine::run_phase`] phase after phase, whatever the host's threads.
pub fn simulate_frame(config: &MachineConfig, phases: &[(&str, &[TaskRecord])]) -> Vec<PhaseReport> {
    let mut machine = Machine::new(config);
    let mut ids = std::mem::take(&mut machine.ids);
    std::thread::scope(|scope| {
        let (full_tx, full_rx) = crossbeam::channel::bounded::<Vec<u32>>(PIPELINE_DEPTH);
        let (empty_tx, empty_rx) = crossbeam::channel::unbounded::<Vec<u32>>();
        scope.spawn(move || {
            for task in phases.iter().flat_map(|p| p.1.iter()) {
                let mut buf = empty_rx.try_recv().unwrap_or_default();
                map_lines(&mut ids, task, &mut buf);
                if full_tx.send(buf).is_err() {
                    return;
                }
            }
        });
        phases
            .iter()
            .map(|&(name, tasks)| {
                machine.run_phase_with(name, tasks, |_, out| {
                    let buf = full_rx.recv().expect("the mapping thread maps every task");
                    // Hand the previous buffer back for reuse (the mapper may have finished).
                    let _ = empty_tx.send(std::mem::replace(out, buf));
                })
            })
            .collect()
    })
}

/// Decodes `task`'s line stream into `out` as `id << 1 | is_write`, ids from `ids` (first touch over
/// the frame, so tasks must be mapped in frame order).
pub fn map_lines(ids: &mut LineIds, task: &TaskRecord, out: &mut Vec<u32>) {
    out.clear();
    out.reserve(task.lines.len() as usize);
    task.lines
        .for_each(|line, write| out.push(ids.id(line) << 1 | write as u32));
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
    f.cycles += p.cycles;
    f.stack.add(&p.stack);
    f.counters += p.counters;
    f.memory.add(&p.memory);
    f.dram_bound += p.dram_bound;
    for (a, b) in f.core_busy.iter_mut().zip(&p.core_busy) {
        *a += b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
