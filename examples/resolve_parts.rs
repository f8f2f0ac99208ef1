//! Where the eye resolve's host time goes, by part, against the model's issue for the same
//! operations: `cargo run --release --example resolve_parts -- MACHINE [full|silhouettes]`.
//!
//! The kernel is `raster::eye`'s `write_receivers` on synthetic tiles (64×64 pixels, 4×4 blocks; every
//! pixel covered, or discs of coverage with silhouettes): per block a vector part (the centre ray,
//! five gathers of the winning triangle's plane, eight divides and square roots, selects) and a lane
//! part (per pixel: six lane reads, an `Option<Receiver>` and a triangle id stored). The output tile
//! (115 KB) is reused, so memory beyond L2 plays no part: what is timed is issue. Variants:
//! - `full`: the kernel as `write_receivers` has it;
//! - `vector-part`: the vector part, its results stored as seven vectors (no lane loop);
//! - `lane-part`: the lane loop alone, reading lanes of arrays written long before;
//! - `far-lanes`: both parts, the lane loop reading arrays written long before (no forwarding);
//! - `const-stores`: both parts, the lane loop storing constants (no lane reads).
//!
//! Each variant's host time is the best of 27 runs of 1,000 tiles, interleaved; the model's is
//! `timing::port_bounds(..).issue()` over the counted tasks (no memory), on MACHINE (a
//! `sism calibrate` file of this host). Measured on the Intel Xeon VM (ARCHITECTURE.md, "The eye
//! resolve's lane loop"): the lane loop adds to the vector part instead of hiding under it.
use sism::frame::Receiver;
use sism::sampling::Rng;
use sism_simd::{Kernel, Recorder, Simd};
use std::hint::black_box;

const TILE: usize = 64;
const BLOCKS: usize = (TILE / 4) * (TILE / 4);
const NO_TRIANGLE: u32 = u32::MAX;

#[derive(Clone, Copy, PartialEq, Debug)]
enum Variant {
    Full,
    VectorPart,
    LanePart,
    FarLanes,
    ConstStores,
}

const VARIANTS: [(Variant, &str); 5] = [
    (Variant::Full, "full"),
    (Variant::VectorPart, "vector-part"),
    (Variant::LanePart, "lane-part"),
    (Variant::FarLanes, "far-lanes"),
    (Variant::ConstStores, "const-stores"),
];

/// The winning triangles' planes, by list position.
struct Table {
    nx: Vec<f32>,
    ny: Vec<f32>,
    nz: Vec<f32>,
    plane_dist: Vec<f32>,
    original: Vec<i32>,
}

struct Inputs {
    /// Per tile, the winning list position of each pixel (-1: uncovered), in block order.
    ids: Vec<Vec<i32>>,
    /// Per tile, 1 / view depth of each pixel, in block order.
    inv_z: Vec<Vec<f32>>,
    table: Table,
    /// Lane arrays written once, before any timing (`lane-part`, `far-lanes`).
    far: [[f32; 16]; 6],
}

struct Resolve<'a> {
    inp: &'a Inputs,
    pixels: &'a mut [Option<Receiver>],
    triangles: &'a mut [u32],
    soa: &'a mut [f32],
    variant: Variant,
    tiles: usize,
}

fn lanes(f: impl Fn(usize) -> f32) -> [f32; 16] {
    std::array::from_fn(f)
}

