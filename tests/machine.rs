//! The machine model: cache and scheduler on hand-computed cases, the cycle-stack and scaling
//! invariants, a real frame timed on larrabee-24, replay from a file, machine-file errors, and
//! native against counted visibility.

use std::path::Path;

use sism::exec::{Exec, PhaseRecords};
use sism::machine::cache::Cache;
use sism::machine::timing::{compute_cost, Machine, MemoryCounts};
use sism::machine::{load_records, save_records, simulate, MachineConfig};
use sism::render::{render, RenderOptions};
use sism::scene::Scene;
use sism_simd::{Counters, TaskRecord};

// Line-aligned blocks, no address reuse within a counted frame: counted records are repeatable.
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<std::alloc::System> = sism_simd::LineAlloc(std::alloc::System);

// ---------------------------------------------------------------------------------------------
// Building synthetic records: a TaskRecord byte image (record.rs's documented format) with a line
// stream encoded one access per token against stream head 0.

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Encodes `lines` as a LineStream the decoder reads back (mirrors its 4-head predictor: a delta
/// of at most 1024 lines updates the slot used, a larger one the least recently stamped slot).
fn encode_lines(lines: &[(u64, bool)]) -> Vec<u8> {
    let mut heads = [0u64; 4];
    let mut stamps = [0u64; 4];
    let mut t = 0;
    let mut out = Vec::new();
    for &(line, write) in lines {
        let delta = line.wrapping_sub(heads[0]) as i64;
        let zz = ((delta << 1) ^ (delta >> 63)) as u64;
        // Slot 0, no run: stored = ((zz << 3 | slot << 1 | write) << 1) | run.
        let tok = ((zz << 3) | write as u64) << 1;
        varint(&mut out, tok);
        let s = if delta.unsigned_abs() <= 1024 {
            0
        } else {
            (0..4).min_by_key(|&i| stamps[i]).unwrap()
        };
        t += 1;
        heads[s] = line;
        stamps[s] = t;
    }
    out
}

fn task(counters: Counters, lines: &[(u64, bool)]) -> TaskRecord {
    let stream = encode_lines(lines);
    let mut b = vec![0x5A, sism_simd::TASK_RECORD_VERSION];
    varint(&mut b, 0);
    varint(&mut b, Counters::FIELDS.len() as u64);
    for v in counters.values() {
        varint(&mut b, v);
    }
    varint(&mut b, lines.len() as u64);
    varint(&mut b, lines.last().map(|l| l.0).unwrap_or(0));
    varint(&mut b, stream.len() as u64);
    b.extend_from_slice(&stream);
    let (t, used) = TaskRecord::from_bytes(&b).unwrap();
    assert_eq!(used, b.len());
    let back: Vec<(u64, bool)> = t.lines.iter().collect();
    assert_eq!(back, lines, "test encoder mirrors the decoder");
    t
}

fn valu(n: u64) -> Counters {
    Counters {
        valu: n,
        vector_ops: n,
        active_lanes: 16 * n,
        ..Default::default()
    }
}

fn phase(name: &str, tasks: Vec<TaskRecord>) -> PhaseRecords {
    PhaseRecords {
        phase: name.into(),
        tasks,
        serial: false,
        first_touch: false,
    }
}

fn machine(cores: u32, threads: u32) -> MachineConfig {
    MachineConfig {
        cores,
        threads_per_core: threads,
        ..MachineConfig::larrabee_24()
    }
}

fn load(name: &str, width: u32, height: u32) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let mut s = Scene::load(&path).unwrap();
    s.camera.width = width;
    s.camera.height = height;
    s
}

fn counted(scene: &Scene, algorithm: &str, exec: Exec) -> sism::render::RenderResult {
    let algo = sism::algorithms::find(algorithm).unwrap();
    let params = algo.params(&[]).unwrap();
    render(
        scene,
        algo,
        &params,
        &RenderOptions {
            exec,
            progress: false,
        },
    )
}

fn counted_records(scene: &Scene) -> Vec<PhaseRecords> {
    counted(scene, "sism", Exec::Counting).records
}

// ---------------------------------------------------------------------------------------------
// Cache

