//! Silhouette edges with respect to the light centre, found per frame from the scene's adjacency
//! ([`SceneTopology`], built once per scene).
//!
//! Silhouettes follow from the counted triangles ([`SceneTopology::counts`]): an edge whose counted
//! neighbours lie on the same side of it as seen from the light, or that has one counted neighbour
//! only (open, non-manifold, or the front-facing side of a closed object's outline). Edge terms of two
//! counted triangles on opposite sides cancel exactly, so dropping those edges is an optimisation
//! only: correctness never depends on the adjacency being found.

use glam::Vec3;
use rayon::prelude::*;
use sism_simd::{Kernel, ScalarClass, Simd};

use super::occlusion::EdgeRecord;
use crate::counted;
use crate::exec::{task_kind, Exec, Phase};
use crate::scene::topology::{EdgeTopology, SceneTopology};

/// Edges per silhouette task.
pub const CHUNK: usize = 4096;

/// A frame's silhouette edge records (relative to the light centre) and the object
/// ([`SceneTopology::object`]) of each.
#[derive(Clone, Debug, Default)]
pub struct Silhouettes {
    /// Silhouette edge records, relative to the light centre.
    pub edges: Vec<EdgeRecord>,
    /// Object of each edge, parallel to `edges`.
    pub objects: Vec<u32>,
}

/// The silhouettes with respect to the light centre `c`, one task per [`CHUNK`] edges. With
/// `per_object`, an edge between two objects gives each its own record even where their terms would
/// cancel: the independent composition evaluates objects apart, so nothing cancels across them.
pub fn extract(phase: &mut Phase, topo: &SceneTopology, c: Vec3, per_object: bool) -> Silhouettes {
    let per_chunk = phase.run_par(
        "",
        topo.edges.par_chunks(CHUNK).map(|edges| SilhouetteChunk {
            topo,
            edges,
            c,
            per_object,
        }),
    );
    let mut out = Silhouettes::default();
    for s in per_chunk {
        out.edges.extend(s.edges);
        out.objects.extend(s.objects);
    }
    out
}

/// The silhouette edge records with respect to `c`, natively (for tests and tools).
pub fn silhouettes(topo: &SceneTopology, c: Vec3) -> Vec<EdgeRecord> {
    let mut log = crate::exec::FrameLog::new(Exec::Native);
    log.phase("silhouettes", "silhouettes", |p| extract(p, topo, c, false))
        .edges
}

/// One silhouette task: a chunk of the scene's edges.
struct SilhouetteChunk<'a> {
    topo: &'a SceneTopology,
    edges: &'a [EdgeTopology],
    c: Vec3,
    per_object: bool,
}

impl Kernel for SilhouetteChunk<'_> {
    type Output = Silhouettes;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Silhouettes {
        s.begin_task(task_kind::SILHOUETTES);
        let mut out = Silhouettes::default();
        // The neighbours that count, per edge (one buffer for the task, not one per edge).
        let mut lit = Vec::new();
        s.scalar_read(self.edges);
        for k in 0..self.edges.len() {
            // The edge's record: endpoints, range (its lines read with the chunk above).
            let e = &self.edges[k];
            for _ in 0..4 {
                s.scalar_op(ScalarClass::Mem);
            }
            edge_records(s, self.topo, e, self.c, self.per_object, &mut lit, &mut out);
        }
        s.end_task();
        out
    }
}

/// The records of edge `e` (none, one per counting neighbour, or one for a fold) pushed to `out`;
/// every operation counted by `s`. `lit` is scratch space.
#[inline(always)]
fn edge_records<S: Simd>(
    s: S,
    topo: &SceneTopology,
    e: &EdgeTopology,
    c: Vec3,
    per_object: bool,
    lit: &mut Vec<(Vec3, u32)>,
    out: &mut Silhouettes,
) {
    let tris = &topo.edge_triangles[e.first as usize..(e.first + e.count) as usize];
    s.scalar_read(tris);
    lit.clear();
    for k in 0..tris.len() {
        let (t, v3) = counted::streamed(s, tris, k);
        if topo.counts_counted(s, t as usize, c) {
            s.s_push(lit, (v3, s.s_load(&topo.object, t as usize)));
        }
    }
    let rel = |p: Vec3| counted::sub(s, p, c).to_array();
    let mut push = |v3: &[Vec3], object: u32| {
        let record = EdgeRecord {
            a: rel(e.a),
            b: rel(e.b),
            v3: [rel(v3[0]), rel(*v3.get(1).unwrap_or(&v3[0]))],
            n_tri: v3.len() as u32,
        };
        s.s_push(&mut out.edges, record);
        s.s_push(&mut out.objects, object);
    };
    s.scalar_op(ScalarClass::Branch); // the match on the counts
    match (e.count, lit.len()) {
        (_, 0) => {}
        (2, 2) if !per_object || s.s_branch(lit[0].1 == lit[1].1) => {
            // Same side of the edge as seen from the light: a fold, the terms add (silhouette).
            // Opposite sides: the terms cancel, nothing to do.
            let m = counted::cross(s, counted::sub(s, e.a, c), counted::sub(s, e.b, c));
            let side = |p: Vec3| counted::dot(s, m, counted::sub(s, p, c));
            if s.s_le(0.0, s.s_mul(side(lit[0].0), side(lit[1].0))) {
                push(&[lit[0].0, lit[1].0], lit[0].1);
            }
        }
        (_, _) => {
            for &(v3, object) in lit.iter() {
                push(&[v3], object);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{shapes, Scene};

    fn scene_of(meshes: Vec<crate::scene::Mesh>) -> Scene {
        Scene {
            source: "test".into(),
            origin: [0.0; 3],
            meshes,
            camera: crate::scene::Camera {
                eye: [0.0, 0.0, 5.0],
                look_at: [0.0; 3],
                up: [0.0, 1.0, 0.0],
                fov_y_deg: 45.0,
                width: 8,
                height: 8,
            },
            light: crate::scene::Light {
                center: [0.0, 10.0, 0.0],
                radius: 1.0,
            },
        }
    }

    #[test]
    fn box_is_closed_and_has_a_four_edge_outline_from_above() {
        let topo = SceneTopology::build(&scene_of(vec![shapes::axis_box("b", Vec3::ZERO, Vec3::ONE)]));
        assert!(topo.closed.iter().all(|&c| c));
        assert_eq!(topo.edges.len(), 18);
        assert_eq!(topo.open_edges, 0);
        // Light straight above: the outline is the top face's 4 edges.
        let sil = silhouettes(&topo, Vec3::new(0.5, 10.0, 0.5));
        assert_eq!(sil.len(), 4, "{sil:?}");
        assert!(sil.iter().all(|r| r.n_tri == 1));
    }

    #[test]
    fn quad_is_open_and_its_border_is_the_silhouette() {
        let q = shapes::quad("q", Vec3::ZERO, Vec3::X, Vec3::Z);
        let topo = SceneTopology::build(&scene_of(vec![q]));
        assert!(topo.closed.iter().all(|&c| !c));
        // Both triangles count from either side; the diagonal cancels; 4 border edges remain.
        assert_eq!(silhouettes(&topo, Vec3::new(0.3, 5.0, 0.2)).len(), 4);
        assert_eq!(silhouettes(&topo, Vec3::new(0.3, -5.0, 0.2)).len(), 4);
    }
}
