//! Penumbra occlusion kernel: the signed, clipped circle-segment term of paper Eq. 3.
//!
//! # What is computed
//!
//! A receiver sample `p` sees the spherical light (centre `c`, radius `r > 0`) as the disk of radius
//! `r` centred at `c` and perpendicular to `n = c - p` (CONTRACTS.md, *Visibility*). Everything here
//! works in coordinates **relative to the light centre** (`c` = origin): the caller subtracts `c`
//! once, in f64 or at least before the differences get small, so that f32 keeps its digits where
//! they matter (the geometry between the receiver and the light, not the world origin).
//!
//! For one sample `p` and one silhouette edge `(a, b)` the signed penumbra term is
//!
//! 1. **Slab clip.** With `D = |n|`, `n̂ = n / D` and heights `h(x) = (x - p)·n̂` (0 at the
//!    receiver, `D` at the light plane), only the part of the segment `a → b` with
//!    `h ∈ [h_min, D]`, `h_min = `[`H_MIN_FRACTION`]` · D`, is kept: geometry behind the receiver or
//!    beyond the light plane cannot occlude. Nothing left → 0.
//! 2. **Projection** of the clipped segment from `p` onto the light plane, scaled by `1/r`, so that
//!    the light disk is the unit circle at the origin.
//! 3. **Eq. 3** (EQ3-NOTES.md): `d` = distance from the origin to the projected line, positions
//!    along the line measured from the foot of the perpendicular, clipped to the chord
//!    `[-√(1-d²), +√(1-d²)]` → `lo < hi`; nothing left or `d ≥ 1` → 0. Then
//!    `θ = atan2(d·(hi-lo), lo·hi + d²)` (the angle the clipped segment subtends at the origin;
//!    atan2 of cross and dot keeps its relative accuracy near 0 and π where `acos` loses digits) and
//!    `T = (θ - d·(hi-lo)) / (2π) ∈ [0, 1/2]`: the part of the disk inside the wedge from the
//!    origin through the clipped segment and beyond it (sector minus triangle, over the disk area).
//! 4. **Sign** per adjacent counted triangle `k` (third vertex `v3[k]`): with
//!    `m = (a - p) × (b - p)`, the light centre's side `sc = m·(c - p)` and the triangle's interior
//!    side `s3 = m·(v3[k] - p)`: same sign (the interior faces the light centre) → **subtract**
//!    `T`, opposite signs → **add** `T`; `s3 == 0` (triangle seen edge-on from `p`: it covers no
//!    area) → 0; `sc == 0` (the edge's line meets the light centre, `d = 0`) counts as positive, so
//!    that two triangles on opposite sides still cancel. The record's value is `Σ_k sign_k · T`,
//!    in `[-n_tri/2, +n_tri/2]`: a fold edge with both triangles on the same side counts twice, a
//!    boundary edge (`n_tri = 1`) once, an edge between triangles on opposite sides (not a
//!    silhouette as seen from `p`) not at all.
//!
//! Summed over the edges of an occluder polygon, plus 1 when the segment `p → c` crosses it (the
//! umbra test, done by the umbra stage), this is that occluder's covered fraction of the light disk,
//! exactly (any polygon, vertices inside or outside the disk; see [`triangle_coverage_f64`] and the
//! Monte Carlo checks in `tests/occlusion_stress.rs`) — as long as the occluder lies between
//! `h_min` and the light plane. Parts behind `h_min` project outside the disk except in the
//! degenerate case of geometry touching the receiver; parts beyond the light plane are dropped
//! without the clip edge a polygon clip would add (an occluder crossing the light's plane
//! intersects the light itself). The caller composes `V = 1 - clamp01(umbra + Σ terms)` (Eq. 4).
//!
//! # How the vector kernel evaluates it
//!
//! The kernel never forms the projected points (they blow up like `D / h` near the receiver).
//! The projected line is the light plane cut by the plane through `p`, `a`, `b` (normal `m`); with
//! `g = n̂ × m` (the line's direction, `|g| = |m⊥|`):
//!
//! * `d = |sc| / (r·|g|)` with `sc = m·(c - p) = -(m·p)` (the same quantity that decides the
//!   sign; using the exact `-p` instead of the rounded `n̂` keeps its relative accuracy when the
//!   line passes close to the light centre),
//! * position of a point `x` of the segment along the line: `s(x) = ((x-p)·g) / (r·|g|) · D/h(x)`,
//!   a projective function of the segment parameter, so clipping in height is exact: the clipped
//!   endpoint at height `H` has `G = (x-p)·g` interpolated linearly in `H`.
//!
//! `m` is computed with Kahan's FMA difference of products (error ~1 ulp of each component
//! however much cancels): edges whose line passes near `p` make `a - p` and `b - p` nearly
//! parallel, and `m`'s direction is what places the projected line. Quantities are ratios in which
//! the length scale cancels; with a unit `n̂` the largest intermediate is `|g|² ~ L⁴`, so
//! coordinates up to ~1e9 stay in f32 range. Degenerate inputs (zero-length edges, edges whose
//! line passes through `p`, `p` at the light centre, edges in the receiver's own light-parallel
//! plane) make `|g| = 0` or `d` infinite/NaN and are rejected by the ordered test `d < 1`; every
//! surviving lane has a finite `1/(r|g|)`, `D/H ≤ 1/H_MIN_FRACTION`, and the positions are formed
//! as `(G/(r|g|))·(D/H)`, never `0·∞`, so no NaN or ∞ can reach the result. A segment that only
//! touches the slab (both ends clamped to the same bound) is a point and gives 0. `T` is clamped
//! to `[0, 1/2]` against rounding.
//!
//! **Accuracy** (tests/occlusion_stress.rs, 1.05 million configurations): against the f64 oracle
//! on the same f32 inputs, max error 1.2e-5 over well-conditioned configurations (asserted ≤ 1e-4);
//! ill-conditioned ones (the answer jumps: line through the light centre, `v3` in the plane,
//! sliver segments at the centre) stay within the range the oracle takes over 8-ulp input
//! perturbations. Where one f32 quantum of the coordinates moves the projected edge by more than
//! ~2% of the disk (light image tiny against the coordinates' magnitude), the f32 inputs do not
//! determine the term; it is still finite and within bounds.
//!
//! The f64 oracle [`edge_term_f64`] is written independently, literally as steps 1–4 (clip in 3D,
//! project the points, 2-D coordinates in an orthonormal basis of the light plane). The scalar f32
//! reference [`edge_term_scalar`] performs exactly the vector kernel's operation sequence (FMAs,
//! atan2 polynomial, x86 min/max rules) and matches it **bit for bit** on every backend.
//!
//! Cost per 16 samples and edge (counting context, inside [`AccumulateEdgeTerms`]): 157 vector
//! instructions for `n_tri = 1`, 169 for `n_tri = 2`, of which 8 are long-latency (5 divisions, one
//! inside `atan2_f`, and 3 square roots). Measured throughput (benches/occlusion.rs, 2-core
//! AVX-512 machine under load): ~260 M edge terms/s on AVX-512, ~32 M/s portable-avx2, ~6 M/s
//! portable baseline, ~7 M/s for the scalar reference.

