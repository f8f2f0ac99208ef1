//! The bound on held frees: a counted frame that frees more than the limit gives the excess back at
//! once (memory stays bounded) and counts it, instead of exhausting the host.

use sism_simd::{HoldFrees, LineAlloc};

#[global_allocator]
static GLOBAL: LineAlloc<std::alloc::System> = LineAlloc(std::alloc::System);

#[test]
fn frees_past_the_limit_are_given_back_and_counted() {
    const MIB: usize = 1 << 20;
    HoldFrees::set_limit(4 * MIB);
    let hold = HoldFrees::new();
    assert_eq!(HoldFrees::released(), 0);
    for _ in 0..16 {
        // 1 MiB blocks, freed at once: four fit under the limit, the rest go back.
        let v = std::hint::black_box(vec![1u8; MIB]);
        drop(v);
    }
    let released = HoldFrees::released();
    assert!((11..=13).contains(&released), "{released} frees released");
    assert!(
        HoldFrees::held_blocks() < 64,
        "{} blocks held",
        HoldFrees::held_blocks()
    );
    drop(hold);
    // A new hold starts its count afresh; without a limit nothing is released.
    HoldFrees::set_limit(usize::MAX);
    let hold = HoldFrees::new();
    for _ in 0..8 {
        drop(std::hint::black_box(vec![1u8; MIB]));
    }
    assert_eq!(HoldFrees::released(), 0);
    drop(hold);
}
