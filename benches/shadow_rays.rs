//! Shadow-ray throughput per thread: the reference's beams, its one-ray-at-a-time CWBVH tracer, and
//! (with `--features embree`) Intel Embree 3 on the very same rays, in one run.
//!
//! `cargo bench --bench shadow_rays [--features embree] [-- ROUNDS]` (default 3 rounds). Embree needs
//! Debian's `libembree-dev` (`apt-get install libembree-dev`). Per scene: one primary ray per pixel at
//! 160×120, then for each receiver facing the light 256 stratified light-disk samples (the
//! reference's rays exactly: its origin offset, sample jitter and segment ends), stored once. Each
//! round traces every ray with every tracer in turn on one thread (the calling thread; Embree's
//! device is made with `threads=1`), so the machine's noise falls on all alike; the table gives the
//! median rays per second over rounds and each ratio to Embree's single rays (`rtcOccluded1`, the
//! way a general tracer is compared) and to its 16-ray packets (`rtcOccluded16` over the same
//! groups of 16 consecutive rays of one receiver that the beams use). Every tracer's answers are
//! compared ray by ray with the CWBVH tracer's.

mod common;

use sism::scene::Scene;

use std::time::Instant;

use glam::Vec3;
use sism::algorithms::reference::{cast_primary_rays, DiskRays};
use sism::bvh::beam::{Beam, BEAM_RAYS};
use sism::bvh::SceneBvh;
use sism::sampling::{Rng, Strata};
use sism_simd::{Kernel, Mask16, Simd};

const SPP: u32 = 256;
const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;

/// One receiver's rays: a shared origin, unit directions and segment lengths.
struct Receiver {
    origin: Vec3,
    rays: Vec<(Vec3, f32)>,
}

/// The reference's shadow rays of every receiver facing the light (those below its tangent plane,
/// which the reference counts as occluded without a ray, left out).
fn shadow_rays(scene: &Scene, bvh: &SceneBvh) -> Vec<Receiver> {
    let receivers = cast_primary_rays(scene, bvh);
    let strata = Strata::new(SPP);
    let light = &scene.light;
    let mut out = Vec::new();
    for (i, r) in receivers.pixels.iter().enumerate() {
        let Some(r) = r else { continue };
        let Some(disk) = DiskRays::new(bvh, light.center(), light.radius, r) else {
            continue;
        };
        let mut rng = Rng::new(0, i as u64);
        let rays = (0..strata.count())
            .filter_map(|k| disk.ray(disk.sample(k, &strata, &mut rng).0))
            .collect();
        out.push(Receiver {
            origin: disk.origin,
            rays,
        });
    }
    out
}

/// Every receiver's rays as beams of up to [`BEAM_RAYS`]; returns the occluded rays.
struct TraceBeams<'a> {
    bvh: &'a SceneBvh,
    receivers: &'a [Receiver],
    answers: &'a mut Vec<bool>,
}

impl Kernel for TraceBeams<'_> {
    type Output = ();
    #[inline(always)]
    fn run<S: Simd>(self, s: S) {
        let mut beam = Beam::new(Vec3::ZERO);
        let mut stack = Vec::new();
        let mut hits = [Mask16::NONE; BEAM_RAYS / 16];
        self.answers.clear();
        for r in self.receivers {
            for chunk in r.rays.chunks(BEAM_RAYS) {
                beam.reset(r.origin);
                for &(d, len) in chunk {
                    beam.push(d, len);
                }
                self.bvh.beams().occluded(s, &beam, &mut stack, &mut hits);
                self.answers
                    .extend((0..chunk.len()).map(|k| hits[k / 16].test(k % 16)));
            }
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A tracer of the comparison: name and "trace every ray, write the answers".
type Tracer<'a> = (&'static str, Box<dyn FnMut(&mut Vec<bool>) + 'a>);

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(3)
        .max(1);
    println!(
        "backend {}, one thread, {rounds} rounds, {WIDTH}x{HEIGHT} receivers, {SPP} rays each",
        sism_simd::selected_backend().name()
    );
    for name in ["stanford-bunny", "japanese-maple", "palm"] {
        let Some(scene) = common::scene(name, WIDTH, HEIGHT) else {
            continue;
        };
        let t = Instant::now();
        let bvh = SceneBvh::build(&scene);
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        let receivers = shadow_rays(&scene, &bvh);
        let n_rays: usize = receivers.iter().map(|r| r.rays.len()).sum();
        println!(
            "\n{name}: {} triangles (sism BVH build {build_ms:.0} ms), {} receivers, {n_rays} rays",
            scene.triangle_count(),
            receivers.len()
        );
        #[cfg(feature = "embree")]
        let embree = embree::Embree::new(&scene);
        #[allow(unused_mut)] // Embree's tracers join with the feature
        let mut tracers: Vec<Tracer> = vec![
            (
                "sism beams",
                Box::new(|answers: &mut Vec<bool>| {
                    sism_simd::run_native(TraceBeams {
                        bvh: &bvh,
                        receivers: &receivers,
                        answers,
                    })
                }),
            ),
            (
                "sism single rays (CWBVH)",
                Box::new(|answers: &mut Vec<bool>| {
                    answers.clear();
                    for r in &receivers {
                        answers.extend(r.rays.iter().map(|&(d, len)| bvh.occluded(r.origin, d, len)));
                    }
                }),
            ),
        ];
        #[cfg(feature = "embree")]
        {
            tracers.push((
                "embree rtcOccluded1",
                Box::new(|answers: &mut Vec<bool>| embree.occluded1(&receivers, answers)),
            ));
            tracers.push((
                "embree rtcOccluded16",
                Box::new(|answers: &mut Vec<bool>| embree.occluded16(&receivers, answers)),
            ));
        }
        let mut times = vec![Vec::new(); tracers.len()];
        let mut answers = vec![Vec::new(); tracers.len()];
        for _ in 0..rounds {
            for (k, (_, trace)) in tracers.iter_mut().enumerate() {
                let t = Instant::now();
                trace(&mut answers[k]);
                times[k].push(t.elapsed().as_secs_f64());
            }
        }
        let rate: Vec<f64> = times.into_iter().map(|t| n_rays as f64 / median(t)).collect();
        let find = |label: &str| tracers.iter().position(|(n, _)| *n == label).map(|k| rate[k]);
        let (e1, e16) = (find("embree rtcOccluded1"), find("embree rtcOccluded16"));
        println!(
            "{:<28} {:>12} {:>10} {:>12} {:>12}",
            "tracer", "Mrays/s", "occluded", "÷ embree 1", "÷ embree 16"
        );
        let reference = &answers[1];
        for (k, (label, _)) in tracers.iter().enumerate() {
            let differ = answers[k].iter().zip(reference).filter(|(a, b)| a != b).count();
            let ratio = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("{:.2}", rate[k] / e));
            println!(
                "{label:<28} {:>12.2} {:>9.1}% {:>12} {:>12}   ({differ} answers differ from the CWBVH tracer's)",
                rate[k] / 1e6,
                100.0 * answers[k].iter().filter(|&&h| h).count() as f64 / n_rays as f64,
                ratio(e1),
                ratio(e16),
            );
        }
    }
}

