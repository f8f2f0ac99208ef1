//! Ray queries against the whole scene through obvhs' compressed wide BVH (CWBVH, Ylitie et al. 2017):
//! closest hit for primary rays, any hit with early out for shadow rays; and, over the same binary
//! BVH before its collapse, beams of one receiver's shadow rays ([`beam`]).

pub mod beam;

use glam::{UVec2, Vec3, Vec3A};
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::Ray;
use obvhs::rt_triangle::RtTriangle;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use crate::scene::Scene;

/// The scene's triangles in BVH leaf order, with the BVH over them.
pub struct SceneBvh {
    bvh: CwBvh,
    /// The binary BVH the CWBVH was collapsed from, laid out for beams of shadow rays.
    beam: beam::BeamBvh,
    /// Triangles reordered so `triangles[i]` is the BVH's primitive `i` (no indirection in the hot loop).
    triangles: Vec<RtTriangle>,
    /// `original[i]` is primitive `i`'s index in [`Scene::triangles`] order.
    original: Vec<u32>,
    /// Geometric unit normals of the primitives, in BVH order (counter-clockwise front).
    normals: Vec<Vec3>,
    /// Length of the scene's bounding-box diagonal, world units: the scale for ray offsets.
    pub scene_diagonal: f32,
}

/// The closest surface along a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Triangle index in [`Scene::triangles`] order.
    pub triangle: u32,
    /// Unit geometric normal of that triangle (not yet flipped towards the viewer).
    pub normal: Vec3,
}

impl SceneBvh {
    /// Builds the BVH (obvhs' medium preset: PLOC with reinsertion, then CWBVH collapse; the steps of
    /// `obvhs::cwbvh::builder::build_cwbvh_from_tris`, kept apart so the binary BVH serves the beams).
    pub fn build(scene: &Scene) -> SceneBvh {
        let tris: Vec<Triangle> = scene
            .triangles()
            .map(|[a, b, c]| Triangle {
                v0: a.into(),
                v1: b.into(),
                v2: c.into(),
            })
            .collect();
        let config = BvhBuildParams::medium_build();
        let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(
            config.ploc_search_distance,
            &tris,
            (0..tris.len() as u32).collect::<Vec<_>>(),
            config.sort_precision,
            config.search_depth_threshold,
        );
        ReinsertionOptimizer::default().run(&mut bvh2, config.reinsertion_batch_ratio, None);
        let bvh = bvh2_to_cwbvh(&bvh2, config.max_prims_per_leaf.clamp(1, 3), true, false);
        let rt: Vec<RtTriangle> = tris.iter().map(RtTriangle::from).collect();
        let beam = beam::BeamBvh::new(&bvh2, &rt);
        let original = bvh.primitive_indices.clone();
        let triangles = original.iter().map(|&i| rt[i as usize]).collect();
        let normals = original
            .iter()
            .map(|&i| Vec3::from(tris[i as usize].compute_normal()))
            .collect();
        let (lo, hi) = scene.bounds();
        SceneBvh {
            bvh,
            beam,
            triangles,
            original,
            normals,
            scene_diagonal: (hi - lo).length(),
        }
    }

    /// The closest triangle hit by the ray `origin + t * dir`, `t` in (0, inf). `dir` must be unit.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let mut ray = Ray::new_inf(origin.into(), dir.into());
        let mut hit_prim = u32::MAX;
        let mut state = self.bvh.new_traversal(Vec3A::from(dir));
        let mut node;
        let bvh = &self.bvh;
        obvhs::traverse!(bvh, node, state, node.intersect_ray(&ray, state.oct_inv4), {
            let t = self.triangles[state.primitive_id as usize].intersect(&ray);
            if t < ray.tmax && t > 0.0 {
                hit_prim = state.primitive_id;
                ray.tmax = t;
            }
        });
        (hit_prim != u32::MAX).then(|| Hit {
            t: ray.tmax,
            triangle: self.original[hit_prim as usize],
            normal: self.normals[hit_prim as usize],
        })
    }

    /// True when any triangle crosses the open segment `origin + t * dir`, `t` in (0, `t_max`). Stops at
    /// the first hit found (shadow rays need no closest hit). `dir` must be unit.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let ray = Ray::new(origin.into(), dir.into(), 0.0, t_max);
        let mut state = self.bvh.new_traversal(Vec3A::from(dir));
        let mut node;
        let bvh = &self.bvh;
        let mut hit = false;
        'search: {
            obvhs::traverse!(bvh, node, state, node.intersect_ray(&ray, state.oct_inv4), {
                let t = self.triangles[state.primitive_id as usize].intersect(&ray);
                if t < t_max && t > 0.0 {
                    hit = true;
                    break 'search;
                }
            });
        }
        hit
    }

    /// Number of triangles crossing the open segment `origin + t * dir`, `t` in (0, `t_max`), among
    /// those for which `counts(triangle index in Scene::triangles order)` is true. `dir` must be unit.
    pub fn count_crossings(&self, origin: Vec3, dir: Vec3, t_max: f32, counts: impl Fn(u32) -> bool) -> u32 {
        let ray = Ray::new(origin.into(), dir.into(), 0.0, t_max);
        let mut n = 0;
        self.bvh.ray_traverse_anyhit(ray, |ray, id| {
            let t = self.triangles[id].intersect(ray);
            if t < t_max && t > 0.0 && counts(self.original[id]) {
                n += 1;
            }
        });
        n
    }

    /// The beam layout of the BVH, for [`beam::Beam`]s of shadow rays.
    pub fn beams(&self) -> &beam::BeamBvh {
        &self.beam
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
}
