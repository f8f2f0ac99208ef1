//! Light views fitted to the receivers: one perspective frustum when every receiver lies within a cone
//! around a common direction from the light, a cube of six views otherwise (a light inside the scene,
//! receivers all around it, as in the conference room).
//!
//! Face coordinates of a point `q` given relative to the light centre: `x = q·right`, `y = q·up`,
//! depth `z = q·axis` (> 0 in front of the face), image-plane position `(u, v) = (x / z, y / z)` on the
//! plane at distance 1.

use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use crate::counted;
use crate::exec::{task_kind, Phase};
use crate::scene::shapes::orthonormal_basis;

/// Largest half-angle (degrees) of the cone of receiver directions one frustum may cover. Beyond it the
/// image plane stretches too much (cells near the border cover far more solid angle than those near the
/// axis), so a cube of six 90-degree faces is used instead.
pub const MAX_SINGLE_FRUSTUM_HALF_ANGLE_DEG: f32 = 60.0;

/// One perspective view from the light centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightFace {
    /// Unit view direction.
    pub axis: Vec3,
    /// Unit image-plane `u` direction.
    pub right: Vec3,
    /// Unit image-plane `v` direction.
    pub up: Vec3,
}

impl LightFace {
    /// Face coordinates `(x, y, z)` of `q` (relative to the light centre).
    #[inline]
    pub fn to_face(&self, q: Vec3) -> Vec3 {
        self.to_face_counted(sism_simd::Portable, q)
    }

    /// [`LightFace::to_face`] with its three dot products counted by `s` (bit-identical).
    #[inline(always)]
    pub fn to_face_counted<S: Simd>(&self, s: S, q: Vec3) -> Vec3 {
        Vec3::new(
            crate::counted::dot(s, q, self.right),
            crate::counted::dot(s, q, self.up),
            crate::counted::dot(s, q, self.axis),
        )
    }

    /// Image-plane position and depth of `q`; meaningful only for `z > 0`.
    #[inline]
    pub fn project(&self, q: Vec3) -> (Vec2, f32) {
        let f = self.to_face(q);
        (Vec2::new(f.x / f.z, f.y / f.z), f.z)
    }
}

/// The light's views and, for each sample, the face it belongs to.
#[derive(Clone, Debug)]
pub struct LightView {
    /// The views: one frustum, or the six cube faces.
    pub faces: Vec<LightFace>,
    /// True when the six cube faces are used.
    pub is_cube: bool,
}

/// The six cube faces, each a 90-degree frustum; a direction belongs to the face of its largest
/// component (ties to the lower face index, so the assignment is deterministic).
pub fn cube_faces() -> Vec<LightFace> {
    [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z]
        .into_iter()
        .map(|axis| {
            let (right, up) = orthonormal_basis(axis);
            LightFace { axis, right, up }
        })
        .collect()
}

/// Index into [`cube_faces`] of the face whose frustum holds direction `q`.
#[inline]
pub fn cube_face_of(q: Vec3) -> usize {
    cube_face_of_counted(sism_simd::Portable, q)
}

/// [`cube_face_of`] with its operations counted by `s`: three absolute values and up to three
/// compares with their branches.
#[inline(always)]
pub fn cube_face_of_counted<S: Simd>(s: S, q: Vec3) -> usize {
    let a = Vec3::new(
        s.s_fn(ScalarClass::Alu, q.x, f32::abs),
        s.s_fn(ScalarClass::Alu, q.y, f32::abs),
        s.s_fn(ScalarClass::Alu, q.z, f32::abs),
    );
    if s.s_le(a.y, a.x) && s.s_le(a.z, a.x) {
        if s.s_le(0.0, q.x) {
            0
        } else {
            1
        }
    } else if s.s_le(a.z, a.y) {
        if s.s_le(0.0, q.y) {
            2
        } else {
            3
        }
    } else if s.s_le(0.0, q.z) {
        4
    } else {
        5
    }
}

/// Points per task of the `fit` step (fixed: the mean's f64 partial sums follow it).
pub const FIT_CHUNK: usize = 65_536;

/// Points per task of the `cone` and `faces` steps (results do not depend on it).
pub const TEST_CHUNK: usize = 16_384;

