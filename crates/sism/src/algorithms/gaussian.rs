//! Multi-pass Gaussian contact-hardening soft shadows (Cherry et al., GRAPP 2015): a hard shadow test
//! and an occluder distance per pixel, then screen-space blurs sized by that distance, so shadows
//! harden where the occluder touches the receiver. Three variants, as the paper's pass 4:
//!
//! * `gaussian-pcf`: a box filter of `S` of side `2·round(D) + 1` (1–19 pixels);
//! * `gaussian-single`: one Gaussian of `S`, side `2·round(D) + 1` (1–19), `σ = side / 3`, every pixel
//!   of the kernel a tap;
//! * `gaussian-multi`: up to `passes` (1–10) blurs where `D > 0`, `D` decremented by one after each;
//!   the kernel `KS` fixed, or widening 3, 5, 7, … up to `kernel`; the taps are the first `taps` (≤ 64)
//!   points of a Poisson disk in `[−1, 1]²` whose first point is `(0, 0)`, at pixel offsets
//!   `round(P_i · KS / 2)` (so the kernel spans `KS` pixels), weighted by a Gaussian of `σ = KS / 3`
//!   and normalised.
//!
//! Passes (phases): `light_samples` and `depth_map` (the shadow-map family's, from the light centre),
//! `distance_map` (per receiver `S ∈ {0, 1}` and `D = (occluder distance)^Dp · Dm`, pixels), then
//! the screen passes: optional `dilate` (a Gaussian of `D`, side `dilate`), optional `umbra_skip`
//! (`D = 0` where the pixel and its 8 neighbours are all shadowed), and the variant's blur(s). `V` is
//! `1 − S`. Pixels seeing nothing are lit (`S = 0`), receivers facing away shadowed (`S = 1`), both
//! with `D = 0` and never written. All passes are kernels, 16 pixels a vector.
//!
//! `Dp` and `Dm` have no physical meaning: their defaults are fitted once on `scenes/sphere.toml`
//! (see the README, "Contact-hardening soft shadows"), never on a scene the figures report.

use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use super::params::{ChoiceParam, FloatParam, IntParam};
use super::shadow_map::{self as sm, lookup::Method as MapMethod};
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use crate::counted;
use crate::exec::{task_kind, FrameLog};
use crate::frame::V_FACING_AWAY;
use crate::stats::StatsReport;

/// Largest kernel side, pixels (the paper's 19).
pub const MAX_KERNEL: u32 = 19;
/// Rows of the image per screen-pass task.
const ROWS_PER_TASK: usize = 16;

crate::declare_stats! {
    /// Counters of a contact-hardening frame.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct GaussianStats {
        /// Receivers the hard test shadows.
        pub shadowed: u64 => ("gaussian.shadowed", "pixels", "receivers the hard test shadows (S = 1)"),
        /// Blur passes run (the variant's; dilation and umbra skip not included).
        pub passes: u64 => ("gaussian.passes", "passes", "blur passes run"),
        /// Taps of the blurs, summed over passes and pixels.
        pub taps: u64 => ("gaussian.taps", "taps", "blur taps (reads of S) over all passes and pixels"),
        /// Taps per receiver pixel (mean).
        pub taps_per_pixel: f64 => ("gaussian.taps_per_pixel", "taps", "blur taps per receiver pixel (mean over all passes)"),
        /// Pixels whose D the umbra-skip pass set to 0.
        pub umbra_skipped: u64 => ("gaussian.umbra_skipped", "pixels", "pixels set to D = 0 by the umbra-skip pass (all 8 neighbours shadowed)"),
    }
}

