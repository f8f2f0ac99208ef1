//! Per step of a saved records file, the summed counters of its tasks, one line per step:
//! `cargo run --release --example step_counters -- out/records.bin`.
use sism::machine::records::load_records;
use sism_simd::Counters;

fn main() {
    let path = std::env::args().nth(1).expect("usage: step_counters RECORDS");
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
}
