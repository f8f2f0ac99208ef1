//! How a frame's work executes, and what it leaves behind for the machine model.
//!
//! Every algorithm's frame is a sequence of named **phases** (`eye_pass`, `grid`, `penumbra`, ...),
//! run through [`FrameLog::phase`]: the phase's host wall time becomes one `time.<phase>` row, and its
//! kernels run as **tasks** ([`Exec::Native`], or [`Exec::Counting`] with one
//! [`sism_simd::TaskRecord`] per task). Within a phase, tasks are grouped into **steps**
//! (`grid.classify`, `grid.scatter`, ...): the work of one step depends on the whole of the previous
//! one, so the machine model ends each step with a barrier, and a step's tasks are what its cores share.
//! A phase that runs no task at all under counting (host code the chip would run but nobody has
//! written as a kernel yet) is listed as *untimed* ([`FrameLog::untimed`]), so no simulated frame time
//! is mistaken for a whole frame.
//!
//! Task records are always kept in a fixed order (a step's tasks in the order they were built, never
//! the host's scheduling order), so records, and the simulated cycles, do not depend on the host's
//! thread count.

use std::time::{Duration, Instant};

use rayon::prelude::*;
use sism_simd::{Kernel, Recorder, TaskRecord};

use crate::stats::StatsReport;

/// How kernels execute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Exec {
    /// `sism_simd::run_native`: the fastest backend, no records.
    #[default]
    Native,
    /// `sism_simd::run_counting`: the same results bit for bit, plus one [`TaskRecord`] per task.
    Counting,
}

/// Runs kernel `k` natively on the selected backend ([`sism_simd::run_native`]). In the library's
/// unit-test build, on AVX-512 or the portable baseline only ([`sism_simd::run_native_lean`]): every
/// kernel is compiled once per backend, and the four backends' copies of every algorithm were half
/// of CI's build time; the unit tests check the algorithms, which give the same bits on every
/// backend (the simd crate's suites and the end-to-end tests check every backend).
#[inline]
pub fn native<K: Kernel>(k: K) -> K::Output {
    #[cfg(not(test))]
    return sism_simd::run_native(k);
    #[cfg(test)]
    return sism_simd::run_native_lean(k);
}

/// Runs kernel `k` counted into `recorder` ([`sism_simd::run_counting`]); in the library's
/// unit-test build, over the portable baseline only ([`native`]; the records are the same).
#[inline]
pub fn counting<K: Kernel>(recorder: &Recorder, k: K) -> K::Output {
    #[cfg(not(test))]
    return sism_simd::run_counting(recorder, k);
    #[cfg(test)]
    return sism_simd::run_counting_lean(recorder, k);
}

std::thread_local! {
    /// Recorders of finished tasks, for the next task on the same thread. A recorder's tables
    /// (about 70 KB: scalar depths, branch predictor, stack renaming) made fresh for each task
    /// were a tenth of a counted frame's host time, all of it the kernel zeroing new pages: frees
    /// are held during a counted frame ([`sism_simd::HoldFrees`]), so every new table is new
    /// memory. A recorder starts every task from the same state (a fresh epoch, an untrained
    /// predictor, no stack lines), so reusing one changes no record.
    static RECORDERS: core::cell::RefCell<Vec<Recorder>> = const { core::cell::RefCell::new(Vec::new()) };
}

/// Recorders kept per thread (a task run inside another task's kernel takes a second one).
const RECORDERS_KEPT: usize = 4;

/// Runs kernel `k` as one task under `exec`: its output and, under [`Exec::Counting`], its records
/// (recorders are per thread: one of the thread's, reused task after task).
#[inline]
pub fn run_task<K: Kernel>(exec: Exec, k: K) -> (K::Output, Vec<TaskRecord>) {
    match exec {
        Exec::Native => (native(k), Vec::new()),
        Exec::Counting => {
            let recorder = RECORDERS.with(|r| r.borrow_mut().pop()).unwrap_or_default();
            let out = counting(&recorder, k);
            let records = recorder.take_tasks();
            RECORDERS.with(|r| {
                let mut r = r.borrow_mut();
                if r.len() < RECORDERS_KEPT {
                    r.push(recorder);
                }
            });
            (out, records)
        }
    }
}

