//! The fuzz suite: structured mutations of scene TOML, OBJ, machine TOML, records files, frame traces,
//! study directories (manifest, task results, job list, logs) and algorithm parameters at and beyond
//! their registered ranges, each case run through the library entry points the CLI uses
//! (`Scene::load`, `render::render`, `MachineConfig::from_toml`, `machine::parse_records`,
//! `machine::simulate`, `trace::parse_over`/`check`/`write`, `study::slurm::run_task`/`collect`,
//! `Algorithm::params`), asserting:
//!
//! * no panic (each case runs under `catch_unwind`; a failing input is written to
//!   `target/fuzz-failures/` and the seed is printed);
//! * an error, or a render whose every pixel is NaN exactly where the eye ray misses and otherwise in
//!   [0, 1] or -1 (facing away), with finite statistics;
//! * for counted renders and replays, cycle stacks that sum to each phase's and the frame's total;
//! * a trace that parses and checks writes text that parses back as the same trace;
//! * a study that collects holds exactly the manifest's points, each with its configuration;
//! * parameters that resolve are every one inside its registered range.
//!
//! `SISM_FUZZ_CASES` sets the number of cases (default 20,000; CI runs the default), `SISM_FUZZ_SEED`
//! the seed (default fixed, so CI is repeatable; any seed reproduces its run exactly). The seed
//! corpus is `tests/fuzz/corpus/` (scenes, meshes, machines); records are made at start from a
//! counted render of the corpus plate, since their bytes depend on the version.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::Instant;

use sism::algorithms::{self, Algorithm};
use sism::exec::Exec;
use sism::machine::{self, MachineConfig, MachineReport};
use sism::render::{render, RenderOptions, RenderResult};
use sism::scene::Scene;
use sism::study::{scheduler, slurm};
use sism::trace;

/// As in the `sism` binary: counted frames are repeatable.
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

/// SplitMix64: small, fast, and the same on every host.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn chance(&mut self, one_in: u64) -> bool {
        self.next().is_multiple_of(one_in)
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

const FLOATS: &[f64] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-3,
    1e-30,
    1e-45,
    1e15,
    -1e15,
    1.0000001e15,
    2e15,
    1e16,
    1e18,
    1e21,
    3e38,
    -3e38,
    1e300,
    -1e300,
    179.999,
    180.0,
    1e-300,
    4294967296.0,
];
const SPECIAL_FLOATS: &[&str] = &["inf", "-inf", "nan", "+inf"];
const INTS: &[i64] = &[
    0,
    1,
    -1,
    2,
    3,
    7,
    16,
    1024,
    1025,
    32768,
    32769,
    65536,
    100000,
    4194304,
    4294967295,
    4294967296,
    -4294967296,
    i64::MAX,
    i64::MIN,
];
const STRINGS: &[&str] = &[
    "",
    "mesh.obj",
    "tetra.obj",
    "missing.obj",
    "/dev/null",
    "/dev/zero",
    ".",
    "..",
    "larrabee-24",
    "larrabee-5",
    "\u{0}",
];

/// A random TOML value of any kind.
fn random_value(rng: &mut Rng) -> toml::Value {
    match rng.below(9) {
        0 | 1 => toml::Value::Float(*rng.pick(FLOATS)),
        2 => toml::Value::Integer(*rng.pick(INTS)),
        3 => toml::Value::String(rng.pick(STRINGS).to_string()),
        4 => toml::Value::Boolean(rng.chance(2)),
        5 | 6 => {
            let n = *rng.pick(&[0usize, 1, 2, 3, 3, 3, 4, 7]);
            toml::Value::Array((0..n).map(|_| toml::Value::Float(*rng.pick(FLOATS))).collect())
        }
        7 => toml::Value::Table(toml::Table::new()),
        _ => toml::Value::Array(vec![toml::Value::String("x".into())]),
    }
}

