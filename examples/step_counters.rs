//! Per step of a saved records file, the summed counters of its tasks, one line per step:
//! `cargo run --release --example step_counters -- out/records.bin [MACHINE]`. With a machine file,
//! then one line per step and task kind: its tasks' issue cycles on that machine
//! (`timing::compute_cost`, no memory), to split a step's prediction between its kinds of task;
//! each step's port bounds; and per step and task kind the whole prediction (issue, memory,
//! atomics) of the frame replayed on one core, as a one-thread host frame runs it.
use sism::machine::records::load_records;
use sism_simd::Counters;

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: step_counters RECORDS [MACHINE]");
    let recs = load_records(std::path::Path::new(&path)).expect("records");
    println!("step,{}", Counters::FIELDS.join(","));
    for p in &recs.0 {
        let mut sum = vec![0u64; Counters::FIELDS.len()];
        for t in &p.tasks {
            for (s, v) in sum.iter_mut().zip(t.counters.values()) {
                *s += v;
            }
        }
        let v: Vec<String> = sum.iter().map(|x| x.to_string()).collect();
        println!("{},{}", p.phase, v.join(","));
    }
    let Some(machine) = std::env::args().nth(2) else {
        return;
    };
    let m = sism::machine::config::MachineConfig::load(std::path::Path::new(&machine), None)
        .expect("machine file");
    println!("step,kind,tasks,issue_cycles,ms_at_clock");
    for p in &recs.0 {
        let mut by_kind = std::collections::BTreeMap::<u32, (u64, u64)>::new();
        for t in &p.tasks {
            let (issue, atomics) = sism::machine::timing::compute_cost(&t.counters, &m);
            let e = by_kind.entry(t.kind).or_default();
            e.0 += 1;
            e.1 += issue + atomics;
        }
        for (kind, (n, cycles)) in by_kind {
            println!("{},{kind:#x},{n},{cycles},{:.3}", p.phase, m.ms(cycles));
        }
    }
    // Each bound of `compute_cost`'s out-of-order issue (`timing::port_bounds`) summed over the
    // step's tasks, in ms: which one sets the prediction, and how far the others are from it.
    println!("step,issue_ms,vector_ms,load_store_ms,scalar_ms,divider_ms,chain_ms,mispredict_ms");
    for p in &recs.0 {
        let mut sum = [0f64; 7];
        for t in &p.tasks {
            let b = sism::machine::timing::port_bounds(&t.counters, &m);
            let each = [
                b.issue(),
                b.vector,
                b.load_store,
                b.scalar,
                b.divider,
                b.chain,
                b.mispredict,
            ];
            for (acc, v) in sum.iter_mut().zip(each) {
                *acc += v;
            }
        }
        let ms: Vec<String> = sum.iter().map(|&c| format!("{:.3}", m.ms(c as u64))).collect();
        println!("{},{}", p.phase, ms.join(","));
    }
    replay_by_kind(&recs, &m);
}

/// Per step and task kind, the whole frame replayed on one core of `m` (as a one-thread frame
/// runs): each kind's tasks' core time (issue, stalls, atomics) from the schedule, in ms, to split
/// a step's whole prediction between its kinds of task (their issue alone is the table above's).
fn replay_by_kind(recs: &sism::machine::records::CanonicalRecords, m: &sism::machine::config::MachineConfig) {
    let mut one = m.clone();
    one.cores = 1;
    let report = sism::machine::simulate(recs, &one);
    println!("step,kind,tasks,total_ms");
    for (p, r) in recs.iter().zip(&report.phases) {
        let mut by_kind = std::collections::BTreeMap::<u32, (u64, u64)>::new();
        for (t, &(_, cycles)) in p.tasks.iter().zip(&r.schedule) {
            let e = by_kind.entry(t.kind).or_default();
            e.0 += 1;
            e.1 += cycles;
        }
        for (kind, (n, total)) in by_kind {
            println!("{},{kind:#x},{n},{:.3}", p.phase, one.ms(total));
        }
    }
}
