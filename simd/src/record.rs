//! Task records: counters that add up, and the compressed cache-line stream.

use core::ops::AddAssign;

macro_rules! counters {
    ($( $(#[$doc:meta])* $field:ident ),* $(,)?) => {
        /// Per-task counters recorded by [`crate::Counting`].
        ///
        /// Instruction classes (each op issued counts 1 in exactly one class,
        /// except horizontal reductions which count 4 `valu`):
        /// `valu`, `fma`, `transcendental`, `mask`, `scalar`, `load`, `store`,
        /// `gather`, `scatter`, `compress_expand`, `atomic`. Broadcasts of
        /// scalars (`splat_*`), `index_i`, bit casts and constant masks are
        /// free: Larrabee folds them into operands.
        ///
        /// The other fields describe lane utilisation and memory behaviour.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        pub struct Counters {
            $( $(#[$doc])* pub $field: u64, )*
        }

        impl AddAssign for Counters {
            fn add_assign(&mut self, o: Counters) {
                $( self.$field += o.$field; )*
            }
        }

        impl Counters {
            /// Field names, in serialisation order.
            pub const FIELDS: &'static [&'static str] = &[$( stringify!($field) ),*];

            /// What each counter grew by since `earlier`, a snapshot of the same task's counters
            /// (every field of `self` at least `earlier`'s).
            pub fn since(&self, earlier: &Counters) -> Counters {
                Counters { $( $field: self.$field - earlier.$field, )* }
            }

            /// Field values, in [`Counters::FIELDS`] order.
            pub fn values(&self) -> Vec<u64> {
                vec![$( self.$field ),*]
            }

            fn write(&self, out: &mut Vec<u8>) {
                $( put_varint(out, self.$field); )*
            }

            fn read(r: &mut Reader<'_>) -> Result<Counters, DecodeError> {
                Ok(Counters { $( $field: r.varint()?, )* })
            }
        }
    };
}

counters! {
    /// Vector ALU instructions (add, mul, compares, logic, shifts,
    /// conversions, selects, permutes, rounding; reductions count 4).
    valu,
    /// Fused multiply-add family (`fmadd`, `fmsub`, `fnmadd`, `mask_fmadd`).
    fma,
    /// Long-latency arithmetic: `div`, `sqrt`, `rcp*`, `rsqrt*`.
    transcendental,
    /// Mask-register instructions (`mask_and`, `mask_popcnt`, ...).
    mask,
    /// Scalar instructions declared by the kernel via `scalar_ops(n)` (estimates; being replaced
    /// by the counted classes below).
    scalar,
    /// Counted scalar integer ALU operations (`s_add`, `s_mul`, `s_min` on integers), float abs,
    /// rounding and conversions (`s_fn`), and declared ALU work.
    scalar_alu,
    /// Counted scalar float adds, subtracts, multiplies, min and max ([`crate::ScalarClass::Float`]).
    scalar_float,
    /// Counted scalar divides and square roots.
    scalar_div,
    /// Counted scalar compares and branches.
    scalar_branch,
    /// Counted scalar loads and stores.
    scalar_mem,
    /// Of `scalar_mem`, the stores ([`crate::ScalarClass::Store`]): each holds a store-buffer
    /// entry until its line is in the cache, so stores per written line bound how many written
    /// lines a core can wait for at once.
    scalar_stores,
    /// Contiguous vector loads (incl. masked and `from_array`).
    load,
    /// Contiguous vector stores (incl. masked and `to_array`).
    store,
    /// Gathers.
    gather,
    /// Scatters.
    scatter,
    /// Compress / expand (register or memory form).
    compress_expand,
    /// Vector fetch-adds (private `fetch_add_i` and `atomic_fetch_add_i`).
    atomic,
    /// Vector (16-lane) instructions of every class above except `mask`
    /// and `scalar`.
    vector_ops,
    /// Sum over vector instructions of the lanes they operate on (16 for
    /// unmasked ones, popcount of the mask for masked ones).
    active_lanes,
    /// Vector instructions that took a mask.
    masked_ops,
    /// Vector instructions that move between lanes and a mask: compares and `test_i` (lanes into
    /// a mask), selects, masked arithmetic and masked loads and stores (a mask into lanes). Each
    /// is also counted in its own class; this is what it costs beyond that. With mask registers
    /// (Larrabee, AVX-512) nothing much; on the portable backend 16 lane bits packed or spread.
    mask_moves,
    /// Cache lines touched by contiguous loads (1, or 2 when a 64-byte
    /// access straddles lines).
    load_lines,
    /// Cache lines touched by contiguous stores.
    store_lines,
    /// Sum over gathers of the distinct 64-byte lines each one touched
    /// (≤ 16 per gather).
    gather_lines,
    /// Sum over scatters of the distinct lines each one touched.
    scatter_lines,
    /// Sum over vector fetch-adds of the distinct lines each one touched.
    atomic_lines,
    /// Active fetch-add lanes whose address repeats an earlier active lane
    /// of the same instruction (what conflict detection had to combine).
    atomic_conflicts,
    /// The task's critical path: its longest chain of dependent vector operations, in nominal
    /// cycles ([`crate::latency`]), recorded as the task executes (each result is as
    /// deep as its deepest input plus its latency). Summed over tasks when records are merged.
    critical_path,
    /// Counted conditional branches (`s_branch`, `s_lt`, `s_le`) that the counting context's
    /// branch predictor model ([`crate::branch`]) mispredicted: an event, not an instruction.
    branch_mispredicts,
    /// The task's issue as an out-of-order window sees it: the sum, over the task's stretches of
    /// [`crate::WINDOW`] counted operations, of each stretch's nominal issue bound
    /// ([`nominal_issue`]), in eighths of a nominal cycle. A task whose classes of work interleave
    /// evenly gets its whole counters' bound; one that does its scalar work and its vector work in
    /// separate stretches (a triangle's setup, then its blocks) gets up to their sum, because a
    /// window cannot overlap work that lies further apart than it reaches. Summed when records are
    /// merged.
    window_issue,
}

impl Counters {
    /// Total instructions over all classes.
    pub fn instructions(&self) -> u64 {
        self.valu
            + self.fma
            + self.transcendental
            + self.mask
            + self.scalar
            + self.scalar_alu
            + self.scalar_float
            + self.scalar_div
            + self.scalar_branch
            + self.scalar_mem
            + self.load
            + self.store
            + self.gather
            + self.scatter
            + self.compress_expand
            + self.atomic
    }
    /// Average fraction of the 16 lanes active per vector instruction
    /// (1.0 when no vector instruction was issued).
    pub fn lane_utilisation(&self) -> f64 {
        if self.vector_ops == 0 {
            1.0
        } else {
            self.active_lanes as f64 / (16.0 * self.vector_ops as f64)
        }
    }
}

/// The nominal issue bound of `c`'s operations on an out-of-order core, in eighths of a cycle:
/// the largest of its port groups' busy times at nominal reciprocal throughputs (the vector unit's
/// two pipes, its compress, transcendental and gather sequences; two load/store ports; about three
/// scalar ALUs; the scalar divider), the constants of the host calibrations (`sism calibrate` on
/// Zen 4 and Emerald Rapids VMs fits 0.44 cycles a vector operation, 0.51 a load or store, 0.37 a
/// scalar one, 2.3 a scalar divide, 6 a compress, 9 a gather). Only ratios of these bounds are
/// used ([`Counters::window_issue`] against the bound of the task's whole counters), so the
/// constants classify stretches of work by the port group they keep busy; they are not a
/// machine's costs.
pub fn nominal_issue(c: &Counters) -> u64 {
    // In u128: counters of a loaded (untrusted) records file may be anything; the bound saturates.
    let w = |n: u64, k: u128| n as u128 * k;
    let vector = w(c.valu, 4)
        + w(c.fma, 4)
        + w(c.mask_moves, 2)
        + w(c.scalar_float, 2)
        + w(c.compress_expand, 48)
        + w(c.transcendental, 64)
        + w(c.gather, 72)
        + w(c.scatter, 72);
    let load_store = w(c.load, 4) + w(c.store, 4) + w(c.scalar_mem, 4);
    let scalar =
        w(c.scalar, 3) + w(c.mask, 3) + w(c.scalar_alu, 3) + w(c.scalar_float, 3) + w(c.scalar_branch, 3);
    let divider = w(c.scalar_div, 18);
    vector
        .max(load_store)
        .max(scalar)
        .max(divider)
        .min(u64::MAX as u128) as u64
}

/// Kind id of work recorded outside any `begin_task` / `end_task` pair.
pub const NO_TASK: u32 = u32::MAX;

/// What one task did: its kind, counters and cache-line stream.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TaskRecord {
    /// The `kind` given to `begin_task` ([`NO_TASK`] for untracked work).
    pub kind: u32,
    /// Instruction and memory counters.
    pub counters: Counters,
    /// Ordered cache lines touched.
    pub lines: LineStream,
}

impl AddAssign<&TaskRecord> for TaskRecord {
    /// Adds the counters and appends the other record's line stream; the
    /// kind is kept.
    fn add_assign(&mut self, o: &TaskRecord) {
        self.counters += o.counters;
        let mut enc = LineEncoder::from_stream(core::mem::take(&mut self.lines));
        for (line, w) in o.lines.iter() {
            enc.push(line, w);
        }
        self.lines = enc.finish();
    }
}

const MAGIC: u8 = 0x5A;
/// The task record format's version ([`TaskRecord::to_bytes`]'s second byte). 2: `critical_path`
/// and the counted scalar classes; 3: `branch_mispredicts`; 4: `scalar_float`; 5: `mask_moves`;
/// 6: `window_issue`.
pub const TASK_RECORD_VERSION: u8 = 6;
const VERSION: u8 = TASK_RECORD_VERSION;

impl TaskRecord {
    /// Compact binary form: magic, version, then varints (kind, every
    /// counter in [`Counters::FIELDS`] order, line count, last line,
    /// stream byte length) followed by the stream bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.bytes_bound());
        self.write_bytes(&mut out);
        out
    }

    /// At least the length of [`TaskRecord::to_bytes`] (a bound for reserving space).
    pub fn bytes_bound(&self) -> usize {
        // Magic, version, four varints of at most 10 bytes, the counters at most 10 each.
        2 + 4 * 10 + 10 * Counters::FIELDS.len() + self.lines.bytes.len()
    }

    /// Appends [`TaskRecord::to_bytes`] to `out` (without a copy of its own).
    pub fn write_bytes(&self, out: &mut Vec<u8>) {
        out.push(MAGIC);
        out.push(VERSION);
        put_varint(out, self.kind as u64);
        put_varint(out, Counters::FIELDS.len() as u64);
        self.counters.write(out);
        put_varint(out, self.lines.count);
        put_varint(out, self.lines.last);
        put_varint(out, self.lines.bytes.len() as u64);
        out.extend_from_slice(&self.lines.bytes);
    }

    /// Inverse of [`TaskRecord::to_bytes`]; returns the record and the
    /// number of bytes consumed (records can be concatenated).
    pub fn from_bytes(b: &[u8]) -> Result<(TaskRecord, usize), DecodeError> {
        let mut r = Reader { b, pos: 0 };
        if r.byte()? != MAGIC {
            return Err(DecodeError("bad magic"));
        }
        if r.byte()? != VERSION {
            return Err(DecodeError("unsupported version"));
        }
        let kind = u32::try_from(r.varint()?).map_err(|_| DecodeError("kind overflow"))?;
        if r.varint()? != Counters::FIELDS.len() as u64 {
            return Err(DecodeError("counter field count mismatch"));
        }
        let counters = Counters::read(&mut r)?;
        let count = r.varint()?;
        let last = r.varint()?;
        let n = r.varint()? as usize;
        if r.b.len() - r.pos < n {
            return Err(DecodeError("truncated line stream"));
        }
        let bytes = r.b[r.pos..r.pos + n].to_vec();
        r.pos += n;
        Ok((
            TaskRecord {
                kind,
                counters,
                lines: LineStream { bytes, count, last },
            },
            r.pos,
        ))
    }
}