/// The few Embree 3 calls the comparison needs (Debian's libembree3).
#[cfg(feature = "embree")]
mod embree {
    use std::ffi::c_void;
    use std::os::raw::{c_char, c_int, c_uint};

    use super::Receiver;
    use sism::scene::Scene;

    type Device = *mut c_void;
    type EScene = *mut c_void;
    type Geometry = *mut c_void;

    #[repr(C)]
    struct IntersectContext {
        flags: c_uint,
        filter: *const c_void,
        inst_id: [c_uint; 1],
    }

    #[repr(C, align(16))]
    #[derive(Clone, Copy)]
    struct Ray {
        org: [f32; 3],
        tnear: f32,
        dir: [f32; 3],
        time: f32,
        tfar: f32,
        mask: c_uint,
        id: c_uint,
        flags: c_uint,
    }

    #[repr(C, align(64))]
    struct Ray16 {
        org_x: [f32; 16],
        org_y: [f32; 16],
        org_z: [f32; 16],
        tnear: [f32; 16],
        dir_x: [f32; 16],
        dir_y: [f32; 16],
        dir_z: [f32; 16],
        time: [f32; 16],
        tfar: [f32; 16],
        mask: [c_uint; 16],
        id: [c_uint; 16],
        flags: [c_uint; 16],
    }

    #[link(name = "embree3")]
    extern "C" {
        fn rtcNewDevice(config: *const c_char) -> Device;
        fn rtcReleaseDevice(device: Device);
        fn rtcNewScene(device: Device) -> EScene;
        fn rtcReleaseScene(scene: EScene);
        fn rtcSetSceneBuildQuality(scene: EScene, quality: c_int);
        fn rtcNewGeometry(device: Device, kind: c_int) -> Geometry;
        fn rtcSetSharedGeometryBuffer(
            geometry: Geometry,
            kind: c_int,
            slot: c_uint,
            format: c_int,
            ptr: *const c_void,
            byte_offset: usize,
            byte_stride: usize,
            count: usize,
        );
        fn rtcCommitGeometry(geometry: Geometry);
        fn rtcAttachGeometry(scene: EScene, geometry: Geometry) -> c_uint;
        fn rtcReleaseGeometry(geometry: Geometry);
        fn rtcCommitScene(scene: EScene);
        fn rtcOccluded1(scene: EScene, context: *mut IntersectContext, ray: *mut Ray);
        fn rtcOccluded16(valid: *const c_int, scene: EScene, context: *mut IntersectContext, ray: *mut Ray16);
    }

    const GEOMETRY_TYPE_TRIANGLE: c_int = 0;
    const BUFFER_TYPE_INDEX: c_int = 0;
    const BUFFER_TYPE_VERTEX: c_int = 1;
    const FORMAT_UINT3: c_int = 0x5003;
    const FORMAT_FLOAT3: c_int = 0x9003;
    const BUILD_QUALITY_HIGH: c_int = 2;
    const INVALID_ID: c_uint = u32::MAX;
    const CONTEXT_FLAG_COHERENT: c_uint = 1;

