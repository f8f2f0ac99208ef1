//! The counting context: same results as the wrapped backend, plus a record
//! of everything issued.

use crate::record::{Counters, LineEncoder, TaskRecord, NO_TASK};
use crate::simd::{BackendKind, Simd};
use crate::Mask16;
use core::cell::UnsafeCell;
use core::sync::atomic::AtomicI32;

/// Collects [`TaskRecord`]s for one thread. Not `Sync`: use one per worker
/// thread (or per task) and merge the records afterwards.
#[derive(Debug)]
pub struct Recorder {
    /// The state, reached only through [`Recorder::with`]: every counted operation goes through it,
    /// and a `RefCell`'s borrow flag was a few percent of a counted frame's host time.
    st: UnsafeCell<State>,
    /// Debug builds check that no access to the state nests in another.
    #[cfg(debug_assertions)]
    busy: core::cell::Cell<bool>,
}

#[derive(Debug)]
struct State {
    kind: u32,
    c: Counters,
    enc: LineEncoder,
    record_lines: bool,
    done: Vec<TaskRecord>,
    /// The current epoch (a task, or the stretch between two tasks), never 0: a depth carries its
    /// epoch in its high 32 bits, so a value made in another epoch (an earlier task, another
    /// thread, the setup before a parallel loop) counts as ready when the task begins, whichever
    /// host thread made it and whatever ran there before: critical paths do not depend on the
    /// pool's scheduling.
    epoch: u64,
    /// Largest depth of a reduction's result in the current epoch, relative to its start (the
    /// issued operations' largest is `retired`; [`State::path`] is the larger of the two).
    top: u64,
    /// Retirement depths of the last [`WINDOW`] vector and counted scalar operations (a ring;
    /// `issued` mod [`WINDOW`] is the oldest): an operation enters the window only when the one
    /// [`WINDOW`] before it has retired. Retirement is in order: an operation retires when it and every
    /// earlier one have completed.
    window: [u64; WINDOW],
    /// Retirement depth of the latest operation (the running maximum of completions).
    retired: u64,
    /// Vector and counted scalar operations issued (indexes the window ring).
    issued: usize,
    /// The depths of recent scalar results, direct-mapped by their [`crate::ChainKey`]: (key,
    /// epoch-tagged depth). A value not found (never produced in this epoch, or evicted by another
    /// key in its slot) is ready at the epoch's start.
    scalars: Box<[(u64, u64); SCALAR_SLOTS]>,
    /// The branch predictor model: each task starts it untrained.
    predictor: crate::branch::BranchPredictor,
    /// The host thread's stack as the kernels see it ([`Recorder::mark_stack`]).
    stack: StackLines,
    /// The counters at the start of the current stretch of [`WINDOW`] counted operations
    /// ([`Counters::window_issue`]).
    stretch_start: Counters,
    /// Counted operations in the current stretch.
    stretch_ops: usize,
}

/// Bytes below a counting run's stack mark whose lines are the kernel's own stack
/// ([`Recorder::mark_stack`]): far more than a kernel's frames use, far less than a thread's stack
/// (rayon's workers get 2 MiB), so no heap block can fall in it.
pub const STACK_WINDOW: usize = 512 << 10;

/// Line number of the first renamed stack line ([`StackLines`]): above every line of a user
/// address (addresses below 2^57, lines below 2^51).
pub const STACK_LINES_BASE: u64 = 1 << 52;

/// Renames the lines of the kernel's own stack frames. Stack arrays (lanes a kernel stores and
/// reloads, `LaneArray`) sit at addresses of whichever host thread ran the task, at whatever depth
/// rayon ran it: recorded as they are, two tasks run one after the other on one host thread would
/// share lines where on two threads they would not, and the records would depend on the pool's
/// scheduling. Each counting run's stack lines are renamed, in the order it first touches them,
/// to lines `STACK_LINES_BASE + 0, 1, …`: every task's stack is the same few lines, as a modelled
/// hardware thread's stack is, whichever host thread ran it.
#[derive(Debug, Default)]
struct StackLines {
    /// Line of the mark (exclusive upper bound); 0: no mark, nothing renamed.
    top: u64,
    /// The stack lines touched so far, in first-touch order (index = renamed line - base), as
    /// their distance below the mark's line.
    seen: Vec<u32>,
    /// Per line below the mark (distance `top - 1 - line`, [`STACK_WINDOW`] / 64 entries, made on
    /// the first mark): its renamed index + 1, or 0 when not touched yet. A table, not a search
    /// of `seen`, since a kernel may keep a whole tile buffer (hundreds of lines) on its stack.
    index: Vec<u32>,
}

impl StackLines {
    /// Starts over below a new mark `top`: no line touched yet.
    fn reset(&mut self, top: u64) {
        for &d in &self.seen {
            self.index[d as usize] = 0;
        }
        self.seen.clear();
        if self.index.is_empty() {
            self.index = vec![0; STACK_WINDOW >> 6];
        }
        self.top = top;
    }

    /// `line` renamed if it lies in the kernel's stack, else unchanged.
    #[inline(always)]
    fn rename(&mut self, line: u64) -> u64 {
        if line >= self.top || line + (STACK_WINDOW as u64 >> 6) < self.top {
            return line;
        }
        // In 0..STACK_WINDOW / 64 by the test above; `top` is set only by `reset`, which makes
        // the table.
        let d = (self.top - 1 - line) as usize;
        let slot = &mut self.index[d];
        if *slot == 0 {
            self.seen.push(d as u32);
            *slot = self.seen.len() as u32;
        }
        STACK_LINES_BASE + u64::from(*slot - 1)
    }
}

/// Slots of [`State::scalars`]: the scalar results whose depth a task remembers.
const SCALAR_SLOTS: usize = 1024;

/// The slot of a scalar key.
#[inline(always)]
fn scalar_slot(key: u64) -> usize {
    (key.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 54) as usize
}

/// The nominal out-of-order window, in vector and counted scalar operations (those with a chain:
/// arithmetic, divides, conversions): an operation cannot start before the one this many before it
/// has retired (in order), which frees its place. Zen 4's and Ice Lake's reorder buffers hold 320
/// and 352 instructions; the kernels' counted operations come with about as many other
/// instructions (loop control, addresses, loads, mask-register moves), hence 128 operations (an
/// assumption, stated; not fitted). With it a record's critical path is the
/// time a core of unbounded issue width but this window would take: independent chains overlap
/// only as far as the window reaches (the instruction-window model of Sniper, Carlson et al. 2014).
pub const WINDOW: usize = 128;

