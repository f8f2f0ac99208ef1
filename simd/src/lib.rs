//! # sism-simd: a 16-wide vector ISA in Larrabee's style
//!
//! The vocabulary the sism kernels (perspective-grid binning with vector
//! atomics, point-in-triangle tests, penumbra occlusion) are written in:
//! 16 lanes of `f32` / `i32` / `u32`, a 16-bit lane mask ([`Mask16`]),
//! merge masking, gather/scatter, compress/expand, conflict-combining vector
//! fetch-add, and vector math with stated accuracy.
//!
//! ## Design
//!
//! * **One source.** A kernel is written once, as a function generic over an
//!   execution context `S: `[`Simd`]. Every vector operation is a method on
//!   the context (`s.fmadd(a, b, c)`, `s.mask_gather_f(src, m, mem, idx)`),
//!   with associated types `S::F32` / `S::I32` for the registers.
//! * **Backends.** [`Avx512`] maps each method to `_mm512_*` intrinsics
//!   (`x86_64` only); [`Avx2`] keeps each vector in two 256-bit registers
//!   (`x86_64` CPUs without AVX-512); [`Portable`] uses 64-byte aligned `[f32; 16]` arrays and
//!   lane loops that LLVM auto-vectorizes, on any target. The portable
//!   backend *defines* the semantics; AVX-512 matches it bit for bit (min/max
//!   follow x86 `minps` rules, float→int conversions give `i32::MIN` on
//!   overflow/NaN, reductions use a fixed tree order, `rcp_f`/`rsqrt_f` are
//!   true divisions). The only non-bit-identical operations are
//!   [`Simd::rcp_fast_f`] and [`Simd::rsqrt_fast_f`].
//! * **Dispatch once per kernel.** A kernel implements [`Kernel`] (`fn
//!   run<S: Simd>(self, s: S)`, marked `#[inline(always)]`);
//!   [`run_native`] detects the CPU (cached), honours `SISM_SIMD` /
//!   [`set_backend`], and calls a `#[target_feature(enable = "avx512f,...")]`
//!   entry point instantiated for that backend. The whole kernel body is
//!   compiled inside it, so every operation inlines to straight-line AVX-512
//!   (or AVX2 for the portable code) with no per-operation dispatch.
//! * **Counting without cost.** [`Counting`] wraps any backend, forwards
//!   every operation (bit-identical results by construction) and records
//!   per task ([`TaskRecord`]): instructions by class, active lanes, distinct
//!   cache lines per gather/scatter, atomic conflicts, and the ordered,
//!   compressed stream of cache lines touched. The native contexts pay
//!   nothing: their `begin_task`/`end_task`/`scalar_ops` hooks are empty
//!   inline functions.
//!
//! ## Example
//!
//! ```
//! use sism_simd::{Kernel, Recorder, Simd};
//!
//! /// Count points inside the triangle (0,0) (1,0) (0,1).
//! struct Inside<'a> { xs: &'a [f32], ys: &'a [f32] }
//!
//! impl Kernel for Inside<'_> {
//!     type Output = u32;
//!     #[inline(always)]
//!     fn run<S: Simd>(self, s: S) -> u32 {
//!         s.begin_task(0);
//!         let zero = s.splat_f(0.0);
//!         let mut n = 0;
//!         for i in (0..self.xs.len()).step_by(16) {
//!             let m = s.mask_first_n(self.xs.len() - i);
//!             let x = s.mask_load_f(zero, m, &self.xs[i..]);
//!             let y = s.mask_load_f(zero, m, &self.ys[i..]);
//!             let w = s.sub_f(s.sub_f(s.splat_f(1.0), x), y);
//!             let inside = s.mask_and(m, s.mask_and(s.cmp_ge_f(x, zero),
//!                 s.mask_and(s.cmp_ge_f(y, zero), s.cmp_ge_f(w, zero))));
//!             n += s.mask_popcnt(inside);
//!         }
//!         s.end_task();
//!         n
//!     }
//! }
//!
//! let xs: Vec<f32> = (0..100).map(|i| i as f32 / 100.0).collect();
//! let ys = vec![0.25f32; 100];
//! let native = sism_simd::run_native(Inside { xs: &xs, ys: &ys });
//! let rec = Recorder::new();
//! let counted = sism_simd::run_counting(&rec, Inside { xs: &xs, ys: &ys });
//! assert_eq!(native, counted);
//! let task = &rec.take_tasks()[0];
//! assert_eq!(task.counters.load, 2 * 7); // 7 iterations, 2 masked loads each
//! println!("{:?} lane utilisation {:.2}", task.counters, task.counters.lane_utilisation());
//! ```

#![deny(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

pub mod alloc;
pub mod branch;
mod common;
mod counting;
mod dispatch;
pub mod examples;
mod mask;
mod portable;
mod record;
mod simd;

#[cfg(target_arch = "x86_64")]
pub mod avx2;
#[cfg(target_arch = "x86_64")]
pub mod avx512;

pub use alloc::{HoldFrees, LineAlloc, GAP_LINES};
pub use counting::{latency, Counting, Recorder, Tracked, STACK_LINES_BASE, STACK_WINDOW, WINDOW};
pub use dispatch::{
    available, available_backends, best_available, parse_backend, run_counting, run_counting_lean,
    run_counting_with, run_native, run_native_lean, run_with, selected_backend, set_backend, Kernel,
};
pub use mask::{Mask16, MaskIter};
pub use portable::{F32x16, I32x16, Portable};
pub use record::{
    nominal_issue, Counters, DecodeError, LineIter, LineStream, LineStreamEncoder, TaskRecord, NO_TASK,
    TASK_RECORD_VERSION,
};
pub use simd::{
    scalar_latency, BackendKind, ChainKey, ScalarClass, ScalarNum, Simd, ACOS_MAX_ABS_ERR, ACOS_MAX_REL_ERR,
    ASIN_MAX_REL_ERR, ATAN2_MAX_ABS_ERR, ATAN2_MAX_REL_ERR, LANES,
};

#[cfg(target_arch = "x86_64")]
pub use avx2::Avx2;
#[cfg(target_arch = "x86_64")]
pub use avx512::Avx512;

/// View a `u32` slice as `i32` (same size and alignment), for the `_i`
/// memory operations on unsigned data.
pub fn as_i32(s: &[u32]) -> &[i32] {
    // SAFETY: u32 and i32 have identical size, alignment and validity.
    unsafe { core::slice::from_raw_parts(s.as_ptr().cast(), s.len()) }
}

/// Mutable [`as_i32`].
pub fn as_i32_mut(s: &mut [u32]) -> &mut [i32] {
    // SAFETY: as above; the borrow is carried over.
    unsafe { core::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), s.len()) }
}
