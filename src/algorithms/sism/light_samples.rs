//! Light samples: the receivers that face the light, as samples relative to its centre, each in the
//! light face that sees it, grouped by face; the light view fitted to them ([`light_view::fit`]); and
//! each face's width factor for penumbra quads.
//!
//! Steps (tasks of the phase):
//! 1. `classify`, one task per band of [`BAND_ROWS`] image rows: per pixel a miss, a receiver facing
//!    away (which never enters the grid; one at the light centre has no direction to it and is treated
//!    the same way), or a sample (its position relative to the light and `cos θ`).
//! 2. `fit` and `cone` (and `faces` for a cube): the light view (see [`light_view`]).
//! 3. `face_sort`: a stable counting sort by face (at most six faces), so each face keeps pixel order.
//! 4. `project`: each sample's face coordinates, and per face the bounds that give its width factor.

use std::mem::MaybeUninit;

use glam::Vec3;
use rayon::prelude::*;
use sism_simd::{Kernel, Simd};

use super::grid::SampleIn;
use super::light_view::{self, LightView};
use super::SismLight;
use crate::exec::{task_kind, Phase};
use crate::frame::{Receiver, Receivers, VisibilityImage, V_FACING_AWAY, V_MISS};
use crate::scene::Light;

/// Image rows per `classify` task.
pub const BAND_ROWS: usize = 16;

/// Samples per `project` task.
pub const PROJECT_CHUNK: usize = 65_536;

/// What the light-samples stage produces.
pub struct LightSamples {
    /// The frame's image, holding [`V_MISS`] at misses, [`V_FACING_AWAY`] at receivers facing away
    /// and 1 at samples (overwritten by the resolve).
    pub image: VisibilityImage,
    /// The samples, grouped by face, pixel order within a face.
    pub samples: Vec<SampleIn>,
    /// The light with its faces' width factors.
    pub light: SismLight,
    /// The light view.
    pub view: LightView,
}

/// The light samples of `receivers` for `light`, as the steps of the module docs.
pub fn build(phase: &mut Phase, receivers: &Receivers, light: &Light) -> LightSamples {
    let c = light.center();
    let mut image = VisibilityImage::filled(receivers.width, receivers.height, V_MISS);
    let band = receivers.width as usize * BAND_ROWS;
    let bands: Vec<Band> = phase.run_par(
        "classify",
        image
            .values
            .par_chunks_mut(band)
            .zip(receivers.pixels.par_chunks(band))
            .enumerate()
            .map(|(k, (values, pixels))| Classify {
                values,
                pixels,
                first_pixel: (k * band) as u32,
                c,
            }),
    );
    // The bands' samples, concatenated in band (pixel) order. (A chip's classify tasks would write at
    // their prefix offsets directly; their writes are counted there.)
    let n: usize = bands.iter().map(|b| b.q.len()).sum();
    let (mut points, mut cosines, mut pixels) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for b in bands {
        points.extend(b.q);
        cosines.extend(b.cos_theta);
        pixels.extend(b.pixel);
    }
    let (view, face_of) = light_view::fit(phase, &points);
    let order = phase.run(
        "face_sort",
        FaceSort {
            face_of: &face_of,
            faces: view.faces.len(),
        },
    );

    // Projection into the faces, written in place in sorted order, with per-face bounds: the smallest
    // cos(angle to the axis) and the nearest distance of each face's samples.
    let n_faces = view.faces.len();
    let mut samples: Vec<SampleIn> = Vec::with_capacity(n);
    let bounds: Vec<FaceBounds> = phase.run_par(
        "project",
        samples.spare_capacity_mut()[..n]
            .par_chunks_mut(PROJECT_CHUNK)
            .zip(order.par_chunks(PROJECT_CHUNK))
            .map(|(out, order)| Project {
                order,
                points: &points,
                cosines: &cosines,
                pixels: &pixels,
                face_of: &face_of,
                view: &view,
                out,
            }),
    );
    // SAFETY: the `project` tasks' output slices partition the first `n` elements of the spare
    // capacity, and each task writes every element of its slice (one per index of its `order`
    // chunk, which has the slice's length). Had one panicked, we would not get here.
    unsafe { samples.set_len(n) };
    // Width factor per face: the line of sight from a sample through an edge deviates from the axis by
    // at most the sample's own angle plus asin(r / distance).
    let (mut cos_min, mut dist_min) = (vec![1.0f32; n_faces], vec![f32::INFINITY; n_faces]);
    for b in &bounds {
        for f in 0..n_faces {
            cos_min[f] = cos_min[f].min(b.cos_min[f]);
            dist_min[f] = dist_min[f].min(b.dist_min[f]);
        }
    }
    let widen = cos_min
        .iter()
        .zip(&dist_min)
        .map(|(&cos, &dist)| {
            let alpha = cos.clamp(-1.0, 1.0).acos() + (light.radius / dist).min(1.0).asin();
            1.0 / alpha.min(89.0f32.to_radians()).cos()
        })
        .collect();
    LightSamples {
        image,
        samples,
        light: SismLight::new(light, widen),
        view,
    }
}