use sism_simd::{Kernel, Mask16, Simd};

/// `h_min / D`: the part of an edge closer to the receiver's light-parallel plane than this
/// fraction of the receiver–light distance is clipped away (its projection is `≥ 1e5` times larger
/// than the geometry, outside the light disk unless the geometry touches the receiver).
pub const H_MIN_FRACTION: f32 = 1e-5;

/// `1 / (2π)`: converts sector-minus-triangle areas of the unit disk (area π, halved areas) to
/// fractions of the disk.
const INV_2PI: f32 = 0.159_154_94;

/// A receiver within this angle (radians, as a sine, seen from the edge's first endpoint) of an
/// adjacent triangle's plane sees that triangle edge-on: it covers no area and contributes 0.
/// `s3 = m·(v3 - p) = ±n·(p - a)` with `n = (b - a) × (v3 - a)`, so the test is
/// `|s3| ≤ sin |n| |p - a|` (unsquared: s3 reaches 1e24 at the stress suite's coordinates). Without it, a receiver on the triangle's own plane (on a face next
/// to its own silhouette edge) gets a sign decided by rounding noise.
pub const EDGE_ON_SINE: f32 = 1e-4;

/// One silhouette edge as the penumbra stage hands it to the kernel, **relative to the light
/// centre** (world units).
///
/// `v3[k]` for `k < n_tri` is the third vertex of the `k`-th adjacent counted triangle (the
/// triangles whose outline contains the edge); `n_tri ∈ {1, 2}`, `v3[1]` is ignored when
/// `n_tri == 1`. See the module docs for the sign convention.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct EdgeRecord {
    /// First endpoint, relative to the light centre.
    pub a: [f32; 3],
    /// Second endpoint, relative to the light centre.
    pub b: [f32; 3],
    /// Third vertices of the adjacent counted triangles, relative to the light centre.
    pub v3: [[f32; 3]; 2],
    /// Number of adjacent counted triangles, 1 or 2 (other values are treated as 2 if > 1 and
    /// give 0 if 0).
    pub n_tri: u32,
}

impl EdgeRecord {
    /// 32-bit words per record.
    pub const WORDS: usize = std::mem::size_of::<EdgeRecord>() / 4;

    /// `edges` as one flat slice of 32-bit words read as `f32` (only the coordinates should be read
    /// from it; `a` is words 0..3, `b` words 3..6), for gathers of 16 records' endpoints.
    pub fn words(edges: &[EdgeRecord]) -> &[f32] {
        const _: () = assert!(
            std::mem::size_of::<EdgeRecord>() == 52 && std::mem::align_of::<EdgeRecord>() == 4,
            "EdgeRecord is thirteen 4-byte words without padding"
        );
        // SAFETY: `EdgeRecord` is `repr(C)` of f32 arrays and a u32, 52 bytes with no padding
        // (checked above), so `len` records are `13 * len` initialised, 4-aligned words; every bit
        // pattern is a valid `f32`.
        unsafe { std::slice::from_raw_parts(edges.as_ptr().cast::<f32>(), edges.len() * Self::WORDS) }
    }

