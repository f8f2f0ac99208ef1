//! The portable backend: plain 16-element arrays and lane loops.
//!
//! Every operation is written as a straight `for i in 0..16` / `from_fn`
//! over 64-byte aligned arrays so that LLVM vectorizes it for whatever
//! target features the enclosing function is compiled with (SSE2 baseline,
//! or AVX2+FMA inside [`crate::run_with`]'s `PortableAvx2` entry point).
//! It defines the reference semantics the AVX-512 backend must match.

// Indexed lane loops are deliberate: they are what LLVM vectorizes best.
#![allow(clippy::needless_range_loop)]

use crate::common::{self, aligned, check_indices, masked_extent, need};
use crate::simd::{BackendKind, Simd};
use crate::Mask16;
use core::sync::atomic::AtomicI32;

/// 16 × f32 in a 64-byte aligned array.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[repr(C, align(64))]
pub struct F32x16(pub [f32; 16]);

/// 16 × i32 in a 64-byte aligned array.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[repr(C, align(64))]
pub struct I32x16(pub [i32; 16]);

/// The portable backend. Always available on every target.
#[derive(Clone, Copy, Debug, Default)]
pub struct Portable;

/// `f` on every lane, as an indexed loop: `[T; 16]::map` is not always inlined (the conversions
/// were out-of-line calls of `core::array::try_map`, lane by lane), and a loop is what LLVM
/// vectorizes.
#[inline(always)]
fn lanes<T: Copy, U: Copy + Default>(a: [T; 16], f: impl Fn(T) -> U) -> [U; 16] {
    let mut o = [U::default(); 16];
    for i in 0..16 {
        o[i] = f(a[i]);
    }
    o
}
#[inline(always)]
fn mapf(a: F32x16, f: impl Fn(f32) -> f32) -> F32x16 {
    F32x16(lanes(a.0, f))
}
#[inline(always)]
fn mapf2(a: F32x16, b: F32x16, f: impl Fn(f32, f32) -> f32) -> F32x16 {
    let mut o = [0f32; 16];
    for i in 0..16 {
        o[i] = f(a.0[i], b.0[i]);
    }
    F32x16(o)
}
#[inline(always)]
fn mapf3(a: F32x16, b: F32x16, c: F32x16, f: impl Fn(f32, f32, f32) -> f32) -> F32x16 {
    let mut o = [0f32; 16];
    for i in 0..16 {
        o[i] = f(a.0[i], b.0[i], c.0[i]);
    }
    F32x16(o)
}
#[inline(always)]
fn mapi(a: I32x16, f: impl Fn(i32) -> i32) -> I32x16 {
    I32x16(lanes(a.0, f))
}
#[inline(always)]
fn mapi2(a: I32x16, b: I32x16, f: impl Fn(i32, i32) -> i32) -> I32x16 {
    let mut o = [0i32; 16];
    for i in 0..16 {
        o[i] = f(a.0[i], b.0[i]);
    }
    I32x16(o)
}
/// The mask of 16 lane results, each 0 or -1 (all ones): bit i set where lane i is.
///
/// On x86_64 four SSE `movmskps` (part of the x86_64 baseline; under AVX2 LLVM joins them into
/// two 256-bit ones) read the lanes' sign bits. LLVM does not recognize the lane loop
/// `m |= (lane as u16) << i` as that: it compiled it lane by lane (an extract, an `and`, a shift
/// and an `or` per lane), so a compare into a mask cost about 12 cycles on the Intel Xeon VM,
/// the PCSS lookups' largest cost on the portable backend. Elsewhere, the lane loop.
#[inline(always)]
fn pack_signs(lanes: [i32; 16]) -> Mask16 {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_mm_loadu_ps, _mm_movemask_ps};
        let p = lanes.as_ptr() as *const f32;
        // SAFETY: SSE is in the x86_64 baseline; each load reads 4 of the array's 16 lanes.
        let quarter = |k: usize| unsafe { _mm_movemask_ps(_mm_loadu_ps(p.add(4 * k))) as u16 };
        Mask16(quarter(0) | quarter(1) << 4 | quarter(2) << 8 | quarter(3) << 12)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut m = 0u16;
        for i in 0..16 {
            m |= ((lanes[i] != 0) as u16) << i;
        }
        Mask16(m)
    }
}
/// The mask of `f` on each pair of lanes of `a` and `b`.
#[inline(always)]
fn cmp_lanes<T: Copy>(a: [T; 16], b: [T; 16], f: impl Fn(T, T) -> bool) -> Mask16 {
    let mut l = [0i32; 16];
    for i in 0..16 {
        l[i] = -(f(a[i], b[i]) as i32);
    }
    pack_signs(l)
}
#[inline(always)]
fn cmpf(a: F32x16, b: F32x16, f: impl Fn(f32, f32) -> bool) -> Mask16 {
    cmp_lanes(a.0, b.0, f)
}
#[inline(always)]
fn cmpi(a: I32x16, b: I32x16, f: impl Fn(i32, i32) -> bool) -> Mask16 {
    cmp_lanes(a.0, b.0, f)
}
#[inline(always)]
fn blendf(src: F32x16, m: Mask16, v: F32x16) -> F32x16 {
    let mut o = [0f32; 16];
    for i in 0..16 {
        o[i] = if (m.0 >> i) & 1 == 1 { v.0[i] } else { src.0[i] };
    }
    F32x16(o)
}
#[inline(always)]
fn blendi(src: I32x16, m: Mask16, v: I32x16) -> I32x16 {
    let mut o = [0i32; 16];
    for i in 0..16 {
        o[i] = if (m.0 >> i) & 1 == 1 { v.0[i] } else { src.0[i] };
    }
    I32x16(o)
}
/// Tree reduction in the documented order: lane i combines with i^8, i^4,
/// i^2, i^1; the result is lane 0.
#[inline(always)]
fn tree<T: Copy>(v: [T; 16], f: impl Fn(T, T) -> T) -> T {
    let mut a = v;
    let mut k = 8;
    while k > 0 {
        for i in 0..k {
            a[i] = f(a[i], a[i + k]);
        }
        k /= 2;
    }
    a[0]
}
#[inline(always)]
pub(crate) fn minf(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}
#[inline(always)]
pub(crate) fn maxf(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}
/// x86 `cvttps2dq`: truncate, NaN / out of range → i32::MIN.
///
/// Written so that LLVM vectorizes it within the kernels (two compares, a max, a min, `cvttps2dq`
/// and a blend per 8 lanes under AVX2): the value converted is clamped into i32's range by data
/// selects, and the result picked by one. A saturating `x as i32` inside the range test, or an
/// unchecked conversion of `if in_range { x } else { 0.0 }`, were compiled lane by lane
/// (`cvttss2si`, compares and branches or `cmov`s per lane): on the portable backend a `floor_i`
/// cost about 100 instructions, where the model prices it as one vector operation.
#[inline(always)]
pub(crate) fn cvtt(x: f32) -> i32 {
    let in_range = (-2_147_483_648.0..2_147_483_648.0).contains(&x);
    // NaN fails both comparisons: its clamped value is -2^31. 2_147_483_520 is the largest f32
    // below 2^31.
    let c = if x > -2_147_483_648.0 { x } else { -2_147_483_648.0 };
    let c = if c < 2_147_483_520.0 { c } else { 2_147_483_520.0 };
    // SAFETY: `c` is finite and within [-2^31, 2^31 - 128], so its truncation fits an i32.
    let t = unsafe { c.to_int_unchecked::<i32>() };
    if in_range {
        t
    } else {
        i32::MIN
    }
}
/// Lanes of `v` whose bit is set in `m`, packed to the front in lane order; the rest are
/// `T::default()`.
///
/// Without a branch per lane: every lane is written at the packed position, which advances by the
/// lane's bit. A branch per lane mispredicts on about half the bits of an unpredictable mask (the
/// calibration's random masks cost about 155 cycles a compress that way on a Xeon host), so the
/// host's cost would hang on the masks' pattern, which no counter sees; this way it does not.
#[inline(always)]
pub(crate) fn compress<T: Copy + Default>(m: Mask16, v: [T; 16]) -> [T; 16] {
    // One lane of slack: after the last set bit, the unset lanes land at `o[count]`, which is
    // then cleared (it is the slack lane when all 16 are set).
    let mut o = [T::default(); 17];
    let mut n = 0;
    for (i, &x) in v.iter().enumerate() {
        o[n] = x;
        n += ((m.0 >> i) & 1) as usize;
    }
    o[n] = T::default();
    let mut out = [T::default(); 16];
    out.copy_from_slice(&o[..16]);
    out
}
/// `src` with the lanes whose bit is set in `m` replaced, in lane order, by `v[0]`, `v[1]`, …
/// (`v` holds at least as many elements as `m` has bits set).
///
/// Without a branch per lane, for the reason [`compress`] gives: each lane picks between its own
/// value and the next of `v` by its bit.
#[inline(always)]
pub(crate) fn expand<T: Copy + Default>(src: [T; 16], m: Mask16, v: &[T]) -> [T; 16] {
    let Some(last) = v.len().checked_sub(1) else {
        return src;
    };
    let mut o = src;
    let mut n = 0;
    for (i, lane) in o.iter_mut().enumerate() {
        let bit = ((m.0 >> i) & 1) as usize;
        *lane = [*lane, v[n.min(last)]][bit];
        n += bit;
    }
    o
}