/// The last epoch handed out ([`State::epoch`]).
static EPOCHS: core::sync::atomic::AtomicU64 = core::sync::atomic::AtomicU64::new(0);

/// A fresh epoch: 1, 2, … (wrapping within 32 bits, skipping 0).
fn next_epoch() -> u64 {
    loop {
        let e = (EPOCHS.fetch_add(1, core::sync::atomic::Ordering::Relaxed) + 1) & 0xffff_ffff;
        if e != 0 {
            return e;
        }
    }
}

/// Largest depth within an epoch, nominal cycles (a longer chain saturates).
const MAX_LOCAL_DEPTH: u64 = 0xffff_ffff;

impl State {
    /// Starts a new epoch: depths restart at 0 and the window is empty.
    fn start_epoch(&mut self) {
        self.epoch = next_epoch();
        self.predictor.start_task();
        self.top = 0;
        self.retired = 0;
        self.window.fill(0);
    }

    /// `depth` relative to the current epoch's start: its low bits when it was made in this
    /// epoch, else 0 (ready when the epoch began).
    #[inline(always)]
    fn local(&self, depth: u64) -> u64 {
        if depth >> 32 == self.epoch {
            depth & MAX_LOCAL_DEPTH
        } else {
            0
        }
    }

    /// A depth of this epoch, as values carry it.
    #[inline(always)]
    fn tagged(&self, local: u64) -> u64 {
        self.epoch << 32 | local.min(MAX_LOCAL_DEPTH)
    }

    /// The depth (relative to the epoch's start) of the scalar with key `key`.
    #[inline(always)]
    fn scalar_depth(&self, key: Option<u64>) -> u64 {
        key.map_or(0, |k| {
            let (stored, depth) = self.scalars[scalar_slot(k)];
            if stored == k {
                self.local(depth)
            } else {
                0
            }
        })
    }

    /// Remembers that the scalar with key `key` is `local` deep (relative to the epoch's start).
    #[inline(always)]
    fn set_scalar(&mut self, key: Option<u64>, local: u64) {
        if let Some(k) = key {
            let tagged = self.tagged(local);
            self.scalars[scalar_slot(k)] = (k, tagged);
        }
    }

    /// Issues one operation whose inputs are ready at `ready` (relative to the epoch's start) and
    /// whose result comes `latency` later: it waits for the operation [`WINDOW`] before it to
    /// retire, retires in order, and may deepen the task's path. Returns the result's depth.
    #[inline(always)]
    fn issue(&mut self, ready: u64, latency: u64) -> u64 {
        let slot = self.issued % WINDOW;
        let depth = ready.max(self.window[slot]) + latency;
        self.retired = self.retired.max(depth);
        self.window[slot] = self.retired;
        self.issued += 1;
        // `retired` is the running maximum of every result's depth, so the task's path is the
        // larger of it and `top` ([`State::path`]), not a third read-modify-write per operation.
        depth
    }

    /// Files the current task's record if it recorded anything; returns whether it did.
    fn file_task(&mut self) -> bool {
        let recorded = self.c != Counters::default() || !self.enc.is_empty();
        if recorded {
            let r = take(self);
            self.done.push(r);
        }
        recorded
    }

    /// The current epoch's longest chain: every issued result's (`retired`, their running
    /// maximum) and the reductions' ones (`top`).
    #[inline]
    fn path(&self) -> u64 {
        self.top.max(self.retired)
    }

    /// Counts `n` operations into the current stretch; a full stretch ([`WINDOW`] operations)
    /// adds its nominal issue bound to [`Counters::window_issue`].
    #[inline(always)]
    fn tick(&mut self, n: usize) {
        self.stretch_ops += n;
        if self.stretch_ops >= WINDOW {
            self.close_stretch();
        }
    }

    /// Ends the current stretch: its operations' nominal issue bound joins the task's
    /// [`Counters::window_issue`].
    #[cold]
    fn close_stretch(&mut self) {
        // The stretch's own operations: the counters' growth since it began.
        let d = self.c.since(&self.stretch_start);
        self.c.window_issue += crate::record::nominal_issue(&d);
        self.stretch_start = self.c;
        self.stretch_ops = 0;
    }

    /// Appends `line` to the task's stream.
    #[inline(always)]
    fn push_line(&mut self, line: u64, write: bool) {
        let line = self.stack.rename(line);
        self.enc.push(line, write);
    }
}

impl Default for Recorder {
    fn default() -> Self {
        Self::new()
    }
}

impl Recorder {
    /// A recorder that records counters and the cache-line stream.
    pub fn new() -> Self {
        Self::with_lines(true)
    }
    /// `record_lines = false` keeps only the counters (faster, smaller).
    pub fn with_lines(record_lines: bool) -> Self {
        Recorder {
            #[cfg(debug_assertions)]
            busy: core::cell::Cell::new(false),
            st: UnsafeCell::new(State {
                kind: NO_TASK,
                c: Counters::default(),
                enc: LineEncoder::default(),
                record_lines,
                done: Vec::new(),
                epoch: next_epoch(),
                scalars: Box::new([(0, 0); SCALAR_SLOTS]),
                predictor: Default::default(),
                top: 0,
                window: [0; WINDOW],
                retired: 0,
                issued: 0,
                stack: StackLines::default(),
                stretch_start: Counters::default(),
                stretch_ops: 0,
            }),
        }
    }

    /// Marks the host stack: lines in the [`STACK_WINDOW`] bytes below `addr` are the kernel's
    /// own stack frames and are renamed ([`StackLines`]). `addr` must be an address in a frame that
    /// encloses every frame of the kernel and holds no data the kernel accesses with counted
    /// operations ([`crate::run_counting`] marks its own frame).
    pub fn mark_stack(&self, addr: usize) {
        self.with(|st| st.stack.reset(line_of(addr)));
    }