/// Error from [`TaskRecord::from_bytes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeError(pub &'static str);

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "TaskRecord decode error: {}", self.0)
    }
}
impl std::error::Error for DecodeError {}

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn byte(&mut self) -> Result<u8, DecodeError> {
        let v = *self.b.get(self.pos).ok_or(DecodeError("truncated"))?;
        self.pos += 1;
        Ok(v)
    }
    fn varint(&mut self) -> Result<u64, DecodeError> {
        let (v, n) = get_varint(&self.b[self.pos..]).ok_or(DecodeError("bad varint"))?;
        self.pos += n;
        Ok(v)
    }
}

#[inline]
pub(crate) fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    // Line-stream tokens are mostly 1 or 2 bytes.
    if v < 0x80 {
        out.push(v as u8);
        return;
    }
    if v < 0x4000 {
        out.extend_from_slice(&[(v as u8) | 0x80, (v >> 7) as u8]);
        return;
    }
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

#[inline]
fn get_varint(b: &[u8]) -> Option<(u64, usize)> {
    // Most tokens of a line stream fit one byte.
    if let Some(&b0) = b.first() {
        if b0 < 0x80 {
            return Some((b0 as u64, 1));
        }
    }
    let mut v = 0u64;
    for (i, &byte) in b.iter().enumerate().take(10) {
        v |= ((byte & 0x7F) as u64) << (7 * i);
        if byte & 0x80 == 0 {
            return Some((v, i + 1));
        }
    }
    None
}