#[test]
fn cache_lru_hand_case() {
    // 32 KB, 8 ways, 64 B lines: 64 sets. Lines 0, 64, 128, ... share set 0.
    let mut c = Cache::new(32 * 1024, 8, 64);
    assert_eq!(c.sets(), 64);
    for k in 0..8 {
        assert!(!c.access(k * 64, false).hit);
    }
    for k in 0..8 {
        assert!(c.access(k * 64, false).hit, "8 lines fit one 8-way set");
    }
    // A ninth line evicts the least recently used (line 0), then line 0 evicts line 64.
    assert!(!c.access(8 * 64, false).hit);
    assert!(!c.contains(0) && c.contains(64));
    assert!(!c.access(0, false).hit);
    assert!(!c.contains(64));
    // Other sets are untouched.
    assert!(!c.access(1, false).hit);
    assert!(c.access(1, false).hit);
}

#[test]
fn memory_latency_hand_case() {
    // One core, one thread: lines 0, 1, 0 → two DRAM misses, then an L1 hit.
    let m = machine(1, 1);
    let mut mach = Machine::new(&m);
    let mut mem = MemoryCounts::default();
    let t = task(valu(10), &[(1000, false), (1001, true), (1000, false)]);
    let cost = mach.run_task(0, &t, &mut mem);
    let miss = m.l2_latency as u64 + m.ring_hop_latency as u64 + 1 + 100;
    assert_eq!(m.dram_miss_cycles(), miss);
    assert_eq!(cost.issue, 10);
    assert_eq!(cost.stall, 2 * miss);
    assert_eq!(cost.exposed, 2 * miss);
    assert_eq!(
        (mem.accesses, mem.l1_misses, mem.l2_misses, mem.writebacks),
        (3, 2, 2, 0)
    );
    // The same lines again on the same core: L1 hits, no stall (l1_latency 0).
    let cost = mach.run_task(0, &t, &mut mem);
    assert_eq!(cost.stall, 0);
}

#[test]
fn dirty_lines_written_back_cost_writeback_cycles_each() {
    // One core writing 8192 distinct lines (512 KiB, beyond its 32 KiB L1 and 256 KiB L2): the
    // lines beyond what the caches hold are evicted dirty; each write-back costs `writeback_cycles`.
    let lines: Vec<(u64, bool)> = (0..8192u64).map(|k| (10_000 + k, true)).collect();
    let t = task(valu(10), &lines);
    let run = |writeback_cycles: f64| {
        let m = MachineConfig {
            writeback_cycles,
            ..machine(1, 1)
        };
        let mut mem = MemoryCounts::default();
        let cost = Machine::new(&m).run_task(0, &t, &mut mem);
        (cost, mem.writebacks)
    };
    let (free, writebacks) = run(0.0);
    let (dear, again) = run(3.0);
    assert_eq!(writebacks, again, "the cost does not change the caches");
    assert!(
        (2048..8192).contains(&writebacks),
        "{writebacks} write-backs of 8192 lines written"
    );
    assert_eq!(dear.stall, free.stall + 3 * writebacks);
    assert_eq!(dear.exposed, free.exposed + 3 * writebacks);
    assert_eq!(dear.issue, free.issue);
}

#[test]
fn threads_hide_latency() {
    let t = task(valu(20), &[(7, false)]);
    let one = simulate(&[phase("p", vec![t.clone()])], &machine(1, 1));
    let four = simulate(&[phase("p", vec![t])], &machine(1, 4));
    assert!(four.frame.cycles < one.frame.cycles);
    // 4 threads: exposed = (stall - 3 * 20) / 4 rounded up.
    let stall = machine(1, 4).dram_miss_cycles();
    assert_eq!(four.phases[0].core_busy[0], 20 + (stall - 60).div_ceil(4));
    assert_eq!(one.phases[0].core_busy[0], 20 + stall);
}

// ---------------------------------------------------------------------------------------------
// Scheduler and invariants

