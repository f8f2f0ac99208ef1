//! Light samples: the receivers that face the light, as samples relative to its centre, each in the
//! light face that sees it, grouped by face; the light view fitted to them ([`light_view::fit`]); and
//! each face's width factor for penumbra quads.
//!
//! Steps (tasks of the phase):
//! 1. `classify`, one task per band of [`BAND_ROWS`] image rows: per pixel a miss, a receiver facing
//!    away (which never enters the grid; one at the light centre has no direction to it and is treated
//!    the same way), or a sample (its position relative to the light and `cos θ`).
//! 2. `fit` and `cone` (and `faces` for a cube): the light view (see [`light_view`]).
//! 3. `face_sort` and `face_scatter` (a cube only; one face is already in order): a stable counting
//!    sort by face (at most six faces), so each face keeps pixel order.
//! 4. `project`: each sample's face coordinates, and per face the bounds that give its width factor.

use std::mem::MaybeUninit;

use glam::Vec3;
use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use super::grid::SampleIn;
use super::light_view::{self, LightView};
use super::SismLight;
use crate::counted;
use crate::exec::{task_kind, Phase};
use crate::frame::{Receiver, Receivers, VisibilityImage, V_FACING_AWAY, V_MISS};
use crate::scene::Light;

/// Image rows per `classify` task.
pub const BAND_ROWS: usize = 16;

/// Samples per `face_sort`, `face_scatter` and `project` task (results do not depend on it).
pub const CHUNK: usize = 16_384;

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
    let order = (view.faces.len() > 1).then(|| face_sort(phase, &face_of, view.faces.len()));

    // Projection into the faces, written in place in sorted order, with per-face bounds: the smallest
    // cos(angle to the axis) and the nearest distance of each face's samples.
    let n_faces = view.faces.len();
    let mut samples: Vec<SampleIn> = Vec::with_capacity(n);
    let bounds: Vec<FaceBounds> = phase.run_par(
        "project",
        samples.spare_capacity_mut()[..n]
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(k, out)| Project {
                first: k * CHUNK,
                order: order.as_deref().map(|o| &o[k * CHUNK..k * CHUNK + out.len()]),
                points: &points,
                cosines: &cosines,
                pixels: &pixels,
                face_of: &face_of,
                view: &view,
                out,
            }),
    );
    // SAFETY: the `project` tasks' output slices partition the first `n` elements of the spare
    // capacity, and each task writes every element of its slice (one per sorted position). Had one
    // panicked, we would not get here.
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
        // Counted per pixel: the receiver's tag and its branch; per receiver its two vectors, the
        // difference, the facing test, length and cosine, and the pushes.
        for k in 0..self.values.len() {
            let r = &self.pixels[k];
            s.scalar_op(ScalarClass::Mem);
            let Some(r) = s.s_branch(r.is_some()).then(|| r.as_ref().expect("tested")) else {
                continue;
            };
            let q = counted::sub(s, s.s_read(&r.position), self.c);
            let facing = counted::dot(s, s.s_read(&r.normal), counted::neg(s, q));
            if s.s_lt(0.0, facing) && s.s_lt(0.0, counted::dot(s, q, q)) {
                self.values[k] = 1.0;
                s.scalar_op(ScalarClass::Store);
                s.s_push(&mut out.q, q);
                s.s_push(
                    &mut out.cos_theta,
                    s.s_min(s.s_div(facing, counted::length(s, q)), 1.0),
                );
                s.s_push(&mut out.pixel, s.s_add(self.first_pixel, k as u32));
            } else {
                self.values[k] = V_FACING_AWAY;
                s.scalar_op(ScalarClass::Store);
            }
        }
        // The values' lines (their stores are counted above); the pushes recorded their own.
        s.scalar_write(self.values);
        s.end_task();
        out
    }
}

/// The stable counting sort of the samples by face: each sorted position's sample index. Step
/// `face_sort` counts each chunk's faces; after the prefix sum (face-major, chunk-minor: stable),
/// step `face_scatter` places each chunk's indices. (A general stable sort of the 40-byte samples
/// costs a dozen copying passes.)
fn face_sort(phase: &mut Phase, face_of: &[u8], faces: usize) -> Vec<u32> {
    let counts: Vec<[u32; 6]> = phase.run_par(
        "face_sort",
        face_of.par_chunks(CHUNK).map(|face_of| FaceCount { face_of }),
    );
    let mut next: Vec<[u32; 6]> = vec![[0; 6]; counts.len()];
    let mut running = 0u32;
    for f in 0..faces {
        for (k, c) in counts.iter().enumerate() {
            next[k][f] = running;
            running += c[f];
        }
    }
    let mut order = vec![0u32; face_of.len()];
    for (k, (face_of, next)) in face_of.chunks(CHUNK).zip(next).enumerate() {
        phase.run(
            "face_scatter",
            FaceScatter {
                first: (k * CHUNK) as u32,
                face_of,
                next,
                order: &mut order,
            },
        );
    }
    order
}

