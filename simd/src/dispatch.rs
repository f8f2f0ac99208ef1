//! Choosing a backend once per kernel call.
//!
//! A kernel is a value implementing [`Kernel`]; its `run<S: Simd>` is
//! instantiated once per backend. [`run_native`] picks the backend (run-time
//! CPU detection, overridable with the `SISM_SIMD` environment variable or
//! [`set_backend`]) and calls a `#[target_feature]` entry point that runs the
//! whole kernel body, so every vector operation inlines into code compiled
//! for that instruction set.
//!
//! | `SISM_SIMD`         | backend                                                 |
//! |---------------------|---------------------------------------------------------|
//! | unset, `auto`       | best available: AVX-512, else AVX2, else portable-avx2, else portable |
//! | `avx512`            | AVX-512 (falls back to the best available, with a warning) |
//! | `avx2`              | the AVX2 backend: two 256-bit registers a vector          |
//! | `portable`          | portable code (compiled for AVX2+FMA when the CPU has them) |
//! | `portable-baseline` | portable code compiled for the baseline target only      |

use crate::counting::{Counting, Recorder};
use crate::portable::Portable;
use crate::simd::{BackendKind, Simd};
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::OnceLock;

/// A kernel written once, generic over the execution context.
///
/// Implementations **must mark `run` `#[inline(always)]`** (and any generic
/// helper it calls): that is what lets the body be compiled inside the
/// backend's `#[target_feature]` entry point. Without it the kernel is still
/// correct but AVX-512 operations become out-of-line calls.
///
/// ```
/// use sism_simd::{Kernel, Simd};
///
/// /// out[i] = a[i] * x + out[i] over whole vectors (len multiple of 16).
/// struct Axpy<'a> { a: &'a [f32], x: f32, out: &'a mut [f32] }
///
/// impl Kernel for Axpy<'_> {
///     type Output = ();
///     #[inline(always)]
///     fn run<S: Simd>(self, s: S) {
///         let x = s.splat_f(self.x);
///         for (a, o) in self.a.chunks_exact(16).zip(self.out.chunks_exact_mut(16)) {
///             let r = s.fmadd(s.load_f(a), x, s.load_f(o));
///             s.store_f(o, r);
///         }
///     }
/// }
///
/// let a = vec![1.0f32; 32];
/// let mut out = vec![2.0f32; 32];
/// sism_simd::run_native(Axpy { a: &a, x: 3.0, out: &mut out });
/// assert!(out.iter().all(|&v| v == 5.0));
/// ```
pub trait Kernel {
    /// What the kernel returns.
    type Output;
    /// The kernel body, generic over the context. Mark it `#[inline(always)]`.
    fn run<S: Simd>(self, s: S) -> Self::Output;
}

const NONE: u8 = 0;

fn encode(k: Option<BackendKind>) -> u8 {
    match k {
        None => NONE,
        Some(BackendKind::Avx512) => 1,
        Some(BackendKind::PortableAvx2) => 2,
        Some(BackendKind::Portable) => 3,
        Some(BackendKind::Avx2) => 4,
    }
}
fn decode(v: u8) -> Option<BackendKind> {
    match v {
        1 => Some(BackendKind::Avx512),
        2 => Some(BackendKind::PortableAvx2),
        3 => Some(BackendKind::Portable),
        4 => Some(BackendKind::Avx2),
        _ => None,
    }
}

static OVERRIDE: AtomicU8 = AtomicU8::new(NONE);
static FROM_ENV: OnceLock<BackendKind> = OnceLock::new();

/// Can this machine run `kind`?
pub fn available(kind: BackendKind) -> bool {
    match kind {
        BackendKind::Portable => true,
        #[cfg(target_arch = "x86_64")]
        BackendKind::Avx512 => crate::avx512::detected(),
        #[cfg(target_arch = "x86_64")]
        BackendKind::Avx2 => crate::avx2::detected(),
        #[cfg(target_arch = "x86_64")]
        // The portable code's AVX2 entry point is compiled for the AVX2 backend's features.
        BackendKind::PortableAvx2 => crate::avx2::detected(),
        #[cfg(not(target_arch = "x86_64"))]
        _ => false,
    }
}

