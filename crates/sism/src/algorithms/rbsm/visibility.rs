//! The revectorization visibility functions (Macedo and Apolinário 2016) exactly as
//! `../shared/docs/RBSM-VISIBILITY.md` states them, per fragment, over a depth map:
//!
//! * discontinuity detection and encoding (§1), with RSMSS's speck filter;
//! * ONDS traversal (§2) with `maxSearch` steps and the cumulative ε rule;
//! * `v_SMSR`, the **paper-era (Unoptimized)** version (§3: rules 1–6 with the corner dominance test);
//! * `v_RSMSS`, the **ReallyOptimized** version (§4: cases C1–C31, with its quirks kept as coded: the
//!   ±3 and −2 shifts, C12–C15's probes testing for umbra, the uncapped scans — except that C13's and
//!   C15's walks "until q is lit" stop at the first texel outside the map, which the document's rule
//!   (outside is shadowed) would never leave);
//! * RPCF (§5), the **2017 generalisation**: `(K + 1)²` taps at offsets `−P, −P + 2P/K, … ≤ P` texels
//!   (a float loop, as coded), the RSMSS taps with the speck filter.
//!
//! The shaders output `I + (1 − I) f` with an intensity `I` for shadow; that is a shading convention,
//! and sism's visibility is `f` itself (`I = 0`). Depths are the map's normalised depths (a face's
//! receivers span [0, 1]); ε is in the same unit. Reads outside the map are shadowed (the shaders'
//! black border: depth −∞ here). All arithmetic is f32, the ε decrements included.
//!
//! These are the scalar per-fragment functions the lookup kernel runs for the lanes that carry a
//! discontinuity; `tests/rbsm_oracle.rs` holds an independent transcription they are checked against.

use super::super::shadow_map::depth_map::{FaceMap, Lookup};
use sism_simd::ScalarClass;

/// Which visibility function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Function {
    /// `v_SMSR`, the paper-era (Unoptimized) version (§3).
    Smsr,
    /// `v_RSMSS`, the ReallyOptimized version (§4), with the speck filter.
    Rsmss,
}

/// The settings every function shares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Steps of an ONDS walk (the paper's maximum edge length), 1..=256.
    pub max_search: i32,
    /// The depth threshold of the sloped-surface rule, normalised depth.
    pub epsilon: f32,
}

/// A depth map as the functions read it: `D(x, y)`, −∞ outside.
pub trait DepthTexels {
    /// Depth of texel `(x, y)`, normalised; −∞ outside the map.
    fn depth(&self, x: i64, y: i64) -> f32;
    /// Is texel `(x, y)` inside the map?
    fn inside(&self, x: i64, y: i64) -> bool;
    /// Counts one scalar operation of `class` the functions executed (a counted map reports it to
    /// its SIMD context; a plain map ignores it).
    #[inline(always)]
    fn op(&self, class: ScalarClass) {
        let _ = class;
    }
    /// A conditional branch the functions executed on `taken`: a counted map counts it and has its
    /// SIMD context's branch predictor model predict it at the caller's site (so a walk's
    /// data-dependent tests cost what their mispredictions cost); returns `taken`.
    #[inline(always)]
    #[track_caller]
    fn branch(&self, taken: bool) -> bool {
        taken
    }
}

impl DepthTexels for FaceMap {
    #[inline]
    fn depth(&self, x: i64, y: i64) -> f32 {
        match self.at(x, y) {
            Lookup::Depth(d) => d,
            Lookup::Outside => f32::NEG_INFINITY,
        }
    }
    #[inline]
    fn inside(&self, x: i64, y: i64) -> bool {
        let n = self.size as i64;
        x >= 0 && y >= 0 && x < n && y < n
    }
}

/// The four neighbour offsets in the shaders' order: L, R, B (+v), T (−v).
const L: (i64, i64) = (-1, 0);
const R: (i64, i64) = (1, 0);
const B: (i64, i64) = (0, 1);
const T: (i64, i64) = (0, -1);

/// A fragment against one map: its texel, sub-texel position and depth.
struct Fragment<'m, M: DepthTexels> {
    map: &'m M,
    i: i64,
    j: i64,
    px: f32,
    py: f32,
    z: f32,
}

