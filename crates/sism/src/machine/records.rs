//! The records file (`records.bin`): a frame's task records, saved by `render --machine` and
//! `study`, re-timed by `replay`. Read as untrusted input: every count is checked against the bytes
//! that remain before anything is allocated, so a corrupt or hostile file is an error naming the byte
//! offset, never a panic, an abort or a runaway allocation; the memory a replay takes is bounded by
//! the file's size.
//!
//! Format, version 9 (little-endian; 3: task records carry `branch_mispredicts`; 4: `scalar_float`;
//! 5: a step's flags; 6: `mask_moves`; 7: each line carries its stream state; 8: `window_issue`;
//! 9: `scalar_stores`):
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `SISMREC\0` |
//! | 4 | version (9) |
//! | 4 | flags: bit 0 = line ids are first-touch ids (always set by this version) |
//! | 8 | total file size, bytes |
//! | 4 | phase (step) count |
//! | per step | name length (u32), name (UTF-8), flags (u32: bit 0 = the host ran the tasks serially, [`PhaseRecords::serial`]), task count (u64), per task its byte length (u64) and [`sism_simd::TaskRecord::to_bytes`] |
//! | 8 | checksum of every byte before it (see [`checksum`]) |
//!
//! **Identical bytes.** Recorded lines are process addresses, which differ from run to run. Saving
//! replaces them by first-touch ids (the `n`-th distinct line of the frame, in record order, is line
//! `n`) — exactly the ids the model's caches use — so two counted runs of the same frame write the
//! same file, byte for byte. The prefetcher model follows streams on addresses, which the ids no
//! longer are (any first pass over fresh lines would look sequential), so each saved line is
//! `id << 2 | stream`, the stream state its address gave ([`super::timing::StreamFollower`]): every
//! replay of the file is identical to replaying the records in memory. (Version 6 files held bare
//! ids, and their replays on a machine with a prefetcher took every first pass for a stream.)

use std::path::Path;

use sism_simd::{LineStreamEncoder, TaskRecord};

use super::cache::LineIds;
use super::timing::{self, StreamFollower};
use crate::exec::PhaseRecords;

const MAGIC: &[u8; 8] = b"SISMREC\0";
/// The version this sism writes and reads.
pub const VERSION: u32 = 9;
/// Flag bit: line ids are first-touch ids.
const FLAG_FIRST_TOUCH: u32 = 1;
/// Step flag bit: the host ran the step's tasks serially.
const STEP_SERIAL: u32 = 1;
/// Header bytes before the first step.
const HEADER: usize = 8 + 4 + 4 + 8 + 4;
/// Smallest encoded task record (magic, version, kind, field count, 20 one-byte counters, count,
/// last, stream length), bytes: bounds the task count a length can claim.
const MIN_TASK_BYTES: u64 = 27;
/// Smallest encoded step (name length, flags, task count), bytes: bounds the step count.
const MIN_STEP_BYTES: u64 = 4 + 4 + 8;
/// Most steps a file may hold.
pub const MAX_STEPS: u64 = 1 << 16;
/// Longest step name, bytes.
pub const MAX_NAME_BYTES: usize = 256;
/// Line accesses a file may hold per byte of its size, and in all: the replay's time and the line-id
/// table's memory are bounded by the file's size. (A counted japanese-maple frame at 1600×1200 holds
/// 0.6 accesses per byte.)
pub const MAX_ACCESSES_PER_BYTE: u64 = 64;
/// Most line accesses in one file.
pub const MAX_ACCESSES: u64 = 1 << 38;
/// Largest sum over a file of any one counter (instructions of a class, lines, lanes): within it and
/// a validated machine, no cycle count can overflow.
pub const MAX_COUNTER_TOTAL: u64 = 1 << 40;

/// The checksum of a records file: a multiply-rotate hash over 8-byte little-endian words (the tail
/// zero-padded), then the length. Catches corruption (flipped bits, truncation, splices), not
/// tampering.
pub fn checksum(bytes: &[u8]) -> u64 {
    const K: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut h: u64 = 0x5155_4D53_4952_4543;
    let mut chunks = bytes.chunks_exact(8);
    for c in &mut chunks {
        let w = u64::from_le_bytes(c.try_into().expect("8 bytes"));
        h = (h.rotate_left(23) ^ w).wrapping_mul(K);
    }
    let mut tail = [0u8; 8];
    tail[..chunks.remainder().len()].copy_from_slice(chunks.remainder());
    h = (h.rotate_left(23) ^ u64::from_le_bytes(tail)).wrapping_mul(K);
    (h ^ bytes.len() as u64).wrapping_mul(K)
}

/// A frame's records with their lines replaced by first-touch ids in record order (see the module
/// docs): what a records file holds. They time exactly as the records they came from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CanonicalRecords(pub Vec<PhaseRecords>);