#[test]
fn greedy_scheduler_hand_case() {
    // Issue costs 10, 20, 5, 5 on 2 cores: 10 → core 0, 20 → core 1, 5 → core 0 (busy 10),
    // 5 → core 0 (busy 15 < 20).
    let tasks: Vec<TaskRecord> = [10, 20, 5, 5].iter().map(|&n| task(valu(n), &[])).collect();
    let m = machine(2, 4);
    let r = simulate(&[phase("p", tasks)], &m);
    let p = &r.phases[0];
    assert_eq!(p.schedule, vec![(0, 10), (1, 20), (0, 5), (0, 5)]);
    assert_eq!(p.core_busy, vec![20, 20]);
    assert_eq!(p.cycles, 20 + m.barrier_cycles as u64);
    assert_eq!(p.stack.issue, 20);
    assert_eq!(p.stack.atomics_sync, m.barrier_cycles as u64);
    assert_eq!(p.stack.imbalance_idle, 0);
    // Ties go to the lowest core.
    let r = simulate(
        &[phase("p", vec![task(valu(3), &[]), task(valu(3), &[])])],
        &machine(4, 4),
    );
    assert_eq!(r.phases[0].schedule, vec![(0, 3), (1, 3)]);
}

#[test]
fn serial_steps_run_on_one_core_where_the_machine_says_so() {
    // Four tasks of 10 cycles that the host ran one after another (a shared output buffer).
    let tasks: Vec<TaskRecord> = (0..4).map(|_| task(valu(10), &[])).collect();
    let step = PhaseRecords {
        serial: true,
        ..phase("p", tasks)
    };
    // Larrabee runs them in parallel (its cores share the write positions through atomics).
    let lrb = machine(2, 4);
    let p = &simulate(std::slice::from_ref(&step), &lrb).phases[0];
    assert_eq!(p.core_busy, vec![20, 20]);
    // A machine with `serial_steps` (the host presets) runs them on one core, in order.
    let host = MachineConfig {
        serial_steps: true,
        ..lrb.clone()
    };
    let p = &simulate(std::slice::from_ref(&step), &host).phases[0];
    assert_eq!(p.schedule, vec![(0, 10); 4]);
    assert_eq!(p.core_busy, vec![40, 0]);
    assert_eq!(p.cycles, 40 + host.barrier_cycles as u64);
    // The flag survives a records file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("records.bin");
    save_records(
        &path,
        &sism::machine::records::canonical(std::slice::from_ref(&step)),
    )
    .unwrap();
    let back = load_records(&path).unwrap();
    assert!(back[0].serial);
    assert_eq!(simulate(&back, &host).phases[0].core_busy, vec![40, 0]);
}

#[test]
fn a_busy_chip_shares_dram_bandwidth_among_streams() {
    // Two cores with a prefetcher: a streamed DRAM line costs 2 cycles alone, and on a busy chip
    // at least its share of 32 bytes a cycle: two cores × 64 bytes / 32 = 4 cycles.
    let m = MachineConfig {
        prefetcher: true,
        stream_dram_cycles: 2.0,
        clock_ghz: 1.0,
        dram_bandwidth_gbs: 32.0,
        ..machine(2, 1)
    };
    let n = 1000u64;
    let stream = |first: u64| {
        task(
            valu(10),
            &(first..first + n).map(|l| (l, false)).collect::<Vec<_>>(),
        )
    };
    let alone = simulate(&[phase("p", vec![stream(1 << 20)])], &m).phases[0].core_busy[0];
    let busy = simulate(&[phase("p", vec![stream(1 << 20), stream(1 << 22)])], &m).phases[0].clone();
    // Each core streams its own lines, each line 2 cycles dearer than alone; the lines of a young
    // stream (the first `STREAM_RAMP`) pay their latency share either way.
    assert_eq!(busy.core_busy[0], busy.core_busy[1]);
    let extra = busy.core_busy[0] - alone;
    let ramp = sism::machine::timing::STREAM_RAMP as u64;
    assert!(
        extra.is_multiple_of(2) && extra <= 2 * n && extra >= 2 * (n - ramp - 1),
        "{extra}"
    );
    // With bandwidth to spare, or the two tasks on one core, nothing changes.
    let wide = MachineConfig {
        dram_bandwidth_gbs: 1000.0,
        ..m.clone()
    };
    let two = [phase("p", vec![stream(1 << 20), stream(1 << 22)])];
    assert_eq!(simulate(&two, &wide).phases[0].core_busy[0], alone);
    let one_core = MachineConfig {
        cores: 1,
        ..m.clone()
    };
    let p = &simulate(&two, &one_core).phases[0];
    assert_eq!(p.schedule[0].1, alone);
}

