//! The per-receiver visibility of the shadow-map family, as 16-wide kernels over a face's receivers:
//! the hard test, PCF and PCSS. Every map read is a gather; reads outside the map count as shadowed
//! (a black border, as the revectorization shaders have it; the maps' padding keeps filters of
//! receivers inside them).
//!
//! **Receiver-plane depth.** A filter tap away from the receiver's own map position compares the map
//! with the depth of the receiver's tangent plane along that tap's ray from the light (Isidoro 2006),
//! not with the receiver's own depth: otherwise a receiver seen at a grazing angle from the light
//! shadows itself in every tap that lands on its own surface nearer the light.

use glam::{Vec2, Vec3};
use sism_simd::{Kernel, Mask16, ScalarClass, Simd};

use super::depth_map::FaceMap;
use crate::algorithms::sism::grid::SampleIn;
use crate::counted;
use crate::exec::task_kind;
use crate::frame::Receiver;

/// Largest PCSS search or filter radius, texels: a blocker near the light would otherwise make the
/// search region the whole map.
pub const MAX_PCSS_RADIUS: f32 = 128.0;

/// What a lookup computes per receiver.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// The hard test at the receiver's texel.
    Hard,
    /// The hard test plus 2 where a 4-neighbour texel's test (same receiver depth) differs from it: the
    /// screen-space discontinuity flag of the adaptive method (RBSM-VISIBILITY.md §1, basic rule).
    /// Values 0–3.
    HardAndDiscontinuity,
    /// `-1` where the hard test lights the receiver, else the occluder distance: the receiver's view
    /// depth minus the depth the map holds at its texel, world units, `>= 0` (0 where the texel lies
    /// outside the map). The distance map of the contact-hardening methods.
    OccluderDistance,
    /// The mean of the hard tests over an `n × n` box of texels centred on the receiver's (`n` odd).
    Pcf {
        /// Box side, texels (odd).
        n: u32,
    },
    /// Percentage-closer soft shadows (Fernando 2005), see [`super`].
    Pcss {
        /// Light radius, world units.
        radius: f32,
        /// Blocker-search taps and filter taps, in the unit disk (or square), map-texel space.
        blocker: Vec<Vec2>,
        /// Filter taps, in the unit disk (or square), map-texel space.
        filter: Vec<Vec2>,
    },
}

/// Counters of one lookup task.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LookupCounts {
    /// Receivers looked up.
    pub fragments: u64,
    /// Map reads (taps), over all receivers.
    pub taps: u64,
    /// Receivers whose visibility differs from the plain hard test's.
    pub differs_from_hard: u64,
    /// PCSS: receivers whose blocker search found nothing (fully lit, no filter).
    pub no_blocker: u64,
}

impl std::ops::AddAssign for LookupCounts {
    fn add_assign(&mut self, o: Self) {
        self.fragments += o.fragments;
        self.taps += o.taps;
        self.differs_from_hard += o.differs_from_hard;
        self.no_blocker += o.no_blocker;
    }
}

/// One lookup task: `samples` of one face (relative to the light centre, plus `shift` to the map's
/// light point), their visibility written to `out`.
pub struct LookupTask<'a> {
    /// The face's depth map.
    pub map: &'a FaceMap,
    /// The frame's receivers (a sample's normal is its pixel's).
    pub receivers: &'a [Option<Receiver>],
    /// `light centre − map origin`: added to a sample's `q` for its position relative to the map's
    /// light point.
    pub shift: Vec3,
    /// The samples to look up, all of this face.
    pub samples: &'a [SampleIn],
    /// What to compute per sample.
    pub method: &'a Method,
    /// One output per sample of `samples`: the method's value (visibility for most methods).
    pub out: &'a mut [f32],
}