/// All backends this machine can run, best first.
pub fn available_backends() -> Vec<BackendKind> {
    [
        BackendKind::Avx512,
        BackendKind::Avx2,
        BackendKind::PortableAvx2,
        BackendKind::Portable,
    ]
    .into_iter()
    .filter(|&k| available(k))
    .collect()
}

/// The fastest backend this machine can run.
pub fn best_available() -> BackendKind {
    available_backends()[0]
}

fn best_portable() -> BackendKind {
    if available(BackendKind::PortableAvx2) {
        BackendKind::PortableAvx2
    } else {
        BackendKind::Portable
    }
}

/// Parse a `SISM_SIMD` value (`auto`, `avx512`, `avx2`, `portable`,
/// `portable-baseline`; case-insensitive). `None` for unknown values.
pub fn parse_backend(s: &str) -> Option<Option<BackendKind>> {
    match s.trim().to_ascii_lowercase().as_str() {
        "" | "auto" | "native" => Some(None),
        "avx512" | "avx-512" => Some(Some(BackendKind::Avx512)),
        "avx2" => Some(Some(BackendKind::Avx2)),
        "portable" => Some(Some(best_portable())),
        "portable-avx2" => Some(Some(BackendKind::PortableAvx2)),
        "portable-baseline" | "baseline" | "scalar" => Some(Some(BackendKind::Portable)),
        _ => None,
    }
}

fn from_env() -> BackendKind {
    *FROM_ENV.get_or_init(|| {
        let req = match std::env::var("SISM_SIMD") {
            Ok(v) => match parse_backend(&v) {
                Some(r) => r,
                None => {
                    eprintln!("sism-simd: ignoring unknown SISM_SIMD={v:?} (use auto, avx512, avx2, portable, portable-baseline)");
                    None
                }
            },
            Err(_) => None,
        };
        match req {
            Some(k) if available(k) => k,
            Some(k) => {
                let b = best_available();
                eprintln!(
                    "sism-simd: SISM_SIMD requested {} which this CPU cannot run; using {}",
                    k.name(),
                    b.name()
                );
                b
            }
            None => best_available(),
        }
    })
}

/// Force the backend used by [`run_native`] / [`run_counting`] for the
/// whole process (`None`: back to `SISM_SIMD` / auto-detection). Panics if
/// the backend is not available on this CPU. Prefer [`run_with`] in tests
/// that run concurrently.
pub fn set_backend(kind: Option<BackendKind>) {
    if let Some(k) = kind {
        assert!(
            available(k),
            "sism-simd: backend {} not available on this CPU",
            k.name()
        );
    }
    OVERRIDE.store(encode(kind), Ordering::Relaxed);
}

/// The backend [`run_native`] will use now.
pub fn selected_backend() -> BackendKind {
    decode(OVERRIDE.load(Ordering::Relaxed)).unwrap_or_else(from_env)
}

/// Run `k` on the selected backend (see the module docs). The backend is
/// chosen once here; the whole kernel runs compiled for it.
#[inline]
pub fn run_native<K: Kernel>(k: K) -> K::Output {
    run_with(selected_backend(), k)
}

/// Run `k` on a specific backend. Panics if it is not available.
#[inline]
pub fn run_with<K: Kernel>(kind: BackendKind, k: K) -> K::Output {
    match kind {
        #[cfg(target_arch = "x86_64")]
        BackendKind::Avx512 => {
            assert!(crate::avx512::detected(), "sism-simd: AVX-512 not available");
            // SAFETY: features detected just above.
            unsafe { x86::run_avx512(k) }
        }
        #[cfg(target_arch = "x86_64")]
        BackendKind::Avx2 => {
            assert!(crate::avx2::detected(), "sism-simd: AVX2 not available");
            // SAFETY: features detected just above.
            unsafe { x86::run_avx2(k) }
        }
        #[cfg(target_arch = "x86_64")]
        BackendKind::PortableAvx2 => {
            assert!(available(kind), "sism-simd: AVX2+FMA not available");
            // SAFETY: features detected just above.
            unsafe { x86::run_portable_avx2(k) }
        }
        BackendKind::Portable => run_portable(k),
        #[cfg(not(target_arch = "x86_64"))]
        _ => panic!("sism-simd: backend {} not available", kind.name()),
    }
}