#[inline]
fn zigzag(d: i64) -> u64 {
    ((d << 1) ^ (d >> 63)) as u64
}
#[inline]
fn unzigzag(z: u64) -> i64 {
    ((z >> 1) as i64) ^ -((z & 1) as i64)
}

/// Number of stream heads the line encoder predicts from.
const SLOTS: usize = 4;
/// A delta at most this large (in lines) continues a stream; larger ones
/// start a new stream in the least recently used slot.
const NEAR: u64 = 1024;

/// Stream-head predictor shared by the encoder and the decoder.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct Heads {
    line: [u64; SLOTS],
    stamp: [u64; SLOTS],
    t: u64,
}

impl Heads {
    /// Slot whose head is nearest to `line`, and the delta from it.
    #[inline]
    fn nearest(&self, line: u64) -> (usize, i64) {
        let mut best = (0, line.wrapping_sub(self.line[0]) as i64);
        for s in 1..SLOTS {
            let d = line.wrapping_sub(self.line[s]) as i64;
            if d.unsigned_abs() < best.1.unsigned_abs() {
                best = (s, d);
            }
        }
        best
    }
    #[inline]
    fn update(&mut self, slot: usize, delta: i64, line: u64) {
        let s = if delta.unsigned_abs() <= NEAR {
            slot
        } else {
            // The least recently updated slot (ties to the lowest); SLOTS > 0, so there is one.
            let mut oldest = 0;
            for i in 1..SLOTS {
                if self.stamp[i] < self.stamp[oldest] {
                    oldest = i;
                }
            }
            oldest
        };
        self.t += 1;
        self.line[s] = line;
        self.stamp[s] = self.t;
    }
}