/// Step `face_sort`: how many samples of a chunk each face has.
struct FaceCount<'a> {
    face_of: &'a [u8],
}

impl Kernel for FaceCount<'_> {
    type Output = [u32; 6];
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> [u32; 6] {
        s.begin_task(task_kind::LIGHT_SAMPLES_FACE_SORT);
        let mut counts = [0u32; 6];
        s.scalar_read(self.face_of);
        // Counted per sample: the face's load and the count's load, increment and store (a local
        // array: no line).
        for i in 0..self.face_of.len() {
            let f = counted::streamed(s, self.face_of, i) as usize;
            let c = counted::streamed(s, &counts, f);
            counts[f] = s.s_add(c, 1);
            s.scalar_op(ScalarClass::Store);
        }
        s.end_task();
        counts
    }
}

/// Step `face_scatter`: a chunk's sample indices placed at their faces' next positions.
struct FaceScatter<'a> {
    first: u32,
    face_of: &'a [u8],
    next: [u32; 6],
    order: &'a mut [u32],
}

impl Kernel for FaceScatter<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(mut self, s: S) {
        s.begin_task(task_kind::LIGHT_SAMPLES_FACE_SORT);
        s.scalar_read(self.face_of);
        // Counted per sample: the face, its next position (a local array), the index's store and
        // the position's increment.
        for k in 0..self.face_of.len() {
            let f = counted::streamed(s, self.face_of, k) as usize;
            let at = counted::streamed(s, &self.next, f);
            s.s_store(self.order, at as usize, s.s_add(self.first, k as u32));
            self.next[f] = s.s_add(at, 1);
            s.scalar_op(ScalarClass::Store);
        }
        s.end_task();
    }
}

/// Per-face bounds of a chunk of samples: smallest cosine to the axis, nearest distance.
struct FaceBounds {
    cos_min: Vec<f32>,
    dist_min: Vec<f32>,
}

/// Step `project`: a chunk of sorted positions, projected into their faces.
struct Project<'a> {
    /// First sorted position of the chunk.
    first: usize,
    /// The sample index of each sorted position of the chunk (`None`: one face, already in order).
    order: Option<&'a [u32]>,
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
        if let Some(order) = self.order {
            s.scalar_read(order);
        }
        // Counted per sample: its index, its three fields, the face's basis, the projection (three
        // dot products, two divides), the record's six stores, the length and the face's bounds (a
        // divide, two loads, two minima, two stores).
        for (i, out) in self.out.iter_mut().enumerate() {
            let k = match self.order {
                Some(order) => counted::streamed(s, order, i) as usize,
                None => s.s_add(self.first, i),
            };
            let (q, face) = (s.s_read(&self.points[k]), s.s_read(&self.face_of[k]));
            let (pixel, cos_theta) = (s.s_read(&self.pixels[k]), s.s_read(&self.cosines[k]));
            let f = s.s_read(&self.view.faces[face as usize]).to_face_counted(s, q);
            let (uv, depth) = (glam::Vec2::new(s.s_div(f.x, f.z), s.s_div(f.y, f.z)), f.z);
            out.write(SampleIn {
                q,
                face: face as u32,
                uv,
                depth,
                pixel,
                cos_theta,
            });
            for _ in 0..6 {
                s.scalar_op(ScalarClass::Store);
            }
            let len = counted::length(s, q);
            let f = face as usize;
            let cos = s.s_div(depth, len);
            b.cos_min[f] = s.s_min(counted::streamed(s, &b.cos_min, f), cos);
            b.dist_min[f] = s.s_min(counted::streamed(s, &b.dist_min, f), len);
            s.scalar_op(ScalarClass::Store);
            s.scalar_op(ScalarClass::Store);
        }
        s.scalar_touch(self.out.as_ptr() as usize, std::mem::size_of_val(self.out), true);
        s.end_task();
        b
    }
}