/// The task records of one step of a frame, in task order, for the machine model to replay. Steps
/// run one after another on the modelled chip, each ending at a barrier.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhaseRecords {
    /// `phase.step` (or just `phase` for a phase of one step), e.g. `grid.classify`, `umbra`.
    pub phase: String,
    /// The step's task records, in task order.
    pub tasks: Vec<TaskRecord>,
    /// True when the host ran the tasks one after another on the calling thread ([`Phase::run`],
    /// [`Phase::run_seq`]: tasks that share an output buffer), false when in parallel
    /// ([`Phase::run_par`]). A machine with `serial_steps` replays them so.
    pub serial: bool,
    /// The tasks' lines are first-touch ids carrying the stream state their addresses gave, as a
    /// records file holds them ([`crate::machine::canonical`]); false: line addresses, as recorded.
    pub first_touch: bool,
}

impl PhaseRecords {
    /// The phase a step belongs to: its name up to the first `.`.
    pub fn group(&self) -> &str {
        group_of(&self.phase)
    }
}

/// The phase of step name `name` (its part before the first `.`).
pub fn group_of(name: &str) -> &str {
    name.split('.').next().unwrap_or(name)
}

/// Host wall time of one phase of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseTime {
    /// Phase name.
    pub name: &'static str,
    /// What the phase does, for the `time.<name>` row's description.
    pub what: &'static str,
    /// Host wall time.
    pub host: Duration,
    /// Tasks the phase ran (natively or counted).
    pub tasks: u64,
    /// True when the phase ran its work as kernels (even as no task at all: nothing to do); false
    /// when it never went through the kernel runners (host work the model cannot time).
    pub modelled: bool,
    /// Host wall time of each named step the phase ran kernels in (`step`, not `phase.step`), in
    /// first-run order; a step run several times sums its runs.
    pub steps: Vec<(String, Duration)>,
}

/// A frame's phases: host times, and under [`Exec::Counting`] every step's task records.
#[derive(Debug)]
pub struct FrameLog {
    exec: Exec,
    times: Vec<PhaseTime>,
    records: Vec<PhaseRecords>,
}

impl FrameLog {
    /// An empty log for a frame executed as `exec` says.
    pub fn new(exec: Exec) -> FrameLog {
        FrameLog {
            exec,
            times: Vec::new(),
            records: Vec::new(),
        }
    }

    /// How the frame's kernels execute.
    pub fn exec(&self) -> Exec {
        self.exec
    }

    /// Runs `f` as phase `name` (`what` says what it does, for the stats): its host wall time is
    /// timed, and the tasks it runs through the [`Phase`] are recorded as the phase's steps.
    pub fn phase<T>(&mut self, name: &'static str, what: &'static str, f: impl FnOnce(&mut Phase) -> T) -> T {
        let t = Instant::now();
        let mut phase = Phase {
            name,
            exec: self.exec,
            tasks: 0,
            modelled: false,
            steps: Vec::new(),
            step_times: Vec::new(),
        };
        let out = f(&mut phase);
        self.times.push(PhaseTime {
            name,
            what,
            host: t.elapsed(),
            tasks: phase.tasks,
            modelled: phase.modelled,
            steps: phase.step_times,
        });
        self.records.extend(phase.steps);
        out
    }

    /// Host times of the phases run so far, in order.
    pub fn times(&self) -> &[PhaseTime] {
        &self.times
    }

    /// Sum of the phases' host times.
    pub fn total(&self) -> Duration {
        self.times.iter().map(|t| t.host).sum()
    }

    /// The task records of every step, in frame order (empty natively).
    pub fn records(&self) -> &[PhaseRecords] {
        &self.records
    }

    /// Takes the records out of the log.
    pub fn take_records(&mut self) -> Vec<PhaseRecords> {
        std::mem::take(&mut self.records)
    }

    /// Under counting, the phases that did their work outside the kernel runners: host work the
    /// machine model does not time. (A phase whose kernels had nothing to do is timed: as zero.)
    pub fn untimed(&self) -> impl Iterator<Item = &PhaseTime> {
        let counting = self.exec == Exec::Counting;
        self.times.iter().filter(move |t| counting && !t.modelled)
    }

    /// `time.<phase>` per phase, `time.<phase>.<step>` per named step of a phase of several steps,
    /// and `time.frame` (the phases' sum), host wall times in ms.
    pub fn time_rows(&self, out: &mut StatsReport) {
        for t in &self.times {
            out.stat(
                &format!("time.{}", t.name),
                t.host.as_secs_f64() * 1e3,
                "ms",
                &format!("{} (host wall time)", t.what),
            );
            if t.steps.len() > 1 {
                for (step, host) in t.steps.iter().filter(|(step, _)| !step.is_empty()) {
                    out.stat(
                        &format!("time.{}.{step}", t.name),
                        host.as_secs_f64() * 1e3,
                        "ms",
                        &format!("step `{step}` of the {} phase (host wall time)", t.name),
                    );
                }
            }
        }
        out.stat(
            "time.frame",
            self.total().as_secs_f64() * 1e3,
            "ms",
            "sum of the phases (host wall time)",
        );
    }