    /// Start a task (files the current one first if it recorded anything).
    pub fn begin_task(&self, kind: u32) {
        self.with(|st| {
            st.file_task();
            // The task's own epoch: what was made before it is ready when it begins.
            st.start_epoch();
            st.kind = kind;
        })
    }

    /// End the current task and return its record (not filed).
    pub fn finish_task(&self) -> TaskRecord {
        self.with(take)
    }

    /// End the current task and file its record.
    pub fn end_task(&self) {
        self.with(|st| {
            let r = take(st);
            st.done.push(r);
        })
    }

    /// Counters of the task in progress.
    pub fn current(&self) -> Counters {
        self.with(|st| Counters {
            critical_path: st.path(),
            ..st.c
        })
    }

    /// Take the filed records, plus the one in progress if it recorded
    /// anything (as a record of kind [`NO_TASK`] or its begun kind). The recorder is then as a
    /// new one would be for the next task: a fresh epoch, no kind, an untrained predictor; it can
    /// be reused (its tables are not made again).
    pub fn take_tasks(&self) -> Vec<TaskRecord> {
        self.with(|st| {
            if !st.file_task() {
                // A begun task that recorded nothing (no counters, so no stretch either): its
                // kind and epoch end here too.
                st.kind = NO_TASK;
                st.start_epoch();
            }
            core::mem::take(&mut st.done)
        })
    }

    /// Runs `f` on the state. Every access to the state goes through here, and no `f` reaches the
    /// recorder again (they are this module's closures over the state alone), so the exclusive
    /// borrow is never aliased; debug builds check it.
    #[inline(always)]
    fn with<R>(&self, f: impl FnOnce(&mut State) -> R) -> R {
        #[cfg(debug_assertions)]
        {
            assert!(
                !self.busy.replace(true),
                "sism-simd: nested access to a recorder's state"
            );
            // SAFETY: as below, and the flag just checked that no other access is in progress.
            let r = f(unsafe { &mut *self.st.get() });
            self.busy.set(false);
            r
        }
        // SAFETY: `Recorder` is not `Sync` (`UnsafeCell`), so only this thread reaches the state,
        // and only through `with`, whose closures never call back into the recorder: this is the
        // only reference to the state while `f` runs.
        #[cfg(not(debug_assertions))]
        f(unsafe { &mut *self.st.get() })
    }
}

fn take(st: &mut State) -> TaskRecord {
    // The task's last, partial stretch of operations.
    if st.stretch_ops > 0 {
        st.close_stretch();
    }
    st.stretch_start = Counters::default();
    // The task's longest chain; the next task's chains start above every value made so far.
    st.c.critical_path = st.path();
    st.start_epoch();
    let r = TaskRecord {
        kind: st.kind,
        counters: core::mem::take(&mut st.c),
        lines: core::mem::take(&mut st.enc).finish(),
    };
    st.kind = NO_TASK;
    r
}

/// Instruction class of one issued operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    Valu,
    Fma,
    Trans,
    Load,
    Store,
    Gather,
    Scatter,
    CompressExpand,
    Atomic,
}

/// Nominal latencies (cycles from an operation to the first one that can use its result) of a
/// generic out-of-order AVX-512 core (Agner Fog's tables for Zen 4 and Ice Lake, rounded), in which
/// a record's [`Counters::critical_path`] is measured. A machine converts them to its own cycles
/// with one factor (`latency_scale` of the machine model), fitted on a one-chain microbenchmark.
pub mod latency {
    /// Bitwise logic, integer add/sub/shift/min/max, blends and selects.
    pub const SIMPLE: u64 = 1;
    /// Float min/max/abs/negate.
    pub const FLOAT_MINMAX: u64 = 2;
    /// Compares and lane permutes.
    pub const COMPARE_PERMUTE: u64 = 3;
    /// Lane extraction to a scalar register.
    pub const EXTRACT: u64 = 3;
    /// Float add, subtract, multiply, fused multiply-add, rounding and conversions.
    pub const ARITH: u64 = 4;
    /// Register compress and expand.
    pub const COMPRESS: u64 = 4;
    /// Fast reciprocal (square root) approximations with their Newton step.
    pub const RCP_FAST: u64 = 9;
    /// 32-bit integer multiply.
    pub const MUL_I: u64 = 10;
    /// Conflict detection.
    pub const CONFLICT: u64 = 12;
    /// Reductions (a tree of four shuffle-and-combine steps).
    pub const REDUCE: u64 = 12;
    /// Correctly rounded divide and reciprocal.
    pub const DIV: u64 = 14;
    /// Correctly rounded square root and reciprocal square root (sqrt then divide).
    pub const SQRT: u64 = 16;
    /// A vector load that hits L1 (misses are the cache model's).
    pub const LOAD: u64 = 5;
    /// Memory-form expand.
    pub const EXPAND_LOAD: u64 = 8;
    /// Gathers and vector fetch-adds (L1 hits).
    pub const GATHER: u64 = 20;
}

/// A vector under the counting context: the wrapped backend's value and the depth of the
/// dependency chain that produced it, in nominal cycles ([`latency`]). A result is as deep as its
/// deepest input plus its own latency; the recorder keeps, per task, the deepest result: the
/// task's critical path. Masks carry no depth (a chain through a mask restarts at the task's
/// base); scalars carry theirs in the recorder's table (see [`crate::ChainKey`]), so a chain
/// through `extract_f`, `to_array_f`, a float reduction or `splat_f` continues.
#[derive(Clone, Copy, Debug)]
pub struct Tracked<T> {
    value: T,
    depth: u64,
}

/// An argument or result of a forwarded method: a [`Tracked`] vector, or a plain value.
trait Operand: Copy {
    type Raw;
    fn raw(self) -> Self::Raw;
    fn depth(&self) -> u64;
    fn wrap(raw: Self::Raw, depth: u64) -> Self;
}

impl<T: Copy> Operand for Tracked<T> {
    type Raw = T;
    #[inline(always)]
    fn raw(self) -> T {
        self.value
    }
    #[inline(always)]
    fn depth(&self) -> u64 {
        self.depth
    }
    #[inline(always)]
    fn wrap(value: T, depth: u64) -> Self {
        Tracked { value, depth }
    }
}

