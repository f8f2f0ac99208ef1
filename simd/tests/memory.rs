//! Loads, stores, masked forms, gather/scatter, compress/expand and vector
//! fetch-add (private and atomic), with random masks and colliding indices,
//! on every backend and on the counting context.

mod common;
use common::*;
use proptest::prelude::*;
use sism_simd::{Mask16, Recorder, Simd};
use std::sync::atomic::{AtomicI32, Ordering};

const N: usize = 40;

fn mem_f() -> impl Strategy<Value = [f32; N]> {
    prop::array::uniform32(f32_any()).prop_flat_map(|a| {
        prop::array::uniform8(f32_any()).prop_map(move |b| {
            let mut m = [0.0; N];
            m[..32].copy_from_slice(&a);
            m[32..].copy_from_slice(&b);
            m
        })
    })
}
fn mem_i() -> impl Strategy<Value = [i32; N]> {
    prop::array::uniform32(any::<i32>()).prop_flat_map(|a| {
        prop::array::uniform8(-50i32..50).prop_map(move |b| {
            let mut m = [0; N];
            m[..32].copy_from_slice(&a);
            m[32..].copy_from_slice(&b);
            m
        })
    })
}
/// Valid indices, sometimes heavily colliding.
fn idx() -> impl Strategy<Value = [i32; 16]> {
    prop_oneof![
        prop::array::uniform16(0..N as i32),
        prop::array::uniform16(0i32..3),
        prop::array::uniform16(prop::sample::select(&[0i32, 15, 16, 17, 39][..])),
    ]
}

