//! Penumbra occlusion kernel throughput (paper Eq. 3): signed edge terms per second, per backend,
//! and the scalar f32 reference for comparison.
//!
//! `CARGO_TARGET_DIR=... cargo bench --bench occlusion`. 4096 receiver samples in a patch under a
//! light of radius 0.25 at distance ~4, 64 silhouette edges crossing the light images of the
//! samples (every term goes through the full Eq. 3 path, none is culled early; n_tri = 1 and 2
//! mixed). Throughput is reported as edge terms (sample × edge) per second ("elem/s").

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use sism::algorithms::sism::occlusion::{edge_term_scalar, AccumulateEdgeTerms, EdgeRecord};
use sism_simd::{available_backends, run_with};

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
}

struct Setup {
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    edges: Vec<EdgeRecord>,
    r: f32,
}

fn setup() -> Setup {
    let mut rng = Rng(0x1234_5678_9ABC_DEF1);
    let n = 4096;
    let r = 0.25f32;
    // Light centre at the origin, receivers on a patch 4 below it.
    let xs: Vec<f32> = (0..n).map(|_| rng.range(-0.1, 0.1)).collect();
    let ys: Vec<f32> = (0..n).map(|_| rng.range(-0.1, 0.1)).collect();
    let zs: Vec<f32> = (0..n).map(|_| -4.0 + rng.range(-0.01, 0.01)).collect();
    // Edges half-way, crossing the light images (|offset| < light footprint at that height).
    let edges = (0..64)
        .map(|i| {
            let z = rng.range(-3.0, -1.0);
            let reach = r * (-z) / 4.0 + 0.05;
            let off = rng.range(-0.5, 0.5) * reach;
            let ang = rng.range(0.0, std::f32::consts::PI);
            let (s, c) = ang.sin_cos();
            let a = [off * c - s, off * s + c, z];
            let b = [off * c + s, off * s - c, z + rng.range(-0.1, 0.1)];
            let v3a = [off * c + 0.5 * c, off * s + 0.5 * s, z];
            let v3b = [off * c + 0.4 * c, off * s + 0.4 * s, z - 0.2];
            if i % 4 == 0 {
                EdgeRecord::pair(a, b, v3a, v3b)
            } else {
                EdgeRecord::single(a, b, v3a)
            }
        })
        .collect();
    Setup { xs, ys, zs, edges, r }
}

fn occlusion(c: &mut Criterion) {
    let s = setup();
    let terms = (s.xs.len() * s.edges.len()) as u64;
    let mut out = vec![0.0f32; s.xs.len()];
    // Sanity: most terms are nonzero (the full path is exercised).
    let nonzero = s
        .edges
        .iter()
        .map(|e| {
            (0..s.xs.len())
                .filter(|&i| edge_term_scalar([s.xs[i], s.ys[i], s.zs[i]], e, s.r) != 0.0)
                .count()
        })
        .sum::<usize>();
    eprintln!(
        "occlusion bench: {terms} edge terms per iteration, {:.0}% nonzero",
        100.0 * nonzero as f64 / terms as f64
    );
    let mut group = c.benchmark_group("occlusion_edge_terms");
    group.throughput(Throughput::Elements(terms));
    group.sample_size(20);
    for kind in available_backends() {
        group.bench_function(BenchmarkId::new("vector", kind.name()), |b| {
            b.iter(|| {
                run_with(
                    kind,
                    AccumulateEdgeTerms {
                        xs: &s.xs,
                        ys: &s.ys,
                        zs: &s.zs,
                        edges: &s.edges,
                        light_radius: s.r,
                        out: &mut out,
                    },
                )
            })
        });
    }
    group.bench_function("scalar", |b| {
        b.iter(|| {
            for (i, o) in out.iter_mut().enumerate() {
                let p = [s.xs[i], s.ys[i], s.zs[i]];
                *o = s.edges.iter().map(|e| edge_term_scalar(p, e, s.r)).sum();
            }
        })
    });
    group.finish();
}

criterion_group!(benches, occlusion);
criterion_main!(benches);