impl Simd for Portable {
    type F32 = F32x16;
    type I32 = I32x16;

    #[inline(always)]
    fn kind(self) -> BackendKind {
        BackendKind::Portable
    }

    #[inline(always)]
    fn splat_f(self, x: f32) -> F32x16 {
        F32x16([x; 16])
    }
    #[inline(always)]
    fn splat_i(self, x: i32) -> I32x16 {
        I32x16([x; 16])
    }
    #[inline(always)]
    fn from_array_f(self, a: [f32; 16]) -> F32x16 {
        F32x16(a)
    }
    #[inline(always)]
    fn from_array_i(self, a: [i32; 16]) -> I32x16 {
        I32x16(a)
    }
    #[inline(always)]
    fn to_array_f(self, v: F32x16) -> [f32; 16] {
        v.0
    }
    #[inline(always)]
    fn to_array_i(self, v: I32x16) -> [i32; 16] {
        v.0
    }
    #[inline(always)]
    fn index_i(self) -> I32x16 {
        I32x16([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15])
    }
    #[inline(always)]
    fn extract_f(self, v: F32x16, lane: usize) -> f32 {
        if lane >= 16 {
            common::bad_lane(lane)
        }
        v.0[lane]
    }
    #[inline(always)]
    fn extract_i(self, v: I32x16, lane: usize) -> i32 {
        if lane >= 16 {
            common::bad_lane(lane)
        }
        v.0[lane]
    }

