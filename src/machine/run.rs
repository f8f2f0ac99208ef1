//! The machine model's commands: a SISM render timed on a machine (`sism render --machine`), a
//! replay of saved records (`sism replay`) and a study over cores, threads and L2 sizes
//! (`sism study`). The CLI only parses; the work is here.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use super::{simulate, MachineConfig, MachineReport};
use crate::output::stats::StatsReport;
use crate::render::RenderResult;
use crate::scene::Scene;
use crate::sism::{self, Composition, Exec, PhaseRecords};

/// A SISM frame rendered under the counting context, its records and the machine's report.
pub struct MachineRender {
    pub result: RenderResult,
    pub records: Vec<PhaseRecords>,
    pub report: MachineReport,
    /// Host seconds of the counting render and of the simulation.
    pub render_seconds: f64,
    pub simulate_seconds: f64,
}

/// Renders `scene` with SISM (`composition`) under [`Exec::Counting`], then times the records on
/// `config`. The stats hold the usual SISM counters plus the machine's (`machine.*`).
pub fn render_on_machine(scene: &Scene, composition: Composition, config: &MachineConfig) -> MachineRender {
    let mut stats = StatsReport::default();
    let algorithm = match composition {
        Composition::Additive => "sism",
        Composition::Independent => "sism-independent",
        Composition::Sampled => "sism-sampled",
    };
    stats
        .fact("scene", scene.source.display())
        .fact("algorithm", algorithm)
        .fact("width", scene.camera.width)
        .fact("height", scene.camera.height)
        .fact("host_threads", rayon::current_num_threads())
        .fact("simd_backend", "counting");
    stats
        .stat(
            "scene.triangles",
            scene.triangle_count() as f64,
            "triangles",
            "triangles in the scene",
        )
        .stat(
            "scene.light_radius",
            scene.light.radius as f64,
            "world units",
            "light radius (0 = point light)",
        );
    let t0 = Instant::now();
    let prepared = sism::PreparedScene::new(scene);
    let options = sism::SismOptions {
        composition,
        exec: Exec::Counting,
        ..Default::default()
    };
    let frame = super::counted_frame(scene, &prepared, &options);
    let render_seconds = t0.elapsed().as_secs_f64();
    sism::report(&frame.stats, &mut stats);
    let t1 = Instant::now();
    let report = simulate(&frame.records, config);
    let simulate_seconds = t1.elapsed().as_secs_f64();
    stats
        .stat(
            "time.counting_render",
            render_seconds * 1e3,
            "ms",
            "SISM frame under the counting context, recording tasks (host wall time)",
        )
        .stat(
            "time.machine_simulation",
            simulate_seconds * 1e3,
            "ms",
            "replaying the records on the machine model (host wall time)",
        );
    report.add_to(&mut stats);
    MachineRender {
        result: RenderResult {
            receivers: frame.receivers,
            visibility: frame.visibility,
            stats,
        },
        records: frame.records,
        report,
        render_seconds,
        simulate_seconds,
    }
}

/// Re-times saved records on `config`; writes `stats.txt`, `stats.json` and `machine.toml` into
/// `out`.
pub fn replay(records_path: &Path, config: &MachineConfig, out: &Path) -> anyhow::Result<MachineReport> {
    let records = super::load_records(records_path)?;
    let report = simulate(&records, config);
    std::fs::create_dir_all(out)
        .map_err(|e| anyhow::anyhow!("cannot create output folder {}: {e}", out.display()))?;
    let mut stats = StatsReport::default();
    stats.fact("records", records_path.display());
    report.add_to(&mut stats);
    stats.write(out)?;
    super::write_config(out, config)?;
    Ok(report)
}

/// Settings of `sism study`.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    pub out: PathBuf,
    /// The machine every point starts from (cores, threads and L2 then vary).
    pub base: MachineConfig,
    pub cores: Vec<u32>,
    /// Threads per core to try (empty: the base's).
    pub threads: Vec<u32>,
    /// L2 subset sizes to try, KB (empty: the base's).
    pub l2_kb: Vec<u32>,
    pub composition: Composition,
    pub progress: bool,
}

