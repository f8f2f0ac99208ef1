//! Does an out-of-order host overlap its instruction classes? A standalone measurement for the
//! issue rule of the host model (`machine::timing::port_bounds`), not part of the build:
//!
//!     rustc -C opt-level=3 -o /tmp/port_overlap scripts/port_overlap.rs && /tmp/port_overlap
//!
//! Each loop iteration issues, in inline assembly so the compiler changes nothing: V = 16
//! independent `vaddps zmm` (two 512-bit ALU ports: 8 cycles), S = 18 scalar `add`s in 6 short
//! chains (each started by a zero idiom), L = 8 scalar loads and 4 stores to one L1 line pair. Every
//! class alone and every mix is timed by `overlap_harness.rs` (the best of 5 runs of 20M
//! iterations, 9 rounds, the median round), in cycles of a nominal 2.1 GHz clock (a turbo clock
//! makes them smaller; ratios hold).
//! `alpha` is `(mix - largest part) / (sum of parts - largest part)`: 0 when the classes overlap
//! completely (the model's rule: the largest port bound), 1 when they add up.
//!
//! Measured on the Intel Xeon VM (Emerald Rapids class, 2026-12-06), three runs: V 6.13-6.18,
//! S 3.16-3.23, L 2.13-2.37, V+S 6.09-6.17, V+L 6.14-6.16, S+L 4.71-4.73, V+S+L 6.72-7.07; alpha
//! V+S 0.00, V+L 0.00, S+L 0.65-0.70, V+S+L 0.10-0.17.
//! Vector work hides scalar ALU work and loads completely; scalar ALU work and memory operations
//! together, and all three, are bound by the rename width (38 and 54 uops an iteration at 6 a
//! cycle), which the model does not have.

use std::arch::asm;
#[path = "overlap_harness.rs"]
#[macro_use]
mod harness;

/// `iters` iterations of the chosen classes (see the module's docs); `buf` holds at least 12 u64.
#[inline(never)]
unsafe fn run(iters: u64, v: bool, s: bool, l: bool, buf: *mut u64) {
    for _ in 0..iters {
        if v {
            vector_adds!();
        }
        if s {
            asm!(
                "xor {a:e}, {a:e}", "xor {b:e}, {b:e}", "xor {c:e}, {c:e}", "xor {d:e}, {d:e}", "xor {e:e}, {e:e}", "xor {f:e}, {f:e}",
                "add {a}, 1", "add {b}, 1", "add {c}, 1", "add {d}, 1", "add {e}, 1", "add {f}, 1",
                "add {a}, 1", "add {b}, 1", "add {c}, 1", "add {d}, 1", "add {e}, 1", "add {f}, 1",
                "add {a}, 1", "add {b}, 1", "add {c}, 1", "add {d}, 1", "add {e}, 1", "add {f}, 1",
                a = out(reg) _, b = out(reg) _, c = out(reg) _, d = out(reg) _, e = out(reg) _, f = out(reg) _,
                options(nostack));
        }
        if l {
            asm!(
                "mov {a}, [{p}]", "mov {b}, [{p}+8]", "mov {c}, [{p}+16]", "mov {d}, [{p}+24]",
                "mov [{p}+64], {a}", "mov [{p}+72], {b}",
                "mov {a}, [{p}+32]", "mov {b}, [{p}+40]", "mov {c}, [{p}+48]", "mov {d}, [{p}+56]",
                "mov [{p}+80], {c}", "mov [{p}+88], {d}",
                p = in(reg) buf, a = out(reg) _, b = out(reg) _, c = out(reg) _, d = out(reg) _,
                options(nostack));
        }
    }
}

fn main() {
    if !std::arch::is_x86_feature_detected!("avx512f") {
        eprintln!("port_overlap: this CPU has no AVX-512 (the vector class is 512-bit); nothing measured");
        std::process::exit(2);
    }
    let mut buf = vec![0u64; 64];
    let iters = 20_000_000u64;
    harness::measure(["V", "S", "L"], iters, |iters, [v, s, l]| unsafe {
        run(iters, v, s, l, buf.as_mut_ptr())
    });
}
