//! The native AVX2 backend (`x86_64` only): a 16-lane vector as two 256-bit registers.
//!
//! `F32` is [`F32x8x2`] (two `__m256`), `I32` is [`I32x8x2`] (two `__m256i`); masks stay
//! [`Mask16`] bits, spread into lane masks (`vpcmpeqd` against one bit per lane) where an
//! operation takes one and packed with `vmovmskps` where a compare makes one. This is what the
//! portable backend's lane loops compile to at best; written with intrinsics, every 16-lane value
//! is two registers and every operation two instructions (plus the mask moves), so kernels keep
//! their values in registers instead of the arrays LLVM spills when it cannot prove they stay
//! in registers. It is the fast path on x86 CPUs without AVX-512, and its cost per operation is
//! what `sism calibrate` can measure on microbenchmarks and the model can count.
//!
//! Results are bit-identical to [`crate::Portable`] for every operation, `rcp_fast_f` and
//! `rsqrt_fast_f` included (they are true divisions here, as on the portable backend: AVX2's
//! 12-bit estimates would need a second Newton step to reach AVX-512's accuracy).
//!
//! # Safety argument
//!
//! As for [`crate::Avx512`]: [`Avx2`] is a zero-sized token whose safe constructor checks every
//! feature in [`FEATURES`]; holding one proves the CPU executes these instructions. Memory
//! intrinsics are preceded by bounds checks on every active lane, and a masked load or store
//! never touches a lane its mask leaves off.

use crate::common::{self, aligned, masked_extent, need};
use crate::portable::expand;
use crate::simd::{BackendKind, Simd};
use crate::Mask16;
use core::arch::x86_64::*;
use core::sync::atomic::AtomicI32;

/// The target features the AVX2 backend is compiled for and requires.
pub const FEATURES: &str = "avx2,fma,bmi1,bmi2,popcnt";

/// 16 × `f32` as two AVX registers: lanes 0–7 and 8–15.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct F32x8x2(pub __m256, pub __m256);

/// 16 × `i32` as two AVX registers: lanes 0–7 and 8–15.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct I32x8x2(pub __m256i, pub __m256i);

/// Native AVX2 context. Construct with [`Avx2::new`].
#[derive(Clone, Copy, Debug)]
pub struct Avx2 {
    _private: (),
}

impl Avx2 {
    /// `Some` if this CPU has every feature in [`FEATURES`].
    pub fn new() -> Option<Self> {
        if detected() {
            Some(Avx2 { _private: () })
        } else {
            None
        }
    }
    /// # Safety
    /// The CPU must support every feature in [`FEATURES`].
    #[inline(always)]
    pub unsafe fn new_unchecked() -> Self {
        Avx2 { _private: () }
    }
}

/// Run-time detection of every feature the backend uses (cached by std).
pub fn detected() -> bool {
    std::is_x86_feature_detected!("avx2")
        && std::is_x86_feature_detected!("fma")
        && std::is_x86_feature_detected!("bmi1")
        && std::is_x86_feature_detected!("bmi2")
        && std::is_x86_feature_detected!("popcnt")
}

// SAFETY (whole module): every `unsafe` block only calls AVX / AVX2 / FMA / BMI intrinsics,
// available because an `Avx2` token exists (the helpers below are only called from its methods);
// pointer-taking intrinsics are preceded by bounds checks covering every lane they access.

/// The lane masks of `m`: all ones in lanes whose bit is set (low half, high half).
#[inline(always)]
fn spread(m: Mask16) -> (__m256i, __m256i) {
    unsafe {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let lo = _mm256_set1_epi32((m.0 & 0xFF) as i32);
        let hi = _mm256_set1_epi32((m.0 >> 8) as i32);
        (
            _mm256_cmpeq_epi32(_mm256_and_si256(lo, bits), bits),
            _mm256_cmpeq_epi32(_mm256_and_si256(hi, bits), bits),
        )
    }
}

/// The sign bits of two lane masks as a [`Mask16`].
#[inline(always)]
fn pack(lo: __m256, hi: __m256) -> Mask16 {
    unsafe { Mask16((_mm256_movemask_ps(lo) as u32 | (_mm256_movemask_ps(hi) as u32) << 8) as u16) }
}

#[inline(always)]
fn pack_i(lo: __m256i, hi: __m256i) -> Mask16 {
    unsafe { pack(_mm256_castsi256_ps(lo), _mm256_castsi256_ps(hi)) }
}

#[inline(always)]
fn ps(v: __m256i) -> __m256 {
    unsafe { _mm256_castsi256_ps(v) }
}

#[inline(always)]
fn blend_f(src: F32x8x2, m: Mask16, v: F32x8x2) -> F32x8x2 {
    let (lo, hi) = spread(m);
    unsafe {
        F32x8x2(
            _mm256_blendv_ps(src.0, v.0, ps(lo)),
            _mm256_blendv_ps(src.1, v.1, ps(hi)),
        )
    }
}

