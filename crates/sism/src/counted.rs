//! Counted scalar 3-vector operations: glam's `Vec3` arithmetic, operation for operation in glam's
//! own order (so results are bit-identical to it), each scalar operation counted by the context
//! ([`sism_simd::Simd::s_add`] and friends). Scalar code on a counted path uses these instead of
//! glam's operators, so the machine model sees the work it times.

use glam::Vec3;
use sism_simd::{ScalarClass, Simd};

/// `data[i]`, a scalar load counted by `s` ([`ScalarClass::Mem`]) whose line the caller has already
/// put in the task's line stream with the whole slice (`s.scalar_read(data)` once, so a loop over a
/// long array does not record the same line once per element).
#[inline(always)]
pub fn streamed<S: Simd, T: Copy>(s: S, data: &[T], i: usize) -> T {
    s.scalar_op(ScalarClass::Mem);
    data[i]
}

/// A 16-lane array aligned to one cache line. Lanes a kernel stores or loads with counted scalar
/// operations on the stack (`s.s_store(&mut lanes.0, lane, x)`) must live in one: a plain `[T; 16]`
/// sits wherever the stack puts it, which moves with the address-space layout from run to run, so
/// the lines it shares with its neighbours, and the first-touch ids of the records, would change
/// from run to run (two counted runs of one frame must write the same records).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneArray<T>(pub [T; 16]);

/// The lowest set lane of `rest`, cleared from it; `None` when none is left. The loop's test is a
/// counted branch with its outcome (how many lanes a mask holds varies from vector to vector, and
/// the host mispredicts it); the bit scan is the caller's to count. `while let Some(lane) =
/// next_lane(s, &mut rest)` walks a mask's lanes in increasing order. The branch is predicted at
/// the caller's site (`track_caller`): inlined, each loop has its own branch on the host.
#[inline(always)]
#[track_caller]
pub fn next_lane<S: Simd>(s: S, rest: &mut u16) -> Option<usize> {
    if !s.s_branch(*rest != 0) {
        return None;
    }
    let lane = rest.trailing_zeros() as usize;
    *rest &= *rest - 1;
    Some(lane)
}

/// `-a` (three sign flips).
#[inline(always)]
pub fn neg<S: Simd>(s: S, a: Vec3) -> Vec3 {
    for _ in 0..3 {
        s.scalar_op(ScalarClass::Alu);
    }
    -a
}

/// `a.length()`: the square root of `a.dot(a)`.
#[inline(always)]
pub fn length<S: Simd>(s: S, a: Vec3) -> f32 {
    s.s_fn(ScalarClass::Div, dot(s, a, a), f32::sqrt)
}

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
/// Its branch is predicted at the caller's site, as [`next_lane`]'s.
#[inline(always)]
#[track_caller]
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

/// `if a > b { a } else { b }`, glam's `max` of one component, as one instruction: x86's `maxss`
/// is exactly this select (equal zeros and NaNs give `b`). Written as the select, the compiler may
/// emit a data-dependent branch, which the host mispredicts and the model counts as an operation.
#[inline(always)]
fn select_max(a: f32, b: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    #[allow(unused_unsafe)]
    // SAFETY: SSE is part of x86_64's baseline.
    unsafe {
        use core::arch::x86_64::{_mm_cvtss_f32, _mm_max_ss, _mm_set_ss};
        _mm_cvtss_f32(_mm_max_ss(_mm_set_ss(a), _mm_set_ss(b)))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        if a > b {
            a
        } else {
            b
        }
    }
}

/// `if a < b { a } else { b }`, glam's `min` of one component: `minss`, as [`select_max`].
#[inline(always)]
fn select_min(a: f32, b: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    #[allow(unused_unsafe)]
    // SAFETY: SSE is part of x86_64's baseline.
    unsafe {
        use core::arch::x86_64::{_mm_cvtss_f32, _mm_min_ss, _mm_set_ss};
        _mm_cvtss_f32(_mm_min_ss(_mm_set_ss(a), _mm_set_ss(b)))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        if a < b {
            a
        } else {
            b
        }
    }
}