    /// An edge with one adjacent triangle (third vertex `v3`): an ordinary silhouette or a
    /// boundary edge.
    pub fn single(a: [f32; 3], b: [f32; 3], v3: [f32; 3]) -> Self {
        EdgeRecord {
            a,
            b,
            v3: [v3, v3],
            n_tri: 1,
        }
    }

    /// An edge shared by two counted triangles (third vertices `v3a`, `v3b`).
    pub fn pair(a: [f32; 3], b: [f32; 3], v3a: [f32; 3], v3b: [f32; 3]) -> Self {
        EdgeRecord {
            a,
            b,
            v3: [v3a, v3b],
            n_tri: 2,
        }
    }
}

/// [`EdgeRecord`] in f64, for the accuracy oracle [`edge_term_f64`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeRecordF64 {
    /// First endpoint, relative to the light centre.
    pub a: [f64; 3],
    /// Second endpoint, relative to the light centre.
    pub b: [f64; 3],
    /// Third vertices of the adjacent counted triangles.
    pub v3: [[f64; 3]; 2],
    /// Number of adjacent counted triangles (1 or 2).
    pub n_tri: u32,
}

impl From<&EdgeRecord> for EdgeRecordF64 {
    fn from(e: &EdgeRecord) -> Self {
        let w = |v: [f32; 3]| v.map(f64::from);
        EdgeRecordF64 {
            a: w(e.a),
            b: w(e.b),
            v3: [w(e.v3[0]), w(e.v3[1])],
            n_tri: e.n_tri,
        }
    }
}

impl From<EdgeRecord> for EdgeRecordF64 {
    fn from(e: EdgeRecord) -> Self {
        (&e).into()
    }
}

// ---------------------------------------------------------------------------------------------
// Vector kernel
// ---------------------------------------------------------------------------------------------

pub use crate::vmath::{cross3, dot3, V3};

/// `a·b - c·d` to within ~1 ulp of the result however much cancels (Kahan's FMA trick).
#[inline(always)]
fn diff_prod<S: Simd>(s: S, a: S::F32, b: S::F32, c: S::F32, d: S::F32) -> S::F32 {
    let w = s.mul_f(c, d);
    let err = s.fnmadd(c, d, w); // w - c·d, exact
    s.add_f(s.fmsub(a, b, w), err)
}

/// Cross product with every component from [`diff_prod`].
#[inline(always)]
fn cross3_acc<S: Simd>(s: S, a: V3<S>, b: V3<S>) -> V3<S> {
    [
        diff_prod(s, a[1], b[2], a[2], b[1]),
        diff_prod(s, a[2], b[0], a[0], b[2]),
        diff_prod(s, a[0], b[1], a[1], b[0]),
    ]
}

#[inline(always)]
fn rel<S: Simd>(s: S, x: [f32; 3], p: V3<S>) -> V3<S> {
    [
        s.sub_f(s.splat_f(x[0]), p[0]),
        s.sub_f(s.splat_f(x[1]), p[1]),
        s.sub_f(s.splat_f(x[2]), p[2]),
    ]
}

/// `|(b - a) × (v3 - a)|²`: the squared normal length of the triangle `(a, b, v3)`, f32, computed
/// the same way for every backend (a per-edge constant).
#[inline(always)]
fn plane_normal_len2(a: [f32; 3], b: [f32; 3], v3: [f32; 3]) -> f32 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let w = [v3[0] - a[0], v3[1] - a[1], v3[2] - a[2]];
    let n = [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ];
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
}

/// One edge seen from 16 samples: everything Eq. 3 and the light-point variant
/// (`sampled`) need, in the unit-disk coordinates of each sample's light footprint.
#[derive(Clone, Copy)]
pub struct EdgeFrame<S: Simd> {
    /// Lanes whose projected, clipped edge reaches into the disk (`d < 1`, `lo < hi`).
    pub valid: Mask16,
    /// Distance `d` from the disk centre to the projected edge line, in disk radii, `[0, 1)`.
    pub dist: S::F32,
    /// Clipped endpoint positions along the line (from the foot of the perpendicular, in disk radii,
    /// direction `g`), `-√(1-d²) ≤ lo < hi ≤ √(1-d²)`.
    pub lo: S::F32,
    /// Upper clipped endpoint position along the line, in disk radii (see `lo`).
    pub hi: S::F32,
    /// Unit normal of the light disk, from the sample towards the light centre.
    pub nh: V3<S>,
    /// The projected line's direction (world axes, unnormalised) and its length `|g|`.
    pub g: V3<S>,
    /// `|g|`, the length of `g`.
    pub gl: S::F32,
    /// `m·(c - p)`: on which side of the edge's plane the light centre lies (its sign puts the line on
    /// the `+f` side with `f = -sign(sc) · (g × n̂) / |g|`, `sc = 0` counting as positive).
    pub sc: S::F32,
    /// Inputs of the sign rule: the plane normal `m`, `a - p` and the sample position.
    mv: V3<S>,
    ea: V3<S>,
    p: V3<S>,
}