/// Mutates one leaf of `v` (numbers nudged or replaced, arrays resized, keys dropped or added).
fn mutate_value(rng: &mut Rng, v: &mut toml::Value, depth: u32) {
    match v {
        toml::Value::Table(t) if !t.is_empty() && depth < 4 => {
            let keys: Vec<String> = t.keys().cloned().collect();
            let key = rng.pick(&keys).clone();
            match rng.below(10) {
                0 => {
                    t.remove(&key);
                }
                1 => {
                    t.insert(format!("unknown_{}", rng.below(3)), random_value(rng));
                }
                2 => {
                    t.insert(key, random_value(rng));
                }
                _ => mutate_value(rng, t.get_mut(&key).expect("key"), depth + 1),
            }
        }
        toml::Value::Array(a) if !a.is_empty() && depth < 4 => match rng.below(8) {
            0 => {
                a.pop();
            }
            1 => {
                let copy = a[rng.below(a.len())].clone();
                a.push(copy);
            }
            _ => {
                let k = rng.below(a.len());
                mutate_value(rng, &mut a[k], depth + 1);
            }
        },
        toml::Value::Float(f) => {
            *f = match rng.below(6) {
                // Gentle: a value still in range more often than not, so many cases render.
                4 | 5 => *f * (0.25 + rng.below(8) as f64 * 0.25) + (rng.below(3) as f64 - 1.0) * 0.1,
                0 => *rng.pick(FLOATS),
                1 => *f * 10f64.powi(rng.below(40) as i32),
                2 => -*f,
                _ => *f + rng.pick(FLOATS),
            }
        }
        toml::Value::Integer(i) => {
            *i = if rng.chance(2) {
                *rng.pick(INTS)
            } else {
                i.wrapping_mul(rng.below(1000) as i64)
            }
        }
        _ => *v = random_value(rng),
    }
}

/// Text-level damage: a truncation, a flipped byte, a special float spelled in, a duplicated line.
fn mutate_text(rng: &mut Rng, text: &str) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    match rng.below(5) {
        0 if !b.is_empty() => b.truncate(rng.below(b.len())),
        1 if !b.is_empty() => {
            let k = rng.below(b.len());
            b[k] = rng.next() as u8;
        }
        2 => {
            let special: &str = SPECIAL_FLOATS[rng.below(SPECIAL_FLOATS.len())];
            let s = String::from_utf8_lossy(&b).replacen("0.0", special, 1);
            b = s.into_bytes();
        }
        3 => {
            let lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let line = lines[rng.below(lines.len())];
                b.extend_from_slice(format!("\n{line}\n").as_bytes());
            }
        }
        _ => b.extend_from_slice(b"\n[camera]\nwidth = 1\n"),
    }
    b
}

/// Line-level mutations of OBJ text.
fn mutate_obj(rng: &mut Rng, text: &str) -> Vec<u8> {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for _ in 0..1 + rng.below(3) {
        if lines.is_empty() {
            lines.push("v 0 0 0".into());
        }
        let k = rng.below(lines.len());
        match rng.below(9) {
            0 => {
                lines.remove(k);
            }
            1 => {
                let l = lines[k].clone();
                lines.insert(k, l);
            }
            2 => {
                // A token replaced by a tricky number or word.
                let mut words: Vec<String> = lines[k].split_whitespace().map(String::from).collect();
                if words.len() > 1 {
                    let w = 1 + rng.below(words.len() - 1);
                    words[w] = match rng.below(4) {
                        0 => rng.pick(FLOATS).to_string(),
                        1 => rng.pick(INTS).to_string(),
                        2 => rng.pick(SPECIAL_FLOATS).to_string(),
                        _ => format!("{}/{}/{}", rng.pick(INTS), rng.pick(INTS), rng.pick(INTS)),
                    };
                    lines[k] = words.join(" ");
                }
            }
            3 => lines.insert(k, format!("f {} {}", rng.pick(INTS), rng.pick(INTS))),
            4 => lines.insert(k, format!("v {} {}", rng.pick(FLOATS), rng.pick(FLOATS))),
            5 => lines.insert(
                k,
                format!(
                    "v {} {} {} {}",
                    rng.pick(FLOATS),
                    rng.pick(FLOATS),
                    rng.pick(FLOATS),
                    rng.pick(FLOATS)
                ),
            ),
            6 => {
                let n = lines.len();
                lines.push(format!(
                    "f {} {} {}",
                    1 + rng.below(n),
                    1 + rng.below(n),
                    -(1 + rng.below(n) as i64)
                ));
            }
            7 => {
                let cut = rng.below(lines[k].len().max(1));
                let mut s = lines[k].clone();
                s.truncate(cut);
                lines[k] = s;
            }
            _ => lines.insert(k, format!("o obj{}", rng.below(9))),
        }
    }
    let mut b = lines.join("\n").into_bytes();
    if rng.chance(20) {
        let k = rng.below(b.len().max(1));
        b.insert(k.min(b.len()), 0xFF);
    }
    b
}

/// Files the cases read.
struct Corpus {
    scenes: Vec<(String, String)>,
    objs: Vec<String>,
    machines: Vec<String>,
    records: Vec<u8>,
    /// Algorithms the renders pick from.
    algorithms: Vec<&'static Algorithm>,
    /// The corpus plate at 16×12 (traces run over it).
    plate: Scene,
    /// A pristine study directory (two tasks, the first with its result), copied per case.
    study: tempfile::TempDir,
}