#[test]
fn compute_cost_classes() {
    let m = MachineConfig::larrabee_24();
    let c = Counters {
        valu: 3,
        load: 2,
        scatter: 2,
        scatter_lines: 5,
        mask: 4,
        ..Default::default()
    };
    // vector: 5 + 5 scatter lines = 10; scalar: 4.
    assert_eq!(compute_cost(&c, &m), (10, 0));
}

/// A mixed synthetic frame: unequal tasks, shared and private lines, atomics.
fn synthetic_frame() -> Vec<PhaseRecords> {
    let mut phases = Vec::new();
    for (pi, name) in ["eye_pass", "umbra", "penumbra"].iter().enumerate() {
        let tasks = (0..37u64)
            .map(|i| {
                let mut c = valu(50 + (i * 37 + pi as u64 * 11) % 300);
                c.atomic = i % 3;
                c.atomic_conflicts = i % 5;
                c.scalar = i * 7;
                let lines: Vec<(u64, bool)> = (0..(i % 13) * 20)
                    .map(|k| (0x7fff_0000 + (k * 17 + i * 131) % 4000, k % 4 == 0))
                    .collect();
                task(c, &lines)
            })
            .collect();
        phases.push(phase(name, tasks));
    }
    phases
}

#[test]
fn stack_sums_and_core_time_is_sum_of_tasks() {
    let frame = synthetic_frame();
    for cores in [1, 3, 8, 24, 64] {
        for threads in [1, 4] {
            let r = simulate(&frame, &machine(cores, threads));
            let mut total = 0;
            for p in &r.phases {
                assert_eq!(p.stack.total(), p.cycles, "{} on {cores} cores", p.phase);
                let mut per_core = vec![0u64; cores as usize];
                for &(c, t) in &p.schedule {
                    per_core[c as usize] += t;
                }
                assert_eq!(per_core, p.core_busy);
                assert!(p.ms > 0.0);
                total += p.cycles;
            }
            assert_eq!(r.frame.cycles, total);
            assert_eq!(r.frame.stack.total(), r.frame.cycles);
        }
    }
}

#[test]
fn divisible_work_never_slower_with_more_cores() {
    // Compute-only: every core count 1..=64.
    let tasks: Vec<TaskRecord> = (0..192).map(|_| task(valu(1000), &[])).collect();
    let frame = [phase("p", tasks)];
    let mut last = u64::MAX;
    for cores in 1..=64 {
        let c = simulate(&frame, &machine(cores, 4)).frame.cycles;
        assert!(c <= last, "{cores} cores: {c} > {last}");
        last = c;
    }
    // With memory (each task its own lines; DRAM latency grows with ring hops): doubling cores.
    let tasks: Vec<TaskRecord> = (0..256u64)
        .map(|i| {
            let lines: Vec<(u64, bool)> = (0..64).map(|k| (i * 1000 + k, false)).collect();
            task(valu(300), &lines)
        })
        .collect();
    let frame = [phase("p", tasks)];
    let mut last = u64::MAX;
    for cores in [1, 2, 4, 8, 16, 32, 64] {
        for threads in [1, 4] {
            let c = simulate(&frame, &machine(cores, threads)).frame.cycles;
            if threads == 4 {
                assert!(c <= last, "{cores} cores: {c} > {last}");
                last = c;
            }
        }
    }
}

#[test]
fn deterministic_and_address_independent() {
    let frame = synthetic_frame();
    let m = MachineConfig::preset("larrabee-16").unwrap();
    assert_eq!(simulate(&frame, &m), simulate(&frame, &m));
    // The same accesses at other addresses (another run's allocation) time identically.
    let shifted: Vec<PhaseRecords> = frame
        .iter()
        .map(|p| {
            phase(
                &p.phase,
                p.tasks
                    .iter()
                    .map(|t| {
                        let lines: Vec<(u64, bool)> =
                            t.lines.iter().map(|(l, w)| (l + 0x1234_5677, w)).collect();
                        task(t.counters, &lines)
                    })
                    .collect(),
            )
        })
        .collect();
    assert_eq!(simulate(&frame, &m), simulate(&shifted, &m));
}

