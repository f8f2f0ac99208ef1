//! PNG pictures for people: visibility in grey, a shaded view, and error heat maps.
//!
//! Colours that carry meaning: misses (no surface) are a dark slate blue, receivers facing away from
//! the light are dark red in `visibility.png` and unlit in `shaded.png`.

use std::path::Path;

use glam::Vec3;

use crate::frame::{Receivers, VisibilityImage, V_FACING_AWAY};
use crate::scene::Light;

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

/// `shaded.png`: Lambert × V × distance falloff, plus a faint ambient term so geometry in umbra stays
/// readable. Falloff is `(d_ref / |c - p|)^2` with `d_ref` the light's distance to the scene's
/// bounding-box centre, so the middle of the scene is lit at about full intensity.
pub fn write_shaded_png(
    path: &Path,
    receivers: &Receivers,
    visibility: &VisibilityImage,
    light: &Light,
    scene_center: Vec3,
) -> crate::Result<()> {
    const ALBEDO: f32 = 0.8;
    const AMBIENT: f32 = 0.03;
    let c = light.center();
    let d_ref2 = (c - scene_center).length_squared().max(1e-12);
    let rgb = receivers
        .pixels
        .iter()
        .zip(&visibility.values)
        .flat_map(|(r, &v)| match r {
            None => MISS_RGB,
            Some(r) => {
                let to_light = c - r.position;
                let dist2 = to_light.length_squared().max(1e-12);
                let lambert = r.normal.dot(to_light / dist2.sqrt()).max(0.0);
                let lit = if v >= 0.0 {
                    v * lambert * (d_ref2 / dist2).min(4.0)
                } else {
                    0.0
                };
                let g = srgb8(ALBEDO * (AMBIENT + lit));
                [g, g, g]
            }
        })
        .collect();
    save_rgb(path, receivers.width, receivers.height, rgb)
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
