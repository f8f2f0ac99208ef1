//! The machine model's own speed, as its users measure it: one SISM frame run natively, then under
//! the counting context (every counter and the line stream on), then replayed on larrabee-24; and a
//! 9-point core sweep (1..64 cores) re-timed per configuration, first decoding the line streams for
//! every configuration (as `study` did before), then decoding them once for all.
//!
//! Prints host seconds (medians of 3 runs each: the host may be shared), the slowdowns against the
//! native frame, and simulated instructions (vector and scalar) per host second.
//!
//! `cargo bench --bench machine` (plain `main`, no criterion: one counted frame takes seconds).
//! `SISM_BENCH_SCENE=palm` picks another scene of `scenes/` (default japanese-maple),
//! `SISM_BENCH_SIZE=1024x1024` another image size (default 800x600).

mod common;

use std::time::Instant;

use sism::algorithms::{self, PreparedScene};
use sism::exec::Exec;
use sism::machine::{decode, simulate, simulate_decoded, sweep, MachineConfig};
use sism::render::{render_prepared, RenderOptions};

/// As in the `sism` binary: mimalloc, with line-aligned blocks and no reuse within a counted frame,
/// and freed pages kept for the next frame (`MI_OPTION_PURGE_DELAY`).
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

/// The core counts of the sweep (threads per core and L2 as larrabee-24).
const SWEEP_CORES: [u32; 9] = [1, 2, 4, 8, 16, 24, 32, 48, 64];

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// mimalloc's `mi_option_purge_delay`, as `src/main.rs` sets it.
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Seconds of `f`, median of 3 runs, and the last run's result.
fn timed<T>(f: impl FnMut() -> T) -> (f64, T) {
    let (median, _, out) = timed_first(f);
    (median, out)
}

/// [`timed`], also giving the first run's seconds.
fn timed_first<T>(mut f: impl FnMut() -> T) -> (f64, f64, T) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..3 {
        let t = Instant::now();
        out = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    let first = times[0];
    (median(times), first, out.expect("3 runs"))
}

fn main() {
    // Freed pages are kept, never purged, as the `sism` binary keeps them: a counted frame's
    // memory (its records, its held temporaries) is then the previous frame's, as in `validate`
    // or `study`, which count many frames in one process; the first counted frame, on memory the
    // process never touched, is printed too.
    // SAFETY: sets an option of the global allocator before any thread is started.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
    // `cargo bench` passes `--bench`; nothing to parse.
    let name = std::env::var("SISM_BENCH_SCENE").unwrap_or_else(|_| "japanese-maple".into());
    let size = std::env::var("SISM_BENCH_SIZE").unwrap_or_else(|_| "800x600".into());
    let Some((width, height)) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| (1..=8192).contains(&w) && (1..=8192).contains(&h))
    else {
        eprintln!("SISM_BENCH_SIZE must read WIDTHxHEIGHT (1..8192 each), got `{size}`");
        std::process::exit(2);
    };
    let Some(scene) = common::scene(&name, width, height) else {
        return;
    };
    let prepared = PreparedScene::new(&scene);
    let algo = algorithms::find("sism").expect("registered");
    let params = algo.params(&[]).expect("defaults");
    let run = |exec| {
        render_prepared(
            &prepared,
            algo,
            &params,
            &RenderOptions {
                exec,
                progress: false,
            },
        )
    };
    // The host is shared and noisy: medians of 3 runs each (after a native warm-up).
    run(Exec::Native);
    let (native, _) = timed(|| run(Exec::Native));
    let mut fingerprints = Vec::new();
    let (counting, counting_first, frame) = timed_first(|| {
        let f = run(Exec::Counting);
        // Counters and line-stream lengths of every task: the same in every counted run.
        let fp: Vec<_> = f
            .records
            .iter()
            .flat_map(|p| p.tasks.iter().map(|t| (t.counters, t.lines.len())))
            .collect();
        fingerprints.push(fp);
        f
    });
    assert!(
        fingerprints.windows(2).all(|w| w[0] == w[1]),
        "counted runs differ"
    );
    let records = frame.records;
    let config = MachineConfig::larrabee_24();
    let (sim, report) = timed(|| simulate(&records, &config));
    let accesses = report.frame.memory.accesses;
    let c = &report.frame.counters;
    let (vector, scalar) = (
        c.vector_ops as f64,
        c.instructions().saturating_sub(c.vector_ops) as f64,
    );
    let mips = |s: f64| (vector + scalar) / s / 1e6;

    // The sweep, on one host thread so the two ways compare per configuration.
    let configs = sweep::configurations(
        &config,
        &sweep::SweepAxes {
            cores: SWEEP_CORES.to_vec(),
            ..Default::default()
        },
    )
    .expect("valid sweep");
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let (per_config, before) = one_thread.install(|| {
        timed(|| {
            configs
                .iter()
                .map(|m| simulate(&records, m).frame.cycles)
                .collect::<Vec<_>>()
        })
    });
    let (decode_once, after) = one_thread.install(|| {
        timed(|| {
            let d = decode(&records);
            configs
                .iter()
                .map(|m| simulate_decoded(&records, &d, m).frame.cycles)
                .collect::<Vec<_>>()
        })
    });
    assert_eq!(before, after, "decoding once changed a configuration's cycles");
    let (decode_only, _) = one_thread.install(|| timed(|| decode(&records)));
    let (parallel, points) = timed(|| sweep::run(&records, &configs, || ()));
    assert_eq!(
        points.iter().map(|p| p.report.frame.cycles).collect::<Vec<_>>(),
        before,
        "sweep::run differs from per-configuration replays"
    );

    let n = configs.len() as f64;
    println!(
        "{name} {width}x{height}, {} host threads, medians of 3",
        rayon::current_num_threads()
    );
    println!("native frame              {native:>9.3} s");
    println!(
        "counting frame            {counting:>9.3} s  ({:.1}x native, {:.0} simulated MIPS; the first, on fresh memory, {counting_first:.3} s)",
        counting / native,
        mips(counting)
    );
    println!(
        "replay (larrabee-24)      {sim:>9.3} s  ({:.1}x native, {:.0} simulated MIPS, {accesses} line accesses, {:.1} ns each)",
        sim / native,
        mips(sim),
        sim * 1e9 / accesses.max(1) as f64
    );
    println!(
        "counting + replay         {:>9.3} s  ({:.1}x native, {:.0} simulated MIPS)",
        counting + sim,
        (counting + sim) / native,
        mips(counting + sim)
    );
    println!(
        "simulated instructions    {:.3e} vector, {:.3e} scalar and mask; frame {:.3} ms on {} ({} cycles)",
        vector, scalar, report.frame.ms, config.name, report.frame.cycles
    );
    println!(
        "9-point core sweep, 1 host thread: decoding per configuration {per_config:.3} s ({:.3} s each); \
         decoding once {decode_once:.3} s ({:.3} s each, decode {decode_only:.3} s); {:.2}x",
        per_config / n,
        (decode_once - decode_only) / n,
        per_config / decode_once
    );
    println!(
        "9-point core sweep, sweep::run on {} host threads: {parallel:.3} s",
        rayon::current_num_threads()
    );
}
