//! The native AVX-512 backend (`x86_64` only).
//!
//! `F32 = __m512`, `I32 = __m512i`, masks are `__mmask16`. Each method is a
//! handful of `_mm512_*` intrinsics. The methods are `#[inline(always)]`
//! without `#[target_feature]` themselves; they are meant to be inlined into
//! a kernel that is itself inlined into the `#[target_feature(enable =
//! "avx512f,...")]` entry point of [`crate::run_native`], so the whole
//! kernel compiles to straight AVX-512 code. Called from anywhere else they
//! remain correct (the intrinsics are then out-of-line calls), just slower.
//!
//! # Safety argument
//!
//! [`Avx512`] is a zero-sized token whose only constructors check
//! `is_x86_feature_detected!` for every feature in [`FEATURES`] (or are
//! `unsafe`). Holding one proves the CPU executes these instructions, which
//! is the only precondition of the arithmetic intrinsics. Memory intrinsics
//! are additionally preceded by bounds checks on every active lane.

use crate::common::{self, aligned, masked_extent, need};
use crate::simd::{BackendKind, Simd};
use crate::Mask16;
use core::arch::x86_64::*;
use core::sync::atomic::AtomicI32;

/// The target features the AVX-512 backend is compiled for and requires.
pub const FEATURES: &str = "avx512f,avx512cd,avx512bw,avx512dq,avx512vl,avx2,fma,bmi1,bmi2,popcnt";

/// Native AVX-512 context. Construct with [`Avx512::new`].
#[derive(Clone, Copy, Debug)]
pub struct Avx512 {
    _private: (),
}

impl Avx512 {
    /// `Some` if this CPU has every feature in [`FEATURES`].
    pub fn new() -> Option<Self> {
        if detected() {
            Some(Avx512 { _private: () })
        } else {
            None
        }
    }
    /// # Safety
    /// The CPU must support every feature in [`FEATURES`].
    #[inline(always)]
    pub unsafe fn new_unchecked() -> Self {
        Avx512 { _private: () }
    }
}

/// Run-time detection of every feature the backend uses (cached by std).
pub fn detected() -> bool {
    std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx512cd")
        && std::is_x86_feature_detected!("avx512bw")
        && std::is_x86_feature_detected!("avx512dq")
        && std::is_x86_feature_detected!("avx512vl")
        && std::is_x86_feature_detected!("avx2")
        && std::is_x86_feature_detected!("fma")
        && std::is_x86_feature_detected!("bmi1")
        && std::is_x86_feature_detected!("bmi2")
        && std::is_x86_feature_detected!("popcnt")
}

#[inline(always)]
fn k(m: Mask16) -> __mmask16 {
    m.0
}

/// Bounds check of active lane indices: one unsigned compare + mask test.
#[inline(always)]
#[track_caller]
fn check_idx(op: &str, m: Mask16, idx: __m512i, len: usize) {
    let lim = common::index_limit(len);
    // SAFETY: `Avx512` exists, so avx512f is available (see module docs).
    let bad =
        unsafe { _mm512_mask_cmp_epu32_mask::<_MM_CMPINT_NLT>(k(m), idx, _mm512_set1_epi32(lim as i32)) };
    if bad != 0 {
        // A bit copy, not a store intrinsic: this cold path must not need the target features.
        // SAFETY: __m512i and [i32; 16] have the same size and every bit pattern is valid for both.
        let lanes: [i32; 16] = unsafe { core::mem::transmute(idx) };
        common::oob_index(op, m, &lanes, lim as usize);
    }
}

/// A register's lanes as an array. A bit copy, not a store intrinsic: the intrinsic is an
/// `#[inline]` function of its own, and LLVM once left it out of line in a large kernel (CI's
/// non-incremental build; `tests/integration/inlining.rs`), one call per conversion.
#[inline(always)]
fn to_i(v: __m512i) -> [i32; 16] {
    // SAFETY: __m512i and [i32; 16] have the same size and every bit pattern is valid for both.
    unsafe { core::mem::transmute(v) }
}