impl<M: DepthTexels> Fragment<'_, M> {
    /// The depth test of texel `(x, y)`: its address (two adds), the read, the compare and branch
    /// (predicted at the caller's site, as an inlined test is a branch of its own).
    #[inline]
    #[track_caller]
    fn lit_at(&self, x: i64, y: i64, z: f32) -> bool {
        self.map.op(ScalarClass::Alu);
        self.map.op(ScalarClass::Alu);
        self.map.branch(z <= self.map.depth(x, y))
    }
    /// A branch of the functions on `taken` (counted and predicted at the caller's site).
    #[inline]
    #[track_caller]
    fn br(&self, taken: bool) -> bool {
        self.map.branch(taken)
    }
    /// Is `z` within `epsilon` of texel `(x, y)`'s depth? The address, the read, a subtract, an
    /// absolute value, the compare and branch.
    #[inline]
    #[track_caller]
    fn near(&self, x: i64, y: i64, z: f32, epsilon: f32) -> bool {
        for _ in 0..4 {
            self.map.op(ScalarClass::Alu);
        }
        self.map.branch((z - self.map.depth(x, y)).abs() < epsilon)
    }
    /// One step of a walk or scan: the step count and two coordinates advanced, the loop's branch.
    #[inline]
    #[track_caller]
    fn step(&self, steps: &mut u32) {
        *steps += 1;
        for _ in 0..3 {
            self.map.op(ScalarClass::Alu);
        }
        // The loop's branch, taken back to the loop's top.
        self.map.branch(true);
    }
    /// `x` clamped to [0, 1] (a min and a max).
    #[inline]
    fn clamp01(&self, x: f32) -> f32 {
        self.map.op(ScalarClass::Alu);
        self.map.op(ScalarClass::Alu);
        clamp01(x)
    }
    #[inline]
    #[track_caller]
    fn shadowed(&self, x: i64, y: i64) -> bool {
        !self.lit_at(x, y, self.z)
    }
}

/// The discontinuity code of a fragment (§1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Code {
    /// `c`: the fragment's texel is lit.
    c: bool,
    /// `4 r = 2 d_L + d_R`, `4 g = 2 d_B + d_T`.
    rc: u8,
    gc: u8,
}

fn code<M: DepthTexels>(f: &Fragment<'_, M>, speck: bool) -> Code {
    let c = f.lit_at(f.i, f.j, f.z);
    let mut d = [false; 4];
    for (k, off) in [L, R, B, T].into_iter().enumerate() {
        let (x, y) = (f.i + off.0, f.j + off.1);
        let mut n = f.lit_at(x, y, f.z);
        if speck && n != c {
            // A neighbour that differs while all of its own neighbours agree with the fragment is a
            // single-texel speck: ignore it.
            let all_like_c = [L, R, B, T].iter().all(|m| f.lit_at(x + m.0, y + m.1, f.z) == c);
            if all_like_c {
                n = c;
            }
        }
        d[k] = n != c;
    }
    Code {
        c,
        rc: 2 * d[0] as u8 + d[1] as u8,
        gc: 2 * d[2] as u8 + d[3] as u8,
    }
}

/// Up to two flagged sides (no heap allocation: a walk runs per flagged fragment).
#[derive(Clone, Copy)]
struct Sides {
    side: [(i64, i64); 2],
    len: usize,
}

impl Sides {
    fn of(first: Option<(i64, i64)>, second: Option<(i64, i64)>) -> Sides {
        let mut v = Sides {
            side: [(0, 0); 2],
            len: 0,
        };
        for d in [first, second].into_iter().flatten() {
            v.side[v.len] = d;
            v.len += 1;
        }
        v
    }
    fn iter(&self) -> std::slice::Iter<'_, (i64, i64)> {
        self.side[..self.len].iter()
    }
}

/// The flagged sides, in the order L, R (horizontal flags) or B, T (vertical flags).
fn flags_x(rc: u8) -> Sides {
    Sides::of((rc >= 2).then_some(L), (rc == 1 || rc == 3).then_some(R))
}

fn flags_y(gc: u8) -> Sides {
    Sides::of((gc >= 2).then_some(B), (gc == 1 || gc == 3).then_some(T))
}

