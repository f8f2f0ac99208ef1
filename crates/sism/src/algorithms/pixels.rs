//! Per-sample results back to their pixels: the last step of every algorithm that works on samples
//! in its own order (SISM's grid order, the shadow maps' face order).

use sism_simd::{as_i32, Kernel, Simd};

use crate::exec::Phase;

/// Samples per scatter task.
pub const SCATTER_CHUNK: usize = 16_384;

/// Stores `values[k]` at `image[pixels[k]]` for every sample, as tasks of [`SCATTER_CHUNK`] samples
/// (kind `kind`) of step `step`. The tasks share the image, so the host runs them one after another;
/// a pixel has at most one sample, so the chip's tasks would not conflict.
pub fn scatter_to_pixels(
    phase: &mut Phase,
    step: &str,
    kind: u32,
    pixels: &[u32],
    values: &[f32],
    image: &mut [f32],
) {
    for (pixels, values) in pixels.chunks(SCATTER_CHUNK).zip(values.chunks(SCATTER_CHUNK)) {
        phase.run(
            step,
            ScatterToPixels {
                kind,
                pixels,
                values,
                image: &mut *image,
            },
        );
    }
}

/// A chunk of samples' values stored at their pixels (a vector scatter per 16).
struct ScatterToPixels<'a> {
    kind: u32,
    pixels: &'a [u32],
    values: &'a [f32],
    image: &'a mut [f32],
}

impl Kernel for ScatterToPixels<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(self.kind);
        let zero = s.splat_f(0.0);
        // Pixel indices are < 2^27 (MAX_PIXELS): exact as i32 lanes.
        let pixels = as_i32(self.pixels);
        let mut i = 0;
        while i < self.pixels.len() {
            let m = s.mask_first_n(self.pixels.len() - i);
            let idx = s.mask_load_i(s.splat_i(0), m, &pixels[i..]);
            let v = s.mask_load_f(zero, m, &self.values[i..]);
            s.mask_scatter_f(self.image, m, idx, v);
            i += 16;
        }
        s.end_task();
    }
}
