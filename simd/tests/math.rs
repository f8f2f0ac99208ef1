//! Accuracy of the math operations against f64 over dense sweeps, asserted
//! against the documented bounds, plus bit-identity across backends.

mod common;
use common::*;
use sism_simd::{
    available, run_with, BackendKind, Kernel, Simd, ACOS_MAX_ABS_ERR, ACOS_MAX_REL_ERR, ASIN_MAX_REL_ERR,
    ATAN2_MAX_ABS_ERR, ATAN2_MAX_REL_ERR,
};
use std::marker::PhantomData;

trait Fun {
    fn f<S: Simd>(s: S, x: S::F32, y: S::F32) -> S::F32;
}
macro_rules! fun {
    ($N:ident, |$s:ident, $x:ident, $y:ident| $e:expr) => {
        struct $N;
        impl Fun for $N {
            #[inline(always)]
            fn f<S: Simd>($s: S, $x: S::F32, $y: S::F32) -> S::F32 {
                let _ = $y;
                $e
            }
        }
    };
}
fun!(Acos, |s, x, y| s.acos_f(x));
fun!(Asin, |s, x, y| s.asin_f(x));
fun!(Atan, |s, x, y| s.atan_f(x));
fun!(Atan2, |s, x, y| s.atan2_f(x, y));
fun!(Sqrt, |s, x, y| s.sqrt_f(x));
fun!(Rcp, |s, x, y| s.rcp_f(x));
fun!(Rsqrt, |s, x, y| s.rsqrt_f(x));
fun!(RcpFast, |s, x, y| s.rcp_fast_f(x));
fun!(RsqrtFast, |s, x, y| s.rsqrt_fast_f(x));

struct Apply<'a, F>(&'a [f32], &'a [f32], PhantomData<F>);
impl<F: Fun> Kernel for Apply<'_, F> {
    type Output = Vec<f32>;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Vec<f32> {
        let n = self.0.len();
        let mut out = vec![0.0f32; n];
        let z = s.splat_f(0.0);
        let mut i = 0;
        while i < n {
            let m = s.mask_first_n(n - i);
            let x = s.mask_load_f(z, m, &self.0[i..]);
            let y = s.mask_load_f(z, m, &self.1[i..]);
            s.mask_store_f(&mut out[i..], m, F::f(s, x, y));
            i += 16;
        }
        out
    }
}

/// Evaluate on every context (counting ones on a prefix only, for speed);
/// assert bit-identity and return the result.
fn eval<F: Fun>(x: &[f32], y: &[f32]) -> Vec<f32> {
    let reference = run_with(BackendKind::Portable, Apply::<F>(x, y, PhantomData));
    for c in contexts() {
        let (xs, ys) = match c {
            Ctx::Counting(_) => (&x[..x.len().min(20_000)], &y[..y.len().min(20_000)]),
            Ctx::Native(_) => (x, y),
        };
        let got = run(c, Apply::<F>(xs, ys, PhantomData));
        for (i, (a, b)) in got.iter().zip(&reference).enumerate() {
            assert!(
                same_f32(*a, *b),
                "{c:?}: lane {i} x={} y={}: {a} vs {b}",
                xs[i],
                ys[i]
            );
        }
    }
    reference
}

#[derive(Default, Debug)]
struct Err {
    abs: f64,
    rel: f64,
    ulp: f64,
    at_abs: f32,
    at_rel: f32,
}
impl Err {
    fn add(&mut self, x: f32, got: f32, want: f64) {
        let e = (got as f64 - want).abs();
        if e > self.abs {
            self.abs = e;
            self.at_abs = x;
        }
        if want != 0.0 {
            let r = e / want.abs();
            if r > self.rel {
                self.rel = r;
                self.at_rel = x;
            }
        } else {
            assert_eq!(got, 0.0);
        }
        let ulp = (want as f32).abs().max(f32::MIN_POSITIVE);
        let ulp = f32::from_bits(ulp.to_bits() + 1) - ulp;
        self.ulp = self.ulp.max(e / ulp as f64);
    }
}

