//! Soft shadow mip-maps' cost against the kernel side n (Shen 2016, §4.2: "the number of texels
//! being accessed per frame grows quadratically" with n). Measured on stanford-bunny, japanese-maple
//! and palm at 800×600 with the default 1024² chain.
//!
//! `cargo bench --bench ssmm_cost [-- ROUNDS]` (default 5 rounds). Each round renders every n once,
//! in turn, so the machine's noise falls on all alike; per n the table gives the median over rounds
//! of the filter step (`time.lookup.lookup`: the chain and the scatter are left out), its ratio to
//! n = 2, the texels read per receiver, and `(n + 1)² / 9`, the growth of one layer's region; and the
//! simulated lookup phase on larrabee-24 (one counted frame).

mod common;

use sism::exec::Exec;
use sism::machine::MachineConfig;
use sism::render::{render, render_on_machine, RenderOptions};

const NS: [u32; 5] = [2, 3, 4, 6, 9];

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5)
        .max(1);
    let machine = MachineConfig::larrabee_24();
    println!(
        "backend {}, {} host threads, {rounds} rounds; chain 1024, 800x600",
        sism_simd::selected_backend().name(),
        rayon::current_num_threads()
    );
    let options = RenderOptions {
        exec: Exec::Native,
        progress: false,
    };
    for name in ["stanford-bunny", "japanese-maple", "palm"] {
        let Some(scene) = common::scene(name, 800, 600) else {
            continue;
        };
        for algo in ["ssmm", "ssmm-v2"] {
            let a = sism::algorithms::find(algo).unwrap();
            let setups: Vec<_> = NS
                .iter()
                .map(|n| (*n, a.params(&[("n".to_string(), n.to_string())]).unwrap()))
                .collect();
            for (_, p) in &setups {
                render(&scene, a, p, &options); // warm-up
            }
            let mut step = vec![Vec::new(); setups.len()];
            let mut texels = vec![0.0; setups.len()];
            for _ in 0..rounds {
                for (k, (_, p)) in setups.iter().enumerate() {
                    let r = render(&scene, a, p, &options);
                    step[k].push(r.stats.get("time.lookup.lookup").expect("time.lookup.lookup"));
                    texels[k] = r.stats.get("ssmm.texels_per_fragment").expect("texels");
                }
            }
            let simulated: Vec<f64> = setups
                .iter()
                .map(|(_, p)| {
                    let m = render_on_machine(&scene, a, p, &machine, false);
                    m.report
                        .groups
                        .iter()
                        .find(|g| g.phase == "lookup")
                        .map_or(f64::NAN, |g| g.ms)
                })
                .collect();
            let step: Vec<f64> = step.into_iter().map(median).collect();
            println!("\n{name} {algo}");
            println!(
                "{:>3} {:>10} {:>7} {:>12} {:>7} {:>10} {:>12} {:>7}",
                "n", "filter ms", "ratio", "texels/recv", "ratio", "(n+1)²/9", "sim lookup", "ratio"
            );
            for (k, (n, _)) in setups.iter().enumerate() {
                println!(
                    "{n:>3} {:>10.2} {:>7.2} {:>12.1} {:>7.2} {:>10.2} {:>9.3} ms {:>7.2}",
                    step[k],
                    step[k] / step[0],
                    texels[k],
                    texels[k] / texels[0],
                    ((n + 1) * (n + 1)) as f64 / 9.0,
                    simulated[k],
                    simulated[k] / simulated[0]
                );
            }
        }
    }
}
