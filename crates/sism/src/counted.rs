//! Counted scalar 3-vector operations: glam's `Vec3` arithmetic, operation for operation in glam's
//! own order (so results are bit-identical to it), each scalar operation counted by the context
//! ([`sism_simd::Simd::s_add`] and friends). Scalar code on a counted path uses these instead of
//! glam's operators, so the machine model sees the work it times.

use glam::Vec3;
use sism_simd::{ScalarClass, Simd};

/// `a + b`.
#[inline(always)]
pub fn add<S: Simd>(s: S, a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(s.s_add(a.x, b.x), s.s_add(a.y, b.y), s.s_add(a.z, b.z))
}

/// `a - b`.
#[inline(always)]
pub fn sub<S: Simd>(s: S, a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(s.s_sub(a.x, b.x), s.s_sub(a.y, b.y), s.s_sub(a.z, b.z))
}

/// `a * k`.
#[inline(always)]
pub fn scale<S: Simd>(s: S, a: Vec3, k: f32) -> Vec3 {
    Vec3::new(s.s_mul(a.x, k), s.s_mul(a.y, k), s.s_mul(a.z, k))
}

/// `a.dot(b)`: `(a.x * b.x) + (a.y * b.y) + (a.z * b.z)`.
#[inline(always)]
pub fn dot<S: Simd>(s: S, a: Vec3, b: Vec3) -> f32 {
    s.s_add(s.s_add(s.s_mul(a.x, b.x), s.s_mul(a.y, b.y)), s.s_mul(a.z, b.z))
}

/// `a.cross(b)`.
#[inline(always)]
pub fn cross<S: Simd>(s: S, a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(
        s.s_sub(s.s_mul(a.y, b.z), s.s_mul(b.y, a.z)),
        s.s_sub(s.s_mul(a.z, b.x), s.s_mul(b.z, a.x)),
        s.s_sub(s.s_mul(a.x, b.y), s.s_mul(b.x, a.y)),
    )
}

/// `a.normalize_or_zero()`: `a * (1 / |a|)` when that reciprocal is finite and positive, else zero.
#[inline(always)]
pub fn normalize_or_zero<S: Simd>(s: S, a: Vec3) -> Vec3 {
    let length = s.s_fn(ScalarClass::Div, dot(s, a, a), f32::sqrt);
    let rcp = s.s_div(1.0, length);
    // `is_finite` and `> 0`: two compares, one branch.
    s.scalar_op(ScalarClass::Branch);
    if s.s_branch(rcp.is_finite() && rcp > 0.0) {
        scale(s, a, rcp)
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-identical to glam on awkward inputs.
    #[test]
    fn the_counted_operations_are_glams() {
        let s = sism_simd::Portable;
        let vs = [
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-0.0, 1e-30, 3e38),
            Vec3::new(0.1, -0.7, 1e-7),
            Vec3::ZERO,
            Vec3::new(f32::MIN_POSITIVE, 0.5, -2.5),
        ];
        let same = |a: Vec3, b: Vec3| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits);
        for &a in &vs {
            assert!(same(normalize_or_zero(s, a), a.normalize_or_zero()), "{a}");
            for &b in &vs {
                assert!(same(add(s, a, b), a + b));
                assert!(same(sub(s, a, b), a - b));
                assert!(same(cross(s, a, b), a.cross(b)), "{a} x {b}");
                assert_eq!(dot(s, a, b).to_bits(), a.dot(b).to_bits());
                assert!(same(scale(s, a, b.y), a * b.y));
            }
        }
    }
}
