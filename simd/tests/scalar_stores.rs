//! The counting context counts scalar stores apart (`Counters::scalar_stores`, a part of
//! `scalar_mem`): the machine model bounds write misses by the stores a written line takes.

use sism_simd::{Kernel, Recorder, ScalarClass, Simd};

/// A 28-byte value written a word at a time, one written with a single store, one read, one load
/// counted by class, one store counted by class, and one push.
struct Writes;
impl Kernel for Writes {
    type Output = u32;
    fn run<S: Simd>(self, s: S) -> u32 {
        let mut fields = [0u32; 7];
        let mut one = 0u32;
        let mut pushed = Vec::with_capacity(1);
        s.begin_task(0);
        fields[3] = 5;
        s.s_wrote_words(&fields);
        one += 1;
        s.s_wrote(&one);
        let read = s.s_read(&fields[3]);
        s.scalar_op(ScalarClass::Mem);
        s.scalar_op(ScalarClass::Store);
        s.s_push(&mut pushed, read);
        s.end_task();
        read + one + pushed[0]
    }
}

#[test]
fn stores_are_counted_apart_and_with_the_loads() {
    let rec = Recorder::with_lines(false);
    assert_eq!(sism_simd::run_counting(&rec, Writes), 11);
    let c = rec.take_tasks()[0].counters;
    // Stores: 7 words, 1, 1 by class, 1 push; loads: 1 read, 1 by class.
    assert_eq!(c.scalar_stores, 10);
    assert_eq!(c.scalar_mem, 12);
    // Natively the same result, nothing counted.
    assert_eq!(sism_simd::run_native(Writes), 11);
}