/// One simulated configuration of a study.
#[derive(Clone, Debug)]
pub struct StudyPoint {
    pub cores: u32,
    pub threads: u32,
    pub l2_kb: u32,
    pub report: MachineReport,
}

/// Parses a comma-separated list of positive integers (`--cores 1,2,4`).
pub fn parse_list(flag: &str, s: &str) -> anyhow::Result<Vec<u32>> {
    s.split(',')
        .filter(|t| !t.trim().is_empty())
        .map(|t| {
            let v: u32 = t
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("{flag}: `{}` is not a positive integer", t.trim()))?;
            anyhow::ensure!(v > 0, "{flag}: values must be at least 1");
            Ok(v)
        })
        .collect()
}

/// Renders `scene` once under the counting context, then simulates every (threads, L2, cores)
/// combination in parallel on the host; writes `study.csv`, `speedup.png`, `phases.png`,
/// `records.bin` and `machine.toml` (the base) into `options.out`.
pub fn study(scene: &Scene, options: &StudyOptions) -> anyhow::Result<Vec<StudyPoint>> {
    anyhow::ensure!(!options.cores.is_empty(), "--cores: give at least one core count");
    std::fs::create_dir_all(&options.out)
        .map_err(|e| anyhow::anyhow!("cannot create output folder {}: {e}", options.out.display()))?;
    let prepared = sism::PreparedScene::new(scene);
    let sism_options = sism::SismOptions {
        composition: options.composition,
        exec: Exec::Counting,
        ..Default::default()
    };
    let frame = super::counted_frame(scene, &prepared, &sism_options);
    super::save_records(&options.out.join("records.bin"), &frame.records)?;
    super::write_config(&options.out, &options.base)?;

    let threads = if options.threads.is_empty() {
        vec![options.base.threads_per_core]
    } else {
        options.threads.clone()
    };
    let l2s = if options.l2_kb.is_empty() {
        vec![options.base.l2_kb]
    } else {
        options.l2_kb.clone()
    };
    let mut configs = Vec::new();
    for &t in &threads {
        for &l2 in &l2s {
            for &c in &options.cores {
                let mut m = options.base.clone();
                m.cores = c;
                m.threads_per_core = t;
                m.l2_kb = l2;
                m.name = format!("{}-c{c}-t{t}-l2{l2}", options.base.name);
                m.validate()
                    .map_err(|(k, msg)| anyhow::anyhow!("study point {}: `{k}` {msg}", m.name))?;
                configs.push(m);
            }
        }
    }
    let bar = crate::progress::bar(configs.len() as u64, "simulating", options.progress);
    let points: Vec<StudyPoint> = configs
        .par_iter()
        .map(|m| {
            let report = simulate(&frame.records, m);
            bar.inc(1);
            StudyPoint {
                cores: m.cores,
                threads: m.threads_per_core,
                l2_kb: m.l2_kb,
                report,
            }
        })
        .collect();
    bar.finish_and_clear();
    write_csv(&options.out.join("study.csv"), &points)?;
    plots::speedup(&options.out.join("speedup.png"), scene, &points)?;
    let table_point = points
        .iter()
        .find(|p| {
            p.cores == options.base.cores
                && p.threads == options.base.threads_per_core
                && p.l2_kb == options.base.l2_kb
        })
        .or_else(|| points.iter().find(|p| p.cores == options.base.cores))
        .unwrap_or_else(|| points.last().expect("at least one point"));
    plots::phases(&options.out.join("phases.png"), scene, table_point)?;
    Ok(points)
}

/// Frame speedup of `p` over the smallest core count with the same threads and L2 size.
pub fn speedup(points: &[StudyPoint], p: &StudyPoint) -> f64 {
    let base = points
        .iter()
        .filter(|q| q.threads == p.threads && q.l2_kb == p.l2_kb)
        .min_by_key(|q| q.cores)
        .expect("p itself");
    base.report.frame.cycles as f64 / p.report.frame.cycles.max(1) as f64
}

