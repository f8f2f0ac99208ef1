//! The counting context records each task's critical path as the task executes: a result is as
//! deep as its deepest input plus its latency (`sism_simd::latency`), a task's chains start at the
//! task, and an operation waits for the one `WINDOW` before it to complete.

use sism_simd::{latency, Kernel, Recorder, Simd, WINDOW};

/// `n` operations: on one chain (`dependent`) or each on constants.
struct Adds {
    n: usize,
    dependent: bool,
}
impl Kernel for Adds {
    type Output = f32;
    fn run<S: Simd>(self, s: S) -> f32 {
        let one = s.splat_f(1.0);
        let mut acc = s.splat_f(0.0);
        let mut last = acc;
        s.begin_task(0);
        for _ in 0..self.n {
            if self.dependent {
                acc = s.add_f(acc, one);
            } else {
                last = s.add_f(one, one);
            }
        }
        s.end_task();
        s.extract_f(s.add_f(acc, last), 0)
    }
}

fn path(k: Adds) -> u64 {
    let rec = Recorder::with_lines(false);
    sism_simd::run_counting(&rec, k);
    let tasks = rec.take_tasks();
    tasks[0].counters.critical_path
}

#[test]
fn a_chain_is_as_long_as_its_operations_and_independent_ones_overlap() {
    assert_eq!(
        path(Adds {
            n: 10,
            dependent: true
        }),
        10 * latency::ARITH
    );
    assert_eq!(
        path(Adds {
            n: 10,
            dependent: false
        }),
        latency::ARITH
    );
}

#[test]
fn independent_operations_overlap_only_within_the_window() {
    // Operation i waits for i − WINDOW to retire: ten windows of independent adds take ten
    // latencies.
    assert_eq!(
        path(Adds {
            n: 10 * WINDOW,
            dependent: false
        }),
        10 * latency::ARITH
    );
}

/// Two tasks, the second continuing the first's chain and adding a divide.
struct TwoTasks;
impl Kernel for TwoTasks {
    type Output = f32;
    fn run<S: Simd>(self, s: S) -> f32 {
        let one = s.splat_f(1.0);
        s.begin_task(0);
        let mut acc = one;
        for _ in 0..5 {
            acc = s.fmadd(acc, one, one);
        }
        s.end_task();
        s.begin_task(1);
        let r = s.div_f(acc, one);
        let m = s.cmp_lt_f(r, one);
        // Masks carry no depth: the select is one step past the divide, not past the compare.
        let sel = s.select_f(m, one, r);
        s.end_task();
        s.extract_f(sel, 0)
    }
}

#[test]
fn a_task_counts_only_its_own_chain() {
    let rec = Recorder::with_lines(false);
    sism_simd::run_counting(&rec, TwoTasks);
    let t = rec.take_tasks();
    assert_eq!(t[0].counters.critical_path, 5 * latency::ARITH);
    // The divide's input comes from the previous task: its chain starts at this task. The deepest
    // result is the compare's (the select, one step past the divide, is shallower).
    assert_eq!(
        t[1].counters.critical_path,
        latency::DIV + latency::COMPARE_PERMUTE
    );
}

/// A divide, then independent adds: they retire only after the divide (in order).
struct DivideThenAdds;
impl Kernel for DivideThenAdds {
    type Output = f32;
    fn run<S: Simd>(self, s: S) -> f32 {
        let one = s.splat_f(1.0);
        s.begin_task(0);
        let d = s.div_f(one, one);
        let mut last = one;
        for _ in 0..WINDOW {
            last = s.add_f(one, one);
        }
        s.end_task();
        s.extract_f(s.add_f(d, last), 0)
    }
}

#[test]
fn retirement_is_in_order() {
    let rec = Recorder::with_lines(false);
    sism_simd::run_counting(&rec, DivideThenAdds);
    // The last add waits for the divide's slot, which retires at DIV: DIV + ARITH.
    assert_eq!(
        rec.take_tasks()[0].counters.critical_path,
        latency::DIV + latency::ARITH
    );
}