/// `distance_power` (Dp), with `gaussian-pcf`'s default; each variant declares its own fitted one.
const DISTANCE_POWER: FloatParam = FloatParam::new(ParamSpec {
    key: "distance_power",
    kind: ParamKind::Float { min: 0.01, max: 8.0 },
    default: "2",
    description:
        "Dp: D = (occluder distance)^Dp · Dm, pixels (default fitted on scenes/sphere.toml at 800×600)",
});
/// `distance_multiplier` (Dm), with `gaussian-pcf`'s default; each variant declares its own fitted one.
const DISTANCE_MULTIPLIER: FloatParam = FloatParam::new(ParamSpec {
    key: "distance_multiplier",
    kind: ParamKind::Float { min: 0.0, max: 1e6 },
    default: "10",
    description:
        "Dm: pixels of D per unit of (occluder distance)^Dp (default fitted on scenes/sphere.toml at 800×600)",
});
/// `distance_power` (Dp) with a variant's fitted default.
const fn dp(default: &'static str) -> ParamSpec {
    DISTANCE_POWER.with_default(default).spec()
}
/// `distance_multiplier` (Dm) with a variant's fitted default.
const fn dm(default: &'static str) -> ParamSpec {
    DISTANCE_MULTIPLIER.with_default(default).spec()
}
const DILATE: IntParam = IntParam::new(ParamSpec {
    key: "dilate",
    kind: ParamKind::Int { min: 0, max: 19 },
    default: "0",
    description: "side of the Gaussian that dilates D before the blurs, pixels (0: off; odd)",
});
const UMBRA_SKIP: ChoiceParam<bool> = ChoiceParam::new(
    ParamSpec {
        key: "umbra_skip",
        kind: ParamKind::Choice(&["no", "yes"]),
        default: "no",
        description: "yes: D = 0 where a pixel and all 8 neighbours are shadowed (no blur inside umbrae)",
    },
    &[false, true],
);

// Fitted defaults (`cargo run --release --example fit_contact_hardening -- scenes/sphere.toml 800 600`):
// pcf Dp 2, Dm 10 (MAE 0.0123); single Dp 1.5, Dm 10 (0.0128); multi Dp 6, Dm 2 (0.0122).
const PCF_PARAMS: [ParamSpec; 7] = [
    sm::MAP_PARAMS[0],
    sm::MAP_PARAMS[1],
    sm::MAP_PARAMS[2],
    dp("2"),
    dm("10"),
    DILATE.spec(),
    UMBRA_SKIP.spec(),
];
const SINGLE_PARAMS: [ParamSpec; 7] = [
    sm::MAP_PARAMS[0],
    sm::MAP_PARAMS[1],
    sm::MAP_PARAMS[2],
    dp("1.5"),
    dm("10"),
    DILATE.spec(),
    UMBRA_SKIP.spec(),
];
const PASSES: IntParam = IntParam::new(ParamSpec {
    key: "passes",
    kind: ParamKind::Int { min: 1, max: 10 },
    default: "10",
    description: "most blur passes (D decremented by 1 after each)",
});
const KERNEL: IntParam = IntParam::new(ParamSpec {
    key: "kernel",
    kind: ParamKind::OddInt { min: 3, max: 19 },
    default: "9",
    description: "kernel side KS, pixels (the widening kernel's upper bound)",
});
const WIDENING: ChoiceParam<bool> = ChoiceParam::new(
    ParamSpec {
        key: "widening",
        kind: ParamKind::Choice(&["no", "yes"]),
        default: "no",
        description: "yes: KS = 3, 5, 7, ... up to kernel, one step per pass",
    },
    &[false, true],
);
const TAPS: IntParam = IntParam::new(ParamSpec {
    key: "taps",
    kind: ParamKind::Int { min: 1, max: 64 },
    default: "20",
    description: "Poisson taps per pass (the first at the centre)",
});
const MULTI_PARAMS: [ParamSpec; 11] = [
    sm::MAP_PARAMS[0],
    sm::MAP_PARAMS[1],
    sm::MAP_PARAMS[2],
    dp("6"),
    dm("2"),
    DILATE.spec(),
    UMBRA_SKIP.spec(),
    PASSES.spec(),
    KERNEL.spec(),
    WIDENING.spec(),
    TAPS.spec(),
];

macro_rules! gaussian_algorithm {
    ($name:ident, $key:literal, $summary:literal, $params:expr, $variant:expr) => {
        #[doc = concat!("`", $key, "`: ", $summary)]
        pub static $name: super::Algorithm = super::Algorithm {
            name: $key,
            family: Family::ShadowMap,
            summary: $summary,
            params: $params,
            receivers: ReceiverSource::Raster,
            kernels: true,
            bench: BenchPlan::Defaults,
            run: |inputs, params, log| run(inputs, params, log, $variant),
        };
    };
}

gaussian_algorithm!(
    GAUSSIAN_PCF,
    "gaussian-pcf",
    "contact-hardening (Cherry 2015): the hard test's S box-filtered over 2·round(D)+1 pixels, D from the occluder distance",
    &PCF_PARAMS,
    Variant::Pcf
);
gaussian_algorithm!(
    GAUSSIAN_SINGLE,
    "gaussian-single",
    "contact-hardening (Cherry 2015): one Gaussian of S sized by D (side 2·round(D)+1, sigma = side/3)",
    &SINGLE_PARAMS,
    Variant::Single
);
gaussian_algorithm!(
    GAUSSIAN_MULTI,
    "gaussian-multi",
    "contact-hardening (Cherry 2015): up to 10 Poisson-tap Gaussian blurs where D > 0, D decremented each pass",
    &MULTI_PARAMS,
    Variant::Multi
);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    Pcf,
    Single,
    Multi,
}

