//! Per-scene topology, built once and reused across frames: edge adjacency, connected components,
//! which components are solid, coincident duplicates, and the smooth patches (objects) of open
//! components.
//!
//! Which triangles count as occluders matters for every algorithm that counts crossings (SISM's Eq. 4,
//! the ray-traced additive model): a ray through a closed object crosses it twice, so counting every
//! triangle would darken penumbrae twofold. Triangles of a closed, consistently oriented component
//! count only when they face the light; triangles of open components (leaves, planes, scans with
//! holes) always count, each being a single layer ([`SceneTopology::counts`]).

use std::collections::HashMap;

use glam::Vec3;

use super::Scene;

/// Largest share of a component's edges that may be open, non-manifold or inconsistently oriented for
/// it to count as a solid (only its light-facing triangles occlude). Real meshes of solids have small
/// defects — the Stanford bunny's holes (0.2% of its edges), voxel faces meeting along an edge in
/// lost-empire (3%) — and should still count once per crossing, not twice; a leaf or a sheet is mostly
/// boundary. 5%: between the two.
pub const SOLID_MAX_DEFECTS: f32 = 0.05;

/// Largest angle between two triangles' normals across an edge for them to be one patch (degrees).
pub const PATCH_MAX_ANGLE_DEG: f32 = 60.0;

/// An edge and the triangles using it.
#[derive(Clone, Copy, Debug)]
pub struct EdgeTopology {
    /// Endpoints, world space.
    pub a: Vec3,
    /// Second endpoint, world space.
    pub b: Vec3,
    /// Range into [`SceneTopology::edge_triangles`].
    pub first: u32,
    /// Triangles using it: the length of its range in [`SceneTopology::edge_triangles`].
    pub count: u32,
    /// Connected component of its triangles (see [`SceneTopology::component`]).
    pub component: u32,
}

/// Triangles, their adjacency and closedness, for the whole scene.
#[derive(Clone, Debug, Default)]
pub struct SceneTopology {
    /// Triangle corners, world space, in [`Scene::triangles`] order.
    pub triangles: Vec<[Vec3; 3]>,
    /// True for triangles of a solid component: closed and consistently oriented up to
    /// [`SOLID_MAX_DEFECTS`] of its edges.
    pub closed: Vec<bool>,
    /// True for a triangle whose three (welded) corners repeat an earlier triangle's, in either
    /// winding: a coincident copy (double-sided leaves are often modelled so) adds no occlusion, but
    /// counted twice it would double its shadow. Duplicates never count and take no part in adjacency.
    pub duplicate: Vec<bool>,
    /// Number of duplicates found.
    pub duplicates: u32,
    /// Connected component (triangles joined through shared edges) of every triangle. Unique across
    /// meshes.
    pub component: Vec<u32>,
    /// Occluder ("object") of every triangle for the independent-occluder composition: a solid
    /// component is one object; an open component is cut into smooth patches, joined only across
    /// edges whose two triangles' normals agree within [`PATCH_MAX_ANGLE_DEG`] (a leaf, not the
    /// cluster of leaves it hangs in, which overlap one another like separate occluders).
    pub object: Vec<u32>,
    /// Every edge of every mesh (welded corners), once, with the triangles using it.
    pub edges: Vec<EdgeTopology>,
    /// For each edge's triangles: (triangle index, the triangle's vertex opposite the edge).
    pub edge_triangles: Vec<(u32, Vec3)>,
    /// Edges used by one triangle only.
    pub open_edges: u32,
    /// Edges used by three or more triangles.
    pub nonmanifold_edges: u32,
}

