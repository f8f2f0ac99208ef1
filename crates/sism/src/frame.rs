//! What one view of a scene produces, whatever the algorithm: receivers (the surface point behind every
//! pixel) and visibility per pixel, with the CONTRACTS.md conventions for misses and back-facing points.

use glam::Vec3;

/// `V` of a pixel whose eye ray hits nothing.
pub const V_MISS: f32 = f32::NAN;
/// `V` of a receiver whose visible side faces away from the light centre.
pub const V_FACING_AWAY: f32 = -1.0;

/// A receiver point: the first surface seen through a pixel centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Receiver {
    /// World position, world units.
    pub position: Vec3,
    /// Unit geometric normal, flipped to face the camera.
    pub normal: Vec3,
}

/// Receivers of a whole image, row-major from the top-left pixel; `None` where the eye ray misses.
#[derive(Clone, Debug)]
pub struct Receivers {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// One receiver per pixel, row-major; `None` where the eye ray misses.
    pub pixels: Vec<Option<Receiver>>,
}

/// Visibility per pixel, row-major from the top-left pixel: `V` in [0, 1], [`V_MISS`] or
/// [`V_FACING_AWAY`].
#[derive(Clone, Debug, PartialEq)]
pub struct VisibilityImage {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// `V` per pixel, row-major.
    pub values: Vec<f32>,
}

impl VisibilityImage {
    /// An image of `width * height` pixels all holding `fill`.
    pub fn filled(width: u32, height: u32, fill: f32) -> Self {
        Self {
            width,
            height,
            values: vec![fill; width as usize * height as usize],
        }
    }

    /// True for a pixel that holds a real visibility (neither a miss nor facing away).
    #[inline]
    pub fn is_receiver_value(v: f32) -> bool {
        v >= 0.0
    }
}