macro_rules! plain_operand {
    ($($t:ty),*) => { $(
        impl Operand for $t {
            type Raw = $t;
            #[inline(always)]
            fn raw(self) -> $t {
                self
            }
            #[inline(always)]
            fn depth(&self) -> u64 {
                0
            }
            #[inline(always)]
            fn wrap(raw: $t, _: u64) -> $t {
                raw
            }
        }
    )* };
}
plain_operand!(
    Mask16,
    f32,
    i32,
    u32,
    usize,
    bool,
    Option<u32>,
    [f32; 16],
    [i32; 16]
);

#[inline(always)]
fn line_of(addr: usize) -> u64 {
    (addr as u64) >> 6
}

/// Distinct values among up to 16 line numbers (sorts them).
fn distinct(lines: &mut [u64]) -> u64 {
    lines.sort_unstable();
    let mut n = 0;
    for i in 0..lines.len() {
        if i == 0 || lines[i] != lines[i - 1] {
            n += 1;
        }
    }
    n
}

/// Counting execution context wrapping backend `B`.
///
/// Every method forwards to `B` (so results are bit-identical to running on
/// `B`) and records the operation in the [`Recorder`]: its class, lanes,
/// and for memory operations the 64-byte lines touched. Derived methods
/// (`acos_f`, `clamp_f`, ...) are not forwarded but run as their
/// constituent instructions, which is what they are on the modelled
/// machine.
#[derive(Clone, Copy, Debug)]
pub struct Counting<'r, B: Simd> {
    inner: B,
    rec: &'r Recorder,
}

impl<'r, B: Simd> Counting<'r, B> {
    /// Wrap `inner`, recording into `rec`.
    pub fn new(inner: B, rec: &'r Recorder) -> Self {
        Counting { inner, rec }
    }
    /// The wrapped backend.
    pub fn inner(self) -> B {
        self.inner
    }
    /// The recorder.
    pub fn recorder(self) -> &'r Recorder {
        self.rec
    }
    /// End the current task and return its record directly.
    pub fn finish_task(self) -> TaskRecord {
        self.rec.finish_task()
    }

    /// Counts one operation of `class` on `lanes` lanes whose deepest input is `inputs` deep and
    /// whose result is `latency` later; returns the result's depth.
    #[inline(always)]
    fn op(self, class: Class, lanes: u32, masked: bool, inputs: u64, latency: u64) -> u64 {
        self.rec.with(|st| {
            let c = &mut st.c;
            match class {
                Class::Valu => c.valu += 1,
                Class::Fma => c.fma += 1,
                Class::Trans => c.transcendental += 1,
                Class::Load => c.load += 1,
                Class::Store => c.store += 1,
                Class::Gather => c.gather += 1,
                Class::Scatter => c.scatter += 1,
                Class::CompressExpand => c.compress_expand += 1,
                Class::Atomic => c.atomic += 1,
            }
            c.vector_ops += 1;
            c.active_lanes += lanes as u64;
            c.masked_ops += masked as u64;
            st.tick(1);
            let depth = st.issue(st.local(inputs), latency);
            st.tagged(depth)
        })
    }
    #[inline(always)]
    fn mask_op(self) {
        self.rec.with(|st| {
            st.c.mask += 1;
            st.tick(1);
        })
    }
    /// One instruction moving between lanes and a mask ([`Counters::mask_moves`]), besides its
    /// own class's count.
    #[inline(always)]
    fn mask_move(self) {
        self.rec.with(|st| st.c.mask_moves += 1)
    }
    #[inline(always)]
    fn reduce(self, input: u64) {
        self.rec.with(|st| {
            st.c.valu += 4;
            st.c.vector_ops += 4;
            st.c.active_lanes += 64;
            st.tick(4);
            st.top = st.top.max(st.local(input) + latency::REDUCE);
        })
    }

    /// Contiguous access of elements `[first, last]` (inclusive, in units
    /// of 4 bytes) starting at `base`.
    fn contiguous(self, base: usize, first: usize, last: usize, write: bool) {
        let l0 = line_of(base + 4 * first);
        let l1 = line_of(base + 4 * last + 3);
        self.rec.with(|st| {
            let n = l1 - l0 + 1;
            if write {
                st.c.store_lines += n;
            } else {
                st.c.load_lines += n;
            }
            if st.record_lines {
                for l in l0..=l1 {
                    st.push_line(l, write);
                }
            }
        })
    }
    fn masked_contiguous(self, base: usize, m: Mask16, write: bool) {
        // A masked load or store spreads its mask into lanes (a mask move) as a select does.
        self.mask_move();
        if let (Some(f), Some(l)) = (m.first(), m.last()) {
            self.contiguous(base, f as usize, l as usize, write);
        }
    }
    /// Indexed access: lines of the active lanes in lane order; returns the
    /// number of distinct lines.
    fn indexed(self, base: usize, m: Mask16, idx: &[i32; 16], write: bool) -> u64 {
        let mut lines = [0u64; 16];
        let mut n = 0;
        for lane in m.iter() {
            lines[n] = line_of(base.wrapping_add(4 * idx[lane] as usize));
            n += 1;
        }
        let lines = &mut lines[..n];
        // Lanes usually hold increasing indices (compress-stored), so the lines come in runs: push
        // one line per run (the encoder drops a repeat of the line just pushed anyway) and, when
        // the lines never decrease, count the distinct ones as the runs without sorting.
        let mut runs = 0;
        let mut sorted = true;
        self.rec.with(|st| {
            for i in 0..lines.len() {
                if i > 0 && lines[i] == lines[i - 1] {
                    continue;
                }
                runs += 1;
                sorted &= i == 0 || lines[i] > lines[i - 1];
                if st.record_lines {
                    st.push_line(lines[i], write);
                }
            }
        });
        if sorted {
            runs
        } else {
            distinct(lines)
        }
    }
}

