//! A global allocator wrapper that makes counted line streams independent of where the allocator
//! puts things.
//!
//! The counting context records the 64-byte lines of real addresses. Two things about those
//! addresses would otherwise change from run to run (and with the host's thread count):
//!
//! * **Alignment.** A 16-lane load from a buffer that starts mid-line touches two lines, from a
//!   line-aligned one a single line; the distinct lines of a gather depend on it too.
//!   [`LineAlloc`] aligns every block to [`LINE`] bytes, so a buffer's lines are a function of the
//!   offsets accessed, and two blocks never share a line. [`GAP_LINES`] unused lines follow every
//!   block, so that two blocks are never near neighbours either (a model following sequential
//!   streams would otherwise run from one into the other in the runs that place them side by side).
//! * **Reuse.** Memory freed during a frame and handed out again makes two unrelated buffers (a
//!   task's scratch vector and the next task's, which host thread ran which) the same lines for
//!   the machine model's caches. While a [`HoldFrees`] guard is alive, freed blocks are held back
//!   and only returned to the allocator when the last guard drops, so within a counted frame no
//!   address is ever reused.
//!
//! With both, the lines of a counted frame are the same up to a per-buffer translation in every
//! run, and the model's first-touch line ids (`sism::machine::cache`) make the simulation exactly
//! repeatable. Without the wrapper installed as the `#[global_allocator]` the guard does nothing
//! and counted runs differ slightly (well under 1% of the cycles).
//!
//! ```
//! use sism_simd::{HoldFrees, LineAlloc};
//! // In a binary: #[global_allocator] static GLOBAL: LineAlloc<std::alloc::System> = LineAlloc(std::alloc::System);
//! let _hold = HoldFrees::new(); // around a counted frame
//! ```