#[inline(always)]
fn blend_i(src: I32x8x2, m: Mask16, v: I32x8x2) -> I32x8x2 {
    let (lo, hi) = spread(m);
    unsafe {
        I32x8x2(
            _mm256_blendv_epi8(src.0, v.0, lo),
            _mm256_blendv_epi8(src.1, v.1, hi),
        )
    }
}

/// Flip the sign bit: unsigned order becomes signed order.
#[inline(always)]
fn biased(v: I32x8x2) -> I32x8x2 {
    unsafe {
        let s = _mm256_set1_epi32(i32::MIN);
        I32x8x2(_mm256_xor_si256(v.0, s), _mm256_xor_si256(v.1, s))
    }
}

/// Lanes where `a > b` (signed).
#[inline(always)]
fn gt_i(a: I32x8x2, b: I32x8x2) -> Mask16 {
    unsafe { pack_i(_mm256_cmpgt_epi32(a.0, b.0), _mm256_cmpgt_epi32(a.1, b.1)) }
}

#[inline(always)]
fn eq_i(a: I32x8x2, b: I32x8x2) -> Mask16 {
    unsafe { pack_i(_mm256_cmpeq_epi32(a.0, b.0), _mm256_cmpeq_epi32(a.1, b.1)) }
}

#[inline(always)]
fn arr_f(v: F32x8x2) -> [f32; 16] {
    // SAFETY: two __m256 are 64 bytes, as [f32; 16]; every bit pattern is valid for both.
    unsafe { core::mem::transmute(v) }
}
#[inline(always)]
fn arr_i(v: I32x8x2) -> [i32; 16] {
    // SAFETY: as above.
    unsafe { core::mem::transmute(v) }
}
#[inline(always)]
fn vec_f(a: [f32; 16]) -> F32x8x2 {
    // SAFETY: as above.
    unsafe { core::mem::transmute(a) }
}
#[inline(always)]
fn vec_i(a: [i32; 16]) -> I32x8x2 {
    // SAFETY: as above.
    unsafe { core::mem::transmute(a) }
}

/// Bounds check of active lane indices: an unsigned compare per half and a mask test.
#[inline(always)]
#[track_caller]
fn check_idx(op: &str, m: Mask16, idx: I32x8x2, len: usize) {
    let lim = common::index_limit(len);
    let lim_v = unsafe { _mm256_set1_epi32(lim as i32) };
    // idx < lim (unsigned) where the lane is fine.
    let ok = gt_i(biased(I32x8x2(lim_v, lim_v)), biased(idx));
    if m.0 & !ok.0 != 0 {
        common::oob_index(op, m, &arr_i(idx), lim as usize);
    }
}

/// The numbers of the lanes (0–7) whose bit of `bits` (8 bits) is set, packed one a byte from
/// the lowest (BMI2: a byte of ones per set bit, then the identity's bytes it selects).
#[inline(always)]
fn lane_numbers(bits: u32) -> u64 {
    unsafe {
        let bytes = _pdep_u64(bits as u64, 0x0101_0101_0101_0101).wrapping_mul(0xFF);
        _pext_u64(0x0706_0504_0302_0100, bytes)
    }
}

/// Eight lane numbers (bytes) as the 32-bit indices `vpermd` takes.
#[inline(always)]
fn indices(bytes: u64) -> __m256i {
    unsafe { _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(bytes as i64)) }
}

/// The active lanes of `v` moved to the front, in lane order; lanes from `m.count()` on hold
/// whatever the permutation brings (callers zero or skip them).
#[inline(always)]
fn compress16(v: I32x8x2, m: Mask16) -> I32x8x2 {
    let (lo, hi) = ((m.0 & 0xFF) as u32, (m.0 >> 8) as u32);
    // The high half's lane numbers (8–15) follow the low half's.
    let order = lane_numbers(lo) as u128
        | ((lane_numbers(hi) + 0x0808_0808_0808_0808) as u128) << (8 * lo.count_ones());
    I32x8x2(
        permute_half(v, indices(order as u64)),
        permute_half(v, indices((order >> 64) as u64)),
    )
}

/// Store the active lanes of `v` packed to the front of `mem`, which holds at least
/// `m.count()` elements; nothing beyond them is written.
#[inline(always)]
fn compress_store(mem: &mut [i32], m: Mask16, v: I32x8x2) {
    let n = m.count() as usize;
    let c = compress16(v, m);
    let keep = Mask16::first_n(n);
    if mem.len() >= 16 {
        // Read, blend, write back (the exclusive borrow makes rewriting the elements past `n`
        // with their own values unobservable); `vpmaskmovd` stores are slow on AMD.
        let p = mem.as_mut_ptr() as *mut __m256i;
        unsafe {
            let old = I32x8x2(_mm256_loadu_si256(p), _mm256_loadu_si256(p.add(1)));
            let new = blend_i(old, keep, c);
            _mm256_storeu_si256(p, new.0);
            _mm256_storeu_si256(p.add(1), new.1);
        }
        return;
    }
    let (lo, hi) = spread(keep);
    let p = mem.as_mut_ptr();
    unsafe {
        // `wrapping_add`: with fewer than 9 elements the high half's mask is all off and the
        // store touches nothing.
        _mm256_maskstore_epi32(p, lo, c.0);
        _mm256_maskstore_epi32(p.wrapping_add(8), hi, c.1);
    }
}

