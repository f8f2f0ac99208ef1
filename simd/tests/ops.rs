//! Every arithmetic, compare, conversion, reduction and mask operation,
//! property-tested lane by lane against scalar Rust on every backend and
//! on the counting context.

mod common;
use common::*;
use proptest::prelude::*;
use sism_simd::{Mask16, Simd};

#[inline(always)]
fn minf(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}
#[inline(always)]
fn maxf(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}
fn cvtt(x: f32) -> i32 {
    if (-2147483648.0..2147483648.0).contains(&x) {
        x as i32
    } else {
        i32::MIN
    }
}
fn tree<T: Copy>(v: [T; 16], f: impl Fn(T, T) -> T) -> T {
    let mut a = v;
    let mut k = 8;
    while k > 0 {
        for i in 0..k {
            a[i] = f(a[i], a[i + k]);
        }
        k /= 2;
    }
    a[0]
}

macro_rules! f1 {
    ($t:ident, $O:ident, |$s:ident, $a:ident| $v:expr, |$x:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = [f32; 16];
            type Out = [f32; 16];
            fn vec<S: Simd>($s: S, a: [f32; 16]) -> [f32; 16] {
                let $a = $s.from_array_f(a);
                $s.to_array_f($v)
            }
            fn reference(a: [f32; 16]) -> [f32; 16] {
                a.map(|$x| $r)
            }
        }
        proptest! { #[test] fn $t(a in arr_f()) { check::<$O>(a)?; } }
    };
}
macro_rules! f2 {
    ($t:ident, $O:ident, |$s:ident, $a:ident, $b:ident| $v:expr, |$x:ident, $y:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([f32; 16], [f32; 16]);
            type Out = [f32; 16];
            fn vec<S: Simd>($s: S, (a, b): Self::In) -> [f32; 16] {
                let $a = $s.from_array_f(a);
                let $b = $s.from_array_f(b);
                $s.to_array_f($v)
            }
            fn reference((a, b): Self::In) -> [f32; 16] {
                core::array::from_fn(|i| {
                    let ($x, $y) = (a[i], b[i]);
                    $r
                })
            }
        }
        proptest! { #[test] fn $t(a in arr_f(), b in arr_f()) { check::<$O>((a, b))?; } }
    };
}
macro_rules! f3 {
    ($t:ident, $O:ident, |$s:ident, $a:ident, $b:ident, $c:ident| $v:expr, |$x:ident, $y:ident, $z:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([f32; 16], [f32; 16], [f32; 16]);
            type Out = [f32; 16];
            fn vec<S: Simd>($s: S, (a, b, c): Self::In) -> [f32; 16] {
                let $a = $s.from_array_f(a);
                let $b = $s.from_array_f(b);
                let $c = $s.from_array_f(c);
                $s.to_array_f($v)
            }
            fn reference((a, b, c): Self::In) -> [f32; 16] {
                core::array::from_fn(|i| {
                    let ($x, $y, $z) = (a[i], b[i], c[i]);
                    $r
                })
            }
        }
        proptest! { #[test] fn $t(a in arr_f(), b in arr_f(), c in arr_f()) { check::<$O>((a, b, c))?; } }
    };
}
/// Merge-masked binary f32 op: lanes in m get op, others src.
macro_rules! mf2 {
    ($t:ident, $O:ident, |$s:ident, $src:ident, $m:ident, $a:ident, $b:ident| $v:expr, |$x:ident, $y:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([f32; 16], Mask16, [f32; 16], [f32; 16]);
            type Out = [f32; 16];
            fn vec<S: Simd>($s: S, (src, m, a, b): Self::In) -> [f32; 16] {
                let $src = $s.from_array_f(src);
                let $m = m;
                let $a = $s.from_array_f(a);
                let $b = $s.from_array_f(b);
                $s.to_array_f($v)
            }
            fn reference((src, m, a, b): Self::In) -> [f32; 16] {
                core::array::from_fn(|i| if mbit(m, i) { let ($x, $y) = (a[i], b[i]); $r } else { src[i] })
            }
        }
        proptest! { #[test] fn $t(src in arr_f(), m in mask(), a in arr_f(), b in arr_f()) { check::<$O>((src, m, a, b))?; } }
    };
}
macro_rules! fcmp {
    ($t:ident, $O:ident, |$s:ident, $a:ident, $b:ident| $v:expr, |$x:ident, $y:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([f32; 16], [f32; 16]);
            type Out = Mask16;
            fn vec<S: Simd>($s: S, (a, b): Self::In) -> Mask16 {
                let $a = $s.from_array_f(a);
                let $b = $s.from_array_f(b);
                $v
            }
            fn reference((a, b): Self::In) -> Mask16 {
                let mut m = 0u16;
                for i in 0..16 {
                    let ($x, $y) = (a[i], b[i]);
                    m |= ($r as u16) << i;
                }
                Mask16(m)
            }
        }
        proptest! { #[test] fn $t(a in arr_f(), b in arr_f()) { check::<$O>((a, b))?; } }
    };
}
macro_rules! i1 {
    ($t:ident, $O:ident, |$s:ident, $a:ident| $v:expr, |$x:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = [i32; 16];
            type Out = [i32; 16];
            fn vec<S: Simd>($s: S, a: [i32; 16]) -> [i32; 16] {
                let $a = $s.from_array_i(a);
                $s.to_array_i($v)
            }
            fn reference(a: [i32; 16]) -> [i32; 16] {
                a.map(|$x| $r)
            }
        }
        proptest! { #[test] fn $t(a in arr_i()) { check::<$O>(a)?; } }
    };
}
macro_rules! i2 {
    ($t:ident, $O:ident, |$s:ident, $a:ident, $b:ident| $v:expr, |$x:ident, $y:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([i32; 16], [i32; 16]);
            type Out = [i32; 16];
            fn vec<S: Simd>($s: S, (a, b): Self::In) -> [i32; 16] {
                let $a = $s.from_array_i(a);
                let $b = $s.from_array_i(b);
                $s.to_array_i($v)
            }
            fn reference((a, b): Self::In) -> [i32; 16] {
                core::array::from_fn(|i| {
                    let ($x, $y) = (a[i], b[i]);
                    $r
                })
            }
        }
        proptest! { #[test] fn $t(a in arr_i(), b in arr_i()) { check::<$O>((a, b))?; } }
    };
}
macro_rules! ishift {
    ($t:ident, $O:ident, |$s:ident, $a:ident, $n:ident| $v:expr, |$x:ident, $k:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([i32; 16], u32);
            type Out = [i32; 16];
            fn vec<S: Simd>($s: S, (a, n): Self::In) -> [i32; 16] {
                let $a = $s.from_array_i(a);
                let $n = n;
                $s.to_array_i($v)
            }
            fn reference((a, n): Self::In) -> [i32; 16] {
                a.map(|$x| { let $k = n; $r })
            }
        }
        proptest! { #[test] fn $t(a in arr_i(), n in prop_oneof![0u32..40, any::<u32>()]) { check::<$O>((a, n))?; } }
    };
}
macro_rules! icmp {
    ($t:ident, $O:ident, |$s:ident, $a:ident, $b:ident| $v:expr, |$x:ident, $y:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = ([i32; 16], [i32; 16]);
            type Out = Mask16;
            fn vec<S: Simd>($s: S, (a, b): Self::In) -> Mask16 {
                let $a = $s.from_array_i(a);
                let $b = $s.from_array_i(b);
                $v
            }
            fn reference((a, b): Self::In) -> Mask16 {
                let mut m = 0u16;
                for i in 0..16 {
                    let ($x, $y) = (a[i], b[i]);
                    m |= ($r as u16) << i;
                }
                Mask16(m)
            }
        }
        proptest! { #[test] fn $t(a in arr_i(), b in prop_oneof![arr_i(), Just([0; 16]), Just([-1; 16])]) {
            check::<$O>((a, b))?;
            check::<$O>((a, a))?;
        } }
    };
}
macro_rules! fred {
    ($t:ident, $O:ident, |$s:ident, $a:ident| $v:expr, $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = [f32; 16];
            type Out = f32;
            fn vec<S: Simd>($s: S, a: [f32; 16]) -> f32 {
                let $a = $s.from_array_f(a);
                $v
            }
            fn reference(a: [f32; 16]) -> f32 {
                tree(a, $r)
            }
        }
        proptest! { #[test] fn $t(a in arr_f()) { check::<$O>(a)?; } }
    };
}
macro_rules! ired {
    ($t:ident, $O:ident, $T:ty, |$s:ident, $a:ident| $v:expr, |$arr:ident| $r:expr) => {
        struct $O;
        impl Op for $O {
            type In = [i32; 16];
            type Out = $T;
            fn vec<S: Simd>($s: S, a: [i32; 16]) -> $T {
                let $a = $s.from_array_i(a);
                $v
            }
            fn reference($arr: [i32; 16]) -> $T {
                $r
            }
        }
        proptest! { #[test] fn $t(a in arr_i()) { check::<$O>(a)?; } }
    };
}

// ---------------- f32 arithmetic ----------------
f2!(add_f, AddF, |s, a, b| s.add_f(a, b), |x, y| x + y);
f2!(sub_f, SubF, |s, a, b| s.sub_f(a, b), |x, y| x - y);
f2!(mul_f, MulF, |s, a, b| s.mul_f(a, b), |x, y| x * y);
f2!(div_f, DivF, |s, a, b| s.div_f(a, b), |x, y| x / y);
f2!(min_f, MinF, |s, a, b| s.min_f(a, b), |x, y| minf(x, y));
f2!(max_f, MaxF, |s, a, b| s.max_f(a, b), |x, y| maxf(x, y));
f2!(copysign_f, CopysignF, |s, a, b| s.copysign_f(a, b), |x, y| x
    .copysign(y));
f2!(
    mulsign_f,
    MulsignF,
    |s, a, b| s.mulsign_f(a, b),
    |x, y| if y.is_sign_negative() { -x } else { x }
);
f3!(fmadd, Fmadd, |s, a, b, c| s.fmadd(a, b, c), |x, y, z| x
    .mul_add(y, z));
f3!(fmsub, Fmsub, |s, a, b, c| s.fmsub(a, b, c), |x, y, z| x
    .mul_add(y, -z));
f3!(fnmadd, Fnmadd, |s, a, b, c| s.fnmadd(a, b, c), |x, y, z| (-x)
    .mul_add(y, z));
f3!(clamp_f, ClampF, |s, a, b, c| s.clamp_f(a, b, c), |x, y, z| minf(
    maxf(x, y),
    z
));
f3!(lerp_f, LerpF, |s, a, b, c| s.lerp_f(a, b, c), |x, y, z| z
    .mul_add(y - x, x));
f1!(abs_f, AbsF, |s, a| s.abs_f(a), |x| x.abs());
f1!(neg_f, NegF, |s, a| s.neg_f(a), |x| -x);
f1!(sqrt_f, SqrtF, |s, a| s.sqrt_f(a), |x| x.sqrt());
f1!(rcp_f, RcpF, |s, a| s.rcp_f(a), |x| 1.0 / x);
f1!(rsqrt_f, RsqrtF, |s, a| s.rsqrt_f(a), |x| 1.0 / x.sqrt());
f1!(floor_f, FloorF, |s, a| s.floor_f(a), |x| x.floor());
f1!(ceil_f, CeilF, |s, a| s.ceil_f(a), |x| x.ceil());
f1!(trunc_f, TruncF, |s, a| s.trunc_f(a), |x| x.trunc());
f1!(round_f, RoundF, |s, a| s.round_f(a), |x| x.round_ties_even());
f1!(fract_f, FractF, |s, a| s.fract_f(a), |x| x - x.floor());

mf2!(
    mask_add_f,
    MaskAddF,
    |s, src, m, a, b| s.mask_add_f(src, m, a, b),
    |x, y| x + y
);
mf2!(
    mask_sub_f,
    MaskSubF,
    |s, src, m, a, b| s.mask_sub_f(src, m, a, b),
    |x, y| x - y
);
mf2!(
    mask_mul_f,
    MaskMulF,
    |s, src, m, a, b| s.mask_mul_f(src, m, a, b),
    |x, y| x * y
);
mf2!(
    mask_div_f,
    MaskDivF,
    |s, src, m, a, b| s.mask_div_f(src, m, a, b),
    |x, y| x / y
);
mf2!(
    mask_min_f,
    MaskMinF,
    |s, src, m, a, b| s.mask_min_f(src, m, a, b),
    |x, y| minf(x, y)
);
mf2!(
    mask_max_f,
    MaskMaxF,
    |s, src, m, a, b| s.mask_max_f(src, m, a, b),
    |x, y| maxf(x, y)
);
mf2!(
    mask_fmadd,
    MaskFmadd,
    |s, src, m, a, b| s.mask_fmadd(src, m, a, b, a),
    |x, y| x.mul_add(y, x)
);
mf2!(
    mask_sqrt_f,
    MaskSqrtF,
    |s, src, m, a, _b| s.mask_sqrt_f(src, m, a),
    |x, _y| x.sqrt()
);
mf2!(
    select_f,
    SelectF,
    |s, src, m, a, _b| s.select_f(m, a, src),
    |x, _y| x
);

fcmp!(cmp_eq_f, CmpEqF, |s, a, b| s.cmp_eq_f(a, b), |x, y| x == y);
fcmp!(cmp_ne_f, CmpNeF, |s, a, b| s.cmp_ne_f(a, b), |x, y| x != y);
fcmp!(cmp_lt_f, CmpLtF, |s, a, b| s.cmp_lt_f(a, b), |x, y| x < y);
fcmp!(cmp_le_f, CmpLeF, |s, a, b| s.cmp_le_f(a, b), |x, y| x <= y);
fcmp!(cmp_gt_f, CmpGtF, |s, a, b| s.cmp_gt_f(a, b), |x, y| x > y);
fcmp!(cmp_ge_f, CmpGeF, |s, a, b| s.cmp_ge_f(a, b), |x, y| x >= y);
fcmp!(cmp_unord_f, CmpUnordF, |s, a, b| s.cmp_unord_f(a, b), |x, y| x
    .is_nan()
    || y.is_nan());
fcmp!(is_nan_f, IsNanF, |s, a, _b| s.is_nan_f(a), |x, _y| x.is_nan());

fred!(reduce_add_f, ReduceAddF, |s, a| s.reduce_add_f(a), |x, y| x + y);
fred!(reduce_min_f, ReduceMinF, |s, a| s.reduce_min_f(a), minf);
fred!(reduce_max_f, ReduceMaxF, |s, a| s.reduce_max_f(a), maxf);

// ---------------- i32 / u32 ----------------
i2!(add_i, AddI, |s, a, b| s.add_i(a, b), |x, y| x.wrapping_add(y));
i2!(sub_i, SubI, |s, a, b| s.sub_i(a, b), |x, y| x.wrapping_sub(y));
i2!(mul_i, MulI, |s, a, b| s.mul_i(a, b), |x, y| x.wrapping_mul(y));
i2!(and_i, AndI, |s, a, b| s.and_i(a, b), |x, y| x & y);
i2!(or_i, OrI, |s, a, b| s.or_i(a, b), |x, y| x | y);
i2!(xor_i, XorI, |s, a, b| s.xor_i(a, b), |x, y| x ^ y);
i2!(andn_i, AndnI, |s, a, b| s.andn_i(a, b), |x, y| !x & y);
i2!(min_i, MinI, |s, a, b| s.min_i(a, b), |x, y| x.min(y));
i2!(max_i, MaxI, |s, a, b| s.max_i(a, b), |x, y| x.max(y));
i2!(
    min_u,
    MinU,
    |s, a, b| s.min_u(a, b),
    |x, y| (x as u32).min(y as u32) as i32
);
i2!(
    max_u,
    MaxU,
    |s, a, b| s.max_u(a, b),
    |x, y| (x as u32).max(y as u32) as i32
);
i2!(
    shlv_i,
    ShlvI,
    |s, a, b| s.shlv_i(a, b),
    |x, y| if (y as u32) < 32 { x << y } else { 0 }
);
i2!(
    shrv_u,
    ShrvU,
    |s, a, b| s.shrv_u(a, b),
    |x, y| if (y as u32) < 32 {
        ((x as u32) >> y) as i32
    } else {
        0
    }
);
i2!(shrv_i, ShrvI, |s, a, b| s.shrv_i(a, b), |x, y| x
    >> (y as u32).min(31));
i1!(abs_i, AbsI, |s, a| s.abs_i(a), |x| x.wrapping_abs());
i1!(not_i, NotI, |s, a| s.not_i(a), |x| !x);
i1!(neg_i, NegI, |s, a| s.neg_i(a), |x| x.wrapping_neg());
ishift!(shl_i, ShlI, |s, a, n| s.shl_i(a, n), |x, n| if n < 32 {
    x << n
} else {
    0
});
ishift!(shr_u, ShrU, |s, a, n| s.shr_u(a, n), |x, n| if n < 32 {
    ((x as u32) >> n) as i32
} else {
    0
});
ishift!(shr_i, ShrI, |s, a, n| s.shr_i(a, n), |x, n| x >> n.min(31));

icmp!(cmp_eq_i, CmpEqI, |s, a, b| s.cmp_eq_i(a, b), |x, y| x == y);
icmp!(cmp_ne_i, CmpNeI, |s, a, b| s.cmp_ne_i(a, b), |x, y| x != y);
icmp!(cmp_lt_i, CmpLtI, |s, a, b| s.cmp_lt_i(a, b), |x, y| x < y);
icmp!(cmp_le_i, CmpLeI, |s, a, b| s.cmp_le_i(a, b), |x, y| x <= y);
icmp!(cmp_gt_i, CmpGtI, |s, a, b| s.cmp_gt_i(a, b), |x, y| x > y);
icmp!(cmp_ge_i, CmpGeI, |s, a, b| s.cmp_ge_i(a, b), |x, y| x >= y);
icmp!(cmp_lt_u, CmpLtU, |s, a, b| s.cmp_lt_u(a, b), |x, y| (x as u32)
    < (y as u32));
icmp!(cmp_le_u, CmpLeU, |s, a, b| s.cmp_le_u(a, b), |x, y| (x as u32)
    <= (y as u32));
icmp!(cmp_gt_u, CmpGtU, |s, a, b| s.cmp_gt_u(a, b), |x, y| (x as u32)
    > (y as u32));
icmp!(cmp_ge_u, CmpGeU, |s, a, b| s.cmp_ge_u(a, b), |x, y| (x as u32)
    >= (y as u32));
icmp!(test_i, TestI, |s, a, b| s.test_i(a, b), |x, y| x & y != 0);

ired!(reduce_add_i, ReduceAddI, i32, |s, a| s.reduce_add_i(a), |v| v
    .iter()
    .fold(0i32, |a, &b| a.wrapping_add(b)));
ired!(reduce_min_i, ReduceMinI, i32, |s, a| s.reduce_min_i(a), |v| *v
    .iter()
    .min()
    .unwrap());
ired!(reduce_max_i, ReduceMaxI, i32, |s, a| s.reduce_max_i(a), |v| *v
    .iter()
    .max()
    .unwrap());
ired!(reduce_min_u, ReduceMinU, u32, |s, a| s.reduce_min_u(a), |v| v
    .iter()
    .map(|&x| x as u32)
    .min()
    .unwrap());
ired!(reduce_max_u, ReduceMaxU, u32, |s, a| s.reduce_max_u(a), |v| v
    .iter()
    .map(|&x| x as u32)
    .max()
    .unwrap());
ired!(reduce_or_i, ReduceOrI, i32, |s, a| s.reduce_or_i(a), |v| v
    .iter()
    .fold(0, |a, &b| a | b));
ired!(reduce_and_i, ReduceAndI, i32, |s, a| s.reduce_and_i(a), |v| v
    .iter()
    .fold(-1, |a, &b| a & b));
ired!(
    conflict_i,
    ConflictI,
    [i32; 16],
    |s, a| s.to_array_i(s.conflict_i(a)),
    |v| core::array::from_fn(|i| (0..i).filter(|&j| v[j] == v[i]).map(|j| 1 << j).sum())
);

// conflict with many collisions
proptest! {
    #[test]
    fn conflict_i_collisions(a in prop::array::uniform16(0i32..4)) { check::<ConflictI>(a)?; }
}

// ---------------- conversions ----------------
struct CvtIF;
impl Op for CvtIF {
    type In = [i32; 16];
    type Out = ([f32; 16], [f32; 16]);
    fn vec<S: Simd>(s: S, a: [i32; 16]) -> Self::Out {
        let v = s.from_array_i(a);
        (s.to_array_f(s.cvt_i_f(v)), s.to_array_f(s.cvt_u_f(v)))
    }
    fn reference(a: [i32; 16]) -> Self::Out {
        (a.map(|x| x as f32), a.map(|x| x as u32 as f32))
    }
}
proptest! { #[test] fn cvt_i_f_u_f(a in arr_i()) { check::<CvtIF>(a)?; } }

struct CvtFI;
impl Op for CvtFI {
    type In = [f32; 16];
    type Out = ([i32; 16], [i32; 16], [i32; 16]);
    fn vec<S: Simd>(s: S, a: [f32; 16]) -> Self::Out {
        let v = s.from_array_f(a);
        (
            s.to_array_i(s.cvtt_f_i(v)),
            s.to_array_i(s.cvtr_f_i(v)),
            s.to_array_i(s.floor_i(v)),
        )
    }
    fn reference(a: [f32; 16]) -> Self::Out {
        (
            a.map(cvtt),
            a.map(|x| cvtt(x.round_ties_even())),
            a.map(|x| cvtt(x.floor())),
        )
    }
}
proptest! { #[test] fn cvtt_cvtr_floor_i(a in arr_f()) { check::<CvtFI>(a)?; } }

struct Casts;
impl Op for Casts {
    type In = [i32; 16];
    type Out = ([i32; 16], [f32; 16]);
    fn vec<S: Simd>(s: S, a: [i32; 16]) -> Self::Out {
        let f = s.cast_i_f(s.from_array_i(a));
        (s.to_array_i(s.cast_f_i(f)), s.to_array_f(f))
    }
    fn reference(a: [i32; 16]) -> Self::Out {
        (a, a.map(|x| f32::from_bits(x as u32)))
    }
}
proptest! { #[test] fn casts(a in arr_i()) { check::<Casts>(a)?; } }

// ---------------- lanes, permutes, compress/expand ----------------
struct Lanes;
impl Op for Lanes {
    type In = ([f32; 16], [i32; 16], [i32; 16], f32, i32);
    type Out = ([f32; 16], [i32; 16], [i32; 16], [f32; 16], ([f32; 16], [i32; 16]));
    fn vec<S: Simd>(s: S, (a, b, idx, x, y): Self::In) -> Self::Out {
        let va = s.from_array_f(a);
        let vb = s.from_array_i(b);
        let vi = s.from_array_i(idx);
        let ex: [f32; 16] = core::array::from_fn(|l| s.extract_f(va, l));
        let ey: [i32; 16] = core::array::from_fn(|l| s.extract_i(vb, l));
        (
            s.to_array_f(s.permute_f(va, vi)),
            s.to_array_i(s.permute_i(vb, vi)),
            s.to_array_i(s.add_i(s.index_i(), s.splat_i(y))),
            s.to_array_f(s.add_f(s.splat_f(x), s.splat_f(0.0))),
            (ex, ey),
        )
    }
    fn reference((a, b, idx, x, y): Self::In) -> Self::Out {
        (
            core::array::from_fn(|i| a[(idx[i] & 15) as usize]),
            core::array::from_fn(|i| b[(idx[i] & 15) as usize]),
            core::array::from_fn(|i| (i as i32).wrapping_add(y)),
            [x + 0.0; 16],
            (a, b),
        )
    }
}
proptest! { #[test] fn lanes_permute_splat_index(a in arr_f(), b in arr_i(), idx in arr_i(), x in f32_any(), y in i32_any()) {
    check::<Lanes>((a, b, idx, x, y))?;
} }

struct CompressExpand;
impl Op for CompressExpand {
    type In = (Mask16, [f32; 16], [i32; 16]);
    type Out = ([f32; 16], [i32; 16], [f32; 16], [i32; 16]);
    fn vec<S: Simd>(s: S, (m, a, b): Self::In) -> Self::Out {
        let va = s.from_array_f(a);
        let vb = s.from_array_i(b);
        (
            s.to_array_f(s.compress_f(m, va)),
            s.to_array_i(s.compress_i(m, vb)),
            s.to_array_f(s.expand_f(m, va)),
            s.to_array_i(s.expand_i(m, vb)),
        )
    }
    fn reference((m, a, b): Self::In) -> Self::Out {
        let mut cf = [0.0; 16];
        let mut ci = [0; 16];
        let mut ef = [0.0; 16];
        let mut ei = [0; 16];
        let mut n = 0;
        for i in 0..16 {
            if mbit(m, i) {
                cf[n] = a[i];
                ci[n] = b[i];
                ef[i] = a[n];
                ei[i] = b[n];
                n += 1;
            }
        }
        (cf, ci, ef, ei)
    }
}
proptest! { #[test] fn compress_expand_reg(m in mask(), a in arr_f(), b in arr_i()) { check::<CompressExpand>((m, a, b))?; } }

struct MaskedI;
impl Op for MaskedI {
    type In = ([i32; 16], Mask16, [i32; 16], [i32; 16]);
    type Out = ([i32; 16], [i32; 16], [i32; 16]);
    fn vec<S: Simd>(s: S, (src, m, a, b): Self::In) -> Self::Out {
        let (vs, va, vb) = (s.from_array_i(src), s.from_array_i(a), s.from_array_i(b));
        (
            s.to_array_i(s.mask_add_i(vs, m, va, vb)),
            s.to_array_i(s.mask_sub_i(vs, m, va, vb)),
            s.to_array_i(s.select_i(m, va, vb)),
        )
    }
    fn reference((src, m, a, b): Self::In) -> Self::Out {
        (
            core::array::from_fn(|i| {
                if mbit(m, i) {
                    a[i].wrapping_add(b[i])
                } else {
                    src[i]
                }
            }),
            core::array::from_fn(|i| {
                if mbit(m, i) {
                    a[i].wrapping_sub(b[i])
                } else {
                    src[i]
                }
            }),
            core::array::from_fn(|i| if mbit(m, i) { a[i] } else { b[i] }),
        )
    }
}
proptest! { #[test] fn masked_i(src in arr_i(), m in mask(), a in arr_i(), b in arr_i()) { check::<MaskedI>((src, m, a, b))?; } }

// ---------------- masks ----------------
struct MaskOps;
impl Op for MaskOps {
    type In = (Mask16, Mask16, usize);
    type Out = ([Mask16; 6], (u32, bool), (bool, Option<u32>));
    fn vec<S: Simd>(s: S, (a, b, n): Self::In) -> Self::Out {
        (
            [
                s.mask_and(a, b),
                s.mask_or(a, b),
                s.mask_xor(a, b),
                s.mask_andn(a, b),
                s.mask_not(a),
                s.mask_first_n(n),
            ],
            (s.mask_popcnt(a), s.mask_any(a)),
            (s.mask_all(a), s.mask_first(a)),
        )
    }
    fn reference((a, b, n): Self::In) -> Self::Out {
        let first_n = if n >= 16 { 0xFFFF } else { (1u16 << n) - 1 };
        (
            [
                Mask16(a.0 & b.0),
                Mask16(a.0 | b.0),
                Mask16(a.0 ^ b.0),
                Mask16(!a.0 & b.0),
                Mask16(!a.0),
                Mask16(first_n),
            ],
            (a.0.count_ones(), a.0 != 0),
            (a.0 == 0xFFFF, (0..16).find(|&i| mbit(a, i as usize))),
        )
    }
}
proptest! { #[test] fn mask_ops(a in mask(), b in mask(), n in 0usize..40) { check::<MaskOps>((a, b, n))?; } }

#[test]
fn mask16_helpers() {
    let m = Mask16(0b1010_0000_0000_0110);
    assert_eq!(m.iter().collect::<Vec<_>>(), vec![1, 2, 13, 15]);
    assert_eq!(m.first(), Some(1));
    assert_eq!(m.last(), Some(15));
    assert_eq!(Mask16::NONE.last(), None);
    assert!(m.test(13) && !m.test(14) && !m.test(99));
    assert_eq!(Mask16::first_n(0), Mask16::NONE);
    assert_eq!(Mask16::first_n(16), Mask16::ALL);
}

// ---------------- edge values, explicitly ----------------
#[test]
fn min_max_nan_and_zero_semantics() {
    // x86 minps/maxps: second operand when unordered or both zero.
    let nan = f32::NAN;
    let a = [
        nan,
        1.0,
        -0.0,
        0.0,
        nan,
        f32::INFINITY,
        -1.0e-40,
        3.0,
        0.,
        0.,
        0.,
        0.,
        0.,
        0.,
        0.,
        0.,
    ];
    let b = [
        1.0,
        nan,
        0.0,
        -0.0,
        nan,
        nan,
        1.0e-40,
        f32::NEG_INFINITY,
        0.,
        0.,
        0.,
        0.,
        0.,
        0.,
        0.,
        0.,
    ];
    check::<MinF>((a, b)).unwrap();
    check::<MaxF>((a, b)).unwrap();
    let r = MinF::reference((a, b));
    assert_eq!(r[0], 1.0); // min(NaN, 1) = 1
    assert!(r[1].is_nan()); // min(1, NaN) = NaN
    assert!(r[2].to_bits() == 0.0f32.to_bits()); // min(-0, +0) = +0 (second)
    assert!(r[3].to_bits() == (-0.0f32).to_bits());
    check::<ReduceMinF>(a).unwrap();
    check::<ReduceMaxF>(b).unwrap();
}

#[test]
fn special_value_sweep() {
    // All pairs of specials through every binary op.
    let sp = SPECIALS;
    let mut pairs = Vec::new();
    for &x in sp {
        for &y in sp {
            pairs.push((x, y));
        }
    }
    for chunk in pairs.chunks(16) {
        let mut a = [0.0f32; 16];
        let mut b = [0.0f32; 16];
        for (i, &(x, y)) in chunk.iter().enumerate() {
            a[i] = x;
            b[i] = y;
        }
        check::<AddF>((a, b)).unwrap();
        check::<SubF>((a, b)).unwrap();
        check::<MulF>((a, b)).unwrap();
        check::<DivF>((a, b)).unwrap();
        check::<MinF>((a, b)).unwrap();
        check::<MaxF>((a, b)).unwrap();
        check::<CmpLtF>((a, b)).unwrap();
        check::<CmpNeF>((a, b)).unwrap();
        check::<Fmadd>((a, b, a)).unwrap();
        check::<SqrtF>(a).unwrap();
        check::<RcpF>(a).unwrap();
        check::<RsqrtF>(a).unwrap();
        check::<FloorF>(a).unwrap();
        check::<RoundF>(a).unwrap();
        check::<CvtFI>(a).unwrap();
    }
}