/// The taps of one multi-pass blur: `taps` Poisson points (the first `(0, 0)`) at offsets
/// `round(P · ks / 2)`, with normalised Gaussian weights of `σ = ks / 3`.
pub fn multi_pass_taps(ks: u32, taps: usize) -> Vec<(i32, i32, f32)> {
    let points = sm::lookup::poisson_disk(64);
    let mut pts: Vec<glam::Vec2> = vec![glam::Vec2::ZERO];
    pts.extend(points.into_iter().filter(|p| *p != glam::Vec2::ZERO));
    // The family's Poisson disk lies in the unit disk, so inside the paper's range [−1, 1]².
    let half = ks as f32 / 2.0;
    let sigma = ks as f32 / 3.0;
    let mut out: Vec<(i32, i32, f32)> = pts
        .iter()
        .take(taps)
        .map(|p| {
            let (dx, dy) = ((p.x * half).round() as i32, (p.y * half).round() as i32);
            let r2 = (dx * dx + dy * dy) as f32;
            (dx, dy, (-r2 / (2.0 * sigma * sigma)).exp())
        })
        .collect();
    let total: f32 = out.iter().map(|t| t.2).sum();
    out.iter_mut().for_each(|t| t.2 /= total);
    out
}

/// Per kernel radius `r` (0..=9, side `2r + 1`), the normalised Gaussian weights (`σ = side / 3`) of
/// every offset of the 19×19 window, row-major from `(−9, −9)`; 0 outside the kernel.
fn gaussian_table() -> Vec<f32> {
    let h = (MAX_KERNEL / 2) as i32;
    let w = MAX_KERNEL as usize;
    let mut t = vec![0f32; (h as usize + 1) * w * w];
    for r in 0..=h {
        let sigma = (2 * r + 1) as f32 / 3.0;
        let base = r as usize * w * w;
        let mut total = 0.0;
        for dy in -r..=r {
            for dx in -r..=r {
                let v = (-((dx * dx + dy * dy) as f32) / (2.0 * sigma * sigma)).exp();
                t[base + ((dy + h) as usize) * w + (dx + h) as usize] = v;
                total += v;
            }
        }
        for v in &mut t[base..base + w * w] {
            *v /= total;
        }
    }
    t
}

/// The distance-map image: `S` and `D` per pixel, and which pixels are receivers facing the light.
struct Screen {
    width: usize,
    height: usize,
    s: Vec<f32>,
    d: Vec<f32>,
    receiver: Vec<bool>,
}

fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog, variant: Variant) -> AlgorithmFrame {
    let (dp, dm) = (
        params.get(&DISTANCE_POWER) as f32,
        params.get(&DISTANCE_MULTIPLIER) as f32,
    );
    let (visibility, map_stats, per_sample) = sm::map_frame(
        inputs,
        params,
        log,
        "distance map: the hard test and the occluder distance per receiver",
        |p, maps, samples, shift, values| {
            sm::lookups(
                p,
                maps,
                samples,
                &inputs.receivers.pixels,
                shift,
                &MapMethod::OccluderDistance,
                values,
            );
            // (pixel, −1 if lit else the occluder distance) per receiver facing the light.
            samples
                .iter()
                .zip(values.iter())
                .map(|(smp, &v)| (smp.pixel, v))
                .collect::<Vec<_>>()
        },
    );
    let width = visibility.width as usize;
    let height = visibility.height as usize;
    // The distance map: S = 1 and D = distance^Dp · Dm where the hard test shadows a receiver;
    // receivers facing away are shadowed with D = 0; pixels seeing nothing are lit.
    let mut scr = Screen {
        width,
        height,
        s: vec![0.0; width * height],
        d: vec![0.0; width * height],
        receiver: vec![false; width * height],
    };
    let mut stats = GaussianStats::default();
    for (k, &v) in visibility.values.iter().enumerate() {
        if v == V_FACING_AWAY {
            scr.s[k] = 1.0;
        }
    }
    for &(pixel, v) in &per_sample {
        let k = pixel as usize;
        scr.receiver[k] = true;
        scr.s[k] = 0.0;
        if v >= 0.0 {
            scr.s[k] = 1.0;
            scr.d[k] = v.powf(dp) * dm;
            stats.shadowed += 1;
        }
    }
    let receivers = scr.receiver.iter().filter(|&&r| r).count() as u64;
    log.phase(
        "screen",
        "screen-space passes: dilation, umbra skip, blurs",
        |p| {
            // A frame with nothing to blur runs no pass: timed as zero, not as untimed host work.
            p.skip();
            let dilate = params.get(&DILATE) as u32;
            if dilate > 1 {
                let table = gaussian_table();
                let r = (dilate / 2) as f32;
                let radius = vec![r; width * height];
                let src = scr.d.clone();
                if let Some((out, _)) =
                    run_pass(p, "dilate", &scr, &src, &radius, &PassTaps::Table(&table), None)
                {
                    scr.d = out;
                }
            }
            if params.get(&UMBRA_SKIP) {
                let src = scr.d.clone();
                let (out, skipped) = umbra_skip(p, &scr, &src);
                scr.d = out;
                stats.umbra_skipped = skipped;
            }
            let zero_radius = |d: &[f32]| -> Vec<f32> {
                d.iter()
                    .map(|&d| d.round().clamp(0.0, (MAX_KERNEL / 2) as f32))
                    .collect()
            };
            match variant {
                Variant::Pcf | Variant::Single => {
                    let radius = zero_radius(&scr.d);
                    let table = if variant == Variant::Single {
                        gaussian_table()
                    } else {
                        box_table()
                    };
                    let src = scr.s.clone();
                    if let Some((out, taps)) = run_pass(
                        p,
                        "blur",
                        &scr,
                        &src,
                        &radius,
                        &PassTaps::Table(&table),
                        Some(&scr.receiver),
                    ) {
                        scr.s = out;
                        stats.taps += taps;
                    }
                    stats.passes = 1;
                }
                Variant::Multi => {
                    let passes = params.get(&PASSES) as u32;
                    let kernel = params.get(&KERNEL) as u32;
                    let widening = params.get(&WIDENING);
                    let n_taps = params.get(&TAPS) as usize;
                    for pass in 0..passes {
                        if !scr.d.iter().zip(&scr.receiver).any(|(&d, &r)| r && d > 0.0) {
                            break;
                        }
                        let ks = if widening {
                            (3 + 2 * pass).min(kernel)
                        } else {
                            kernel
                        };
                        let taps = multi_pass_taps(ks, n_taps);
                        // Pixels with D > 0 are blurred (radius 1 marks them), the rest kept.
                        let active: Vec<f32> =
                            scr.d.iter().map(|&d| if d > 0.0 { 1.0 } else { 0.0 }).collect();
                        let src = scr.s.clone();
                        if let Some((out, t)) = run_pass(
                            p,
                            "blur",
                            &scr,
                            &src,
                            &active,
                            &PassTaps::Fixed(&taps),
                            Some(&scr.receiver),
                        ) {
                            scr.s = out;
                            stats.taps += t;
                        }
                        scr.d.iter_mut().for_each(|d| *d = (*d - 1.0).max(0.0));
                        stats.passes += 1;
                    }
                }
            }
        },
    );
    stats.taps_per_pixel = if receivers == 0 {
        0.0
    } else {
        stats.taps as f64 / receivers as f64
    };
    let mut image = visibility;
    for (k, v) in image.values.iter_mut().enumerate() {
        if scr.receiver[k] {
            *v = (1.0 - scr.s[k]).clamp(0.0, 1.0);
        }
    }
    let mut out = StatsReport::default();
    out.rows(&map_stats).rows(&stats);
    AlgorithmFrame {
        visibility: image,
        stats: out,
    }
}

/// A box filter as a table like [`gaussian_table`]: uniform weights inside each radius.
fn box_table() -> Vec<f32> {
    let h = (MAX_KERNEL / 2) as i32;
    let w = MAX_KERNEL as usize;
    let mut t = vec![0f32; (h as usize + 1) * w * w];
    for r in 0..=h {
        let base = r as usize * w * w;
        let v = 1.0 / ((2 * r + 1) * (2 * r + 1)) as f32;
        for dy in -r..=r {
            for dx in -r..=r {
                t[base + ((dy + h) as usize) * w + (dx + h) as usize] = v;
            }
        }
    }
    t
}