/// A band's samples: position relative to the light, `cos θ`, pixel.
struct Band {
    q: Vec<Vec3>,
    cos_theta: Vec<f32>,
    pixel: Vec<u32>,
}

/// Step `classify`: one band of rows.
struct Classify<'a> {
    values: &'a mut [f32],
    pixels: &'a [Option<Receiver>],
    first_pixel: u32,
    c: Vec3,
}

impl Kernel for Classify<'_> {
    type Output = Band;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Band {
        s.begin_task(task_kind::LIGHT_SAMPLES_CLASSIFY);
        s.scalar_read(self.pixels);
        let mut out = Band {
            q: Vec::with_capacity(self.values.len()),
            cos_theta: Vec::with_capacity(self.values.len()),
            pixel: Vec::with_capacity(self.values.len()),
        };
        let mut receivers = 0u64;
        for (k, (v, r)) in self.values.iter_mut().zip(self.pixels).enumerate() {
            let Some(r) = r else { continue };
            receivers += 1;
            let q = r.position - self.c;
            let facing = r.normal.dot(-q);
            if facing > 0.0 && q.length_squared() > 0.0 {
                *v = 1.0;
                out.q.push(q);
                out.cos_theta.push((facing / q.length()).min(1.0));
                out.pixel.push(self.first_pixel + k as u32);
            } else {
                *v = V_FACING_AWAY;
            }
        }
        // Per pixel the miss test and the store (~3); per receiver the difference, dot, length, square
        // root, division and the pushes (~20).
        s.scalar_ops(3 * self.values.len() as u64 + 20 * receivers);
        s.scalar_write(self.values);
        s.scalar_write(&out.q);
        s.scalar_write(&out.cos_theta);
        s.scalar_write(&out.pixel);
        s.end_task();
        out
    }
}

/// Step `face_sort`: the stable counting sort of the samples by face; returns each sorted position's
/// sample index. (A general stable sort of the 40-byte samples costs a dozen copying passes.)
struct FaceSort<'a> {
    face_of: &'a [u8],
    faces: usize,
}

impl Kernel for FaceSort<'_> {
    type Output = Vec<u32>;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Vec<u32> {
        s.begin_task(task_kind::LIGHT_SAMPLES_FACE_SORT);
        let mut next = vec![0usize; self.faces];
        for &f in self.face_of {
            next[f as usize] += 1;
        }
        let mut first = 0;
        for n in next.iter_mut() {
            (*n, first) = (first, first + *n);
        }
        let mut order = vec![0u32; self.face_of.len()];
        for (k, &f) in self.face_of.iter().enumerate() {
            order[next[f as usize]] = k as u32;
            next[f as usize] += 1;
        }
        // Two passes over the faces: count (~2 per sample), place (~4 per sample).
        s.scalar_ops(6 * self.face_of.len() as u64);
        s.scalar_read(self.face_of);
        s.scalar_read(self.face_of);
        s.scalar_write(&order);
        s.end_task();
        order
    }
}

/// Per-face bounds of a chunk of samples: smallest cosine to the axis, nearest distance.
struct FaceBounds {
    cos_min: Vec<f32>,
    dist_min: Vec<f32>,
}

/// Step `project`: a chunk of sorted positions, projected into their faces.
struct Project<'a> {
    order: &'a [u32],
    points: &'a [Vec3],
    cosines: &'a [f32],
    pixels: &'a [u32],
    face_of: &'a [u8],
    view: &'a LightView,
    out: &'a mut [MaybeUninit<SampleIn>],
}

impl Kernel for Project<'_> {
    type Output = FaceBounds;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> FaceBounds {
        s.begin_task(task_kind::LIGHT_SAMPLES_PROJECT);
        let n_faces = self.view.faces.len();
        let mut b = FaceBounds {
            cos_min: vec![1.0f32; n_faces],
            dist_min: vec![f32::INFINITY; n_faces],
        };
        s.scalar_read(self.order);
        for (out, &k) in self.out.iter_mut().zip(self.order) {
            let k = k as usize;
            let (q, face) = (self.points[k], self.face_of[k]);
            // Gathered by sample index: one line each (points, cosines, pixels, faces).
            s.scalar_read(&self.points[k..k + 1]);
            s.scalar_read(&self.cosines[k..k + 1]);
            s.scalar_read(&self.pixels[k..k + 1]);
            let (uv, depth) = self.view.faces[face as usize].project(q);
            out.write(SampleIn {
                q,
                face,
                uv,
                depth,
                pixel: self.pixels[k],
                cos_theta: self.cosines[k],
            });
            let len = q.length();
            let f = face as usize;
            b.cos_min[f] = b.cos_min[f].min(depth / len);
            b.dist_min[f] = b.dist_min[f].min(len);
        }
        // Per sample: 3 dot products and 2 divisions (~14), the length (~6), the bounds (~4), the
        // record (~6).
        s.scalar_ops(30 * self.order.len() as u64);
        s.scalar_touch(self.out.as_ptr() as usize, std::mem::size_of_val(self.out), true);
        s.end_task();
        b
    }
}
