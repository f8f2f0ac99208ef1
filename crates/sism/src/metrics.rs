//! Error of a visibility image against a reference.
//!
//! Pixels count only where both images hold a receiver value (`V >= 0`): misses (NaN) and receivers
//! facing away from the light (-1) are left out, as CONTRACTS.md says.

use serde::Serialize;

use crate::frame::VisibilityImage;

/// `V_ref` range that makes a pixel a penumbra pixel for [`ErrorReport::penumbra_mae`].
pub const PENUMBRA_RANGE: (f32, f32) = (0.02, 0.98);
/// |error| above which a pixel counts as bad for [`ErrorReport::share_over_0_1`].
pub const BAD_PIXEL_THRESHOLD: f32 = 0.1;

/// Error statistics of a test image against a reference, over pixels valid in both.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct ErrorReport {
    /// Pixels compared (receivers in both images).
    pub compared: u64,
    /// Mean absolute error.
    pub mae: f64,
    /// Root mean square error.
    pub rmse: f64,
    /// 99th percentile of |error| (nearest rank).
    pub p99: f64,
    /// Largest |error|.
    pub max: f64,
    /// Share of compared pixels with |error| > 0.1, in [0, 1].
    pub share_over_0_1: f64,
    /// Pixels whose reference value is in the penumbra range (0.02, 0.98).
    pub penumbra_pixels: u64,
    /// Mean absolute error over penumbra pixels (0 when there are none).
    pub penumbra_mae: f64,
    /// Mean ꟻLIP between the two frames' shaded views ([`crate::perceptual`]), [0, 1]; `None` where
    /// the comparison had no shading (two bare visibility files).
    pub flip: Option<f64>,
}

/// Why two images cannot be compared.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CompareError {
    /// The images differ in size: the reference's width and height, then the test's, pixels.
    #[error("images differ in size: reference {0}x{1}, test {2}x{3}")]
    SizeMismatch(u32, u32, u32, u32),
    /// A value outside the contract: `V` in [0, 1], NaN at a miss, -1 facing away.
    #[error(
        "{image} image, pixel ({x}, {y}) holds {value}: visibility values are in [0, 1], NaN (a miss) or -1 (facing away)"
    )]
    OutOfRange {
        /// Which image, e.g. "reference" or "test".
        image: &'static str,
        /// Pixel column, from the left.
        x: u32,
        /// Pixel row, from the top.
        y: u32,
        /// The value the pixel holds.
        value: f32,
    },
    /// No pixel holds a visibility in both images.
    #[error("no pixel holds a visibility in both images (reference: {reference} receivers, test: {test}): nothing to compare")]
    NothingToCompare {
        /// Pixels of the reference holding a visibility (`V >= 0`).
        reference: u64,
        /// Pixels of the test image holding a visibility (`V >= 0`).
        test: u64,
    },
}

/// Checks that every value of `image` is a visibility, a miss (NaN) or facing away (-1).
pub fn check_values(image: &VisibilityImage, which: &'static str) -> Result<(), CompareError> {
    let w = image.width.max(1);
    match image
        .values
        .iter()
        .position(|&v| !(v.is_nan() || v == crate::frame::V_FACING_AWAY || (0.0..=1.0).contains(&v)))
    {
        None => Ok(()),
        Some(k) => Err(CompareError::OutOfRange {
            image: which,
            x: k as u32 % w,
            y: k as u32 / w,
            value: image.values[k],
        }),
    }
}

/// Per-pixel |error| where both images hold receiver values, `None` elsewhere (for heat maps).
pub fn abs_error_map(
    reference: &VisibilityImage,
    test: &VisibilityImage,
) -> Result<Vec<Option<f32>>, CompareError> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(CompareError::SizeMismatch(
            reference.width,
            reference.height,
            test.width,
            test.height,
        ));
    }
    Ok(reference
        .values
        .iter()
        .zip(&test.values)
        .map(|(&r, &t)| {
            (VisibilityImage::is_receiver_value(r) && VisibilityImage::is_receiver_value(t))
                .then(|| (t - r).abs())
        })
        .collect())
}

/// [`compare`], plus the mean ꟻLIP of the two frames' shaded views: both images are visibility of
/// the frame whose receivers are `receivers` in `scene`.
pub fn compare_frame(
    scene: &crate::Scene,
    receivers: &crate::frame::Receivers,
    reference: &VisibilityImage,
    test: &VisibilityImage,
) -> Result<ErrorReport, CompareError> {
    let mut report = compare(reference, test)?;
    report.flip = Some(crate::perceptual::flip_of_frame(scene, receivers, reference, test)?.mean());
    Ok(report)
}