/// Steps 1–3 of the module docs up to the clipped positions: `None` when no lane of `m` sees the
/// edge inside its light disk. See [`edge_term`] for the parameters.
#[inline(always)]
pub fn edge_frame<S: Simd>(
    s: S,
    m: Mask16,
    px: S::F32,
    py: S::F32,
    pz: S::F32,
    e: &EdgeRecord,
    light_radius: f32,
) -> Option<EdgeFrame<S>> {
    let zero = s.splat_f(0.0);
    let one = s.splat_f(1.0);
    let p = [px, py, pz];
    // D = |c - p| and n̂ = (c - p) / D = p · (-1/D).
    let dd = s.sqrt_f(dot3(s, p, p));
    let minv = s.div_f(s.splat_f(-1.0), dd);
    let nh = [s.mul_f(px, minv), s.mul_f(py, minv), s.mul_f(pz, minv)];
    let ea = rel(s, e.a, p);
    let eb = rel(s, e.b, p);
    // Plane through p, a, b; its trace on the light plane is the projected edge line. `m` is
    // compensated (edges nearly through p make a - p and b - p nearly parallel) and `sc` uses the
    // exact `c - p = -p` rather than the rounded n̂: together they decide on which side of the
    // light centre a line passing close to it lies.
    let mv = cross3_acc(s, ea, eb);
    let sc = s.neg_f(dot3(s, p, mv));
    let g = cross3(s, nh, mv);
    let gl = s.sqrt_f(dot3(s, g, g));
    // Heights above the receiver and (unnormalised) positions along the line.
    let ha = dot3(s, ea, nh);
    let hb = dot3(s, eb, nh);
    let ga = dot3(s, ea, g);
    let gb = dot3(s, eb, g);
    // Slab clip h ∈ [h_min, D]: move each endpoint along the segment to the clamped height; G is
    // affine in h along the segment.
    let hmin = s.mul_f(dd, s.splat_f(H_MIN_FRACTION));
    let reach = s.mask_and(s.cmp_ge_f(s.max_f(ha, hb), hmin), s.cmp_le_f(s.min_f(ha, hb), dd));
    let hac = s.clamp_f(ha, hmin, dd);
    let hbc = s.clamp_f(hb, hmin, dd);
    let dh = s.sub_f(hb, ha);
    // dh == 0 with a clamped endpoint means both ends are outside the slab (masked by `reach`);
    // otherwise (H' - H) is 0 and any finite slope will do.
    let dh = s.select_f(s.cmp_eq_f(dh, zero), one, dh);
    let slope = s.div_f(s.sub_f(gb, ga), dh);
    let gac = s.fmadd(s.sub_f(hac, ha), slope, ga);
    let gbc = s.fmadd(s.sub_f(hbc, hb), slope, gb);
    // d = |sc| / (r |g|) and s(x) = (G / (r |g|)) · (D / H). In every lane that passes `d < 1`,
    // 1/(r|g|) is finite, and D/H ≤ 1/H_MIN_FRACTION, so no product below is 0 · ∞.
    let inv_rg = s.div_f(one, s.mul_f(s.splat_f(light_radius), gl));
    let dist = s.mul_f(s.abs_f(sc), inv_rg);
    let dhh = s.div_f(dd, s.mul_f(hac, hbc));
    let sa = s.mul_f(s.mul_f(gac, inv_rg), s.mul_f(hbc, dhh));
    let sb = s.mul_f(s.mul_f(gbc, inv_rg), s.mul_f(hac, dhh));
    // Chord clip.
    let chord = s.sqrt_f(s.max_f(s.fnmadd(dist, dist, one), zero));
    let nchord = s.neg_f(chord);
    let lo = s.clamp_f(s.min_f(sa, sb), nchord, chord);
    let hi = s.clamp_f(s.max_f(sa, sb), nchord, chord);
    // A segment that only touches the slab (both ends clamped to the same bound) is a point.
    let touches = s.mask_andn(s.cmp_eq_f(ha, hb), s.cmp_eq_f(hac, hbc));
    let valid = s.mask_and(
        s.mask_andn(touches, s.mask_and(m, reach)),
        s.mask_and(s.cmp_lt_f(dist, one), s.cmp_lt_f(lo, hi)),
    );
    if !s.s_branch(s.mask_any(valid)) || s.s_branch(e.n_tri == 0) {
        return None;
    }
    Some(EdgeFrame {
        valid,
        dist,
        lo,
        hi,
        nh,
        g,
        gl,
        sc,
        mv,
        ea,
        p,
    })
}