impl std::ops::Deref for CanonicalRecords {
    type Target = [PhaseRecords];
    fn deref(&self) -> &[PhaseRecords] {
        &self.0
    }
}

/// `records` with their lines replaced by first-touch ids in record order, each carrying the
/// stream state its address gave ([`timing::canonical_line`]: the prefetcher's streams are followed
/// on addresses, which the ids no longer are). Records already in that form are copied.
pub fn canonical(records: &[PhaseRecords]) -> CanonicalRecords {
    let mut ids = LineIds::new();
    first_touch_form(records, |p, t| {
        let mut lines = LineStreamEncoder::default();
        let mut streams = StreamFollower::default();
        t.lines.for_each(|line, write| {
            let (line, stream) = if p.first_touch {
                timing::canonical_parts(line)
            } else {
                (line, streams.follow(line))
            };
            lines.push(timing::canonical_line(ids.id(line), stream), write)
        });
        lines.finish()
    })
}

/// `records` in first-touch form, each task's lines given by `lines` (called for every task in
/// record order with its step): [`canonical`]'s and [`super::simulate_canonical`]'s shape.
pub(crate) fn first_touch_form(
    records: &[PhaseRecords],
    mut lines: impl FnMut(&PhaseRecords, &TaskRecord) -> sism_simd::LineStream,
) -> CanonicalRecords {
    CanonicalRecords(
        records
            .iter()
            .map(|p| PhaseRecords {
                phase: p.phase.clone(),
                serial: p.serial,
                first_touch: true,
                tasks: p
                    .tasks
                    .iter()
                    .map(|t| TaskRecord {
                        kind: t.kind,
                        counters: t.counters,
                        lines: lines(p, t),
                    })
                    .collect(),
            })
            .collect(),
    )
}

/// The bytes of a records file holding `records`.
pub fn to_bytes(records: &CanonicalRecords) -> Vec<u8> {
    // Reserved whole: a frame's records are hundreds of MB, and growing the buffer by doubling
    // copied each half into fresh pages (4 of the 26 s of a japanese-maple 800x600 `render
    // --machine` on one thread went to the kernel zeroing them).
    let bound = 64
        + records
            .iter()
            .map(|p| 24 + p.phase.len() + p.tasks.iter().map(|t| 8 + t.bytes_bound()).sum::<usize>())
            .sum::<usize>();
    let mut out = Vec::with_capacity(bound);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&FLAG_FIRST_TOUCH.to_le_bytes());
    out.extend_from_slice(&0u64.to_le_bytes()); // the total size, patched below
    out.extend_from_slice(&(records.len() as u32).to_le_bytes());
    for p in records.iter() {
        out.extend_from_slice(&(p.phase.len() as u32).to_le_bytes());
        out.extend_from_slice(p.phase.as_bytes());
        out.extend_from_slice(&(if p.serial { STEP_SERIAL } else { 0 }).to_le_bytes());
        out.extend_from_slice(&(p.tasks.len() as u64).to_le_bytes());
        for t in &p.tasks {
            // The record's length, patched once it is written.
            let at = out.len();
            out.extend_from_slice(&0u64.to_le_bytes());
            t.write_bytes(&mut out);
            let len = (out.len() - at - 8) as u64;
            out[at..at + 8].copy_from_slice(&len.to_le_bytes());
        }
    }
    let total = out.len() as u64 + 8;
    out[16..24].copy_from_slice(&total.to_le_bytes());
    let sum = checksum(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// Writes `records` to `path` (see the module docs for the format).
pub fn save_records(path: &Path, records: &CanonicalRecords) -> crate::Result<()> {
    crate::output::write_atomic(path, &to_bytes(records))
}

/// Reads a records file written by [`save_records`] (a regular file of at most
/// [`crate::input::MAX_RECORDS_BYTES`]).
pub fn load_records(path: &Path) -> crate::Result<CanonicalRecords> {
    let bytes = crate::input::read_file(path, "records file", crate::input::MAX_RECORDS_BYTES)?;
    parse_records(&bytes).map_err(|e| crate::Error::invalid(format!("records file {}: {e}", path.display())))
}

/// A cursor over untrusted bytes whose reads fail (naming the offset) instead of panicking.
struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        if self.b.len() - self.pos < n {
            return Err(format!(
                "truncated at byte {}: {what} needs {n} bytes, {} remain",
                self.pos,
                self.b.len() - self.pos
            ));
        }
        self.pos += n;
        Ok(&self.b[self.pos - n..self.pos])
    }
    fn u32(&mut self, what: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4, what)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self, what: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8, what)?.try_into().expect("8 bytes"),
        ))
    }
    fn remaining(&self) -> u64 {
        (self.b.len() - self.pos) as u64
    }
}