/// Eight lanes of a 16-lane permute: each picks from both halves of `v` (index bits 0–2) and
/// keeps the one index bit 3 names (moved to the sign bit for the blend). A function, not a
/// closure: closures are compiled without the kernel's target features
/// (`tests/integration/inlining.rs`).
#[inline(always)]
fn permute_half(v: I32x8x2, i: __m256i) -> __m256i {
    unsafe {
        let from_lo = _mm256_permutevar8x32_epi32(v.0, i);
        let from_hi = _mm256_permutevar8x32_epi32(v.1, i);
        _mm256_castps_si256(_mm256_blendv_ps(
            _mm256_castsi256_ps(from_lo),
            _mm256_castsi256_ps(from_hi),
            _mm256_castsi256_ps(_mm256_slli_epi32::<28>(i)),
        ))
    }
}

/// Eight lanes of `u32 as f32`: the high and low 16 bits convert exactly and one fused
/// multiply-add rounds once, so the result is correctly rounded.
#[inline(always)]
fn cvt_u_half(x: __m256i) -> __m256 {
    unsafe {
        let hi = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(x));
        let lo = _mm256_cvtepi32_ps(_mm256_and_si256(x, _mm256_set1_epi32(0xFFFF)));
        _mm256_fmadd_ps(hi, _mm256_set1_ps(65536.0), lo)
    }
}

macro_rules! f2 {
    ($a:expr, $b:expr, $op:ident) => {{
        let (a, b) = ($a, $b);
        unsafe { F32x8x2($op(a.0, b.0), $op(a.1, b.1)) }
    }};
}
macro_rules! i2 {
    ($a:expr, $b:expr, $op:ident) => {{
        let (a, b) = ($a, $b);
        unsafe { I32x8x2($op(a.0, b.0), $op(a.1, b.1)) }
    }};
}
macro_rules! f1 {
    ($a:expr, $op:expr) => {{
        let a = $a;
        unsafe { F32x8x2($op(a.0), $op(a.1)) }
    }};
}
macro_rules! cmp_f {
    ($a:expr, $b:expr, $pred:ident) => {{
        let (a, b) = ($a, $b);
        unsafe { pack(_mm256_cmp_ps::<$pred>(a.0, b.0), _mm256_cmp_ps::<$pred>(a.1, b.1)) }
    }};
}

/// Tree reduction with the documented lane order (i^8, i^4, i^2, i^1).
macro_rules! tree_f {
    ($v:expr, $op:ident) => {{
        let v = $v;
        let v = $op(v.0, v.1);
        let v = $op(v, _mm256_permute2f128_ps::<0x01>(v, v));
        let v = $op(v, _mm256_permute_ps::<0b01_00_11_10>(v));
        let v = $op(v, _mm256_permute_ps::<0b10_11_00_01>(v));
        _mm256_cvtss_f32(v)
    }};
}
macro_rules! tree_i {
    ($v:expr, $op:ident) => {{
        let v = $v;
        let v = $op(v.0, v.1);
        let v = $op(v, _mm256_permute2x128_si256::<0x01>(v, v));
        let v = $op(v, _mm256_shuffle_epi32::<0b01_00_11_10>(v));
        let v = $op(v, _mm256_shuffle_epi32::<0b10_11_00_01>(v));
        _mm256_cvtsi256_si32(v)
    }};
}

impl Simd for Avx2 {
    type F32 = F32x8x2;
    type I32 = I32x8x2;

    #[inline(always)]
    fn kind(self) -> BackendKind {
        BackendKind::Avx2
    }

    #[inline(always)]
    fn splat_f(self, x: f32) -> F32x8x2 {
        unsafe { F32x8x2(_mm256_set1_ps(x), _mm256_set1_ps(x)) }
    }
    #[inline(always)]
    fn splat_i(self, x: i32) -> I32x8x2 {
        unsafe { I32x8x2(_mm256_set1_epi32(x), _mm256_set1_epi32(x)) }
    }
    #[inline(always)]
    fn from_array_f(self, a: [f32; 16]) -> F32x8x2 {
        vec_f(a)
    }
    #[inline(always)]
    fn from_array_i(self, a: [i32; 16]) -> I32x8x2 {
        vec_i(a)
    }
    #[inline(always)]
    fn to_array_f(self, v: F32x8x2) -> [f32; 16] {
        arr_f(v)
    }
    #[inline(always)]
    fn to_array_i(self, v: I32x8x2) -> [i32; 16] {
        arr_i(v)
    }
    #[inline(always)]
    fn index_i(self) -> I32x8x2 {
        unsafe {
            I32x8x2(
                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
                _mm256_setr_epi32(8, 9, 10, 11, 12, 13, 14, 15),
            )
        }
    }
    #[inline(always)]
    fn extract_f(self, v: F32x8x2, lane: usize) -> f32 {
        if lane >= 16 {
            common::bad_lane(lane)
        }
        arr_f(v)[lane]
    }
    #[inline(always)]
    fn extract_i(self, v: I32x8x2, lane: usize) -> i32 {
        if lane >= 16 {
            common::bad_lane(lane)
        }
        arr_i(v)[lane]
    }