// ---------------- contiguous ----------------
struct LoadStore;
impl Op for LoadStore {
    type In = ([f32; N], [i32; N], usize);
    type Out = ([f32; 16], [i32; 16], [f32; N], [i32; N]);
    fn vec<S: Simd>(s: S, (mf, mi, off): Self::In) -> Self::Out {
        let off = off % (N - 15);
        let a = s.load_f(&mf[off..]);
        let b = s.load_i(&mi[off..]);
        let mut of = [0.0; N];
        let mut oi = [0; N];
        s.store_f(&mut of[N - 16 - off..], a);
        s.store_i(&mut oi[N - 16 - off..], b);
        (s.to_array_f(a), s.to_array_i(b), of, oi)
    }
    fn reference((mf, mi, off): Self::In) -> Self::Out {
        let off = off % (N - 15);
        let mut of = [0.0; N];
        let mut oi = [0; N];
        of[N - 16 - off..][..16].copy_from_slice(&mf[off..off + 16]);
        oi[N - 16 - off..][..16].copy_from_slice(&mi[off..off + 16]);
        (
            mf[off..off + 16].try_into().unwrap(),
            mi[off..off + 16].try_into().unwrap(),
            of,
            oi,
        )
    }
}
proptest! { #[test] fn load_store(mf in mem_f(), mi in mem_i(), off in 0usize..100) { check::<LoadStore>((mf, mi, off))?; } }

#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
struct Aligned([f32; 32]);

struct AlignedLS;
impl Op for AlignedLS {
    type In = [f32; 32];
    type Out = ([f32; 16], [f32; 32], [i32; 16]);
    fn vec<S: Simd>(s: S, m: [f32; 32]) -> Self::Out {
        let a = Aligned(m);
        let v = s.load_aligned_f(&a.0[16..]);
        let mut o = Aligned([0.0; 32]);
        s.store_aligned_f(&mut o.0, v);
        #[repr(C, align(64))]
        struct AI([i32; 16]);
        let ai = AI(core::array::from_fn(|i| i as i32 * 3));
        let vi = s.load_aligned_i(&ai.0);
        let mut oi = AI([0; 16]);
        s.store_aligned_i(&mut oi.0, vi);
        (s.to_array_f(v), o.0, oi.0)
    }
    fn reference(m: [f32; 32]) -> Self::Out {
        let mut o = [0.0; 32];
        o[..16].copy_from_slice(&m[16..]);
        (
            m[16..].try_into().unwrap(),
            o,
            core::array::from_fn(|i| i as i32 * 3),
        )
    }
}
proptest! { #[test] fn aligned_load_store(m in prop::array::uniform32(f32_any())) { check::<AlignedLS>(m)?; } }

/// Masked load/store with a slice only as long as the highest active lane
/// needs (loop tails): inactive lanes must not be touched.
struct MaskedLS;
impl Op for MaskedLS {
    type In = ([f32; 16], [i32; 16], Mask16, [f32; N], [i32; N]);
    type Out = ([f32; 16], [i32; 16], [f32; N], [i32; N]);
    fn vec<S: Simd>(s: S, (srcf, srci, m, mf, mi): Self::In) -> Self::Out {
        let ext = 16 - m.0.leading_zeros() as usize;
        let a = s.mask_load_f(s.from_array_f(srcf), m, &mf[..ext]);
        let b = s.mask_load_i(s.from_array_i(srci), m, &mi[..ext]);
        let mut of = mf;
        let mut oi = mi;
        s.mask_store_f(&mut of[3..3 + ext], m, s.from_array_f(srcf));
        s.mask_store_i(&mut oi[3..3 + ext], m, s.from_array_i(srci));
        (s.to_array_f(a), s.to_array_i(b), of, oi)
    }
    fn reference((srcf, srci, m, mf, mi): Self::In) -> Self::Out {
        let mut of = mf;
        let mut oi = mi;
        for i in m.iter() {
            of[3 + i] = srcf[i];
            oi[3 + i] = srci[i];
        }
        (
            core::array::from_fn(|i| if mbit(m, i) { mf[i] } else { srcf[i] }),
            core::array::from_fn(|i| if mbit(m, i) { mi[i] } else { srci[i] }),
            of,
            oi,
        )
    }
}
proptest! { #[test] fn masked_load_store(sf in arr_f(), si in arr_i(), m in mask(), mf in mem_f(), mi in mem_i()) {
    check::<MaskedLS>((sf, si, m, mf, mi))?;
} }

// ---------------- gather / scatter ----------------
struct Gather;
impl Op for Gather {
    type In = ([f32; 16], [i32; 16], Mask16, [i32; 16], [f32; N], [i32; N]);
    type Out = ([f32; 16], [i32; 16], [f32; 16], [i32; 16]);
    fn vec<S: Simd>(s: S, (sf, si, m, idx, mf, mi): Self::In) -> Self::Out {
        let vi = s.from_array_i(idx);
        (
            s.to_array_f(s.mask_gather_f(s.from_array_f(sf), m, &mf, vi)),
            s.to_array_i(s.mask_gather_i(s.from_array_i(si), m, &mi, vi)),
            s.to_array_f(s.gather_f(&mf, vi)),
            s.to_array_i(s.gather_i(&mi, vi)),
        )
    }
    fn reference((sf, si, m, idx, mf, mi): Self::In) -> Self::Out {
        (
            core::array::from_fn(|i| if mbit(m, i) { mf[idx[i] as usize] } else { sf[i] }),
            core::array::from_fn(|i| if mbit(m, i) { mi[idx[i] as usize] } else { si[i] }),
            core::array::from_fn(|i| mf[idx[i] as usize]),
            core::array::from_fn(|i| mi[idx[i] as usize]),
        )
    }
}
proptest! { #[test] fn gather(sf in arr_f(), si in arr_i(), m in mask(), idx in idx(), mf in mem_f(), mi in mem_i()) {
    check::<Gather>((sf, si, m, idx, mf, mi))?;
} }