fn corpus() -> Corpus {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz/corpus");
    let mut scenes = Vec::new();
    let mut objs = Vec::new();
    let mut machines = Vec::new();
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/fuzz/corpus")
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    for p in names {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&p).unwrap();
        if name.ends_with(".machine.toml") {
            machines.push(text);
        } else if name.ends_with(".toml") {
            scenes.push((name, text));
        } else if name.ends_with(".obj") {
            objs.push(text);
        }
    }
    // Records of a small counted frame (the corpus plate at 16×12).
    let plate = Scene::from_toml(
        &scenes.iter().find(|s| s.0 == "plate.toml").unwrap().1,
        &dir.join("plate.toml"),
    )
    .unwrap();
    let algo = algorithms::find("sism").unwrap();
    let r = render(
        &plate,
        algo,
        &algo.params(&[]).unwrap(),
        &RenderOptions {
            exec: Exec::Counting,
            progress: false,
        },
    );
    let canonical = machine::canonical(&r.records);
    let records = machine::records::to_bytes(&canonical);
    assert!(!scenes.is_empty() && !objs.is_empty() && !machines.is_empty());
    // A study of three points in two tasks, both run: what `collect` merges when nothing is wrong.
    let study = tempfile::tempdir().unwrap();
    let base = MachineConfig::larrabee_24();
    let axes = machine::sweep::SweepAxes {
        cores: vec![1, 2, 4],
        threads: Vec::new(),
        l2_kb: Vec::new(),
        ..Default::default()
    };
    let configs = machine::sweep::configurations(&base, &axes).unwrap();
    let label = sism::study::Label {
        name: "plate".into(),
        width: plate.camera.width,
        height: plate.camera.height,
    };
    let job = slurm::JobOptions {
        chunk: 2,
        dry_run: true,
        executable: Some(std::env::current_exe().unwrap()),
        ..Default::default()
    };
    slurm::prepare(
        study.path(),
        &slurm::Study {
            scene: &dir.join("plate.toml"),
            label: &label,
            algorithm: "sism",
            params: "",
            machine: "larrabee-24",
            base: &base,
            configs: &configs,
            set_keys: &[],
            records: &canonical,
            sensitivity_factor: None,
        },
        &job,
        &mut |_, _| {},
    )
    .unwrap();
    for task in 0..2 {
        slurm::run_task(study.path(), task).unwrap();
    }
    Corpus {
        scenes,
        objs,
        machines,
        records,
        algorithms: algorithms::REGISTRY.to_vec(),
        plate,
        study,
    }
}

/// What a case did (for the summary).
#[derive(Default, Debug)]
struct Tally {
    cases: u64,
    errors: u64,
    renders: u64,
    counted: u64,
    replays: u64,
    skipped_large: u64,
    traces: u64,
    studies: u64,
    params: u64,
    images: u64,
}

/// Stacks sum to every phase's and the frame's cycles; times are finite.
fn check_report(r: &MachineReport) -> Result<(), String> {
    for p in r.phases.iter().chain(&r.groups).chain(std::iter::once(&r.frame)) {
        if p.stack.total() != p.cycles {
            return Err(format!(
                "{}: stack {} != cycles {}",
                p.phase,
                p.stack.total(),
                p.cycles
            ));
        }
        if !p.ms.is_finite() || p.ms < 0.0 {
            return Err(format!("{}: ms {}", p.phase, p.ms));
        }
    }
    let steps: u64 = r.phases.iter().map(|p| p.cycles).sum();
    if steps != r.frame.cycles {
        return Err(format!("steps sum to {steps}, frame {}", r.frame.cycles));
    }
    Ok(())
}

/// Every pixel NaN exactly at misses, else in [0, 1] or -1; every stat finite.
fn check_render(r: &RenderResult) -> Result<(), String> {
    let v = &r.visibility;
    if v.values.len() != v.width as usize * v.height as usize || r.receivers.pixels.len() != v.values.len() {
        return Err("image and receivers sizes differ".into());
    }
    for (k, (&x, p)) in v.values.iter().zip(&r.receivers.pixels).enumerate() {
        let ok = match p {
            None => x.is_nan(),
            Some(_) => x == -1.0 || (0.0..=1.0).contains(&x),
        };
        if !ok {
            return Err(format!("pixel {k}: V = {x}, receiver {}", p.is_some()));
        }
    }
    if let Some(s) = r.stats.stats.iter().find(|s| !s.value.is_finite()) {
        return Err(format!("stat {} = {}", s.name, s.value));
    }
    Ok(())
}