/// The map position and normalised depth of 16 receivers (lanes `m`), and the lanes in front of the
/// light point.
pub(crate) struct Projected<S: Simd> {
    /// Continuous map position, texels.
    pub tx: S::F32,
    pub ty: S::F32,
    /// Normalised depth.
    pub d: S::F32,
    /// Face coordinates of the receiver relative to the light point (world units); `z` is 1 on
    /// lanes not `valid`.
    pub x: S::F32,
    pub y: S::F32,
    pub z: S::F32,
    pub valid: Mask16,
    /// The receiver's tangent plane in face coordinates: normal `(nx, ny, nz)`, and `n · p` of its
    /// position `p` (relative to the light point).
    pub nx: S::F32,
    pub ny: S::F32,
    pub nz: S::F32,
    pub np: S::F32,
}

/// `a · (x, y, z)` for a broadcast `a`.
#[inline(always)]
fn dot_splat<S: Simd>(s: S, a: Vec3, x: S::F32, y: S::F32, z: S::F32) -> S::F32 {
    s.fmadd(
        s.splat_f(a.x),
        x,
        s.fmadd(s.splat_f(a.y), y, s.mul_f(s.splat_f(a.z), z)),
    )
}

#[inline(always)]
pub(crate) fn project<S: Simd>(
    s: S,
    map: &FaceMap,
    shift: Vec3,
    samples: &[SampleIn],
    receivers: &[Option<Receiver>],
    m: Mask16,
) -> Projected<S> {
    let mut q = [[0f32; 16]; 3];
    let mut nrm = [[0f32; 16]; 3];
    // Counted per lane (the transposition into lanes is scalar work): the loop's branch, the
    // sample's position and pixel (their lines read below with the samples), the shift, the
    // receiver's tag and normal (its line here), and the six stores into the lane arrays.
    for (lane, smp) in samples.iter().enumerate().take(16) {
        s.scalar_op(ScalarClass::Branch);
        s.scalar_op(ScalarClass::Mem);
        s.scalar_op(ScalarClass::Mem);
        let p = counted::add(s, smp.q, shift);
        q[0][lane] = p.x;
        q[1][lane] = p.y;
        q[2][lane] = p.z;
        let r = &receivers[smp.pixel as usize];
        s.scalar_read(std::slice::from_ref(r));
        s.scalar_op(ScalarClass::Mem);
        s.s_branch(r.is_some());
        let n = r.map_or(Vec3::ZERO, |r| {
            s.scalar_op(ScalarClass::Mem);
            r.normal
        });
        nrm[0][lane] = n.x;
        nrm[1][lane] = n.y;
        nrm[2][lane] = n.z;
        for _ in 0..6 {
            s.scalar_op(ScalarClass::Store);
        }
    }
    s.scalar_read(&samples[..samples.len().min(16)]);
    let (x, y, z) = (s.from_array_f(q[0]), s.from_array_f(q[1]), s.from_array_f(q[2]));
    let (wx, wy, wz) = (
        s.from_array_f(nrm[0]),
        s.from_array_f(nrm[1]),
        s.from_array_f(nrm[2]),
    );
    let f = &map.face;
    let (fx, fy, fz) = (
        dot_splat(s, f.right, x, y, z),
        dot_splat(s, f.up, x, y, z),
        dot_splat(s, f.axis, x, y, z),
    );
    let valid = s.mask_and(m, s.cmp_gt_f(fz, s.splat_f(0.0)));
    let safe_z = s.select_f(valid, fz, s.splat_f(1.0));
    let inv_z = s.div_f(s.splat_f(1.0), safe_z);
    let half = s.splat_f(0.5 * map.size as f32);
    let inv_extent = s.splat_f(1.0 / map.extent);
    let one = s.splat_f(1.0);
    let tx = s.mul_f(s.fmadd(s.mul_f(fx, inv_z), inv_extent, one), half);
    let ty = s.mul_f(s.fnmadd(s.mul_f(fy, inv_z), inv_extent, one), half);
    let d = s.mul_f(s.sub_f(safe_z, s.splat_f(map.z0)), s.splat_f(map.inv_range));
    let (nx, ny, nz) = (
        dot_splat(s, f.right, wx, wy, wz),
        dot_splat(s, f.up, wx, wy, wz),
        dot_splat(s, f.axis, wx, wy, wz),
    );
    let np = s.fmadd(nx, fx, s.fmadd(ny, fy, s.mul_f(nz, fz)));
    Projected {
        tx,
        ty,
        d,
        x: fx,
        y: fy,
        z: safe_z,
        valid,
        nx,
        ny,
        nz,
        np,
    }
}