    #[inline(always)]
    fn add_f(self, a: F32x16, b: F32x16) -> F32x16 {
        mapf2(a, b, |x, y| x + y)
    }
    #[inline(always)]
    fn sub_f(self, a: F32x16, b: F32x16) -> F32x16 {
        mapf2(a, b, |x, y| x - y)
    }
    #[inline(always)]
    fn mul_f(self, a: F32x16, b: F32x16) -> F32x16 {
        mapf2(a, b, |x, y| x * y)
    }
    #[inline(always)]
    fn div_f(self, a: F32x16, b: F32x16) -> F32x16 {
        mapf2(a, b, |x, y| x / y)
    }
    #[inline(always)]
    fn fmadd(self, a: F32x16, b: F32x16, c: F32x16) -> F32x16 {
        mapf3(a, b, c, |x, y, z| x.mul_add(y, z))
    }
    #[inline(always)]
    fn fmsub(self, a: F32x16, b: F32x16, c: F32x16) -> F32x16 {
        mapf3(a, b, c, |x, y, z| x.mul_add(y, -z))
    }
    #[inline(always)]
    fn fnmadd(self, a: F32x16, b: F32x16, c: F32x16) -> F32x16 {
        mapf3(a, b, c, |x, y, z| (-x).mul_add(y, z))
    }
    #[inline(always)]
    fn min_f(self, a: F32x16, b: F32x16) -> F32x16 {
        mapf2(a, b, minf)
    }
    #[inline(always)]
    fn max_f(self, a: F32x16, b: F32x16) -> F32x16 {
        mapf2(a, b, maxf)
    }
    #[inline(always)]
    fn abs_f(self, a: F32x16) -> F32x16 {
        mapf(a, f32::abs)
    }
    #[inline(always)]
    fn neg_f(self, a: F32x16) -> F32x16 {
        mapf(a, |x| -x)
    }
    #[inline(always)]
    fn sqrt_f(self, a: F32x16) -> F32x16 {
        mapf(a, f32::sqrt)
    }
    #[inline(always)]
    fn rcp_f(self, a: F32x16) -> F32x16 {
        mapf(a, |x| 1.0 / x)
    }
    #[inline(always)]
    fn rsqrt_f(self, a: F32x16) -> F32x16 {
        mapf(a, |x| 1.0 / x.sqrt())
    }
    #[inline(always)]
    fn rcp_fast_f(self, a: F32x16) -> F32x16 {
        mapf(a, |x| 1.0 / x)
    }
    #[inline(always)]
    fn rsqrt_fast_f(self, a: F32x16) -> F32x16 {
        mapf(a, |x| 1.0 / x.sqrt())
    }
    #[inline(always)]
    fn floor_f(self, a: F32x16) -> F32x16 {
        mapf(a, f32::floor)
    }
    #[inline(always)]
    fn ceil_f(self, a: F32x16) -> F32x16 {
        mapf(a, f32::ceil)
    }
    #[inline(always)]
    fn trunc_f(self, a: F32x16) -> F32x16 {
        mapf(a, f32::trunc)
    }
    #[inline(always)]
    fn round_f(self, a: F32x16) -> F32x16 {
        mapf(a, f32::round_ties_even)
    }