/// One ONDS walk (§2) from the fragment's texel in direction `dir`; returns α and adds the steps
/// taken to `steps`.
fn alpha<M: DepthTexels>(
    f: &Fragment<'_, M>,
    code: Code,
    dir: (i64, i64),
    function: Function,
    s: &Settings,
    steps: &mut u32,
) -> i32 {
    let vertical = dir.0 == 0;
    if vertical && code.rc == 0 && code.gc != 0 {
        return -1;
    }
    if !vertical && code.rc != 0 && code.gc == 0 {
        return -1;
    }
    let rsmss = function == Function::Rsmss;
    let entering = code.c; // b = 0
    let perpendicular = if vertical {
        flags_x(code.rc)
    } else {
        flags_y(code.gc)
    };
    let mut k = 1i32;
    let (mut tx, mut ty) = (f.i + dir.0, f.j + dir.1);
    let mut zz = f.z;
    for _ in 0..s.max_search {
        f.step(steps);
        if f.br(entering) && f.near(tx, ty, zz, s.epsilon) {
            zz -= s.epsilon;
        }
        let here = f.lit_at(tx, ty, zz);
        if here != code.c {
            if !rsmss {
                return k;
            }
            let agrees = [L, R, B, T]
                .iter()
                .any(|m| f.lit_at(tx + m.0, ty + m.1, zz) == here);
            return if agrees { k } else { -k };
        }
        let mut zl = zz;
        let mut keep = false;
        for m in perpendicular.iter() {
            if f.br(rsmss && !entering) && f.near(tx + m.0, ty + m.1, zl, s.epsilon) {
                zl -= s.epsilon;
            }
            if f.lit_at(tx + m.0, ty + m.1, zl) != code.c {
                keep = true;
                break;
            }
        }
        if !keep {
            return -k;
        }
        k += 1;
        tx += dir.0;
        ty += dir.1;
        if rsmss && !entering {
            zz = zl;
        }
    }
    -k
}

/// The normalised position on one axis from its two walks (§2).
fn normalise<M: DepthTexels>(f: &Fragment<'_, M>, a_minus: i32, a_plus: i32, p: f32, max_search: i32) -> f32 {
    // Counted as executed: the two tests, `lh` (two absolute values, an add, a subtract, a min, a
    // conversion), the choice of `po`, `d` (a max, a conversion, two divides, two adds) and the
    // last test with its multiply-add.
    let ops = |class: ScalarClass, n: usize| (0..n).for_each(|_| f.map.op(class));
    if f.br(a_minus < 0) && f.br(a_plus < 0) {
        return -1.0;
    }
    ops(ScalarClass::Alu, 6);
    let lh = ((a_minus.abs() + a_plus.abs() - 1).min(max_search)) as f32;
    ops(ScalarClass::Alu, 6);
    ops(ScalarClass::Div, 2);
    let po = if f.br(a_minus == a_plus) {
        p.min(1.0 - p)
    } else if f.br(a_minus > a_plus) {
        1.0 - p
    } else {
        p
    };
    let d = 1.0 - a_minus.max(a_plus) as f32 / lh + po / lh;
    if f.br(a_minus > 0) && f.br(a_plus > 0) {
        2.0 * d - 3.0
    } else {
        d
    }
}

#[inline]
fn clamp01(x: f32) -> f32 {
    x.clamp(0.0, 1.0)
}

/// `(nx, ny)` of a fragment: the horizontal walks give `nx`, the vertical ones `ny`.
fn onds<M: DepthTexels>(
    f: &Fragment<'_, M>,
    code: Code,
    function: Function,
    s: &Settings,
    steps: &mut u32,
) -> (f32, f32) {
    let left = alpha(f, code, (-1, 0), function, s, steps);
    let right = alpha(f, code, (1, 0), function, s, steps);
    let down = alpha(f, code, (0, -1), function, s, steps);
    let up = alpha(f, code, (0, 1), function, s, steps);
    (
        normalise(f, left, right, f.px, s.max_search),
        normalise(f, down, up, f.py, s.max_search),
    )
}