/// The ordered stream of 64-byte cache lines a task touched.
///
/// Each access is a line number (`address >> 6`, real virtual addresses of
/// the process) and a read/write flag. Consecutive repeats of the same line
/// with the same flag are dropped. Each remaining access is coded against
/// the nearest of 4 recent *stream heads* (so interleaved streams — x, y,
/// out arrays — each stay delta +1) as the zig-zag varint token
/// `(((zz(delta) << 2 | slot) << 1 | write) << 1 | run)`; `run = 1` is
/// followed by a varint `n - 2`: the same token repeats `n` times. A single
/// streaming pass costs a few bytes in total, interleaved streams about
/// 1 byte per line, scattered accesses 2–4 bytes per line (measured figures
/// in the README).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LineStream {
    bytes: Vec<u8>,
    count: u64,
    last: u64,
}

impl LineStream {
    /// Number of line accesses recorded (after dropping repeats).
    pub fn len(&self) -> u64 {
        self.count
    }
    /// No accesses recorded?
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
    /// Size of the encoded stream in bytes.
    pub fn encoded_len(&self) -> usize {
        self.bytes.len()
    }
    /// Average encoded bytes per recorded line access.
    pub fn bytes_per_line(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.bytes.len() as f64 / self.count as f64
        }
    }
    /// Calls `f(line, is_write)` for every access in order: the same sequence as
    /// [`LineStream::iter`], decoded in one tight loop (runs of a repeated token stay in an inner
    /// loop). The machine model's replay uses it.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut(u64, bool)) {
        let b = &self.bytes[..];
        let mut pos = 0;
        let mut heads = Heads::default();
        while pos < b.len() {
            let Some((tok, n)) = get_varint(&b[pos..]) else {
                return;
            };
            pos += n;
            let reps = if tok & 1 == 1 {
                let Some((c, n)) = get_varint(&b[pos..]) else {
                    return;
                };
                pos += n;
                c.saturating_add(2)
            } else {
                1
            };
            let tok = tok >> 1;
            let write = tok & 1 == 1;
            let slot = ((tok >> 1) & (SLOTS as u64 - 1)) as usize;
            let delta = unzigzag(tok >> 3);
            if delta.unsigned_abs() <= NEAR {
                // Each repetition continues the same head (what `Heads::update` does for a near
                // delta), so the head only needs writing back once.
                let mut line = heads.line[slot];
                for _ in 0..reps {
                    line = line.wrapping_add(delta as u64);
                    f(line, write);
                }
                heads.t = heads.t.wrapping_add(reps);
                heads.line[slot] = line;
                heads.stamp[slot] = heads.t;
            } else {
                for _ in 0..reps {
                    let line = heads.line[slot].wrapping_add(delta as u64);
                    heads.update(slot, delta, line);
                    f(line, write);
                }
            }
        }
    }

    /// Encodes `accesses` (`(line, is_write)` in order) as a stream, as a recorder would have.
    pub fn encode(accesses: impl IntoIterator<Item = (u64, bool)>) -> LineStream {
        let mut e = LineStreamEncoder::default();
        for (line, write) in accesses {
            e.push(line, write);
        }
        e.finish()
    }

    /// Decodes the stream as [`LineStream::for_each`] does, but trusting nothing: calls
    /// `f(line, is_write)` for every access and returns their number, or an error when the bytes
    /// are malformed (a truncated or overlong varint), when more than `limit` accesses would be
    /// decoded (checked before each run is expanded), when the decoded count differs from the
    /// recorded one, or when `f` returns false. For streams read from files.
    pub fn try_for_each(&self, limit: u64, mut f: impl FnMut(u64, bool) -> bool) -> Result<u64, DecodeError> {
        let b = &self.bytes[..];
        let mut pos = 0;
        let mut heads = Heads::default();
        let mut decoded = 0u64;
        while pos < b.len() {
            let (tok, n) = get_varint(&b[pos..]).ok_or(DecodeError("malformed line-stream token"))?;
            pos += n;
            let reps = if tok & 1 == 1 {
                let (c, n) = get_varint(&b[pos..]).ok_or(DecodeError("malformed line-stream run length"))?;
                pos += n;
                c.checked_add(2)
                    .ok_or(DecodeError("line-stream run length overflows"))?
            } else {
                1
            };
            decoded = decoded
                .checked_add(reps)
                .filter(|&d| d <= limit)
                .ok_or(DecodeError("line stream longer than the file can hold"))?;
            let tok = tok >> 1;
            let write = tok & 1 == 1;
            let slot = ((tok >> 1) & (SLOTS as u64 - 1)) as usize;
            let delta = unzigzag(tok >> 3);
            for _ in 0..reps {
                let line = heads.line[slot].wrapping_add(delta as u64);
                heads.update(slot, delta, line);
                if !f(line, write) {
                    return Err(DecodeError("line rejected"));
                }
            }
        }
        if decoded != self.count {
            return Err(DecodeError(
                "line-stream count differs from the accesses it holds",
            ));
        }
        Ok(decoded)
    }

    /// Decode: `(line, is_write)` in access order.
    #[inline]
    pub fn iter(&self) -> LineIter<'_> {
        LineIter {
            b: &self.bytes,
            pos: 0,
            heads: Heads::default(),
            tok: 0,
            left: 0,
        }
    }
}