/// Step 4 of the module docs: `Σ_k sign_k · t` over the edge's adjacent counted triangles (subtract
/// where the triangle's interior faces the light centre, 0 where the sample sees it edge-on), for
/// every lane (callers mask with `f.valid`). With `t = 1` it is the edge's integer weight.
#[inline(always)]
pub fn signed_sum<S: Simd>(s: S, f: &EdgeFrame<S>, e: &EdgeRecord, t: S::F32) -> S::F32 {
    let zero = s.splat_f(0.0);
    let sc_pos = s.cmp_ge_f(f.sc, zero);
    let sc_neg = s.cmp_lt_f(f.sc, zero);
    let nt = s.neg_f(t);
    let mut acc = zero;
    let pa = s.sqrt_f(dot3(s, f.ea, f.ea));
    for v3 in &e.v3[..if e.n_tri > 1 { 2 } else { 1 }] {
        let v = rel(s, *v3, f.p);
        let s3 = dot3(s, f.mv, v);
        let tol = s.splat_f(EDGE_ON_SINE * plane_normal_len2(e.a, e.b, *v3).sqrt());
        let same = s.mask_or(
            s.mask_and(sc_pos, s.cmp_gt_f(s3, zero)),
            s.mask_and(sc_neg, s.cmp_lt_f(s3, zero)),
        );
        let signed = s.select_f(same, nt, t);
        // Edge-on: s3^2 <= sin^2 |m|^2 |v3 - p|^2.
        let edge_on = s.cmp_le_f(s.abs_f(s3), s.mul_f(tol, pa));
        let signed = s.select_f(edge_on, zero, signed);
        acc = s.add_f(acc, signed);
    }
    acc
}

/// Signed penumbra term of one edge for 16 samples at once.
///
/// `px, py, pz`: sample (receiver) positions relative to the light centre, world units, finite.
/// `e`: the edge, relative to the light centre. `light_radius`: `r > 0`, world units. Lanes
/// outside `m` return exactly `+0.0`; active lanes return `Σ_k sign_k · T ∈ [-n_tri/2, n_tri/2]`
/// (module docs), never NaN or ∞ for finite inputs. Bit-identical on every backend and to
/// [`edge_term_scalar`].
#[inline(always)]
pub fn edge_term<S: Simd>(
    s: S,
    m: Mask16,
    px: S::F32,
    py: S::F32,
    pz: S::F32,
    e: &EdgeRecord,
    light_radius: f32,
) -> S::F32 {
    let zero = s.splat_f(0.0);
    let Some(f) = edge_frame(s, m, px, py, pz, e, light_radius) else {
        return zero;
    };
    s.select_f(f.valid, signed_sum(s, &f, e, region_area(s, &f)), zero)
}

/// Eq. 3 proper: `T = (θ - d (hi - lo)) / 2π ∈ [0, 1/2]`, the share of the unit disk inside the wedge
/// through the clipped edge and beyond its line (unsigned; meaningful in `f.valid` lanes).
#[inline(always)]
pub fn region_area<S: Simd>(s: S, f: &EdgeFrame<S>) -> S::F32 {
    let w = s.sub_f(f.hi, f.lo);
    let dw = s.mul_f(f.dist, w);
    let theta = s.atan2_f(dw, s.fmadd(f.lo, f.hi, s.mul_f(f.dist, f.dist)));
    let t = s.mul_f(s.sub_f(theta, dw), s.splat_f(INV_2PI));
    s.clamp_f(t, s.splat_f(0.0), s.splat_f(0.5))
}

// ---------------------------------------------------------------------------------------------
// Scalar f32 mirror
// ---------------------------------------------------------------------------------------------

/// x86 `minps` rule, as [`Simd::min_f`].
#[inline(always)]
fn min1(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// x86 `maxps` rule, as [`Simd::max_f`].
#[inline(always)]
fn max1(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

#[inline(always)]
fn clamp1(x: f32, lo: f32, hi: f32) -> f32 {
    min1(max1(x, lo), hi)
}

#[inline(always)]
fn dot1(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

#[inline(always)]
fn cross1(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1].mul_add(b[2], -(a[2] * b[1])),
        a[2].mul_add(b[0], -(a[0] * b[2])),
        a[0].mul_add(b[1], -(a[1] * b[0])),
    ]
}

#[inline(always)]
fn diff_prod1(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let w = c * d;
    let err = (-c).mul_add(d, w);
    a.mul_add(b, -w) + err
}

#[inline(always)]
fn cross1_acc(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        diff_prod1(a[1], b[2], a[2], b[1]),
        diff_prod1(a[2], b[0], a[0], b[2]),
        diff_prod1(a[0], b[1], a[1], b[0]),
    ]
}

#[inline(always)]
fn rel1(x: [f32; 3], p: [f32; 3]) -> [f32; 3] {
    [x[0] - p[0], x[1] - p[1], x[2] - p[2]]
}

