//! Coherent shadow rays: one receiver's rays to its light disk, traced together.
//!
//! A receiver's shadow rays share their origin and end on a disk that is small seen from it (a sun
//! degree, a lamp a few degrees), so they fill a thin cone. Tracing them one by one, as a general ray
//! tracer does, walks nearly the same BVH nodes once per ray. [`BeamBvh`] walks them once per *beam*
//! (up to [`BEAM_RAYS`] rays): a node is entered when the beam's bounding cone meets the node's bounding
//! sphere (a scalar test), and a leaf's triangles are tested against the beam's still-unoccluded rays
//! 16 lanes a vector. The walk stops when every ray is occluded.
//!
//! The per-ray answer is exactly [`super::SceneBvh::occluded`]'s: the triangle test is obvhs'
//! `RtTriangle::intersect` written lane-wise with the same operations in the same order (no fused
//! multiply-add), and the cone and sphere tests are conservative (inflated), so they only skip nodes
//! no ray of the beam can reach. A test checks both on random rays bit for bit.

use glam::Vec3;
use obvhs::bvh2::Bvh2;
use obvhs::rt_triangle::RtTriangle;
use sism_simd::{Mask16, ScalarClass, Simd};

use crate::counted;

/// Rays of one beam: 16 vectors of 16 lanes.
pub const BEAM_RAYS: usize = 256;
const VECTORS: usize = BEAM_RAYS / 16;

/// Sine of the cone half-angle above which a beam also tests boxes lane by lane (about 1.1°: a
/// light of 2° seen from the receiver).
const WIDE_SIN: f32 = 0.0;

/// A node is tested vector by vector when its radius is below this times the beam's radius there.
const BOX_TEST_RATIO: f32 = 2.0;

/// A node of the beam BVH: its box's bounding sphere and its children or triangles.
#[derive(Clone, Copy, Debug)]
struct BeamNode {
    /// Centre of the bounding sphere of the node's box, world units.
    center: Vec3,
    /// Radius of that sphere, inflated so rounding never excludes a point of the box.
    radius: f32,
    /// The box, inflated likewise, world units.
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first triangle (in [`BeamBvh::triangles`]); inner node: the left child (right is + 1).
    first: u32,
    /// Triangles of a leaf; 0 for an inner node.
    count: u32,
}

/// A binary BVH over the scene's triangles laid out for beams of shadow rays.
pub struct BeamBvh {
    nodes: Vec<BeamNode>,
    /// Triangles in leaf order.
    triangles: Vec<RtTriangle>,
    /// Deepest root-to-leaf path (sizes the traversal stack).
    max_depth: usize,
}

/// Up to [`BEAM_RAYS`] rays from one origin: unit directions and segment lengths, structure of arrays.
#[derive(Clone, Debug)]
pub struct Beam {
    origin: Vec3,
    dx: [[f32; 16]; VECTORS],
    dy: [[f32; 16]; VECTORS],
    dz: [[f32; 16]; VECTORS],
    t_max: [[f32; 16]; VECTORS],
    len: usize,
}

impl Beam {
    /// An empty beam from `origin`.
    pub fn new(origin: Vec3) -> Beam {
        Beam {
            origin,
            dx: [[0.0; 16]; VECTORS],
            dy: [[0.0; 16]; VECTORS],
            dz: [[0.0; 16]; VECTORS],
            t_max: [[0.0; 16]; VECTORS],
            len: 0,
        }
    }

    /// Empties the beam and moves its origin.
    pub fn reset(&mut self, origin: Vec3) {
        self.origin = origin;
        self.len = 0;
    }

    /// Rays held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the beam holds no ray.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True when no more ray fits.
    pub fn is_full(&self) -> bool {
        self.len == BEAM_RAYS
    }

    /// Adds the open segment `origin + t * dir`, `t` in (0, `t_max`); `dir` unit. Panics when full.
    pub fn push(&mut self, dir: Vec3, t_max: f32) {
        self.push_counted(sism_simd::Portable, dir, t_max);
    }

