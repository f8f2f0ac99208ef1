//! Per step of a saved records file: line accesses, how many continue a stream the prefetcher
//! model follows, how many are a line's first access in the frame, and the stream-less accesses'
//! distance (in lines) from the access before them:
//! `cargo run --release --example stream_report -- out/records.bin`.
use sism::machine::records::load_records;
use sism::machine::timing::{canonical_parts, LineMapper};
use std::collections::HashSet;

fn main() {
    let path = std::env::args().nth(1).expect("usage: stream_report RECORDS");
    let recs = load_records(std::path::Path::new(&path)).expect("records");
    let mut mapper = LineMapper::default();
    let mut seen: HashSet<u32> = HashSet::new();
    println!(
        "{:28} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9}",
        "step", "accesses", "streamed", "first", "random", "|d|<=16", "|d|<=64", "writes"
    );
    for p in &recs.0 {
        let (mut acc, mut streamed, mut first, mut random, mut near16, mut near64, mut writes) =
            (0u64, 0u64, 0u64, 0u64, 0u64, 0u64, 0u64);
        for t in &p.tasks {
            // A records file's line is an id and a stream state: the ids.
            let lines: Vec<u64> = t.lines.iter().map(|(l, _)| canonical_parts(l).0).collect();
            let mut k = 0;
            mapper.map_each(t, p.first_touch, |a| {
                // `id << 3 | established << 2 | young << 1 | write`.
                let (id, write, stream) = (a >> 3, a & 1 == 1, a >> 1 & 3 != 0);
                acc += 1;
                streamed += stream as u64;
                writes += write as u64;
                if seen.insert(id) {
                    first += 1;
                }
                if !stream {
                    random += 1;
                    if k > 0 {
                        let d = lines[k].abs_diff(lines[k - 1]);
                        near16 += (d <= 16) as u64;
                        near64 += (d <= 64) as u64;
                    }
                }
                k += 1;
            });
        }
        println!(
            "{:28} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9}",
            p.phase, acc, streamed, first, random, near16, near64, writes
        );
    }
}