    /// `machine.untimed.<phase>` rows: host ms of the phases that ran no task under counting.
    pub fn untimed_rows(&self, out: &mut StatsReport) {
        for t in self.untimed() {
            out.stat(
                &format!("machine.untimed.{}", t.name),
                t.host.as_secs_f64() * 1e3,
                "ms",
                &format!(
                    "{}: host work the machine model does not time (host wall time)",
                    t.what
                ),
            );
        }
    }
}

/// One phase in progress: runs its kernels as tasks and files their records by step.
#[derive(Debug)]
pub struct Phase {
    name: &'static str,
    exec: Exec,
    tasks: u64,
    modelled: bool,
    steps: Vec<PhaseRecords>,
    step_times: Vec<(String, Duration)>,
}

impl Phase {
    /// How the phase's kernels execute.
    pub fn exec(&self) -> Exec {
        self.exec
    }

    /// The records of step `step` (`""` for the phase's only step) run serially or not, opened if
    /// the last records are another step's or were run the other way.
    fn step_records(&mut self, step: &str, serial: bool) -> &mut Vec<TaskRecord> {
        let name = if step.is_empty() {
            self.name.to_string()
        } else {
            format!("{}.{step}", self.name)
        };
        if self
            .steps
            .last()
            .is_none_or(|s| s.phase != name || s.serial != serial)
        {
            self.steps.push(PhaseRecords {
                phase: name,
                tasks: Vec::new(),
                serial,
                first_touch: false,
            });
        }
        &mut self.steps.last_mut().expect("just pushed").tasks
    }

    /// Runs `k` as one task of step `step` on the calling thread.
    pub fn run<K: Kernel>(&mut self, step: &str, k: K) -> K::Output {
        let t = Instant::now();
        let (out, records) = run_task(self.exec, k);
        self.time_step(step, t.elapsed());
        self.file(step, true, vec![records]);
        out
    }

    /// Runs the kernels of `tasks` (one task each) in parallel on the host as tasks of step `step`;
    /// their outputs and records come back in the iterator's order.
    ///
    /// Each task is a job of its own, taken by whichever host thread is free, as the model's
    /// scheduler deals tasks to the least busy core. Rayon's default split would hand each thread
    /// a few runs of consecutive tasks, and tasks sorted by bin differ in cost by orders of
    /// magnitude: measured on stanford-bunny `sism` at 1600×1200 on a 2-thread pool, the
    /// penumbra's Eq. 3 step took 48 ms that way (one thread idle most of it) and 26 ms so.
    pub fn run_par<K, I>(&mut self, step: &str, tasks: I) -> Vec<K::Output>
    where
        K: Kernel + Send,
        K::Output: Send,
        I: ParallelIterator<Item = K>,
    {
        let exec = self.exec;
        let t = Instant::now();
        // Collected first: some steps filter their tasks, and a filtered iterator has no index to
        // split one task a job by.
        let tasks: Vec<K> = tasks.collect();
        let (outs, records): (Vec<K::Output>, Vec<Vec<TaskRecord>>) = tasks
            .into_par_iter()
            .with_max_len(1)
            .map(|k| run_task(exec, k))
            .unzip();
        self.time_step(step, t.elapsed());
        self.file(step, false, records);
        outs
    }

    /// Runs the kernels of `tasks` one after another on the calling thread (for steps whose host code
    /// shares one output buffer) as tasks of step `step`: recorded as serial (a machine with
    /// `serial_steps` replays them one after another on one core; Larrabee in parallel).
    pub fn run_seq<K: Kernel>(&mut self, step: &str, tasks: impl IntoIterator<Item = K>) -> Vec<K::Output> {
        let exec = self.exec;
        let t = Instant::now();
        let (outs, records): (Vec<K::Output>, Vec<Vec<TaskRecord>>) =
            tasks.into_iter().map(|k| run_task(exec, k)).unzip();
        self.time_step(step, t.elapsed());
        self.file(step, true, records);
        outs
    }

    /// Notes that the phase's kernel work was skipped (nothing needs it, e.g. a light face no receiver
    /// falls in): the phase is timed, as zero, rather than listed as untimed host work.
    pub fn skip(&mut self) {
        self.modelled = true;
    }