/// `δx`, `δy`: the distance from a single flagged side (0 when the flag is absent or dual).
fn deltas(f_px: f32, f_py: f32, code: Code) -> (f32, f32) {
    let dx = match code.rc {
        2 => f_px,
        1 => 1.0 - f_px,
        _ => 0.0,
    };
    let dy = match code.gc {
        2 => 1.0 - f_py,
        1 => f_py,
        _ => 0.0,
    };
    (dx, dy)
}

/// `v_SMSR`, paper era (§3). Returns `f`.
fn smsr<M: DepthTexels>(f: &Fragment<'_, M>, code: Code, s: &Settings, steps: &mut u32) -> f32 {
    if f.br(!code.c) {
        return 0.0;
    }
    if f.br(code.rc == 0 && code.gc == 0) {
        return 1.0;
    }
    let (nx, ny) = onds(f, code, Function::Smsr, s, steps);
    let (dx, dy) = deltas(f.px, f.py, code);
    if f.br(nx == -1.0 && ny == -1.0) {
        return 1.0;
    }
    if f.br(nx <= -2.0 || ny <= -2.0) {
        return 0.0;
    }
    if f.br(code.rc == 3 || code.gc == 3) {
        return 0.0;
    }
    let rule5 = if nx <= dy { 1.0 } else { 0.0 };
    let rule6 = if ny <= dx { 1.0 } else { 0.0 };
    if f.br(code.rc > 0 && code.gc > 0) {
        let qx = if code.rc == 2 {
            (f.i + 1, f.j)
        } else {
            (f.i - 1, f.j)
        };
        let h = f.shadowed(qx.0 + B.0, qx.1 + B.1) || f.shadowed(qx.0 + T.0, qx.1 + T.1);
        let qy = if code.gc == 2 {
            (f.i, f.j - 1)
        } else {
            (f.i, f.j + 1)
        };
        let v = f.shadowed(qy.0 + L.0, qy.1 + L.1) || f.shadowed(qy.0 + R.0, qy.1 + R.1);
        return match (h, v) {
            (true, false) | (false, false) => rule5,
            (false, true) => rule6,
            (true, true) => rule5.min(rule6),
        };
    }
    if f.br(code.gc > 0) {
        rule5
    } else {
        rule6
    }
}