/// The normalised depth of the receivers' tangent planes along the light's ray through map position
/// `(x, y)` (continuous texel coordinates); the receivers' own depth where that ray meets the plane
/// behind the light or almost along it.
#[inline(always)]
fn plane_depth<S: Simd>(s: S, map: &FaceMap, p: &Projected<S>, x: S::F32, y: S::F32) -> S::F32 {
    let one = s.splat_f(1.0);
    let scale = s.splat_f(2.0 * map.extent / map.size as f32);
    let e = s.splat_f(map.extent);
    // Image-plane position of the ray: u = (2x/size - 1) extent, v = (1 - 2y/size) extent.
    let u = s.fmsub(x, scale, e);
    let v = s.fnmadd(y, scale, e);
    let den = s.fmadd(p.nx, u, s.fmadd(p.ny, v, p.nz));
    let z = s.div_f(p.np, s.select_f(s.cmp_eq_f(den, s.splat_f(0.0)), one, den));
    // Usable where the ray meets the plane in front of the light and not beyond 4x the receiver's
    // own depth (a plane nearly along the ray).
    let ok = s.mask_and(
        s.cmp_gt_f(z, s.splat_f(0.0)),
        s.cmp_lt_f(z, s.mul_f(p.z, s.splat_f(4.0))),
    );
    let d = s.mul_f(s.sub_f(z, s.splat_f(map.z0)), s.splat_f(map.inv_range));
    s.select_f(ok, d, p.d)
}

/// The map's depth at texel `(ix, iy)` for lanes `m`: `-∞` (shadowed) outside the map; and the lanes
/// inside.
#[inline(always)]
fn fetch<S: Simd>(s: S, map: &FaceMap, m: Mask16, ix: S::I32, iy: S::I32) -> (S::F32, Mask16) {
    let n = s.splat_i(map.size as i32);
    let zero = s.splat_i(0);
    let inside = s.mask_and(
        m,
        s.mask_and(
            s.mask_and(s.cmp_ge_i(ix, zero), s.cmp_lt_i(ix, n)),
            s.mask_and(s.cmp_ge_i(iy, zero), s.cmp_lt_i(iy, n)),
        ),
    );
    let idx = s.add_i(s.mul_i(iy, n), ix);
    (
        s.mask_gather_f(s.splat_f(f32::NEG_INFINITY), inside, &map.depth, idx),
        inside,
    )
}

/// 1 where the receivers at depth `d` are lit by texel `(ix, iy)`, else 0.
#[inline(always)]
fn lit<S: Simd>(s: S, map: &FaceMap, m: Mask16, ix: S::I32, iy: S::I32, d: S::F32) -> S::F32 {
    let (depth, _) = fetch(s, map, m, ix, iy);
    s.select_f(s.cmp_le_f(d, depth), s.splat_f(1.0), s.splat_f(0.0))
}