/// Fits the light view to receiver positions `points` (relative to the light centre, none at it) and
/// returns it with each point's face index. Steps of `phase`: `fit` (the mean unit direction, per
/// chunk in f64, added in chunk order: the same axis for any thread count), `cone` (is every
/// direction within [`MAX_SINGLE_FRUSTUM_HALF_ANGLE_DEG`] of it?) and, for a cube, `faces`.
pub fn fit(phase: &mut Phase, points: &[Vec3]) -> (LightView, Vec<u8>) {
    // The mean unit direction is the cone's axis; if every direction is within the half-angle limit of
    // it, one frustum serves.
    let mean = phase
        .run_par(
            "fit",
            points
                .par_chunks(FIT_CHUNK)
                .map(|points| MeanDirection { points }),
        )
        .into_iter()
        .fold(DVec3::ZERO, |a, b| a + b)
        .as_vec3();
    if let Some(axis) = mean.try_normalize() {
        let cos_limit = MAX_SINGLE_FRUSTUM_HALF_ANGLE_DEG.to_radians().cos();
        let within = phase.run_par(
            "cone",
            points.par_chunks(TEST_CHUNK).map(|points| WithinCone {
                points,
                axis,
                cos_limit,
            }),
        );
        if within.iter().all(|&w| w) {
            let (right, up) = orthonormal_basis(axis);
            let view = LightView {
                faces: vec![LightFace { axis, right, up }],
                is_cube: false,
            };
            return (view, vec![0; points.len()]);
        }
    }
    let faces = cube_faces();
    let mut ids = vec![0u8; points.len()];
    phase.run_par(
        "faces",
        ids.par_chunks_mut(TEST_CHUNK)
            .zip(points.par_chunks(TEST_CHUNK))
            .map(|(ids, points)| CubeFaces { points, ids }),
    );
    (LightView { faces, is_cube: true }, ids)
}

/// Step `fit`: the sum of a chunk's unit directions, in f64.
struct MeanDirection<'a> {
    points: &'a [Vec3],
}

impl Kernel for MeanDirection<'_> {
    type Output = DVec3;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> DVec3 {
        s.begin_task(task_kind::LIGHT_SAMPLES_FIT);
        s.scalar_read(self.points);
        // Counted per point: its load, the normalisation, three widenings and three f64 adds.
        let mut sum = DVec3::ZERO;
        for i in 0..self.points.len() {
            let u = counted::normalize_or_zero(s, counted::streamed(s, self.points, i));
            let w = DVec3::new(
                s.s_fn(ScalarClass::Alu, u.x, f64::from),
                s.s_fn(ScalarClass::Alu, u.y, f64::from),
                s.s_fn(ScalarClass::Alu, u.z, f64::from),
            );
            sum = DVec3::new(s.s_add(sum.x, w.x), s.s_add(sum.y, w.y), s.s_add(sum.z, w.z));
        }
        s.end_task();
        sum
    }
}

/// Step `cone`: is every direction of a chunk within the cone?
struct WithinCone<'a> {
    points: &'a [Vec3],
    axis: Vec3,
    cos_limit: f32,
}

impl Kernel for WithinCone<'_> {
    type Output = bool;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> bool {
        s.begin_task(task_kind::LIGHT_SAMPLES_FIT);
        s.scalar_read(self.points);
        // Counted per point, up to the first outside the cone: its load, the normalisation, the dot
        // product and the compare.
        let all = (0..self.points.len()).all(|i| {
            let u = counted::normalize_or_zero(s, counted::streamed(s, self.points, i));
            s.s_le(self.cos_limit, counted::dot(s, u, self.axis))
        });
        s.end_task();
        all
    }
}

/// Step `faces`: the cube face of each point of a chunk.
struct CubeFaces<'a> {
    points: &'a [Vec3],
    ids: &'a mut [u8],
}

impl Kernel for CubeFaces<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        s.begin_task(task_kind::LIGHT_SAMPLES_FIT);
        s.scalar_read(self.points);
        // Counted per point: its load, the face test and the id's store (its line below).
        for i in 0..self.points.len() {
            self.ids[i] = cube_face_of_counted(s, counted::streamed(s, self.points, i)) as u8;
            s.scalar_op(ScalarClass::Store);
        }
        s.scalar_write(self.ids);
        s.end_task();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::{Exec, FrameLog};

    fn fit_native(points: &[Vec3]) -> (LightView, Vec<u8>) {
        FrameLog::new(Exec::Native).phase("fit", "fit", |p| fit(p, points))
    }

    #[test]
    fn narrow_cone_gets_one_face_wide_spread_gets_a_cube() {
        let narrow: Vec<Vec3> = (0..50).map(|i| Vec3::new(i as f32 * 0.01, -1.0, 0.2)).collect();
        let (view, ids) = fit_native(&narrow);
        assert_eq!(view.faces.len(), 1);
        assert!(ids.iter().all(|&i| i == 0));
        for q in &narrow {
            assert!(view.faces[0].to_face(*q).z > 0.0);
        }
        let wide = vec![Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::new(0.1, -1.0, 0.0)];
        let (view, ids) = fit_native(&wide);
        assert!(view.is_cube);
        assert_eq!(ids, vec![0, 1, 2, 3]);
    }

    #[test]
    fn every_direction_is_in_front_of_its_cube_face_within_90_degrees() {
        let faces = cube_faces();
        for i in 0..1000 {
            let t = i as f32 * 0.7;
            let q = Vec3::new(t.sin() * 3.0, (t * 1.3).cos(), (t * 0.37).sin() - 0.2);
            let f = faces[cube_face_of(q)].to_face(q);
            assert!(
                f.z > 0.0 && f.x.abs() <= f.z * 1.0001 && f.y.abs() <= f.z * 1.0001,
                "{q} {f}"
            );
        }
    }
}