/// Inactive lanes may hold garbage indices: they must be ignored.
struct GatherGarbage;
impl Op for GatherGarbage {
    type In = (Mask16, [i32; 16], [i32; 16], [f32; N]);
    type Out = [f32; 16];
    fn vec<S: Simd>(s: S, (m, idx, junk, mf): Self::In) -> Self::Out {
        let idx: [i32; 16] = core::array::from_fn(|i| if mbit(m, i) { idx[i] } else { junk[i] });
        s.to_array_f(s.mask_gather_f(s.splat_f(-7.0), m, &mf, s.from_array_i(idx)))
    }
    fn reference((m, idx, _junk, mf): Self::In) -> Self::Out {
        core::array::from_fn(|i| if mbit(m, i) { mf[idx[i] as usize] } else { -7.0 })
    }
}
proptest! { #[test] fn gather_inactive_garbage(m in mask(), idx in idx(), junk in arr_i(), mf in mem_f()) {
    check::<GatherGarbage>((m, idx, junk, mf))?;
} }

struct Scatter;
impl Op for Scatter {
    type In = (Mask16, [i32; 16], [f32; 16], [i32; 16], [f32; N], [i32; N]);
    type Out = ([f32; N], [i32; N]);
    fn vec<S: Simd>(s: S, (m, idx, vf, vi, mf, mi): Self::In) -> Self::Out {
        let (mut of, mut oi) = (mf, mi);
        let ix = s.from_array_i(idx);
        s.mask_scatter_f(&mut of, m, ix, s.from_array_f(vf));
        s.mask_scatter_i(&mut oi, m, ix, s.from_array_i(vi));
        (of, oi)
    }
    fn reference((m, idx, vf, vi, mf, mi): Self::In) -> Self::Out {
        let (mut of, mut oi) = (mf, mi);
        for i in m.iter() {
            // lane order: highest lane wins on collisions
            of[idx[i] as usize] = vf[i];
            oi[idx[i] as usize] = vi[i];
        }
        (of, oi)
    }
}
proptest! { #[test] fn scatter(m in mask(), idx in idx(), vf in arr_f(), vi in arr_i(), mf in mem_f(), mi in mem_i()) {
    check::<Scatter>((m, idx, vf, vi, mf, mi))?;
} }

// ---------------- compress-store / expand-load ----------------
struct CompressStore;
impl Op for CompressStore {
    type In = (Mask16, [f32; 16], [i32; 16], [f32; N], [i32; N]);
    type Out = (usize, [f32; N], [i32; N], usize);
    fn vec<S: Simd>(s: S, (m, vf, vi, mf, mi): Self::In) -> Self::Out {
        let (mut of, mut oi) = (mf, mi);
        let n = m.count() as usize;
        // the destination slice is exactly n long (binning writes at the tail)
        let a = s.compress_store_f(&mut of[5..5 + n], m, s.from_array_f(vf));
        let b = s.compress_store_i(&mut oi[5..5 + n], m, s.from_array_i(vi));
        (a, of, oi, b)
    }
    fn reference((m, vf, vi, mf, mi): Self::In) -> Self::Out {
        let (mut of, mut oi) = (mf, mi);
        let mut n = 0;
        for i in m.iter() {
            of[5 + n] = vf[i];
            oi[5 + n] = vi[i];
            n += 1;
        }
        (n, of, oi, n)
    }
}
proptest! { #[test] fn compress_store(m in mask(), vf in arr_f(), vi in arr_i(), mf in mem_f(), mi in mem_i()) {
    check::<CompressStore>((m, vf, vi, mf, mi))?;
} }

struct ExpandLoad;
impl Op for ExpandLoad {
    type In = (Mask16, [f32; 16], [i32; 16], [f32; N], [i32; N]);
    type Out = ([f32; 16], [i32; 16]);
    fn vec<S: Simd>(s: S, (m, sf, si, mf, mi): Self::In) -> Self::Out {
        let n = m.count() as usize;
        (
            s.to_array_f(s.expand_load_f(s.from_array_f(sf), m, &mf[7..7 + n])),
            s.to_array_i(s.expand_load_i(s.from_array_i(si), m, &mi[7..7 + n])),
        )
    }
    fn reference((m, sf, si, mf, mi): Self::In) -> Self::Out {
        let (mut a, mut b) = (sf, si);
        for (n, i) in m.iter().enumerate() {
            a[i] = mf[7 + n];
            b[i] = mi[7 + n];
        }
        (a, b)
    }
}
proptest! { #[test] fn expand_load(m in mask(), sf in arr_f(), si in arr_i(), mf in mem_f(), mi in mem_i()) {
    check::<ExpandLoad>((m, sf, si, mf, mi))?;
} }