/// Scalar transcription of [`Simd::atan2_f`] (same reduction, polynomial, FMAs and fix-ups), so
/// that [`edge_term_scalar`] is bit-identical to the vector kernel.
fn atan2_mirror(y: f32, x: f32) -> f32 {
    use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    const TAN_PI_8: f32 = 0.414_213_57;
    let ax = x.abs();
    let ay = y.abs();
    let swap = ay > ax;
    let mn0 = if swap { ax } else { ay };
    let mx0 = if swap { ay } else { ax };
    let both_inf = mn0 == f32::INFINITY;
    let mn = if both_inf { 1.0 } else { mn0 };
    let mx = if both_inf { 1.0 } else { mx0 };
    let big = mn > mx * TAN_PI_8;
    let num = if big { mn - mx } else { mn };
    let den0 = if big { mn + mx } else { mx };
    let den = if den0 == 0.0 { 1.0 } else { den0 };
    let t = num / den;
    let base = if big { FRAC_PI_4 } else { 0.0 };
    let z = t * t;
    let mut p = 8.053_744_5e-2f32;
    p = p.mul_add(z, -1.387_768_6e-1);
    p = p.mul_add(z, 1.997_771_1e-1);
    p = p.mul_add(z, -3.333_295e-1);
    let tz = t * z;
    let r0 = base + tz.mul_add(p, t);
    let r1 = if swap { FRAC_PI_2 - r0 } else { r0 };
    let r2 = if (x.to_bits() as i32) < 0 { PI - r1 } else { r1 };
    f32::from_bits(r2.to_bits() ^ (y.to_bits() & 0x8000_0000))
}

/// Scalar f32 reference of [`edge_term`] for one sample `p` (relative to the light centre):
/// the same operation sequence, bit for bit (for tests, and for odd samples outside a vector).
/// Returns `Σ_k sign_k · T ∈ [-n_tri/2, n_tri/2]`, 0 when the edge cannot occlude.
pub fn edge_term_scalar(p: [f32; 3], e: &EdgeRecord, light_radius: f32) -> f32 {
    let dd = dot1(p, p).sqrt();
    let minv = -1.0 / dd;
    let nh = p.map(|c| c * minv);
    let ea = rel1(e.a, p);
    let eb = rel1(e.b, p);
    let mv = cross1_acc(ea, eb);
    let sc = -dot1(p, mv);
    let g = cross1(nh, mv);
    let gl = dot1(g, g).sqrt();
    let ha = dot1(ea, nh);
    let hb = dot1(eb, nh);
    let ga = dot1(ea, g);
    let gb = dot1(eb, g);
    let hmin = dd * H_MIN_FRACTION;
    let reach = max1(ha, hb) >= hmin && min1(ha, hb) <= dd;
    let hac = clamp1(ha, hmin, dd);
    let hbc = clamp1(hb, hmin, dd);
    let dh = hb - ha;
    let dh = if dh == 0.0 { 1.0 } else { dh };
    let slope = (gb - ga) / dh;
    let gac = (hac - ha).mul_add(slope, ga);
    let gbc = (hbc - hb).mul_add(slope, gb);
    let inv_rg = 1.0 / (light_radius * gl);
    let dist = sc.abs() * inv_rg;
    let dhh = dd / (hac * hbc);
    let sa = (gac * inv_rg) * (hbc * dhh);
    let sb = (gbc * inv_rg) * (hac * dhh);
    let chord = max1((-dist).mul_add(dist, 1.0), 0.0).sqrt();
    let lo = clamp1(min1(sa, sb), -chord, chord);
    let hi = clamp1(max1(sa, sb), -chord, chord);
    let touches = hac == hbc && ha != hb;
    if !(reach && !touches && dist < 1.0 && lo < hi) || e.n_tri == 0 {
        return 0.0;
    }
    let w = hi - lo;
    let dw = dist * w;
    let theta = atan2_mirror(dw, lo.mul_add(hi, dist * dist));
    let t = clamp1((theta - dw) * INV_2PI, 0.0, 0.5);
    let mut acc = 0.0f32;
    let pa = dot1(ea, ea).sqrt();
    for v3 in &e.v3[..if e.n_tri > 1 { 2 } else { 1 }] {
        let v = rel1(*v3, p);
        let s3 = dot1(mv, v);
        let same = (sc >= 0.0 && s3 > 0.0) || (sc < 0.0 && s3 < 0.0);
        let tol = EDGE_ON_SINE * plane_normal_len2(e.a, e.b, *v3).sqrt();
        let signed = if s3.abs() <= tol * pa {
            0.0
        } else if same {
            -t
        } else {
            t
        };
        acc += signed;
    }
    acc
}

// ---------------------------------------------------------------------------------------------
// f64 oracle: the definition, step by step
// ---------------------------------------------------------------------------------------------

type D3 = [f64; 3];