impl Kernel for LookupTask<'_> {
    type Output = LookupCounts;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> LookupCounts {
        s.begin_task(task_kind::SHADOW_LOOKUP);
        let map = self.map;
        let mut c = LookupCounts::default();
        let (zero, one) = (s.splat_f(0.0), s.splat_f(1.0));
        let mut i = 0;
        // Counted scalar work beside `project`'s: the loop's compare and increment, the method's
        // branch and each tap loop's branch.
        while s.s_lt(i, self.samples.len()) {
            let m = s.mask_first_n(self.samples.len() - i);
            let p = project::<S>(s, map, self.shift, &self.samples[i..], self.receivers, m);
            s.scalar_op(ScalarClass::Branch);
            let (ix, iy) = (s.floor_i(p.tx), s.floor_i(p.ty));
            let hard = s.select_f(p.valid, lit(s, map, p.valid, ix, iy, p.d), zero);
            let lanes = s.mask_popcnt(m) as u64;
            c.fragments += lanes;
            let v = match self.method {
                Method::Hard => {
                    c.taps += lanes;
                    hard
                }
                Method::OccluderDistance => {
                    c.taps += lanes;
                    let (depth, _) = fetch(s, map, p.valid, ix, iy);
                    let dist = s.mul_f(s.sub_f(p.d, depth), s.splat_f(map.range()));
                    // Outside the map (depth −∞) or rounding: no usable distance.
                    let ok = s.mask_and(s.cmp_ge_f(dist, zero), s.cmp_lt_f(dist, s.splat_f(f32::INFINITY)));
                    let dist = s.select_f(ok, dist, zero);
                    s.select_f(s.cmp_gt_f(hard, zero), s.splat_f(-1.0), dist)
                }
                Method::HardAndDiscontinuity => {
                    c.taps += 5 * lanes;
                    let mut differ = zero;
                    for (dx, dy) in [(-1, 0), (1, 0), (0, 1), (0, -1)] {
                        s.scalar_op(ScalarClass::Branch);
                        let t = lit(
                            s,
                            map,
                            p.valid,
                            s.add_i(ix, s.splat_i(dx)),
                            s.add_i(iy, s.splat_i(dy)),
                            p.d,
                        );
                        differ = s.add_f(differ, s.abs_f(s.sub_f(t, hard)));
                    }
                    s.add_f(hard, s.select_f(s.cmp_gt_f(differ, zero), s.splat_f(2.0), zero))
                }
                Method::Pcf { n } => {
                    let h = (*n / 2) as i32;
                    let mut sum = zero;
                    for dy in -h..=h {
                        for dx in -h..=h {
                            s.scalar_op(ScalarClass::Branch);
                            // The tap's ray is the receiver's, moved by whole texels: the same
                            // place within its texel as the hard test's.
                            let d = if dx == 0 && dy == 0 {
                                p.d
                            } else {
                                let x = s.add_f(p.tx, s.splat_f(dx as f32));
                                let y = s.add_f(p.ty, s.splat_f(dy as f32));
                                plane_depth(s, map, &p, x, y)
                            };
                            let t = lit(
                                s,
                                map,
                                p.valid,
                                s.add_i(ix, s.splat_i(dx)),
                                s.add_i(iy, s.splat_i(dy)),
                                d,
                            );
                            sum = s.add_f(sum, t);
                        }
                    }
                    c.taps += lanes * (*n as u64 * *n as u64);
                    s.mul_f(sum, s.splat_f(1.0 / (*n * *n) as f32))
                }
                Method::Pcss {
                    radius,
                    blocker,
                    filter,
                } => {
                    let tpu = s.splat_f(map.texels_per_unit() * radius);
                    let max_r = s.splat_f(MAX_PCSS_RADIUS);
                    let inv_zr = s.div_f(one, p.z);
                    // Blocker search: a blocker at depth z covers the receiver's disk within
                    // r (1/z - 1/z_r) of its image-plane position; the nearest geometry bounds z.
                    let inv_near = s.splat_f(1.0 / map.z_min.max(map.z0 * 1e-4));
                    let rs = s.min_f(s.max_f(s.mul_f(tpu, s.sub_f(inv_near, inv_zr)), zero), max_r);
                    let (mut sum_z, mut count) = (zero, zero);
                    for t in blocker {
                        s.scalar_op(ScalarClass::Branch);
                        let (x, y) = (
                            s.fmadd(rs, s.splat_f(t.x), p.tx),
                            s.fmadd(rs, s.splat_f(t.y), p.ty),
                        );
                        let (depth, inside) = fetch(s, map, p.valid, s.floor_i(x), s.floor_i(y));
                        // A blocker is nearer than the receiver's plane along its ray; outside the map
                        // is no blocker here (its depth is unknown).
                        let d = plane_depth(s, map, &p, x, y);
                        let is = s.mask_and(inside, s.cmp_lt_f(depth, d));
                        let zb = s.fmadd(depth, s.splat_f(map.range()), s.splat_f(map.z0));
                        sum_z = s.select_f(is, s.add_f(sum_z, zb), sum_z);
                        count = s.select_f(is, s.add_f(count, one), count);
                    }
                    let found = s.mask_and(p.valid, s.cmp_gt_f(count, zero));
                    c.no_blocker += (s.mask_popcnt(p.valid) - s.mask_popcnt(found)) as u64;
                    c.taps +=
                        lanes * blocker.len() as u64 + s.mask_popcnt(found) as u64 * filter.len() as u64;
                    let mut v = s.select_f(p.valid, one, zero);
                    if s.s_branch(s.mask_any(found)) {
                        let z_avg = s.div_f(sum_z, s.select_f(found, count, one));
                        let z_avg = s.max_f(z_avg, s.splat_f(1e-30));
                        // Penumbra width w = r (z_r - z_b) / z_b at the receiver, r (1/z_b - 1/z_r)
                        // in the image plane.
                        let rf = s.min_f(
                            s.max_f(s.mul_f(tpu, s.sub_f(s.div_f(one, z_avg), inv_zr)), zero),
                            max_r,
                        );
                        let mut sum = zero;
                        for t in filter {
                            s.scalar_op(ScalarClass::Branch);
                            let (x, y) = (
                                s.fmadd(rf, s.splat_f(t.x), p.tx),
                                s.fmadd(rf, s.splat_f(t.y), p.ty),
                            );
                            let d = plane_depth(s, map, &p, x, y);
                            sum = s.add_f(sum, lit(s, map, found, s.floor_i(x), s.floor_i(y), d));
                        }
                        let pcss = s.mul_f(sum, s.splat_f(1.0 / filter.len() as f32));
                        v = s.select_f(found, pcss, v);
                    }
                    v
                }
            };
            let v = s.select_f(p.valid, v, zero);
            c.differs_from_hard += s.mask_popcnt(s.mask_and(m, s.cmp_ne_f(v, hard))) as u64;
            s.mask_store_f(&mut self.out[i..], m, v);
            i = s.s_add(i, 16);
        }
        s.end_task();
        c
    }
}