// ---------------- fetch-add ----------------
fn seq_fetch_add(mem: &mut [i32], m: Mask16, idx: &[i32; 16], val: &[i32; 16]) -> [i32; 16] {
    let mut out = [0; 16];
    for i in m.iter() {
        let p = &mut mem[idx[i] as usize];
        out[i] = *p;
        *p = p.wrapping_add(val[i]);
    }
    out
}

struct FetchAdd;
impl Op for FetchAdd {
    type In = (Mask16, [i32; 16], [i32; 16], [i32; N]);
    type Out = ([i32; 16], [i32; N], [i32; 16], [i32; N]);
    fn vec<S: Simd>(s: S, (m, idx, val, mi): Self::In) -> Self::Out {
        let mut a = mi;
        let ix = s.from_array_i(idx);
        let v = s.from_array_i(val);
        let r1 = s.to_array_i(s.fetch_add_i(&mut a, m, ix, v));
        let at: Vec<AtomicI32> = mi.iter().map(|&x| AtomicI32::new(x)).collect();
        let r2 = s.to_array_i(s.atomic_fetch_add_i(&at, m, ix, v));
        let b: [i32; N] = core::array::from_fn(|i| at[i].load(Ordering::Relaxed));
        (r1, a, r2, b)
    }
    fn reference((m, idx, val, mi): Self::In) -> Self::Out {
        let mut a = mi;
        let r = seq_fetch_add(&mut a, m, &idx, &val);
        (r, a, r, a)
    }
}
proptest! {
    #[test]
    fn fetch_add(m in mask(), idx in idx(), val in prop_oneof![arr_i(), Just([1; 16])], mi in mem_i()) {
        check::<FetchAdd>((m, idx, val, mi))?;
    }
}

#[test]
fn atomic_fetch_add_multithreaded() {
    // 4 threads × 2000 vector fetch-adds of 1 into 8 counters with heavy
    // collisions: totals must be exact, and each thread's returned values
    // must be distinct tickets per counter.
    for c in contexts() {
        let counters: Vec<AtomicI32> = (0..8).map(|_| AtomicI32::new(0)).collect();
        std::thread::scope(|sc| {
            for t in 0..4 {
                let counters = &counters;
                sc.spawn(move || {
                    struct K<'a>(&'a [AtomicI32], i32);
                    impl sism_simd::Kernel for K<'_> {
                        type Output = Vec<(i32, i32)>;
                        #[inline(always)]
                        fn run<S: Simd>(self, s: S) -> Vec<(i32, i32)> {
                            let mut tickets = Vec::new();
                            for it in 0..2000 {
                                let idx: [i32; 16] =
                                    core::array::from_fn(|i| ((i as i32 * 7 + it + self.1) % 8) / 2 * 2);
                                let r = s.atomic_fetch_add_i(
                                    self.0,
                                    Mask16::ALL,
                                    s.from_array_i(idx),
                                    s.splat_i(1),
                                );
                                let r = s.to_array_i(r);
                                for i in 0..16 {
                                    tickets.push((idx[i], r[i]));
                                }
                            }
                            tickets
                        }
                    }
                    run(c, K(counters, t))
                });
            }
        });
        let total: i32 = counters.iter().map(|a| a.load(Ordering::Relaxed)).sum();
        assert_eq!(total, 4 * 2000 * 16, "{c:?}");
    }
}