use core::alloc::{GlobalAlloc, Layout};
use core::ptr::null_mut;
use core::sync::atomic::{AtomicPtr, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Alignment of every block, bytes: one cache line of the modelled machine.
pub const LINE: usize = 64;

/// Global allocator wrapper over `A`: every block [`LINE`]-aligned, and frees held back while a
/// [`HoldFrees`] guard is alive (see the module documentation). The cost outside counted frames is
/// the alignment and the gap (up to five lines per block) and one atomic load per free. Use it only as the
/// `#[global_allocator]`: held blocks are released through the global allocator.
#[derive(Clone, Copy, Debug, Default)]
pub struct LineAlloc<A>(pub A);

/// Live [`HoldFrees`] guards.
static HOLDERS: AtomicUsize = AtomicUsize::new(0);
/// Held blocks, a lock-free stack linked through the blocks themselves.
static HELD: AtomicPtr<Held> = AtomicPtr::new(null_mut());
/// Bytes of the held blocks.
static HELD_BYTES: AtomicUsize = AtomicUsize::new(0);
/// Most bytes held ([`HoldFrees::set_limit`]); a free past it goes back to the allocator at once.
static HOLD_LIMIT: AtomicUsize = AtomicUsize::new(usize::MAX);
/// Frees given back at once because the hold was full, since the first guard of the current hold.
static RELEASED: AtomicUsize = AtomicUsize::new(0);
/// Serialises the first guard's start against the last guard's release, so blocks freed during one
/// hold are never released into a hold that has already begun.
static HOLD_LOCK: Mutex<()> = Mutex::new(());

/// What a held block stores in its own first bytes (every block is at least this large).
#[repr(C)]
struct Held {
    next: *mut Held,
    /// The caller's layout (the block was freed with it; [`inner_layout`] of it is the block's).
    size: usize,
    align: usize,
}

/// Lines left unused after every block ([`LineAlloc`]): two blocks' lines are always more than
/// this many lines apart, so a model that follows sequential streams within a reach of up to this
/// many lines (`sism::machine::timing::STREAM_REACH`) never continues a stream from one block into
/// another because the allocator happened to place them side by side in one run and not in the
/// next.
pub const GAP_LINES: usize = 4;

/// The layout asked of the inner allocator: at least [`LINE`]-aligned, large enough to hold a
/// [`Held`] header, rounded up to whole lines and followed by [`GAP_LINES`] unused lines. A
/// function of the caller's layout alone, so `dealloc` and `realloc` pass the inner allocator the
/// same layout `alloc` did. `None` if the padded size overflows the layout's limit.
#[inline]
fn inner_layout(l: Layout) -> Option<Layout> {
    let size = l
        .size()
        .max(core::mem::size_of::<Held>())
        .checked_next_multiple_of(LINE)?
        .checked_add(GAP_LINES * LINE)?;
    let align = l.align().max(LINE);
    Layout::from_size_align(size, align).ok()
}

// SAFETY: every method forwards to the inner allocator with `inner_layout(layout)`, a function of the
// caller's layout alone, so each block is freed or reallocated with the layout it was allocated
// with, as `GlobalAlloc` requires of the inner allocator. Blocks are at least as large and as aligned
// as the caller asked (`inner_layout` only grows size and alignment), and a held block is never
// handed out again until it is freed to the inner allocator: no two live allocations overlap.
unsafe impl<A: GlobalAlloc> GlobalAlloc for LineAlloc<A> {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        match inner_layout(layout) {
            // SAFETY: the inner layout has non-zero size (at least a header) and a valid alignment.
            Some(inner) => unsafe { self.0.alloc(inner) },
            None => null_mut(),
        }
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        match inner_layout(layout) {
            // SAFETY: as in `alloc`.
            Some(inner) => unsafe { self.0.alloc_zeroed(inner) },
            None => null_mut(),
        }
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // `alloc` succeeded with this layout, so its inner layout exists.
        let Some(inner) = inner_layout(layout) else {
            return;
        };
        if HOLDERS.load(Ordering::Acquire) == 0 {
            // SAFETY: `ptr` came from `self.0` with `inner` (same mapping of the same layout).
            unsafe { self.0.dealloc(ptr, inner) };
            return;
        }
        // Past the limit the block goes back now: memory stays bounded (a frame that frees more than
        // the limit would otherwise exhaust it), at the price of addresses that may be reused.
        let held = HELD_BYTES.fetch_add(inner.size(), Ordering::Relaxed);
        if held.saturating_add(inner.size()) > HOLD_LIMIT.load(Ordering::Relaxed) {
            HELD_BYTES.fetch_sub(inner.size(), Ordering::Relaxed);
            RELEASED.fetch_add(1, Ordering::Relaxed);
            // SAFETY: as in the unheld case above.
            unsafe { self.0.dealloc(ptr, inner) };
            return;
        }
        let node = ptr.cast::<Held>();
        // SAFETY: the block is at least `size_of::<Held>()` bytes and LINE-aligned, and the caller
        // gave it up, so it is ours to write.
        unsafe {
            node.write(Held {
                next: null_mut(),
                size: layout.size(),
                align: layout.align(),
            })
        };
        let mut head = HELD.load(Ordering::Relaxed);
        loop {
            // SAFETY: `node` is a valid, exclusively owned header (written above).
            unsafe { (*node).next = head };
            match HELD.compare_exchange_weak(head, node, Ordering::Release, Ordering::Relaxed) {
                Ok(_) => return,
                Err(h) => head = h,
            }
        }
    }

    #[inline]
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if HOLDERS.load(Ordering::Acquire) == 0 {
            // SAFETY: the caller's contract, with both layouts mapped the same way as in `alloc`.
            // The new inner size keeps the header minimum and the inner alignment.
            unsafe {
                let (Some(old), Some(new)) = (
                    inner_layout(layout),
                    inner_layout(Layout::from_size_align_unchecked(new_size, layout.align())),
                ) else {
                    return null_mut();
                };
                return self.0.realloc(ptr, old, new.size());
            }
        }
        // While frees are held a moved block must not go back to the allocator: copy by hand.
        // SAFETY: `new_size` with `layout.align()` is a valid layout (the caller's contract).
        let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        // SAFETY: as in `alloc`.
        let new = unsafe { self.alloc(new_layout) };
        if !new.is_null() {
            // SAFETY: both blocks are valid for the smaller size and do not overlap; then the old
            // block is given up exactly once.
            unsafe {
                core::ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
        }
        new
    }
}

/// While alive (and [`LineAlloc`] is the global allocator), freed memory is not reused: blocks
/// freed by any thread are held and given back when the last guard drops. Hold one around a
/// counted frame; memory then grows by what the frame frees (its temporaries).
#[must_use = "frees are held only while the guard lives"]
#[derive(Debug)]
pub struct HoldFrees(());

