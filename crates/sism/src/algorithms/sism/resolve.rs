//! Resolve: paper Eq. 4, `V = 1 - clamp01(depth complexity + sum of edge terms + horizon)`, written to
//! the pixels.
//!
//! The horizon term is ours, not the paper's: where the light disk dips below the receiver's tangent
//! plane, that part of the disk is hidden by the receiver's own surface (CONTRACTS.md counts it as
//! occluded, and the reference's shadow rays see it so). In the disk's plane the tangent plane cuts a
//! chord at distance `d = |c - p| cot(theta) / r` from the centre (theta between normal and light
//! direction); the hidden part is the circular segment beyond it, `(acos d - d sqrt(1 - d^2)) / pi`.

use rayon::prelude::*;
use sism_simd::{Kernel, Simd};

use super::grid::Grid;
use super::StageInputs;
use crate::exec::{task_kind, Phase};
use crate::frame::VisibilityImage;

/// The occlusion a frame has computed, per sample (sorted order).
#[derive(Clone, Debug)]
pub enum Occlusion {
    /// Eq. 4: depth complexity and, unless the light is a point, penumbra sums; `V = 1 - clamp01(sum)`.
    Additive {
        /// Depth complexity per sample: counted occluder triangles between it and the light centre.
        umbra: Vec<i32>,
        /// Penumbra sum per sample; `None` for a point light.
        penumbra: Option<Vec<f32>>,
    },
    /// Composed elsewhere (independent occluders, light points): the visible fraction so far,
    /// multiplied by the horizon's.
    Visible(Vec<f32>),
}

/// Computes the visibility of the samples `first..first + out.len()`.
pub struct Resolve<'a> {
    /// The grid whose sorted samples are resolved.
    pub grid: &'a Grid,
    /// Composition of the occluders' coverages.
    pub occlusion: &'a Occlusion,
    /// Light radius, world units (0: no horizon term).
    pub light_radius: f32,
    /// First sorted sample of this task; `out` holds the visibility of `out.len()` samples from it.
    pub first: usize,
    /// Visibility of the task's samples, from `first` on, in sorted order.
    pub out: &'a mut [f32],
}

/// Samples per resolve task: enough work per task, and tasks for every core of the modelled chip.
pub const RESOLVE_CHUNK: usize = 16_384;

/// Eq. 4 for every sample, as tasks of [`RESOLVE_CHUNK`] samples (step `eq4`), then the values
/// scattered to their pixels of `image` (step `scatter`; pixels without a sample keep their value).
pub fn compose(
    phase: &mut Phase,
    inputs: &StageInputs<'_>,
    occlusion: &Occlusion,
    image: &mut VisibilityImage,
) {
    let grid = inputs.grid;
    let mut values = vec![0f32; grid.samples.pixel.len()];
    phase.run_par(
        "eq4",
        values
            .par_chunks_mut(RESOLVE_CHUNK)
            .enumerate()
            .map(|(k, out)| Resolve {
                grid,
                occlusion,
                light_radius: inputs.light.radius,
                first: k * RESOLVE_CHUNK,
                out,
            }),
    );
    crate::algorithms::pixels::scatter_to_pixels(
        phase,
        "scatter",
        task_kind::SISM_RESOLVE_SCATTER,
        &grid.samples.pixel,
        &values,
        &mut image.values,
    );
}

impl Kernel for Resolve<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::SISM_RESOLVE);
        let end = self.first + self.out.len();
        let zero = s.splat_f(0.0);
        let one = s.splat_f(1.0);
        let mut i = self.first;
        while i < end {
            let m = s.mask_first_n(end - i);
            let mut occlusion = zero;
            if let Occlusion::Additive { umbra, penumbra } = self.occlusion {
                occlusion = s.cvt_i_f(s.mask_load_i(s.splat_i(0), m, &umbra[i..]));
                if let Some(p) = penumbra {
                    occlusion = s.add_f(occlusion, s.mask_load_f(zero, m, &p[i..]));
                }
            }
            if self.light_radius > 0.0 {
                let smp = &self.grid.samples;
                let x = s.mask_load_f(zero, m, &smp.x[i..]);
                let y = s.mask_load_f(zero, m, &smp.y[i..]);
                let z = s.mask_load_f(zero, m, &smp.z[i..]);
                let cos = s.mask_load_f(one, m, &smp.cos_theta[i..]);
                let dist = s.sqrt_f(s.fmadd(z, z, s.fmadd(y, y, s.mul_f(x, x))));
                let sin = s.sqrt_f(s.max_f(s.fnmadd(cos, cos, one), zero));
                // d = dist * cos / (sin * r), compared as d * sin * r < ... to avoid dividing by 0.
                let num = s.mul_f(dist, cos);
                let den = s.mul_f(sin, s.splat_f(self.light_radius));
                let below = s.mask_and(m, s.cmp_lt_f(num, den));
                if s.s_branch(s.mask_any(below)) {
                    let d = s.min_f(s.div_f(num, s.select_f(below, den, one)), one);
                    let chord = s.sqrt_f(s.max_f(s.fnmadd(d, d, one), zero));
                    let segment = s.mul_f(
                        s.fnmadd(d, chord, s.acos_f(d)),
                        s.splat_f(std::f32::consts::FRAC_1_PI),
                    );
                    occlusion = s.add_f(occlusion, s.select_f(below, segment, zero));
                }
            }
            let mut v = s.sub_f(one, s.clamp_f(occlusion, zero, one));
            if let Occlusion::Visible(visible) = self.occlusion {
                // Here `occlusion` holds the horizon alone: one more independent occluder.
                v = s.mul_f(v, s.mask_load_f(one, m, &visible[i..]));
            }
            s.mask_store_f(&mut self.out[i - self.first..], m, v);
            i += 16;
        }
        s.end_task();
    }
}
