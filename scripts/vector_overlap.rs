//! Does an out-of-order host overlap the vector unit's classes? The host model's vector bound
//! (`machine::timing::port_bounds`) adds a task's ALU work, its transcendentals (divides, square
//! roots) and its gathers, as if one unit issued them one after another. A standalone measurement,
//! not part of the build, the sibling of `port_overlap.rs`:
//!
//!     rustc -C opt-level=3 -o /tmp/vector_overlap scripts/vector_overlap.rs && /tmp/vector_overlap
//!
//! Each loop iteration issues, in inline assembly so the compiler changes nothing: A = 16
//! independent `vaddps zmm`; D = 2 independent `vdivps zmm`; G = 1 `vgatherdps zmm` of 16 lanes
//! from one L1-resident line pair (its mask set first, as a gather clears it). Every class alone
//! and every mix is timed by `overlap_harness.rs` (the best of 5 runs, 9 rounds, the median
//! round), in cycles of a nominal 2.1 GHz clock. `alpha` is `(mix - largest part) / (sum of parts - largest part)`: 0 when the
//! classes overlap completely, 1 when they add up (the model's rule today).

use std::arch::asm;
#[path = "overlap_harness.rs"]
#[macro_use]
mod harness;

/// `iters` iterations of the chosen classes; `table` holds at least 32 f32, 64-byte aligned.
#[inline(never)]
unsafe fn run(iters: u64, a: bool, d: bool, g: bool, table: *const f32) {
    // Gather indices 0..15 (one line) in zmm20; divide operands 1.0 in zmm21, zmm22.
    let idx: [i32; 16] = core::array::from_fn(|i| i as i32);
    let ones = [1.0f32; 16];
    asm!(
        "vmovdqu32 zmm20, [{i}]",
        "vmovups zmm21, [{o}]",
        "vmovups zmm22, [{o}]",
        i = in(reg) idx.as_ptr(), o = in(reg) ones.as_ptr(),
        out("zmm20") _, out("zmm21") _, out("zmm22") _,
        options(nostack, readonly));
    for _ in 0..iters {
        if a {
            vector_adds!();
        }
        if d {
            // Independent divides of 1/1 (no denormals, no chain between iterations).
            asm!(
                "vdivps zmm10, zmm21, zmm22",
                "vdivps zmm11, zmm22, zmm21",
                out("zmm10") _, out("zmm11") _,
                options(nostack));
        }
        if g {
            asm!(
                "kxnorw k1, k1, k1",
                "vgatherdps zmm12{{k1}}, [{t} + zmm20*4]",
                t = in(reg) table,
                out("zmm12") _, out("k1") _,
                options(nostack, readonly));
        }
    }
}

fn main() {
    if !std::arch::is_x86_feature_detected!("avx512f") {
        eprintln!("vector_overlap: this CPU has no AVX-512; nothing measured");
        std::process::exit(2);
    }
    #[repr(C, align(64))]
    struct Table([f32; 32]);
    let table = Table([1.0; 32]);
    let iters = 10_000_000u64;
    harness::measure(["A", "D", "G"], iters, |iters, [a, d, g]| unsafe {
        run(iters, a, d, g, table.0.as_ptr())
    });
}