// ---------------------------------------------------------------------------------------------
// A real frame

#[test]
fn plate_on_larrabee_24_and_replay() {
    let scene = load("plate.toml", 160, 120);
    let records = counted_records(&scene);
    // Every phase of the frame is timed, step by step (the plate's receivers need a cube of faces).
    let names: Vec<&str> = records.iter().map(|p| p.phase.as_str()).collect();
    assert_eq!(
        names,
        [
            "eye_pass.front_end",
            "eye_pass.tile_lists",
            "eye_pass.tiles",
            "light_samples.classify",
            "light_samples.fit",
            "light_samples.cone",
            "light_samples.faces",
            "light_samples.face_sort",
            "light_samples.face_scatter",
            "light_samples.project",
            "grid.face_bounds",
            "grid.classify",
            "grid.scatter",
            "grid.cell_sort",
            "grid.gather",
            "grid.bins",
            "umbra.bin",
            "umbra.lists",
            "umbra.depth",
            "silhouettes",
            "penumbra.bin",
            "penumbra.lists",
            "penumbra.eq3",
            "resolve.eq4",
            "resolve.scatter",
        ]
    );
    let m = MachineConfig::preset("larrabee-24").unwrap();
    let r = simulate(&records, &m);
    for p in &r.phases {
        assert!(p.ms > 0.0 && p.tasks > 0, "{}", p.phase);
        assert_eq!(p.stack.total(), p.cycles);
        assert!(p.lane_utilisation() > 0.0 && p.lane_utilisation() <= 1.0);
    }
    let groups: Vec<&str> = r.groups.iter().map(|g| g.phase.as_str()).collect();
    assert_eq!(
        groups,
        [
            "eye_pass",
            "light_samples",
            "grid",
            "umbra",
            "silhouettes",
            "penumbra",
            "resolve"
        ]
    );
    let steps: u64 = r.phases.iter().map(|p| p.cycles).sum();
    assert_eq!(r.groups.iter().map(|g| g.cycles).sum::<u64>(), steps);
    assert_eq!(r.frame.cycles, steps);
    // Nothing the frame does is left untimed.
    let full = counted(&scene, "sism", Exec::Counting);
    assert!(
        !full
            .stats
            .stats
            .iter()
            .any(|s| s.name.starts_with("machine.untimed.")),
        "untimed phases"
    );
    // Counters land in the stats report.
    let mut stats = sism::stats::StatsReport::default();
    r.add_to(&mut stats);
    assert!(stats.get("machine.umbra.ms").unwrap() > 0.0);
    assert!(stats.get("machine.frame.ms").unwrap() > 0.0);
    let stack: f64 = ["issue", "memory", "atomics_sync", "imbalance_idle"]
        .iter()
        .map(|k| stats.get(&format!("machine.frame.stack.{k}")).unwrap())
        .sum();
    assert_eq!(stack, stats.get("machine.frame.cycles").unwrap());

    // Replay from a file equals the direct simulation, on this and another machine.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("records.bin");
    let canonical = sism::machine::canonical(&records);
    // First-touch ids time exactly as the addresses they replace.
    assert_eq!(simulate(&canonical, &m), r);
    // The replay's own mapped lines give the same first-touch form, and the same report.
    assert_eq!(
        sism::machine::simulate_canonical(&records, &m),
        (r.clone(), canonical.clone())
    );
    save_records(&path, &canonical).unwrap();
    let loaded = load_records(&path).unwrap();
    assert_eq!(loaded, canonical);
    assert_eq!(simulate(&loaded, &m), r);
    let m48 = MachineConfig::resolve("larrabee-48", None).unwrap();
    assert_eq!(simulate(&loaded, &m48), simulate(&records, &m48));
    // And on a machine whose prefetcher follows streams (on addresses: the file keeps each line's
    // stream state, else every first pass over fresh lines would replay as a stream).
    let host = MachineConfig::resolve("host", Some(sism::host::facts())).unwrap();
    assert!(host.prefetcher);
    let direct = simulate(&records, &host);
    assert_eq!(simulate(&loaded, &host), direct);
    assert!(direct.frame.memory.l2_misses > 0);
    // Saving the saved records again changes nothing, by either path.
    assert_eq!(sism::machine::canonical(&loaded), loaded);
    assert_eq!(
        sism::machine::simulate_canonical(&loaded, &host),
        (direct.clone(), loaded.clone())
    );
    // A second counted render (new allocations at new addresses) times identically.
    assert_eq!(simulate(&counted_records(&scene), &m), r);
    // A corrupt file is an error, not a panic.
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    assert!(load_records(&path).is_err());
}

