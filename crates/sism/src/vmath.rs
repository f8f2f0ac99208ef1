//! Small 16-lane vector helpers shared by the kernels: 3-vectors of registers, dot and cross
//! products, broadcasts. All `#[inline(always)]` plain functions (never closures), so they compile
//! inside each kernel's target-feature entry point.

use glam::Vec3;
use sism_simd::Simd;

/// A 3-vector of 16 lanes.
pub type V3<S> = [<S as Simd>::F32; 3];

/// `a · b` with fused multiply-adds: `a0 b0 + (a1 b1 + a2 b2)`, rounded twice less than the plain
/// products.
#[inline(always)]
pub fn dot3<S: Simd>(s: S, a: V3<S>, b: V3<S>) -> S::F32 {
    s.fmadd(a[0], b[0], s.fmadd(a[1], b[1], s.mul_f(a[2], b[2])))
}

/// `a · b` exactly as glam's scalar `Vec3::dot` rounds it: `(a0 b0 + a1 b1) + a2 b2`, no fused
/// operations. For kernels that must match scalar glam code bit for bit (the eye pass's ray
/// directions equal the ray caster's).
#[inline(always)]
pub fn dot3_unfused<S: Simd>(s: S, a: &V3<S>, b: &V3<S>) -> S::F32 {
    s.add_f(
        s.add_f(s.mul_f(a[0], b[0]), s.mul_f(a[1], b[1])),
        s.mul_f(a[2], b[2]),
    )
}

/// `a - b` per coordinate.
#[inline(always)]
pub fn sub3<S: Simd>(s: S, a: &V3<S>, b: &V3<S>) -> V3<S> {
    [s.sub_f(a[0], b[0]), s.sub_f(a[1], b[1]), s.sub_f(a[2], b[2])]
}

/// `a × b` with fused multiply-subtracts.
#[inline(always)]
pub fn cross3<S: Simd>(s: S, a: V3<S>, b: V3<S>) -> V3<S> {
    [
        s.fmsub(a[1], b[2], s.mul_f(a[2], b[1])),
        s.fmsub(a[2], b[0], s.mul_f(a[0], b[2])),
        s.fmsub(a[0], b[1], s.mul_f(a[1], b[0])),
    ]
}

/// A world vector broadcast to three registers.
#[inline(always)]
pub fn splat3<S: Simd>(s: S, a: Vec3) -> V3<S> {
    [s.splat_f(a.x), s.splat_f(a.y), s.splat_f(a.z)]
}

/// 16 lanes `[c(k) for k in 0..16]` as an array (for lane constants; `c` runs at setup, not per op).
#[inline(always)]
pub fn lanes(c: impl Fn(usize) -> f32) -> [f32; 16] {
    std::array::from_fn(c)
}