/// Parses the bytes of a records file (see the module docs), checking everything.
pub fn parse_records(b: &[u8]) -> Result<CanonicalRecords, String> {
    if b.len() < 8 || &b[..8] != MAGIC {
        return Err("not a sism records file (bad magic)".into());
    }
    let mut r = Reader { b, pos: 8 };
    let version = r.u32("the version")?;
    if version != VERSION {
        return Err(if version > VERSION {
            format!("version {version} is newer than this sism reads ({VERSION}): use a newer sism")
        } else {
            format!("version {version} is older than this sism reads ({VERSION}): record the frame again")
        });
    }
    let flags = r.u32("the flags")?;
    if flags != FLAG_FIRST_TOUCH {
        return Err(format!("unknown flags {flags:#x} at byte 12"));
    }
    let total = r.u64("the total size")?;
    if total != b.len() as u64 {
        return Err(format!(
            "the header says {total} bytes but the file has {}: truncated or padded",
            b.len()
        ));
    }
    if b.len() < HEADER + 8 {
        return Err(format!(
            "truncated: {} bytes, a header needs {}",
            b.len(),
            HEADER + 8
        ));
    }
    let (body, sum) = b.split_at(b.len() - 8);
    if checksum(body) != u64::from_le_bytes(sum.try_into().expect("8 bytes")) {
        return Err("checksum mismatch: the file is corrupt".into());
    }
    let mut r = Reader { b: body, pos: r.pos };
    let steps = r.u32("the step count")? as u64;
    if steps > MAX_STEPS || steps > r.remaining() / MIN_STEP_BYTES {
        return Err(format!(
            "{steps} steps claimed at byte 24; at most {} fit the file",
            MAX_STEPS.min(r.remaining() / MIN_STEP_BYTES)
        ));
    }
    let access_budget = (MAX_ACCESSES_PER_BYTE.saturating_mul(b.len() as u64)).min(MAX_ACCESSES);
    let mut accesses = 0u64;
    let mut next_id = 0u64;
    let mut totals = [0u64; sism_simd::Counters::FIELDS.len()];
    let mut out = Vec::with_capacity(steps as usize);
    for s in 0..steps {
        let at = r.pos;
        let len = r.u32("a step name's length")? as usize;
        if len > MAX_NAME_BYTES {
            return Err(format!(
                "step {s} at byte {at}: a name of {len} bytes (at most {MAX_NAME_BYTES})"
            ));
        }
        let phase = std::str::from_utf8(r.take(len, "a step name")?)
            .map_err(|_| format!("step {s} at byte {at}: the name is not UTF-8"))?
            .to_string();
        let step_flags = r.u32("a step's flags")?;
        if step_flags & !STEP_SERIAL != 0 {
            return Err(format!(
                "step {s} ({phase}) at byte {at}: unknown step flags {step_flags:#x}"
            ));
        }
        let tasks = r.u64("a task count")?;
        if tasks > r.remaining() / (8 + MIN_TASK_BYTES) {
            return Err(format!(
                "step {s} ({phase}) at byte {at}: {tasks} tasks claimed, at most {} fit the bytes left",
                r.remaining() / (8 + MIN_TASK_BYTES)
            ));
        }
        let mut list = Vec::with_capacity(tasks as usize);
        for i in 0..tasks {
            let at = r.pos;
            let len = r.u64("a task's length")?;
            if len > r.remaining() {
                return Err(format!(
                    "step {s} ({phase}), task {i} at byte {at}: {len} bytes claimed, {} remain",
                    r.remaining()
                ));
            }
            let bytes = r.take(len as usize, "a task")?;
            let (t, used) = TaskRecord::from_bytes(bytes)
                .map_err(|e| format!("step {s} ({phase}), task {i} at byte {at}: {e}"))?;
            if used as u64 != len {
                return Err(format!(
                    "step {s} ({phase}), task {i} at byte {at}: length mismatch"
                ));
            }
            for (total, v) in totals.iter_mut().zip(t.counters.values()) {
                *total = total.saturating_add(v);
                if *total > MAX_COUNTER_TOTAL {
                    return Err(format!(
                        "step {s} ({phase}), task {i} at byte {at}: counters beyond {MAX_COUNTER_TOTAL} in total"
                    ));
                }
            }
            // Lines: every id is one seen before or the next new one (first-touch order), with a
            // stream state of at most 2.
            let n = t
                .lines
                .try_for_each(access_budget - accesses, |line, _| {
                    let (line, stream) = timing::canonical_parts(line);
                    if stream > 2 {
                        false
                    } else if line < next_id {
                        true
                    } else if line == next_id {
                        next_id += 1;
                        true
                    } else {
                        false
                    }
                })
                .map_err(|e| format!("step {s} ({phase}), task {i} at byte {at}: {e}"))?;
            accesses += n;
            list.push(t);
        }
        out.push(PhaseRecords {
            phase,
            tasks: list,
            serial: step_flags & STEP_SERIAL != 0,
            first_touch: true,
        });
    }
    if r.remaining() != 0 {
        return Err(format!("{} trailing bytes before the checksum", r.remaining()));
    }
    Ok(CanonicalRecords(out))
}
