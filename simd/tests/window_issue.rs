//! The counting context records each task's windowed issue (`Counters::window_issue`): the sum,
//! over its stretches of `WINDOW` counted operations, of each stretch's nominal issue bound. Work
//! of two port groups done in separate long stretches adds; the same work interleaved overlaps.

use sism_simd::{nominal_issue, Kernel, Recorder, ScalarClass, Simd, WINDOW};

/// `n` vector adds and `n` scalar ALU operations: all the adds then all the scalar operations
/// (`interleaved == false`), or alternating.
struct Mix {
    n: usize,
    interleaved: bool,
}
impl Kernel for Mix {
    type Output = f32;
    fn run<S: Simd>(self, s: S) -> f32 {
        let one = s.splat_f(1.0);
        let mut acc = s.splat_f(0.0);
        s.begin_task(0);
        if self.interleaved {
            for _ in 0..self.n {
                acc = s.add_f(acc, one);
                s.scalar_op(ScalarClass::Alu);
            }
        } else {
            for _ in 0..self.n {
                acc = s.add_f(acc, one);
            }
            for _ in 0..self.n {
                s.scalar_op(ScalarClass::Alu);
            }
        }
        s.end_task();
        s.extract_f(acc, 0)
    }
}

fn counters(k: Mix) -> sism_simd::Counters {
    let rec = Recorder::with_lines(false);
    sism_simd::run_counting(&rec, k);
    rec.take_tasks()[0].counters
}

#[test]
fn separate_stretches_add_and_interleaved_work_overlaps() {
    let n = 10 * WINDOW;
    let apart = counters(Mix {
        n,
        interleaved: false,
    });
    let mixed = counters(Mix { n, interleaved: true });
    // The same operations either way.
    assert_eq!(apart.valu, mixed.valu);
    assert_eq!(apart.scalar_alu, mixed.scalar_alu);
    let whole = nominal_issue(&apart);
    assert_eq!(whole, nominal_issue(&mixed));
    // Apart: each stretch holds one group's work, so the windows see the groups' sum.
    let sum = nominal_issue(&sism_simd::Counters {
        valu: apart.valu,
        ..Default::default()
    }) + nominal_issue(&sism_simd::Counters {
        scalar_alu: apart.scalar_alu,
        ..Default::default()
    });
    assert_eq!(apart.window_issue, sum);
    // Interleaved: every stretch holds both, and the windows see the larger group's bound.
    assert_eq!(mixed.window_issue, whole);
    assert!(apart.window_issue > mixed.window_issue);
}

#[test]
fn a_task_shorter_than_the_window_is_one_stretch() {
    let c = counters(Mix {
        n: WINDOW / 4,
        interleaved: false,
    });
    assert_eq!(c.window_issue, nominal_issue(&c));
}