/// `study.csv`: one row per configuration and phase (plus `frame`).
pub fn write_csv(path: &Path, points: &[StudyPoint]) -> anyhow::Result<()> {
    let mut s = String::from(
        "cores,threads,l2_kb,phase,tasks,cycles,ms,stack_issue,stack_memory,stack_atomics_sync,\
         stack_imbalance_idle,lane_utilisation,l1_miss_rate,l2_miss_rate,bytes_dram,frame_speedup\n",
    );
    for p in points {
        let sp = speedup(points, p);
        for ph in p.report.phases.iter().chain(std::iter::once(&p.report.frame)) {
            s += &format!(
                "{},{},{},{},{},{},{:.6},{},{},{},{},{:.6},{:.6},{:.6},{},{:.6}\n",
                p.cores,
                p.threads,
                p.l2_kb,
                ph.phase,
                ph.tasks,
                ph.cycles,
                ph.ms,
                ph.stack.issue,
                ph.stack.memory,
                ph.stack.atomics_sync,
                ph.stack.imbalance_idle,
                ph.lane_utilisation(),
                ph.memory.l1_miss_rate(),
                ph.memory.l2_miss_rate(),
                ph.memory.dram_bytes(p.report.config.line_bytes),
                sp
            );
        }
    }
    std::fs::write(path, s).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))
}

mod plots {
    use std::path::Path;

    use plotters::prelude::*;

    use super::StudyPoint;
    use crate::scene::Scene;

    use crate::output::plot::{canvas, register_fonts, save, PALETTE, PLOT_SIZE as SIZE};

