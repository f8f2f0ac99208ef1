//! Realistic kernels: native and counting contexts bit-identical on every
//! backend, counters equal to what the kernel issues, compact records.

mod common;
use common::*;
use sism_simd::examples::{Binning, Occlusion, PointInTriangles, Tri};
use sism_simd::{run_counting_with, run_with, BackendKind, Recorder, TaskRecord};

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
    let xs = (0..n).map(|_| r.f()).collect();
    let ys = (0..n).map(|_| r.f()).collect();
    (xs, ys)
}

fn tris(k: usize) -> Vec<Tri> {
    let mut r = Rng(77);
    (0..k)
        .map(|_| Tri::new([r.f(), r.f()], [r.f(), r.f()], [r.f(), r.f()]))
        .collect()
}

fn pit(ctx: Ctx, xs: &[f32], ys: &[f32], t: &[Tri]) -> Vec<i32> {
    let mut out = vec![0; xs.len()];
    run(
        ctx,
        PointInTriangles {
            xs,
            ys,
            tris: t,
            out: &mut out,
        },
    );
    out
}

#[test]
fn point_in_triangle_identical_and_correct() {
    let n = 100_003; // not a multiple of 16: exercises the tail mask
    let (xs, ys) = points(n, 1);
    let t = tris(7);
    let reference = pit(Ctx::Native(BackendKind::Portable), &xs, &ys, &t);
    // scalar reference with the same fused edge function
    for i in (0..n).step_by(7) {
        let want: i32 = t
            .iter()
            .enumerate()
            .map(|(k, tr)| (tr.contains([xs[i], ys[i]]) as i32) << k)
            .sum();
        assert_eq!(reference[i], want, "point {i}");
    }
    assert!(reference.iter().any(|&b| b != 0) && reference.contains(&0));
    for c in contexts() {
        assert_eq!(pit(c, &xs, &ys, &t), reference, "{c:?}");
    }
}

#[test]
fn point_in_triangle_counters_exact() {
    let n = 1000;
    let (xs, ys) = points(n, 2);
    let t = tris(5);
    let k = t.len() as u64;
    let iters = n.div_ceil(16) as u64;
    for b in sism_simd::available_backends() {
        let rec = Recorder::new();
        let mut out = vec![0; n];
        run_counting_with(
            b,
            &rec,
            PointInTriangles {
                xs: &xs,
                ys: &ys,
                tris: &t,
                out: &mut out,
            },
        );
        let tasks = rec.take_tasks();
        assert_eq!(tasks.len(), 1);
        let c = tasks[0].counters;
        assert_eq!(tasks[0].kind, 1);
        // per iteration: 2 masked loads, 1 masked store, first_n mask;
        // per triangle: 3 × (2 sub + mul + cmp) valu + 3 fmsub + 3 mask_and
        // + or + select.
        assert_eq!(c.load, 2 * iters);
        assert_eq!(c.store, iters);
        assert_eq!(c.fma, 3 * k * iters);
        assert_eq!(c.valu, (12 + 2) * k * iters);
        assert_eq!(c.mask, (1 + 3 * k) * iters);
        assert_eq!(c.scalar, (8 * k + 2) * iters);
        assert_eq!(
            c.transcendental + c.gather + c.scatter + c.atomic + c.compress_expand,
            0
        );
        assert_eq!(c.vector_ops, c.load + c.store + c.fma + c.valu);
        assert_eq!(c.masked_ops, 3 * iters);
        // Mask moves: per iteration the 3 masked loads and stores; per triangle its 3 compares
        // and the select (the mask logic and the `or` move nothing between lanes and masks).
        assert_eq!(c.mask_moves, (3 + 4 * k) * iters);
        let tail = (n % 16) as u64;
        assert_eq!(c.active_lanes, 16 * c.vector_ops - 3 * (16 - tail));
        // xs and ys streamed: each 64-byte aligned-or-not 16-float load
        // touches 1-2 lines, and the stream is tiny.
        assert!(c.load_lines >= 2 * (n as u64 * 4 / 64) && c.load_lines <= 2 * 2 * iters);
        let bpl = tasks[0].lines.bytes_per_line();
        println!(
            "{b:?}: {c:?}\nlines {} bytes {} ({bpl:.2} B/line)",
            tasks[0].lines.len(),
            tasks[0].lines.encoded_len()
        );
    }
}

