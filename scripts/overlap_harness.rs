//! The measurement `port_overlap.rs` and `vector_overlap.rs` share (included by each with
//! `#[path]`; not a program of its own): three instruction classes, timed alone, in pairs and all
//! together, and how far each mix overlaps its parts.

use std::time::Instant;

/// Sixteen independent 16-lane `vaddps` (zmm0..zmm7, twice), the vector-ALU class both scripts
/// issue. The sources are zeroed first (zero idioms: no port), so no denormal ever slows an add.
/// Expands to an `asm!` block: use it inside `unsafe`.
macro_rules! vector_adds {
    () => {
        std::arch::asm!(
            "vxorps zmm8, zmm8, zmm8",
            "vxorps zmm9, zmm9, zmm9",
            "vaddps zmm0, zmm8, zmm9", "vaddps zmm1, zmm8, zmm9", "vaddps zmm2, zmm8, zmm9", "vaddps zmm3, zmm8, zmm9",
            "vaddps zmm4, zmm8, zmm9", "vaddps zmm5, zmm8, zmm9", "vaddps zmm6, zmm8, zmm9", "vaddps zmm7, zmm8, zmm9",
            "vaddps zmm0, zmm9, zmm8", "vaddps zmm1, zmm9, zmm8", "vaddps zmm2, zmm9, zmm8", "vaddps zmm3, zmm9, zmm8",
            "vaddps zmm4, zmm9, zmm8", "vaddps zmm5, zmm9, zmm8", "vaddps zmm6, zmm9, zmm8", "vaddps zmm7, zmm9, zmm8",
            out("zmm0") _, out("zmm1") _, out("zmm2") _, out("zmm3") _, out("zmm4") _, out("zmm5") _, out("zmm6") _, out("zmm7") _, out("zmm8") _, out("zmm9") _,
            options(nostack));
    };
}

/// Times the seven mixes of `classes` (each alone, each pair, all three; named `A`, `A+B`, ...):
/// `run(iters, on)` runs `iters` loop iterations issuing the classes `on` selects. Each mix is the
/// best of 5 runs, in cycles of an iteration at a nominal 2.1 GHz clock (a turbo clock makes them
/// smaller; ratios hold); 9 rounds, each printed, then the median round and, per mix, `alpha` =
/// `(mix - largest part) / (sum of parts - largest part)`: 0 when the classes overlap completely,
/// 1 when they add up.
pub fn measure(classes: [&str; 3], iters: u64, mut run: impl FnMut(u64, [bool; 3])) {
    let [a, b, c] = classes;
    let cases: [(String, [bool; 3]); 7] = [
        (a.to_string(), [true, false, false]),
        (b.to_string(), [false, true, false]),
        (c.to_string(), [false, false, true]),
        (format!("{a}+{b}"), [true, true, false]),
        (format!("{a}+{c}"), [true, false, true]),
        (format!("{b}+{c}"), [false, true, true]),
        (format!("{a}+{b}+{c}"), [true, true, true]),
    ];
    let mut rounds: Vec<Vec<f64>> = Vec::new();
    for _round in 0..9 {
        let mut line = String::new();
        let mut row = Vec::new();
        for (name, on) in &cases {
            let mut best = f64::MAX;
            for _ in 0..5 {
                let t = Instant::now();
                run(iters, *on);
                best = best.min(t.elapsed().as_secs_f64());
            }
            let cycles = best / iters as f64 * 2.1e9;
            row.push(cycles);
            line += &format!("{name}: {cycles:.2} cyc  ");
        }
        println!("{line}");
        rounds.push(row);
    }
    let median = |k: usize| {
        let mut v: Vec<f64> = rounds.iter().map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let m: Vec<f64> = (0..cases.len()).map(median).collect();
    let alpha = |mix: usize, parts: &[usize]| {
        let largest = parts.iter().map(|&p| m[p]).fold(0.0, f64::max);
        let sum: f64 = parts.iter().map(|&p| m[p]).sum();
        (m[mix] - largest) / (sum - largest)
    };
    let names: Vec<String> = cases
        .iter()
        .zip(&m)
        .map(|(c, v)| format!("{} {v:.2}", c.0))
        .collect();
    println!("median round: {}", names.join(", "));
    println!(
        "alpha: {} {:.2}, {} {:.2}, {} {:.2}, {} {:.2}",
        cases[3].0,
        alpha(3, &[0, 1]),
        cases[4].0,
        alpha(4, &[0, 2]),
        cases[5].0,
        alpha(5, &[1, 2]),
        cases[6].0,
        alpha(6, &[0, 1, 2])
    );
}