fn acos_inputs() -> Vec<f32> {
    let mut v: Vec<f32> = (0..=4_000_000)
        .map(|i| -1.0 + 2.0 * i as f32 / 4_000_000.0)
        .collect();
    // every float within ~2^-12 of ±1 and of ±0.5 (the two branches)
    for &c in &[1.0f32, 0.5] {
        let mut x = c;
        for _ in 0..40_000 {
            v.push(x);
            v.push(-x);
            x = f32::from_bits(x.to_bits() - 1);
        }
        let mut x = c;
        for _ in 0..40_000 {
            v.push(x);
            v.push(-x);
            x = f32::from_bits(x.to_bits() + 1);
        }
    }
    // tiny values and zeros
    v.extend([0.0, -0.0, 1e-30, -1e-30, 1e-40, 3e-8, -3e-8]);
    v.retain(|x| x.abs() <= 1.0);
    v
}

#[test]
fn acos_accuracy() {
    let x = acos_inputs();
    let out = eval::<Acos>(&x, &x);
    let mut e = Err::default();
    for (&xi, &o) in x.iter().zip(&out) {
        e.add(xi, o, (xi as f64).acos());
    }
    println!("acos over {} inputs: {e:?}", x.len());
    assert!(e.abs <= ACOS_MAX_ABS_ERR as f64, "{e:?}");
    assert!(e.rel <= ACOS_MAX_REL_ERR as f64, "{e:?}");
}

#[test]
fn asin_accuracy() {
    let x = acos_inputs();
    let out = eval::<Asin>(&x, &x);
    let mut e = Err::default();
    for (&xi, &o) in x.iter().zip(&out) {
        e.add(xi, o, (xi as f64).asin());
    }
    println!("asin over {} inputs: {e:?}", x.len());
    assert!(e.abs <= ACOS_MAX_ABS_ERR as f64, "{e:?}");
    assert!(e.rel <= ASIN_MAX_REL_ERR as f64, "{e:?}");
}

#[test]
fn acos_clamps_domain() {
    let x = [
        1.5f32,
        -7.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.0,
        -1.0,
        0.0,
        1.0000001,
    ];
    let out = eval::<Acos>(&x, &x);
    let pi = std::f32::consts::PI;
    assert_eq!(
        out,
        vec![0.0, pi, 0.0, pi, pi, 0.0, pi, std::f32::consts::FRAC_PI_2, 0.0]
    );
}

#[test]
fn atan2_accuracy() {
    let mut ys = Vec::new();
    let mut xs = Vec::new();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for i in 0..2_000_000 {
        let th = -std::f64::consts::PI + 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / 2e6;
        let r = 10f64.powf(rnd() * 12.0 - 6.0);
        ys.push((r * th.sin()) as f32);
        xs.push((r * th.cos()) as f32);
    }
    // near the axes and near ±π (x < 0, tiny y), octant boundaries
    for k in 0..20_000 {
        let t = k as f32 * 1e-5;
        for (y, x) in [
            (t, 1.0),
            (t, -1.0),
            (-t, -1.0),
            (1.0, t),
            (1.0, -t),
            (1.0, 1.0 + t),
            (0.41421357, 1.0 - t),
        ] {
            ys.push(y);
            xs.push(x);
        }
    }
    let out = eval::<Atan2>(&ys, &xs);
    let mut e = Err::default();
    for i in 0..ys.len() {
        e.add(ys[i], out[i], (ys[i] as f64).atan2(xs[i] as f64));
    }
    println!("atan2 over {} inputs: {e:?}", ys.len());
    assert!(e.abs <= ATAN2_MAX_ABS_ERR as f64, "{e:?}");
    assert!(e.rel <= ATAN2_MAX_REL_ERR as f64, "{e:?}");

    let t: Vec<f32> = (0..200_001).map(|i| (i as f32 - 100_000.0) * 1e-3).collect();
    let out = eval::<Atan>(&t, &t);
    let mut e = Err::default();
    for i in 0..t.len() {
        e.add(t[i], out[i], (t[i] as f64).atan());
    }
    println!("atan: {e:?}");
    assert!(
        e.abs <= ATAN2_MAX_ABS_ERR as f64 && e.rel <= ATAN2_MAX_REL_ERR as f64,
        "{e:?}"
    );
}