#[test]
fn occlusion_identical() {
    let n = 50_000;
    let (xs, ys) = points(n, 3);
    // occluder edges through the unit square, normals normalised; scaled
    // so that |d| < 1 for a good share of samples.
    let mut r = Rng(5);
    let edges: Vec<[f32; 3]> = (0..6)
        .map(|_| {
            let a = r.f() * 6.2831855;
            [
                a.cos() * 4.0,
                a.sin() * 4.0,
                -2.0 * (a.cos() + a.sin()) + (r.f() - 0.5) * 2.0,
            ]
        })
        .collect();
    let mut reference = vec![0.0; n];
    run_with(
        BackendKind::Portable,
        Occlusion {
            xs: &xs,
            ys: &ys,
            edges: &edges,
            out: &mut reference,
        },
    );
    assert!(reference.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(reference.iter().any(|&v| v > 0.0 && v < 1.0));
    for c in contexts() {
        let mut out = vec![0.0; n];
        run(
            c,
            Occlusion {
                xs: &xs,
                ys: &ys,
                edges: &edges,
                out: &mut out,
            },
        );
        assert!(
            out.iter()
                .zip(&reference)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{c:?}"
        );
    }
    // scalar f64 reference, loose: the kernel's acos/sqrt are accurate to
    // ~1e-6 per edge.
    for i in (0..n).step_by(97) {
        let mut occ = 0.0f64;
        for e in &edges {
            let d = (e[0] as f64) * xs[i] as f64 + (e[1] as f64) * ys[i] as f64 + e[2] as f64;
            if d.abs() < 1.0 {
                occ += (d.acos() - d * (1.0 - d * d).sqrt()) / std::f64::consts::PI;
            } else if d <= -1.0 {
                occ += 1.0;
            }
        }
        let want = (1.0 - occ).max(0.0);
        assert!(
            (reference[i] as f64 - want).abs() < 1e-5,
            "sample {i}: {} vs {want}",
            reference[i]
        );
    }
    // counts: every taken branch issues acos (1 sqrt) + root sqrt
    let rec = Recorder::new();
    let mut out = vec![0.0; n];
    sism_simd::run_counting(
        &rec,
        Occlusion {
            xs: &xs,
            ys: &ys,
            edges: &edges,
            out: &mut out,
        },
    );
    let c = rec.take_tasks()[0].counters;
    assert!(c.transcendental > 0 && c.transcendental.is_multiple_of(2));
    assert!(c.fma > c.transcendental);
    println!("occlusion: {c:?}");
}

#[test]
fn binning_counting_sort() {
    let n = 20_011;
    let (xs, ys) = points(n, 4);
    let (w, h) = (8, 5); // 40 cells: heavy collisions inside each vector
    let cell = |i: usize| {
        let cx = ((xs[i] * w as f32).floor() as i32).clamp(0, w as i32 - 1);
        let cy = ((ys[i] * h as f32).floor() as i32).clamp(0, h as i32 - 1);
        (cy * w as i32 + cx) as usize
    };
    // scalar stable counting sort
    let mut want: Vec<i32> = (0..n as i32).collect();
    want.sort_by_key(|&i| cell(i as usize));
    let mut reference = None;
    for c in contexts() {
        let mut starts = vec![0; w * h + 1];
        let mut sorted = vec![-1; n];
        run(
            c,
            Binning {
                xs: &xs,
                ys: &ys,
                w,
                h,
                starts: &mut starts,
                sorted: &mut sorted,
            },
        );
        assert_eq!(sorted, want, "{c:?}");
        for k in 0..w * h {
            for &id in &sorted[starts[k] as usize..starts[k + 1] as usize] {
                assert_eq!(cell(id as usize), k);
            }
        }
        if let Some(r) = &reference {
            assert_eq!(&starts, r);
        }
        reference = Some(starts);
    }
    let rec = Recorder::new();
    let mut starts = vec![0; w * h + 1];
    let mut sorted = vec![-1; n];
    sism_simd::run_counting(
        &rec,
        Binning {
            xs: &xs,
            ys: &ys,
            w,
            h,
            starts: &mut starts,
            sorted: &mut sorted,
        },
    );
    let tasks = rec.take_tasks();
    assert_eq!(tasks.iter().map(|t| t.kind).collect::<Vec<_>>(), vec![3, 4, 5]);
    let iters = n.div_ceil(16) as u64;
    let (hist, prefix, scatter) = (tasks[0].counters, tasks[1].counters, tasks[2].counters);
    assert_eq!(hist.atomic, iters);
    assert!(
        hist.atomic_conflicts > iters,
        "40 cells, 16 lanes: many conflicts"
    );
    assert!(hist.atomic_lines <= 16 * hist.atomic && hist.atomic_lines >= hist.atomic);
    assert_eq!(prefix.scalar, 3 * (w * h) as u64);
    assert_eq!(prefix.vector_ops, 0);
    assert_eq!((scatter.gather, scatter.scatter), (iters, iters));
    assert!(scatter.gather_lines <= 16 * scatter.gather);
    assert!(scatter.scatter_lines <= 16 * scatter.scatter);
    // The 41 starts (164 bytes) span 3 lines, or 4 when the allocator places them off a line.
    let start_lines = {
        let a = starts.as_ptr() as usize;
        ((a + 4 * starts.len() - 1) / 64 - a / 64 + 1) as u64
    };
    assert!(
        scatter.gather_lines <= start_lines * scatter.gather,
        "41 starts span {start_lines} lines"
    );
    for t in &tasks {
        let b = t.to_bytes();
        let (back, used) = TaskRecord::from_bytes(&b).unwrap();
        assert_eq!(used, b.len());
        assert_eq!(&back, t);
        println!(
            "task {}: {} lines, {} bytes ({:.2} B/line)",
            t.kind,
            t.lines.len(),
            b.len(),
            t.lines.bytes_per_line()
        );
    }
}

#[test]
fn record_size_is_compact() {
    // 2^18 samples × 8 triangles with line recording: the record must stay
    // tiny (streaming) — a full 1600×1200 frame scales linearly from here.
    let n = 1 << 18;
    let (xs, ys) = points(n, 9);
    let t = tris(8);
    let rec = Recorder::new();
    let mut out = vec![0; n];
    sism_simd::run_counting(
        &rec,
        PointInTriangles {
            xs: &xs,
            ys: &ys,
            tris: &t,
            out: &mut out,
        },
    );
    let task = &rec.take_tasks()[0];
    let bytes = task.to_bytes().len();
    println!(
        "{} instructions, {} line accesses, record {} bytes ({:.3} B/line)",
        task.counters.instructions(),
        task.lines.len(),
        bytes,
        task.lines.bytes_per_line()
    );
    assert!(task.lines.len() >= 3 * (n as u64 * 4 / 64));
    assert!(
        task.lines.bytes_per_line() <= 1.05,
        "interleaved streams should cost ~1 B/line"
    );
}

/// A kernel whose records depend on every part of a recorder's state: data-dependent branches
/// (the predictor), scalar chains (the depth table), a stack array (the stack renaming) and a task
/// that records nothing after its kind is set.
struct BranchyStack<'a> {
    xs: &'a [f32],
    out: &'a mut [f32],
}

