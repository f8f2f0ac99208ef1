//! AVX-512 vs portable speed on realistic kernels, and the counting
//! context's slowdown. Run:
//! `CARGO_TARGET_DIR=/work/target-simd cargo bench -p sism-simd -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use sism_simd::examples::{Binning, Occlusion, PointInTriangles, Tri};
use sism_simd::{available_backends, run_counting_with, run_with, BackendKind, Kernel, Recorder};
use std::hint::black_box;

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn points(n: usize, seed: u64) -> (Vec<f32>, Vec<f32>) {
    let mut r = Rng(seed);
    ((0..n).map(|_| r.f()).collect(), (0..n).map(|_| r.f()).collect())
}

#[derive(Clone, Copy)]
enum Mode {
    Native(BackendKind),
    Counting(BackendKind, bool),
}

fn modes() -> Vec<(String, Mode)> {
    let mut v: Vec<(String, Mode)> = available_backends()
        .into_iter()
        .map(|b| (b.name().to_string(), Mode::Native(b)))
        .collect();
    let b = available_backends()[0];
    v.push((format!("counting-{}", b.name()), Mode::Counting(b, true)));
    v.push((format!("counting-{}-nolines", b.name()), Mode::Counting(b, false)));
    v
}

fn exec<K: Kernel>(m: Mode, k: K) -> K::Output {
    match m {
        Mode::Native(b) => run_with(b, k),
        Mode::Counting(b, lines) => {
            let rec = Recorder::with_lines(lines);
            let r = run_counting_with(b, &rec, k);
            black_box(rec.take_tasks());
            r
        }
    }
}

fn bench(c: &mut Criterion) {
    let n = 1 << 20;
    let (xs, ys) = points(n, 1);
    let mut r = Rng(7);
    let tris: Vec<Tri> = (0..4)
        .map(|_| Tri::new([r.f(), r.f()], [r.f(), r.f()], [r.f(), r.f()]))
        .collect();
    let edges: Vec<[f32; 3]> = (0..4)
        .map(|_| {
            let a = r.f() * 6.2831855;
            [
                a.cos() * 4.0,
                a.sin() * 4.0,
                -2.0 * (a.cos() + a.sin()) + (r.f() - 0.5) * 2.0,
            ]
        })
        .collect();

    let mut g = c.benchmark_group("point_in_triangle_1M_pts_4_tris");
    g.throughput(Throughput::Elements(n as u64));
    for (name, m) in modes() {
        let mut out = vec![0i32; n];
        g.bench_function(BenchmarkId::from_parameter(&name), |b| {
            b.iter(|| {
                exec(
                    m,
                    PointInTriangles {
                        xs: &xs,
                        ys: &ys,
                        tris: &tris,
                        out: &mut out,
                    },
                )
            })
        });
    }
    g.finish();

    let mut g = c.benchmark_group("occlusion_acos_1M_pts_4_edges");
    g.throughput(Throughput::Elements(n as u64));
    for (name, m) in modes() {
        let mut out = vec![0f32; n];
        g.bench_function(BenchmarkId::from_parameter(&name), |b| {
            b.iter(|| {
                exec(
                    m,
                    Occlusion {
                        xs: &xs,
                        ys: &ys,
                        edges: &edges,
                        out: &mut out,
                    },
                )
            })
        });
    }
    g.finish();

    let mut g = c.benchmark_group("binning_1M_pts_64x64");
    g.throughput(Throughput::Elements(n as u64));
    for (name, m) in modes() {
        let mut starts = vec![0i32; 64 * 64 + 1];
        let mut sorted = vec![0i32; n];
        g.bench_function(BenchmarkId::from_parameter(&name), |b| {
            b.iter(|| {
                exec(
                    m,
                    Binning {
                        xs: &xs,
                        ys: &ys,
                        w: 64,
                        h: 64,
                        starts: &mut starts,
                        sorted: &mut sorted,
                    },
                )
            })
        });
    }
    g.finish();

    // Record size on the full 1M-point runs (printed once).
    let b = available_backends()[0];
    for (name, k) in [("point_in_triangle", 0), ("occlusion", 1), ("binning", 2)] {
        let rec = Recorder::new();
        match k {
            0 => {
                let mut out = vec![0i32; n];
                run_counting_with(
                    b,
                    &rec,
                    PointInTriangles {
                        xs: &xs,
                        ys: &ys,
                        tris: &tris,
                        out: &mut out,
                    },
                )
            }
            1 => {
                let mut out = vec![0f32; n];
                run_counting_with(
                    b,
                    &rec,
                    Occlusion {
                        xs: &xs,
                        ys: &ys,
                        edges: &edges,
                        out: &mut out,
                    },
                )
            }
            _ => {
                let mut starts = vec![0i32; 64 * 64 + 1];
                let mut sorted = vec![0i32; n];
                run_counting_with(
                    b,
                    &rec,
                    Binning {
                        xs: &xs,
                        ys: &ys,
                        w: 64,
                        h: 64,
                        starts: &mut starts,
                        sorted: &mut sorted,
                    },
                )
            }
        }
        let tasks = rec.take_tasks();
        let instr: u64 = tasks.iter().map(|t| t.counters.instructions()).sum();
        let lines: u64 = tasks.iter().map(|t| t.lines.len()).sum();
        let bytes: usize = tasks.iter().map(|t| t.to_bytes().len()).sum();
        println!(
            "record {name}: {} tasks, {instr} instructions, {lines} line accesses, {bytes} bytes ({:.3} B/line)",
            tasks.len(),
            bytes as f64 / lines.max(1) as f64
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