// ---------------- bounds checks ----------------
macro_rules! oob {
    ($name:ident, |$s:ident, $mem:ident| $e:expr) => {
        #[test]
        fn $name() {
            for c in contexts() {
                let r = std::panic::catch_unwind(|| {
                    struct K;
                    impl sism_simd::Kernel for K {
                        type Output = ();
                        #[inline(always)]
                        fn run<S: Simd>(self, $s: S) {
                            #[allow(unused_mut)]
                            let mut $mem = vec![0i32; 10];
                            let _ = $e;
                        }
                    }
                    run(c, K)
                });
                let err = r.expect_err(&format!("{c:?}: expected a panic"));
                let msg = err
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| err.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                assert!(
                    msg.contains("sism-simd"),
                    "{c:?}: unexpected panic message {msg:?}"
                );
            }
        }
    };
}
oob!(oob_gather_high, |s, mem| s.mask_gather_i(
    s.splat_i(0),
    Mask16(1 << 5),
    &mem,
    s.splat_i(10)
));
oob!(oob_gather_negative, |s, mem| s.gather_i(&mem, s.splat_i(-1)));
oob!(oob_scatter, |s, mem| s.mask_scatter_i(
    &mut mem,
    Mask16(0x8000),
    s.index_i(),
    s.splat_i(1)
));
oob!(oob_fetch_add, |s, mem| s.fetch_add_i(
    &mut mem,
    Mask16(0x0800),
    s.index_i(),
    s.splat_i(1)
));
oob!(oob_load, |s, mem| s.load_i(&mem));
oob!(oob_store, |s, mem| s.store_i(&mut mem, s.splat_i(0)));
oob!(oob_mask_load, |s, mem| s.mask_load_i(
    s.splat_i(0),
    Mask16(1 << 10),
    &mem
));
oob!(oob_compress, |s, mem| s.compress_store_i(
    &mut mem,
    Mask16(0x0FFF),
    s.splat_i(0)
));
oob!(oob_expand, |s, mem| s.expand_load_i(
    s.splat_i(0),
    Mask16(0x0FFF),
    &mem
));
oob!(oob_misaligned, |s, mem| {
    #[repr(align(64))]
    struct A([i32; 32]);
    let a = A([0; 32]);
    let _ = &mut mem;
    s.load_aligned_i(&a.0[1..])
});
oob!(oob_extract, |s, mem| {
    let _ = &mut mem;
    s.extract_i(s.splat_i(0), 16)
});

#[test]
fn inactive_lanes_do_not_touch_memory() {
    // A masked load/store on a slice that ends right after the last active
    // lane, and a gather with all lanes inactive on an empty slice.
    for c in contexts() {
        struct K;
        impl sism_simd::Kernel for K {
            type Output = (i32, [i32; 3]);
            #[inline(always)]
            fn run<S: Simd>(self, s: S) -> (i32, [i32; 3]) {
                let mem = [1, 2, 3];
                let v = s.mask_load_i(s.splat_i(0), Mask16(0b101), &mem);
                let mut out = [0; 3];
                s.mask_store_i(&mut out, Mask16(0b110), s.index_i());
                let e: [i32; 0] = [];
                let g = s.mask_gather_i(s.splat_i(9), Mask16::NONE, &e, s.splat_i(1234));
                s.mask_scatter_i(&mut [], Mask16::NONE, s.splat_i(-5), g);
                let n = s.compress_store_i(&mut [], Mask16::NONE, g);
                (s.reduce_add_i(v) + s.extract_i(g, 3) + n as i32, out)
            }
        }
        assert_eq!(run(c, K), (1 + 3 + 9, [0, 1, 2]), "{c:?}");
    }
}

