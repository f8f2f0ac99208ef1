//! Scalar helpers shared by the backends: bounds checks with clear panic
//! messages, reference lane semantics, and the atomic fetch-add.

#![allow(clippy::needless_range_loop)]

use crate::Mask16;
use core::sync::atomic::{AtomicI32, Ordering};

#[cold]
#[inline(never)]
#[track_caller]
pub(crate) fn oob_index(op: &str, m: Mask16, idx: &[i32; 16], len: usize) -> ! {
    for lane in m.iter() {
        let i = idx[lane];
        if i < 0 || i as usize >= len {
            panic!(
                "sism-simd: {op}: active lane {lane} has index {i}, out of bounds for a slice of length {len}"
            );
        }
    }
    panic!("sism-simd: {op}: index out of bounds for a slice of length {len}")
}

#[cold]
#[inline(never)]
#[track_caller]
pub(crate) fn short_slice(op: &str, need: usize, len: usize) -> ! {
    panic!("sism-simd: {op}: needs {need} elements but the slice has length {len}")
}

#[cold]
#[inline(never)]
#[track_caller]
pub(crate) fn misaligned(op: &str, addr: usize) -> ! {
    panic!("sism-simd: {op}: address {addr:#x} is not 64-byte aligned")
}

#[cold]
#[inline(never)]
#[track_caller]
pub(crate) fn bad_lane(lane: usize) -> ! {
    panic!("sism-simd: lane {lane} out of range 0..16")
}

/// Panics unless the slice holds `n` elements (a contiguous access's extent).
#[inline(always)]
#[track_caller]
pub(crate) fn need(op: &str, mem_len: usize, n: usize) {
    if mem_len < n {
        short_slice(op, n, mem_len);
    }
}

/// Panics unless `mem` starts on a 64-byte boundary and holds a whole vector.
#[inline(always)]
#[track_caller]
pub(crate) fn aligned<T>(op: &str, mem: &[T]) {
    let addr = mem.as_ptr() as usize;
    if !addr.is_multiple_of(64) {
        misaligned(op, addr);
    }
    need(op, mem.len(), 16);
}

/// Scatter lane by lane in lane order (a later lane's write wins); indices already checked.
#[inline(always)]
pub(crate) fn scatter_lanes<T: Copy>(mem: &mut [T], m: Mask16, idx: &[i32; 16], v: &[T; 16]) {
    for i in m.iter() {
        mem[idx[i] as usize] = v[i];
    }
}

/// Private fetch-add lane by lane in lane order (a duplicate index sees its earlier lanes' adds):
/// the reference semantics; indices already checked.
#[inline(always)]
pub(crate) fn fetch_add_lanes(mem: &mut [i32], m: Mask16, idx: &[i32; 16], val: &[i32; 16]) -> [i32; 16] {
    let mut o = [0i32; 16];
    for i in m.iter() {
        let p = &mut mem[idx[i] as usize];
        o[i] = *p;
        *p = p.wrapping_add(val[i]);
    }
    o
}

/// The mask-register methods of [`crate::Simd`], the same on every native backend (a
/// [`Mask16`] is their mask on each); the counting context has its own, which count.
macro_rules! native_mask_ops {
    () => {
        #[inline(always)]
        fn mask_and(self, a: Mask16, b: Mask16) -> Mask16 {
            Mask16(a.0 & b.0)
        }
        #[inline(always)]
        fn mask_or(self, a: Mask16, b: Mask16) -> Mask16 {
            Mask16(a.0 | b.0)
        }
        #[inline(always)]
        fn mask_xor(self, a: Mask16, b: Mask16) -> Mask16 {
            Mask16(a.0 ^ b.0)
        }
        #[inline(always)]
        fn mask_andn(self, a: Mask16, b: Mask16) -> Mask16 {
            Mask16(!a.0 & b.0)
        }
        #[inline(always)]
        fn mask_not(self, a: Mask16) -> Mask16 {
            Mask16(!a.0)
        }
        #[inline(always)]
        fn mask_popcnt(self, a: Mask16) -> u32 {
            a.count()
        }
        #[inline(always)]
        fn mask_any(self, a: Mask16) -> bool {
            a.any()
        }
        #[inline(always)]
        fn mask_all(self, a: Mask16) -> bool {
            a.all()
        }
        #[inline(always)]
        fn mask_first(self, a: Mask16) -> Option<u32> {
            a.first()
        }
        #[inline(always)]
        fn mask_first_n(self, n: usize) -> Mask16 {
            Mask16::first_n(n)
        }
    };
}
pub(crate) use native_mask_ops;

/// Check that every active lane index is in `0..len`.
#[inline(always)]
#[track_caller]
pub(crate) fn check_indices(op: &str, m: Mask16, idx: &[i32; 16], len: usize) {
    let mut bad = false;
    for i in 0..16 {
        bad |= m.test(i) & ((idx[i] as u32 as usize) >= len);
    }
    if bad {
        oob_index(op, m, idx, len);
    }
}

/// Number of elements a masked contiguous access needs: highest active lane + 1.
#[inline(always)]
pub(crate) fn masked_extent(m: Mask16) -> usize {
    16 - m.0.leading_zeros() as usize
}

/// Effective index limit for i32-indexed gathers: indices are sign-extended
/// 32-bit, so only elements below 2^31 - 1 are addressable.
#[inline(always)]
pub(crate) fn index_limit(len: usize) -> u32 {
    len.min(i32::MAX as usize) as u32
}

/// Reference conflict detection: bit j of lane i set when j < i and v[j] == v[i].
#[inline(always)]
pub(crate) fn conflict(v: &[i32; 16]) -> [i32; 16] {
    let mut out = [0i32; 16];
    for i in 0..16 {
        let mut bits = 0u32;
        for j in 0..i {
            bits |= ((v[j] == v[i]) as u32) << j;
        }
        out[i] = bits as i32;
    }
    out
}

/// Atomic fetch-add shared by all backends. `conf` is the conflict vector of
/// `idx` (any lanes); indices must already be bounds-checked.
#[inline(always)]
pub(crate) fn atomic_fetch_add(
    mem: &[AtomicI32],
    m: Mask16,
    idx: &[i32; 16],
    val: &[i32; 16],
    conf: &[i32; 16],
) -> [i32; 16] {
    let mbits = m.0 as u32;
    let mut out = [0i32; 16];
    for lane in m.iter() {
        // Earlier active lanes with the same address.
        let earlier = (conf[lane] as u32) & mbits;
        if earlier != 0 {
            continue; // handled with its group's first lane
        }
        // First lane of a group: combine the whole group in lane order.
        let mut total = 0i32;
        let mut prefix = [0i32; 16];
        let mut members = 0u32;
        for j in lane..16 {
            if (mbits >> j) & 1 == 1 && idx[j] == idx[lane] {
                prefix[j] = total;
                total = total.wrapping_add(val[j]);
                members |= 1 << j;
            }
        }
        let old = mem[idx[lane] as usize].fetch_add(total, Ordering::Relaxed);
        for j in Mask16(members as u16).iter() {
            out[j] = old.wrapping_add(prefix[j]);
        }
    }
    out
}