    /// [`Beam::push`] counted by `s`: the slot's two index operations, four stores (the beam is a
    /// task's scratch: its lines are recorded where the walk loads its vectors) and the count.
    #[inline(always)]
    pub fn push_counted<S: Simd>(&mut self, s: S, dir: Vec3, t_max: f32) {
        for _ in 0..3 {
            s.scalar_op(ScalarClass::Alu);
        }
        for _ in 0..4 {
            s.scalar_op(ScalarClass::Store);
        }
        let (v, l) = (self.len / 16, self.len % 16);
        self.dx[v][l] = dir.x;
        self.dy[v][l] = dir.y;
        self.dz[v][l] = dir.z;
        self.t_max[v][l] = t_max;
        self.len += 1;
    }

    /// The bounding cone of the rays: unit axis, sine and cosine of the half-angle (inflated; `None`
    /// when some ray is 90° or more from the axis: no cone bounds them), and the longest segment.
    /// 16 rays a vector (about a tenth of a thin beam's walk when it was scalar).
    #[inline(always)]
    fn cone<S: Simd>(&self, s: S) -> (Vec3, Option<(f32, f32)>, f32) {
        let vectors = self.len.div_ceil(16);
        let zero = s.splat_f(0.0);
        // No closures around vector operations here: a closure is compiled without the kernel's
        // target features and its vector operations would become calls.
        let (mut sx, mut sy, mut sz, mut longest) = (zero, zero, zero, zero);
        for v in 0..vectors {
            let m = s.mask_first_n(self.len - 16 * v);
            sx = s.add_f(sx, s.mask_load_f(zero, m, &self.dx[v]));
            sy = s.add_f(sy, s.mask_load_f(zero, m, &self.dy[v]));
            sz = s.add_f(sz, s.mask_load_f(zero, m, &self.dz[v]));
            longest = s.max_f(longest, s.mask_load_f(zero, m, &self.t_max[v]));
        }
        let first = Vec3::new(self.dx[0][0], self.dy[0][0], self.dz[0][0]);
        let sum = Vec3::new(s.reduce_add_f(sx), s.reduce_add_f(sy), s.reduce_add_f(sz));
        let axis = sum.normalize_or(first);
        let longest = s.reduce_max_f(longest);
        // The half-angle's sine from the largest component across the axis (well conditioned for
        // thin cones, unlike acos of a dot product near 1).
        let (ax, ay, az) = (s.splat_f(axis.x), s.splat_f(axis.y), s.splat_f(axis.z));
        let mut sin = zero;
        for v in 0..vectors {
            let m = s.mask_first_n(self.len - 16 * v);
            let (x, y, z) = (
                s.mask_load_f(zero, m, &self.dx[v]),
                s.mask_load_f(zero, m, &self.dy[v]),
                s.mask_load_f(zero, m, &self.dz[v]),
            );
            let along = s.add_f(s.add_f(s.mul_f(x, ax), s.mul_f(y, ay)), s.mul_f(z, az));
            if s.mask_any(s.mask_and(m, s.cmp_le_f(along, s.splat_f(1e-3)))) {
                return (axis, None, longest);
            }
            let (px, py, pz) = (
                s.sub_f(x, s.mul_f(ax, along)),
                s.sub_f(y, s.mul_f(ay, along)),
                s.sub_f(z, s.mul_f(az, along)),
            );
            let across = s.sqrt_f(s.add_f(s.add_f(s.mul_f(px, px), s.mul_f(py, py)), s.mul_f(pz, pz)));
            sin = s.select_f(m, s.max_f(sin, across), sin);
        }
        // Slack for rounding in the directions and in this computation: about 20 ulps of angle.
        let sin = (s.reduce_max_f(sin) * (1.0 + 1e-5) + 2e-6).min(1.0);
        let cos = (1.0 - sin * sin).max(0.0).sqrt();
        (axis, Some((sin, cos)), longest)
    }
}

/// What a beam walk did (summed into the reference's counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BeamCounts {
    /// Nodes whose sphere the cone was tested against.
    pub nodes: u64,
    /// Triangle tests, in 16-lane vectors.
    pub triangle_vectors: u64,
    /// Box (slab) tests of wide beams, in 16-lane vectors.
    pub box_vectors: u64,
}