/// Decoder for [`LineStream`].
#[derive(Clone, Debug)]
pub struct LineIter<'a> {
    b: &'a [u8],
    pos: usize,
    heads: Heads,
    tok: u64,
    left: u64,
}

impl Iterator for LineIter<'_> {
    type Item = (u64, bool);
    // Inlined across the crate boundary: the replay decodes every access through it.
    #[inline]
    fn next(&mut self) -> Option<(u64, bool)> {
        if self.left == 0 {
            if self.pos >= self.b.len() {
                return None;
            }
            let (tok, n) = get_varint(&self.b[self.pos..])?;
            self.pos += n;
            self.tok = tok >> 1;
            self.left = if tok & 1 == 1 {
                let (c, n) = get_varint(&self.b[self.pos..])?;
                self.pos += n;
                c.saturating_add(2)
            } else {
                1
            };
        }
        self.left -= 1;
        let write = self.tok & 1 == 1;
        let slot = ((self.tok >> 1) & (SLOTS as u64 - 1)) as usize;
        let delta = unzigzag(self.tok >> 3);
        let line = self.heads.line[slot].wrapping_add(delta as u64);
        self.heads.update(slot, delta, line);
        Some((line, write))
    }
}

/// Builds a [`LineStream`] access by access (what [`LineStream::encode`] does from an iterator), for
/// callers that produce accesses inside a callback.
#[derive(Default)]
pub struct LineStreamEncoder(LineEncoder);