impl HoldFrees {
    /// Starts holding frees (nested and concurrent guards are fine).
    pub fn new() -> HoldFrees {
        let _l = HOLD_LOCK.lock().unwrap_or_else(|e| e.into_inner());
        if HOLDERS.fetch_add(1, Ordering::AcqRel) == 0 {
            RELEASED.store(0, Ordering::Relaxed);
        }
        HoldFrees(())
    }

    /// Holds at most `bytes` of freed blocks (all guards; default unlimited): a free past it is given
    /// back at once, so a frame that frees more than memory holds still completes, but the addresses
    /// of its later blocks may repeat earlier ones (then the frame's cache-line ids, and the counters
    /// the model derives from them, may differ between runs). [`HoldFrees::released`] counts those
    /// frees.
    pub fn set_limit(bytes: usize) {
        HOLD_LIMIT.store(bytes, Ordering::Relaxed);
    }

    /// Whether frees are being held (a counted frame is running). Code that reuses a buffer across
    /// tasks through a per-thread cache must not while this holds: which host thread runs which task
    /// is the pool's choice, so the buffer's address (and with it the recorded lines) would differ
    /// from run to run.
    pub fn active() -> bool {
        HOLDERS.load(Ordering::Acquire) > 0
    }

    /// Frees given back at once because the hold was at its limit, since the current hold began.
    pub fn released() -> usize {
        RELEASED.load(Ordering::Relaxed)
    }

    /// Blocks currently held (a walk of the list; for tests and diagnostics).
    pub fn held_blocks() -> usize {
        let _l = HOLD_LOCK.lock().unwrap_or_else(|e| e.into_inner());
        let mut n = 0;
        let mut p = HELD.load(Ordering::Acquire);
        while !p.is_null() {
            n += 1;
            // SAFETY: held blocks stay valid until released, which needs the lock we hold.
            p = unsafe { (*p).next };
        }
        n
    }
}

impl Default for HoldFrees {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for HoldFrees {
    fn drop(&mut self) {
        let _l = HOLD_LOCK.lock().unwrap_or_else(|e| e.into_inner());
        if HOLDERS.fetch_sub(1, Ordering::AcqRel) != 1 {
            return;
        }
        // The last guard: give every held block back. A free racing with this (it saw a guard
        // alive just before the count dropped) may still push after the swap; it is released by
        // the next hold's end.
        let mut p = HELD.swap(null_mut(), Ordering::AcqRel);
        while !p.is_null() {
            // SAFETY: every node on the list is a block freed through `LineAlloc::dealloc` with the
            // recorded (caller's) layout; it is released exactly once (the list was taken atomically).
            unsafe {
                let Held { next, size, align } = p.read();
                let layout = Layout::from_size_align_unchecked(size, align);
                let inner = inner_layout(layout).map_or(0, |l| l.size());
                HELD_BYTES.fetch_sub(inner, Ordering::Relaxed);
                release(p.cast(), layout);
                p = next;
            }
        }
    }
}

/// Frees a held block. Blocks are only held by [`LineAlloc`] as the `#[global_allocator]` (it is
/// not meant to be used as a plain allocator value), so the global allocator is the wrapper, and
/// with no guard alive its `dealloc` goes straight to the inner allocator with the inner layout of
/// the caller's `layout`: the one the block was allocated with.
///
/// # Safety
/// `ptr` was allocated by the global `LineAlloc` with the caller's layout `layout`, no guard is
/// alive, and the block is freed exactly once.
unsafe fn release(ptr: *mut u8, layout: Layout) {
    // SAFETY: per the function's contract.
    unsafe { std::alloc::dealloc(ptr, layout) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inner_layout_is_aligned_whole_lines_and_a_gap() {
        for (size, align) in [(1, 1), (7, 4), (24, 8), (64, 64), (100, 16), (4096, 4096)] {
            let l = inner_layout(Layout::from_size_align(size, align).unwrap()).unwrap();
            assert!(l.align() >= LINE && l.align() >= align);
            assert_eq!(l.size() % LINE, 0);
            assert_eq!(l.size(), size.max(24).next_multiple_of(LINE) + GAP_LINES * LINE);
        }
        // Past the largest layout: no block, not a wrapped size.
        let huge = Layout::from_size_align(isize::MAX as usize - 63, 64).unwrap();
        assert!(inner_layout(huge).is_none());
    }
}
