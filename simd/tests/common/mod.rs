//! Shared test harness: every check runs on every available backend, both
//! natively and wrapped in the counting context.
#![allow(dead_code)]

use proptest::prelude::*;
use sism_simd::{
    available_backends, run_counting_with, run_with, BackendKind, Kernel, Mask16, Recorder, Simd,
};
use std::fmt::Debug;
use std::sync::Once;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ctx {
    Native(BackendKind),
    Counting(BackendKind),
}

static NOTE: Once = Once::new();

/// Every context to test: each available backend, native and counting.
pub fn contexts() -> Vec<Ctx> {
    let b = available_backends();
    NOTE.call_once(|| {
        if !b.contains(&BackendKind::Avx512) {
            eprintln!("note: AVX-512 not detected on this CPU; AVX-512 backend tests skipped");
        }
    });
    b.iter()
        .flat_map(|&k| [Ctx::Native(k), Ctx::Counting(k)])
        .collect()
}

pub fn run<K: Kernel>(c: Ctx, k: K) -> K::Output {
    match c {
        Ctx::Native(b) => run_with(b, k),
        Ctx::Counting(b) => {
            let rec = Recorder::new();
            run_counting_with(b, &rec, k)
        }
    }
}

/// Equality for results: floats bitwise, except any NaN equals any NaN.
pub trait Same {
    fn same(&self, o: &Self) -> bool;
}
pub fn same_f32(a: f32, b: f32) -> bool {
    (a.is_nan() && b.is_nan()) || a.to_bits() == b.to_bits()
}
impl Same for f32 {
    fn same(&self, o: &Self) -> bool {
        same_f32(*self, *o)
    }
}
macro_rules! same_eq {
    ($($t:ty),*) => { $( impl Same for $t { fn same(&self, o: &Self) -> bool { self == o } } )* };
}
same_eq!(i32, u32, usize, bool, Mask16, Option<u32>);
impl<T: Same, const N: usize> Same for [T; N] {
    fn same(&self, o: &Self) -> bool {
        self.iter().zip(o).all(|(a, b)| a.same(b))
    }
}
impl<A: Same, B: Same> Same for (A, B) {
    fn same(&self, o: &Self) -> bool {
        self.0.same(&o.0) && self.1.same(&o.1)
    }
}
impl<A: Same, B: Same, C: Same> Same for (A, B, C) {
    fn same(&self, o: &Self) -> bool {
        self.0.same(&o.0) && self.1.same(&o.1) && self.2.same(&o.2)
    }
}
impl<A: Same, B: Same, C: Same, D: Same> Same for (A, B, C, D) {
    fn same(&self, o: &Self) -> bool {
        self.0.same(&o.0) && self.1.same(&o.1) && self.2.same(&o.2) && self.3.same(&o.3)
    }
}
impl<A: Same, B: Same, C: Same, D: Same, E: Same> Same for (A, B, C, D, E) {
    fn same(&self, o: &Self) -> bool {
        self.0.same(&o.0) && self.1.same(&o.1) && self.2.same(&o.2) && self.3.same(&o.3) && self.4.same(&o.4)
    }
}
impl<T: Same> Same for Vec<T> {
    fn same(&self, o: &Self) -> bool {
        self.len() == o.len() && self.iter().zip(o).all(|(a, b)| a.same(b))
    }
}

/// An operation under test: the vector form and a scalar reference.
pub trait Op {
    type In: Copy + Debug;
    type Out: Same + Debug;
    fn vec<S: Simd>(s: S, i: Self::In) -> Self::Out;
    fn reference(i: Self::In) -> Self::Out;
}

pub struct OpKernel<O: Op>(pub O::In);
impl<O: Op> Kernel for OpKernel<O> {
    type Output = O::Out;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> O::Out {
        O::vec(s, self.0)
    }
}

/// Run `O` on every context and compare with the scalar reference.
pub fn check<O: Op>(i: O::In) -> Result<(), TestCaseError> {
    let want = O::reference(i);
    for c in contexts() {
        let got = run(c, OpKernel::<O>(i));
        prop_assert!(
            got.same(&want),
            "{} on {:?}\ninput {:?}\n  got {:?}\n want {:?}",
            std::any::type_name::<O>(),
            c,
            i,
            got,
            want
        );
    }
    Ok(())
}

pub const SPECIALS: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -0.5,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    -f32::NAN,
    f32::MIN_POSITIVE,
    -f32::MIN_POSITIVE,
    1.0e-40,
    -1.0e-40,
    f32::MAX,
    f32::MIN,
    2147483648.0,
    -2147483648.0,
    2147483520.0,
    4294967296.0,
    0.49999997,
    1.5,
    2.5,
    -2.5,
];

pub fn f32_any() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1000.0f32..1000.0,
        2 => -2.0f32..2.0,
        3 => any::<u32>().prop_map(f32::from_bits),
        2 => prop::sample::select(SPECIALS),
    ]
}

pub fn i32_any() -> impl Strategy<Value = i32> {
    prop_oneof![
        3 => any::<i32>(),
        2 => -100i32..100,
        1 => prop::sample::select(&[0, 1, -1, i32::MIN, i32::MAX, 31, 32, 33, 64, -32][..]),
    ]
}

pub fn arr_f() -> impl Strategy<Value = [f32; 16]> {
    prop::array::uniform16(f32_any())
}
pub fn arr_i() -> impl Strategy<Value = [i32; 16]> {
    prop::array::uniform16(i32_any())
}
pub fn mask() -> impl Strategy<Value = Mask16> {
    prop_oneof![
        3 => any::<u16>().prop_map(Mask16),
        1 => prop::sample::select(&[0u16, 0xFFFF, 1, 0x8000, 0x00FF, 0x5555][..]).prop_map(Mask16),
    ]
}
pub fn mbit(m: Mask16, i: usize) -> bool {
    (m.0 >> i) & 1 == 1
}
