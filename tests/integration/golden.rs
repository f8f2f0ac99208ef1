//! Bit-exact regression guard: every registered algorithm's image and work counters on the repo's
//! scenes (and two shared meshes) against checksums stored in `tests/golden/`, so a refactor that
//! changes a single bit of a visibility value or a counter fails here.
//!
//! A golden file holds `visibility <hash> <pixels>` (FNV-1a 64 of the values' bits) and one line per
//! counter, `name value-as-f64-bits value`. Host times (`time.*`) and throughputs (`*_per_second`)
//! are not deterministic and are left out. Every stored line must appear unchanged; counters added
//! later are allowed (and printed), so the guard is on what existed. `SISM_BLESS=1 cargo test --test integration golden`
//! rewrites the files (`SISM_BLESS=new` writes only missing ones); never bless to make a refactor pass: a diff there is a behaviour change.

use std::path::{Path, PathBuf};

use sism::frame::VisibilityImage;
use sism::scene::Scene;
use sism::stats::StatsReport;

/// (case name, scene file relative to the repo, width, height, algorithms).
const CASES: &[(&str, &str, u32, u32)] = &[
    ("plate", "scenes/plate.toml", 96, 72),
    ("sphere", "scenes/sphere.toml", 96, 72),
    ("room", "scenes/room.toml", 64, 64),
    ("palm", "scenes/palm.toml", 96, 96),
    ("japanese-maple", "scenes/japanese-maple.toml", 96, 72),
];

/// Every registered algorithm but the test-only family: a new registry line gets a guard by
/// existing (its golden files are blessed once, then checked like the rest).
fn algorithms() -> impl Iterator<Item = &'static sism::algorithms::Algorithm> {
    sism::algorithms::REGISTRY
        .iter()
        .copied()
        .filter(|a| a.family != sism::algorithms::Family::Test)
}

/// Light-disk samples of the ray-traced algorithms in the golden renders (few: the check is bits).
const SPP: u32 = 16;

fn fnv1a(values: &[f32]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for v in values {
        for b in v.to_bits().to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// The golden text of one render.
fn golden_text(visibility: &VisibilityImage, stats: &StatsReport) -> String {
    let mut s = format!(
        "visibility {:016x} {}\n",
        fnv1a(&visibility.values),
        visibility.values.len()
    );
    for stat in &stats.stats {
        if stat.name.starts_with("time.") || stat.name.ends_with("_per_second") {
            continue;
        }
        s += &format!("{} {:016x} {}\n", stat.name, stat.value.to_bits(), stat.value);
    }
    s
}

fn render(scene: &Scene, algo: &sism::algorithms::Algorithm) -> (VisibilityImage, StatsReport) {
    let mut given = Vec::new();
    if algo.param("spp").is_some() {
        given.push(("spp".to_string(), SPP.to_string()));
    }
    let params = algo.params(&given).unwrap();
    let r = sism::render::render(scene, algo, &params, &Default::default());
    (r.visibility, r.stats)
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

#[test]
fn images_and_counters_match_the_stored_checksums() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bless_mode = std::env::var("SISM_BLESS").ok();
    let bless_new = bless_mode.as_deref() == Some("new");
    let bless = bless_mode.is_some() && !bless_new;
    let mut failures = Vec::new();
    let mut checked = 0;
    for &(case, file, width, height) in CASES {
        let path = root.join(file);
        let mut scene = match Scene::load(&path) {
            Ok(s) => s,
            // The shared meshes live beside the repository; outside CI a checkout may lack them.
            Err(e) if crate::util::shared_scenes().is_none() => {
                eprintln!("skipping {case}: {e}");
                continue;
            }
            Err(e) => panic!("{case}: {e}"),
        };
        scene.camera.width = width;
        scene.camera.height = height;
        for algo in algorithms() {
            let algorithm = algo.name;
            let (visibility, stats) = render(&scene, algo);
            let text = golden_text(&visibility, &stats);
            let golden = golden_dir().join(format!("{case}.{algorithm}.txt"));
            // SISM_BLESS=1 rewrites every file; SISM_BLESS=new writes only the missing ones (a new
            // algorithm's first guard), leaving the stored ones to be checked.
            if bless || (bless_new && !golden.exists()) {
                std::fs::create_dir_all(golden_dir()).unwrap();
                std::fs::write(&golden, &text).unwrap();
                continue;
            }
            let want = std::fs::read_to_string(&golden)
                .unwrap_or_else(|e| panic!("{}: {e} (bless with SISM_BLESS=1)", golden.display()));
            checked += 1;
            // Every stored line must be there, bit for bit; rows added since are allowed (listed).
            let got: std::collections::BTreeSet<&str> = text.lines().collect();
            let stored: std::collections::BTreeSet<&str> = want.lines().collect();
            let missing: Vec<&str> = stored.difference(&got).copied().collect();
            let added: Vec<&str> = got.difference(&stored).copied().collect();
            if !added.is_empty() {
                eprintln!("{case} {algorithm}: {} rows not in the golden file", added.len());
            }
            if !missing.is_empty() {
                let names: Vec<&str> = missing.iter().filter_map(|l| l.split(' ').next()).collect();
                let now: Vec<&str> = added
                    .iter()
                    .filter(|l| l.split(' ').next().is_some_and(|n| names.contains(&n)))
                    .copied()
                    .collect();
                failures.push(format!(
                    "{case} {algorithm}:\n    stored, now missing or different:\n      {}\n    now:\n      {}",
                    missing.join("\n      "),
                    now.join("\n      ")
                ));
            }
        }
    }
    assert!(failures.is_empty(), "golden mismatches:\n{}", failures.join("\n"));
    if !bless && !bless_new {
        // The repo's three scenes always render; the shared two only when ../shared is there.
        let guarded = algorithms().count();
        assert!(
            checked >= 3 * guarded,
            "only {checked} golden renders checked for {guarded} algorithms"
        );
    }
}
