//! Reference kernels in the shape of the sism workloads. They are used by
//! this crate's tests and benchmarks and double as examples of how a kernel
//! is written: a struct of inputs implementing [`Kernel`] with an
//! `#[inline(always)]` generic `run`.

use crate::{Kernel, Simd};

/// A triangle prepared for edge-function tests (counter-clockwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tri {
    /// Vertices.
    pub v: [[f32; 2]; 3],
}

impl Tri {
    /// Counter-clockwise triangle from three points (reorders if needed).
    pub fn new(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> Self {
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area >= 0.0 {
            Tri { v: [a, b, c] }
        } else {
            Tri { v: [a, c, b] }
        }
    }
    /// Scalar reference of the same test as [`PointInTriangles`] (same
    /// fused operations, so bit-identical decisions).
    pub fn contains(&self, p: [f32; 2]) -> bool {
        (0..3).all(|e| {
            let a = self.v[e];
            let b = self.v[(e + 1) % 3];
            let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
            let (dx, dy) = (p[0] - a[0], p[1] - a[1]);
            ex.mul_add(dy, -(ey * dx)) >= 0.0
        })
    }
}

/// For every point, a bit mask of the triangles (at most 32) containing it:
/// the dense point-in-triangle test of irregular shadow mapping, with the
/// triangle broadcast and 16 samples per vector.
pub struct PointInTriangles<'a> {
    /// Sample x coordinates.
    pub xs: &'a [f32],
    /// Sample y coordinates (same length).
    pub ys: &'a [f32],
    /// Triangles (≤ 32).
    pub tris: &'a [Tri],
    /// Output: bit t set when triangle t contains the sample.
    pub out: &'a mut [i32],
}

impl Kernel for PointInTriangles<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        assert!(self.tris.len() <= 32);
        let n = self.xs.len();
        assert!(self.ys.len() == n && self.out.len() == n);
        s.begin_task(1);
        let zero = s.splat_f(0.0);
        let mut i = 0;
        while i < n {
            let m = s.mask_first_n(n - i);
            let px = s.mask_load_f(zero, m, &self.xs[i..]);
            let py = s.mask_load_f(zero, m, &self.ys[i..]);
            let mut acc = s.splat_i(0);
            for (t, tri) in self.tris.iter().enumerate() {
                let mut inside = m;
                for e in 0..3 {
                    let a = tri.v[e];
                    let b = tri.v[(e + 1) % 3];
                    let w = s.edge_f(
                        s.splat_f(a[0]),
                        s.splat_f(a[1]),
                        s.splat_f(b[0] - a[0]),
                        s.splat_f(b[1] - a[1]),
                        px,
                        py,
                    );
                    inside = s.mask_and(inside, s.cmp_ge_f(w, zero));
                }
                acc = s.select_i(inside, s.or_i(acc, s.splat_i(1 << t)), acc);
                s.scalar_ops(8); // edge setup (6 subs) + loop
            }
            s.mask_store_i(&mut self.out[i..], m, acc);
            s.scalar_ops(2);
            i += 16;
        }
        s.end_task();
    }
}

/// Penumbra-style occlusion: for every sample, the fraction of a unit
/// light disk left uncovered by a set of half-plane occluder edges, each
/// contributing the circle-segment area `(acos d - d sqrt(1 - d²)) / π`
/// for signed distance `d = nx·px + ny·py + c` (masked to `|d| < 1`;
/// `d ≤ -1` covers everything).
pub struct Occlusion<'a> {
    /// Sample x coordinates.
    pub xs: &'a [f32],
    /// Sample y coordinates.
    pub ys: &'a [f32],
    /// Edges `[nx, ny, c]`, `(nx, ny)` normalised.
    pub edges: &'a [[f32; 3]],
    /// Output visibility in `[0, 1]`.
    pub out: &'a mut [f32],
}