/// Compares `test` against `reference`: both must hold only contract values ([`check_values`]) and
/// share at least one receiver.
pub fn compare(reference: &VisibilityImage, test: &VisibilityImage) -> Result<ErrorReport, CompareError> {
    check_values(reference, "reference")?;
    check_values(test, "test")?;
    let errors = abs_error_map(reference, test)?;
    let mut abs: Vec<f32> = Vec::with_capacity(errors.len());
    let (mut sum, mut sum2, mut bad, mut pen_n, mut pen_sum) = (0.0f64, 0.0f64, 0u64, 0u64, 0.0f64);
    for (e, &r) in errors.iter().zip(&reference.values) {
        let Some(e) = *e else { continue };
        let e64 = e as f64;
        abs.push(e);
        sum += e64;
        sum2 += e64 * e64;
        bad += (e > BAD_PIXEL_THRESHOLD) as u64;
        if r > PENUMBRA_RANGE.0 && r < PENUMBRA_RANGE.1 {
            pen_n += 1;
            pen_sum += e64;
        }
    }
    let n = abs.len();
    if n == 0 {
        let receivers = |i: &VisibilityImage| i.values.iter().filter(|&&v| v >= 0.0).count() as u64;
        return Err(CompareError::NothingToCompare {
            reference: receivers(reference),
            test: receivers(test),
        });
    }
    let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1;
    let p99 = *abs.select_nth_unstable_by(rank, |a, b| a.total_cmp(b)).1 as f64;
    let max = abs.iter().copied().fold(0.0f32, f32::max) as f64;
    Ok(ErrorReport {
        compared: n as u64,
        mae: sum / n as f64,
        rmse: (sum2 / n as f64).sqrt(),
        p99,
        max,
        share_over_0_1: bad as f64 / n as f64,
        penumbra_pixels: pen_n,
        penumbra_mae: if pen_n > 0 { pen_sum / pen_n as f64 } else { 0.0 },
        flip: None,
    })
}

impl std::fmt::Display for ErrorReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "pixels compared      {}", self.compared)?;
        writeln!(f, "MAE                  {:.6}", self.mae)?;
        writeln!(f, "RMSE                 {:.6}", self.rmse)?;
        writeln!(f, "p99 |error|          {:.6}", self.p99)?;
        writeln!(f, "max |error|          {:.6}", self.max)?;
        writeln!(f, "share |error| > 0.1  {:.6}", self.share_over_0_1)?;
        writeln!(f, "penumbra pixels      {}", self.penumbra_pixels)?;
        write!(f, "penumbra MAE         {:.6}", self.penumbra_mae)?;
        if let Some(flip) = self.flip {
            write!(f, "\nꟻLIP (mean, LDR)    {flip:.6}")?;
        }
        Ok(())
    }
}

/// The median of `values`: the mean of the middle two for an even count (so two frames' median is
/// their mean, not the slower one), NaN for none. The one median of every timing sism reports.
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(values: Vec<f32>) -> VisibilityImage {
        VisibilityImage {
            width: values.len() as u32,
            height: 1,
            values,
        }
    }

    #[test]
    fn hand_computed_example() {
        let reference = img(vec![0.0, 0.5, 1.0, f32::NAN, -1.0, 0.5]);
        let test = img(vec![0.2, 0.5, 0.95, 0.3, 0.3, f32::NAN]);
        let r = compare(&reference, &test).unwrap();
        assert_eq!(r.compared, 3); // pixels 0, 1, 2
        assert!((r.mae - 0.25 / 3.0).abs() < 1e-6, "{r:?}");
        assert!((r.rmse - ((0.04 + 0.0025) / 3.0f64).sqrt()).abs() < 1e-6);
        assert!((r.p99 - 0.2).abs() < 1e-6);
        assert!((r.share_over_0_1 - 1.0 / 3.0).abs() < 1e-6);
        assert_eq!(r.penumbra_pixels, 1);
        assert!(r.penumbra_mae.abs() < 1e-9);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(compare(&img(vec![0.0; 2]), &img(vec![0.0; 3])).is_err());
    }

    #[test]
    fn out_of_range_values_and_nothing_to_compare_are_errors() {
        for bad in [f32::INFINITY, 7.0, 1e30, -0.5, 1.0001] {
            let e = compare(&img(vec![0.5, 0.5]), &img(vec![0.5, bad])).unwrap_err();
            assert!(
                matches!(
                    e,
                    CompareError::OutOfRange {
                        image: "test",
                        x: 1,
                        ..
                    }
                ),
                "{bad}: {e}"
            );
        }
        let e = compare(&img(vec![f32::NAN; 3]), &img(vec![0.5; 3])).unwrap_err();
        assert_eq!(
            e,
            CompareError::NothingToCompare {
                reference: 0,
                test: 3
            }
        );
        assert!(e.to_string().contains("nothing to compare"));
    }
}