#[test]
fn counting_records_memory() {
    let rec = Recorder::new();
    struct K<'a>(&'a [f32], &'a mut [i32]);
    impl sism_simd::Kernel for K<'_> {
        type Output = ();
        #[inline(always)]
        fn run<S: Simd>(self, s: S) {
            s.begin_task(9);
            // 16 indices spread over 4 lines (16 floats per line)
            let idx = s.from_array_i(core::array::from_fn(|i| (i as i32 % 4) * 16 + 1));
            let _ = s.gather_f(self.0, idx);
            let _ = s.mask_gather_f(s.splat_f(0.0), Mask16(0b11), self.0, s.index_i());
            let dup = s.from_array_i(core::array::from_fn(|i| (i as i32) / 4));
            let _ = s.fetch_add_i(self.1, Mask16::ALL, dup, s.splat_i(1));
            s.scalar_ops(5);
            s.end_task();
        }
    }
    #[repr(C, align(64))]
    struct A([f32; 64]);
    let a = Box::new(A([1.0; 64]));
    let mut b = vec![0i32; 8];
    sism_simd::run_counting(&rec, K(&a.0, &mut b));
    assert_eq!(b[..4], [4, 4, 4, 4]);
    let t = rec.take_tasks();
    assert_eq!(t.len(), 1);
    let c = t[0].counters;
    assert_eq!(t[0].kind, 9);
    assert_eq!((c.gather, c.atomic, c.scalar), (2, 1, 5));
    assert_eq!(c.gather_lines, 4 + 1);
    assert_eq!(c.atomic_lines, 1);
    assert_eq!(c.atomic_conflicts, 12);
    assert_eq!(c.masked_ops, 2); // masked gather + fetch-add (all lanes, masked op)
    assert_eq!(c.active_lanes, 16 + 2 + 16 + 2 * 16); // + two from_array_i loads
    assert_eq!(c.load, 2);
    // line stream: gather lines 0,1,2,3,0,1,2,3,... dedups only consecutive repeats
    let lines: Vec<_> = t[0].lines.iter().collect();
    assert!(lines.len() > 5);
    assert!(lines.iter().take(16).all(|&(_, w)| !w));
    assert!(lines.last().unwrap().1, "fetch-add recorded as a write");
}

#[test]
fn scalar_touches_join_the_line_stream_and_cost_nothing_natively() {
    struct K<'a>(&'a [u64], &'a mut [u64]);
    impl sism_simd::Kernel for K<'_> {
        type Output = u64;
        #[inline(always)]
        fn run<S: Simd>(self, s: S) -> u64 {
            s.begin_task(3);
            // Scalar code streaming 20 u64 (160 bytes over 3 lines), then one store.
            s.scalar_read(&self.0[..20]);
            let sum = self.0[..20].iter().sum();
            self.1[0] = sum;
            s.scalar_write(&self.1[..1]);
            s.scalar_read::<u64>(&[]);
            s.end_task();
            sum
        }
    }
    #[repr(C, align(64))]
    struct A([u64; 24]);
    let a = Box::new(A([2; 24]));
    let mut b = Box::new(A([0; 24]));
    assert_eq!(sism_simd::run_native(K(&a.0, &mut b.0)), 40);
    let rec = Recorder::new();
    assert_eq!(sism_simd::run_counting(&rec, K(&a.0, &mut b.0)), 40);
    let t = rec.take_tasks();
    let lines: Vec<(u64, bool)> = t[0].lines.iter().collect();
    let first = a.0.as_ptr() as u64 >> 6;
    let out = b.0.as_ptr() as u64 >> 6;
    assert_eq!(
        lines,
        [
            (first, false),
            (first + 1, false),
            (first + 2, false),
            (out, true)
        ]
    );
    // Scalar touches are memory traffic, not instructions.
    assert_eq!(t[0].counters.instructions(), 0);
}