impl Kernel for Occlusion<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        let n = self.xs.len();
        assert!(self.ys.len() == n && self.out.len() == n);
        s.begin_task(2);
        let zero = s.splat_f(0.0);
        let one = s.splat_f(1.0);
        let inv_pi = s.splat_f(core::f32::consts::FRAC_1_PI);
        let mut i = 0;
        while i < n {
            let m = s.mask_first_n(n - i);
            let px = s.mask_load_f(zero, m, &self.xs[i..]);
            let py = s.mask_load_f(zero, m, &self.ys[i..]);
            let mut occ = zero;
            for e in self.edges {
                let d = s.fmadd(s.splat_f(e[0]), px, s.fmadd(s.splat_f(e[1]), py, s.splat_f(e[2])));
                let partial = s.mask_and(m, s.cmp_lt_f(s.abs_f(d), one));
                let full = s.mask_and(m, s.cmp_le_f(d, s.neg_f(one)));
                if s.mask_any(partial) {
                    let root = s.sqrt_f(s.fnmadd(d, d, one));
                    let seg = s.mul_f(s.fnmadd(d, root, s.acos_f(d)), inv_pi);
                    occ = s.mask_add_f(occ, partial, occ, seg);
                }
                occ = s.mask_add_f(occ, full, occ, one);
                s.scalar_ops(4);
            }
            let vis = s.max_f(s.sub_f(one, occ), zero);
            s.mask_store_f(&mut self.out[i..], m, vis);
            s.scalar_ops(2);
            i += 16;
        }
        s.end_task();
    }
}

/// Counting-sort binning (perspective-grid construction): cell of each
/// point in a `w × h` grid over `[0, 1)²`, histogram with conflict-combining
/// vector fetch-add, exclusive prefix sum, then scatter of the point ids
/// into `sorted` at `start[cell] + rank`.
pub struct Binning<'a> {
    /// Point x in `[0, 1)`.
    pub xs: &'a [f32],
    /// Point y in `[0, 1)`.
    pub ys: &'a [f32],
    /// Grid width.
    pub w: usize,
    /// Grid height.
    pub h: usize,
    /// Output: `w*h + 1` cell starts.
    pub starts: &'a mut [i32],
    /// Output: point ids sorted by cell (stable within a cell).
    pub sorted: &'a mut [i32],
}

impl Kernel for Binning<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        let n = self.xs.len();
        let cells = self.w * self.h;
        assert!(self.starts.len() == cells + 1 && self.sorted.len() == n);
        let fw = s.splat_f(self.w as f32);
        let fh = s.splat_f(self.h as f32);
        let wi = s.splat_i(self.w as i32);
        let maxx = s.splat_i(self.w as i32 - 1);
        let maxy = s.splat_i(self.h as i32 - 1);
        let zi = s.splat_i(0);
        let one = s.splat_i(1);
        let mut ranks = vec![0i32; n];
        let counts = &mut self.starts[..cells];
        counts.fill(0);
        // Pass 1: histogram, remembering each point's rank in its cell.
        s.begin_task(3);
        // A nested #[inline(always)] fn rather than a closure: closures are
        // not guaranteed to inline into the #[target_feature] entry point.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn cell_of<S: Simd>(
            s: S,
            xs: &[f32],
            ys: &[f32],
            m: crate::Mask16,
            f: (S::F32, S::F32),
            max: (S::I32, S::I32),
            wi: S::I32,
        ) -> S::I32 {
            let zero = s.splat_f(0.0);
            let zi = s.splat_i(0);
            let x = s.mask_load_f(zero, m, xs);
            let y = s.mask_load_f(zero, m, ys);
            let cx = s.min_i(s.max_i(s.floor_i(s.mul_f(x, f.0)), zi), max.0);
            let cy = s.min_i(s.max_i(s.floor_i(s.mul_f(y, f.1)), zi), max.1);
            s.add_i(s.mul_i(cy, wi), cx)
        }
        let mut i = 0;
        while i < n {
            let m = s.mask_first_n(n - i);
            let cell = cell_of(s, &self.xs[i..], &self.ys[i..], m, (fw, fh), (maxx, maxy), wi);
            let rank = s.fetch_add_i(counts, m, cell, one);
            s.mask_store_i(&mut ranks[i..], m, rank);
            i += 16;
        }
        s.end_task();
        // Exclusive prefix sum (scalar).
        s.begin_task(4);
        let mut sum = 0i32;
        for c in self.starts[..cells].iter_mut() {
            let v = *c;
            *c = sum;
            sum += v;
        }
        self.starts[cells] = n as i32;
        s.scalar_ops(3 * cells as u64);
        s.end_task();
        // Pass 2: scatter ids to their sorted position.
        s.begin_task(5);
        let mut i = 0;
        while i < n {
            let m = s.mask_first_n(n - i);
            let cell = cell_of(s, &self.xs[i..], &self.ys[i..], m, (fw, fh), (maxx, maxy), wi);
            let start = s.mask_gather_i(zi, m, self.starts, cell);
            let rank = s.mask_load_i(zi, m, &ranks[i..]);
            let pos = s.add_i(start, rank);
            let id = s.add_i(s.index_i(), s.splat_i(i as i32));
            s.mask_scatter_i(self.sorted, m, pos, id);
            i += 16;
        }
        s.end_task();
    }
}