// The forwarding macros unwrap every argument ([`Operand::raw`]), forward, and wrap the result
// with its depth: the deepest argument's plus the operation's latency.
macro_rules! fwd {
    ($class:ident, $lat:expr; $( fn $name:ident(self $(, $arg:ident : $ty:ty)*) -> $ret:ty; )*) => { $(
        #[inline(always)]
        fn $name(self $(, $arg: $ty)*) -> $ret {
            let d = self.op(Class::$class, 16, false, 0 $(.max(Operand::depth(&$arg)))*, $lat);
            <$ret as Operand>::wrap(self.inner.$name($(Operand::raw($arg)),*), d)
        }
    )* };
}
/// [`fwd`] for an operation that moves between lanes and a mask (compares, selects).
macro_rules! fwd_mask_move {
    ($class:ident, $lat:expr; $( fn $name:ident(self $(, $arg:ident : $ty:ty)*) -> $ret:ty; )*) => { $(
        #[inline(always)]
        fn $name(self $(, $arg: $ty)*) -> $ret {
            self.mask_move();
            let d = self.op(Class::$class, 16, false, 0 $(.max(Operand::depth(&$arg)))*, $lat);
            <$ret as Operand>::wrap(self.inner.$name($(Operand::raw($arg)),*), d)
        }
    )* };
}
macro_rules! fwd_masked {
    ($class:ident, $lat:expr; $( fn $name:ident(self, $src:ident : $sty:ty, $m:ident : Mask16 $(, $arg:ident : $ty:ty)*) -> $ret:ty; )*) => { $(
        #[inline(always)]
        fn $name(self, $src: $sty, $m: Mask16 $(, $arg: $ty)*) -> $ret {
            self.mask_move();
            let d = self.op(Class::$class, $m.count(), true, $src.depth $(.max(Operand::depth(&$arg)))*, $lat);
            <$ret as Operand>::wrap(self.inner.$name($src.value, $m $(, Operand::raw($arg))*), d)
        }
    )* };
}
macro_rules! fwd_mask {
    ($( fn $name:ident(self $(, $arg:ident : $ty:ty)*) -> $ret:ty; )*) => { $(
        #[inline(always)]
        fn $name(self $(, $arg: $ty)*) -> $ret {
            self.mask_op();
            self.inner.$name($($arg),*)
        }
    )* };
}
/// Free operations (broadcasts, bit casts): no count, the depth passes through.
macro_rules! fwd_free {
    ($( fn $name:ident(self $(, $arg:ident : $ty:ty)*) -> $ret:ty; )*) => { $(
        #[inline(always)]
        fn $name(self $(, $arg: $ty)*) -> $ret {
            let d = 0 $(.max(Operand::depth(&$arg)))*;
            <$ret as Operand>::wrap(self.inner.$name($(Operand::raw($arg)),*), d)
        }
    )* };
}
macro_rules! fwd_reduce {
    ($( fn $name:ident(self, v: $ty:ty) -> $ret:ty; )*) => { $(
        #[inline(always)]
        fn $name(self, v: $ty) -> $ret {
            self.reduce(v.depth);
            let r = self.inner.$name(v.value);
            // The scalar result continues the vector's chain.
            self.rec.with(|st| {
                let d = st.local(v.depth) + latency::REDUCE;
                st.set_scalar(crate::ChainKey::chain_key(r), d);
            });
            r
        }
    )* };
}