/// `v_RSMSS`, ReallyOptimized (§4). Returns `f`.
fn rsmss<M: DepthTexels>(f: &Fragment<'_, M>, code: Code, s: &Settings, steps: &mut u32) -> f32 {
    let (rc, gc) = (code.rc, code.gc);
    if f.br(rc == 0 && gc == 0) {
        return if code.c { 1.0 } else { 0.0 };
    }
    let b = if code.c { 0.0 } else { 1.0 };
    // C2/C3.
    if f.br(rc == 3 && gc == 3) {
        return b;
    }
    let (nx, ny) = onds(f, code, Function::Rsmss, s, steps);
    let (px, py) = (f.px, f.py);
    let (dx, dy) = deltas(px, py, code);
    let ay = if gc == 0 {
        f32::INFINITY
    } else if f.br(nx < -2.0) {
        dy
    } else {
        f.clamp01(1.0 + dy - nx)
    };
    let ax = if rc == 0 {
        f32::INFINITY
    } else if f.br(ny < -2.0) {
        dx
    } else {
        f.clamp01(1.0 + dx - ny)
    };
    let (i, j) = (f.i, f.j);
    if f.br(code.c) {
        // ---- Entering.
        if f.br(nx == -1.0 && ny == -1.0) {
            return 1.0; // C1
        }
        let mut start = (i, j);
        if f.br(nx <= -2.0 && ny <= -2.0 && rc != 0 && gc != 0 && (rc == 3 || gc == 3)) {
            // C5/C7.
            let sx = match rc {
                2 => 1,
                1 => -1,
                _ => 3,
            };
            let sy = match gc {
                2 => -1,
                1 => 1,
                _ => -3,
            };
            let q = (i + sx, j + sy);
            let umbra_both = if rc == 3 {
                f.shadowed(q.0 - 1, q.1) && f.shadowed(q.0 + 1, q.1)
            } else {
                f.shadowed(q.0, q.1 + 1) && f.shadowed(q.0, q.1 - 1)
            };
            if f.br(umbra_both) {
                let (nxp, nyp) = ((nx + 4.0) / 2.0, (ny + 4.0) / 2.0);
                return if rc == 3 {
                    f.clamp01(px - nyp + 1.0).min(f.clamp01(2.0 - px - nyp)).min(py)
                } else {
                    f.clamp01(py - nxp + 1.0).min(f.clamp01(2.0 - py - nxp)).min(px)
                };
            }
            start = q; // fall through to C8/C10 from q
        }
        if f.br(gc == 3 && (rc == 1 || rc == 2)) {
            // C8/C10, g dual.
            let step = if rc == 2 { (1, 0) } else { (-1, 0) };
            let mut q = start;
            let (mut pb, mut nt);
            loop {
                q = (q.0 + step.0, q.1 + step.1);
                f.step(steps);
                pb = f.shadowed(q.0 + B.0, q.1 + B.1);
                nt = f.shadowed(q.0 + T.0, q.1 + T.1);
                if f.br(!(pb && nt)) || f.shadowed(q.0, q.1) {
                    break;
                }
            }
            return if !pb && !nt {
                f.clamp01(1.0 - nx)
            } else {
                let a = if pb { f.clamp01(2.0 - py - nx) } else { dx };
                let c = if nt { f.clamp01(1.0 + py - nx) } else { dx };
                a.min(c)
            };
        }
        if f.br(rc == 3 && (gc == 1 || gc == 2)) {
            // C8/C10, r dual.
            let step = if gc == 2 { (0, -1) } else { (0, -2) };
            let mut q = start;
            let (mut pl, mut nr);
            loop {
                q = (q.0 + step.0, q.1 + step.1);
                f.step(steps);
                pl = f.shadowed(q.0 + L.0, q.1 + L.1);
                nr = f.shadowed(q.0 + R.0, q.1 + R.1);
                if f.br(!(pl && nr)) || f.shadowed(q.0, q.1) {
                    break;
                }
            }
            return if !pl && !nr {
                f.clamp01(1.0 - ny)
            } else {
                let a = if nr { f.clamp01(2.0 - px - ny) } else { 1.0 - py };
                let c = if pl { f.clamp01(1.0 + px - ny) } else { 1.0 - py };
                a.min(c)
            };
        }
        if f.br(rc == 3 && gc == 0) {
            // C9/C11, a vertical corridor: walk ±v.
            let (lp, rp, lm, rm) = corridor(f, (0, 1), L, R, steps);
            return corridor_value(px, ny, lp, rp, lm, rm);
        }
        if f.br(gc == 3 && rc == 0) {
            // C9/C11 mirrored: walk ±u, T for L, B for R.
            let (tp, bp, tm, bm) = corridor(f, (1, 0), T, B, steps);
            return corridor_value(py, nx, tp, bp, tm, bm);
        }
        return ax.min(ay); // C16–C23
    }
    // ---- Exiting.
    let sigma_y = if gc == 1 { 1.0 - py } else { py };
    let sigma_x = if rc == 1 { px } else { 1.0 - px };
    let sel = |n: f32, a: f32, c: f32| if n < -2.0 { a } else { c };
    if f.br(rc == 3 && gc == 0) {
        // C12.
        let mut l = f.shadowed(i - 2, j);
        let mut r = f.shadowed(i + 2, j);
        if f.br(!l && !r) {
            let mut k = 1i64;
            loop {
                f.step(steps);
                let mut hit = false;
                for row in [j + k, j - k] {
                    l = f.shadowed(i - 1, row + 1) || f.shadowed(i - 1, row - 1);
                    r = f.shadowed(i + 1, row + 1) || f.shadowed(i + 1, row - 1);
                    if f.br(l || r) {
                        hit = true;
                        break;
                    }
                }
                if f.br(hit) {
                    break;
                }
                k += 1;
            }
        }
        return if l && r {
            f.clamp01(ny)
        } else if f.br(!l) {
            sel(ny, 1.0 - px, f.clamp01(ny - px))
        } else {
            sel(ny, px, f.clamp01(ny - 1.0 + px))
        };
    }
    if f.br(rc == 3) {
        // C13 (gc != 0).
        let dv = if gc == 2 { -1 } else { 1 };
        let mut q = (i, j + dv);
        let l = f.shadowed(q.0 - 1, q.1);
        let r = f.shadowed(q.0 + 1, q.1);
        if f.br(l && r) {
            return f.clamp01(ny);
        }
        if f.br(l != r) {
            let a = if l {
                sigma_y
            } else {
                sel(ny, 1.0 - px, f.clamp01(ny - px))
            };
            let c = if r {
                sigma_y
            } else {
                sel(ny, px, f.clamp01(ny - 1.0 + px))
            };
            return a.max(c);
        }
        // (Outside the map is shadowed, so a walk heading off it would never end: it stops at the
        // first texel outside, where it probes.)
        while f.shadowed(q.0, q.1) && f.map.inside(q.0, q.1) {
            f.step(steps);
            q.1 += dv;
        }
        let l = f.shadowed(i - 1, q.1 + 1) || f.shadowed(i - 1, q.1 - 1);
        let r = f.shadowed(i + 1, q.1 + 1) || f.shadowed(i + 1, q.1 - 1);
        return if l && r {
            f.clamp01(ny)
        } else {
            (if l { px } else { 1.0 - px }).max(sigma_y)
        };
    }
    if f.br(gc == 3 && rc == 0) {
        // C14.
        let mut t = f.shadowed(i - 1, j - 1) || f.shadowed(i + 1, j - 1);
        let mut bt = f.shadowed(i - 1, j + 1) || f.shadowed(i + 1, j + 1);
        if f.br(!t && !bt) {
            let mut k = 1i64;
            loop {
                f.step(steps);
                let mut hit = false;
                for col in [i + k, i - k] {
                    t = f.shadowed(col - 1, j - 1) || f.shadowed(col + 1, j - 1);
                    bt = f.shadowed(col - 1, j + 1) || f.shadowed(col + 1, j + 1);
                    if f.br(t || bt) {
                        hit = true;
                        break;
                    }
                }
                if f.br(hit) {
                    break;
                }
                k += 1;
            }
        }
        return if t && bt {
            f.clamp01(nx)
        } else if f.br(!t) {
            sel(nx, 1.0 - py, f.clamp01(nx - py))
        } else {
            sel(nx, py, f.clamp01(nx - 1.0 + py))
        };
    }
    if f.br(gc == 3) {
        // C15 (rc != 0).
        let du = if rc == 2 { 1 } else { -1 };
        let mut q = (i + du, j);
        let bt = f.shadowed(q.0, q.1 + 1);
        let t = f.shadowed(q.0, q.1 - 1);
        if f.br(bt && t) {
            return f.clamp01(nx);
        }
        if f.br(bt != t) {
            let a = if t {
                sigma_x
            } else {
                sel(nx, 1.0 - py, f.clamp01(nx - py))
            };
            let c = if bt {
                sigma_x
            } else {
                sel(nx, py, f.clamp01(nx - 1.0 + py))
            };
            return a.max(c);
        }
        while f.shadowed(q.0, q.1) && f.map.inside(q.0, q.1) {
            f.step(steps);
            q.0 += du;
        }
        let t = f.shadowed(q.0 - 1, j - 1) || f.shadowed(q.0 + 1, j - 1);
        let bt = f.shadowed(q.0 - 1, j + 1) || f.shadowed(q.0 + 1, j + 1);
        return if t && bt {
            f.clamp01(nx)
        } else {
            (if t { py } else { 1.0 - py }).max(sigma_x)
        };
    }
    1.0 - ax.min(ay) // C24–C31
}

