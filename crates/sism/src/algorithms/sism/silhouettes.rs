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
use sism_simd::{Kernel, Simd};

use super::occlusion::EdgeRecord;
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
        s.scalar_read(self.edges);
        for e in self.edges {
            let tris = &self.topo.edge_triangles[e.first as usize..(e.first + e.count) as usize];
            s.scalar_read(tris);
            let before = out.edges.len();
            edge_records(
                self.topo,
                e,
                self.c,
                self.per_object,
                &mut out.edges,
                &mut out.objects,
            );
            // Per edge: fetch and the loop (~8), per adjacent triangle the counted test (a plane test
            // of ~12 for closed components), the side test of a fold (~16), ~20 per record written.
            s.scalar_ops(8 + 14 * e.count as u64 + 16 + 20 * (out.edges.len() - before) as u64);
        }
        s.scalar_write(&out.edges);
        s.end_task();
        out
    }
}

fn edge_records(
    topo: &SceneTopology,
    e: &EdgeTopology,
    c: Vec3,
    per_object: bool,
    out: &mut Vec<EdgeRecord>,
    objects: &mut Vec<u32>,
) {
    let tris = &topo.edge_triangles[e.first as usize..(e.first + e.count) as usize];
    let counted: Vec<(Vec3, u32)> = tris
        .iter()
        .filter(|(t, _)| topo.counts(*t as usize, c))
        .map(|&(t, v3)| (v3, topo.object[t as usize]))
        .collect();
    let rel = |p: Vec3| (p - c).to_array();
    let mut push = |v3: &[Vec3], object: u32| {
        out.push(EdgeRecord {
            a: rel(e.a),
            b: rel(e.b),
            v3: [rel(v3[0]), rel(*v3.get(1).unwrap_or(&v3[0]))],
            n_tri: v3.len() as u32,
        });
        objects.push(object);
    };
    match (e.count, counted.len()) {
        (_, 0) => {}
        (2, 2) if !per_object || counted[0].1 == counted[1].1 => {
            // Same side of the edge as seen from the light: a fold, the terms add (silhouette).
            // Opposite sides: the terms cancel, nothing to do.
            let m = (e.a - c).cross(e.b - c);
            if m.dot(counted[0].0 - c) * m.dot(counted[1].0 - c) >= 0.0 {
                push(&[counted[0].0, counted[1].0], counted[0].1);
            }
        }
        (_, _) => {
            for &(v3, object) in &counted {
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