    #[inline(always)]
    fn mask_add_f(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(src, m, self.add_f(a, b))
    }
    #[inline(always)]
    fn mask_sub_f(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(src, m, self.sub_f(a, b))
    }
    #[inline(always)]
    fn mask_mul_f(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(src, m, self.mul_f(a, b))
    }
    #[inline(always)]
    fn mask_div_f(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(src, m, self.div_f(a, b))
    }
    #[inline(always)]
    fn mask_fmadd(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16, c: F32x16) -> F32x16 {
        blendf(src, m, self.fmadd(a, b, c))
    }
    #[inline(always)]
    fn mask_min_f(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(src, m, self.min_f(a, b))
    }
    #[inline(always)]
    fn mask_max_f(self, src: F32x16, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(src, m, self.max_f(a, b))
    }
    #[inline(always)]
    fn mask_sqrt_f(self, src: F32x16, m: Mask16, a: F32x16) -> F32x16 {
        blendf(src, m, self.sqrt_f(a))
    }
    #[inline(always)]
    fn select_f(self, m: Mask16, a: F32x16, b: F32x16) -> F32x16 {
        blendf(b, m, a)
    }

    #[inline(always)]
    fn cmp_eq_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x == y)
    }
    #[inline(always)]
    fn cmp_ne_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x != y)
    }
    #[inline(always)]
    fn cmp_lt_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x < y)
    }
    #[inline(always)]
    fn cmp_le_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x <= y)
    }
    #[inline(always)]
    fn cmp_gt_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x > y)
    }
    #[inline(always)]
    fn cmp_ge_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x >= y)
    }
    #[inline(always)]
    fn cmp_unord_f(self, a: F32x16, b: F32x16) -> Mask16 {
        cmpf(a, b, |x, y| x.is_nan() || y.is_nan())
    }

    #[inline(always)]
    fn reduce_add_f(self, v: F32x16) -> f32 {
        tree(v.0, |a, b| a + b)
    }
    #[inline(always)]
    fn reduce_min_f(self, v: F32x16) -> f32 {
        tree(v.0, minf)
    }
    #[inline(always)]
    fn reduce_max_f(self, v: F32x16) -> f32 {
        tree(v.0, maxf)
    }
    #[inline(always)]
    fn permute_f(self, v: F32x16, idx: I32x16) -> F32x16 {
        F32x16(core::array::from_fn(|i| v.0[(idx.0[i] & 15) as usize]))
    }
    #[inline(always)]
    fn compress_f(self, m: Mask16, v: F32x16) -> F32x16 {
        F32x16(compress(m, v.0))
    }
    #[inline(always)]
    fn expand_f(self, m: Mask16, v: F32x16) -> F32x16 {
        F32x16(expand([0.0; 16], m, &v.0))
    }

    #[inline(always)]
    fn add_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, i32::wrapping_add)
    }
    #[inline(always)]
    fn sub_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, i32::wrapping_sub)
    }
    #[inline(always)]
    fn mul_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, i32::wrapping_mul)
    }
    #[inline(always)]
    fn and_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| x & y)
    }
    #[inline(always)]
    fn or_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| x | y)
    }
    #[inline(always)]
    fn xor_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| x ^ y)
    }
    #[inline(always)]
    fn andn_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| !x & y)
    }
    #[inline(always)]
    fn shl_i(self, a: I32x16, n: u32) -> I32x16 {
        mapi(a, |x| if n >= 32 { 0 } else { x << n })
    }
    #[inline(always)]
    fn shr_u(self, a: I32x16, n: u32) -> I32x16 {
        mapi(a, |x| if n >= 32 { 0 } else { ((x as u32) >> n) as i32 })
    }
    #[inline(always)]
    fn shr_i(self, a: I32x16, n: u32) -> I32x16 {
        mapi(a, |x| x >> n.min(31))
    }
    #[inline(always)]
    fn shlv_i(self, a: I32x16, n: I32x16) -> I32x16 {
        mapi2(a, n, |x, s| if (s as u32) >= 32 { 0 } else { x << s })
    }
    #[inline(always)]
    fn shrv_u(self, a: I32x16, n: I32x16) -> I32x16 {
        mapi2(a, n, |x, s| {
            if (s as u32) >= 32 {
                0
            } else {
                ((x as u32) >> s) as i32
            }
        })
    }
    #[inline(always)]
    fn shrv_i(self, a: I32x16, n: I32x16) -> I32x16 {
        mapi2(a, n, |x, s| x >> (s as u32).min(31))
    }
    #[inline(always)]
    fn min_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| x.min(y))
    }
    #[inline(always)]
    fn max_i(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| x.max(y))
    }
    #[inline(always)]
    fn min_u(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| (x as u32).min(y as u32) as i32)
    }
    #[inline(always)]
    fn max_u(self, a: I32x16, b: I32x16) -> I32x16 {
        mapi2(a, b, |x, y| (x as u32).max(y as u32) as i32)
    }
    #[inline(always)]
    fn abs_i(self, a: I32x16) -> I32x16 {
        mapi(a, i32::wrapping_abs)
    }
    #[inline(always)]
    fn mask_add_i(self, src: I32x16, m: Mask16, a: I32x16, b: I32x16) -> I32x16 {
        blendi(src, m, self.add_i(a, b))
    }
    #[inline(always)]
    fn mask_sub_i(self, src: I32x16, m: Mask16, a: I32x16, b: I32x16) -> I32x16 {
        blendi(src, m, self.sub_i(a, b))
    }
    #[inline(always)]
    fn select_i(self, m: Mask16, a: I32x16, b: I32x16) -> I32x16 {
        blendi(b, m, a)
    }

    #[inline(always)]
    fn cmp_eq_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x == y)
    }
    #[inline(always)]
    fn cmp_ne_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x != y)
    }
    #[inline(always)]
    fn cmp_lt_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x < y)
    }
    #[inline(always)]
    fn cmp_le_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x <= y)
    }
    #[inline(always)]
    fn cmp_gt_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x > y)
    }
    #[inline(always)]
    fn cmp_ge_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x >= y)
    }
    #[inline(always)]
    fn cmp_lt_u(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| (x as u32) < (y as u32))
    }
    #[inline(always)]
    fn cmp_le_u(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| (x as u32) <= (y as u32))
    }
    #[inline(always)]
    fn cmp_gt_u(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| (x as u32) > (y as u32))
    }
    #[inline(always)]
    fn cmp_ge_u(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| (x as u32) >= (y as u32))
    }
    #[inline(always)]
    fn test_i(self, a: I32x16, b: I32x16) -> Mask16 {
        cmpi(a, b, |x, y| x & y != 0)
    }

    #[inline(always)]
    fn reduce_add_i(self, v: I32x16) -> i32 {
        tree(v.0, i32::wrapping_add)
    }
    #[inline(always)]
    fn reduce_min_i(self, v: I32x16) -> i32 {
        tree(v.0, i32::min)
    }
    #[inline(always)]
    fn reduce_max_i(self, v: I32x16) -> i32 {
        tree(v.0, i32::max)
    }
    #[inline(always)]
    fn reduce_min_u(self, v: I32x16) -> u32 {
        tree(lanes(v.0, |x| x as u32), u32::min)
    }
    #[inline(always)]
    fn reduce_max_u(self, v: I32x16) -> u32 {
        tree(lanes(v.0, |x| x as u32), u32::max)
    }
    #[inline(always)]
    fn reduce_or_i(self, v: I32x16) -> i32 {
        tree(v.0, |a, b| a | b)
    }
    #[inline(always)]
    fn reduce_and_i(self, v: I32x16) -> i32 {
        tree(v.0, |a, b| a & b)
    }
    #[inline(always)]
    fn permute_i(self, v: I32x16, idx: I32x16) -> I32x16 {
        I32x16(core::array::from_fn(|i| v.0[(idx.0[i] & 15) as usize]))
    }
    #[inline(always)]
    fn compress_i(self, m: Mask16, v: I32x16) -> I32x16 {
        I32x16(compress(m, v.0))
    }
    #[inline(always)]
    fn expand_i(self, m: Mask16, v: I32x16) -> I32x16 {
        I32x16(expand([0; 16], m, &v.0))
    }
    #[inline(always)]
    fn conflict_i(self, v: I32x16) -> I32x16 {
        I32x16(common::conflict(&v.0))
    }

    #[inline(always)]
    fn cvt_i_f(self, a: I32x16) -> F32x16 {
        F32x16(lanes(a.0, |x| x as f32))
    }
    #[inline(always)]
    fn cvt_u_f(self, a: I32x16) -> F32x16 {
        F32x16(lanes(a.0, |x| x as u32 as f32))
    }
    #[inline(always)]
    fn cvtt_f_i(self, a: F32x16) -> I32x16 {
        I32x16(lanes(a.0, cvtt))
    }
    #[inline(always)]
    fn cvtr_f_i(self, a: F32x16) -> I32x16 {
        I32x16(lanes(a.0, |x| cvtt(x.round_ties_even())))
    }
    #[inline(always)]
    fn cast_f_i(self, a: F32x16) -> I32x16 {
        I32x16(lanes(a.0, |x| x.to_bits() as i32))
    }
    #[inline(always)]
    fn cast_i_f(self, a: I32x16) -> F32x16 {
        F32x16(lanes(a.0, |x| f32::from_bits(x as u32)))
    }

    crate::common::native_mask_ops!();

    #[inline(always)]
    fn load_f(self, mem: &[f32]) -> F32x16 {
        need("load_f", mem.len(), 16);
        F32x16(core::array::from_fn(|i| mem[i]))
    }
    #[inline(always)]
    fn load_i(self, mem: &[i32]) -> I32x16 {
        need("load_i", mem.len(), 16);
        I32x16(core::array::from_fn(|i| mem[i]))
    }
    #[inline(always)]
    fn load_aligned_f(self, mem: &[f32]) -> F32x16 {
        aligned("load_aligned_f", mem);
        self.load_f(mem)
    }
    #[inline(always)]
    fn load_aligned_i(self, mem: &[i32]) -> I32x16 {
        aligned("load_aligned_i", mem);
        self.load_i(mem)
    }
    #[inline(always)]
    fn store_f(self, mem: &mut [f32], v: F32x16) {
        need("store_f", mem.len(), 16);
        mem[..16].copy_from_slice(&v.0);
    }
    #[inline(always)]
    fn store_i(self, mem: &mut [i32], v: I32x16) {
        need("store_i", mem.len(), 16);
        mem[..16].copy_from_slice(&v.0);
    }
    #[inline(always)]
    fn store_aligned_f(self, mem: &mut [f32], v: F32x16) {
        aligned("store_aligned_f", mem);
        self.store_f(mem, v)
    }
    #[inline(always)]
    fn store_aligned_i(self, mem: &mut [i32], v: I32x16) {
        aligned("store_aligned_i", mem);
        self.store_i(mem, v)
    }
    #[inline(always)]
    fn mask_load_f(self, src: F32x16, m: Mask16, mem: &[f32]) -> F32x16 {
        need("mask_load_f", mem.len(), masked_extent(m));
        if mem.len() >= 16 {
            // Full-width read + blend: inactive in-bounds elements are read
            // but discarded, which a shared borrow makes unobservable.
            let full: [f32; 16] = core::array::from_fn(|i| mem[i]);
            let mut o = src.0;
            for i in 0..16 {
                o[i] = if (m.0 >> i) & 1 == 1 { full[i] } else { o[i] };
            }
            return F32x16(o);
        }
        let mut o = src.0;
        for i in m.iter() {
            o[i] = mem[i];
        }
        F32x16(o)
    }
    #[inline(always)]
    fn mask_load_i(self, src: I32x16, m: Mask16, mem: &[i32]) -> I32x16 {
        need("mask_load_i", mem.len(), masked_extent(m));
        if mem.len() >= 16 {
            // Full-width read + blend: inactive in-bounds elements are read
            // but discarded, which a shared borrow makes unobservable.
            let full: [i32; 16] = core::array::from_fn(|i| mem[i]);
            let mut o = src.0;
            for i in 0..16 {
                o[i] = if (m.0 >> i) & 1 == 1 { full[i] } else { o[i] };
            }
            return I32x16(o);
        }
        let mut o = src.0;
        for i in m.iter() {
            o[i] = mem[i];
        }
        I32x16(o)
    }
    #[inline(always)]
    fn mask_store_f(self, mem: &mut [f32], m: Mask16, v: F32x16) {
        need("mask_store_f", mem.len(), masked_extent(m));
        if mem.len() >= 16 {
            // Full-width read-modify-write; the exclusive borrow makes
            // rewriting inactive elements with their own value unobservable.
            let dst = &mut mem[..16];
            for i in 0..16 {
                dst[i] = if (m.0 >> i) & 1 == 1 { v.0[i] } else { dst[i] };
            }
            return;
        }
        for i in m.iter() {
            mem[i] = v.0[i];
        }
    }
    #[inline(always)]
    fn mask_store_i(self, mem: &mut [i32], m: Mask16, v: I32x16) {
        need("mask_store_i", mem.len(), masked_extent(m));
        if mem.len() >= 16 {
            // Full-width read-modify-write; the exclusive borrow makes
            // rewriting inactive elements with their own value unobservable.
            let dst = &mut mem[..16];
            for i in 0..16 {
                dst[i] = if (m.0 >> i) & 1 == 1 { v.0[i] } else { dst[i] };
            }
            return;
        }
        for i in m.iter() {
            mem[i] = v.0[i];
        }
    }
    #[inline(always)]
    fn gather_f(self, mem: &[f32], idx: I32x16) -> F32x16 {
        self.mask_gather_f(F32x16::default(), Mask16::ALL, mem, idx)
    }
    #[inline(always)]
    fn gather_i(self, mem: &[i32], idx: I32x16) -> I32x16 {
        self.mask_gather_i(I32x16::default(), Mask16::ALL, mem, idx)
    }
    #[inline(always)]
    fn mask_gather_f(self, src: F32x16, m: Mask16, mem: &[f32], idx: I32x16) -> F32x16 {
        check_indices("gather_f", m, &idx.0, common::index_limit(mem.len()) as usize);
        let mut o = src.0;
        for i in m.iter() {
            o[i] = mem[idx.0[i] as usize];
        }
        F32x16(o)
    }
    #[inline(always)]
    fn mask_gather_i(self, src: I32x16, m: Mask16, mem: &[i32], idx: I32x16) -> I32x16 {
        check_indices("gather_i", m, &idx.0, common::index_limit(mem.len()) as usize);
        let mut o = src.0;
        for i in m.iter() {
            o[i] = mem[idx.0[i] as usize];
        }
        I32x16(o)
    }
    #[inline(always)]
    fn mask_scatter_f(self, mem: &mut [f32], m: Mask16, idx: I32x16, v: F32x16) {
        check_indices("scatter_f", m, &idx.0, common::index_limit(mem.len()) as usize);
        common::scatter_lanes(mem, m, &idx.0, &v.0);
    }
    #[inline(always)]
    fn mask_scatter_i(self, mem: &mut [i32], m: Mask16, idx: I32x16, v: I32x16) {
        check_indices("scatter_i", m, &idx.0, common::index_limit(mem.len()) as usize);
        common::scatter_lanes(mem, m, &idx.0, &v.0);
    }
    #[inline(always)]
    fn compress_store_f(self, mem: &mut [f32], m: Mask16, v: F32x16) -> usize {
        let n = m.count() as usize;
        need("compress_store_f", mem.len(), n);
        mem[..n].copy_from_slice(&compress(m, v.0)[..n]);
        n
    }
    #[inline(always)]
    fn compress_store_i(self, mem: &mut [i32], m: Mask16, v: I32x16) -> usize {
        let n = m.count() as usize;
        need("compress_store_i", mem.len(), n);
        mem[..n].copy_from_slice(&compress(m, v.0)[..n]);
        n
    }
    #[inline(always)]
    fn expand_load_f(self, src: F32x16, m: Mask16, mem: &[f32]) -> F32x16 {
        let n = m.count() as usize;
        need("expand_load_f", mem.len(), n);
        F32x16(expand(src.0, m, &mem[..n]))
    }
    #[inline(always)]
    fn expand_load_i(self, src: I32x16, m: Mask16, mem: &[i32]) -> I32x16 {
        let n = m.count() as usize;
        need("expand_load_i", mem.len(), n);
        I32x16(expand(src.0, m, &mem[..n]))
    }
    #[inline(always)]
    fn fetch_add_i(self, mem: &mut [i32], m: Mask16, idx: I32x16, val: I32x16) -> I32x16 {
        check_indices("fetch_add_i", m, &idx.0, common::index_limit(mem.len()) as usize);
        I32x16(common::fetch_add_lanes(mem, m, &idx.0, &val.0))
    }
    #[inline(always)]
    fn atomic_fetch_add_i(self, mem: &[AtomicI32], m: Mask16, idx: I32x16, val: I32x16) -> I32x16 {
        check_indices(
            "atomic_fetch_add_i",
            m,
            &idx.0,
            common::index_limit(mem.len()) as usize,
        );
        let conf = common::conflict(&idx.0);
        I32x16(common::atomic_fetch_add(mem, m, &idx.0, &val.0, &conf))
    }
}