/// `n` points of the unit disk, evenly spread (best-candidate sampling, Mitchell 1991: each new point
/// the farthest of 32 random candidates from those chosen), the first at the centre; the same set on
/// every run.
pub fn poisson_disk(n: usize) -> Vec<Vec2> {
    let mut state = 0x243F_6A88_85A3_08D3u64;
    let mut next = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut pts = vec![Vec2::ZERO];
    while pts.len() < n {
        let mut best = (Vec2::ZERO, -1.0f32);
        for _ in 0..32 {
            let c = loop {
                let c = Vec2::new(2.0 * next() - 1.0, 2.0 * next() - 1.0);
                if c.length_squared() <= 1.0 {
                    break c;
                }
            };
            let dist = pts
                .iter()
                .map(|p| p.distance_squared(c))
                .fold(f32::INFINITY, f32::min);
            if dist > best.1 {
                best = (c, dist);
            }
        }
        pts.push(best.0);
    }
    pts.truncate(n);
    pts
}

/// `n` points on a regular `k × k` grid over `[-1, 1]²` (`k = ⌈√n⌉`; the first `n` in row order).
pub fn regular_grid(n: usize) -> Vec<Vec2> {
    let k = (n as f64).sqrt().ceil().max(1.0) as usize;
    (0..n)
        .map(|i| {
            let (a, b) = (i % k, i / k);
            Vec2::new(
                2.0 * (a as f32 + 0.5) / k as f32 - 1.0,
                2.0 * (b as f32 + 0.5) / k as f32 - 1.0,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_patterns_are_in_range_and_spread() {
        for n in [1, 16, 64] {
            let p = poisson_disk(n);
            assert_eq!(p.len(), n);
            assert!(p.iter().all(|q| q.length() <= 1.0));
            assert_eq!(p[0], Vec2::ZERO);
        }
        let p = poisson_disk(16);
        let min = (0..16)
            .flat_map(|i| (0..i).map(move |j| (i, j)))
            .map(|(i, j)| p[i].distance(p[j]))
            .fold(f32::INFINITY, f32::min);
        assert!(min > 0.25, "points clump: {min}");
        let g = regular_grid(9);
        assert_eq!(g.len(), 9);
        assert!(g.iter().all(|q| q.x.abs() < 1.0 && q.y.abs() < 1.0));
    }
}