#[test]
fn counted_frames_repeat_exactly_for_any_thread_count() {
    // New allocations at new addresses each time, tasks on other host threads: with LineAlloc and
    // counted_frame the records, hence every simulated figure, are the same. (Without LineAlloc the
    // line counts already differ between runs.) `sism-sampled` and `pcss` keep lanes in stack arrays
    // (their lines are renamed per counting run, else which host thread ran a task shows in them).
    let scene = load("plate.toml", 160, 120);
    let m = MachineConfig::preset("larrabee-24").unwrap();
    for algorithm in ["sism", "sism-sampled", "pcss"] {
        let mut runs = Vec::new();
        for threads in [2, 1, 3, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let records = pool.install(|| counted(&scene, algorithm, Exec::Counting).records);
            let report = simulate(&records, &m);
            runs.push((threads, records, report));
        }
        let (_, first_records, first) = &runs[0];
        assert!(first.frame.memory.accesses > 0 && first.frame.memory.l2_misses > 0);
        let counters = |p: &PhaseRecords| p.tasks.iter().map(|t| t.counters).collect::<Vec<_>>();
        let lines = |p: &PhaseRecords| p.tasks.iter().map(|t| t.lines.len()).collect::<Vec<_>>();
        let canonical = sism::machine::canonical(first_records);
        for (threads, records, report) in &runs[1..] {
            assert_eq!(records.len(), first_records.len());
            for (a, b) in records.iter().zip(first_records) {
                assert_eq!(
                    counters(a),
                    counters(b),
                    "{algorithm}: {} counters, {threads} threads",
                    a.phase
                );
                assert_eq!(
                    lines(a),
                    lines(b),
                    "{algorithm}: {} line counts, {threads} threads",
                    a.phase
                );
            }
            // The lines themselves, as a records file holds them.
            assert!(
                sism::machine::canonical(records) == canonical,
                "{algorithm}, {threads} threads: the records' lines"
            );
            assert_eq!(
                report.frame.cycles, first.frame.cycles,
                "{algorithm}, {threads} threads"
            );
            assert_eq!(
                report.frame.memory, first.frame.memory,
                "{algorithm}, {threads} threads"
            );
            assert_eq!(report, first, "{algorithm}, {threads} threads: the whole report");
        }
    }
}

