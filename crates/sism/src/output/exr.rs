//! OpenEXR images beside the PFM: `visibility.exr` (one 32-bit float channel `V`, top row first,
//! the contract's NaN at a miss and -1 facing away kept bit for bit) and `shaded.exr` (linear RGB,
//! half floats). Written with ZIP compression in scan lines, lossless, in the order tev, OpenImageIO
//! and the OpenEXR library read; one thread, so the bytes do not depend on the host.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::*;

use crate::error::InputError;
use crate::frame::VisibilityImage;
use crate::scene::MAX_PIXELS;

/// The magic number every OpenEXR file starts with.
pub const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Most channels in a file read.
pub const MAX_CHANNELS: usize = 16;

fn encode(
    path: &Path,
    width: u32,
    height: u32,
    channels: AnyChannels<FlatSamples>,
) -> crate::Result<Vec<u8>> {
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let mut bytes = Vec::new();
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(Cursor::new(&mut bytes))
        .map_err(|e| crate::Error::write(path, std::io::Error::other(e.to_string())))?;
    Ok(bytes)
}

/// Writes `image` as `path` (whole or not at all: [`super::write_atomic`]): one `FLOAT` channel `V`.
pub fn write_visibility_exr(path: &Path, image: &VisibilityImage) -> crate::Result<()> {
    let v = AnyChannel::new("V", FlatSamples::F32(image.values.clone()));
    let bytes = encode(
        path,
        image.width,
        image.height,
        AnyChannels::sort(SmallVec::from_vec(vec![v])),
    )?;
    super::write_atomic(path, &bytes)
}

/// Writes linear RGB pixels (row-major, top row first) as `HALF` channels `R`, `G`, `B`.
pub fn write_rgb_half_exr(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> crate::Result<()> {
    let channel = |name: &str, k: usize| {
        AnyChannel::new(
            name,
            FlatSamples::F16(rgb.iter().map(|p| f16::from_f32(p[k])).collect()),
        )
    };
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        channel("R", 0),
        channel("G", 1),
        channel("B", 2),
    ]));
    let bytes = encode(path, width, height, channels)?;
    super::write_atomic(path, &bytes)
}

/// Reads a visibility image from an OpenEXR file: its first layer's channel `V`, or its only
/// channel when it has one (any sample type, converted to 32-bit float). Sizes are checked against
/// [`crate::scene::MAX_IMAGE_SIDE`] from the header, before any pixel is decoded.
pub fn read_visibility_exr(path: &Path) -> std::result::Result<VisibilityImage, InputError> {
    let bytes = crate::input::read_file(path, "OpenEXR image", crate::input::MAX_IMAGE_BYTES)?;
    decode_visibility(path, &bytes)
}

/// [`read_visibility_exr`] on bytes already read.
pub fn decode_visibility(path: &Path, bytes: &[u8]) -> std::result::Result<VisibilityImage, InputError> {
    let bad = |message: String| InputError::Image {
        path: path.into(),
        format: "OpenEXR",
        message,
    };
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| bad(format!("unreadable header: {e}")))?;
    let header = meta.headers.first().ok_or_else(|| bad("has no layer".into()))?;
    if meta.headers.len() > 1 {
        return Err(bad(format!(
            "has {} layers; a visibility image has one",
            meta.headers.len()
        )));
    }
    if header.deep {
        return Err(bad("holds deep data; a visibility image is flat".into()));
    }
    let size = header.layer_size;
    let max = crate::scene::MAX_IMAGE_SIDE as usize;
    if size.0 == 0 || size.1 == 0 || size.0 > max || size.1 > max {
        return Err(bad(format!(
            "is {}x{} pixels; each side must be in 1..={max}",
            size.0, size.1
        )));
    }
    // Decoding expands every channel of the layer: bound what a small compressed file can ask for.
    let pixels = size.0 as u64 * size.1 as u64;
    if pixels > MAX_PIXELS {
        return Err(bad(format!("has {pixels} pixels; at most {MAX_PIXELS} are read")));
    }
    if header.channels.list.len() > MAX_CHANNELS {
        return Err(bad(format!(
            "has {} channels; at most {MAX_CHANNELS} are read",
            header.channels.list.len()
        )));
    }
    let names: Vec<String> = header.channels.list.iter().map(|c| c.name.to_string()).collect();
    let wanted = if names.iter().any(|n| n == "V") {
        "V".to_string()
    } else if names.len() == 1 {
        names[0].clone()
    } else {
        return Err(bad(format!(
            "has channels {} and none named `V`; a visibility image has a channel `V` (or one channel only)",
            names.join(", ")
        )));
    };
    // The decoder: any panic inside it on a corrupt file is turned into this file's error.
    let decoded = std::panic::catch_unwind(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(Cursor::new(bytes))
    })
    .map_err(|_| bad("corrupt pixel data (the decoder gave up)".into()))?
    .map_err(|e| bad(format!("unreadable pixels: {e}")))?;
    let layer = &decoded.layer_data;
    let channel = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == wanted)
        .ok_or_else(|| bad(format!("channel `{wanted}` vanished while decoding")))?;
    let (w, h) = (layer.size.0, layer.size.1);
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    if values.len() != w * h {
        return Err(bad(format!(
            "channel `{wanted}` has {} samples, {w}x{h} needs {} (subsampled channels are not visibility images)",
            values.len(),
            w * h
        )));
    }
    Ok(VisibilityImage {
        width: w as u32,
        height: h as u32,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visibility_round_trip_keeps_every_bit() {
        let image = VisibilityImage {
            width: 3,
            height: 2,
            values: vec![0.0, 0.5, f32::NAN, -1.0, 1.0, 0.123_456_79],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.exr");
        write_visibility_exr(&path, &image).unwrap();
        assert_eq!(std::fs::read(&path).unwrap()[..4], MAGIC);
        let back = read_visibility_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        for (a, b) in image.values.iter().zip(&back.values) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a} != {b}");
        }
    }

    #[test]
    fn rgb_is_not_a_visibility_image_and_garbage_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let rgb = dir.path().join("s.exr");
        write_rgb_half_exr(&rgb, 2, 1, &[[0.25, 0.5, 1.0], [0.0, 0.0, 0.0]]).unwrap();
        let e = read_visibility_exr(&rgb).unwrap_err().to_string();
        assert!(e.contains("none named `V`") && e.contains("s.exr"), "{e}");
        let junk = dir.path().join("j.exr");
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&[2, 0, 0, 0, 0xff, 0xff, 0xff]);
        std::fs::write(&junk, &bytes).unwrap();
        let e = read_visibility_exr(&junk).unwrap_err().to_string();
        assert!(e.contains("j.exr") && e.contains("OpenEXR"), "{e}");
    }

    #[test]
    fn truncated_pixels_are_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.exr");
        let image = VisibilityImage {
            width: 64,
            height: 64,
            values: (0..64 * 64).map(|i| (i % 97) as f32 / 97.0).collect(),
        };
        write_visibility_exr(&path, &image).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let e = read_visibility_exr(&path).unwrap_err().to_string();
        assert!(e.contains("v.exr"), "{e}");
    }
}