impl LineStreamEncoder {
    /// Appends one access (a repeat of the previous access is dropped, as when recording).
    #[inline]
    pub fn push(&mut self, line: u64, write: bool) {
        self.0.push(line, write);
    }
    /// The finished stream.
    pub fn finish(self) -> LineStream {
        self.0.finish()
    }
}

std::thread_local! {
    /// Byte buffers of finished encoders, reused by the next encoder on the thread. A stream grows
    /// by doubling; growing every task's stream in fresh memory costs page faults (the kernel zeroes
    /// each new page) and, while frees are held ([`crate::HoldFrees`]), memory. A finished stream
    /// is copied out at its exact length instead.
    static SCRATCH: core::cell::RefCell<Vec<Vec<u8>>> = const { core::cell::RefCell::new(Vec::new()) };
}

/// Scratch buffers kept per thread (more are freed).
const SCRATCH_KEEP: usize = 4;

/// Incremental encoder for [`LineStream`].
#[derive(Clone, Debug, Default)]
pub(crate) struct LineEncoder {
    s: LineStream,
    heads: Heads,
    last_write: bool,
    run_tok: u64,
    run_len: u64,
}

impl LineEncoder {
    fn from_stream(s: LineStream) -> Self {
        // Re-open a finished stream by replaying it (restores the heads).
        let mut e = LineEncoder::default();
        for (l, w) in s.iter() {
            e.push(l, w);
        }
        e
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, line: u64, write: bool) {
        if self.s.count != 0 && line == self.s.last && write == self.last_write {
            return;
        }
        let (slot, delta) = self.heads.nearest(line);
        self.heads.update(slot, delta, line);
        self.s.last = line;
        self.last_write = write;
        self.s.count += 1;
        let tok = (zigzag(delta) << 3) | ((slot as u64) << 1) | write as u64;
        if self.run_len > 0 && tok == self.run_tok {
            self.run_len += 1;
        } else {
            self.flush();
            self.run_tok = tok;
            self.run_len = 1;
        }
    }

    #[inline]
    fn flush(&mut self) {
        if self.run_len == 0 {
            return;
        }
        if self.s.bytes.capacity() == 0 {
            self.s.bytes = SCRATCH
                .with(|p| p.borrow_mut().pop())
                .unwrap_or_else(|| Vec::with_capacity(4096));
        }
        if self.run_len == 1 {
            put_varint(&mut self.s.bytes, self.run_tok << 1);
        } else {
            put_varint(&mut self.s.bytes, (self.run_tok << 1) | 1);
            put_varint(&mut self.s.bytes, self.run_len - 2);
        }
        self.run_len = 0;
    }