impl sism_simd::Kernel for BranchyStack<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: sism_simd::Simd>(self, s: S) {
        s.begin_task(7);
        let mut acc = 0.0f32;
        let mut lanes = [0.0f32; 16];
        for (i, &x) in self.xs.iter().enumerate() {
            if s.s_lt(x, 0.5) {
                acc = s.s_add(acc, x);
            } else {
                acc = s.s_mul(acc, 0.5);
            }
            lanes[i % 16] = acc;
            if i % 16 == 15 {
                let v = s.load_f(&lanes);
                s.store_f(&mut self.out[i - 15..=i], v);
            }
        }
        s.begin_task(8);
    }
}

#[test]
fn a_reused_recorder_records_what_fresh_ones_do() {
    let n = 4096;
    let (xs, ys) = points(n, 11);
    let t = tris(5);
    let mut out_i = vec![0; n];
    let mut out_f = vec![0.0; n];
    let shared = Recorder::new();
    // Each kernel in turn on one recorder, or on a fresh recorder each; twice over, so the reused
    // recorder carries the branch history and stack lines of the kernels before.
    let mut runs = |reuse: bool| {
        let mut all = Vec::new();
        for k in 0..4 {
            let fresh;
            let rec = if reuse {
                &shared
            } else {
                fresh = Recorder::new();
                &fresh
            };
            if k % 2 == 0 {
                let out = &mut out_f[..];
                sism_simd::run_counting(rec, BranchyStack { xs: &xs, out });
            } else {
                let out = &mut out_i[..];
                let k = PointInTriangles {
                    xs: &xs,
                    ys: &ys,
                    tris: &t,
                    out,
                };
                sism_simd::run_counting(rec, k);
            }
            all.push(rec.take_tasks());
        }
        all
    };
    let fresh = runs(false);
    let reused = runs(true);
    assert!(fresh[0][0].counters.branch_mispredicts > 0);
    assert_eq!(fresh[0].len(), 1, "the empty task 8 files no record");
    assert_eq!(fresh, reused);
}