impl Kernel for Resolve<'_> {
    type Output = u64;
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // index loops keep every vector op in the kernel body
    fn run<S: Simd>(self, s: S) -> u64 {
        let t = &self.inp.table;
        let (one, two, half, zero) = (s.splat_f(1.0), s.splat_f(2.0), s.splat_f(0.5), s.splat_f(0.0));
        let (w, h) = (s.splat_f(1600.0), s.splat_f(1200.0));
        let (tan, aspect) = (s.splat_f(0.4), s.splat_f(4.0 / 3.0));
        let fw = [s.splat_f(0.1), s.splat_f(0.2), s.splat_f(0.97)];
        let rt = [s.splat_f(0.99), s.splat_f(0.0), s.splat_f(-0.1)];
        let up = [s.splat_f(0.0), s.splat_f(0.99), s.splat_f(-0.2)];
        let eye = [s.splat_f(1.0), s.splat_f(2.0), s.splat_f(3.0)];
        let lane_x = s.from_array_f(lanes(|k| (k % 4) as f32));
        let lane_y = s.from_array_f(lanes(|k| (k / 4) as f32));
        let mut covered = 0u64;
        let mut stored = [[0.0f32; 16]; 7];
        for rep in 0..self.tiles {
            let tile = rep % self.inp.ids.len();
            s.begin_task(1);
            let (ids, inv_zs) = (&self.inp.ids[tile], &self.inp.inv_z[tile]);
            for b in 0..BLOCKS {
                let base = b * 16;
                let (bx, by) = ((b % (TILE / 4)) * 4, (b / (TILE / 4)) * 4);
                let slot = s.load_i(&ids[base..base + 16]);
                let hit = s.cmp_ge_i(slot, s.splat_i(0));
                if self.variant != Variant::VectorPart && !s.s_branch(s.mask_any(hit)) {
                    for r in 0..4 {
                        for c in 0..4 {
                            let i = (by + r) * TILE + bx + c;
                            s.s_wrote(write(&mut self.pixels[i], None));
                            s.s_wrote(write(&mut self.triangles[i], NO_TRIANGLE));
                        }
                    }
                    continue;
                }
                let (pos, nrm, original): ([[f32; 16]; 3], [[f32; 16]; 3], [i32; 16]);
                if self.variant == Variant::LanePart {
                    let far = &self.inp.far;
                    (pos, nrm, original) = ([far[0], far[1], far[2]], [far[3], far[4], far[5]], [7; 16]);
                } else {
                    // `write_receivers`' vector part, operation for operation.
                    let i = s.add_f(lane_x, s.splat_f(bx as f32));
                    let j = s.add_f(lane_y, s.splat_f(by as f32));
                    let sx = s.div_f(s.mul_f(two, s.add_f(i, half)), w);
                    let sx = s.mul_f(s.mul_f(s.sub_f(sx, one), tan), aspect);
                    let sy = s.div_f(s.mul_f(two, s.add_f(j, half)), h);
                    let sy = s.mul_f(s.sub_f(one, sy), tan);
                    let mut d = [zero; 3];
                    for c in 0..3 {
                        d[c] = s.add_f(s.add_f(fw[c], s.mul_f(sx, rt[c])), s.mul_f(sy, up[c]));
                    }
                    let dd = s.add_f(
                        s.add_f(s.mul_f(d[0], d[0]), s.mul_f(d[1], d[1])),
                        s.mul_f(d[2], d[2]),
                    );
                    let inv_len = s.div_f(one, s.sqrt_f(dd));
                    let mut dir = [zero; 3];
                    for c in 0..3 {
                        dir[c] = s.mul_f(d[c], inv_len);
                    }
                    let n = [
                        s.mask_gather_f(zero, hit, &t.nx, slot),
                        s.mask_gather_f(zero, hit, &t.ny, slot),
                        s.mask_gather_f(zero, hit, &t.nz, slot),
                    ];
                    let plane_dist = s.mask_gather_f(zero, hit, &t.plane_dist, slot);
                    let orig = s.mask_gather_i(s.splat_i(-1), hit, &t.original, slot);
                    let denom = s.add_f(
                        s.add_f(s.mul_f(n[0], dir[0]), s.mul_f(n[1], dir[1])),
                        s.mul_f(n[2], dir[2]),
                    );
                    let dist = s.div_f(plane_dist, denom);
                    let ahead =
                        s.mask_and(s.cmp_gt_f(dist, zero), s.cmp_lt_f(dist, s.splat_f(f32::INFINITY)));
                    let inv_z = s.load_f(&inv_zs[base..base + 16]);
                    let away = s.cmp_gt_f(denom, zero);
                    let mut pv = [zero; 3];
                    let mut nv = [zero; 3];
                    for c in 0..3 {
                        let on_plane = s.add_f(eye[c], s.mul_f(dir[c], dist));
                        let by_depth = s.add_f(eye[c], s.div_f(d[c], inv_z));
                        pv[c] = s.select_f(ahead, on_plane, by_depth);
                        nv[c] = s.select_f(away, s.neg_f(n[c]), n[c]);
                    }
                    match self.variant {
                        Variant::VectorPart => {
                            let o = b * 16 * 7;
                            for c in 0..3 {
                                s.store_f(&mut self.soa[o + 16 * c..o + 16 * c + 16], pv[c]);
                                s.store_f(&mut self.soa[o + 48 + 16 * c..o + 64 + 16 * c], nv[c]);
                            }
                            s.store_f(&mut self.soa[o + 96..o + 112], s.cast_i_f(orig));
                            covered += s.mask_popcnt(hit) as u64;
                            continue;
                        }
                        Variant::FarLanes => {
                            for c in 0..3 {
                                stored[c] = s.to_array_f(pv[c]);
                                stored[3 + c] = s.to_array_f(nv[c]);
                            }
                            stored[6] = s.to_array_f(s.cast_i_f(orig));
                            let far = &self.inp.far;
                            (pos, nrm, original) =
                                ([far[0], far[1], far[2]], [far[3], far[4], far[5]], [7; 16]);
                        }
                        _ => {
                            pos = [s.to_array_f(pv[0]), s.to_array_f(pv[1]), s.to_array_f(pv[2])];
                            nrm = [s.to_array_f(nv[0]), s.to_array_f(nv[1]), s.to_array_f(nv[2])];
                            original = s.to_array_i(orig);
                        }
                    }
                }
                for r in 0..4 {
                    for c in 0..4 {
                        let k = 4 * r + c;
                        let i = (by + r) * TILE + bx + c;
                        if s.s_branch(hit.test(k)) {
                            let value = if self.variant == Variant::ConstStores {
                                Receiver {
                                    position: glam::Vec3::new(1.0, 2.0, 3.0),
                                    normal: glam::Vec3::new(0.0, 0.0, 1.0),
                                }
                            } else {
                                // Counted as `write_receivers` counts it: six lane reads.
                                let lane = |a: &[f32; 16]| s.s_load(a, k);
                                Receiver {
                                    position: glam::Vec3::new(lane(&pos[0]), lane(&pos[1]), lane(&pos[2])),
                                    normal: glam::Vec3::new(lane(&nrm[0]), lane(&nrm[1]), lane(&nrm[2])),
                                }
                            };
                            s.s_wrote_words(write(&mut self.pixels[i], Some(value)));
                            s.s_wrote(write(&mut self.triangles[i], s.s_load(&original, k) as u32));
                            covered += 1;
                        } else {
                            s.s_wrote(write(&mut self.pixels[i], None));
                            s.s_wrote(write(&mut self.triangles[i], NO_TRIANGLE));
                        }
                    }
                }
            }
            s.end_task();
        }
        black_box(&stored);
        covered
    }
}

