//! The soft shadow mip-maps' filter sizes (Shen 2016, §§3.1–3.3), in one place.
//!
//! **Units.** Distances (`receiver`, `blocker`) are world units from the light's centre. A *filter
//! size* is a length in the depth map's texture space, as a fraction of the map's side (the map spans
//! `[0, 1]`); it is the radius of the region at the blocker's distance through which the receiver
//! sees the light (the thesis' `r_B` over the map's width there, `r_G`). `tan_half_fov` is the tangent
//! of half the map's field of view: at distance `d` the map spans `2 d tan_half_fov` world units.
//! The light radius is in world units.
//!
//! **Layers.** Layer `i` of the mip chain has texels `2^i` base texels wide (`h_i = 2^i / size`). Its
//! kernel is `n × n` of its texels, the square around the receiver's position that bounds the
//! blocker region's disk: so the layer's filter size (a radius) is `ρ_i = n h_i / 2`. The thesis
//! writes Eq. 3.4 as `r_i = n h_i` with a filter region `2 r_i` wide, which would be `2n × 2n` texels
//! and contradicts its own "n × n texel region" and cost; the radius convention of Eq. 3.3 with the
//! `n × n` region is taken here.
//!
//! **Layer weights** (Eqs. 3.9–3.13). A filter size `r` between two consecutive layers' sizes
//! (`ρ_i ≤ r ≤ ρ_{i+1} = 2 ρ_i`) blends them linearly in `r`: with `x = r / ρ_i`, layer `i` weighs
//! `2 − x` and layer `i + 1` weighs `2 (x / 2) − 1 = x − 1`. So each layer has a hat over
//! `(ρ_i / 2, 2 ρ_i)` peaking at `ρ_i`; below the first layer's size it keeps weight 1 (Eq. 3.12),
//! above the last layer's as well (Eq. 3.13). The hats form a partition of unity over the layers for
//! every `r ≥ 0` (tested).

/// Eq. 3.3: the filter size (fraction of the map's side) of a blocker at distance `blocker` for a
/// receiver at distance `receiver` under a light of radius `light_radius`:
/// `r = r_L (d_R − d_B) / (d_R · 2 d_B tan(fov/2))`. Distances `> 0`; `r ≤ 0` when the blocker is not
/// nearer than the receiver (not a blocker).
pub fn filter_size(light_radius: f64, receiver: f64, blocker: f64, tan_half_fov: f64) -> f64 {
    light_radius * (receiver - blocker) / (receiver * 2.0 * blocker * tan_half_fov)
}

/// Eq. 3.5, the inverse of [`filter_size`]: the blocker distance whose filter size is `r` (a fraction
/// of the map's side, `≥ 0`) for a receiver at distance `receiver`:
/// `d = r_L d_R / (2 d_R r tan(fov/2) + r_L)`. In `(0, receiver]`; `receiver` at `r = 0`.
pub fn blocker_distance(light_radius: f64, receiver: f64, r: f64, tan_half_fov: f64) -> f64 {
    light_radius * receiver / (2.0 * receiver * r * tan_half_fov + light_radius)
}

/// Eq. 3.3 per unit of a layer's filter size, as the kernels evaluate it: `r / ρ = a (1/d_B − 1/d_R)`
/// with `a = r_L / (2 tan(fov/2) ρ)` ([`filter_scale`]), from inverse distances (1/world units).
#[inline]
pub fn filter_ratio(scale: f32, inv_blocker: f32, inv_receiver: f32) -> f32 {
    scale * (inv_blocker - inv_receiver)
}

/// `a = r_L / (2 tan(fov/2) ρ)` of [`filter_ratio`] for a layer of filter size `rho` (fraction of the
/// map's side, `> 0`): world units.
pub fn filter_scale(light_radius: f32, tan_half_fov: f32, rho: f32) -> f32 {
    filter_scale_counted(sism_simd::Portable, light_radius, tan_half_fov, rho)
}

/// [`filter_scale`] counted by `s` (two multiplies and a divide; the same bits).
#[inline(always)]
pub fn filter_scale_counted<S: sism_simd::Simd>(s: S, light_radius: f32, tan_half_fov: f32, rho: f32) -> f32 {
    s.s_div(light_radius, s.s_mul(s.s_mul(2.0, tan_half_fov), rho))
}

/// Layer `level`'s filter size `ρ_i = n 2^i / (2 size)` (fraction of the map's side) for a kernel of
/// `n × n` texels on a base map of `size` texels a side.
pub fn layer_filter_size(n: u32, level: usize, size: u32) -> f32 {
    layer_filter_size_counted(sism_simd::Portable, n, level, size)
}

/// [`layer_filter_size`] counted by `s` (three conversions, a shift, two multiplies and a divide;
/// the same bits).
#[inline(always)]
pub fn layer_filter_size_counted<S: sism_simd::Simd>(s: S, n: u32, level: usize, size: u32) -> f32 {
    use sism_simd::ScalarClass::Alu;
    let nf = s.s_fn(Alu, n, |n: u32| n as f32);
    let pow = s.s_fn(Alu, s.s_fn(Alu, level, |l: usize| 1u64 << l), |p: u64| p as f32);
    let sf = s.s_fn(Alu, size, |z: u32| z as f32);
    s.s_div(s.s_mul(nf, pow), s.s_mul(2.0, sf))
}

