//! Native wall time of a SISM frame and of each phase at 1600x1200, on palm (43K triangles) and
//! japanese-maple (198K), plus the embedded plate.
//!
//! `cargo bench --bench sism`. Criterion times whole frames (the scene's per-mesh data is prepared
//! once, outside the timing, as it would be across frames); the per-phase medians over the measured
//! frames are printed from the frame's own phase timers.

mod common;

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use sism::algorithms::sism::{render_scene, Composition, SismOptions};
use sism::exec::{Exec, PhaseTime};
use sism::scene::topology::SceneTopology;

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

fn bench_scene(c: &mut Criterion, name: &str, composition: Composition) {
    let Some(scene) = common::scene(name, 1600, 1200) else {
        return;
    };
    let topo = SceneTopology::build(&scene);
    let options = SismOptions {
        composition,
        ..Default::default()
    };
    let mut phases: Vec<Vec<PhaseTime>> = Vec::new();
    let mut group = c.benchmark_group("sism_frame_1600x1200");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function(format!("{name} {composition:?}"), |b| {
        b.iter(|| {
            let frame = render_scene(&scene, &topo, &options, Exec::Native);
            phases.push(frame.log.times().to_vec());
        })
    });
    group.finish();
    if phases.is_empty() {
        return; // filtered out on the command line (`cargo bench --bench sism -- Sampled`)
    }
    // Per-phase medians over the measured frames, from the frames' own phase timers.
    let mut line = format!("{name} {composition:?} per-phase medians (ms):");
    for (k, t) in phases[0].iter().enumerate() {
        line += &format!(
            " {} {:.1} |",
            t.name,
            median(phases.iter().map(|p| p[k].host).collect())
        );
    }
    let frame = median(phases.iter().map(|p| p.iter().map(|t| t.host).sum()).collect());
    eprintln!("{line} frame {frame:.1}");
}

fn frames(c: &mut Criterion) {
    bench_scene(c, "plate", Composition::Additive);
    bench_scene(c, "palm", Composition::Additive);
    bench_scene(c, "palm", Composition::Independent);
    bench_scene(c, "palm", Composition::Sampled);
    bench_scene(c, "japanese-maple", Composition::Additive);
    bench_scene(c, "japanese-maple", Composition::Independent);
    bench_scene(c, "japanese-maple", Composition::Sampled);
}

/// As the CLI: freed frame buffers stay mapped for the next frame (see src/main.rs).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

criterion_group!(benches, frames);
criterion_main!(benches);