#[test]
fn native_and_counting_visibility_identical() {
    let scene = load("plate.toml", 160, 120);
    for algorithm in ["sism", "sism-independent", "sism-sampled"] {
        let native = counted(&scene, algorithm, Exec::Native);
        let counted = counted(&scene, algorithm, Exec::Counting);
        assert!(native.records.is_empty() && !counted.records.is_empty());
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&native.visibility.values),
            bits(&counted.visibility.values),
            "{algorithm}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Machine files

#[test]
fn machine_toml_base_and_overrides() {
    let m = MachineConfig::from_toml("base = \"larrabee-48\"\nl2_kb = 512\nclock_ghz = 2\n", "mine").unwrap();
    assert_eq!(
        (m.cores, m.l2_kb, m.clock_ghz, m.name.as_str()),
        (48, 512, 2.0, "mine")
    );
    // Without base: larrabee-24.
    let m = MachineConfig::from_toml("threads_per_core = 2", "x").unwrap();
    assert_eq!((m.cores, m.threads_per_core), (24, 2));
    // The resolved file reads back to the same configuration.
    let back = MachineConfig::from_toml(&m.to_toml(), "y").unwrap();
    assert_eq!(back, m);
    for p in sism::machine::config::PRESETS {
        let c = MachineConfig::resolve(p, Some(sism::host::facts())).unwrap();
        c.validate().unwrap();
        assert_eq!(c.name, *p);
    }
}

#[test]
fn bad_machine_toml_names_the_key() {
    let cases = [
        ("corez = 4", "corez"),
        ("cores = \"many\"", "cores"),
        ("cores = 0", "cores"),
        ("cores = -3", "cores"),
        ("simd_width = 8", "simd_width"),
        ("l2_kb = 300", "l2_kb"),
        ("clock_ghz = 0.0", "clock_ghz"),
        ("base = \"larrabee-5\"", "base"),
        ("cores = ", ""),
    ];
    for (text, key) in cases {
        let e = MachineConfig::from_toml(text, "t").unwrap_err();
        assert!(e.contains(&format!("`{key}`")) || key.is_empty(), "{text}: {e}");
    }
    // Through a file: the message names the file too.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, "base = \"larrabee-24\"\nl1_wayz = 4\n").unwrap();
    let e = format!(
        "{:#}",
        MachineConfig::resolve(path.to_str().unwrap(), None).unwrap_err()
    );
    assert!(e.contains("bad.toml") && e.contains("`l1_wayz`"), "{e}");
    let e = format!(
        "{:#}",
        MachineConfig::resolve("no-such-machine", None).unwrap_err()
    );
    assert!(e.contains("larrabee-24"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// The host model, decoding once, calibration files

/// Lines decoded once give the same report as decoding per replay, on Larrabee and on the host
/// model (shared L3, separate ports, memory parallelism, task overhead), and `sweep::run` (which
/// decodes once) equals one `simulate` per configuration.
#[test]
fn decoded_once_replays_equal_streaming_replays() {
    let scene = load("plate.toml", 96, 72);
    let records = counted_records(&scene);
    let decoded = sism::machine::decode(&records);
    let host = sism::host::resolve_machine("host").unwrap();
    let mut small_l3 = host.clone();
    small_l3.l3_kb = 64;
    small_l3.l3_ways = 4;
    let configs = [machine(24, 4), machine(3, 1), host.clone(), small_l3];
    for m in &configs {
        let a = simulate(&records, m);
        let b = sism::machine::simulate_decoded(&records, &decoded, m);
        assert_eq!(a, b, "{}", m.name);
    }
    let points = sism::machine::sweep::run(&records, &configs, || {});
    for (p, m) in points.iter().zip(&configs) {
        assert_eq!(p.report, simulate(&records, m), "{}", m.name);
    }
    // The host model's shared cache is used: an L2 miss can hit it.
    let r = simulate(&records, &configs[3]);
    assert!(r.frame.memory.l2_misses > 0);
}

/// A machine file written by `to_toml` (every field) reads back equal, for the host preset too, and
/// the new fields keep Larrabee's meaning when a file leaves them out.
#[test]
fn host_preset_round_trips_through_toml() {
    let host = sism::host::resolve_machine("host").unwrap();
    let back = MachineConfig::from_toml(&host.to_toml(), "x").unwrap();
    assert_eq!(
        back,
        MachineConfig {
            name: "host".into(),
            ..back.clone()
        }
    );
    assert_eq!(
        MachineConfig {
            name: host.name.clone(),
            ..back
        },
        host
    );
    let old = MachineConfig::from_toml("cores = 8", "old").unwrap();
    assert_eq!(old.vector_cycles, 1.0);
    assert!(!old.separate_ports && old.l3_kb == 0 && old.memory_parallelism == 1.0);
    for (text, key) in [
        ("vector_cycles = 0.0", "vector_cycles"),
        ("memory_parallelism = 0.5", "memory_parallelism"),
        ("l3_kb = 100", "l3_kb"),
        ("separate_ports = 3", "separate_ports"),
    ] {
        let e = MachineConfig::from_toml(text, "t").unwrap_err();
        assert!(e.contains(&format!("`{key}`")), "{text}: {e}");
    }
}