    #[inline(always)]
    fn add_f(self, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        f2!(a, b, _mm256_add_ps)
    }
    #[inline(always)]
    fn sub_f(self, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        f2!(a, b, _mm256_sub_ps)
    }
    #[inline(always)]
    fn mul_f(self, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        f2!(a, b, _mm256_mul_ps)
    }
    #[inline(always)]
    fn div_f(self, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        f2!(a, b, _mm256_div_ps)
    }
    #[inline(always)]
    fn fmadd(self, a: F32x8x2, b: F32x8x2, c: F32x8x2) -> F32x8x2 {
        unsafe { F32x8x2(_mm256_fmadd_ps(a.0, b.0, c.0), _mm256_fmadd_ps(a.1, b.1, c.1)) }
    }
    #[inline(always)]
    fn fmsub(self, a: F32x8x2, b: F32x8x2, c: F32x8x2) -> F32x8x2 {
        unsafe { F32x8x2(_mm256_fmsub_ps(a.0, b.0, c.0), _mm256_fmsub_ps(a.1, b.1, c.1)) }
    }
    #[inline(always)]
    fn fnmadd(self, a: F32x8x2, b: F32x8x2, c: F32x8x2) -> F32x8x2 {
        unsafe { F32x8x2(_mm256_fnmadd_ps(a.0, b.0, c.0), _mm256_fnmadd_ps(a.1, b.1, c.1)) }
    }
    #[inline(always)]
    fn min_f(self, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        f2!(a, b, _mm256_min_ps)
    }
    #[inline(always)]
    fn max_f(self, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        f2!(a, b, _mm256_max_ps)
    }
    #[inline(always)]
    fn abs_f(self, a: F32x8x2) -> F32x8x2 {
        let m = self.cast_i_f(self.splat_i(i32::MAX));
        f2!(a, m, _mm256_and_ps)
    }
    #[inline(always)]
    fn neg_f(self, a: F32x8x2) -> F32x8x2 {
        let s = self.cast_i_f(self.splat_i(i32::MIN));
        f2!(a, s, _mm256_xor_ps)
    }
    #[inline(always)]
    fn sqrt_f(self, a: F32x8x2) -> F32x8x2 {
        f1!(a, _mm256_sqrt_ps)
    }
    #[inline(always)]
    fn rcp_f(self, a: F32x8x2) -> F32x8x2 {
        self.div_f(self.splat_f(1.0), a)
    }
    #[inline(always)]
    fn rsqrt_f(self, a: F32x8x2) -> F32x8x2 {
        self.div_f(self.splat_f(1.0), self.sqrt_f(a))
    }
    #[inline(always)]
    fn rcp_fast_f(self, a: F32x8x2) -> F32x8x2 {
        self.rcp_f(a)
    }
    #[inline(always)]
    fn rsqrt_fast_f(self, a: F32x8x2) -> F32x8x2 {
        self.rsqrt_f(a)
    }
    #[inline(always)]
    fn floor_f(self, a: F32x8x2) -> F32x8x2 {
        f1!(a, _mm256_round_ps::<0x09>)
    }
    #[inline(always)]
    fn ceil_f(self, a: F32x8x2) -> F32x8x2 {
        f1!(a, _mm256_round_ps::<0x0A>)
    }
    #[inline(always)]
    fn trunc_f(self, a: F32x8x2) -> F32x8x2 {
        f1!(a, _mm256_round_ps::<0x0B>)
    }
    #[inline(always)]
    fn round_f(self, a: F32x8x2) -> F32x8x2 {
        f1!(a, _mm256_round_ps::<0x08>)
    }