    /// Adds `host` to step `step`'s host time.
    fn time_step(&mut self, step: &str, host: Duration) {
        match self.step_times.iter_mut().find(|(name, _)| name == step) {
            Some((_, total)) => *total += host,
            None => self.step_times.push((step.to_string(), host)),
        }
    }

    fn file(&mut self, step: &str, serial: bool, records: Vec<Vec<TaskRecord>>) {
        let tasks = records.len() as u64;
        self.tasks += tasks;
        self.modelled = true;
        // A step with no task has nothing to time (and no barrier to wait at).
        if self.exec == Exec::Counting && tasks > 0 {
            let out = self.step_records(step, serial);
            out.extend(records.into_iter().flatten());
        }
    }
}

/// The task kinds of counting records, one table so none repeats (a test checks).
pub mod task_kind {
    /// Eye pass (or any view's raster): a front-end chunk (transform, clip, project, bin).
    pub const RASTER_FRONT_END: u32 = 0x100;
    /// Raster: a tile (rasterize and depth test).
    pub const RASTER_TILE: u32 = 0x101;
    /// Eye pass: a tile's receivers (resolve of the raster into receiver points).
    pub const EYE_RECEIVERS: u32 = 0x102;
    /// Raster: per-tile triangle lists filled from a front-end chunk's (tile, triangle) pairs.
    pub const RASTER_TILE_LISTS: u32 = 0x103;
    /// SISM light samples: classify receivers of a band of rows (miss, facing away, sample).
    pub const LIGHT_SAMPLES_CLASSIFY: u32 = 0x200;
    /// SISM light samples: the light view's fit (mean direction, cone test) over a chunk.
    pub const LIGHT_SAMPLES_FIT: u32 = 0x201;
    /// SISM light samples: counting sort of the samples by light face.
    pub const LIGHT_SAMPLES_FACE_SORT: u32 = 0x202;
    /// SISM light samples: a chunk's projection into its light face and its width-factor bounds.
    pub const LIGHT_SAMPLES_PROJECT: u32 = 0x203;
    /// SISM grid: classify samples into bins and cells (the paper's Figure 3, pass 1).
    pub const GRID_CLASSIFY: u32 = 1;
    /// SISM grid: scatter sample indices to their bins.
    pub const GRID_SCATTER: u32 = 0x300;
    /// SISM grid: counting sort of one bin's samples by cell.
    pub const GRID_CELL_SORT: u32 = 0x301;
    /// SISM grid: gather of the sorted structure of arrays.
    pub const GRID_GATHER: u32 = 0x302;
    /// SISM grid: one bin's descriptor (sample range and depth bounds).
    pub const GRID_BINS: u32 = 0x303;
    /// SISM umbra: one bin's depth complexity.
    pub const UMBRA_BIN: u32 = 2;
    /// SISM penumbra: one bin (or row of a bin) of Eq. 3 terms.
    pub const PENUMBRA_BIN: u32 = 3;
    /// SISM resolve: Eq. 4 of a chunk of samples.
    pub const SISM_RESOLVE: u32 = 4;
    /// SISM independent composition: one bin of the fused occlusion pass.
    pub const OCCLUSION_BIN: u32 = 5;
    /// SISM light-point composition: one bin (or row) of light-point counts.
    pub const SAMPLED_BIN: u32 = 6;
    /// SISM resolve: a chunk's values scattered to their pixels.
    pub const SISM_RESOLVE_SCATTER: u32 = 0x400;
    /// Sort-middle binning: a chunk of items (triangles, quads) binned.
    pub const BIN_ITEMS: u32 = 0x500;
    /// Sort-middle binning: a chunk's (bin, item) pairs scattered into the per-bin lists.
    pub const BIN_LISTS: u32 = 0x501;
    /// SISM silhouettes: a chunk of edges tested against the light centre.
    pub const SILHOUETTES: u32 = 0x600;
    /// Depth map: a tile's texels (resolve of the light view's raster).
    pub const DEPTH_MAP_TEXELS: u32 = 0x700;
    /// Depth map: the nearest depth over a chunk of texels.
    pub const DEPTH_MAP_MIN: u32 = 0x701;
    /// Shadow-map family: a chunk of receivers looked up in the depth maps.
    pub const SHADOW_LOOKUP: u32 = 0x702;
    /// Shadow-map family: a chunk of visibilities scattered to their pixels.
    pub const SHADOW_SCATTER: u32 = 0x703;
    /// Multi-sample shadow maps: one light point's results added into the receivers' sums.
    pub const MULTI_SAMPLE_ACCUMULATE: u32 = 0x704;
    /// Adaptive multi-sample: per-sample codes, reprojection, evaluation and final passes.
    pub const ADAPTIVE_PASS: u32 = 0x705;
    /// Contact-hardening: a band of rows of a screen-space pass.
    pub const SCREEN_PASS: u32 = 0x706;
    /// Soft shadow mip-maps: rows of a level of the mip chain.
    pub const SSMM_CHAIN: u32 = 0x707;
    /// Soft shadow mip-maps: a face's receivers filtered over the chain's layers.
    pub const SSMM_LOOKUP: u32 = 0x708;
    /// Depth map: a chunk of one face's receivers, their image-plane extent and depth range.
    pub const DEPTH_MAP_BOUNDS: u32 = 0x709;