fn sub64(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot64(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross64(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn scale64(a: D3, k: f64) -> D3 {
    a.map(|c| c * k)
}
fn lerp64(a: D3, b: D3, t: f64) -> D3 {
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
    ]
}

/// An orthonormal basis `(u1, u2)` of the plane perpendicular to the unit vector `n`.
fn plane_basis64(n: D3) -> (D3, D3) {
    let helper = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u1 = cross64(n, helper);
    let u1 = scale64(u1, 1.0 / dot64(u1, u1).sqrt());
    (u1, cross64(n, u1))
}

/// Unsigned wedge term `T ∈ [0, 1/2]` of the segment `a → b` (clipped and projected from `p`),
/// f64, literally steps 1–3 of the module docs.
fn wedge_f64(p: D3, a: D3, b: D3, r: f64) -> f64 {
    let n = scale64(p, -1.0);
    let dd = dot64(n, n).sqrt();
    if !(dd > 0.0 && r > 0.0) {
        return 0.0;
    }
    let nh = scale64(n, 1.0 / dd);
    let h = |x: D3| dot64(sub64(x, p), nh);
    let hmin = f64::from(H_MIN_FRACTION) * dd;
    // 1. Slab clip in the segment parameter.
    let (ha, hb) = (h(a), h(b));
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let dh = hb - ha;
    if dh == 0.0 {
        if ha < hmin || ha > dd {
            return 0.0;
        }
    } else {
        let ta = (hmin - ha) / dh;
        let tb = (dd - ha) / dh;
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
        if t0 > t1 {
            return 0.0;
        }
    }
    // 2. Project the clipped endpoints from p onto the light plane, relative to c, over r.
    let proj = |t: f64| {
        let x = lerp64(a, b, t);
        let hx = h(x).max(hmin); // h(x) ≥ hmin up to rounding after the clip
        let e = sub64(x, p);
        let y = [
            p[0] + e[0] * (dd / hx),
            p[1] + e[1] * (dd / hx),
            p[2] + e[2] * (dd / hx),
        ];
        scale64(y, 1.0 / r)
    };
    let (u1, u2) = plane_basis64(nh);
    let (pa, pb) = (proj(t0), proj(t1));
    let a2 = [dot64(pa, u1), dot64(pa, u2)];
    let b2 = [dot64(pb, u1), dot64(pb, u2)];
    // 3. Eq. 3 on the unit disk.
    let dir = [b2[0] - a2[0], b2[1] - a2[1]];
    let len = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        return 0.0; // point-like projection: no area
    }
    let u = [dir[0] / len, dir[1] / len];
    let d = (a2[0] * u[1] - a2[1] * u[0]).abs();
    if d >= 1.0 {
        return 0.0;
    }
    let sa = a2[0] * u[0] + a2[1] * u[1];
    let sb = sa + len;
    let chord = (1.0 - d * d).sqrt();
    let lo = sa.max(-chord);
    let hi = sb.min(chord);
    if lo >= hi {
        return 0.0;
    }
    let theta = (d * (hi - lo)).atan2(lo * hi + d * d);
    ((theta - d * (hi - lo)) / (2.0 * core::f64::consts::PI)).clamp(0.0, 0.5)
}

/// Sign of adjacent triangle `v3` for the edge `(a, b)` seen from `p` (module docs, step 4):
/// -1 (interior faces the light centre), 0 (edge-on), +1.
fn tri_sign64(p: D3, a: D3, b: D3, v3: D3) -> f64 {
    let m = cross64(sub64(a, p), sub64(b, p));
    let sc = dot64(m, scale64(p, -1.0));
    let s3 = dot64(m, sub64(v3, p));
    let n = cross64(sub64(b, a), sub64(v3, a));
    let pa = sub64(p, a);
    let tol = EDGE_ON_SINE as f64;
    if s3.abs() <= tol * dot64(n, n).sqrt() * dot64(pa, pa).sqrt() {
        0.0
    } else if (sc >= 0.0 && s3 > 0.0) || (sc < 0.0 && s3 < 0.0) {
        -1.0
    } else {
        1.0
    }
}

/// f64 evaluation of the signed term of [`edge_term`] (the accuracy oracle), written directly
/// from the definition: clip the segment in 3-D, project its endpoints, work in 2-D coordinates of
/// the light plane. `p` and `e` relative to the light centre, `light_radius > 0` (else 0).
pub fn edge_term_f64(p: [f64; 3], e: &EdgeRecordF64, light_radius: f64) -> f64 {
    let n = e.n_tri.min(2) as usize;
    if n == 0 {
        return 0.0;
    }
    let t = wedge_f64(p, e.a, e.b, light_radius);
    if t == 0.0 {
        return 0.0;
    }
    e.v3[..n].iter().map(|&v3| tri_sign64(p, e.a, e.b, v3) * t).sum()
}

/// Does the segment from `p` to the light centre (the origin) cross triangle `tri`? The umbra
/// indicator, f64 Möller–Trumbore with closed boundaries (parameter and barycentrics `≥ 0`).
pub fn umbra_indicator_f64(p: [f64; 3], tri: &[[f64; 3]; 3]) -> bool {
    let dir = scale64(p, -1.0);
    let e1 = sub64(tri[1], tri[0]);
    let e2 = sub64(tri[2], tri[0]);
    let pv = cross64(dir, e2);
    let det = dot64(e1, pv);
    if det == 0.0 {
        return false;
    }
    let inv = 1.0 / det;
    let tv = sub64(p, tri[0]);
    let u = dot64(tv, pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let qv = cross64(tv, e1);
    let v = dot64(dir, qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let t = dot64(e2, qv) * inv;
    (0.0..=1.0).contains(&t)
}

/// Covered fraction of the light disk by one triangle, f64: umbra indicator plus the signed terms
/// of its three edges (each with `n_tri = 1` and the opposite vertex as `v3`). Exact for
/// triangles between `h_min` and the light plane; in `[0, 1]` up to rounding.
pub fn triangle_coverage_f64(p: [f64; 3], tri: &[[f64; 3]; 3], light_radius: f64) -> f64 {
    let mut c = if umbra_indicator_f64(p, tri) { 1.0 } else { 0.0 };
    for i in 0..3 {
        let e = EdgeRecordF64 {
            a: tri[i],
            b: tri[(i + 1) % 3],
            v3: [tri[(i + 2) % 3]; 2],
            n_tri: 1,
        };
        c += edge_term_f64(p, &e, light_radius);
    }
    c
}

/// [`triangle_coverage_f64`] with the f32 scalar kernel for the three edge terms (the umbra
/// indicator is still evaluated in f64 from the f32 inputs).
pub fn triangle_coverage_f32(p: [f32; 3], tri: &[[f32; 3]; 3], light_radius: f32) -> f32 {
    let w = |v: [f32; 3]| v.map(f64::from);
    let mut c = if umbra_indicator_f64(w(p), &tri.map(w)) {
        1.0
    } else {
        0.0
    };
    for i in 0..3 {
        let e = EdgeRecord::single(tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]);
        c += edge_term_scalar(p, &e, light_radius);
    }
    c
}

// ---------------------------------------------------------------------------------------------
// Penumbra-quad width
// ---------------------------------------------------------------------------------------------

/// Half-width, in light-view image-plane units (image plane at distance 1 from the light centre),
/// of the band around an edge's image that contains every receiver the edge can shade:
/// `r · (1/z_edge_min - 1/z_receiver_max)`, 0 if the edge is not in front of the receivers.
///
/// Derivation: a receiver at depth `z_p` on the view axis sees the light disk (radius `r`) through
/// the plane at depth `z_e` as a disk of radius `r (z_p - z_e) / z_p`, i.e. `r (1/z_e - 1/z_p)` in
/// the image plane; the bound is the maximum over `z_e ≥ z_edge_min`, `z_p ≤ z_receiver_max`.
/// Depths are light-view depths (distance along the view axis). It is exact on the view axis; off
/// axis (angle `α`) the image-plane metric is stretched by up to `1 / cos² α`, so a caller with a
/// wide light frustum should scale the result by `1 / cos² α_max` to stay conservative.
pub fn penumbra_half_width(light_radius: f32, z_edge_min: f32, z_receiver_max: f32) -> f32 {
    (light_radius * (1.0 / z_edge_min - 1.0 / z_receiver_max)).max(0.0)
}

// ---------------------------------------------------------------------------------------------
// A batch kernel (tests, benchmarks, simple callers)
// ---------------------------------------------------------------------------------------------

/// Sum of [`edge_term`] over `edges` for every sample: `out[i] = Σ_j edge_term(p_i, edges[j])`.
/// Samples are given as three coordinate arrays relative to the light centre (any length; the
/// tail vector is masked). One task of kind [`AccumulateEdgeTerms::TASK_KIND`].
pub struct AccumulateEdgeTerms<'a> {
    /// Sample x coordinates (relative to the light centre).
    pub xs: &'a [f32],
    /// Sample y coordinates.
    pub ys: &'a [f32],
    /// Sample z coordinates.
    pub zs: &'a [f32],
    /// The edges.
    pub edges: &'a [EdgeRecord],
    /// Light radius `r > 0`.
    pub light_radius: f32,
    /// Output, one sum per sample (overwritten).
    pub out: &'a mut [f32],
}

impl AccumulateEdgeTerms<'_> {
    /// Task kind recorded by the counting context.
    pub const TASK_KIND: u32 = 0x0CC1;
}

impl Kernel for AccumulateEdgeTerms<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        let n = self.xs.len();
        assert!(self.ys.len() == n && self.zs.len() == n && self.out.len() == n);
        s.begin_task(Self::TASK_KIND);
        let zero = s.splat_f(0.0);
        let mut i = 0;
        while i < n {
            let m = s.mask_first_n(n - i);
            let px = s.mask_load_f(zero, m, &self.xs[i..]);
            let py = s.mask_load_f(zero, m, &self.ys[i..]);
            let pz = s.mask_load_f(zero, m, &self.zs[i..]);
            let mut acc = zero;
            for e in self.edges {
                acc = s.add_f(acc, edge_term(s, m, px, py, pz, e, self.light_radius));
            }
            s.mask_store_f(&mut self.out[i..], m, acc);
            i += 16;
        }
        s.end_task();
    }
}