/// Tree reduction with the documented lane order (i^8, i^4, i^2, i^1).
macro_rules! tree_f {
    ($v:expr, $op:ident) => {{
        let v = $v;
        let v = $op(v, _mm512_shuffle_f32x4::<0b01_00_11_10>(v, v));
        let v = $op(v, _mm512_shuffle_f32x4::<0b10_11_00_01>(v, v));
        let v = $op(v, _mm512_permute_ps::<0b01_00_11_10>(v));
        let v = $op(v, _mm512_permute_ps::<0b10_11_00_01>(v));
        _mm512_cvtss_f32(v)
    }};
}

impl Simd for Avx512 {
    type F32 = __m512;
    type I32 = __m512i;

    #[inline(always)]
    fn kind(self) -> BackendKind {
        BackendKind::Avx512
    }

    // SAFETY (whole impl): every `unsafe` block below only calls AVX-512 /
    // AVX2 / FMA intrinsics, available because an `Avx512` token exists;
    // pointer-taking intrinsics are preceded by bounds checks covering every
    // active lane, and masked-off lanes are never accessed by the hardware.

    #[inline(always)]
    fn splat_f(self, x: f32) -> __m512 {
        unsafe { _mm512_set1_ps(x) }
    }
    #[inline(always)]
    fn splat_i(self, x: i32) -> __m512i {
        unsafe { _mm512_set1_epi32(x) }
    }
    #[inline(always)]
    fn from_array_f(self, a: [f32; 16]) -> __m512 {
        // SAFETY: bit copies between types of one size (see `to_i`).
        unsafe { core::mem::transmute(a) }
    }
    #[inline(always)]
    fn from_array_i(self, a: [i32; 16]) -> __m512i {
        // SAFETY: as above.
        unsafe { core::mem::transmute(a) }
    }
    #[inline(always)]
    fn to_array_f(self, v: __m512) -> [f32; 16] {
        // SAFETY: as above.
        unsafe { core::mem::transmute(v) }
    }
    #[inline(always)]
    fn to_array_i(self, v: __m512i) -> [i32; 16] {
        to_i(v)
    }
    #[inline(always)]
    fn index_i(self) -> __m512i {
        unsafe { _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) }
    }
    #[inline(always)]
    fn extract_f(self, v: __m512, lane: usize) -> f32 {
        if lane >= 16 {
            common::bad_lane(lane)
        }
        unsafe { _mm512_cvtss_f32(_mm512_permutexvar_ps(_mm512_set1_epi32(lane as i32), v)) }
    }
    #[inline(always)]
    fn extract_i(self, v: __m512i, lane: usize) -> i32 {
        if lane >= 16 {
            common::bad_lane(lane)
        }
        unsafe { _mm512_cvtsi512_si32(_mm512_permutexvar_epi32(_mm512_set1_epi32(lane as i32), v)) }
    }

    #[inline(always)]
    fn add_f(self, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_add_ps(a, b) }
    }
    #[inline(always)]
    fn sub_f(self, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_sub_ps(a, b) }
    }
    #[inline(always)]
    fn mul_f(self, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mul_ps(a, b) }
    }
    #[inline(always)]
    fn div_f(self, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_div_ps(a, b) }
    }
    #[inline(always)]
    fn fmadd(self, a: __m512, b: __m512, c: __m512) -> __m512 {
        unsafe { _mm512_fmadd_ps(a, b, c) }
    }
    #[inline(always)]
    fn fmsub(self, a: __m512, b: __m512, c: __m512) -> __m512 {
        unsafe { _mm512_fmsub_ps(a, b, c) }
    }
    #[inline(always)]
    fn fnmadd(self, a: __m512, b: __m512, c: __m512) -> __m512 {
        unsafe { _mm512_fnmadd_ps(a, b, c) }
    }
    #[inline(always)]
    fn min_f(self, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_min_ps(a, b) }
    }
    #[inline(always)]
    fn max_f(self, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_max_ps(a, b) }
    }
    #[inline(always)]
    fn abs_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_abs_ps(a) }
    }
    #[inline(always)]
    fn neg_f(self, a: __m512) -> __m512 {
        unsafe {
            _mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(a),
                _mm512_set1_epi32(i32::MIN),
            ))
        }
    }
    #[inline(always)]
    fn sqrt_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_sqrt_ps(a) }
    }
    #[inline(always)]
    fn rcp_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_div_ps(_mm512_set1_ps(1.0), a) }
    }
    #[inline(always)]
    fn rsqrt_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_div_ps(_mm512_set1_ps(1.0), _mm512_sqrt_ps(a)) }
    }
    #[inline(always)]
    fn rcp_fast_f(self, a: __m512) -> __m512 {
        unsafe {
            let r = _mm512_rcp14_ps(a);
            let e = _mm512_fnmadd_ps(a, r, _mm512_set1_ps(1.0));
            let r2 = _mm512_fmadd_ps(r, e, r);
            // Specials (0, inf) make the Newton step NaN: keep rcp14 there.
            let nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(r2, r2);
            _mm512_mask_blend_ps(nan, r2, r)
        }
    }
    #[inline(always)]
    fn rsqrt_fast_f(self, a: __m512) -> __m512 {
        unsafe {
            let r = _mm512_rsqrt14_ps(a);
            let h = _mm512_mul_ps(a, r);
            let e = _mm512_fnmadd_ps(h, r, _mm512_set1_ps(1.0));
            let r2 = _mm512_fmadd_ps(_mm512_mul_ps(r, _mm512_set1_ps(0.5)), e, r);
            let nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(r2, r2);
            _mm512_mask_blend_ps(nan, r2, r)
        }
    }
    #[inline(always)]
    fn floor_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_roundscale_ps::<0x09>(a) }
    }
    #[inline(always)]
    fn ceil_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_roundscale_ps::<0x0A>(a) }
    }
    #[inline(always)]
    fn trunc_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_roundscale_ps::<0x0B>(a) }
    }
    #[inline(always)]
    fn round_f(self, a: __m512) -> __m512 {
        unsafe { _mm512_roundscale_ps::<0x08>(a) }
    }

    #[inline(always)]
    fn mask_add_f(self, src: __m512, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_add_ps(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_sub_f(self, src: __m512, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_sub_ps(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_mul_f(self, src: __m512, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_mul_ps(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_div_f(self, src: __m512, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_div_ps(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_fmadd(self, src: __m512, m: Mask16, a: __m512, b: __m512, c: __m512) -> __m512 {
        unsafe { _mm512_mask_mov_ps(src, k(m), _mm512_fmadd_ps(a, b, c)) }
    }
    #[inline(always)]
    fn mask_min_f(self, src: __m512, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_min_ps(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_max_f(self, src: __m512, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_max_ps(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_sqrt_f(self, src: __m512, m: Mask16, a: __m512) -> __m512 {
        unsafe { _mm512_mask_sqrt_ps(src, k(m), a) }
    }
    #[inline(always)]
    fn select_f(self, m: Mask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_blend_ps(k(m), b, a) }
    }

    #[inline(always)]
    fn cmp_eq_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_ne_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_lt_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_le_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_gt_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_ge_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_unord_f(self, a: __m512, b: __m512) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(a, b) })
    }

    #[inline(always)]
    fn reduce_add_f(self, v: __m512) -> f32 {
        unsafe { tree_f!(v, _mm512_add_ps) }
    }
    #[inline(always)]
    fn reduce_min_f(self, v: __m512) -> f32 {
        unsafe { tree_f!(v, _mm512_min_ps) }
    }
    #[inline(always)]
    fn reduce_max_f(self, v: __m512) -> f32 {
        unsafe { tree_f!(v, _mm512_max_ps) }
    }
    #[inline(always)]
    fn permute_f(self, v: __m512, idx: __m512i) -> __m512 {
        unsafe { _mm512_permutexvar_ps(idx, v) }
    }
    #[inline(always)]
    fn compress_f(self, m: Mask16, v: __m512) -> __m512 {
        unsafe { _mm512_maskz_compress_ps(k(m), v) }
    }
    #[inline(always)]
    fn expand_f(self, m: Mask16, v: __m512) -> __m512 {
        unsafe { _mm512_maskz_expand_ps(k(m), v) }
    }

    #[inline(always)]
    fn add_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_add_epi32(a, b) }
    }
    #[inline(always)]
    fn sub_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_sub_epi32(a, b) }
    }
    #[inline(always)]
    fn mul_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_mullo_epi32(a, b) }
    }
    #[inline(always)]
    fn and_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_and_si512(a, b) }
    }
    #[inline(always)]
    fn or_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_or_si512(a, b) }
    }
    #[inline(always)]
    fn xor_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_xor_si512(a, b) }
    }
    #[inline(always)]
    fn andn_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_andnot_si512(a, b) }
    }
    #[inline(always)]
    fn shl_i(self, a: __m512i, n: u32) -> __m512i {
        unsafe { _mm512_sll_epi32(a, _mm_cvtsi32_si128(n.min(32) as i32)) }
    }
    #[inline(always)]
    fn shr_u(self, a: __m512i, n: u32) -> __m512i {
        unsafe { _mm512_srl_epi32(a, _mm_cvtsi32_si128(n.min(32) as i32)) }
    }
    #[inline(always)]
    fn shr_i(self, a: __m512i, n: u32) -> __m512i {
        unsafe { _mm512_sra_epi32(a, _mm_cvtsi32_si128(n.min(32) as i32)) }
    }
    #[inline(always)]
    fn shlv_i(self, a: __m512i, n: __m512i) -> __m512i {
        unsafe { _mm512_sllv_epi32(a, n) }
    }
    #[inline(always)]
    fn shrv_u(self, a: __m512i, n: __m512i) -> __m512i {
        unsafe { _mm512_srlv_epi32(a, n) }
    }
    #[inline(always)]
    fn shrv_i(self, a: __m512i, n: __m512i) -> __m512i {
        unsafe { _mm512_srav_epi32(a, n) }
    }
    #[inline(always)]
    fn min_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_min_epi32(a, b) }
    }
    #[inline(always)]
    fn max_i(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_max_epi32(a, b) }
    }
    #[inline(always)]
    fn min_u(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_min_epu32(a, b) }
    }
    #[inline(always)]
    fn max_u(self, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_max_epu32(a, b) }
    }
    #[inline(always)]
    fn abs_i(self, a: __m512i) -> __m512i {
        unsafe { _mm512_abs_epi32(a) }
    }
    #[inline(always)]
    fn mask_add_i(self, src: __m512i, m: Mask16, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_mask_add_epi32(src, k(m), a, b) }
    }
    #[inline(always)]
    fn mask_sub_i(self, src: __m512i, m: Mask16, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_mask_sub_epi32(src, k(m), a, b) }
    }
    #[inline(always)]
    fn select_i(self, m: Mask16, a: __m512i, b: __m512i) -> __m512i {
        unsafe { _mm512_mask_blend_epi32(k(m), b, a) }
    }

    #[inline(always)]
    fn cmp_eq_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epi32_mask::<_MM_CMPINT_EQ>(a, b) })
    }
    #[inline(always)]
    fn cmp_ne_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epi32_mask::<_MM_CMPINT_NE>(a, b) })
    }
    #[inline(always)]
    fn cmp_lt_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epi32_mask::<_MM_CMPINT_LT>(a, b) })
    }
    #[inline(always)]
    fn cmp_le_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epi32_mask::<_MM_CMPINT_LE>(a, b) })
    }
    #[inline(always)]
    fn cmp_gt_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epi32_mask::<_MM_CMPINT_NLE>(a, b) })
    }
    #[inline(always)]
    fn cmp_ge_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epi32_mask::<_MM_CMPINT_NLT>(a, b) })
    }
    #[inline(always)]
    fn cmp_lt_u(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epu32_mask::<_MM_CMPINT_LT>(a, b) })
    }
    #[inline(always)]
    fn cmp_le_u(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epu32_mask::<_MM_CMPINT_LE>(a, b) })
    }
    #[inline(always)]
    fn cmp_gt_u(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epu32_mask::<_MM_CMPINT_NLE>(a, b) })
    }
    #[inline(always)]
    fn cmp_ge_u(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_cmp_epu32_mask::<_MM_CMPINT_NLT>(a, b) })
    }
    #[inline(always)]
    fn test_i(self, a: __m512i, b: __m512i) -> Mask16 {
        Mask16(unsafe { _mm512_test_epi32_mask(a, b) })
    }

    #[inline(always)]
    fn reduce_add_i(self, v: __m512i) -> i32 {
        unsafe { _mm512_reduce_add_epi32(v) }
    }
    #[inline(always)]
    fn reduce_min_i(self, v: __m512i) -> i32 {
        unsafe { _mm512_reduce_min_epi32(v) }
    }
    #[inline(always)]
    fn reduce_max_i(self, v: __m512i) -> i32 {
        unsafe { _mm512_reduce_max_epi32(v) }
    }
    #[inline(always)]
    fn reduce_min_u(self, v: __m512i) -> u32 {
        unsafe { _mm512_reduce_min_epu32(v) }
    }
    #[inline(always)]
    fn reduce_max_u(self, v: __m512i) -> u32 {
        unsafe { _mm512_reduce_max_epu32(v) }
    }
    #[inline(always)]
    fn reduce_or_i(self, v: __m512i) -> i32 {
        unsafe { _mm512_reduce_or_epi32(v) }
    }
    #[inline(always)]
    fn reduce_and_i(self, v: __m512i) -> i32 {
        unsafe { _mm512_reduce_and_epi32(v) }
    }
    #[inline(always)]
    fn permute_i(self, v: __m512i, idx: __m512i) -> __m512i {
        unsafe { _mm512_permutexvar_epi32(idx, v) }
    }
    #[inline(always)]
    fn compress_i(self, m: Mask16, v: __m512i) -> __m512i {
        unsafe { _mm512_maskz_compress_epi32(k(m), v) }
    }
    #[inline(always)]
    fn expand_i(self, m: Mask16, v: __m512i) -> __m512i {
        unsafe { _mm512_maskz_expand_epi32(k(m), v) }
    }
    #[inline(always)]
    fn conflict_i(self, v: __m512i) -> __m512i {
        unsafe { _mm512_conflict_epi32(v) }
    }

    #[inline(always)]
    fn cvt_i_f(self, a: __m512i) -> __m512 {
        unsafe { _mm512_cvtepi32_ps(a) }
    }
    #[inline(always)]
    fn cvt_u_f(self, a: __m512i) -> __m512 {
        unsafe { _mm512_cvtepu32_ps(a) }
    }
    #[inline(always)]
    fn cvtt_f_i(self, a: __m512) -> __m512i {
        unsafe { _mm512_cvttps_epi32(a) }
    }
    #[inline(always)]
    fn cvtr_f_i(self, a: __m512) -> __m512i {
        unsafe { _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(a) }
    }
    #[inline(always)]
    fn cast_f_i(self, a: __m512) -> __m512i {
        unsafe { _mm512_castps_si512(a) }
    }
    #[inline(always)]
    fn cast_i_f(self, a: __m512i) -> __m512 {
        unsafe { _mm512_castsi512_ps(a) }
    }

    crate::common::native_mask_ops!();

    #[inline(always)]
    fn load_f(self, mem: &[f32]) -> __m512 {
        need("load_f", mem.len(), 16);
        unsafe { _mm512_loadu_ps(mem.as_ptr()) }
    }
    #[inline(always)]
    fn load_i(self, mem: &[i32]) -> __m512i {
        need("load_i", mem.len(), 16);
        unsafe { _mm512_loadu_epi32(mem.as_ptr()) }
    }
    #[inline(always)]
    fn load_aligned_f(self, mem: &[f32]) -> __m512 {
        aligned("load_aligned_f", mem);
        unsafe { _mm512_load_ps(mem.as_ptr()) }
    }
    #[inline(always)]
    fn load_aligned_i(self, mem: &[i32]) -> __m512i {
        aligned("load_aligned_i", mem);
        unsafe { _mm512_load_epi32(mem.as_ptr()) }
    }
    #[inline(always)]
    fn store_f(self, mem: &mut [f32], v: __m512) {
        need("store_f", mem.len(), 16);
        unsafe { _mm512_storeu_ps(mem.as_mut_ptr(), v) }
    }
    #[inline(always)]
    fn store_i(self, mem: &mut [i32], v: __m512i) {
        need("store_i", mem.len(), 16);
        unsafe { _mm512_storeu_epi32(mem.as_mut_ptr(), v) }
    }
    #[inline(always)]
    fn store_aligned_f(self, mem: &mut [f32], v: __m512) {
        aligned("store_aligned_f", mem);
        unsafe { _mm512_store_ps(mem.as_mut_ptr(), v) }
    }
    #[inline(always)]
    fn store_aligned_i(self, mem: &mut [i32], v: __m512i) {
        aligned("store_aligned_i", mem);
        unsafe { _mm512_store_epi32(mem.as_mut_ptr(), v) }
    }
    #[inline(always)]
    fn mask_load_f(self, src: __m512, m: Mask16, mem: &[f32]) -> __m512 {
        need("mask_load_f", mem.len(), masked_extent(m));
        unsafe { _mm512_mask_loadu_ps(src, k(m), mem.as_ptr()) }
    }
    #[inline(always)]
    fn mask_load_i(self, src: __m512i, m: Mask16, mem: &[i32]) -> __m512i {
        need("mask_load_i", mem.len(), masked_extent(m));
        unsafe { _mm512_mask_loadu_epi32(src, k(m), mem.as_ptr()) }
    }
    #[inline(always)]
    fn mask_store_f(self, mem: &mut [f32], m: Mask16, v: __m512) {
        need("mask_store_f", mem.len(), masked_extent(m));
        unsafe { _mm512_mask_storeu_ps(mem.as_mut_ptr(), k(m), v) }
    }
    #[inline(always)]
    fn mask_store_i(self, mem: &mut [i32], m: Mask16, v: __m512i) {
        need("mask_store_i", mem.len(), masked_extent(m));
        unsafe { _mm512_mask_storeu_epi32(mem.as_mut_ptr(), k(m), v) }
    }
    #[inline(always)]
    fn gather_f(self, mem: &[f32], idx: __m512i) -> __m512 {
        check_idx("gather_f", Mask16::ALL, idx, mem.len());
        unsafe { _mm512_i32gather_ps::<4>(idx, mem.as_ptr()) }
    }
    #[inline(always)]
    fn gather_i(self, mem: &[i32], idx: __m512i) -> __m512i {
        check_idx("gather_i", Mask16::ALL, idx, mem.len());
        unsafe { _mm512_i32gather_epi32::<4>(idx, mem.as_ptr()) }
    }
    #[inline(always)]
    fn mask_gather_f(self, src: __m512, m: Mask16, mem: &[f32], idx: __m512i) -> __m512 {
        check_idx("gather_f", m, idx, mem.len());
        unsafe { _mm512_mask_i32gather_ps::<4>(src, k(m), idx, mem.as_ptr()) }
    }
    #[inline(always)]
    fn mask_gather_i(self, src: __m512i, m: Mask16, mem: &[i32], idx: __m512i) -> __m512i {
        check_idx("gather_i", m, idx, mem.len());
        unsafe { _mm512_mask_i32gather_epi32::<4>(src, k(m), idx, mem.as_ptr()) }
    }
    #[inline(always)]
    fn mask_scatter_f(self, mem: &mut [f32], m: Mask16, idx: __m512i, v: __m512) {
        check_idx("scatter_f", m, idx, mem.len());
        unsafe { _mm512_mask_i32scatter_ps::<4>(mem.as_mut_ptr(), k(m), idx, v) }
    }
    #[inline(always)]
    fn mask_scatter_i(self, mem: &mut [i32], m: Mask16, idx: __m512i, v: __m512i) {
        check_idx("scatter_i", m, idx, mem.len());
        unsafe { _mm512_mask_i32scatter_epi32::<4>(mem.as_mut_ptr(), k(m), idx, v) }
    }
    #[inline(always)]
    fn compress_store_f(self, mem: &mut [f32], m: Mask16, v: __m512) -> usize {
        let n = m.count() as usize;
        need("compress_store_f", mem.len(), n);
        // Register compress + masked store: much faster than the
        // memory-destination vcompressps on current cores.
        unsafe {
            let c = _mm512_maskz_compress_ps(k(m), v);
            _mm512_mask_storeu_ps(mem.as_mut_ptr(), Mask16::first_n(n).0, c);
        }
        n
    }
    #[inline(always)]
    fn compress_store_i(self, mem: &mut [i32], m: Mask16, v: __m512i) -> usize {
        let n = m.count() as usize;
        need("compress_store_i", mem.len(), n);
        unsafe {
            let c = _mm512_maskz_compress_epi32(k(m), v);
            _mm512_mask_storeu_epi32(mem.as_mut_ptr(), Mask16::first_n(n).0, c);
        }
        n
    }
    #[inline(always)]
    fn expand_load_f(self, src: __m512, m: Mask16, mem: &[f32]) -> __m512 {
        let n = m.count() as usize;
        need("expand_load_f", mem.len(), n);
        unsafe {
            let l = _mm512_maskz_loadu_ps(Mask16::first_n(n).0, mem.as_ptr());
            _mm512_mask_expand_ps(src, k(m), l)
        }
    }
    #[inline(always)]
    fn expand_load_i(self, src: __m512i, m: Mask16, mem: &[i32]) -> __m512i {
        let n = m.count() as usize;
        need("expand_load_i", mem.len(), n);
        unsafe {
            let l = _mm512_maskz_loadu_epi32(Mask16::first_n(n).0, mem.as_ptr());
            _mm512_mask_expand_epi32(src, k(m), l)
        }
    }
    #[inline(always)]
    fn fetch_add_i(self, mem: &mut [i32], m: Mask16, idx: __m512i, val: __m512i) -> __m512i {
        check_idx("fetch_add_i", m, idx, mem.len());
        unsafe {
            let km = k(m);
            // conf[i]: active lanes j < i with the same index.
            let conf = _mm512_and_si512(_mm512_maskz_conflict_epi32(km, idx), _mm512_set1_epi32(km as i32));
            // Exclusive prefix of val over each lane's earlier duplicates:
            // loop only over lanes that are someone's earlier duplicate.
            let mut pre = _mm512_setzero_si512();
            let mut dups = _mm512_reduce_or_epi32(conf) as u32;
            while dups != 0 {
                let j = dups.trailing_zeros();
                dups &= dups - 1;
                let has = _mm512_test_epi32_mask(conf, _mm512_set1_epi32(1 << j));
                let vj = _mm512_permutexvar_epi32(_mm512_set1_epi32(j as i32), val);
                pre = _mm512_mask_add_epi32(pre, has, pre, vj);
            }
            let old = _mm512_mask_i32gather_epi32::<4>(_mm512_setzero_si512(), km, idx, mem.as_ptr());
            let before = _mm512_add_epi32(old, pre);
            // Scatter writes in lane order: the last duplicate, holding the
            // group's full sum, wins.
            let new = _mm512_add_epi32(before, val);
            _mm512_mask_i32scatter_epi32::<4>(mem.as_mut_ptr(), km, idx, new);
            _mm512_maskz_mov_epi32(km, before)
        }
    }
    #[inline(always)]
    fn atomic_fetch_add_i(self, mem: &[AtomicI32], m: Mask16, idx: __m512i, val: __m512i) -> __m512i {
        check_idx("atomic_fetch_add_i", m, idx, mem.len());
        let conf = to_i(unsafe { _mm512_conflict_epi32(idx) });
        let out = common::atomic_fetch_add(mem, m, &to_i(idx), &to_i(val), &conf);
        self.from_array_i(out)
    }
}