/// Loads `scene.toml` of `dir` and, when it is small enough to be quick, renders it with a random
/// algorithm (sometimes counted and replayed).
fn scene_case(rng: &mut Rng, dir: &Path, c: &Corpus, t: &mut Tally) -> Result<(), String> {
    let mut scene = match Scene::load(&dir.join("scene.toml")) {
        Ok(s) => s,
        Err(e) => {
            let msg = e.to_string();
            if msg.is_empty() {
                return Err("an empty error message".into());
            }
            t.errors += 1;
            return Ok(());
        }
    };
    if scene.triangle_count() > 20_000 {
        t.skipped_large += 1;
        return Ok(());
    }
    scene.camera.width = scene.camera.width.min(20);
    scene.camera.height = scene.camera.height.min(16);
    let algo = *rng.pick(&c.algorithms);
    let mut given = Vec::new();
    if algo.param("spp").is_some() {
        given.push(("spp".to_string(), (1 + rng.below(8)).to_string()));
    }
    if algo.param("map_size").is_some() {
        // Small maps keep a case quick (the size is not what is fuzzed).
        given.push((
            "map_size".to_string(),
            rng.pick(&["256", "256", "512"]).to_string(),
        ));
    }
    // Few light samples keep the many-sample methods' cases as quick as the others'.
    if algo.param("samples_per_side").is_some() {
        given.push(("samples_per_side".to_string(), (1 + rng.below(3)).to_string()));
    }
    if algo.param("max_level").is_some() {
        given.push(("max_level".to_string(), rng.below(3).to_string()));
    }
    let params = algo.params(&given).map_err(|e| e.to_string())?;
    let counted = algo.kernels && rng.chance(6);
    let options = RenderOptions {
        exec: if counted { Exec::Counting } else { Exec::Native },
        progress: false,
    };
    let r = render(&scene, algo, &params, &options);
    check_render(&r).map_err(|e| format!("{}: {e}", algo.name))?;
    t.renders += 1;
    if counted {
        t.counted += 1;
        let report = machine::simulate(&machine::canonical(&r.records), &MachineConfig::larrabee_24());
        check_report(&report)?;
        if r.stats
            .stats
            .iter()
            .any(|s| s.name.starts_with("machine.untimed."))
        {
            return Err("a phase is untimed".into());
        }
    }
    Ok(())
}