    pub(crate) fn finish(mut self) -> LineStream {
        self.flush();
        if self.s.bytes.capacity() > 0 {
            // Keep the (grown) buffer for the next encoder; the stream gets an exact copy.
            let mut scratch = core::mem::take(&mut self.s.bytes);
            self.s.bytes = scratch.as_slice().to_vec();
            scratch.clear();
            SCRATCH.with(|p| {
                let mut p = p.borrow_mut();
                if p.len() < SCRATCH_KEEP {
                    p.push(scratch);
                }
            });
        }
        self.s
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.s.count == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_stream_roundtrip() {
        let mut e = LineEncoder::default();
        let mut want = Vec::new();
        let mut x = 0x1234_5678u64;
        for i in 0..5000u64 {
            let line = if i % 7 < 4 {
                1000 + i / 3
            } else {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 20) & 0xFFFF_FFFF
            };
            let w = i % 11 == 0;
            e.push(line, w);
            if want.last() != Some(&(line, w)) {
                want.push((line, w));
            }
        }
        let s = e.finish();
        assert_eq!(s.len(), want.len() as u64);
        let got: Vec<_> = s.iter().collect();
        assert_eq!(got, want);
        let mut each = Vec::new();
        s.for_each(|l, w| each.push((l, w)));
        assert_eq!(each, want);
    }

    #[test]
    fn far_runs_roundtrip() {
        // Repeated far jumps (each token moves to the least recently used head) and near runs.
        let mut e = LineEncoder::default();
        let mut want = Vec::new();
        for k in 0..200u64 {
            let line = if k % 50 < 30 { k * 5000 } else { 1_000_000 + k };
            e.push(line, k % 3 == 0);
            want.push((line, k % 3 == 0));
        }
        let s = e.finish();
        let mut each = Vec::new();
        s.for_each(|l, w| each.push((l, w)));
        assert_eq!(each, want);
        assert_eq!(s.iter().collect::<Vec<_>>(), want);
    }

    #[test]
    fn sequential_stream_is_tiny() {
        let mut e = LineEncoder::default();
        for l in 0..100_000u64 {
            e.push(0x7f00_0000_0000 + l, false);
        }
        let s = e.finish();
        assert_eq!(s.len(), 100_000);
        assert!(s.encoded_len() < 16, "{}", s.encoded_len());
        assert_eq!(s.iter().count(), 100_000);
    }

    #[test]
    fn record_bytes_roundtrip() {
        let mut e = LineEncoder::default();
        for l in [5u64, 6, 7, 3, 100, 100, 99] {
            e.push(l, l == 3);
        }
        let c = Counters {
            valu: 12345678901,
            gather_lines: 3,
            atomic_conflicts: 1,
            ..Default::default()
        };
        let r = TaskRecord {
            kind: 7,
            counters: c,
            lines: e.finish(),
        };
        let mut b = r.to_bytes();
        let n1 = b.len();
        b.extend(r.to_bytes());
        let (r2, n) = TaskRecord::from_bytes(&b).unwrap();
        assert_eq!(n, n1);
        assert_eq!(r2, r);
        let (r3, _) = TaskRecord::from_bytes(&b[n..]).unwrap();
        assert_eq!(r3, r);
        assert!(TaskRecord::from_bytes(&b[..n - 1]).is_err());
    }

    #[test]
    fn add_assign_appends() {
        let mut a = TaskRecord::default();
        let mut e = LineEncoder::default();
        e.push(10, false);
        e.push(11, true);
        a.lines = e.finish();
        a.counters.valu = 2;
        let mut b = TaskRecord::default();
        let mut e = LineEncoder::default();
        e.push(50, false);
        b.lines = e.finish();
        b.counters.valu = 3;
        a += &b;
        assert_eq!(a.counters.valu, 5);
        assert_eq!(
            a.lines.iter().collect::<Vec<_>>(),
            vec![(10, false), (11, true), (50, false)]
        );
    }
}
