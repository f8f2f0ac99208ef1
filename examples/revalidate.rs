//! The model's predictions of a finished `sism validate` run, recomputed with this build's model
//! against that run's measured host figures: a model change is checked on every scene, algorithm
//! and thread count in seconds, instead of a half-hour validation whose host moment differs.
//!
//! `cargo run --release --example revalidate -- VALIDATE_DIR [RECORDS_CACHE] [KEY=VALUE ...]`
//!
//! `VALIDATE_DIR` holds `validate.csv` and, per scene, the machine file it was predicted with
//! (`calibration-K-SCENE.toml` from `--calibrate-per-scene`; else `machine.toml`). Each scene and
//! algorithm is counted once at 1600×1200 from `scenes/SCENE.toml` (`light-samples` with
//! `samples_per_side=4`, as the validation runs it), its records kept in `RECORDS_CACHE`
//! (default `out/revalidate-records`; delete a file after a kernel's counting changes). Prints each
//! scored figure (major phases and frames, the CSV's own major flags) old and new, then both
//! summaries. `KEY=VALUE` sets a machine parameter the validation's files do not state (one added
//! to the model since), in every scene's file.
//!
//! Only the model is new here: the host figures are the validation's, so this measures what a
//! change to the model (its rules, not its calibration) does. A fitted constant is still fitted on
//! microbenchmarks only (`sism calibrate`): this tool must not be used to tune one to frames.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sism::algorithms::PreparedScene;
use sism::exec::Exec;
use sism::machine::config::MachineConfig;
use sism::machine::records::{canonical, load_records, save_records};
use sism::render::{render_prepared, RenderOptions};

#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

struct CsvRow {
    scene: String,
    algorithm: String,
    threads: u32,
    phase: String,
    major: bool,
    measured: f64,
    predicted: Option<f64>,
}

fn read_csv(path: &Path) -> Vec<CsvRow> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f.len() == 8).then(|| CsvRow {
                scene: f[0].into(),
                algorithm: f[1].into(),
                threads: f[2].parse().expect("threads"),
                phase: f[3].into(),
                major: f[4] == "true",
                measured: f[5].parse().expect("measured ms"),
                predicted: f[6].parse().ok(),
            })
        })
        .collect()
}

fn machine_file(dir: &Path, scene: &str) -> PathBuf {
    let per_scene = std::fs::read_dir(dir).ok().and_then(|entries| {
        entries.filter_map(Result::ok).map(|e| e.path()).find(|p| {
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            name.starts_with("calibration-") && name.ends_with(&format!("-{scene}.toml"))
        })
    });
    per_scene.unwrap_or_else(|| dir.join("machine.toml"))
}

fn summary(errors: &[f64]) -> String {
    let n = errors.len().max(1) as f64;
    let mean = errors.iter().map(|e| e.abs()).sum::<f64>() / n;
    let within = errors.iter().filter(|e| e.abs() <= 0.25).count();
    let signed = errors.iter().sum::<f64>() / n;
    format!(
        "mean |error| {:.1}% over {}, within ±25% {} ({:.0}%), mean signed {:+.1}%",
        100.0 * mean,
        errors.len(),
        within,
        100.0 * within as f64 / n,
        100.0 * signed
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(
        args.get(1)
            .expect("usage: revalidate VALIDATE_DIR [RECORDS_CACHE]"),
    );
    let cache = PathBuf::from(args.get(2).map_or("out/revalidate-records", String::as_str));
    std::fs::create_dir_all(&cache).expect("records cache folder");
    let rows = read_csv(&dir.join("validate.csv"));
    let mut runs: BTreeMap<(String, String), Vec<u32>> = BTreeMap::new();
    for r in &rows {
        let t = runs.entry((r.scene.clone(), r.algorithm.clone())).or_default();
        if !t.contains(&r.threads) {
            t.push(r.threads);
        }
    }
    let (mut old, mut new) = (Vec::new(), Vec::new());
    let mut by_phase: BTreeMap<String, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for ((scene, algo), threads) in &runs {
        let file = cache.join(format!("{scene}-{algo}.records"));
        let records = load_records(&file).unwrap_or_else(|_| {
            eprintln!("counting {scene} {algo} ...");
            let mut s = sism::scene::Scene::load(Path::new(&format!("scenes/{scene}.toml"))).expect("scene");
            s.camera.width = 1600;
            s.camera.height = 1200;
            let a = sism::algorithms::find(algo).expect("algorithm");
            let given: Vec<(String, String)> = if algo == "light-samples" {
                vec![("samples_per_side".into(), "4".into())]
            } else {
                vec![]
            };
            let params = a.params(&given).expect("params");
            let prepared = PreparedScene::new(&s);
            let r = render_prepared(
                &prepared,
                a,
                &params,
                &RenderOptions {
                    exec: Exec::Counting,
                    progress: false,
                },
            );
            let c = canonical(&r.records);
            save_records(&file, &c).expect("save records");
            c
        });
        let base = {
            let path = machine_file(&dir, scene);
            let mut text = std::fs::read_to_string(&path).expect("machine file");
            for kv in args.iter().skip(3) {
                let (k, v) = kv.split_once('=').expect("KEY=VALUE");
                // The override replaces the file's own line for the key.
                let own = format!("{k} =");
                text = text
                    .lines()
                    .filter(|l| !l.starts_with(&own))
                    .collect::<Vec<_>>()
                    .join("\n");
                text.push_str(&format!("\n{k} = {v}\n"));
            }
            let with = cache.join("machine.toml");
            std::fs::write(&with, text).expect("write machine file");
            MachineConfig::load(&with, None).expect("machine file")
        };
        let configs: Vec<MachineConfig> = threads
            .iter()
            .map(|&t| sism::host::validate::model_for_threads(&base, t).expect("the model on t threads"))
            .collect();
        let reports = sism::machine::sweep::run(&records, &configs, || ());
        for (&t, point) in threads.iter().zip(&reports) {
            let report = &point.report;
            for r in rows
                .iter()
                .filter(|r| &r.scene == scene && &r.algorithm == algo && r.threads == t)
            {
                if !(r.major || r.phase == "frame") {
                    continue;
                }
                let Some(was) = r.predicted else { continue };
                let now = if r.phase == "frame" {
                    report.frame.ms
                } else {
                    match report.groups.iter().find(|g| g.phase == r.phase) {
                        Some(g) => g.ms,
                        None => continue,
                    }
                };
                let (e0, e1) = ((was - r.measured) / r.measured, (now - r.measured) / r.measured);
                old.push(e0);
                new.push(e1);
                let p = by_phase.entry(r.phase.clone()).or_default();
                p.0.push(e0);
                p.1.push(e1);
                println!(
                    "{scene:15} {algo:14} {t} {:14} host {:8.1}  old {:8.1} ({:+4.0}%)  new {:8.1} ({:+4.0}%)",
                    r.phase,
                    r.measured,
                    was,
                    100.0 * e0,
                    now,
                    100.0 * e1
                );
            }
        }
    }
    println!();
    for (phase, (o, n)) in &by_phase {
        println!("{phase:14} old: {}", summary(o));
        println!("{:14} new: {}", "", summary(n));
    }
    println!("old: {}", summary(&old));
    println!("new: {}", summary(&new));
}