fn run_case(
    rng: &mut Rng,
    dir: &Path,
    c: &Corpus,
    t: &mut Tally,
    kind: &mut &'static str,
) -> Result<(), String> {
    match rng.below(28) {
        // Scene TOML, structured (and sometimes text) mutations, with the corpus meshes.
        0..=6 => {
            *kind = "scene";
            let (_, text) = rng.pick(&c.scenes);
            let mut value: toml::Value = toml::from_str(text).unwrap();
            for _ in 0..1 + rng.below(2) {
                mutate_value(rng, &mut value, 0);
            }
            let mut bytes = toml::to_string(&value).unwrap_or_default().into_bytes();
            if rng.chance(4) {
                bytes = mutate_text(rng, &String::from_utf8_lossy(&bytes));
            }
            std::fs::write(dir.join("scene.toml"), &bytes).unwrap();
            std::fs::write(dir.join("mesh.obj"), &c.objs[0]).unwrap();
            std::fs::write(dir.join("tetra.obj"), &c.objs[c.objs.len() - 1]).unwrap();
            scene_case(rng, dir, c, t)
        }
        // OBJ mutations under the corpus mesh scene.
        7..=11 => {
            *kind = "obj";
            let base = rng.pick(&c.objs).clone();
            let obj = mutate_obj(rng, &base);
            std::fs::write(dir.join("mesh.obj"), &obj).unwrap();
            let (_, text) = c.scenes.iter().find(|s| s.0 == "mesh.toml").unwrap();
            std::fs::write(dir.join("scene.toml"), text).unwrap();
            scene_case(rng, dir, c, t)
        }
        // Machine TOML: parse; if valid, replay the corpus records on it.
        12..=15 => {
            *kind = "machine";
            let mut value: toml::Value = toml::from_str(rng.pick(&c.machines).as_str()).unwrap();
            for _ in 0..1 + rng.below(3) {
                mutate_value(rng, &mut value, 0);
            }
            let mut text = toml::to_string(&value).unwrap_or_default();
            if rng.chance(5) {
                text = String::from_utf8_lossy(&mutate_text(rng, &text)).into_owned();
            }
            std::fs::write(dir.join("machine.toml"), &text).unwrap();
            match MachineConfig::from_toml(&text, "fuzz") {
                Err(e) if e.is_empty() => Err("an empty error message".into()),
                Err(_) => {
                    t.errors += 1;
                    Ok(())
                }
                Ok(config) => {
                    let records = machine::parse_records(&c.records)?;
                    t.replays += 1;
                    check_report(&machine::simulate(&records, &config))
                }
            }
        }
        20..=22 => {
            *kind = "trace";
            trace_case(rng, dir, c, t)
        }
        // One in 26: a collect that succeeds writes the study's CSV and two plots.
        23 => {
            *kind = "study";
            study_case(rng, dir, c, t)
        }
        24 => {
            *kind = "params";
            params_case(rng, dir, c, t)
        }
        26..=27 => {
            *kind = "image";
            image_case(rng, dir, t)
        }
        // Records: damaged bytes, resealed (size and checksum made right) so the deep checks run.
        _ => {
            *kind = "records";
            let mut b = c.records.clone();
            for _ in 0..1 + rng.below(4) {
                // Offsets within the current bytes (a truncation may have come first).
                let n = b.len();
                if n < 44 {
                    break;
                }
                let body = 28..n - 8;
                match rng.below(6) {
                    0 => {
                        let k = rng.below(n);
                        b[k] ^= 1 << rng.below(8);
                    }
                    1 => {
                        let k = body.start + rng.below(body.len());
                        b[k] = *rng.pick(&[0x00u8, 0x01, 0x7F, 0x80, 0xFF]);
                    }
                    2 => {
                        let k = body.start + rng.below(body.len() - 8);
                        let v = *rng.pick(&[0u64, 1, u32::MAX as u64, 1 << 62, u64::MAX]);
                        b[k..k + 8].copy_from_slice(&v.to_le_bytes());
                    }
                    3 => b.truncate(28 + rng.below(n - 28)),
                    _ => {}
                }
            }
            if !rng.chance(8) && b.len() >= 36 {
                let m = b.len();
                b[16..24].copy_from_slice(&(m as u64).to_le_bytes());
                let sum = machine::records::checksum(&b[..m - 8]);
                b[m - 8..].copy_from_slice(&sum.to_le_bytes());
            }
            std::fs::write(dir.join("records.bin"), &b).unwrap();
            match machine::parse_records(&b) {
                Err(e) if e.is_empty() => Err("an empty error message".into()),
                Err(_) => {
                    t.errors += 1;
                    Ok(())
                }
                Ok(records) => {
                    t.replays += 1;
                    check_report(&machine::simulate(&records, &MachineConfig::larrabee_24()))
                }
            }
        }
    }
}

/// A visibility image (OpenEXR or PFM) with contract values and awkward ones, damaged, then read:
/// an error must name the file; an image read must hold width × height values, and comparing it
/// with itself (or, with values out of the contract, refusing to) must not panic.
fn image_case(rng: &mut Rng, dir: &Path, t: &mut Tally) -> Result<(), String> {
    let (w, h) = (1 + rng.below(40) as u32, 1 + rng.below(30) as u32);
    let values = (0..w * h)
        .map(|_| match rng.below(8) {
            0 => f32::NAN,
            1 => -1.0,
            2 => *rng.pick(&[f32::INFINITY, -0.0, 2.0, f32::MIN_POSITIVE, 1e30]),
            _ => rng.below(1001) as f32 / 1000.0,
        })
        .collect();
    let image = sism::VisibilityImage {
        width: w,
        height: h,
        values,
    };
    let path = dir.join("image.bin");
    // The file a case reads is rewritten by the next case on purpose: this process's guard
    // against overwriting inputs would refuse it.
    sism::output::guard::forget_inputs();
    if rng.chance(2) {
        sism::output::exr::write_visibility_exr(&path, &image).map_err(|e| e.to_string())?;
    } else {
        sism::output::pfm::write_pfm(&path, &image).map_err(|e| e.to_string())?;
    }
    let mut b = std::fs::read(&path).unwrap();
    for _ in 0..rng.below(4) {
        let n = b.len();
        if n == 0 {
            break;
        }
        match rng.below(4) {
            0 => {
                let k = rng.below(n);
                b[k] ^= 1 << rng.below(8);
            }
            1 => {
                let k = rng.below(n);
                b[k] = *rng.pick(&[0x00u8, 0x01, 0x7F, 0x80, 0xFF]);
            }
            2 if n > 8 => {
                let k = rng.below(n - 4);
                let v = *rng.pick(&[0u32, 1, 0xFFFF, 1 << 30, u32::MAX]);
                b[k..k + 4].copy_from_slice(&v.to_le_bytes());
            }
            _ => b.truncate(rng.below(n)),
        }
    }
    std::fs::write(&path, &b).unwrap();
    match sism::output::read_visibility(&path) {
        Err(e) => {
            let message = e.to_string();
            if !message.contains("image.bin") {
                return Err(format!("an image error that does not name the file: {message}"));
            }
            t.errors += 1;
            Ok(())
        }
        Ok(v) => {
            if v.values.len() != v.width as usize * v.height as usize {
                return Err(format!(
                    "{}x{} image with {} values",
                    v.width,
                    v.height,
                    v.values.len()
                ));
            }
            t.images += 1;
            let _ = sism::metrics::compare(&v, &v);
            Ok(())
        }
    }
}