/// Layers of the chain: levels `0, 1, …` while a level still has at least `n` texels a side
/// (level `i` has `⌈size / 2^i⌉`); at least 1.
pub fn layer_count(size: u32, n: u32) -> usize {
    let mut layers = 1;
    while (size as u64).div_ceil(1u64 << layers) >= n as u64 {
        layers += 1;
    }
    layers
}

/// The weight of layer `level` (of `layers`) for a filter size `x` times the layer's own
/// (`x = r / ρ_level ≥ 0`): the hat `clamp(min(2x − 1, 2 − x), 0, 1)`, without its rising side on the
/// first layer (Eq. 3.12) and its falling side on the last (Eq. 3.13). The vector form is
/// [`layer_weight_simd`].
pub fn layer_weight(x: f32, level: usize, layers: usize) -> f32 {
    let rise = if level == 0 { f32::INFINITY } else { 2.0 * x - 1.0 };
    let fall = if level + 1 == layers {
        f32::INFINITY
    } else {
        2.0 - x
    };
    rise.min(fall).clamp(0.0, 1.0)
}

/// [`layer_weight`] for 16 lanes.
#[inline(always)]
pub fn layer_weight_simd<S: sism_simd::Simd>(s: S, x: S::F32, level: usize, layers: usize) -> S::F32 {
    let one = s.splat_f(1.0);
    let w = match (level == 0, level + 1 == layers) {
        (true, true) => one,
        (true, false) => s.min_f(s.sub_f(s.splat_f(2.0), x), one),
        (false, true) => s.min_f(s.fmsub(s.splat_f(2.0), x, one), one),
        (false, false) => s.min_f(s.fmsub(s.splat_f(2.0), x, one), s.sub_f(s.splat_f(2.0), x)),
    };
    s.max_f(w, s.splat_f(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Eq. 3.5 inverts Eq. 3.3 over its domain (a blocker between light and receiver), and
        /// Eq. 3.3 inverts Eq. 3.5 for every filter size.
        #[test]
        fn eq_3_3_and_3_5_invert_each_other(
            light in 1e-3f64..1e3,
            receiver in 1e-2f64..1e5,
            share in 1e-4f64..1.0,
            tan in 1e-2f64..1e2,
            r in 0.0f64..1e3,
        ) {
            let blocker = receiver * share;
            let size = filter_size(light, receiver, blocker, tan);
            prop_assert!(size >= 0.0);
            let back = blocker_distance(light, receiver, size, tan);
            prop_assert!((back - blocker).abs() <= 1e-9 * receiver, "{back} vs {blocker}");
            let d = blocker_distance(light, receiver, r, tan);
            prop_assert!(d > 0.0 && d <= receiver);
            let again = filter_size(light, receiver, d, tan);
            prop_assert!((again - r).abs() <= 1e-9 * (1.0 + r), "{again} vs {r}");
        }

        /// The kernels' ratio form is Eq. 3.3 over the layer's size.
        #[test]
        fn ratio_form_is_eq_3_3(
            light in 1e-2f32..10.0,
            receiver in 1.0f32..100.0,
            share in 0.01f32..0.99,
            tan in 0.1f32..4.0,
            level in 0usize..10,
        ) {
            let blocker = receiver * share;
            let rho = layer_filter_size(4, level, 1024);
            let x = filter_ratio(filter_scale(light, tan, rho), 1.0 / blocker, 1.0 / receiver);
            let r = filter_size(light as f64, receiver as f64, blocker as f64, tan as f64) / rho as f64;
            prop_assert!((x as f64 - r).abs() <= 1e-4 * (1.0 + r), "{x} vs {r}");
        }

        /// The layers' weights sum to 1 for every filter size, with every layer count, and each
        /// is in [0, 1]; at most two layers carry weight.
        #[test]
        fn layer_weights_are_a_partition_of_unity(r in 0.0f32..4096.0, layers in 1usize..14) {
            let weights: Vec<f32> =
                (0..layers).map(|i| layer_weight(r / (1u64 << i) as f32, i, layers)).collect();
            let sum: f32 = weights.iter().sum();
            prop_assert!((sum - 1.0).abs() <= 1e-5, "{weights:?}");
            prop_assert!(weights.iter().all(|w| (0.0..=1.0).contains(w)));
            prop_assert!(weights.iter().filter(|&&w| w > 0.0).count() <= 2);
        }
    }

    #[test]
    fn vector_weights_are_the_scalar_ones() {
        use sism_simd::{Portable, Simd};
        let s = Portable;
        let xs: [f32; 16] = std::array::from_fn(|k| k as f32 * 0.23);
        for layers in 1..5 {
            for level in 0..layers {
                let w = s.to_array_f(layer_weight_simd(s, s.from_array_f(xs), level, layers));
                for k in 0..16 {
                    assert_eq!(
                        w[k],
                        layer_weight(xs[k], level, layers),
                        "x {} level {level}/{layers}",
                        xs[k]
                    );
                }
            }
        }
    }

    #[test]
    fn layer_counts_and_sizes() {
        assert_eq!(layer_count(1024, 4), 9); // 1024 .. 4 texels a side
        assert_eq!(layer_count(1024, 9), 7); // 1024 .. 16
        assert_eq!(layer_count(1000, 2), 10); // 1000, 500, …, 4, 2
        assert_eq!(layer_count(4, 9), 1);
        assert_eq!(layer_filter_size(4, 0, 1024), 4.0 / 2048.0);
        assert_eq!(layer_filter_size(4, 3, 1024), 32.0 / 2048.0);
    }
}