/// Where a pass's taps come from.
enum PassTaps<'a> {
    /// Per pixel radius `r` (the pass's `radius` image, 0..=9): the table's weights for `r`.
    Table(&'a [f32]),
    /// The same taps for every pixel whose `radius` is > 0 (the others are copied).
    Fixed(&'a [(i32, i32, f32)]),
}

/// One screen pass over `src`: per pixel (only `only`'s pixels when given; the others copied) the
/// weighted sum of `src` at the taps, offsets clamped to the image. Returns the new image and the
/// taps read; `None` when the frame has no pixel.
#[allow(clippy::too_many_arguments)]
fn run_pass(
    p: &mut crate::exec::Phase,
    step: &str,
    scr: &Screen,
    src: &[f32],
    radius: &[f32],
    taps: &PassTaps<'_>,
    only: Option<&[bool]>,
) -> Option<(Vec<f32>, u64)> {
    if scr.width == 0 || scr.height == 0 {
        return None;
    }
    let mut out = src.to_vec();
    let w = scr.width;
    let counts = p.run_par(
        step,
        out.par_chunks_mut(w * ROWS_PER_TASK)
            .enumerate()
            .map(|(t, rows)| ScreenPass {
                first_row: t * ROWS_PER_TASK,
                width: w,
                height: scr.height,
                src,
                radius,
                taps,
                only,
                out: rows,
            }),
    );
    Some((out, counts.iter().sum()))
}

/// A band of rows of one screen pass.
struct ScreenPass<'a> {
    first_row: usize,
    width: usize,
    height: usize,
    src: &'a [f32],
    radius: &'a [f32],
    taps: &'a PassTaps<'a>,
    only: Option<&'a [bool]>,
    out: &'a mut [f32],
}

impl Kernel for ScreenPass<'_> {
    type Output = u64;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> u64 {
        s.begin_task(task_kind::SCREEN_PASS);
        let (w, h) = (self.width as i32, self.height as i32);
        let zero = s.splat_f(0.0);
        let lane = s.index_i();
        let half = (MAX_KERNEL / 2) as i32;
        let side = MAX_KERNEL as i32;
        let mut taps = 0u64;
        let rows = self.out.len() / self.width;
        for row in 0..rows {
            let y = (self.first_row + row) as i32;
            let mut x0 = 0;
            while x0 < w {
                let m = s.mask_first_n((w - x0) as usize);
                let at = (y * w + x0) as usize;
                let mut m = m;
                if let Some(only) = self.only {
                    let mut bits = 0u16;
                    for l in 0..(w - x0).min(16) as usize {
                        if only[at + l] {
                            bits |= 1 << l;
                        }
                    }
                    m = s.mask_and(m, sism_simd::Mask16::from_bits(bits));
                }
                let rad = s.mask_load_f(zero, m, &self.radius[at..]);
                // Pixels of radius 0 keep their value (`out` starts as a copy of `src`).
                let active = s.mask_and(m, s.cmp_gt_f(rad, zero));
                if !s.mask_any(active) {
                    x0 += 16;
                    continue;
                }
                let xs = s.add_i(lane, s.splat_i(x0));
                let mut acc = zero;
                match self.taps {
                    PassTaps::Table(table) => {
                        let r = s.cvtr_f_i(rad);
                        let rmax = s.reduce_max_f(rad).round() as i32;
                        let base = s.mul_i(r, s.splat_i(side * side));
                        for dy in -rmax..=rmax {
                            let yy = (y + dy).clamp(0, h - 1);
                            for dx in -rmax..=rmax {
                                let widx = s.add_i(base, s.splat_i((dy + half) * side + dx + half));
                                let wt = s.mask_gather_f(zero, active, table, widx);
                                let lanes = s.mask_and(active, s.cmp_gt_f(wt, zero));
                                if !s.mask_any(lanes) {
                                    continue;
                                }
                                let xx = s.min_i(
                                    s.max_i(s.add_i(xs, s.splat_i(dx)), s.splat_i(0)),
                                    s.splat_i(w - 1),
                                );
                                let idx = s.add_i(s.splat_i(yy * w), xx);
                                let v = s.mask_gather_f(zero, lanes, self.src, idx);
                                acc = s.fmadd(v, wt, acc);
                                taps += s.mask_popcnt(lanes) as u64;
                            }
                        }
                        s.mask_store_f(&mut self.out[row * self.width + x0 as usize..], active, acc);
                    }
                    PassTaps::Fixed(list) => {
                        for &(dx, dy, wt) in list.iter() {
                            let yy = (y + dy).clamp(0, h - 1);
                            let xx = s.min_i(
                                s.max_i(s.add_i(xs, s.splat_i(dx)), s.splat_i(0)),
                                s.splat_i(w - 1),
                            );
                            let idx = s.add_i(s.splat_i(yy * w), xx);
                            let v = s.mask_gather_f(zero, active, self.src, idx);
                            acc = s.fmadd(v, s.splat_f(wt), acc);
                        }
                        taps += (s.mask_popcnt(active) as usize * list.len()) as u64;
                        s.mask_store_f(&mut self.out[row * self.width + x0 as usize..], active, acc);
                    }
                }
                x0 += 16;
            }
        }
        s.end_task();
        taps
    }
}