/// Run `k` on the selected backend wrapped in a [`Counting`] context that
/// records into `rec`. Results are bit-identical to [`run_native`].
#[inline]
pub fn run_counting<K: Kernel>(rec: &Recorder, k: K) -> K::Output {
    run_counting_with(selected_backend(), rec, k)
}

/// [`run_counting`] on a specific backend.
#[inline]
pub fn run_counting_with<K: Kernel>(kind: BackendKind, rec: &Recorder, k: K) -> K::Output {
    // The kernel's frames lie below this one (the backends' entry points are never inlined): its
    // stack lines are renamed, so that records do not depend on which host thread ran it.
    let mark = 0u8;
    rec.mark_stack(core::hint::black_box(&mark) as *const u8 as usize);
    run_with(kind, CountingKernel { k, rec })
}

/// [`run_native`] compiled for two backends instead of four: AVX-512 when it is the selected
/// backend, else the portable code for the baseline target. For builds that need every kernel but
/// not every backend's code of it, where each backend's instantiation of each kernel costs compile
/// time: the library's unit-test build (results are bit-identical on every backend; each backend's
/// operations are tested by this crate's suites, and whole kernels on every backend by the
/// end-to-end tests of the normal build).
#[inline]
pub fn run_native_lean<K: Kernel>(k: K) -> K::Output {
    match selected_backend() {
        #[cfg(target_arch = "x86_64")]
        BackendKind::Avx512 => {
            assert!(crate::avx512::detected(), "sism-simd: AVX-512 not available");
            // SAFETY: features detected just above.
            unsafe { x86::run_avx512(k) }
        }
        _ => run_portable(k),
    }
}

/// [`run_counting`] compiled for one backend: counting over the portable code for the baseline
/// target, whatever the selected backend (records and results are the same on every backend). For
/// builds that need every kernel but not every backend's code of it ([`run_native_lean`]).
#[inline]
pub fn run_counting_lean<K: Kernel>(rec: &Recorder, k: K) -> K::Output {
    let mark = 0u8;
    rec.mark_stack(core::hint::black_box(&mark) as *const u8 as usize);
    run_portable(CountingKernel { k, rec })
}

struct CountingKernel<'r, K> {
    k: K,
    rec: &'r Recorder,
}

impl<K: Kernel> Kernel for CountingKernel<'_, K> {
    type Output = K::Output;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> K::Output {
        self.k.run(Counting::new(s, self.rec))
    }
}

#[inline(never)]
fn run_portable<K: Kernel>(k: K) -> K::Output {
    k.run(Portable)
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Kernel;
    use crate::avx2::Avx2;
    use crate::avx512::Avx512;
    use crate::portable::Portable;

    /// # Safety
    /// The CPU must support `crate::avx512::FEATURES`.
    #[target_feature(enable = "avx512f,avx512cd,avx512bw,avx512dq,avx512vl,avx2,fma,bmi1,bmi2,popcnt")]
    #[inline(never)]
    pub(super) unsafe fn run_avx512<K: Kernel>(k: K) -> K::Output {
        // SAFETY: guaranteed by the caller.
        k.run(unsafe { Avx512::new_unchecked() })
    }

    /// # Safety
    /// The CPU must support `crate::avx2::FEATURES`.
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,popcnt")]
    #[inline(never)]
    pub(super) unsafe fn run_avx2<K: Kernel>(k: K) -> K::Output {
        // SAFETY: guaranteed by the caller.
        k.run(unsafe { Avx2::new_unchecked() })
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,popcnt")]
    #[inline(never)]
    pub(super) unsafe fn run_portable_avx2<K: Kernel>(k: K) -> K::Output {
        k.run(Portable)
    }
}