/// A statement a trace could hold, with numbers that are often awkward.
fn random_statement(rng: &mut Rng) -> String {
    let num = |rng: &mut Rng| -> String {
        match rng.below(8) {
            0 => "NaN".into(),
            1 => rng
                .pick(&["1e15", "-1e15", "1e16", "inf", "-0", "1e-45", "3.4e38"])
                .to_string(),
            2 => "x".into(),
            _ => format!("{}", (rng.next() % 2001) as f64 / 100.0 - 10.0),
        }
    };
    match rng.below(8) {
        0 => "frame".into(),
        1 => format!(
            "camera {} {} {}  {} {} {}",
            num(rng),
            num(rng),
            num(rng),
            num(rng),
            num(rng),
            num(rng)
        ),
        2 => format!(
            "fov {}",
            rng.pick(&["0", "45", "179.9", "180", "-1", "NaN", "1e-3"])
        ),
        3 => format!("light {} {} {}  {}", num(rng), num(rng), num(rng), num(rng)),
        4 => format!(
            "mesh {} {} {} {}",
            rng.pick(&["0", "1", "2", "7", "1048577", "-1", "18446744073709551616"]),
            num(rng),
            num(rng),
            num(rng)
        ),
        5 => format!("scene {}", rng.pick(&["plate.toml", "a b.toml", ""])),
        6 => rng.pick(&["# comment", "", "spin 3", "frame 2"]).to_string(),
        _ => "frame".into(),
    }
}

/// A trace over the corpus plate: parsed, checked, written and parsed back.
fn trace_case(rng: &mut Rng, dir: &Path, c: &Corpus, t: &mut Tally) -> Result<(), String> {
    let path = dir.join("case.trace");
    let base = trace::orbit(Path::new("plate.toml"), &c.plate, 2 + rng.below(4), 30.0);
    let mut lines: Vec<String> = trace::write(&base).unwrap().lines().map(str::to_string).collect();
    for _ in 0..1 + rng.below(4) {
        let k = rng.below(lines.len() + 1);
        match rng.below(3) {
            0 if k < lines.len() => {
                lines.remove(k);
            }
            1 if k < lines.len() => lines[k] = random_statement(rng),
            _ => lines.insert(k.max(1), random_statement(rng)),
        }
    }
    let mut text = lines.join("\n");
    if rng.chance(5) {
        text = String::from_utf8_lossy(&mutate_text(rng, &text)).into_owned();
    }
    std::fs::write(&path, &text).unwrap();
    let parsed = match trace::parse_over(&text, &path, &c.plate) {
        Err(e) if e.message.is_empty() => return Err("an empty trace error".into()),
        Err(_) => {
            t.errors += 1;
            return Ok(());
        }
        Ok(p) => p,
    };
    if let Err(e) = trace::check(&parsed, &c.plate) {
        if e.is_empty() {
            return Err("an empty check error".into());
        }
        t.errors += 1;
        return Ok(());
    }
    t.traces += 1;
    let written = trace::write(&parsed).map_err(|e| format!("a checked trace does not write: {e}"))?;
    let back = trace::parse_over(&written, &path, &c.plate)
        .map_err(|e| format!("a written trace does not parse back: {e}"))?;
    if back != parsed {
        return Err("a written trace parses back as another trace".into());
    }
    let first = &parsed.frames[0];
    trace::apply(&c.plate, first).map_err(|e| format!("a checked frame does not apply: {e}"))?;
    Ok(())
}