/// The umbra-skip pass: `D = 0` where the pixel and its 8 neighbours are all shadowed (`S = 1`);
/// returns the new `D` and how many pixels it zeroed.
fn umbra_skip(p: &mut crate::exec::Phase, scr: &Screen, d: &[f32]) -> (Vec<f32>, u64) {
    let w = scr.width;
    let mut out = d.to_vec();
    let counts = p.run_par(
        "umbra_skip",
        out.par_chunks_mut(w.max(1) * ROWS_PER_TASK)
            .enumerate()
            .map(|(t, rows)| UmbraSkip {
                first_row: t * ROWS_PER_TASK,
                width: w,
                height: scr.height,
                s_img: &scr.s,
                out: rows,
            }),
    );
    (out, counts.iter().sum())
}

/// A band of rows of the umbra-skip pass.
struct UmbraSkip<'a> {
    first_row: usize,
    width: usize,
    height: usize,
    s_img: &'a [f32],
    out: &'a mut [f32],
}

impl Kernel for UmbraSkip<'_> {
    type Output = u64;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> u64 {
        s.begin_task(task_kind::SCREEN_PASS);
        let (w, h) = (self.width as i64, self.height as i64);
        let rows = self.out.len() / self.width.max(1);
        // Counted per pixel: the loop's branch, its index and value (the band's lines read here at
        // once); for a pixel in penumbra each neighbour's clamped coordinates, index, load and
        // compare, up to the first that is not fully lit, and the store when all are.
        s.scalar_read(self.out);
        let mut skipped = 0;
        for row in 0..rows {
            let y = s.s_add(self.first_row, row) as i64;
            for x in 0..w {
                s.scalar_op(ScalarClass::Branch);
                let k = s.s_add(s.s_mul(row, self.width), x as usize);
                if s.s_le(counted::streamed(s, self.out, k), 0.0) {
                    continue;
                }
                let lit = |dx: i64, dy: i64| {
                    let xx = s.s_min(s.s_max(s.s_add(x, dx), 0), w - 1);
                    let yy = s.s_min(s.s_max(s.s_add(y, dy), 0), h - 1);
                    s.s_le(1.0, s.s_load(self.s_img, s.s_add(s.s_mul(yy, w), xx) as usize))
                };
                let all = (-1..=1).all(|dy: i64| (-1..=1).all(|dx: i64| lit(dx, dy)));
                if all {
                    s.s_store(self.out, k, 0.0);
                    skipped += 1;
                }
            }
        }
        s.end_task();
        skipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tap_counts_match_the_configuration() {
        assert_eq!(multi_pass_taps(9, 20).len(), 20);
        assert_eq!(multi_pass_taps(19, 38).len(), 38);
        let taps = multi_pass_taps(9, 64);
        assert_eq!((taps[0].0, taps[0].1), (0, 0), "the first tap is the centre");
        assert!(taps.iter().all(|t| t.0.abs() <= 5 && t.1.abs() <= 5));
        let total: f32 = taps.iter().map(|t| t.2).sum();
        assert!((total - 1.0).abs() < 1e-5);
        // The 19×19 Gaussian of radius 9 reads all 361 pixels, each radius's weights sum to 1.
        let t = gaussian_table();
        let w = (MAX_KERNEL * MAX_KERNEL) as usize;
        assert_eq!(t[9 * w..10 * w].iter().filter(|&&v| v > 0.0).count(), 361);
        for r in 0..=9 {
            let sum: f32 = t[r * w..(r + 1) * w].iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "{r}: {sum}");
            let b: f32 = box_table()[r * w..(r + 1) * w].iter().sum();
            assert!((b - 1.0).abs() < 1e-5);
        }
    }
}