proptest! {
    /// Gathers and scatters record, per instruction, the active lanes' lines in lane order (without
    /// consecutive repeats) and count their distinct lines, whether the indices come sorted (the
    /// compress-stored case, counted from the runs) or not (counted by sorting).
    #[test]
    fn indexed_lines_match_a_lane_by_lane_model(
        idx in prop::array::uniform16(0i32..256),
        sorted in any::<bool>(),
        mask in any::<u16>(),
        write in any::<bool>(),
    ) {
        let mut idx = idx;
        if sorted {
            idx.sort_unstable();
        }
        #[repr(C, align(64))]
        struct A([f32; 256]);
        let mut a = Box::new(A([0.0; 256]));
        let m = Mask16(mask);
        let rec = Recorder::new();
        struct K<'a>(&'a mut [f32], [i32; 16], Mask16, bool);
        impl sism_simd::Kernel for K<'_> {
            type Output = ();
            #[inline(always)]
            fn run<S: Simd>(self, s: S) {
                s.begin_task(0);
                let idx = s.from_array_i(self.1);
                if self.3 {
                    s.mask_scatter_f(self.0, self.2, idx, s.splat_f(1.0));
                } else {
                    let _ = s.mask_gather_f(s.splat_f(0.0), self.2, self.0, idx);
                }
                s.end_task();
            }
        }
        sism_simd::run_counting(&rec, K(&mut a.0, idx, m, write));
        let t = &rec.take_tasks()[0];
        let base = a.0.as_ptr() as u64 / 64;
        let lanes: Vec<u64> = m.iter().map(|l| base + idx[l] as u64 / 16).collect();
        let mut want: Vec<(u64, bool)> = Vec::new();
        for &l in &lanes {
            if want.last() != Some(&(l, write)) {
                want.push((l, write));
            }
        }
        let mut distinct = lanes.clone();
        distinct.sort_unstable();
        distinct.dedup();
        let c = t.counters;
        prop_assert_eq!(if write { c.scatter_lines } else { c.gather_lines }, distinct.len() as u64);
        prop_assert_eq!(t.lines.iter().collect::<Vec<_>>(), want);
    }
}

// ---------------- the kernel's own stack ----------------

/// Stores a vector into a line-aligned stack array and reloads it, then loads a heap buffer.
struct StackLanes<'a>(&'a [f32]);
#[repr(C, align(64))]
struct Lanes([f32; 16]);
impl sism_simd::Kernel for StackLanes<'_> {
    type Output = f32;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> f32 {
        s.begin_task(1);
        let mut lanes = Lanes([0.0; 16]);
        let v = s.load_f(self.0);
        s.store_f(&mut lanes.0, s.add_f(v, v));
        let w = s.load_f(std::hint::black_box(&lanes.0));
        s.end_task();
        s.reduce_add_f(w)
    }
}

/// The lines a counting run of [`StackLanes`] records, `depth` frames down the calling thread's stack.
#[inline(never)]
fn stack_lines(heap: &[f32], depth: usize) -> Vec<(u64, bool)> {
    if depth > 0 {
        let pad = std::hint::black_box([depth as u8; 256]);
        let lines = stack_lines(heap, depth - 1);
        std::hint::black_box(&pad);
        return lines;
    }
    let rec = Recorder::new();
    sism_simd::run_counting(&rec, StackLanes(heap));
    let tasks = rec.take_tasks();
    tasks.iter().flat_map(|t| t.lines.iter()).collect()
}

#[test]
fn stack_lines_are_renamed_whatever_the_thread_and_depth() {
    // The same kernel on another thread or deeper in the stack records the same lines: its stack
    // array's line is renamed (STACK_LINES_BASE + 0), the heap buffer's is its own.
    let heap = vec![1.0f32; 16];
    let here = stack_lines(&heap, 0);
    let heap_line = heap.as_ptr() as u64 >> 6;
    assert!(here.iter().any(|&(l, _)| l == heap_line), "{here:?}");
    let renamed: Vec<_> = here
        .iter()
        .filter(|&&(l, _)| l >= sism_simd::STACK_LINES_BASE)
        .collect();
    assert_eq!(
        renamed,
        [
            &(sism_simd::STACK_LINES_BASE, true),
            &(sism_simd::STACK_LINES_BASE, false)
        ]
    );
    assert_eq!(stack_lines(&heap, 7), here);
    let there = std::thread::scope(|sc| sc.spawn(|| stack_lines(&heap, 3)).join().unwrap());
    assert_eq!(there, here);
}