/// Copies the pristine study into `dir/study`, damages one of its files, then runs a task and
/// collects: an error, or a merge of exactly the manifest's points.
fn study_case(rng: &mut Rng, dir: &Path, c: &Corpus, t: &mut Tally) -> Result<(), String> {
    let study = dir.join("study");
    let _ = std::fs::remove_dir_all(&study);
    copy_tree(c.study.path(), &study);
    let target = match rng.below(5) {
        0 => "manifest.toml",
        1 | 2 => "results/task-0.json",
        3 => "jobs.txt",
        _ => "logs/task-1.out",
    };
    let path = study.join(target);
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    let damaged = if target.ends_with(".json") && rng.chance(2) {
        // A structured change: one value of one point replaced.
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let field = *rng.pick(&[
            "cores",
            "threads",
            "l2_kb",
            "index",
            "name",
            "steps",
            "clock_ghz",
            "frame",
        ]);
        let choices = [
            serde_json::json!(0),
            serde_json::json!(7),
            serde_json::json!(-1),
            serde_json::json!([]),
            serde_json::json!("x"),
            serde_json::json!(1e300),
            serde_json::Value::Null,
        ];
        let value = rng.pick(&choices);
        if let Some(p) = v["points"].get_mut(rng.below(2)) {
            p[field] = value.clone();
        }
        serde_json::to_vec(&v).unwrap()
    } else if target.starts_with("logs") || target == "jobs.txt" {
        let mut b = mutate_text(rng, &format!("{text}123 array=0-1 submitted=1\nline\n"));
        if rng.chance(3) {
            b.extend(std::iter::repeat_n(b'x', 200_000));
        }
        b
    } else {
        mutate_text(rng, &text)
    };
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, &damaged).unwrap();
    if target == "manifest.toml" {
        if let Err(e) = slurm::run_task(&study, rng.below(3)) {
            if e.to_string().is_empty() {
                return Err("an empty run_task error".into());
            }
        }
    }
    let options = slurm::CollectOptions::default();
    let sched = scheduler::Local::default();
    match slurm::collect(&sched, &study, &options, &|_| {}, &mut |_, _| {}) {
        Err(e) if e.to_string().is_empty() => Err("an empty collect error".into()),
        Err(_) => {
            t.errors += 1;
            Ok(())
        }
        Ok(slurm::Collected::Complete(points)) => {
            t.studies += 1;
            let m = slurm::load_manifest(&study).map_err(|e| format!("collected, then: {e}"))?;
            if points.len() != m.point.len() {
                return Err(format!(
                    "{} points merged for {} in the manifest",
                    points.len(),
                    m.point.len()
                ));
            }
            for (p, mp) in points.iter().zip(&m.point) {
                if (p.index, p.cores, p.threads, p.l2_kb) != (mp.index, mp.cores, mp.threads, mp.l2_kb)
                    || p.steps.is_empty()
                {
                    return Err(format!("merged point {} is not the manifest's", p.index));
                }
            }
            Ok(())
        }
        Ok(other) => Err(format!("collect without --resubmit returned {other:?}")),
    }
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let dest = to.join(e.file_name());
        if e.path().is_dir() {
            copy_tree(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

/// Parameters at and beyond their registered ranges: an error naming the key, or values all inside
/// the ranges; a small render of those no larger than their defaults.
fn params_case(rng: &mut Rng, dir: &Path, c: &Corpus, t: &mut Tally) -> Result<(), String> {
    use sism::algorithms::params::ParamKind;
    let algo = *rng.pick(&c.algorithms);
    if algo.params.is_empty() {
        return Ok(());
    }
    let mut given = Vec::new();
    let mut cheap = true;
    for _ in 0..1 + rng.below(2) {
        let spec = rng.pick(algo.params);
        let value: String = match spec.kind {
            ParamKind::Int { min, max } | ParamKind::OddInt { min, max } => {
                let v = *rng.pick(&[min, max, min - 1, max + 1, i64::MAX, i64::MIN, (min + max) / 2]);
                match rng.below(8) {
                    0 => rng
                        .pick(&["NaN", "", " 3 ", "1e3", "0x10", "-0", "+1"])
                        .to_string(),
                    _ => v.to_string(),
                }
            }
            ParamKind::Float { min, max } => {
                let v = *rng.pick(&[
                    min,
                    max,
                    min - 1e-9,
                    max * 1.000001 + 1e-9,
                    f64::MAX,
                    -f64::MAX,
                    0.5 * (min + max),
                ]);
                match rng.below(8) {
                    0 => rng
                        .pick(&["NaN", "inf", "-inf", "", "1e-400", "1e400", "-0"])
                        .to_string(),
                    _ => v.to_string(),
                }
            }
            ParamKind::U64 => rng
                .pick(&["0", "18446744073709551615", "18446744073709551616", "-1", "7"])
                .to_string(),
            ParamKind::Choice(names) => match rng.below(3) {
                0 => names[0].to_uppercase(),
                1 => "nonsense".into(),
                _ => rng.pick(names).to_string(),
            },
        };
        let default: Option<f64> = spec.default.parse().ok();
        let as_number: Option<f64> = value.trim().parse().ok();
        if let (Some(d), Some(v)) = (default, as_number) {
            cheap &= v <= d;
        }
        given.push((spec.key.to_string(), value));
    }
    let params = match algo.params(&given) {
        Err(e) if e.message.is_empty() || e.key.is_empty() => {
            return Err("an error without key or message".into())
        }
        Err(_) => {
            t.errors += 1;
            return Ok(());
        }
        Ok(p) => p,
    };
    t.params += 1;
    for (key, value) in params.iter() {
        let spec = algo
            .param(key)
            .ok_or_else(|| format!("resolved an undeclared key {key}"))?;
        spec.parse(&value.to_string())
            .map_err(|e| format!("{} {key} resolved to {value}, outside its range: {e}", algo.name))?;
    }
    if cheap && rng.chance(4) {
        let (_, text) = c.scenes.iter().find(|s| s.0 == "plate.toml").unwrap();
        let scene = Scene::from_toml(text, &dir.join("plate.toml")).map_err(|e| e.to_string())?;
        let r = render(
            &scene,
            algo,
            &params,
            &RenderOptions {
                exec: Exec::Native,
                progress: false,
            },
        );
        t.renders += 1;
        check_render(&r)?;
    }
    Ok(())
}

#[test]
fn fuzz_inputs_never_panic_and_renders_stay_well_formed() {
    let cases: u64 = std::env::var("SISM_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000);
    let seed: u64 = std::env::var("SISM_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5153_4D46_555A_5A31);
    let c = corpus();
    let dir = tempfile::tempdir().unwrap();
    let failures_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-failures");
    let mut t = Tally::default();
    let mut failures = Vec::new();
    let start = Instant::now();
    // Panics are caught and reported; keep their default message off stderr's flood.
    let hook = std::panic::take_hook();
    if std::env::var_os("SISM_FUZZ_VERBOSE").is_none() {
        std::panic::set_hook(Box::new(|_| {}));
    }
    for case in 0..cases {
        let case_seed = seed ^ case.wrapping_mul(0xA24B_AED4_963E_E407);
        let mut rng = Rng(case_seed);
        let mut kind = "";
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            run_case(&mut rng, dir.path(), &c, &mut t, &mut kind)
        }));
        t.cases += 1;
        let problem = match outcome {
            Ok(Ok(())) => None,
            Ok(Err(e)) => Some(e),
            Err(p) => Some(format!(
                "panic: {}",
                p.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            )),
        };
        if let Some(problem) = problem {
            let keep = failures_dir.join(format!("case-{case}"));
            let _ = std::fs::create_dir_all(&keep);
            for f in [
                "scene.toml",
                "mesh.obj",
                "machine.toml",
                "records.bin",
                "case.trace",
                "image.bin",
            ] {
                let _ = std::fs::copy(dir.path().join(f), keep.join(f));
            }
            failures.push(format!(
                "case {case} ({kind}, SISM_FUZZ_SEED={seed}): {problem} (inputs in {})",
                keep.display()
            ));
            if failures.len() >= 10 {
                break;
            }
        }
    }
    std::panic::set_hook(hook);
    eprintln!(
        "fuzz: {} cases in {:.1} s: {} clean errors, {} renders ({} counted), {} replays, {} large scenes loaded only, \
         {} traces round-tripped, {} studies collected, {} parameter sets resolved, {} damaged images read",
        t.cases,
        start.elapsed().as_secs_f64(),
        t.errors,
        t.renders,
        t.counted,
        t.replays,
        t.skipped_large,
        t.traces,
        t.studies,
        t.params,
        t.images
    );
    assert!(
        failures.is_empty(),
        "{} failing cases:\n{}",
        failures.len(),
        failures.join("\n")
    );
    // The mutations must reach both sides: inputs that load and render, and inputs that are refused.
    assert!(
        t.renders > cases / 20
            && t.errors > cases / 10
            && t.replays > cases / 50
            && t.traces > cases / 200
            && t.studies > cases / 1000
            && t.params > cases / 200,
        "{t:?}"
    );
}