    /// A one-thread Embree device with the scene's triangles (high-quality build: the best case).
    pub struct Embree {
        device: Device,
        scene: EScene,
        // Shared buffers: Embree reads them for the scene's lifetime (vertex buffer padded by 4 bytes
        // as Embree requires).
        _vertices: Vec<f32>,
        _indices: Vec<u32>,
    }

    impl Embree {
        pub fn new(scene: &Scene) -> Embree {
            let mut vertices = Vec::new();
            let mut indices = Vec::new();
            for (k, tri) in scene.triangles().enumerate() {
                for v in tri {
                    vertices.extend([v.x, v.y, v.z]);
                }
                let k = 3 * k as u32;
                indices.extend([k, k + 1, k + 2]);
            }
            vertices.push(0.0);
            let n = indices.len() / 3;
            // SAFETY: plain calls into the C library with buffers that outlive the scene (owned here,
            // released in Drop after the scene).
            unsafe {
                let device = rtcNewDevice(c"threads=1".as_ptr());
                assert!(!device.is_null(), "rtcNewDevice failed");
                let escene = rtcNewScene(device);
                rtcSetSceneBuildQuality(escene, BUILD_QUALITY_HIGH);
                let geometry = rtcNewGeometry(device, GEOMETRY_TYPE_TRIANGLE);
                rtcSetSharedGeometryBuffer(
                    geometry,
                    BUFFER_TYPE_VERTEX,
                    0,
                    FORMAT_FLOAT3,
                    vertices.as_ptr().cast(),
                    0,
                    12,
                    3 * n,
                );
                rtcSetSharedGeometryBuffer(
                    geometry,
                    BUFFER_TYPE_INDEX,
                    0,
                    FORMAT_UINT3,
                    indices.as_ptr().cast(),
                    0,
                    12,
                    n,
                );
                rtcCommitGeometry(geometry);
                rtcAttachGeometry(escene, geometry);
                rtcReleaseGeometry(geometry);
                let t = std::time::Instant::now();
                rtcCommitScene(escene);
                println!(
                    "embree BVH build (one thread): {:.0} ms",
                    t.elapsed().as_secs_f64() * 1e3
                );
                Embree {
                    device,
                    scene: escene,
                    _vertices: vertices,
                    _indices: indices,
                }
            }
        }

        fn context(coherent: bool) -> IntersectContext {
            IntersectContext {
                flags: if coherent { CONTEXT_FLAG_COHERENT } else { 0 },
                filter: std::ptr::null(),
                inst_id: [INVALID_ID],
            }
        }

        pub fn occluded1(&self, receivers: &[Receiver], answers: &mut Vec<bool>) {
            answers.clear();
            let mut ctx = Self::context(false);
            for r in receivers {
                for &(d, len) in &r.rays {
                    let mut ray = Ray {
                        org: r.origin.to_array(),
                        tnear: 0.0,
                        dir: d.to_array(),
                        time: 0.0,
                        tfar: len,
                        mask: u32::MAX,
                        id: 0,
                        flags: 0,
                    };
                    // SAFETY: a valid scene, context and ray.
                    unsafe { rtcOccluded1(self.scene, &mut ctx, &mut ray) };
                    answers.push(ray.tfar == f32::NEG_INFINITY);
                }
            }
        }

        pub fn occluded16(&self, receivers: &[Receiver], answers: &mut Vec<bool>) {
            answers.clear();
            let mut ctx = Self::context(true);
            let mut packet = Ray16 {
                org_x: [0.0; 16],
                org_y: [0.0; 16],
                org_z: [0.0; 16],
                tnear: [0.0; 16],
                dir_x: [0.0; 16],
                dir_y: [0.0; 16],
                dir_z: [0.0; 16],
                time: [0.0; 16],
                tfar: [0.0; 16],
                mask: [u32::MAX; 16],
                id: [0; 16],
                flags: [0; 16],
            };
            for r in receivers {
                for chunk in r.rays.chunks(16) {
                    let mut valid = [0 as c_int; 16];
                    for (k, &(d, len)) in chunk.iter().enumerate() {
                        valid[k] = -1;
                        packet.org_x[k] = r.origin.x;
                        packet.org_y[k] = r.origin.y;
                        packet.org_z[k] = r.origin.z;
                        packet.tnear[k] = 0.0;
                        packet.dir_x[k] = d.x;
                        packet.dir_y[k] = d.y;
                        packet.dir_z[k] = d.z;
                        packet.tfar[k] = len;
                    }
                    // SAFETY: a valid scene, context and 64-byte aligned packet.
                    unsafe { rtcOccluded16(valid.as_ptr(), self.scene, &mut ctx, &mut packet) };
                    answers.extend(packet.tfar[..chunk.len()].iter().map(|&t| t == f32::NEG_INFINITY));
                }
            }
        }
    }

    impl Drop for Embree {
        fn drop(&mut self) {
            // SAFETY: releasing what `new` made, scene before device.
            unsafe {
                rtcReleaseScene(self.scene);
                rtcReleaseDevice(self.device);
            }
        }
    }
}
