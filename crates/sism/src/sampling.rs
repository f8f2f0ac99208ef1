//! Deterministic random numbers and stratified light-disk samples.
//!
//! Randomness is a pure function of (seed, pixel, sample): results never depend on which host thread
//! ran which pixel, so renders are identical whatever the thread count.

use glam::Vec2;

/// SplitMix64's finaliser: a bijective 64-bit mix with good avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A tiny counter-based generator: the `n`th number of stream `key` is `mix64(key + n * golden)`.
#[derive(Clone, Copy, Debug)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A stream for `(seed, stream)`, e.g. `(render seed, pixel index)`.
    pub fn new(seed: u64, stream: u64) -> Rng {
        Rng {
            state: mix64(seed ^ mix64(stream.wrapping_add(0x9e37_79b9_7f4a_7c15))),
        }
    }

    /// Uniform in [0, 1), 24 random bits.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(self.state) >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// Shirley–Chiu concentric map from the unit square to the unit disk. Area-preserving, so strata of
/// equal area in the square stay equal-area on the disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Layout of `count` stratified samples over the unit square: `rows = floor(sqrt(count))` rows of equal
/// height, the samples spread over the rows as evenly as possible, each row cut into equal cells. Each
/// sample is uniform in its own cell and weighted by the cell's area, so the estimate is unbiased for
/// any count (not only perfect squares).
#[derive(Clone, Copy, Debug)]
pub struct Strata {
    count: u32,
    rows: u32,
}

impl Strata {
    /// `count` >= 1 samples.
    pub fn new(count: u32) -> Strata {
        let count = count.max(1);
        Strata {
            count,
            rows: (count as f64).sqrt().floor() as u32,
        }
    }

    /// Number of samples.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Sample `k` (< count): its point in the unit square, jittered by `rng`, and its weight (the cell's
    /// area; the weights sum to 1).
    #[inline]
    pub fn sample(&self, k: u32, rng: &mut Rng) -> (Vec2, f32) {
        let base = self.count / self.rows;
        let extra = self.count % self.rows; // the first `extra` rows get one more cell
        let (row, col, cols) = if k < extra * (base + 1) {
            (k / (base + 1), k % (base + 1), base + 1)
        } else {
            let k2 = k - extra * (base + 1);
            (extra + k2 / base, k2 % base, base)
        };
        let u = (col as f32 + rng.next_f32()) / cols as f32;
        let v = (row as f32 + rng.next_f32()) / self.rows as f32;
        (
            Vec2::new(u.min(1.0 - f32::EPSILON), v),
            1.0 / (cols as f32 * self.rows as f32),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_weights_sum_to_one_and_points_stay_in_cells() {
        for count in [1, 2, 3, 7, 16, 17, 64, 100, 255, 256] {
            let strata = Strata::new(count);
            let mut rng = Rng::new(1, 2);
            let total: f64 = (0..count)
                .map(|k| {
                    let (p, w) = strata.sample(k, &mut rng);
                    assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                    w as f64
                })
                .sum();
            assert!((total - 1.0).abs() < 1e-5, "count {count}: weights sum {total}");
        }
    }

    #[test]
    fn concentric_map_stays_in_disk_and_preserves_area() {
        // A fine grid of the square maps to points whose radii are distributed as sqrt(uniform):
        // the mean of r^2 over the disk is 1/2.
        let n = 200;
        let mut mean_r2 = 0.0;
        for i in 0..n {
            for j in 0..n {
                let p = concentric_disk(Vec2::new(
                    (i as f32 + 0.5) / n as f32,
                    (j as f32 + 0.5) / n as f32,
                ));
                assert!(p.length() <= 1.0 + 1e-6);
                mean_r2 += p.length_squared() as f64;
            }
        }
        mean_r2 /= (n * n) as f64;
        assert!((mean_r2 - 0.5).abs() < 1e-3, "{mean_r2}");
    }
}