/// Counted 2-vector operations, glam's `Vec2` arithmetic in glam's order.
pub mod v2 {
    use glam::Vec2;
    use sism_simd::{ScalarClass, Simd};

    /// `a + b`.
    #[inline(always)]
    pub fn add<S: Simd>(s: S, a: Vec2, b: Vec2) -> Vec2 {
        Vec2::new(s.s_add(a.x, b.x), s.s_add(a.y, b.y))
    }

    /// `a - b`.
    #[inline(always)]
    pub fn sub<S: Simd>(s: S, a: Vec2, b: Vec2) -> Vec2 {
        Vec2::new(s.s_sub(a.x, b.x), s.s_sub(a.y, b.y))
    }

    /// `a * k`.
    #[inline(always)]
    pub fn scale<S: Simd>(s: S, a: Vec2, k: f32) -> Vec2 {
        Vec2::new(s.s_mul(a.x, k), s.s_mul(a.y, k))
    }

    /// `a.min(b)` (glam's own, whose choice between equal zeros of opposite sign differs from
    /// `f32::min`'s): two operations.
    #[inline(always)]
    pub fn min<S: Simd>(s: S, a: Vec2, b: Vec2) -> Vec2 {
        s.scalar_op(ScalarClass::Alu);
        s.scalar_op(ScalarClass::Alu);
        Vec2::new(super::select_min(a.x, b.x), super::select_min(a.y, b.y))
    }

    /// `a.max(b)` (glam's own): two operations.
    #[inline(always)]
    pub fn max<S: Simd>(s: S, a: Vec2, b: Vec2) -> Vec2 {
        s.scalar_op(ScalarClass::Alu);
        s.scalar_op(ScalarClass::Alu);
        Vec2::new(super::select_max(a.x, b.x), super::select_max(a.y, b.y))
    }

    /// `a.dot(b)`: `(a.x * b.x) + (a.y * b.y)`.
    #[inline(always)]
    pub fn dot<S: Simd>(s: S, a: Vec2, b: Vec2) -> f32 {
        s.s_add(s.s_mul(a.x, b.x), s.s_mul(a.y, b.y))
    }

    /// `a.length()`: the square root of `a.dot(a)`.
    #[inline(always)]
    pub fn length<S: Simd>(s: S, a: Vec2) -> f32 {
        s.s_fn(ScalarClass::Div, dot(s, a, a), f32::sqrt)
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
                assert!(same(neg(s, a), -a));
                assert_eq!(length(s, a).to_bits(), a.length().to_bits());
                assert!(same(scale(s, a, b.y), a * b.y));
                let (a2, b2) = (a.truncate(), b.truncate());
                let same2 = |x: glam::Vec2, y: glam::Vec2| {
                    x.x.to_bits() == y.x.to_bits() && x.y.to_bits() == y.y.to_bits()
                };
                assert!(same2(v2::add(s, a2, b2), a2 + b2));
                assert!(same2(v2::sub(s, a2, b2), a2 - b2));
                assert!(same2(v2::scale(s, a2, b.z), a2 * b.z));
                assert!(same2(v2::min(s, a2, b2), a2.min(b2)));
                assert!(same2(v2::max(s, a2, b2), a2.max(b2)));
                assert_eq!(v2::dot(s, a2, b2).to_bits(), a2.dot(b2).to_bits());
                assert_eq!(v2::length(s, a2).to_bits(), a2.length().to_bits());
            }
        }
    }

    /// The branch-free component min and max choose as glam's selects do, signed zeros, NaNs and
    /// infinities included.
    #[test]
    fn the_component_selects_are_glams() {
        let xs = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-45,
        ];
        for &a in &xs {
            for &b in &xs {
                let glam_max = if a > b { a } else { b };
                let glam_min = if a < b { a } else { b };
                assert_eq!(select_max(a, b).to_bits(), glam_max.to_bits(), "max({a}, {b})");
                assert_eq!(select_min(a, b).to_bits(), glam_min.to_bits(), "min({a}, {b})");
            }
        }
    }
}