    #[inline(always)]
    fn mask_add_f(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.add_f(a, b))
    }
    #[inline(always)]
    fn mask_sub_f(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.sub_f(a, b))
    }
    #[inline(always)]
    fn mask_mul_f(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.mul_f(a, b))
    }
    #[inline(always)]
    fn mask_div_f(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.div_f(a, b))
    }
    #[inline(always)]
    fn mask_fmadd(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2, c: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.fmadd(a, b, c))
    }
    #[inline(always)]
    fn mask_min_f(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.min_f(a, b))
    }
    #[inline(always)]
    fn mask_max_f(self, src: F32x8x2, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.max_f(a, b))
    }
    #[inline(always)]
    fn mask_sqrt_f(self, src: F32x8x2, m: Mask16, a: F32x8x2) -> F32x8x2 {
        blend_f(src, m, self.sqrt_f(a))
    }
    #[inline(always)]
    fn select_f(self, m: Mask16, a: F32x8x2, b: F32x8x2) -> F32x8x2 {
        blend_f(b, m, a)
    }

    #[inline(always)]
    fn cmp_eq_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_EQ_OQ)
    }
    #[inline(always)]
    fn cmp_ne_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_NEQ_UQ)
    }
    #[inline(always)]
    fn cmp_lt_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_LT_OQ)
    }
    #[inline(always)]
    fn cmp_le_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_LE_OQ)
    }
    #[inline(always)]
    fn cmp_gt_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_GT_OQ)
    }
    #[inline(always)]
    fn cmp_ge_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_GE_OQ)
    }
    #[inline(always)]
    fn cmp_unord_f(self, a: F32x8x2, b: F32x8x2) -> Mask16 {
        cmp_f!(a, b, _CMP_UNORD_Q)
    }

    #[inline(always)]
    fn reduce_add_f(self, v: F32x8x2) -> f32 {
        unsafe { tree_f!(v, _mm256_add_ps) }
    }
    #[inline(always)]
    fn reduce_min_f(self, v: F32x8x2) -> f32 {
        unsafe { tree_f!(v, _mm256_min_ps) }
    }
    #[inline(always)]
    fn reduce_max_f(self, v: F32x8x2) -> f32 {
        unsafe { tree_f!(v, _mm256_max_ps) }
    }
    #[inline(always)]
    fn permute_f(self, v: F32x8x2, idx: I32x8x2) -> F32x8x2 {
        let p = self.permute_i(self.cast_f_i(v), idx);
        self.cast_i_f(p)
    }
    #[inline(always)]
    fn compress_f(self, m: Mask16, v: F32x8x2) -> F32x8x2 {
        self.cast_i_f(self.compress_i(m, self.cast_f_i(v)))
    }
    #[inline(always)]
    fn expand_f(self, m: Mask16, v: F32x8x2) -> F32x8x2 {
        vec_f(expand([0.0; 16], m, &arr_f(v)))
    }

    #[inline(always)]
    fn add_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_add_epi32)
    }
    #[inline(always)]
    fn sub_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_sub_epi32)
    }
    #[inline(always)]
    fn mul_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_mullo_epi32)
    }
    #[inline(always)]
    fn and_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_and_si256)
    }
    #[inline(always)]
    fn or_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_or_si256)
    }
    #[inline(always)]
    fn xor_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_xor_si256)
    }
    #[inline(always)]
    fn andn_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_andnot_si256)
    }
    #[inline(always)]
    fn shl_i(self, a: I32x8x2, n: u32) -> I32x8x2 {
        unsafe {
            let c = _mm_cvtsi32_si128(n.min(32) as i32);
            I32x8x2(_mm256_sll_epi32(a.0, c), _mm256_sll_epi32(a.1, c))
        }
    }
    #[inline(always)]
    fn shr_u(self, a: I32x8x2, n: u32) -> I32x8x2 {
        unsafe {
            let c = _mm_cvtsi32_si128(n.min(32) as i32);
            I32x8x2(_mm256_srl_epi32(a.0, c), _mm256_srl_epi32(a.1, c))
        }
    }
    #[inline(always)]
    fn shr_i(self, a: I32x8x2, n: u32) -> I32x8x2 {
        unsafe {
            let c = _mm_cvtsi32_si128(n.min(32) as i32);
            I32x8x2(_mm256_sra_epi32(a.0, c), _mm256_sra_epi32(a.1, c))
        }
    }
    #[inline(always)]
    fn shlv_i(self, a: I32x8x2, n: I32x8x2) -> I32x8x2 {
        i2!(a, n, _mm256_sllv_epi32)
    }
    #[inline(always)]
    fn shrv_u(self, a: I32x8x2, n: I32x8x2) -> I32x8x2 {
        i2!(a, n, _mm256_srlv_epi32)
    }
    #[inline(always)]
    fn shrv_i(self, a: I32x8x2, n: I32x8x2) -> I32x8x2 {
        i2!(a, n, _mm256_srav_epi32)
    }
    #[inline(always)]
    fn min_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_min_epi32)
    }
    #[inline(always)]
    fn max_i(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_max_epi32)
    }
    #[inline(always)]
    fn min_u(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_min_epu32)
    }
    #[inline(always)]
    fn max_u(self, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        i2!(a, b, _mm256_max_epu32)
    }
    #[inline(always)]
    fn abs_i(self, a: I32x8x2) -> I32x8x2 {
        unsafe { I32x8x2(_mm256_abs_epi32(a.0), _mm256_abs_epi32(a.1)) }
    }
    #[inline(always)]
    fn mask_add_i(self, src: I32x8x2, m: Mask16, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        blend_i(src, m, self.add_i(a, b))
    }
    #[inline(always)]
    fn mask_sub_i(self, src: I32x8x2, m: Mask16, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        blend_i(src, m, self.sub_i(a, b))
    }
    #[inline(always)]
    fn select_i(self, m: Mask16, a: I32x8x2, b: I32x8x2) -> I32x8x2 {
        blend_i(b, m, a)
    }

    #[inline(always)]
    fn cmp_eq_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        eq_i(a, b)
    }
    #[inline(always)]
    fn cmp_ne_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        Mask16(!eq_i(a, b).0)
    }
    #[inline(always)]
    fn cmp_lt_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        gt_i(b, a)
    }
    #[inline(always)]
    fn cmp_le_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        Mask16(!gt_i(a, b).0)
    }
    #[inline(always)]
    fn cmp_gt_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        gt_i(a, b)
    }
    #[inline(always)]
    fn cmp_ge_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        Mask16(!gt_i(b, a).0)
    }
    #[inline(always)]
    fn cmp_lt_u(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        gt_i(biased(b), biased(a))
    }
    #[inline(always)]
    fn cmp_le_u(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        Mask16(!gt_i(biased(a), biased(b)).0)
    }
    #[inline(always)]
    fn cmp_gt_u(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        gt_i(biased(a), biased(b))
    }
    #[inline(always)]
    fn cmp_ge_u(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        Mask16(!gt_i(biased(b), biased(a)).0)
    }
    #[inline(always)]
    fn test_i(self, a: I32x8x2, b: I32x8x2) -> Mask16 {
        let zero = self.splat_i(0);
        Mask16(!eq_i(self.and_i(a, b), zero).0)
    }

    #[inline(always)]
    fn reduce_add_i(self, v: I32x8x2) -> i32 {
        unsafe { tree_i!(v, _mm256_add_epi32) }
    }
    #[inline(always)]
    fn reduce_min_i(self, v: I32x8x2) -> i32 {
        unsafe { tree_i!(v, _mm256_min_epi32) }
    }
    #[inline(always)]
    fn reduce_max_i(self, v: I32x8x2) -> i32 {
        unsafe { tree_i!(v, _mm256_max_epi32) }
    }
    #[inline(always)]
    fn reduce_min_u(self, v: I32x8x2) -> u32 {
        unsafe { tree_i!(v, _mm256_min_epu32) as u32 }
    }
    #[inline(always)]
    fn reduce_max_u(self, v: I32x8x2) -> u32 {
        unsafe { tree_i!(v, _mm256_max_epu32) as u32 }
    }
    #[inline(always)]
    fn reduce_or_i(self, v: I32x8x2) -> i32 {
        unsafe { tree_i!(v, _mm256_or_si256) }
    }
    #[inline(always)]
    fn reduce_and_i(self, v: I32x8x2) -> i32 {
        unsafe { tree_i!(v, _mm256_and_si256) }
    }
    #[inline(always)]
    fn permute_i(self, v: I32x8x2, idx: I32x8x2) -> I32x8x2 {
        I32x8x2(permute_half(v, idx.0), permute_half(v, idx.1))
    }
    #[inline(always)]
    fn compress_i(self, m: Mask16, v: I32x8x2) -> I32x8x2 {
        blend_i(
            self.splat_i(0),
            Mask16::first_n(m.count() as usize),
            compress16(v, m),
        )
    }
    #[inline(always)]
    fn expand_i(self, m: Mask16, v: I32x8x2) -> I32x8x2 {
        vec_i(expand([0; 16], m, &arr_i(v)))
    }
    #[inline(always)]
    fn conflict_i(self, v: I32x8x2) -> I32x8x2 {
        vec_i(common::conflict(&arr_i(v)))
    }

    #[inline(always)]
    fn cvt_i_f(self, a: I32x8x2) -> F32x8x2 {
        unsafe { F32x8x2(_mm256_cvtepi32_ps(a.0), _mm256_cvtepi32_ps(a.1)) }
    }
    #[inline(always)]
    fn cvt_u_f(self, a: I32x8x2) -> F32x8x2 {
        F32x8x2(cvt_u_half(a.0), cvt_u_half(a.1))
    }
    #[inline(always)]
    fn cvtt_f_i(self, a: F32x8x2) -> I32x8x2 {
        unsafe { I32x8x2(_mm256_cvttps_epi32(a.0), _mm256_cvttps_epi32(a.1)) }
    }
    #[inline(always)]
    fn cvtr_f_i(self, a: F32x8x2) -> I32x8x2 {
        // MXCSR's rounding mode, round-to-nearest-even (Rust never changes it).
        unsafe { I32x8x2(_mm256_cvtps_epi32(a.0), _mm256_cvtps_epi32(a.1)) }
    }
    #[inline(always)]
    fn cast_f_i(self, a: F32x8x2) -> I32x8x2 {
        unsafe { I32x8x2(_mm256_castps_si256(a.0), _mm256_castps_si256(a.1)) }
    }
    #[inline(always)]
    fn cast_i_f(self, a: I32x8x2) -> F32x8x2 {
        unsafe { F32x8x2(_mm256_castsi256_ps(a.0), _mm256_castsi256_ps(a.1)) }
    }

    crate::common::native_mask_ops!();

    #[inline(always)]
    fn load_f(self, mem: &[f32]) -> F32x8x2 {
        need("load_f", mem.len(), 16);
        let p = mem.as_ptr();
        unsafe { F32x8x2(_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(8))) }
    }
    #[inline(always)]
    fn load_i(self, mem: &[i32]) -> I32x8x2 {
        need("load_i", mem.len(), 16);
        let p = mem.as_ptr() as *const __m256i;
        unsafe { I32x8x2(_mm256_loadu_si256(p), _mm256_loadu_si256(p.add(1))) }
    }
    #[inline(always)]
    fn load_aligned_f(self, mem: &[f32]) -> F32x8x2 {
        aligned("load_aligned_f", mem);
        let p = mem.as_ptr();
        unsafe { F32x8x2(_mm256_load_ps(p), _mm256_load_ps(p.add(8))) }
    }
    #[inline(always)]
    fn load_aligned_i(self, mem: &[i32]) -> I32x8x2 {
        aligned("load_aligned_i", mem);
        let p = mem.as_ptr() as *const __m256i;
        unsafe { I32x8x2(_mm256_load_si256(p), _mm256_load_si256(p.add(1))) }
    }
    #[inline(always)]
    fn store_f(self, mem: &mut [f32], v: F32x8x2) {
        need("store_f", mem.len(), 16);
        let p = mem.as_mut_ptr();
        unsafe {
            _mm256_storeu_ps(p, v.0);
            _mm256_storeu_ps(p.add(8), v.1);
        }
    }
    #[inline(always)]
    fn store_i(self, mem: &mut [i32], v: I32x8x2) {
        need("store_i", mem.len(), 16);
        let p = mem.as_mut_ptr() as *mut __m256i;
        unsafe {
            _mm256_storeu_si256(p, v.0);
            _mm256_storeu_si256(p.add(1), v.1);
        }
    }
    #[inline(always)]
    fn store_aligned_f(self, mem: &mut [f32], v: F32x8x2) {
        aligned("store_aligned_f", mem);
        let p = mem.as_mut_ptr();
        unsafe {
            _mm256_store_ps(p, v.0);
            _mm256_store_ps(p.add(8), v.1);
        }
    }
    #[inline(always)]
    fn store_aligned_i(self, mem: &mut [i32], v: I32x8x2) {
        aligned("store_aligned_i", mem);
        let p = mem.as_mut_ptr() as *mut __m256i;
        unsafe {
            _mm256_store_si256(p, v.0);
            _mm256_store_si256(p.add(1), v.1);
        }
    }
    #[inline(always)]
    fn mask_load_f(self, src: F32x8x2, m: Mask16, mem: &[f32]) -> F32x8x2 {
        need("mask_load_f", mem.len(), masked_extent(m));
        let v = self.mask_load_i(self.cast_f_i(src), m, as_i32_f32(mem));
        self.cast_i_f(v)
    }
    #[inline(always)]
    fn mask_load_i(self, src: I32x8x2, m: Mask16, mem: &[i32]) -> I32x8x2 {
        need("mask_load_i", mem.len(), masked_extent(m));
        if mem.len() >= 16 {
            // Full-width read and a blend (a shared borrow makes reading the inactive,
            // in-bounds elements unobservable); cheaper than `vpmaskmovd`.
            return blend_i(src, m, self.load_i(mem));
        }
        let (lo, hi) = spread(m);
        let p = mem.as_ptr();
        unsafe {
            // `wrapping_add`: the high half's address may lie past a short slice; the mask then
            // has no high lane (`need` above) and the load touches nothing.
            let l = I32x8x2(
                _mm256_maskload_epi32(p, lo),
                _mm256_maskload_epi32(p.wrapping_add(8), hi),
            );
            blend_i(src, m, l)
        }
    }
    #[inline(always)]
    fn mask_store_f(self, mem: &mut [f32], m: Mask16, v: F32x8x2) {
        need("mask_store_f", mem.len(), masked_extent(m));
        self.mask_store_i(as_i32_mut_f32(mem), m, self.cast_f_i(v))
    }
    #[inline(always)]
    fn mask_store_i(self, mem: &mut [i32], m: Mask16, v: I32x8x2) {
        need("mask_store_i", mem.len(), masked_extent(m));
        if mem.len() >= 16 {
            // Read, blend, write back: the exclusive borrow makes rewriting the inactive
            // elements with their own values unobservable; `vpmaskmovd` stores are slow on AMD.
            let old = self.load_i(mem);
            self.store_i(mem, blend_i(old, m, v));
            return;
        }
        let (lo, hi) = spread(m);
        let p = mem.as_mut_ptr();
        unsafe {
            _mm256_maskstore_epi32(p, lo, v.0);
            _mm256_maskstore_epi32(p.wrapping_add(8), hi, v.1);
        }
    }
    #[inline(always)]
    fn gather_f(self, mem: &[f32], idx: I32x8x2) -> F32x8x2 {
        check_idx("gather_f", Mask16::ALL, idx, mem.len());
        let p = mem.as_ptr();
        unsafe {
            F32x8x2(
                _mm256_i32gather_ps::<4>(p, idx.0),
                _mm256_i32gather_ps::<4>(p, idx.1),
            )
        }
    }
    #[inline(always)]
    fn gather_i(self, mem: &[i32], idx: I32x8x2) -> I32x8x2 {
        check_idx("gather_i", Mask16::ALL, idx, mem.len());
        let p = mem.as_ptr();
        unsafe {
            I32x8x2(
                _mm256_i32gather_epi32::<4>(p, idx.0),
                _mm256_i32gather_epi32::<4>(p, idx.1),
            )
        }
    }
    #[inline(always)]
    fn mask_gather_f(self, src: F32x8x2, m: Mask16, mem: &[f32], idx: I32x8x2) -> F32x8x2 {
        check_idx("gather_f", m, idx, mem.len());
        let (lo, hi) = spread(m);
        let p = mem.as_ptr();
        unsafe {
            F32x8x2(
                _mm256_mask_i32gather_ps::<4>(src.0, p, idx.0, ps(lo)),
                _mm256_mask_i32gather_ps::<4>(src.1, p, idx.1, ps(hi)),
            )
        }
    }
    #[inline(always)]
    fn mask_gather_i(self, src: I32x8x2, m: Mask16, mem: &[i32], idx: I32x8x2) -> I32x8x2 {
        check_idx("gather_i", m, idx, mem.len());
        let (lo, hi) = spread(m);
        let p = mem.as_ptr();
        unsafe {
            I32x8x2(
                _mm256_mask_i32gather_epi32::<4>(src.0, p, idx.0, lo),
                _mm256_mask_i32gather_epi32::<4>(src.1, p, idx.1, hi),
            )
        }
    }
    #[inline(always)]
    fn mask_scatter_f(self, mem: &mut [f32], m: Mask16, idx: I32x8x2, v: F32x8x2) {
        check_idx("scatter_f", m, idx, mem.len());
        // No scatter in AVX2: lane by lane, in lane order (a later lane's write wins).
        common::scatter_lanes(mem, m, &arr_i(idx), &arr_f(v));
    }
    #[inline(always)]
    fn mask_scatter_i(self, mem: &mut [i32], m: Mask16, idx: I32x8x2, v: I32x8x2) {
        check_idx("scatter_i", m, idx, mem.len());
        common::scatter_lanes(mem, m, &arr_i(idx), &arr_i(v));
    }
    #[inline(always)]
    fn compress_store_f(self, mem: &mut [f32], m: Mask16, v: F32x8x2) -> usize {
        let n = m.count() as usize;
        need("compress_store_f", mem.len(), n);
        compress_store(as_i32_mut_f32(mem), m, self.cast_f_i(v));
        n
    }
    #[inline(always)]
    fn compress_store_i(self, mem: &mut [i32], m: Mask16, v: I32x8x2) -> usize {
        let n = m.count() as usize;
        need("compress_store_i", mem.len(), n);
        compress_store(mem, m, v);
        n
    }
    #[inline(always)]
    fn expand_load_f(self, src: F32x8x2, m: Mask16, mem: &[f32]) -> F32x8x2 {
        let n = m.count() as usize;
        need("expand_load_f", mem.len(), n);
        vec_f(expand(arr_f(src), m, &mem[..n]))
    }
    #[inline(always)]
    fn expand_load_i(self, src: I32x8x2, m: Mask16, mem: &[i32]) -> I32x8x2 {
        let n = m.count() as usize;
        need("expand_load_i", mem.len(), n);
        vec_i(expand(arr_i(src), m, &mem[..n]))
    }
    #[inline(always)]
    fn fetch_add_i(self, mem: &mut [i32], m: Mask16, idx: I32x8x2, val: I32x8x2) -> I32x8x2 {
        check_idx("fetch_add_i", m, idx, mem.len());
        // Lane by lane in lane order: a duplicate index sees its earlier lanes' adds.
        vec_i(common::fetch_add_lanes(mem, m, &arr_i(idx), &arr_i(val)))
    }
    #[inline(always)]
    fn atomic_fetch_add_i(self, mem: &[AtomicI32], m: Mask16, idx: I32x8x2, val: I32x8x2) -> I32x8x2 {
        check_idx("atomic_fetch_add_i", m, idx, mem.len());
        let idx = arr_i(idx);
        let conf = common::conflict(&idx);
        vec_i(common::atomic_fetch_add(mem, m, &idx, &arr_i(val), &conf))
    }
}

/// `f32` elements viewed as `i32`: the masked loads and stores only move bits.
#[inline(always)]
fn as_i32_f32(s: &[f32]) -> &[i32] {
    // SAFETY: f32 and i32 have identical size and alignment and every bit pattern is valid for
    // both; the borrow is carried over.
    unsafe { core::slice::from_raw_parts(s.as_ptr().cast(), s.len()) }
}

/// Mutable [`as_i32_f32`].
#[inline(always)]
fn as_i32_mut_f32(s: &mut [f32]) -> &mut [i32] {
    // SAFETY: as above.
    unsafe { core::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), s.len()) }
}