impl SceneTopology {
    /// Builds adjacency for every mesh of `scene`. Vertices at bit-identical positions are welded first,
    /// so meshes that repeat vertices along seams are still connected.
    pub fn build(scene: &Scene) -> SceneTopology {
        let mut topo = SceneTopology::default();
        for mesh in &scene.meshes {
            let base = topo.triangles.len() as u32;
            let first_edge = topo.edges.len();
            let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
            let welded: Vec<u32> = mesh
                .positions
                .iter()
                .map(|p| {
                    let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
                    let next = weld.len() as u32;
                    *weld.entry(key).or_insert(next)
                })
                .collect();
            // (low vertex, high vertex, triangle, forward?) for every triangle edge, sorted: a run of
            // equal keys is one edge.
            let mut uses: Vec<(u32, u32, u32, bool, u8)> = Vec::with_capacity(mesh.triangles.len() * 3);
            let mut seen: HashMap<[u32; 3], u32> = HashMap::new();
            let mut duplicate = vec![false; mesh.triangles.len()];
            for (t, tri) in mesh.triangles.iter().enumerate() {
                let w = tri.map(|i| welded[i as usize]);
                if w[0] == w[1] || w[1] == w[2] || w[2] == w[0] {
                    continue; // degenerate: it has no area, so it occludes nothing
                }
                let mut key = w;
                key.sort_unstable();
                if seen.insert(key, t as u32).is_some() {
                    duplicate[t] = true;
                    topo.duplicates += 1;
                    continue;
                }
                for k in 0..3 {
                    let (i, j) = (w[k], w[(k + 1) % 3]);
                    uses.push((i.min(j), i.max(j), t as u32, i < j, k as u8));
                }
            }
            uses.sort_unstable();
            let n = mesh.triangles.len();
            let mut parent: Vec<u32> = (0..n as u32).collect();
            let mut defective = Vec::new(); // per edge of this mesh: not two consistently oriented uses
            let mut smooth_pairs = Vec::new(); // per edge: its two triangles when they form one patch
            let mut run = 0;
            while run < uses.len() {
                let mut end = run + 1;
                while end < uses.len() && (uses[end].0, uses[end].1) == (uses[run].0, uses[run].1) {
                    end += 1;
                }
                let group = &uses[run..end];
                let (t0, k0) = (group[0].2 as usize, group[0].4 as usize);
                let tri0 = mesh.triangles[t0];
                let a = mesh.positions[tri0[k0] as usize];
                let b = mesh.positions[tri0[(k0 + 1) % 3] as usize];
                let first = topo.edge_triangles.len() as u32;
                for &(_, _, t, _, k) in group {
                    let tri = mesh.triangles[t as usize];
                    let opposite = mesh.positions[tri[(k as usize + 2) % 3] as usize];
                    topo.edge_triangles.push((base + t, opposite));
                }
                topo.edges.push(EdgeTopology {
                    a,
                    b,
                    first,
                    count: group.len() as u32,
                    component: base + t0 as u32, // fixed up to the component root below
                });
                let consistent = group.len() == 2 && group[0].3 != group[1].3;
                defective.push(!consistent);
                let smooth = group.len() == 2 && {
                    let normal = |t: u32| {
                        let [p, q, r] = mesh.corners(t as usize);
                        (q - p).cross(r - p).normalize_or_zero()
                    };
                    // Inconsistent winding flips one normal: compare orientation-free then.
                    let d = normal(group[0].2).dot(normal(group[1].2));
                    let d = if consistent { d } else { d.abs() };
                    d >= PATCH_MAX_ANGLE_DEG.to_radians().cos()
                };
                smooth_pairs.push(smooth.then(|| (group[0].2, group[1].2)));
                if group.len() == 1 {
                    topo.open_edges += 1;
                } else if group.len() > 2 {
                    topo.nonmanifold_edges += 1;
                }
                for w in group.windows(2) {
                    union(&mut parent, w[0].2, w[1].2);
                }
                run = end;
            }
            // A component is solid when nearly all its edges join two consistently oriented triangles
            // (see SOLID_MAX_DEFECTS).
            let mut edges_of = vec![0u32; n];
            let mut defects_of = vec![0u32; n];
            for (e, &bad) in topo.edges[first_edge..].iter_mut().zip(&defective) {
                let root = find(&mut parent, e.component - base);
                e.component = base + root;
                edges_of[root as usize] += 1;
                defects_of[root as usize] += bad as u32;
            }
            let component_open: Vec<bool> = (0..n)
                .map(|r| defects_of[r] as f32 > SOLID_MAX_DEFECTS * edges_of[r] as f32)
                .collect();
            let mut patch: Vec<u32> = (0..n as u32).collect();
            for &(a, b) in smooth_pairs.iter().flatten() {
                union(&mut patch, a, b);
            }
            for (t, &dup) in duplicate.iter().enumerate() {
                let root = find(&mut parent, t as u32) as usize;
                let object = if component_open[root] {
                    find(&mut patch, t as u32)
                } else {
                    root as u32
                };
                topo.object.push(base + object);
                topo.component.push(base + root as u32);
                topo.closed.push(!component_open[root]);
                topo.triangles.push(mesh.corners(t));
                topo.duplicate.push(dup);
            }
        }
        topo
    }

    /// True when triangle `t` counts as an occluder for a light at `c` (see the module docs).
    #[inline]
    pub fn counts(&self, t: usize, c: Vec3) -> bool {
        self.counts_counted(sism_simd::Portable, t, c)
    }

    /// [`SceneTopology::counts`] with its loads, branches and plane test counted by `s` (the same
    /// answer): the two flags' loads and branches, the corners' read and the facing test's cross and
    /// dot products.
    #[inline(always)]
    pub fn counts_counted<S: sism_simd::Simd>(&self, s: S, t: usize, c: Vec3) -> bool {
        use crate::counted::{cross, dot, sub};
        if s.s_branch(s.s_load(&self.duplicate, t)) {
            return false;
        }
        if !s.s_branch(s.s_load(&self.closed, t)) {
            return true;
        }
        let tri = s.s_read_words(&self.triangles[t]);
        let n = cross(s, sub(s, tri[1], tri[0]), sub(s, tri[2], tri[0]));
        s.s_lt(0.0, dot(s, n, sub(s, c, tri[0])))
    }
}

/// True when the front side (counter-clockwise) of `tri` faces the point `c`.
#[inline]
pub fn faces_point(tri: &[Vec3; 3], c: Vec3) -> bool {
    (tri[1] - tri[0]).cross(tri[2] - tri[0]).dot(c - tri[0]) > 0.0
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // The smaller root wins, so the forest does not depend on visiting order.
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}
