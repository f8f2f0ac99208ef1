//! The [`Simd`] trait: the 16-wide vector ISA every kernel is written in.

use crate::Mask16;
use core::sync::atomic::AtomicI32;

/// Number of lanes of every vector.
pub const LANES: usize = 16;

/// Which implementation a context uses (see [`crate::run_native`] and
/// [`crate::selected_backend`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BackendKind {
    /// Native AVX-512 (`x86_64` with avx512f/cd/bw/dq/vl detected at run time).
    Avx512,
    /// Native AVX2 (`x86_64` with avx2/fma/bmi1/bmi2/popcnt detected at run time): each 16-lane
    /// vector is two 256-bit registers ([`crate::avx2`]).
    Avx2,
    /// The portable array backend, compiled for AVX2+FMA (`x86_64` only,
    /// when detected). Same source as [`BackendKind::Portable`]; only the
    /// code generation differs, results are identical.
    PortableAvx2,
    /// The portable array backend compiled for the baseline target.
    Portable,
}

impl BackendKind {
    /// Short lower-case name (`avx512`, `avx2`, `portable-avx2`, `portable`).
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Avx512 => "avx512",
            BackendKind::Avx2 => "avx2",
            BackendKind::PortableAvx2 => "portable-avx2",
            BackendKind::Portable => "portable",
        }
    }
}

/// Class of a counted scalar operation ([`Simd::scalar_op`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarClass {
    /// Integer add, subtract, multiply, min/max, shifts and logic; float abs, rounding and
    /// conversions ([`Simd::s_fn`]).
    Alu,
    /// Float add, subtract, multiply, min/max ([`Simd::s_add`] and friends on `f32`/`f64`): on an
    /// out-of-order x86 core these issue on the vector unit's pipes, beside the vector operations,
    /// not on the integer ALUs.
    Float,
    /// Divides and square roots (long latency, not pipelined on most cores).
    Div,
    /// Compares feeding branches, and branches.
    Branch,
    /// Loads (their lines go into the task's line stream).
    Mem,
    /// Stores (their lines go into the task's line stream): counted in `scalar_mem` with the
    /// loads, and apart in `scalar_stores`, since each one holds a store-buffer entry until its
    /// line is in the cache.
    Store,
}

/// The scalar number types the counted scalar operations take.
pub trait ScalarNum:
    Copy
    + ChainKey
    + PartialOrd
    + core::ops::Add<Output = Self>
    + core::ops::Sub<Output = Self>
    + core::ops::Mul<Output = Self>
    + core::ops::Div<Output = Self>
{
    /// The class of its add, subtract, multiply, min and max: [`ScalarClass::Float`] for floats,
    /// [`ScalarClass::Alu`] for integers.
    const CLASS: ScalarClass;
    /// The type's own `min` (floats: `f32::min`'s NaN rule).
    fn min_of(self, b: Self) -> Self;
    /// The type's own `max`.
    fn max_of(self, b: Self) -> Self;
}

/// What identifies a scalar value for the counting context's dependency chains: floats by their
/// bits (and type); integers, flags and counters are not followed (`None`: their chains are one
/// cycle an operation, loop counters mostly, and small integers repeat too often to tell apart).
/// A float produced by a counted operation is as deep as that operation's chain; one never
/// produced in the task (a constant, a loaded value) is ready when the task begins.
pub trait ChainKey: Copy {
    /// The key of this value, if its chain is followed.
    fn chain_key(self) -> Option<u64> {
        None
    }
}
impl ChainKey for f32 {
    #[inline(always)]
    fn chain_key(self) -> Option<u64> {
        // The commonest constants (±0, ±1) are not followed: an operation reading the literal 1.0
        // does not depend on the last operation that happened to produce 1.0.
        let b = self.to_bits() & 0x7fff_ffff;
        (b != 0 && b != 0x3f80_0000).then_some(u64::from(self.to_bits()) | 1 << 32)
    }
}
impl ChainKey for f64 {
    #[inline(always)]
    fn chain_key(self) -> Option<u64> {
        let b = self.to_bits() & 0x7fff_ffff_ffff_ffff;
        (b != 0 && b != 0x3ff0_0000_0000_0000).then_some(self.to_bits() ^ 0x9e37_79b9_7f4a_7c15)
    }
}
impl ChainKey for bool {}
impl ChainKey for u8 {}
impl ChainKey for u16 {}
impl ChainKey for u32 {}
impl ChainKey for u64 {}
impl ChainKey for i32 {}
impl ChainKey for i64 {}
impl ChainKey for usize {}

/// Nominal latencies of the counted scalar operations, cycles (as [`crate::latency`]'s for vector
/// operations; a machine scales both by `latency_scale`): Zen 4's and Ice Lake's scalar SSE figures
/// (Agner Fog's tables: `addss`/`mulss`/`minss` 3, `divss` 10–11, `sqrtss` 12–15; the divide
/// taken as the vector one's, 14).
pub mod scalar_latency {
    /// Add, subtract, multiply, min/max, conversions and the other ALU operations.
    pub const ALU: u64 = 3;
    /// Divide and square root (the vector unit's correctly rounded divide, [`crate::latency::DIV`]).
    pub const DIV: u64 = 14;
}

macro_rules! scalar_num {
    ($class:ident: $($t:ty),*) => { $(
        impl ScalarNum for $t {
            const CLASS: ScalarClass = ScalarClass::$class;
            #[inline(always)]
            fn min_of(self, b: Self) -> Self {
                self.min(b)
            }
            #[inline(always)]
            fn max_of(self, b: Self) -> Self {
                self.max(b)
            }
        }
    )* };
}
scalar_num!(Float: f32, f64);
scalar_num!(Alu: i32, u32, i64, u64, usize);

/// [`Simd::s_read_words`] and [`Simd::s_wrote_words`]: one [`ScalarClass::Mem`] (read) or
/// [`ScalarClass::Store`] (written) per 4 bytes of `*r` (at least one), and its lines once.
#[inline(always)]
fn count_words<S: Simd, T>(s: S, r: &T, write: bool) {
    let class = if write {
        ScalarClass::Store
    } else {
        ScalarClass::Mem
    };
    for _ in 0..core::mem::size_of::<T>().div_ceil(4).max(1) {
        s.scalar_op(class);
    }
    s.scalar_touch(r as *const T as usize, core::mem::size_of::<T>(), write);
}