    /// Every kind, for the uniqueness test.
    pub const ALL: &[u32] = &[
        RASTER_FRONT_END,
        RASTER_TILE,
        EYE_RECEIVERS,
        RASTER_TILE_LISTS,
        LIGHT_SAMPLES_CLASSIFY,
        LIGHT_SAMPLES_FIT,
        LIGHT_SAMPLES_FACE_SORT,
        LIGHT_SAMPLES_PROJECT,
        GRID_CLASSIFY,
        GRID_SCATTER,
        GRID_CELL_SORT,
        GRID_GATHER,
        GRID_BINS,
        UMBRA_BIN,
        PENUMBRA_BIN,
        SISM_RESOLVE,
        OCCLUSION_BIN,
        SAMPLED_BIN,
        SISM_RESOLVE_SCATTER,
        BIN_ITEMS,
        BIN_LISTS,
        SILHOUETTES,
        DEPTH_MAP_TEXELS,
        DEPTH_MAP_MIN,
        SHADOW_LOOKUP,
        SHADOW_SCATTER,
        MULTI_SAMPLE_ACCUMULATE,
        ADAPTIVE_PASS,
        SCREEN_PASS,
        SSMM_CHAIN,
        SSMM_LOOKUP,
        DEPTH_MAP_BOUNDS,
    ];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task_kinds_are_distinct() {
        let mut kinds = task_kind::ALL.to_vec();
        kinds.sort_unstable();
        kinds.dedup();
        assert_eq!(kinds.len(), task_kind::ALL.len());
        assert!(!kinds.contains(&sism_simd::NO_TASK));
    }

    struct Touch(u32);
    impl Kernel for Touch {
        type Output = u32;
        #[inline(always)]
        fn run<S: sism_simd::Simd>(self, s: S) -> u32 {
            s.begin_task(self.0);
            for _ in 0..self.0 {
                s.scalar_op(sism_simd::ScalarClass::Alu);
            }
            s.end_task();
            self.0 * 2
        }
    }

    #[test]
    fn phases_keep_task_order_and_steps_and_list_untimed_work() {
        let mut log = FrameLog::new(Exec::Counting);
        let outs = log.phase("a", "phase a", |p| {
            let first = p.run_par("x", (1..=40u32).into_par_iter().map(Touch));
            let second = p.run_seq("y", [Touch(7)]);
            first.into_iter().chain(second).collect::<Vec<_>>()
        });
        assert_eq!(outs.len(), 41);
        log.phase("b", "phase b", |_| ());
        log.phase("c", "phase c", |p| p.run("", Touch(3)));
        // Kernels with nothing to do: timed (as zero), not untimed.
        log.phase("d", "phase d", |p| p.run_seq("", Vec::<Touch>::new()));
        let r = log.records();
        let names: Vec<&str> = r.iter().map(|p| p.phase.as_str()).collect();
        assert_eq!(names, ["a.x", "a.y", "c"]);
        let kinds: Vec<u32> = r[0].tasks.iter().map(|t| t.kind).collect();
        assert_eq!(kinds, (1..=40).collect::<Vec<_>>());
        assert_eq!(r[0].group(), "a");
        let untimed: Vec<&str> = log.untimed().map(|t| t.name).collect();
        assert_eq!(untimed, ["b"]);
        // Natively nothing is recorded and nothing is called untimed.
        let mut native = FrameLog::new(Exec::Native);
        native.phase("b", "phase b", |p| p.run("", Touch(1)));
        assert!(native.records().is_empty() && native.untimed().next().is_none());
        assert_eq!(native.times()[0].tasks, 1);
    }
}
