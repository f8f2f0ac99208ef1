//! Beams of shadow rays (`bvh::beam`) give exactly the one-ray-at-a-time tracer's answers: per ray on
//! random rays of every width of cone and on every backend, and per pixel of the reference on real
//! scenes (soft, hard and a large near light).

use std::path::Path;

use glam::Vec3;
use sism::algorithms::reference::{
    cast_primary_rays, receiver_visibility_rays, render_visibility, ReferenceOptions,
};
use sism::bvh::beam::{Beam, BEAM_RAYS};
use sism::bvh::SceneBvh;
use sism::sampling::{Rng, Strata};
use sism::scene::Scene;
use sism_simd::{BackendKind, Kernel, Mask16, Simd};

/// One beam's occlusion on a chosen backend.
struct Trace<'a> {
    bvh: &'a SceneBvh,
    beam: &'a Beam,
}

impl Kernel for Trace<'_> {
    type Output = [Mask16; BEAM_RAYS / 16];
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> Self::Output {
        let mut out = [Mask16::NONE; BEAM_RAYS / 16];
        self.bvh.beams().occluded(s, self.beam, &mut Vec::new(), &mut out);
        out
    }
}

fn load(name: &str, width: u32, height: u32) -> Option<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    if name.contains("bunny") || name.contains("palm") {
        crate::util::shared_scenes()?;
    }
    let mut scene = Scene::load(&path).expect("scene loads");
    scene.camera.width = width;
    scene.camera.height = height;
    Some(scene)
}

#[test]
fn beams_agree_with_single_rays_on_random_rays_on_every_backend() {
    for name in ["sphere.toml", "room.toml", "stanford-bunny.toml"] {
        let Some(scene) = load(name, 8, 8) else { continue };
        let bvh = SceneBvh::build(&scene);
        let (lo, hi) = scene.bounds();
        let size = hi - lo;
        let mut rng = Rng::new(7, name.len() as u64);
        let point = |rng: &mut Rng| {
            lo + size * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - size * 0.1
        };
        let (mut rays, mut hits) = (0u32, 0u32);
        for round in 0..120 {
            let origin = point(&mut rng);
            // Cones from a hair's width to every direction: targets around a point, spread by `spread`.
            let spread = [0.001f32, 0.02, 0.2, 1.0, 4.0][round % 5];
            let aim = point(&mut rng);
            let n = [1usize, 16, 77, BEAM_RAYS][round % 4];
            let mut beam = Beam::new(origin);
            let mut expected = Vec::new();
            for _ in 0..n {
                let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
                let target = aim + jitter * size.length() * spread;
                let d = target - origin;
                let len = d.length();
                if len <= 0.0 {
                    continue;
                }
                beam.push(d / len, len);
                expected.push(bvh.occluded(origin, d / len, len));
            }
            for kind in sism_simd::available_backends() {
                let got = sism_simd::run_with(
                    kind,
                    Trace {
                        bvh: &bvh,
                        beam: &beam,
                    },
                );
                for (k, &e) in expected.iter().enumerate() {
                    assert_eq!(
                        got[k / 16].test(k % 16),
                        e,
                        "{name} round {round} ray {k} on {kind:?}"
                    );
                }
            }
            rays += expected.len() as u32;
            hits += expected.iter().filter(|&&h| h).count() as u32;
        }
        eprintln!("{name}: {rays} rays, {hits} occluded");
        assert!(
            hits > rays / 20 && hits < rays - rays / 20,
            "{name}: a mix of hits and misses: {hits} of {rays}"
        );
    }
    assert!(sism_simd::available_backends().contains(&BackendKind::Portable));
}

#[test]
fn the_reference_with_beams_is_the_reference_with_single_rays() {
    for (name, radius_scale, spp) in [
        ("plate.toml", 1.0, 300u32),
        ("sphere.toml", 1.0, 64),
        ("room.toml", 1.0, 64),
        ("sphere.toml", 0.0, 1),
        // A large light near the occluders: wide cones.
        ("sphere.toml", 25.0, 100),
        ("stanford-bunny.toml", 1.0, 260),
        ("palm.toml", 1.0, 64),
        ("palm.toml", 30.0, 64),
    ] {
        let Some(mut scene) = load(name, 48, 36) else {
            continue;
        };
        scene.light.radius *= radius_scale;
        let bvh = SceneBvh::build(&scene);
        let receivers = cast_primary_rays(&scene, &bvh);
        let options = ReferenceOptions {
            spp,
            seed: 3,
            ..Default::default()
        };
        let (image, counts) = render_visibility(&scene, &bvh, None, &receivers, &options);
        let strata = Strata::new(spp);
        let mut partial = 0;
        for (i, (v, r)) in image.values.iter().zip(&receivers.pixels).enumerate() {
            let Some(r) = r else { continue };
            let mut rng = Rng::new(3, i as u64);
            let (one_by_one, _) = receiver_visibility_rays(&bvh, &scene.light, r, &strata, &mut rng);
            assert_eq!(
                v.to_bits(),
                one_by_one.to_bits(),
                "{name} ×{radius_scale} pixel {i}"
            );
            partial += (*v > 0.0 && *v < 1.0) as u32;
        }
        eprintln!("{name} ×{radius_scale}: {counts:?}, {partial} penumbra pixels");
        assert!(counts.rays > 0 && counts.beams > 0);
        if radius_scale > 0.0 {
            assert!(partial > 0, "{name}: the comparison must cover penumbrae");
        }
    }
}