/// The corridor walk of C9/C11 along `±axis` from the fragment's texel: the flags (`a` side, `b` side)
/// at the `+` end and the `−` end, a stopped side's flags true.
fn corridor<M: DepthTexels>(
    f: &Fragment<'_, M>,
    axis: (i64, i64),
    side_a: (i64, i64),
    side_b: (i64, i64),
    steps: &mut u32,
) -> (bool, bool, bool, bool) {
    let (mut ap, mut bp, mut am, mut bm) = (true, true, true, true);
    let (mut plus, mut minus) = ((f.i, f.j), (f.i, f.j));
    let (mut walk_plus, mut walk_minus) = (true, true);
    while ap && bp && am && bm && (walk_plus || walk_minus) {
        f.step(steps);
        if f.br(walk_plus) {
            plus = (plus.0 + axis.0, plus.1 + axis.1);
            if f.shadowed(plus.0, plus.1) {
                walk_plus = false;
                ap = true;
                bp = true;
            } else {
                ap = f.shadowed(plus.0 + side_a.0, plus.1 + side_a.1);
                bp = f.shadowed(plus.0 + side_b.0, plus.1 + side_b.1);
            }
        }
        if f.br(walk_minus) {
            minus = (minus.0 - axis.0, minus.1 - axis.1);
            if f.shadowed(minus.0, minus.1) {
                walk_minus = false;
                am = true;
                bm = true;
            } else {
                am = f.shadowed(minus.0 + side_a.0, minus.1 + side_a.1);
                bm = f.shadowed(minus.0 + side_b.0, minus.1 + side_b.1);
            }
        }
    }
    (ap, bp, am, bm)
}