impl BeamBvh {
    /// Lays out `bvh` (leaves referring to `triangles` through `bvh.primitive_indices`) for beams.
    pub fn new(bvh: &Bvh2, triangles: &[RtTriangle]) -> BeamBvh {
        let mut leaf_triangles = Vec::with_capacity(triangles.len());
        let nodes = bvh
            .nodes
            .iter()
            .map(|n| {
                let (lo, hi) = (Vec3::from(n.aabb().min), Vec3::from(n.aabb().max));
                let center = 0.5 * (lo + hi);
                let half = 0.5 * (hi - lo);
                // Inflated by a relative 1e-5 of the box and its distance from the origin, so that no
                // rounding in the sphere test (or in the box itself) can exclude a point of the box.
                let slack = 1e-6 * center.abs().max_element() + 1e-30;
                let radius = half.length() * (1.0 + 1e-5) + slack;
                let pad = half * 1e-5 + Vec3::splat(slack);
                let (lo, hi) = (lo - pad, hi + pad);
                if n.is_leaf() {
                    let first = leaf_triangles.len() as u32;
                    for &i in &bvh.primitive_indices
                        [n.first_index as usize..(n.first_index + n.prim_count) as usize]
                    {
                        leaf_triangles.push(triangles[i as usize]);
                    }
                    BeamNode {
                        center,
                        radius,
                        lo,
                        hi,
                        first,
                        count: n.prim_count,
                    }
                } else {
                    BeamNode {
                        center,
                        radius,
                        lo,
                        hi,
                        first: n.first_index,
                        count: 0,
                    }
                }
            })
            .collect();
        BeamBvh {
            nodes,
            triangles: leaf_triangles,
            max_depth: bvh.max_depth.max(1),
        }
    }