impl<B: Simd> Simd for Counting<'_, B> {
    type F32 = Tracked<B::F32>;
    type I32 = Tracked<B::I32>;

    #[inline(always)]
    fn kind(self) -> BackendKind {
        self.inner.kind()
    }

    /// A broadcast scalar continues the scalar's chain (a counted scalar result's depth).
    #[inline(always)]
    fn splat_f(self, x: f32) -> Self::F32 {
        let d = self.rec.with(|st| {
            let local = st.scalar_depth(crate::ChainKey::chain_key(x));
            if local == 0 {
                0
            } else {
                st.tagged(local)
            }
        });
        Tracked {
            value: self.inner.splat_f(x),
            depth: d,
        }
    }
    /// Each lane, as a scalar, continues the vector's chain.
    #[inline(always)]
    fn to_array_f(self, v: Self::F32) -> [f32; 16] {
        self.op(Class::Store, 16, false, v.depth, 0);
        let a = self.inner.to_array_f(v.value);
        self.rec.with(|st| {
            let d = st.local(v.depth);
            if d > 0 {
                for x in a {
                    st.set_scalar(crate::ChainKey::chain_key(x), d);
                }
            }
        });
        a
    }
    /// The lane, as a scalar, continues the vector's chain.
    #[inline(always)]
    fn extract_f(self, v: Self::F32, lane: usize) -> f32 {
        let d = self.op(Class::Valu, 16, false, v.depth, latency::EXTRACT);
        let x = self.inner.extract_f(v.value, lane);
        self.rec.with(|st| {
            let local = st.local(d);
            st.set_scalar(crate::ChainKey::chain_key(x), local);
        });
        x
    }
    #[inline(always)]
    fn scalar_chain(self, latency: u64, a: Option<u64>, b: Option<u64>, out: Option<u64>) {
        // A scalar operation takes its place in the window as a vector one does: scalar code's
        // independent chains (one triangle's, the next one's) overlap only as far as it reaches.
        self.rec.with(|st| {
            let d = st.issue(st.scalar_depth(a).max(st.scalar_depth(b)), latency);
            st.set_scalar(out, d);
        })
    }

    fwd_free! {
        fn splat_i(self, x: i32) -> Self::I32;
        fn index_i(self) -> Self::I32;
        fn cast_f_i(self, a: Self::F32) -> Self::I32;
        fn cast_i_f(self, a: Self::I32) -> Self::F32;
    }

    fwd! { Load, latency::LOAD;
        fn from_array_f(self, a: [f32; 16]) -> Self::F32;
        fn from_array_i(self, a: [i32; 16]) -> Self::I32;
    }
    fwd! { Store, 0;
        fn to_array_i(self, v: Self::I32) -> [i32; 16];
    }

    fwd! { Valu, latency::EXTRACT;
        fn extract_i(self, v: Self::I32, lane: usize) -> i32;
    }
    fwd! { Valu, latency::ARITH;
        fn add_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
        fn sub_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
        fn mul_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
        fn floor_f(self, a: Self::F32) -> Self::F32;
        fn ceil_f(self, a: Self::F32) -> Self::F32;
        fn trunc_f(self, a: Self::F32) -> Self::F32;
        fn round_f(self, a: Self::F32) -> Self::F32;
        fn cvt_i_f(self, a: Self::I32) -> Self::F32;
        fn cvt_u_f(self, a: Self::I32) -> Self::F32;
        fn cvtt_f_i(self, a: Self::F32) -> Self::I32;
        fn cvtr_f_i(self, a: Self::F32) -> Self::I32;
    }
    fwd! { Valu, latency::FLOAT_MINMAX;
        fn min_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
        fn max_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
        fn abs_f(self, a: Self::F32) -> Self::F32;
        fn neg_f(self, a: Self::F32) -> Self::F32;
    }
    fwd_mask_move! { Valu, latency::COMPARE_PERMUTE;
        fn cmp_eq_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_ne_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_lt_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_le_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_gt_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_ge_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_unord_f(self, a: Self::F32, b: Self::F32) -> Mask16;
        fn cmp_eq_i(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_ne_i(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_lt_i(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_le_i(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_gt_i(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_ge_i(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_lt_u(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_le_u(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_gt_u(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn cmp_ge_u(self, a: Self::I32, b: Self::I32) -> Mask16;
        fn test_i(self, a: Self::I32, b: Self::I32) -> Mask16;
    }
    fwd! { Valu, latency::COMPARE_PERMUTE;
        fn permute_f(self, v: Self::F32, idx: Self::I32) -> Self::F32;
        fn permute_i(self, v: Self::I32, idx: Self::I32) -> Self::I32;
    }
    fwd_mask_move! { Valu, latency::SIMPLE;
        fn select_f(self, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
        fn select_i(self, m: Mask16, a: Self::I32, b: Self::I32) -> Self::I32;
    }
    fwd! { Valu, latency::SIMPLE;
        fn add_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn sub_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn and_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn or_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn xor_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn andn_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn shl_i(self, a: Self::I32, n: u32) -> Self::I32;
        fn shr_u(self, a: Self::I32, n: u32) -> Self::I32;
        fn shr_i(self, a: Self::I32, n: u32) -> Self::I32;
        fn shlv_i(self, a: Self::I32, n: Self::I32) -> Self::I32;
        fn shrv_u(self, a: Self::I32, n: Self::I32) -> Self::I32;
        fn shrv_i(self, a: Self::I32, n: Self::I32) -> Self::I32;
        fn min_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn max_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn min_u(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn max_u(self, a: Self::I32, b: Self::I32) -> Self::I32;
        fn abs_i(self, a: Self::I32) -> Self::I32;
    }
    fwd! { Valu, latency::MUL_I;
        fn mul_i(self, a: Self::I32, b: Self::I32) -> Self::I32;
    }
    fwd! { Valu, latency::CONFLICT;
        fn conflict_i(self, v: Self::I32) -> Self::I32;
    }

    fwd! { Fma, latency::ARITH;
        fn fmadd(self, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
        fn fmsub(self, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
        fn fnmadd(self, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
    }

    fwd! { Trans, latency::DIV;
        fn div_f(self, a: Self::F32, b: Self::F32) -> Self::F32;
        fn rcp_f(self, a: Self::F32) -> Self::F32;
    }
    fwd! { Trans, latency::SQRT;
        fn sqrt_f(self, a: Self::F32) -> Self::F32;
        fn rsqrt_f(self, a: Self::F32) -> Self::F32;
    }
    fwd! { Trans, latency::RCP_FAST;
        fn rcp_fast_f(self, a: Self::F32) -> Self::F32;
        fn rsqrt_fast_f(self, a: Self::F32) -> Self::F32;
    }

    fwd_masked! { Valu, latency::ARITH;
        fn mask_add_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
        fn mask_sub_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
        fn mask_mul_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    }
    fwd_masked! { Valu, latency::FLOAT_MINMAX;
        fn mask_min_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
        fn mask_max_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    }
    fwd_masked! { Valu, latency::SIMPLE;
        fn mask_add_i(self, src: Self::I32, m: Mask16, a: Self::I32, b: Self::I32) -> Self::I32;
        fn mask_sub_i(self, src: Self::I32, m: Mask16, a: Self::I32, b: Self::I32) -> Self::I32;
    }
    fwd_masked! { Fma, latency::ARITH;
        fn mask_fmadd(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32, c: Self::F32) -> Self::F32;
    }
    fwd_masked! { Trans, latency::DIV;
        fn mask_div_f(self, src: Self::F32, m: Mask16, a: Self::F32, b: Self::F32) -> Self::F32;
    }
    fwd_masked! { Trans, latency::SQRT;
        fn mask_sqrt_f(self, src: Self::F32, m: Mask16, a: Self::F32) -> Self::F32;
    }

    fwd_reduce! {
        fn reduce_add_f(self, v: Self::F32) -> f32;
        fn reduce_min_f(self, v: Self::F32) -> f32;
        fn reduce_max_f(self, v: Self::F32) -> f32;
        fn reduce_add_i(self, v: Self::I32) -> i32;
        fn reduce_min_i(self, v: Self::I32) -> i32;
        fn reduce_max_i(self, v: Self::I32) -> i32;
        fn reduce_min_u(self, v: Self::I32) -> u32;
        fn reduce_max_u(self, v: Self::I32) -> u32;
        fn reduce_or_i(self, v: Self::I32) -> i32;
        fn reduce_and_i(self, v: Self::I32) -> i32;
    }

    #[inline(always)]
    fn compress_f(self, m: Mask16, v: Self::F32) -> Self::F32 {
        let d = self.op(Class::CompressExpand, m.count(), true, v.depth, latency::COMPRESS);
        Tracked::wrap(self.inner.compress_f(m, v.value), d)
    }
    #[inline(always)]
    fn expand_f(self, m: Mask16, v: Self::F32) -> Self::F32 {
        let d = self.op(Class::CompressExpand, m.count(), true, v.depth, latency::COMPRESS);
        Tracked::wrap(self.inner.expand_f(m, v.value), d)
    }
    #[inline(always)]
    fn compress_i(self, m: Mask16, v: Self::I32) -> Self::I32 {
        let d = self.op(Class::CompressExpand, m.count(), true, v.depth, latency::COMPRESS);
        Tracked::wrap(self.inner.compress_i(m, v.value), d)
    }
    #[inline(always)]
    fn expand_i(self, m: Mask16, v: Self::I32) -> Self::I32 {
        let d = self.op(Class::CompressExpand, m.count(), true, v.depth, latency::COMPRESS);
        Tracked::wrap(self.inner.expand_i(m, v.value), d)
    }

    fwd_mask! {
        fn mask_and(self, a: Mask16, b: Mask16) -> Mask16;
        fn mask_or(self, a: Mask16, b: Mask16) -> Mask16;
        fn mask_xor(self, a: Mask16, b: Mask16) -> Mask16;
        fn mask_andn(self, a: Mask16, b: Mask16) -> Mask16;
        fn mask_not(self, a: Mask16) -> Mask16;
        fn mask_popcnt(self, a: Mask16) -> u32;
        fn mask_any(self, a: Mask16) -> bool;
        fn mask_all(self, a: Mask16) -> bool;
        fn mask_first(self, a: Mask16) -> Option<u32>;
        fn mask_first_n(self, n: usize) -> Mask16;
    }

    // ---------------- memory ----------------

    #[inline(always)]
    fn load_f(self, mem: &[f32]) -> Self::F32 {
        let r = self.inner.load_f(mem);
        let d = self.op(Class::Load, 16, false, 0, latency::LOAD);
        self.contiguous(mem.as_ptr() as usize, 0, 15, false);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn load_i(self, mem: &[i32]) -> Self::I32 {
        let r = self.inner.load_i(mem);
        let d = self.op(Class::Load, 16, false, 0, latency::LOAD);
        self.contiguous(mem.as_ptr() as usize, 0, 15, false);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn load_aligned_f(self, mem: &[f32]) -> Self::F32 {
        let r = self.inner.load_aligned_f(mem);
        let d = self.op(Class::Load, 16, false, 0, latency::LOAD);
        self.contiguous(mem.as_ptr() as usize, 0, 15, false);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn load_aligned_i(self, mem: &[i32]) -> Self::I32 {
        let r = self.inner.load_aligned_i(mem);
        let d = self.op(Class::Load, 16, false, 0, latency::LOAD);
        self.contiguous(mem.as_ptr() as usize, 0, 15, false);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn store_f(self, mem: &mut [f32], v: Self::F32) {
        self.inner.store_f(mem, v.value);
        self.op(Class::Store, 16, false, 0, 0);
        self.contiguous(mem.as_ptr() as usize, 0, 15, true);
    }
    #[inline(always)]
    fn store_i(self, mem: &mut [i32], v: Self::I32) {
        self.inner.store_i(mem, v.value);
        self.op(Class::Store, 16, false, 0, 0);
        self.contiguous(mem.as_ptr() as usize, 0, 15, true);
    }
    #[inline(always)]
    fn store_aligned_f(self, mem: &mut [f32], v: Self::F32) {
        self.inner.store_aligned_f(mem, v.value);
        self.op(Class::Store, 16, false, 0, 0);
        self.contiguous(mem.as_ptr() as usize, 0, 15, true);
    }
    #[inline(always)]
    fn store_aligned_i(self, mem: &mut [i32], v: Self::I32) {
        self.inner.store_aligned_i(mem, v.value);
        self.op(Class::Store, 16, false, 0, 0);
        self.contiguous(mem.as_ptr() as usize, 0, 15, true);
    }
    #[inline(always)]
    fn mask_load_f(self, src: Self::F32, m: Mask16, mem: &[f32]) -> Self::F32 {
        let r = self.inner.mask_load_f(src.value, m, mem);
        let d = self.op(Class::Load, m.count(), true, src.depth, latency::LOAD);
        self.masked_contiguous(mem.as_ptr() as usize, m, false);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn mask_load_i(self, src: Self::I32, m: Mask16, mem: &[i32]) -> Self::I32 {
        let r = self.inner.mask_load_i(src.value, m, mem);
        let d = self.op(Class::Load, m.count(), true, src.depth, latency::LOAD);
        self.masked_contiguous(mem.as_ptr() as usize, m, false);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn mask_store_f(self, mem: &mut [f32], m: Mask16, v: Self::F32) {
        self.inner.mask_store_f(mem, m, v.value);
        self.op(Class::Store, m.count(), true, 0, 0);
        self.masked_contiguous(mem.as_ptr() as usize, m, true);
    }
    #[inline(always)]
    fn mask_store_i(self, mem: &mut [i32], m: Mask16, v: Self::I32) {
        self.inner.mask_store_i(mem, m, v.value);
        self.op(Class::Store, m.count(), true, 0, 0);
        self.masked_contiguous(mem.as_ptr() as usize, m, true);
    }
    #[inline(always)]
    fn gather_f(self, mem: &[f32], idx: Self::I32) -> Self::F32 {
        let r = self.inner.gather_f(mem, idx.value);
        let d = self.after_gather(mem.as_ptr() as usize, Mask16::ALL, idx, false, 0);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn gather_i(self, mem: &[i32], idx: Self::I32) -> Self::I32 {
        let r = self.inner.gather_i(mem, idx.value);
        let d = self.after_gather(mem.as_ptr() as usize, Mask16::ALL, idx, false, 0);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn mask_gather_f(self, src: Self::F32, m: Mask16, mem: &[f32], idx: Self::I32) -> Self::F32 {
        let r = self.inner.mask_gather_f(src.value, m, mem, idx.value);
        let d = self.after_gather(mem.as_ptr() as usize, m, idx, true, src.depth);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn mask_gather_i(self, src: Self::I32, m: Mask16, mem: &[i32], idx: Self::I32) -> Self::I32 {
        let r = self.inner.mask_gather_i(src.value, m, mem, idx.value);
        let d = self.after_gather(mem.as_ptr() as usize, m, idx, true, src.depth);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn mask_scatter_f(self, mem: &mut [f32], m: Mask16, idx: Self::I32, v: Self::F32) {
        self.inner.mask_scatter_f(mem, m, idx.value, v.value);
        self.after_scatter(mem.as_ptr() as usize, m, idx.value);
    }
    #[inline(always)]
    fn mask_scatter_i(self, mem: &mut [i32], m: Mask16, idx: Self::I32, v: Self::I32) {
        self.inner.mask_scatter_i(mem, m, idx.value, v.value);
        self.after_scatter(mem.as_ptr() as usize, m, idx.value);
    }
    #[inline(always)]
    fn compress_store_f(self, mem: &mut [f32], m: Mask16, v: Self::F32) -> usize {
        let n = self.inner.compress_store_f(mem, m, v.value);
        self.op(Class::CompressExpand, m.count(), true, 0, 0);
        if n > 0 {
            self.contiguous(mem.as_ptr() as usize, 0, n - 1, true);
        }
        n
    }
    #[inline(always)]
    fn compress_store_i(self, mem: &mut [i32], m: Mask16, v: Self::I32) -> usize {
        let n = self.inner.compress_store_i(mem, m, v.value);
        self.op(Class::CompressExpand, m.count(), true, 0, 0);
        if n > 0 {
            self.contiguous(mem.as_ptr() as usize, 0, n - 1, true);
        }
        n
    }
    #[inline(always)]
    fn expand_load_f(self, src: Self::F32, m: Mask16, mem: &[f32]) -> Self::F32 {
        let r = self.inner.expand_load_f(src.value, m, mem);
        let d = self.op(
            Class::CompressExpand,
            m.count(),
            true,
            src.depth,
            latency::EXPAND_LOAD,
        );
        let n = m.count() as usize;
        if n > 0 {
            self.contiguous(mem.as_ptr() as usize, 0, n - 1, false);
        }
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn expand_load_i(self, src: Self::I32, m: Mask16, mem: &[i32]) -> Self::I32 {
        let r = self.inner.expand_load_i(src.value, m, mem);
        let d = self.op(
            Class::CompressExpand,
            m.count(),
            true,
            src.depth,
            latency::EXPAND_LOAD,
        );
        let n = m.count() as usize;
        if n > 0 {
            self.contiguous(mem.as_ptr() as usize, 0, n - 1, false);
        }
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn fetch_add_i(self, mem: &mut [i32], m: Mask16, idx: Self::I32, val: Self::I32) -> Self::I32 {
        let r = self.inner.fetch_add_i(mem, m, idx.value, val.value);
        let d = self.after_atomic(mem.as_ptr() as usize, m, idx, val.depth);
        Tracked::wrap(r, d)
    }
    #[inline(always)]
    fn atomic_fetch_add_i(self, mem: &[AtomicI32], m: Mask16, idx: Self::I32, val: Self::I32) -> Self::I32 {
        let r = self.inner.atomic_fetch_add_i(mem, m, idx.value, val.value);
        let d = self.after_atomic(mem.as_ptr() as usize, m, idx, val.depth);
        Tracked::wrap(r, d)
    }

    // ---------------- hooks ----------------

    #[inline(always)]
    fn begin_task(self, kind: u32) {
        self.rec.begin_task(kind)
    }
    #[inline(always)]
    fn end_task(self) {
        self.rec.end_task()
    }
    #[inline(always)]
    fn scalar_ops(self, n: u64) {
        self.rec.with(|st| {
            st.c.scalar += n;
            st.tick(n.min(WINDOW as u64) as usize);
        })
    }
    #[inline(always)]
    fn scalar_op(self, class: crate::ScalarClass) {
        self.rec.with(|st| {
            match class {
                crate::ScalarClass::Alu => st.c.scalar_alu += 1,
                crate::ScalarClass::Float => st.c.scalar_float += 1,
                crate::ScalarClass::Div => st.c.scalar_div += 1,
                crate::ScalarClass::Branch => st.c.scalar_branch += 1,
                crate::ScalarClass::Mem => st.c.scalar_mem += 1,
                crate::ScalarClass::Store => {
                    st.c.scalar_mem += 1;
                    st.c.scalar_stores += 1;
                }
            }
            st.tick(1);
        })
    }
    #[inline(always)]
    fn branch_outcome(self, site: &'static core::panic::Location<'static>, taken: bool) {
        let key = crate::branch::site_key(site);
        self.rec.with(|st| {
            if st.predictor.observe(key, taken) {
                st.c.branch_mispredicts += 1;
            }
        })
    }
    #[inline(always)]
    fn scalar_touch(self, addr: usize, bytes: usize, write: bool) {
        if bytes == 0 {
            return;
        }
        let (l0, l1) = (line_of(addr), line_of(addr + bytes - 1));
        self.rec.with(|st| {
            if st.record_lines {
                for l in l0..=l1 {
                    st.push_line(l, write);
                }
            }
        })
    }
}

impl<B: Simd> Counting<'_, B> {
    /// Counts a gather whose other input (the merge source) is `src_depth` deep; returns the
    /// result's depth.
    #[inline(always)]
    fn after_gather(self, base: usize, m: Mask16, idx: Tracked<B::I32>, masked: bool, src_depth: u64) -> u64 {
        let d = self.op(
            Class::Gather,
            m.count(),
            masked,
            idx.depth.max(src_depth),
            latency::GATHER,
        );
        let idx = self.inner.to_array_i(idx.value);
        let lines = self.indexed(base, m, &idx, false);
        self.rec.with(|st| st.c.gather_lines += lines);
        d
    }
    #[inline(always)]
    fn after_scatter(self, base: usize, m: Mask16, idx: B::I32) {
        self.op(Class::Scatter, m.count(), true, 0, 0);
        let idx = self.inner.to_array_i(idx);
        let d = self.indexed(base, m, &idx, true);
        self.rec.with(|st| st.c.scatter_lines += d);
    }
    /// Counts a vector fetch-add whose added values are `val_depth` deep; returns the depth of the
    /// old values it returns.
    #[inline(always)]
    fn after_atomic(self, base: usize, m: Mask16, idx: Tracked<B::I32>, val_depth: u64) -> u64 {
        let depth = self.op(
            Class::Atomic,
            m.count(),
            true,
            idx.depth.max(val_depth),
            latency::GATHER,
        );
        let idx = self.inner.to_array_i(idx.value);
        let d = self.indexed(base, m, &idx, true);
        let mut conflicts = 0;
        for i in m.iter() {
            if m.iter().take_while(|&j| j < i).any(|j| idx[j] == idx[i]) {
                conflicts += 1;
            }
        }
        self.rec.with(|st| {
            st.c.atomic_lines += d;
            st.c.atomic_conflicts += conflicts;
        });
        depth
    }
}