#[inline(always)]
fn write<T>(slot: &mut T, v: T) -> &T {
    *slot = v;
    slot
}

/// A random list position below `n` (the project's deterministic generator).
fn below(rng: &mut Rng, n: usize) -> i32 {
    ((rng.next_f32() * n as f32) as usize).min(n - 1) as i32
}

/// 16 tiles; `silhouettes`: twelve discs of one triangle each over every tile, else every pixel a
/// random triangle's.
fn inputs(silhouettes: bool) -> Inputs {
    let triangles: usize = 4096;
    let mut rng = Rng::new(0x1234_5678, 0);
    let table = Table {
        nx: (0..triangles).map(|_| rng.next_f32() - 0.5).collect(),
        ny: (0..triangles).map(|_| rng.next_f32() - 0.5).collect(),
        nz: (0..triangles).map(|_| rng.next_f32() + 0.1).collect(),
        plane_dist: (0..triangles).map(|_| rng.next_f32() * 10.0).collect(),
        original: (0..triangles as i32).collect(),
    };
    let (mut ids, mut inv_z) = (vec![], vec![]);
    for _ in 0..16 {
        let mut id = vec![-1i32; TILE * TILE];
        let mut z = vec![0.0f32; TILE * TILE];
        let discs: Vec<(f32, f32, f32, i32)> = (0..12)
            .map(|_| {
                let (x, y, r) = (
                    rng.next_f32() * 64.0,
                    rng.next_f32() * 64.0,
                    4.0 + rng.next_f32() * 14.0,
                );
                (x, y, r, below(&mut rng, triangles))
            })
            .collect();
        for y in 0..TILE {
            for x in 0..TILE {
                let k = ((y / 4) * (TILE / 4) + x / 4) * 16 + (y % 4) * 4 + x % 4;
                z[k] = 0.1 + rng.next_f32();
                if !silhouettes {
                    id[k] = below(&mut rng, triangles);
                    continue;
                }
                for &(cx, cy, r, t) in &discs {
                    if (x as f32 - cx).powi(2) + (y as f32 - cy).powi(2) < r * r {
                        id[k] = t;
                    }
                }
            }
        }
        ids.push(id);
        inv_z.push(z);
    }
    let far = std::array::from_fn(|c| std::array::from_fn(|k| (c * 16 + k) as f32 * 0.01));
    Inputs {
        ids,
        inv_z,
        table,
        far,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(machine), coverage) = (args.get(1), args.get(2).map_or("full", String::as_str)) else {
        eprintln!("usage: resolve_parts MACHINE [full|silhouettes]");
        std::process::exit(2);
    };
    let m =
        sism::machine::config::MachineConfig::load(std::path::Path::new(machine), None).unwrap_or_else(|e| {
            eprintln!("error: {machine}: {e}");
            std::process::exit(1)
        });
    let inp = inputs(coverage == "silhouettes");
    let covered: usize = inp
        .ids
        .iter()
        .map(|t| t.iter().filter(|&&i| i >= 0).count())
        .sum();
    println!(
        "{coverage}: {:.0}% of pixels covered; backend {:?}; machine {machine}",
        100.0 * covered as f64 / (16 * TILE * TILE) as f64,
        sism_simd::selected_backend()
    );
    let mut pixels = vec![None; TILE * TILE];
    let mut triangles = vec![0u32; TILE * TILE];
    let mut soa = vec![0.0f32; BLOCKS * 16 * 7];
    let tiles = 1000;
    let mut best = [f64::MAX; VARIANTS.len()];
    for _round in 0..9 {
        for (v, (variant, _)) in VARIANTS.iter().enumerate() {
            for _ in 0..3 {
                let t0 = std::time::Instant::now();
                black_box(sism_simd::run_native(Resolve {
                    inp: &inp,
                    pixels: &mut pixels,
                    triangles: &mut triangles,
                    soa: &mut soa,
                    variant: *variant,
                    tiles,
                }));
                best[v] = best[v].min(t0.elapsed().as_secs_f64() * 1e9 / (tiles * BLOCKS) as f64);
            }
        }
    }
    println!("variant,host_ns_per_block,model_ns_per_block,vector,load_store,scalar,chain,mispredict");
    for (v, (variant, name)) in VARIANTS.iter().enumerate() {
        let rec = Recorder::new();
        sism_simd::run_counting(
            &rec,
            Resolve {
                inp: &inp,
                pixels: &mut pixels,
                triangles: &mut triangles,
                soa: &mut soa,
                variant: *variant,
                tiles: 16,
            },
        );
        let mut sum = [0f64; 6];
        for t in rec.take_tasks() {
            let b = sism::machine::timing::port_bounds(&t.counters, &m);
            for (acc, x) in
                sum.iter_mut()
                    .zip([b.issue(), b.vector, b.load_store, b.scalar, b.chain, b.mispredict])
            {
                *acc += x;
            }
        }
        let ns = |cycles: f64| cycles / (16 * BLOCKS) as f64 / m.clock_ghz;
        println!(
            "{name},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1}",
            best[v],
            ns(sum[0]),
            ns(sum[1]),
            ns(sum[2]),
            ns(sum[3]),
            ns(sum[4]),
            ns(sum[5])
        );
    }
}