    /// Occlusion of every ray of `beam`: bit `k % 16` of `out[k / 16]` is set when a triangle crosses
    /// ray `k`'s open segment (exactly [`super::SceneBvh::occluded`] of that ray). `stack` is scratch.
    /// Inlined into the calling kernel so its vector operations compile for the kernel's backend.
    #[inline(always)]
    pub fn occluded<S: Simd>(
        &self,
        s: S,
        beam: &Beam,
        stack: &mut Vec<(u32, u16)>,
        out: &mut [Mask16; VECTORS],
    ) -> BeamCounts {
        let mut counts = BeamCounts::default();
        let vectors = beam.len.div_ceil(16);
        // Lanes still open (not yet occluded).
        let mut open = [Mask16::NONE; VECTORS];
        for (v, o) in open.iter_mut().enumerate().take(vectors) {
            *o = Mask16::first_n(beam.len.saturating_sub(v * 16).min(16));
        }
        *out = [Mask16::NONE; VECTORS];
        if beam.len == 0 || self.nodes.is_empty() {
            return counts;
        }
        let (axis, cone, longest) = beam.cone(s);
        let o = beam.origin;
        let (dx, dy, dz, tm) = (
            registers(s, &beam.dx),
            registers(s, &beam.dy),
            registers(s, &beam.dz),
            registers(s, &beam.t_max),
        );
        // Wide beams (a large or near light) also test each node's box against each vector's rays, and
        // carry down which vectors reached the node: the cone alone would let every ray meet every
        // triangle near any of them.
        let wide = cone.is_none_or(|(sin, _)| sin > WIDE_SIN);
        let inv = |d: &[[f32; 16]; VECTORS]| {
            d.map(|a| a.map(|x| 1.0 / if x.abs() < 1e-30 { 1e-30f32.copysign(x) } else { x }))
        };
        // `if`, not `bool::then`: vector operations stay out of closures (see `Beam::cone`).
        let slabs = if wide {
            Some((
                registers(s, &inv(&beam.dx)),
                registers(s, &inv(&beam.dy)),
                registers(s, &inv(&beam.dz)),
            ))
        } else {
            None
        };
        let mut open_vectors = vectors;
        let all_vectors = ((1u32 << vectors) - 1) as u16;
        stack.clear();
        stack.reserve(self.max_depth + 2);
        stack.push((0, all_vectors));
        let zero = s.splat_f(0.0);
        let one = s.splat_f(1.0);
        while let Some((n, mut reach)) = stack.pop() {
            // Counted: the pop (a load, the length's decrement, the loop's branch), the node's line
            // and every operation of the cone test.
            s.scalar_op(ScalarClass::Mem);
            s.scalar_op(ScalarClass::Alu);
            s.scalar_op(ScalarClass::Branch);
            let node = &self.nodes[n as usize];
            counts.nodes += 1;
            s.scalar_read(std::slice::from_ref(node));
            for _ in 0..4 {
                s.scalar_op(ScalarClass::Mem); // centre and radius
            }
            // Sphere against cone: outside when past either end of the segments or farther than its
            // radius from the plane through the cone's nearest generating line (which bounds the cone).
            let v = counted::sub(s, node.center, o);
            let r = node.radius;
            // Whether the node is small against the beam's width where it lies: only then can single
            // vectors miss it, so only then are its box tests worth their cost.
            let small = match cone {
                Some((sin, cos)) => {
                    let along = counted::dot(s, v, axis);
                    if s.s_lt(along, -r) || s.s_lt(s.s_add(longest, r), along) {
                        continue;
                    }
                    let across2 = s.s_sub(counted::dot(s, v, v), s.s_mul(along, along));
                    let across = s.s_fn(ScalarClass::Div, s.s_max(across2, 0.0), f32::sqrt);
                    if s.s_lt(r, s.s_sub(s.s_mul(across, cos), s.s_mul(along, sin))) {
                        continue;
                    }
                    s.s_lt(
                        s.s_mul(r, cos),
                        s.s_mul(s.s_mul(BOX_TEST_RATIO, s.s_add(along, r)), sin),
                    )
                }
                None => {
                    if s.s_lt(s.s_add(longest, r), counted::length(s, v)) {
                        continue;
                    }
                    true
                }
            };
            if let (true, Some((ix, iy, iz))) = (small, &slabs) {
                // Slabs, conservatively: the box is inflated, the far distance stretched a little.
                let (lo, hi) = (counted::sub(s, node.lo, o), counted::sub(s, node.hi, o));
                let mut kept = 0u16;
                for v in 0..vectors {
                    if s.s_branch(reach & (1 << v) == 0 || !open[v].any()) {
                        continue;
                    }
                    counts.box_vectors += 1;
                    let (ax, bx) = (s.mul_f(s.splat_f(lo.x), ix[v]), s.mul_f(s.splat_f(hi.x), ix[v]));
                    let (ay, by) = (s.mul_f(s.splat_f(lo.y), iy[v]), s.mul_f(s.splat_f(hi.y), iy[v]));
                    let (az, bz) = (s.mul_f(s.splat_f(lo.z), iz[v]), s.mul_f(s.splat_f(hi.z), iz[v]));
                    let near = s.max_f(s.max_f(s.min_f(ax, bx), s.min_f(ay, by)), s.min_f(az, bz));
                    let far = s.min_f(s.min_f(s.max_f(ax, bx), s.max_f(ay, by)), s.max_f(az, bz));
                    let far = s.mul_f(far, s.splat_f(1.0 + 1e-6));
                    let meets = s.mask_and(
                        s.mask_and(open[v], s.cmp_le_f(near, far)),
                        s.mask_and(s.cmp_ge_f(far, zero), s.cmp_le_f(near, tm[v])),
                    );
                    if s.s_branch(meets.any()) {
                        kept |= 1 << v;
                    }
                }
                if s.s_branch(kept == 0) {
                    continue;
                }
                reach = kept;
            }
            if s.s_branch(s.s_read(&node.count) == 0) {
                // Nearer child (along the beam) popped first: occluders near the receiver end the
                // walk sooner.
                let (l, rr) = (node.first, node.first + 1);
                let dl = counted::dot(
                    s,
                    counted::sub(s, s.s_read(&self.nodes[l as usize].center), o),
                    axis,
                );
                let dr = counted::dot(
                    s,
                    counted::sub(s, s.s_read(&self.nodes[rr as usize].center), o),
                    axis,
                );
                if s.s_le(dl, dr) {
                    s.s_push(stack, (rr, reach));
                    s.s_push(stack, (l, reach));
                } else {
                    s.s_push(stack, (l, reach));
                    s.s_push(stack, (rr, reach));
                }
                continue;
            }
            let leaf = &self.triangles[node.first as usize..(node.first + node.count) as usize];
            s.scalar_read(leaf);
            for tri in leaf {
                // Counted: the triangle's four vectors' loads (their lines read with the leaf), the
                // loop's branch, the offset corner and the plane's distance.
                for _ in 0..4 {
                    s.scalar_op(ScalarClass::Mem);
                }
                s.scalar_op(ScalarClass::Branch);
                // obvhs' RtTriangle::intersect, lane-wise, the same operations in the same order.
                let c = counted::sub(s, Vec3::from(tri.v0), o);
                let (e1, e2, ng) = (Vec3::from(tri.e1), Vec3::from(tri.e2), Vec3::from(tri.ng));
                let ngc = s.splat_f(counted::dot(s, ng, c));
                let (cx, cy, cz) = (s.splat_f(c.x), s.splat_f(c.y), s.splat_f(c.z));
                for v in 0..vectors {
                    let m = open[v];
                    if s.s_branch(reach & (1 << v) == 0 || !m.any()) {
                        continue;
                    }
                    counts.triangle_vectors += 1;
                    let (x, y, z) = (dx[v], dy[v], dz[v]);
                    // r = d × c
                    let rx = s.sub_f(s.mul_f(y, cz), s.mul_f(z, cy));
                    let ry = s.sub_f(s.mul_f(z, cx), s.mul_f(x, cz));
                    let rz = s.sub_f(s.mul_f(x, cy), s.mul_f(y, cx));
                    let det = dot_sv(s, ng, x, y, z);
                    let inv_det = s.div_f(one, det);
                    let u = s.mul_f(dot_sv(s, e2, rx, ry, rz), inv_det);
                    let w_v = s.mul_f(dot_sv(s, e1, rx, ry, rz), inv_det);
                    let w = s.sub_f(s.sub_f(one, u), w_v);
                    let signs = s.or_i(s.or_i(s.cast_f_i(u), s.cast_f_i(w_v)), s.cast_f_i(w));
                    let inside = s.mask_and(s.cmp_ge_i(signs, s.splat_i(0)), s.cmp_ne_f(inv_det, zero));
                    let t = s.mul_f(ngc, inv_det);
                    let hit = s.mask_and(
                        s.mask_and(m, inside),
                        s.mask_and(s.cmp_gt_f(t, zero), s.cmp_lt_f(t, tm[v])),
                    );
                    if s.s_branch(hit.any()) {
                        out[v] = s.mask_or(out[v], hit);
                        open[v] = s.mask_andn(hit, m);
                        if !open[v].any() {
                            open_vectors -= 1;
                            if open_vectors == 0 {
                                return counts;
                            }
                        }
                    }
                }
            }
        }
        counts
    }
}

/// `a · (x, y, z)` with `a` the same in every lane, summed as glam's `Vec3A::dot`: `(x + y) + z`.
#[inline(always)]
fn dot_sv<S: Simd>(s: S, a: Vec3, x: S::F32, y: S::F32, z: S::F32) -> S::F32 {
    s.add_f(
        s.add_f(s.mul_f(s.splat_f(a.x), x), s.mul_f(s.splat_f(a.y), y)),
        s.mul_f(s.splat_f(a.z), z),
    )
}

/// The beam's `VECTORS` arrays of 16 lanes as registers (a loop, not `array::map`: see
/// [`Beam::cone`]).
#[inline(always)]
fn registers<S: Simd>(s: S, a: &[[f32; 16]; VECTORS]) -> [S::F32; VECTORS] {
    let mut r = [s.splat_f(0.0); VECTORS];
    for (r, a) in r.iter_mut().zip(a) {
        *r = s.from_array_f(*a);
    }
    r
}