/// The 16-wide vector instruction set, in the style of Larrabee's LRBni.
///
/// A *context* `S: Simd` is a zero-sized (or pointer-sized, for counting)
/// `Copy` token. Kernels are generic functions over `S` and issue every
/// vector operation as a method call on the context: `s.fmadd(a, b, c)`.
/// Each backend maps the methods to its representation:
///
/// * [`crate::Avx512`]: `F32 = __m512`, `I32 = __m512i`, each method one or
///   a few intrinsics;
/// * [`crate::Portable`]: `F32 = [f32; 16]` (64-byte aligned), lane loops
///   LLVM auto-vectorizes;
/// * [`crate::Counting`]: wraps another backend, forwards every method and
///   records what was issued (class, active lanes, cache lines).
///
/// # Conventions
///
/// * Methods with suffix `_f` work on 16 × `f32`, `_i` on 16 × `i32`
///   (two's-complement wrapping), `_u` on the same `I32` register
///   interpreted as 16 × `u32`.
/// * Merge-masked operations are named `mask_*` and take `(src, m, ...)`:
///   lanes whose mask bit is set get the result, the others keep `src`
///   (exactly AVX-512's merge masking).
/// * Comparisons return a [`Mask16`]. Float comparisons are *ordered*
///   (false when either operand is NaN) except `cmp_ne_f` (true on NaN).
/// * `min_f(a, b)` is `if a < b { a } else { b }` and `max_f(a, b)` is
///   `if a > b { a } else { b }` (x86 `minps`/`maxps` semantics): if either
///   operand is NaN the **second** operand is returned, and `min(-0, +0)`
///   returns `+0` (the second). Every backend implements exactly this.
/// * Memory operations take slices. Active lanes must be in bounds and are
///   checked on every backend (panic with a message naming the op, lane,
///   index and length); inactive lanes never touch memory.
/// * Unless documented otherwise, results are **bit-identical** across
///   backends (NaN payloads aside: any NaN is reported as NaN by both, but
///   the payload bits of a NaN may differ between hardware families).
///   The only deliberately non-bit-identical operations are
///   [`Simd::rcp_fast_f`] and [`Simd::rsqrt_fast_f`].
///
/// Derived operations (transcendentals, clamps, …) are provided methods
/// built from the required ones. Backends never override them, so they are
/// bit-identical everywhere and the counting context counts them as the
/// instructions they really are.
///
/// All methods are `#[inline(always)]` in every backend: a kernel generic
/// over `S` and itself marked `#[inline(always)]` is compiled as one body
/// inside the `#[target_feature]` entry point chosen by
/// [`crate::run_native`].
#[allow(clippy::wrong_self_convention)]
pub trait Simd: Copy {
    /// 16 × `f32`.
    type F32: Copy;
    /// 16 × `i32` (also used as 16 × `u32`).
    type I32: Copy;

    /// Which backend performs the arithmetic (for a counting context: the
    /// wrapped one).
    fn kind(self) -> BackendKind;

    // ------------------------------------------------------------------
    // Construction and lane access
    // ------------------------------------------------------------------

    /// Broadcast a scalar to all lanes.
    fn splat_f(self, x: f32) -> Self::F32;
    /// Broadcast a scalar to all lanes.
    fn splat_i(self, x: i32) -> Self::I32;
    /// Vector from an array (register load; counted as a load without
    /// cache-line traffic).
    fn from_array_f(self, a: [f32; 16]) -> Self::F32;
    /// Vector from an array.
    fn from_array_i(self, a: [i32; 16]) -> Self::I32;
    /// Vector to an array (counted as a store without cache-line traffic).
    fn to_array_f(self, v: Self::F32) -> [f32; 16];
    /// Vector to an array.
    fn to_array_i(self, v: Self::I32) -> [i32; 16];
    /// The lane index vector `[0, 1, ..., 15]`.
    fn index_i(self) -> Self::I32;
    /// Read one lane. Panics if `lane >= 16`.
    fn extract_f(self, v: Self::F32, lane: usize) -> f32;
    /// Read one lane. Panics if `lane >= 16`.
    fn extract_i(self, v: Self::I32, lane: usize) -> i32;

    // ------------------------------------------------------------------
    // f32 arithmetic
    // ------------------------------------------------------------------