    fn scene_name(scene: &Scene) -> String {
        scene
            .source
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    /// `speedup.png`: frame speedup against cores (over the smallest core count), one series per
    /// (threads, L2) pair, and the linear speedup.
    pub fn speedup(path: &Path, scene: &Scene, points: &[StudyPoint]) -> anyhow::Result<()> {
        register_fonts();
        let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot draw {}: {e}", path.display());
        let c0 = points.iter().map(|p| p.cores).min().unwrap_or(1) as f64;
        let c1 = points.iter().map(|p| p.cores).max().unwrap_or(1) as f64;
        let ymax = points
            .iter()
            .map(|p| super::speedup(points, p))
            .fold(c1 / c0, f64::max)
            * 1.05;
        type Series = ((u32, u32), Vec<(f64, f64)>);
        let mut series: Vec<Series> = Vec::new();
        for p in points {
            let key = (p.threads, p.l2_kb);
            let pt = (p.cores as f64, super::speedup(points, p));
            match series.iter_mut().find(|(k, _)| *k == key) {
                Some((_, v)) => v.push(pt),
                None => series.push((key, vec![pt])),
            }
        }
        let mut rgb = canvas();
        {
            let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let title = format!(
                "{} {}x{}: simulated speedup vs cores",
                scene_name(scene),
                scene.camera.width,
                scene.camera.height
            );
            let mut chart = ChartBuilder::on(&root)
                .caption(title, ("sans-serif", 24))
                .margin(20)
                .x_label_area_size(56)
                .y_label_area_size(70)
                .build_cartesian_2d(0.0..c1 * 1.05, 0.0..ymax)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc("cores")
                .y_desc(format!("frame speedup over {} core(s)", c0))
                .light_line_style(RGBColor(238, 238, 238))
                .bold_line_style(RGBColor(200, 200, 200))
                .axis_desc_style(("sans-serif", 18))
                .label_style(("sans-serif", 15))
                .draw()
                .map_err(|e| err(&e))?;
            chart
                .draw_series(LineSeries::new(
                    vec![(c0, 1.0), (c1, c1 / c0)],
                    BLACK.mix(0.5).stroke_width(1),
                ))
                .map_err(|e| err(&e))?
                .label("linear")
                .legend(|(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], BLACK.mix(0.5)));
            for (i, ((t, l2), pts)) in series.iter().enumerate() {
                let (r, g, b) = PALETTE[i % PALETTE.len()];
                let colour = RGBColor(r, g, b);
                chart
                    .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 5, colour.filled())))
                    .map_err(|e| err(&e))?
                    .label(format!("{t} threads/core, L2 {l2} KB"))
                    .legend(move |(x, y)| {
                        EmptyElement::at((x, y))
                            + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                            + Circle::new((0, 0), 4, colour.filled())
                    });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 16))
                .draw()
                .map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        save(path, rgb)
    }

    /// `phases.png`: per-phase simulated ms and share of the frame, one bar per phase, in the style
    /// of the paper's Table 2.
    pub fn phases(path: &Path, scene: &Scene, point: &StudyPoint) -> anyhow::Result<()> {
        register_fonts();
        let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot draw {}: {e}", path.display());
        let r = &point.report;
        let n = r.phases.len().max(1);
        let ymax = r.phases.iter().map(|p| p.ms).fold(0.0, f64::max).max(1e-6) * 1.2;
        let mut rgb = canvas();
        {
            let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let title = format!(
                "{} {}x{} on {} cores, {} threads/core, {} GHz: {:.2} ms/frame",
                scene_name(scene),
                scene.camera.width,
                scene.camera.height,
                point.cores,
                point.threads,
                r.config.clock_ghz,
                r.frame.ms
            );
            let names: Vec<String> = r.phases.iter().map(|p| p.phase.clone()).collect();
            let mut chart = ChartBuilder::on(&root)
                .caption(title, ("sans-serif", 22))
                .margin(20)
                .x_label_area_size(56)
                .y_label_area_size(70)
                .build_cartesian_2d(-0.5..n as f64 - 0.5, 0.0..ymax)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels(n)
                .x_label_formatter(&|x| {
                    let i = x.round();
                    if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                        names[i as usize].clone()
                    } else {
                        String::new()
                    }
                })
                .x_desc("phase")
                .y_desc("simulated time, ms")
                .bold_line_style(RGBColor(200, 200, 200))
                .light_line_style(RGBColor(238, 238, 238))
                .axis_desc_style(("sans-serif", 18))
                .label_style(("sans-serif", 15))
                .draw()
                .map_err(|e| err(&e))?;
            // Each bar stacked by its cycle stack, scaled to ms.
            let parts = ["issue", "memory", "atomics + sync", "imbalance + idle"];
            for (k, part) in parts.iter().enumerate() {
                let (cr, cg, cb) = PALETTE[k];
                let colour = RGBColor(cr, cg, cb);
                let bars: Vec<Rectangle<(f64, f64)>> = r
                    .phases
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let s = p.stack.parts();
                        let below: u64 = s[..k].iter().map(|x| x.1).sum();
                        let ms = |c: u64| r.config.ms(c);
                        Rectangle::new(
                            [
                                (i as f64 - 0.35, ms(below)),
                                (i as f64 + 0.35, ms(below + s[k].1)),
                            ],
                            colour.filled(),
                        )
                    })
                    .collect();
                chart
                    .draw_series(bars)
                    .map_err(|e| err(&e))?
                    .label(*part)
                    .legend(move |(x, y)| Rectangle::new([(x - 8, y - 6), (x + 8, y + 6)], colour.filled()));
            }
            chart
                .draw_series(r.phases.iter().enumerate().map(|(i, p)| {
                    Text::new(
                        format!(
                            "{:.2} ms ({:.0}%)",
                            p.ms,
                            100.0 * p.cycles as f64 / r.frame.cycles.max(1) as f64
                        ),
                        (i as f64 - 0.3, p.ms + ymax * 0.04),
                        ("sans-serif", 15).into_font(),
                    )
                }))
                .map_err(|e| err(&e))?;
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 16))
                .draw()
                .map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        save(path, rgb)
    }
}