#[test]
fn atan2_special_cases() {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let inf = f32::INFINITY;
    let cases: &[(f32, f32, f32)] = &[
        (0.0, 0.0, 0.0),
        (-0.0, 0.0, -0.0),
        (0.0, -0.0, PI),
        (-0.0, -0.0, -PI),
        (0.0, -1.0, PI),
        (-0.0, -1.0, -PI),
        (1.0, 0.0, FRAC_PI_2),
        (-1.0, 0.0, -FRAC_PI_2),
        (inf, inf, FRAC_PI_4),
        (-inf, inf, -FRAC_PI_4),
        (inf, -inf, 3.0 * FRAC_PI_4),
        (-inf, -inf, -3.0 * FRAC_PI_4),
        (1.0, inf, 0.0),
        (1.0, -inf, PI),
        (inf, 1.0, FRAC_PI_2),
        (-inf, -5.0, -FRAC_PI_2),
        (1e-45, 1e38, 0.0),
    ];
    let y: Vec<f32> = cases.iter().map(|c| c.0).collect();
    let x: Vec<f32> = cases.iter().map(|c| c.1).collect();
    let out = eval::<Atan2>(&y, &x);
    for (i, c) in cases.iter().enumerate() {
        assert!(
            (out[i] - c.2).abs() <= 4e-7 && out[i].is_sign_negative() == c.2.is_sign_negative(),
            "atan2({}, {}) = {} want {}",
            c.0,
            c.1,
            out[i],
            c.2
        );
    }
    let nan = f32::NAN;
    let out = eval::<Atan2>(&[nan, 1.0, nan], &[1.0, nan, nan]);
    assert!(out.iter().all(|v| v.is_nan()));
}

fn positive_sweep() -> Vec<f32> {
    // log-uniform over the whole positive range incl. denormals, plus specials
    let mut v: Vec<f32> = (0..2_000_000u32).map(|i| f32::from_bits(1 + i * 1065)).collect();
    v.extend([
        0.0,
        -0.0,
        f32::INFINITY,
        f32::MAX,
        f32::MIN_POSITIVE,
        1e-45,
        -1.0,
        f32::NAN,
    ]);
    v
}

#[test]
fn sqrt_rcp_exact() {
    let x = positive_sweep();
    let sq = eval::<Sqrt>(&x, &x);
    let rc = eval::<Rcp>(&x, &x);
    let rs = eval::<Rsqrt>(&x, &x);
    let mut e = Err::default();
    for i in 0..x.len() {
        let xd = x[i] as f64;
        assert!(same_f32(sq[i], xd.sqrt() as f32), "sqrt({})", x[i]);
        assert!(same_f32(rc[i], (1.0 / xd) as f32), "rcp({})", x[i]);
        let want = 1.0 / xd.sqrt();
        if want.is_finite() && x[i] > 0.0 {
            e.add(x[i], rs[i], want);
        } else {
            assert!(same_f32(rs[i], want as f32), "rsqrt({})", x[i]);
        }
    }
    println!("rsqrt_f: {e:?}");
    assert!(
        e.rel <= 2f64.powi(-23),
        "rsqrt_f documented rel error <= 2^-23: {e:?}"
    );
}

#[test]
fn fast_rcp_rsqrt_bounds() {
    let x: Vec<f32> = positive_sweep()
        .into_iter()
        .filter(|v| v.is_finite() && *v >= 1e-37 && *v <= 1e37)
        .collect();
    let backends = [
        BackendKind::Avx512,
        BackendKind::Avx2,
        BackendKind::PortableAvx2,
        BackendKind::Portable,
    ];
    for b in backends.into_iter().filter(|&b| available(b)) {
        let rc = run_with(b, Apply::<RcpFast>(&x, &x, PhantomData));
        let rs = run_with(b, Apply::<RsqrtFast>(&x, &x, PhantomData));
        let (mut e1, mut e2) = (Err::default(), Err::default());
        for i in 0..x.len() {
            let xd = x[i] as f64;
            e1.add(x[i], rc[i], 1.0 / xd);
            e2.add(x[i], rs[i], 1.0 / xd.sqrt());
        }
        println!("{b:?}: rcp_fast {e1:?}\n{b:?}: rsqrt_fast {e2:?}");
        assert!(e1.rel <= 2f64.powi(-22) && e2.rel <= 2f64.powi(-22), "{b:?}");
        // specials
        let sp = [0.0f32, -0.0, f32::INFINITY, f32::NAN, -1.0];
        let rc = run_with(b, Apply::<RcpFast>(&sp, &sp, PhantomData));
        let rs = run_with(b, Apply::<RsqrtFast>(&sp, &sp, PhantomData));
        assert_eq!(rc[0], f32::INFINITY);
        assert_eq!(rc[1], f32::NEG_INFINITY);
        assert_eq!(rc[2], 0.0);
        assert!(rc[3].is_nan());
        assert_eq!(rc[4], -1.0);
        assert_eq!(rs[0], f32::INFINITY);
        assert_eq!(rs[2], 0.0);
        assert!(rs[3].is_nan() && rs[4].is_nan());
    }
}
