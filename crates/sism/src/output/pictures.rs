//! PNG pictures for people: visibility in grey, a shaded view, and error heat maps. The shaded view
//! ([`shade`]) is also what `shaded.exr` holds and what ꟻLIP compares.
//!
//! Colours that carry meaning: misses (no surface) are a dark slate blue, receivers facing away from
//! the light are dark red in `visibility.png` and unlit in `shaded.png`.

use std::path::Path;

use glam::Vec3;

use crate::frame::{Receivers, VisibilityImage, V_FACING_AWAY};
use crate::scene::{Light, Scene};

const MISS_RGB: [u8; 3] = [38, 44, 64];
const FACING_AWAY_RGB: [u8; 3] = [90, 20, 20];

/// Linear [0, 1] to 8-bit sRGB.
fn srgb8(linear: f32) -> u8 {
    let x = linear.clamp(0.0, 1.0);
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

fn save_rgb(path: &Path, width: u32, height: u32, rgb: Vec<u8>) -> crate::Result<()> {
    let image = image::RgbImage::from_raw(width, height, rgb).expect("buffer sized width*height*3");
    crate::output::save_png(path, &image)
}

/// `visibility.png`: `V` as grey (linear in V, so 0.5 reads as mid grey), misses and back-facing
/// receivers in their colours.
pub fn write_visibility_png(path: &Path, image: &VisibilityImage) -> crate::Result<()> {
    let rgb = image
        .values
        .iter()
        .flat_map(|&v| {
            if v.is_nan() {
                MISS_RGB
            } else if v == V_FACING_AWAY {
                FACING_AWAY_RGB
            } else {
                let g = (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
                [g, g, g]
            }
        })
        .collect();
    save_rgb(path, image.width, image.height, rgb)
}

/// One pixel of the shaded view: a miss (no surface, drawn in the miss colour) or a grey level,
/// linear in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shade {
    /// The eye ray hits nothing.
    Miss,
    /// Linear grey level of a receiver, [0, 1].
    Grey(f32),
}

/// The shaded view of `shaded.png`, `shaded.exr` and the ꟻLIP comparisons: albedo × (ambient +
/// Lambert × V × distance falloff), the faint ambient term keeping geometry in umbra readable.
/// Falloff is `(d_ref / |c - p|)^2` (at most 4) with `d_ref` the light's distance to
/// `scene_center`, so the middle of the scene is lit at about full intensity. Receivers facing away
/// (V = -1) get the ambient term only. Row-major, top row first.
pub fn shade(
    receivers: &Receivers,
    visibility: &VisibilityImage,
    light: &Light,
    scene_center: Vec3,
) -> Vec<Shade> {
    const ALBEDO: f32 = 0.8;
    const AMBIENT: f32 = 0.03;
    let c = light.center();
    let d_ref2 = (c - scene_center).length_squared().max(1e-12);
    receivers
        .pixels
        .iter()
        .zip(&visibility.values)
        .map(|(r, &v)| match r {
            None => Shade::Miss,
            Some(r) => {
                let to_light = c - r.position;
                let dist2 = to_light.length_squared().max(1e-12);
                let lambert = r.normal.dot(to_light / dist2.sqrt()).max(0.0);
                // A NaN V on a receiver (not a contract value) shades as unlit, not as NaN.
                let lit = if v >= 0.0 {
                    v * lambert * (d_ref2 / dist2).min(4.0)
                } else {
                    0.0
                };
                Shade::Grey(ALBEDO * (AMBIENT + lit))
            }
        })
        .collect()
}

/// [`shade`] of a scene's frame: the light and bounds' centre taken from `scene`.
pub fn shade_scene(scene: &Scene, receivers: &Receivers, visibility: &VisibilityImage) -> Vec<Shade> {
    let (lo, hi) = scene.bounds();
    shade(receivers, visibility, &scene.light, (lo + hi) * 0.5)
}

/// The shaded view as 8-bit sRGB, the bytes of `shaded.png` (and what ꟻLIP, an LDR metric, compares).
pub fn shaded_srgb8(shades: &[Shade], width: u32, height: u32) -> image::RgbImage {
    let rgb = shades
        .iter()
        .flat_map(|s| match *s {
            Shade::Miss => MISS_RGB,
            Shade::Grey(g) => {
                let g = srgb8(g);
                [g, g, g]
            }
        })
        .collect();
    image::RgbImage::from_raw(width, height, rgb).expect("one shade per pixel")
}

/// The shaded view as linear RGB (`shaded.exr`): receivers' grey levels as they are, misses in the
/// miss colour converted from sRGB.
pub fn shaded_linear(shades: &[Shade]) -> Vec<[f32; 3]> {
    let miss = MISS_RGB.map(srgb8_to_linear);
    shades
        .iter()
        .map(|s| match *s {
            Shade::Miss => miss,
            Shade::Grey(g) => [g; 3],
        })
        .collect()
}

/// 8-bit sRGB to linear [0, 1].
fn srgb8_to_linear(v: u8) -> f32 {
    let s = v as f32 / 255.0;
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// `shaded.png`: the [`shade`]d view in 8-bit sRGB.
pub fn write_shaded_png(path: &Path, shades: &[Shade], width: u32, height: u32) -> crate::Result<()> {
    crate::output::save_png(path, &shaded_srgb8(shades, width, height))
}

/// An error heat map: |error| from 0 (black) through red to yellow at `full_scale` and above; pixels
/// not compared in grey.
pub fn write_error_heatmap(
    path: &Path,
    width: u32,
    height: u32,
    abs_error: &[Option<f32>],
    full_scale: f32,
) -> crate::Result<()> {
    let rgb = abs_error
        .iter()
        .flat_map(|e| match e {
            None => [70, 70, 70],
            Some(e) => {
                let x = (e / full_scale).clamp(0.0, 1.0);
                // black -> red over the first two thirds, red -> yellow over the last third
                let r = (x * 1.5).min(1.0);
                let g = ((x - 2.0 / 3.0) * 3.0).clamp(0.0, 1.0);
                [(r * 255.0) as u8, (g * 255.0) as u8, 0]
            }
        })
        .collect();
    save_rgb(path, width, height, rgb)
}
