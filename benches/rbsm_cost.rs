//! The revectorization paper's cost ratios (Macedo and Apolinário 2016, Tables 2 and 5): SMSR about
//! 1.3–1.4× the plain shadow map, RSMSS about 2×, and RPCF over RSMSS taps (3×3) about the cost of
//! PCF 17×17. Measured here on stanford-bunny, japanese-maple and palm at 1280×720 with 2048² maps.
//!
//! `cargo bench --bench rbsm_cost [-- ROUNDS]` (default 7 rounds). Each round renders every method
//! once, in turn, so the machine's noise falls on all of them alike; the table gives per method the
//! median over rounds of the lookup phase (the only phase that differs between them: eye pass, light
//! samples and map rendering are shared) and of the whole frame, each as a ratio to the plain shadow
//! map in the same scene, and the lookup phase simulated on larrabee-24 (one counted frame: exact).

mod common;

use sism::exec::Exec;
use sism::machine::MachineConfig;
use sism::render::{render, render_on_machine, RenderOptions};

/// A method: label, algorithm, parameters.
type Method = (
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
);

const METHODS: [Method; 7] = [
    ("shadow map", "shadow-map", &[]),
    ("SMSR", "smsr", &[]),
    ("RSMSS", "rsmss", &[]),
    ("RPCF+SMSR 3x3", "rpcf-smsr", &[]),
    ("RPCF+RSMSS 3x3", "rpcf-rsmss", &[]),
    ("PCF 3x3", "pcf", &[("n", "3")]),
    ("PCF 17x17", "pcf", &[("n", "17")]),
];

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(7)
        .max(1);
    let machine = MachineConfig::larrabee_24();
    println!(
        "backend {}, {} host threads, {rounds} rounds; map 2048, 1280x720",
        sism_simd::selected_backend().name(),
        rayon::current_num_threads()
    );
    for name in ["stanford-bunny", "japanese-maple", "palm"] {
        let Some(scene) = common::scene(name, 1280, 720) else {
            continue;
        };
        let setups: Vec<_> = METHODS
            .iter()
            .map(|(label, algo, given)| {
                let a = sism::algorithms::find(algo).unwrap();
                let given: Vec<(String, String)> = given
                    .iter()
                    .chain(&[("map_size", "2048")])
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .collect();
                (*label, a, a.params(&given).unwrap())
            })
            .collect();
        let options = RenderOptions {
            exec: Exec::Native,
            progress: false,
        };
        // One warm-up frame each (page faults, pool start-up), then the rounds.
        for (_, a, p) in &setups {
            render(&scene, a, p, &options);
        }
        let mut lookup = vec![Vec::new(); setups.len()];
        let mut frame = vec![Vec::new(); setups.len()];
        for _ in 0..rounds {
            for (k, (_, a, p)) in setups.iter().enumerate() {
                let r = render(&scene, a, p, &options);
                lookup[k].push(r.stats.get("time.lookup").expect("time.lookup"));
                frame[k].push(r.stats.get("time.frame").expect("time.frame"));
            }
        }
        let simulated: Vec<f64> = setups
            .iter()
            .map(|(_, a, p)| {
                let m = render_on_machine(&scene, a, p, &machine, false);
                m.report
                    .groups
                    .iter()
                    .find(|g| g.phase == "lookup")
                    .map_or(f64::NAN, |g| g.ms)
            })
            .collect();
        let (lookup, frame): (Vec<f64>, Vec<f64>) = (
            lookup.into_iter().map(median).collect(),
            frame.into_iter().map(median).collect(),
        );
        println!(
            "\n{name} ({} receivers)",
            scene.camera.width * scene.camera.height
        );
        println!(
            "{:<16} {:>10} {:>7} {:>10} {:>7} {:>12} {:>7}",
            "method", "lookup ms", "ratio", "frame ms", "ratio", "sim lookup", "ratio"
        );
        for (k, (label, _, _)) in setups.iter().enumerate() {
            println!(
                "{label:<16} {:>10.2} {:>7.2} {:>10.2} {:>7.2} {:>9.3} ms {:>7.2}",
                lookup[k],
                lookup[k] / lookup[0],
                frame[k],
                frame[k] / frame[0],
                simulated[k],
                simulated[k] / simulated[0]
            );
        }
    }
}
