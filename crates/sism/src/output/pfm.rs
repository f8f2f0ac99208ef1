//! Portable float map, one channel ("Pf"), little-endian (negative scale), rows bottom to top as the
//! format defines. sism's visibility images are kept top to bottom in memory and flipped here.

use std::path::Path;

use crate::error::InputError;
use crate::frame::VisibilityImage;

/// Writes `image` as a one-channel little-endian PFM (whole or not at all: [`super::write_atomic`]).
pub fn write_pfm(path: &Path, image: &VisibilityImage) -> crate::Result<()> {
    let mut bytes = format!("Pf\n{} {}\n-1.0\n", image.width, image.height).into_bytes();
    bytes.reserve(image.values.len() * 4);
    for row in image.values.chunks_exact(image.width as usize).rev() {
        for v in row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    super::write_atomic(path, &bytes)
}

/// Reads a one-channel PFM of either byte order into a top-to-bottom [`VisibilityImage`].
pub fn read_pfm(path: &Path) -> Result<VisibilityImage, InputError> {
    let bytes = crate::input::read_file(path, "PFM image", crate::input::MAX_IMAGE_BYTES)?;
    decode_pfm(path, &bytes)
}

/// [`read_pfm`] on bytes already read.
pub fn decode_pfm(path: &Path, bytes: &[u8]) -> Result<VisibilityImage, InputError> {
    let bad = |message: String| InputError::Pfm {
        path: path.into(),
        message,
    };
    // The header is three whitespace-separated tokens after the magic, ending in one whitespace byte.
    let mut pos = 0;
    let mut tokens = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            return Err(bad("truncated or malformed header".into()));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1; // the single whitespace byte that ends the header
    match tokens[0].as_str() {
        "Pf" => {}
        "PF" => {
            return Err(bad(
                "is a 3-channel (PF) image; visibility images are 1-channel (Pf)".into(),
            ))
        }
        other => return Err(bad(format!("magic is `{other}`, expected `Pf`"))),
    }
    let parse_dim = |s: &str, what: &str| -> Result<u32, InputError> {
        s.parse::<u32>()
            .ok()
            .filter(|&d| d > 0 && d <= crate::scene::MAX_IMAGE_SIDE)
            .ok_or_else(|| {
                bad(format!(
                    "{what} `{s}` is not in 1..={}",
                    crate::scene::MAX_IMAGE_SIDE
                ))
            })
    };
    let width = parse_dim(&tokens[1], "width")?;
    let height = parse_dim(&tokens[2], "height")?;
    let scale: f32 = tokens[3]
        .parse()
        .ok()
        .filter(|s: &f32| s.is_finite() && *s != 0.0)
        .ok_or_else(|| bad(format!("scale `{}` is not a non-zero number", tokens[3])))?;
    let little = scale < 0.0;
    let count = width as usize * height as usize;
    let data = bytes.get(pos..).unwrap_or(&[]);
    if data.len() != count * 4 {
        return Err(bad(format!(
            "has {} bytes of pixels, {width}x{height} needs {}",
            data.len(),
            count * 4
        )));
    }
    let mut values = vec![0.0f32; count];
    for (row_in_file, chunk) in data.chunks_exact(width as usize * 4).enumerate() {
        let row = height as usize - 1 - row_in_file;
        for (i, b) in chunk.chunks_exact(4).enumerate() {
            let b = [b[0], b[1], b[2], b[3]];
            values[row * width as usize + i] = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Ok(VisibilityImage {
        width,
        height,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_nan_and_orientation() {
        let image = VisibilityImage {
            width: 3,
            height: 2,
            values: vec![0.0, 0.5, f32::NAN, -1.0, 1.0, 0.25],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.pfm");
        write_pfm(&path, &image).unwrap();
        let back = read_pfm(&path).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        for (a, b) in image.values.iter().zip(&back.values) {
            assert!(a.to_bits() == b.to_bits(), "{a} != {b}");
        }
        // First stored row is the bottom one.
        let bytes = std::fs::read(&path).unwrap();
        let header_len = "Pf\n3 2\n-1.0\n".len();
        assert_eq!(
            f32::from_le_bytes(bytes[header_len..header_len + 4].try_into().unwrap()),
            -1.0
        );
    }

    #[test]
    fn truncated_file_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.pfm");
        std::fs::write(&path, b"Pf\n4 4\n-1.0\n\0\0\0\0").unwrap();
        let err = read_pfm(&path).unwrap_err().to_string();
        assert!(err.contains("needs 64"), "{err}");
    }
}
