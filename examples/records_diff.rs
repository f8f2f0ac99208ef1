//! Where two records files of the same frame first differ, step by step (counters, line count, line
//! stream, as `id:stream_state`): `cargo run --release --example records_diff -- A.bin B.bin`.
use sism::machine::records::load_records;
use sism::machine::timing::canonical_parts;

fn main() {
    let mut args = std::env::args().skip(1);
    let (a, b) = match (args.next(), args.next()) {
        (Some(a), Some(b)) => (a, b),
        _ => {
            eprintln!("usage: records_diff A.bin B.bin");
            std::process::exit(2);
        }
    };
    let load = |p: &str| load_records(std::path::Path::new(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let (ra, rb) = (load(&a), load(&b));
    if ra.0.len() != rb.0.len() {
        println!("steps: {} against {}", ra.0.len(), rb.0.len());
    }
    for (i, (sa, sb)) in ra.0.iter().zip(&rb.0).enumerate() {
        if sa.tasks.len() != sb.tasks.len() {
            println!(
                "step {i} {}: {} tasks against {}",
                sa.phase,
                sa.tasks.len(),
                sb.tasks.len()
            );
            continue;
        }
        let differ: Vec<usize> = (0..sa.tasks.len())
            .filter(|&t| sa.tasks[t] != sb.tasks[t])
            .collect();
        if let Some(&t) = differ.first() {
            let (x, y) = (&sa.tasks[t], &sb.tasks[t]);
            let fields: Vec<String> = sism_simd::Counters::FIELDS
                .iter()
                .zip(x.counters.values().into_iter().zip(y.counters.values()))
                .filter(|(_, (p, q))| p != q)
                .map(|(f, (p, q))| format!("{f} {p}/{q}"))
                .collect();
            println!(
                "step {i} {}: {} of {} tasks differ, first {t} (kind {}): lines {}/{} {}",
                sa.phase,
                differ.len(),
                sa.tasks.len(),
                x.kind,
                x.lines.len(),
                y.lines.len(),
                fields.join(", ")
            );
            // The first access that differs (a records file's line is an id and a stream state).
            let (la, lb): (Vec<_>, Vec<_>) = (x.lines.iter().collect(), y.lines.iter().collect());
            if let Some(k) = (0..la.len().min(lb.len())).find(|&k| la[k] != lb[k]) {
                let show = |l: &[(u64, bool)]| {
                    l[k.saturating_sub(2)..(k + 3).min(l.len())]
                        .iter()
                        .map(|&(v, w)| {
                            let (id, stream) = canonical_parts(v);
                            format!("{id}:{stream}{}", if w { "w" } else { "" })
                        })
                        .collect::<Vec<_>>()
                        .join(" ")
                };
                println!("  access {k}: {} / {}", show(&la), show(&lb));
            }
        }
    }
}