    /// `a + b`.
    fn add_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
    /// `a - b`.
    fn sub_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
    /// `a * b`.
    fn mul_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
    /// `a / b`, correctly rounded (IEEE). Counted as a transcendental-class
    /// (long-latency) instruction.
    fn div_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Fused `a * b + c` (single rounding).
    fn fmadd(self, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
    /// Fused `a * b - c` (single rounding).
    fn fmsub(self, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
    /// Fused `-(a * b) + c` (single rounding).
    fn fnmadd(self, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
    /// `if a < b { a } else { b }` (x86 semantics, see the trait docs).
    fn min_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
    /// `if a > b { a } else { b }` (x86 semantics, see the trait docs).
    fn max_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
    /// `|a|` (clears the sign bit, also of NaNs).
    fn abs_f(self, a: Self::F32) -> Self::F32;
    /// `-a` (flips the sign bit, also of NaNs and zeros).
    fn neg_f(self, a: Self::F32) -> Self::F32;
    /// Correctly rounded square root (IEEE); `sqrt(-0) = -0`, negative → NaN.
    fn sqrt_f(self, a: Self::F32) -> Self::F32;
    /// Reciprocal `1 / a`, correctly rounded (a true division, bit-identical
    /// everywhere). See [`Simd::rcp_fast_f`] for the approximation.
    fn rcp_f(self, a: Self::F32) -> Self::F32;
    /// `1 / sqrt(a)` as a correctly rounded sqrt followed by a correctly
    /// rounded division: relative error ≤ 2⁻²³ (measured 8.9e-8, under
    /// 1.5 ulp), bit-identical everywhere.
    fn rsqrt_f(self, a: Self::F32) -> Self::F32;
    /// Fast reciprocal. **Not bit-identical across backends.** AVX-512:
    /// `vrcp14ps` plus one Newton–Raphson step (relative error ≤ 2⁻²²,
    /// specials: ±0 → ±inf, ±inf → ±0, NaN → NaN); portable: `1 / a`.
    fn rcp_fast_f(self, a: Self::F32) -> Self::F32;
    /// Fast reciprocal square root. **Not bit-identical across backends.**
    /// AVX-512: `vrsqrt14ps` plus one Newton–Raphson step (relative error
    /// ≤ 2⁻²²; +0 → +inf, +inf → 0, negative → NaN); portable:
    /// `1 / sqrt(a)`.
    fn rsqrt_fast_f(self, a: Self::F32) -> Self::F32;
    /// Round toward −∞ (exact).
    fn floor_f(self, a: Self::F32) -> Self::F32;
    /// Round toward +∞ (exact).
    fn ceil_f(self, a: Self::F32) -> Self::F32;
    /// Round toward zero (exact).
    fn trunc_f(self, a: Self::F32) -> Self::F32;
    /// Round to nearest, ties to even (exact).
    fn round_f(self, a: Self::F32) -> Self::F32;

    /// Merge-masked `a + b`.
    fn mask_add_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Merge-masked `a - b`.
    fn mask_sub_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Merge-masked `a * b`.
    fn mask_mul_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Merge-masked `a / b`.
    fn mask_div_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Merge-masked fused `a * b + c`.
    fn mask_fmadd(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
    /// Merge-masked `min_f`.
    fn mask_min_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Merge-masked `max_f`.
    fn mask_max_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    /// Merge-masked square root.
    fn mask_sqrt_f(self, src: Self::F32, m: Mask16, a: Self::F32) -> Self::F32;
    /// Blend: `m ? a : b` per lane.
    fn select_f(self, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;

    /// `a == b` (ordered: false on NaN).
    fn cmp_eq_f(self, a: Self::F32, b: Self::F32) -> Mask16;
    /// `a != b` (unordered: true on NaN).
    fn cmp_ne_f(self, a: Self::F32, b: Self::F32) -> Mask16;
    /// `a < b` (ordered).
    fn cmp_lt_f(self, a: Self::F32, b: Self::F32) -> Mask16;
    /// `a <= b` (ordered).
    fn cmp_le_f(self, a: Self::F32, b: Self::F32) -> Mask16;
    /// `a > b` (ordered).
    fn cmp_gt_f(self, a: Self::F32, b: Self::F32) -> Mask16;
    /// `a >= b` (ordered).
    fn cmp_ge_f(self, a: Self::F32, b: Self::F32) -> Mask16;
    /// `a.is_nan() || b.is_nan()`.
    fn cmp_unord_f(self, a: Self::F32, b: Self::F32) -> Mask16;

    /// Horizontal sum in a fixed tree order, the same on every backend: lane
    /// `i` is combined with lane `i^8`, then `i^4`, `i^2`, `i^1`; the result
    /// is lane 0.
    /// Counted as 4 vector ALU instructions.
    fn reduce_add_f(self, v: Self::F32) -> f32;
    /// Horizontal `min_f` in the same tree order as `reduce_add_f`
    /// (x86 NaN semantics apply at every step).
    fn reduce_min_f(self, v: Self::F32) -> f32;
    /// Horizontal `max_f` in the same tree order as `reduce_add_f`.
    fn reduce_max_f(self, v: Self::F32) -> f32;
    /// Lane permute: `out[i] = v[idx[i] & 15]`.
    fn permute_f(self, v: Self::F32, idx: Self::I32) -> Self::F32;
    /// Register compress: active lanes of `v` packed to the low lanes in
    /// order, remaining lanes zero.
    fn compress_f(self, m: Mask16, v: Self::F32) -> Self::F32;
    /// Register expand: the low lanes of `v` are distributed, in order, to
    /// the active lanes; inactive lanes are zero.
    fn expand_f(self, m: Mask16, v: Self::F32) -> Self::F32;

    // ------------------------------------------------------------------
    // i32 / u32 arithmetic and bit operations
    // ------------------------------------------------------------------

    /// Wrapping `a + b`.
    fn add_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Wrapping `a - b`.
    fn sub_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Wrapping `a * b` (low 32 bits; same for signed and unsigned).
    fn mul_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a & b`.
    fn and_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a | b`.
    fn or_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a ^ b`.
    fn xor_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `!a & b` (Intel `andnot` operand order).
    fn andn_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Logical left shift by a uniform count; counts ≥ 32 give 0.
    fn shl_i(self, a: Self::I32, n: u32) -> Self::I32;
    /// Logical right shift by a uniform count; counts ≥ 32 give 0.
    fn shr_u(self, a: Self::I32, n: u32) -> Self::I32;
    /// Arithmetic right shift by a uniform count; counts ≥ 32 fill with
    /// the sign bit.
    fn shr_i(self, a: Self::I32, n: u32) -> Self::I32;
    /// Per-lane logical left shift; counts (as u32) ≥ 32 give 0.
    fn shlv_i(self, a: Self::I32, n: Self::I32) -> Self::I32;
    /// Per-lane logical right shift; counts (as u32) ≥ 32 give 0.
    fn shrv_u(self, a: Self::I32, n: Self::I32) -> Self::I32;
    /// Per-lane arithmetic right shift; counts (as u32) ≥ 32 fill with sign.
    fn shrv_i(self, a: Self::I32, n: Self::I32) -> Self::I32;
    /// Signed minimum.
    fn min_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Signed maximum.
    fn max_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Unsigned minimum.
    fn min_u(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Unsigned maximum.
    fn max_u(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Wrapping absolute value (`i32::MIN` stays `i32::MIN`).
    fn abs_i(self, a: Self::I32) -> Self::I32;
    /// Merge-masked wrapping `a + b`.
    fn mask_add_i(self, src: Self::I32, m: Mask16, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Merge-masked wrapping `a - b`.
    fn mask_sub_i(self, src: Self::I32, m: Mask16, a: Self::I32, b: Self::I32) -> Self::I32;
    /// Blend: `m ? a : b` per lane.
    fn select_i(self, m: Mask16, a: Self::I32, b: Self::I32) -> Self::I32;

    /// `a == b`.
    fn cmp_eq_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// `a != b`.
    fn cmp_ne_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Signed `a < b`.
    fn cmp_lt_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Signed `a <= b`.
    fn cmp_le_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Signed `a > b`.
    fn cmp_gt_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Signed `a >= b`.
    fn cmp_ge_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Unsigned `a < b`.
    fn cmp_lt_u(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Unsigned `a <= b`.
    fn cmp_le_u(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Unsigned `a > b`.
    fn cmp_gt_u(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// Unsigned `a >= b`.
    fn cmp_ge_u(self, a: Self::I32, b: Self::I32) -> Mask16;
    /// `(a & b) != 0` per lane (`vptestmd`).
    fn test_i(self, a: Self::I32, b: Self::I32) -> Mask16;

    /// Wrapping horizontal sum. Counted as 4 vector ALU instructions, as are
    /// all horizontal reductions.
    fn reduce_add_i(self, v: Self::I32) -> i32;
    /// Signed horizontal minimum.
    fn reduce_min_i(self, v: Self::I32) -> i32;
    /// Signed horizontal maximum.
    fn reduce_max_i(self, v: Self::I32) -> i32;
    /// Unsigned horizontal minimum.
    fn reduce_min_u(self, v: Self::I32) -> u32;
    /// Unsigned horizontal maximum.
    fn reduce_max_u(self, v: Self::I32) -> u32;
    /// Horizontal bitwise or.
    fn reduce_or_i(self, v: Self::I32) -> i32;
    /// Horizontal bitwise and.
    fn reduce_and_i(self, v: Self::I32) -> i32;
    /// Lane permute: `out[i] = v[idx[i] & 15]`.
    fn permute_i(self, v: Self::I32, idx: Self::I32) -> Self::I32;
    /// Register compress (see [`Simd::compress_f`]).
    fn compress_i(self, m: Mask16, v: Self::I32) -> Self::I32;
    /// Register expand (see [`Simd::expand_f`]).
    fn expand_i(self, m: Mask16, v: Self::I32) -> Self::I32;
    /// Conflict detection (`vpconflictd`): lane `i` gets the bit set of the
    /// lanes `j < i` with `v[j] == v[i]`.
    fn conflict_i(self, v: Self::I32) -> Self::I32;

    // ------------------------------------------------------------------
    // Conversions
    // ------------------------------------------------------------------

    /// `i32 → f32`, round to nearest even.
    fn cvt_i_f(self, a: Self::I32) -> Self::F32;
    /// `u32 → f32`, round to nearest even.
    fn cvt_u_f(self, a: Self::I32) -> Self::F32;
    /// `f32 → i32` truncating toward zero. NaN and out-of-range inputs give
    /// `i32::MIN` (x86 "integer indefinite"), on every backend.
    fn cvtt_f_i(self, a: Self::F32) -> Self::I32;
    /// `f32 → i32` rounding to nearest even. NaN and out-of-range inputs
    /// give `i32::MIN`.
    fn cvtr_f_i(self, a: Self::F32) -> Self::I32;
    /// Reinterpret the bits of f32 lanes as i32.
    fn cast_f_i(self, a: Self::F32) -> Self::I32;
    /// Reinterpret the bits of i32 lanes as f32.
    fn cast_i_f(self, a: Self::I32) -> Self::F32;

    // ------------------------------------------------------------------
    // Masks (counted as mask-class instructions)
    // ------------------------------------------------------------------

    /// `a & b`.
    fn mask_and(self, a: Mask16, b: Mask16) -> Mask16;
    /// `a | b`.
    fn mask_or(self, a: Mask16, b: Mask16) -> Mask16;
    /// `a ^ b`.
    fn mask_xor(self, a: Mask16, b: Mask16) -> Mask16;
    /// `!a & b`.
    fn mask_andn(self, a: Mask16, b: Mask16) -> Mask16;
    /// `!a`.
    fn mask_not(self, a: Mask16) -> Mask16;
    /// Number of active lanes.
    fn mask_popcnt(self, a: Mask16) -> u32;
    /// Any lane active?
    fn mask_any(self, a: Mask16) -> bool;
    /// All lanes active?
    fn mask_all(self, a: Mask16) -> bool;
    /// Lowest active lane, if any.
    fn mask_first(self, a: Mask16) -> Option<u32>;
    /// Lanes `0..n` (all for `n >= 16`): the loop-tail mask.
    fn mask_first_n(self, n: usize) -> Mask16;

    // ------------------------------------------------------------------
    // Memory. `mem` slices start at the first element addressed; indices
    // are element indices (i32, must be in 0..len for active lanes).
    // ------------------------------------------------------------------

    /// Unaligned load of `mem[0..16]`. Panics if `mem.len() < 16`.
    fn load_f(self, mem: &[f32]) -> Self::F32;
    /// Unaligned load of `mem[0..16]`.
    fn load_i(self, mem: &[i32]) -> Self::I32;
    /// Aligned load: panics unless `mem` starts on a 64-byte boundary and
    /// has at least 16 elements.
    fn load_aligned_f(self, mem: &[f32]) -> Self::F32;
    /// Aligned load (see [`Simd::load_aligned_f`]).
    fn load_aligned_i(self, mem: &[i32]) -> Self::I32;
    /// Unaligned store to `mem[0..16]`.
    fn store_f(self, mem: &mut [f32], v: Self::F32);
    /// Unaligned store to `mem[0..16]`.
    fn store_i(self, mem: &mut [i32], v: Self::I32);
    /// Aligned store (64-byte boundary, ≥ 16 elements, else panic).
    fn store_aligned_f(self, mem: &mut [f32], v: Self::F32);
    /// Aligned store.
    fn store_aligned_i(self, mem: &mut [i32], v: Self::I32);
    /// Masked load: active lane `i` reads `mem[i]`, inactive lanes keep
    /// `src`. `mem` only needs to cover the highest active lane, so this is
    /// the loop-tail load.
    fn mask_load_f(self, src: Self::F32, m: Mask16, mem: &[f32]) -> Self::F32;
    /// Masked load (see [`Simd::mask_load_f`]).
    fn mask_load_i(self, src: Self::I32, m: Mask16, mem: &[i32]) -> Self::I32;
    /// Masked store: active lane `i` writes `mem[i]`.
    fn mask_store_f(self, mem: &mut [f32], m: Mask16, v: Self::F32);
    /// Masked store.
    fn mask_store_i(self, mem: &mut [i32], m: Mask16, v: Self::I32);
    /// Gather `mem[idx[i]]` for all lanes.
    fn gather_f(self, mem: &[f32], idx: Self::I32) -> Self::F32;
    /// Gather `mem[idx[i]]` for all lanes.
    fn gather_i(self, mem: &[i32], idx: Self::I32) -> Self::I32;
    /// Masked gather: active lanes read `mem[idx[i]]`, the others keep `src`.
    fn mask_gather_f(self, src: Self::F32, m: Mask16, mem: &[f32], idx: Self::I32) -> Self::F32;
    /// Masked gather.
    fn mask_gather_i(self, src: Self::I32, m: Mask16, mem: &[i32], idx: Self::I32) -> Self::I32;
    /// Masked scatter: active lanes write `mem[idx[i]] = v[i]`, in lane
    /// order, so with colliding indices the highest lane wins (x86 rule).
    fn mask_scatter_f(self, mem: &mut [f32], m: Mask16, idx: Self::I32, v: Self::F32);
    /// Masked scatter.
    fn mask_scatter_i(self, mem: &mut [i32], m: Mask16, idx: Self::I32, v: Self::I32);
    /// Compress-store (the binning idiom): the active lanes of `v` are
    /// written contiguously to `mem[0..n]` in lane order; returns
    /// `n = popcount(m)`. Panics if `mem.len() < n`.
    fn compress_store_f(self, mem: &mut [f32], m: Mask16, v: Self::F32) -> usize;
    /// Compress-store.
    fn compress_store_i(self, mem: &mut [i32], m: Mask16, v: Self::I32) -> usize;
    /// Expand-load: the active lanes, in order, receive `mem[0..n]` with
    /// `n = popcount(m)`; inactive lanes keep `src`. Panics if
    /// `mem.len() < n`.
    fn expand_load_f(self, src: Self::F32, m: Mask16, mem: &[f32]) -> Self::F32;
    /// Expand-load.
    fn expand_load_i(self, src: Self::I32, m: Mask16, mem: &[i32]) -> Self::I32;
    /// Vector fetch-add into private memory: for active lanes in lane order,
    /// `old[i] = mem[idx[i]]; mem[idx[i]] += val[i]` (wrapping). Lanes
    /// aiming at the same element are combined with conflict detection, so
    /// the result equals that sequential reference exactly. Returns `old`
    /// (0 in inactive lanes).
    fn fetch_add_i(self, mem: &mut [i32], m: Mask16, idx: Self::I32, val: Self::I32) -> Self::I32;
    /// Vector *atomic* fetch-add into shared memory (`Relaxed` ordering):
    /// lanes with equal indices are first combined in the register, then one
    /// atomic `fetch_add` per distinct element is issued (lowest lane's
    /// address first). Each active lane gets the value the element had just
    /// before its own contribution in lane order, so single-threaded the
    /// result equals the sequential reference. Inactive lanes return 0.
    fn atomic_fetch_add_i(self, mem: &[AtomicI32], m: Mask16, idx: Self::I32, val: Self::I32) -> Self::I32;

    // ------------------------------------------------------------------
    // Context hooks: no-ops natively, recorded by the counting context.
    // ------------------------------------------------------------------

    /// Start a task of kind `kind` (ends the previous one, if any).
    #[inline(always)]
    fn begin_task(self, kind: u32) {
        let _ = kind;
    }
    /// End the current task; a counting context files its [`crate::TaskRecord`]
    /// in its [`crate::Recorder`].
    #[inline(always)]
    fn end_task(self) {}
    /// Report `n` scalar instructions executed by the kernel.
    #[inline(always)]
    fn scalar_ops(self, n: u64) {
        let _ = n;
    }
    /// Under the counting context: the scalar result `out` is `latency` nominal cycles deeper than
    /// the deeper of its inputs `a` and `b` (keys from [`ChainKey`]; `None`: not followed). A no-op
    /// natively. The counted scalar operations below call it.
    #[inline(always)]
    fn scalar_chain(self, latency: u64, a: Option<u64>, b: Option<u64>, out: Option<u64>) {
        let _ = (latency, a, b, out);
    }
    /// Under the counting context: the conditional branch at source location `site` went
    /// `taken`; the branch predictor model ([`crate::branch`]) counts a misprediction when it
    /// guessed wrong. A no-op natively. [`Simd::s_branch`], [`Simd::s_lt`] and [`Simd::s_le`] call
    /// it with their caller's location.
    #[inline(always)]
    fn branch_outcome(self, site: &'static core::panic::Location<'static>, taken: bool) {
        let _ = (site, taken);
    }
    /// Count one scalar operation of `class` executed by the kernel (a no-op natively). Kernels
    /// call the counted operations below ([`Simd::s_add`], [`Simd::s_lt`], [`Simd::s_load`], ...),
    /// which execute the operation and count it here.
    #[inline(always)]
    fn scalar_op(self, class: ScalarClass) {
        let _ = class;
    }

    // ------------------------------------------------------------------
    // Counted scalar operations: the operation itself, counted by class under the counting
    // context (natively exactly the plain operation).
    // ------------------------------------------------------------------

    /// Scalar `a + b` (counted: `T::CLASS`, [`ScalarClass::Float`] or [`ScalarClass::Alu`]).
    #[inline(always)]
    fn s_add<T: ScalarNum>(self, a: T, b: T) -> T {
        self.scalar_op(T::CLASS);
        let r = a + b;
        self.scalar_chain(scalar_latency::ALU, a.chain_key(), b.chain_key(), r.chain_key());
        r
    }
    /// Scalar `a - b` (`T::CLASS`).
    #[inline(always)]
    fn s_sub<T: ScalarNum>(self, a: T, b: T) -> T {
        self.scalar_op(T::CLASS);
        let r = a - b;
        self.scalar_chain(scalar_latency::ALU, a.chain_key(), b.chain_key(), r.chain_key());
        r
    }
    /// Scalar `a * b` (`T::CLASS`).
    #[inline(always)]
    fn s_mul<T: ScalarNum>(self, a: T, b: T) -> T {
        self.scalar_op(T::CLASS);
        let r = a * b;
        self.scalar_chain(scalar_latency::ALU, a.chain_key(), b.chain_key(), r.chain_key());
        r
    }
    /// Scalar `a / b` ([`ScalarClass::Div`]).
    #[inline(always)]
    fn s_div<T: ScalarNum>(self, a: T, b: T) -> T {
        self.scalar_op(ScalarClass::Div);
        let r = a / b;
        self.scalar_chain(scalar_latency::DIV, a.chain_key(), b.chain_key(), r.chain_key());
        r
    }
    /// Scalar `a.min(b)`, the type's own (`T::CLASS`).
    #[inline(always)]
    fn s_min<T: ScalarNum>(self, a: T, b: T) -> T {
        self.scalar_op(T::CLASS);
        let r = a.min_of(b);
        self.scalar_chain(scalar_latency::ALU, a.chain_key(), b.chain_key(), r.chain_key());
        r
    }
    /// Scalar `a.max(b)`, the type's own (`T::CLASS`).
    #[inline(always)]
    fn s_max<T: ScalarNum>(self, a: T, b: T) -> T {
        self.scalar_op(T::CLASS);
        let r = a.max_of(b);
        self.scalar_chain(scalar_latency::ALU, a.chain_key(), b.chain_key(), r.chain_key());
        r
    }
    /// Scalar float `f(x)` of the float library (`f64::sqrt`, `f32::floor`, ...): square roots
    /// count as [`ScalarClass::Div`], the rest (`abs`, `floor`, `ceil`, conversions) as ALU.
    #[inline(always)]
    fn s_fn<T: ChainKey, U: ChainKey>(self, class: ScalarClass, x: T, f: fn(T) -> U) -> U {
        self.scalar_op(class);
        let r = f(x);
        let latency = match class {
            ScalarClass::Div => scalar_latency::DIV,
            _ => scalar_latency::ALU,
        };
        self.scalar_chain(latency, x.chain_key(), None, r.chain_key());
        r
    }
    /// Scalar comparison feeding a branch: `a < b` ([`ScalarClass::Branch`]; its outcome is
    /// predicted at the caller's site, [`Simd::branch_outcome`]).
    #[inline(always)]
    #[track_caller]
    fn s_lt<T: PartialOrd>(self, a: T, b: T) -> bool {
        self.scalar_op(ScalarClass::Branch);
        let c = a < b;
        self.branch_outcome(core::panic::Location::caller(), c);
        c
    }
    /// Scalar `a <= b` ([`ScalarClass::Branch`], predicted at the caller's site).
    #[inline(always)]
    #[track_caller]
    fn s_le<T: PartialOrd>(self, a: T, b: T) -> bool {
        self.scalar_op(ScalarClass::Branch);
        let c = a <= b;
        self.branch_outcome(core::panic::Location::caller(), c);
        c
    }
    /// A branch on `c` ([`ScalarClass::Branch`], predicted at the caller's site): `c`.
    #[inline(always)]
    #[track_caller]
    fn s_branch(self, c: bool) -> bool {
        self.scalar_op(ScalarClass::Branch);
        self.branch_outcome(core::panic::Location::caller(), c);
        c
    }
    /// Scalar load of `data[i]` ([`ScalarClass::Mem`], its line in the task's stream).
    #[inline(always)]
    fn s_load<T: Copy>(self, data: &[T], i: usize) -> T {
        self.scalar_op(ScalarClass::Mem);
        let v = data[i];
        self.scalar_touch(&data[i] as *const T as usize, core::mem::size_of::<T>(), false);
        v
    }
    /// Scalar read of `*r` ([`ScalarClass::Mem`], its lines in the task's stream).
    #[inline(always)]
    fn s_read<T: Copy>(self, r: &T) -> T {
        self.scalar_op(ScalarClass::Mem);
        self.scalar_touch(r as *const T as usize, core::mem::size_of::<T>(), false);
        *r
    }
    /// Count a scalar store of `*r`, just written ([`ScalarClass::Store`], its lines in the
    /// stream).
    #[inline(always)]
    fn s_wrote<T>(self, r: &T) {
        self.scalar_op(ScalarClass::Store);
        self.scalar_touch(r as *const T as usize, core::mem::size_of::<T>(), true);
    }
    /// Scalar read of a value `*r` of several 32-bit fields the kernel goes on to use one by one
    /// (a triangle's corners, a screen triangle's setup): the host loads it a field at a time, so
    /// it counts one [`ScalarClass::Mem`] per 4 bytes (at least one), and its lines once.
    #[inline(always)]
    fn s_read_words<T: Copy>(self, r: &T) -> T {
        count_words(self, r, false);
        *r
    }
    /// `v.push(x)` of a value assembled from 32-bit scalars: [`Simd::s_push`], its store counted a
    /// word at a time as [`Simd::s_wrote_words`] counts one.
    #[inline(always)]
    fn s_push_words<T>(self, v: &mut Vec<T>, x: T) {
        self.scalar_op(ScalarClass::Branch);
        self.scalar_op(ScalarClass::Alu);
        v.push(x);
        let last = v.last().expect("just pushed");
        self.s_wrote_words(last);
    }
    /// Count the stores of a value `*r` just written that was assembled from 32-bit scalars (lanes
    /// taken out of vectors one by one, fields computed apart): the compiler stores such a value a
    /// word at a time, so it counts one [`ScalarClass::Store`] per 4 bytes (at least one), and its
    /// lines once.
    #[inline(always)]
    fn s_wrote_words<T>(self, r: &T) {
        count_words(self, r, true);
    }
    /// Scalar store `data[i] = v` ([`ScalarClass::Store`], its line in the stream).
    #[inline(always)]
    fn s_store<T>(self, data: &mut [T], i: usize, v: T) {
        data[i] = v;
        self.s_wrote(&data[i]);
    }
    /// `v.push(x)`: a store of `x` (its lines in the stream), the length update and the capacity
    /// test ([`ScalarClass::Store`], [`ScalarClass::Alu`], [`ScalarClass::Branch`]).
    #[inline(always)]
    fn s_push<T>(self, v: &mut Vec<T>, x: T) {
        self.scalar_op(ScalarClass::Branch);
        self.scalar_op(ScalarClass::Alu);
        self.scalar_op(ScalarClass::Store);
        v.push(x);
        let last = v.last().expect("just pushed");
        self.scalar_touch(last as *const T as usize, core::mem::size_of::<T>(), true);
    }
    /// Report that scalar code of the kernel read (`write == false`) or wrote the `bytes` bytes
    /// starting at address `addr`: a counting context appends their 64-byte lines to the task's
    /// line stream, so the machine model's caches see scalar work's memory traffic too.
    #[inline(always)]
    fn scalar_touch(self, addr: usize, bytes: usize, write: bool) {
        let _ = (addr, bytes, write);
    }
    /// [`Simd::scalar_touch`] of the memory of `data`, read.
    #[inline(always)]
    fn scalar_read<T>(self, data: &[T]) {
        self.scalar_touch(data.as_ptr() as usize, core::mem::size_of_val(data), false);
    }
    /// [`Simd::scalar_touch`] of the memory of `data`, written.
    #[inline(always)]
    fn scalar_write<T>(self, data: &[T]) {
        self.scalar_touch(data.as_ptr() as usize, core::mem::size_of_val(data), true);
    }

    // ==================================================================
    // Derived operations (provided; never overridden by backends)
    // ==================================================================

    /// All-lanes mask (a constant, not counted).
    #[inline(always)]
    fn mask_full(self) -> Mask16 {
        Mask16::ALL
    }
    /// `!a` on integers.
    #[inline(always)]
    fn not_i(self, a: Self::I32) -> Self::I32 {
        self.xor_i(a, self.splat_i(-1))
    }
    /// Wrapping `-a`.
    #[inline(always)]
    fn neg_i(self, a: Self::I32) -> Self::I32 {
        self.sub_i(self.splat_i(0), a)
    }
    /// `min(max(x, lo), hi)`; a NaN `x` becomes `lo` (x86 min/max rules).
    #[inline(always)]
    fn clamp_f(self, x: Self::F32, lo: Self::F32, hi: Self::F32) -> Self::F32 {
        self.min_f(self.max_f(x, lo), hi)
    }
    /// Magnitude of `mag` with the sign bit of `sign`.
    #[inline(always)]
    fn copysign_f(self, mag: Self::F32, sign: Self::F32) -> Self::F32 {
        let m = self.and_i(self.cast_f_i(mag), self.splat_i(0x7FFF_FFFF));
        let s = self.and_i(self.cast_f_i(sign), self.splat_i(i32::MIN));
        self.cast_i_f(self.or_i(m, s))
    }
    /// `a ^ (sign bit of s)`: flips the sign of `a` where `s` is negative.
    #[inline(always)]
    fn mulsign_f(self, a: Self::F32, s: Self::F32) -> Self::F32 {
        let sb = self.and_i(self.cast_f_i(s), self.splat_i(i32::MIN));
        self.cast_i_f(self.xor_i(self.cast_f_i(a), sb))
    }
    /// Lanes whose value is NaN.
    #[inline(always)]
    fn is_nan_f(self, a: Self::F32) -> Mask16 {
        self.cmp_unord_f(a, a)
    }
    /// `floor(a)` converted to i32 (NaN / out of range → `i32::MIN`).
    #[inline(always)]
    fn floor_i(self, a: Self::F32) -> Self::I32 {
        self.cvtt_f_i(self.floor_f(a))
    }
    /// `a - floor(a)`, in `[0, 1]` for finite inputs (may round up to 1.0
    /// for tiny negative inputs).
    #[inline(always)]
    fn fract_f(self, a: Self::F32) -> Self::F32 {
        self.sub_f(a, self.floor_f(a))
    }
    /// `a + t * (b - a)` with one FMA.
    #[inline(always)]
    fn lerp_f(self, a: Self::F32, b: Self::F32, t: Self::F32) -> Self::F32 {
        self.fmadd(t, self.sub_f(b, a), a)
    }
    /// 2-D edge function `(bx - ax) * (py - ay) - (by - ay) * (px - ax)` as
    /// the rasteriser writes it, with `ex = bx - ax`, `ey = by - ay`
    /// precomputed: `ex * (py - ay) - ey * (px - ax)`, one mul + one fmsub.
    /// Positive when `p` is to the left of `a → b`.
    #[inline(always)]
    fn edge_f(
        self,
        ax: Self::F32,
        ay: Self::F32,
        ex: Self::F32,
        ey: Self::F32,
        px: Self::F32,
        py: Self::F32,
    ) -> Self::F32 {
        let dx = self.sub_f(px, ax);
        let dy = self.sub_f(py, ay);
        self.fmsub(ex, dy, self.mul_f(ey, dx))
    }

    /// Arc cosine over `[-1, 1]`, result in `[0, π]`.
    ///
    /// Inputs are clamped into `[-1, 1]` first (so `acos(1.5) = 0`,
    /// `acos(-7) = π`); NaN is clamped to −1 and gives π. Method: Cephes
    /// `asinf` minimax polynomial (degree 5 in `z`) on `|x| ≤ 0.5`, and
    /// `acos(x) = 2 asin(sqrt((1-|x|)/2))` beyond, all branch-free with
    /// FMAs. Bit-identical on every backend.
    ///
    /// **Accuracy** (dense sweep against f64, see `tests/math.rs`): absolute
    /// error ≤ [`ACOS_MAX_ABS_ERR`] over `[-1, 1]`, and relative error ≤
    /// [`ACOS_MAX_REL_ERR`] (acos → 0 at x = 1 is tracked relatively).
    #[inline(always)]
    fn acos_f(self, x: Self::F32) -> Self::F32 {
        let one = self.splat_f(1.0);
        let xc = self.clamp_f(x, self.splat_f(-1.0), one);
        let a = self.abs_f(xc);
        let big = self.cmp_gt_f(a, self.splat_f(0.5));
        // |x| > 0.5: z = (1 - |x|) / 2 (exact), s = sqrt(z).
        let zb = self.mul_f(self.sub_f(one, a), self.splat_f(0.5));
        let zs = self.mul_f(a, a);
        let z = self.select_f(big, zb, zs);
        let s = self.select_f(big, self.sqrt_f(zb), a);
        let r = asin_kernel(self, s, z);
        // big:  x > 0: 2r          x < 0: π - 2r
        // small:       π/2 - sign(x) r
        let neg = self.cmp_lt_f(xc, self.splat_f(0.0));
        let coef_big = self.select_f(neg, self.splat_f(-2.0), self.splat_f(2.0));
        let coef_small = self.select_f(neg, one, self.splat_f(-1.0));
        let coef = self.select_f(big, coef_big, coef_small);
        let add_big = self.select_f(neg, self.splat_f(PI_HI), self.splat_f(0.0));
        let add = self.select_f(big, add_big, self.splat_f(FRAC_PI_2_HI));
        self.fmadd(coef, r, add)
    }

    /// Arc sine over `[-1, 1]`, result in `[-π/2, π/2]`; inputs clamped like
    /// [`Simd::acos_f`] (NaN → −1 → −π/2). Absolute error ≤
    /// [`ACOS_MAX_ABS_ERR`], relative error ≤ [`ASIN_MAX_REL_ERR`].
    #[inline(always)]
    fn asin_f(self, x: Self::F32) -> Self::F32 {
        let one = self.splat_f(1.0);
        let xc = self.clamp_f(x, self.splat_f(-1.0), one);
        let a = self.abs_f(xc);
        let big = self.cmp_gt_f(a, self.splat_f(0.5));
        let zb = self.mul_f(self.sub_f(one, a), self.splat_f(0.5));
        let zs = self.mul_f(a, a);
        let z = self.select_f(big, zb, zs);
        let s = self.select_f(big, self.sqrt_f(zb), a);
        let r = asin_kernel(self, s, z);
        // big: π/2 - 2r, small: r; then the sign of x.
        let rb = self.fmadd(self.splat_f(-2.0), r, self.splat_f(FRAC_PI_2_HI));
        let mag = self.select_f(big, rb, r);
        self.mulsign_f(mag, xc)
    }

    /// Four-quadrant arc tangent of `y / x`, result in `[-π, π]`.
    ///
    /// IEEE special cases: `atan2(±0, +0) = ±0`, `atan2(±0, -0) = ±π`,
    /// `atan2(±inf, ±inf) = ±π/4` or `±3π/4`, infinities otherwise as IEEE,
    /// NaN in → NaN out. Prefer `atan2(cross, dot)` over `acos(dot)` for
    /// angles near 0 or π: its error is relative to the angle.
    ///
    /// Method: octant reduction to `t = min/max` (with `(mn - mx)/(mn + mx)`
    /// beyond tan(π/8)), Cephes `atanf` polynomial, then quadrant fix-up.
    /// **Accuracy**: absolute error ≤ [`ATAN2_MAX_ABS_ERR`], relative error
    /// ≤ [`ATAN2_MAX_REL_ERR`] (measured over a dense sweep of directions and
    /// magnitudes against f64 `atan2`).
    #[inline(always)]
    fn atan2_f(self, y: Self::F32, x: Self::F32) -> Self::F32 {
        let ax = self.abs_f(x);
        let ay = self.abs_f(y);
        let swap = self.cmp_gt_f(ay, ax);
        let mn0 = self.select_f(swap, ax, ay);
        let mx0 = self.select_f(swap, ay, ax);
        let inf = self.splat_f(f32::INFINITY);
        let both_inf = self.cmp_eq_f(mn0, inf);
        let one = self.splat_f(1.0);
        let mn = self.select_f(both_inf, one, mn0);
        let mx = self.select_f(both_inf, one, mx0);
        let big = self.cmp_gt_f(mn, self.mul_f(mx, self.splat_f(TAN_PI_8)));
        let num = self.select_f(big, self.sub_f(mn, mx), mn);
        let den0 = self.select_f(big, self.add_f(mn, mx), mx);
        // 0/0 (both zero): num is 0, use den = 1 so t = 0.
        let den = self.select_f(self.cmp_eq_f(den0, self.splat_f(0.0)), one, den0);
        let t = self.div_f(num, den);
        let base = self.select_f(big, self.splat_f(FRAC_PI_4_HI), self.splat_f(0.0));
        let z = self.mul_f(t, t);
        let mut p = self.splat_f(8.053_744_5e-2);
        p = self.fmadd(p, z, self.splat_f(-1.387_768_6e-1));
        p = self.fmadd(p, z, self.splat_f(1.997_771_1e-1));
        p = self.fmadd(p, z, self.splat_f(-3.333_295e-1));
        let tz = self.mul_f(t, z);
        let r0 = self.add_f(base, self.fmadd(tz, p, t));
        // Octant → quadrant: swap: π/2 - r; x negative (sign bit): π - r.
        let r1 = self.select_f(swap, self.sub_f(self.splat_f(FRAC_PI_2_HI), r0), r0);
        let xneg = self.cmp_lt_i(self.cast_f_i(x), self.splat_i(0));
        let r2 = self.select_f(xneg, self.sub_f(self.splat_f(PI_HI), r1), r1);
        self.mulsign_f(r2, y)
    }

    /// Arc tangent, result in `(-π/2, π/2)`: `atan2(x, 1)`, same accuracy.
    #[inline(always)]
    fn atan_f(self, x: Self::F32) -> Self::F32 {
        self.atan2_f(x, self.splat_f(1.0))
    }
}

/// Cephes asinf core: `asin(s) ≈ s + s·z·P(z)` for `s ∈ [0, 0.5]`,
/// `z = s²` or `z` such that `s = sqrt(z)`.
#[inline(always)]
fn asin_kernel<S: Simd>(s_: S, s: S::F32, z: S::F32) -> S::F32 {
    let mut p = s_.splat_f(4.216_32e-2);
    p = s_.fmadd(p, z, s_.splat_f(2.418_131e-2));
    p = s_.fmadd(p, z, s_.splat_f(4.547_002_6e-2));
    p = s_.fmadd(p, z, s_.splat_f(7.495_300_3e-2));
    p = s_.fmadd(p, z, s_.splat_f(1.666_675_2e-1));
    let sz = s_.mul_f(s, z);
    s_.fmadd(sz, p, s)
}

const PI_HI: f32 = core::f32::consts::PI;
const FRAC_PI_2_HI: f32 = core::f32::consts::FRAC_PI_2;
const FRAC_PI_4_HI: f32 = core::f32::consts::FRAC_PI_4;
const TAN_PI_8: f32 = 0.414_213_57;

/// Documented bound on `|acos_f(x) - acos(x)|` over `[-1, 1]` (radians).
/// Measured maximum over the test sweep: 3.01e-7 (≈ 1.3 ulp, at x ≈ −0.5).
pub const ACOS_MAX_ABS_ERR: f32 = 3.5e-7;
/// Documented bound on the relative error of `acos_f` over `[-1, 1]`.
/// Measured maximum: 1.44e-7.
pub const ACOS_MAX_REL_ERR: f32 = 2.0e-7;
/// Documented bound on the relative error of `asin_f` over `[-1, 1]`
/// (absolute error is within [`ACOS_MAX_ABS_ERR`]). Measured: 2.67e-7
/// (≈ 2.4 ulp, just above |x| = 0.5), absolute 1.65e-7.
pub const ASIN_MAX_REL_ERR: f32 = 3.2e-7;
/// Documented bound on `|atan2_f(y, x) - atan2(y, x)|` (radians).
/// Measured maximum: 2.60e-7 (≈ 2.8 ulp).
pub const ATAN2_MAX_ABS_ERR: f32 = 3.2e-7;
/// Documented bound on the relative error of `atan2_f` and `atan_f`.
/// Measured maximum: 2.05e-7.
pub const ATAN2_MAX_REL_ERR: f32 = 2.6e-7;