/// C9/C11's result from the corridor flags: `p` the sub-texel position across the corridor, `n` the
/// normalised position along it, `a±` the flags of the "L" side, `b±` of the "R" side.
fn corridor_value(p: f32, n: f32, ap: bool, bp: bool, am: bool, bm: bool) -> f32 {
    let b_miss = !bp || !bm;
    let a_miss = !ap || !am;
    if n <= -2.0 {
        let np = (n + 4.0) / 2.0;
        let a = clamp01(p - np + 1.0);
        let a2 = clamp01(2.0 - p - np);
        if b_miss {
            a
        } else if a_miss {
            a2
        } else {
            a.min(a2)
        }
    } else if (!ap && !bp) || (!am && !bm) {
        clamp01(1.0 - n)
    } else if b_miss {
        clamp01(1.0 + p - n)
    } else {
        clamp01(2.0 - p - n)
    }
}

/// What one fragment evaluation cost: texel reads of its walks and scans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Steps of the ONDS walks and of the case scans.
    pub steps: u32,
    /// True when the fragment had a discontinuity (the functions ran past the code).
    pub flagged: bool,
}

/// `f` of one fragment at continuous map position `(x, y)` (texel `i` covers `[i, i + 1)`) and
/// normalised depth `z`, under `function` (the RSMSS code with the speck filter).
pub fn visibility<M: DepthTexels>(
    map: &M,
    x: f32,
    y: f32,
    z: f32,
    function: Function,
    s: &Settings,
) -> (f32, Work) {
    let (fi, fj) = (x.floor(), y.floor());
    let f = Fragment {
        map,
        i: fi as i64,
        j: fj as i64,
        px: x - fi,
        py: y - fj,
        z,
    };
    let mut steps = 0;
    let code = code(&f, function == Function::Rsmss);
    let flagged = code.rc != 0 || code.gc != 0;
    let v = match function {
        Function::Smsr => smsr(&f, code, s, &mut steps),
        Function::Rsmss => rsmss(&f, code, s, &mut steps),
    };
    (v, Work { steps, flagged })
}

/// RPCF (2017): the mean (sum / count) over `(K + 1)²` taps, `h` outer and `w` inner, at texel offsets `w, h ∈ {−P, −P + 2P/K, …} ≤ P` of
/// each tap's value (SMSR taps: shadowed 0, lit without a flag 1, else `v_SMSR`; RSMSS taps: no flag
/// the hard test, else `v_RSMSS`). `k` is the kernel order `K`, `p` the penumbra size `P`, texels.
#[allow(clippy::too_many_arguments)] // the scalar form mirrors the paper's parameter list
pub fn rpcf<M: DepthTexels>(
    map: &M,
    x: f32,
    y: f32,
    z: f32,
    function: Function,
    s: &Settings,
    k: u32,
    p: f32,
) -> (f32, Work) {
    let step = 2.0 * p / k as f32;
    let mut offsets = Vec::new();
    let mut w = -p;
    while w <= p {
        offsets.push(w);
        w += step;
    }
    let mut sum = 0.0f32;
    let mut count = 0u32;
    let mut work = Work::default();
    for &h in &offsets {
        for &w in &offsets {
            let (v, tap) = visibility(map, x + w, y + h, z, function, s);
            sum += v;
            count += 1;
            work.steps += tap.steps;
            work.flagged |= tap.flagged;
        }
    }
    (sum / count as f32, work)
}
