//! Seeded, fast Gaussian pixel noise.
//!
//! Drawing a Gaussian sample per pixel with Box–Muller would take most of the 2 ms render budget. Instead a
//! table holds the inverse normal CDF at 4096 equally likely levels, Φ⁻¹((i + ½)/4096), and each pixel
//! takes 12 bits of a xorshift generator as its index: every pixel gets an independent Gaussian sample,
//! quantized to 4096 levels and cut at ±3.5σ (the table's ends). Same seed, same noise, on every platform.

/// Entries in the inverse-CDF table (12 bits of index).
const LEVELS: usize = 4096;

/// xorshift64* — small, fast, and good enough for image noise; not for cryptography.
#[derive(Debug, Clone, Copy)]
pub struct Xorshift64(u64);

impl Xorshift64 {
    /// A generator from a seed (any value; zero is replaced).
    pub fn new(seed: u64) -> Self {
        // splitmix64 scramble so that nearby seeds give unrelated streams
        let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        Self(if z == 0 { 0x2545_F491_4F6C_DD1D } else { z })
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

/// Gaussian samples of a given σ from a table.
#[derive(Debug, Clone)]
pub struct GaussianTable {
    values: Box<[f32; LEVELS]>,
}

impl GaussianTable {
    /// The table for standard deviation `sigma`.
    pub fn new(sigma: f64) -> Self {
        let mut values = Box::new([0.0_f32; LEVELS]);
        for (i, v) in values.iter_mut().enumerate() {
            *v = (sigma * inverse_normal_cdf((i as f64 + 0.5) / LEVELS as f64)) as f32;
        }
        Self { values }
    }

    /// The sample for the low 12 bits of `bits`.
    #[inline]
    pub fn sample(&self, bits: u64) -> f32 {
        self.values[(bits as usize) & (LEVELS - 1)]
    }
}

/// Φ⁻¹(p) by Acklam's rational approximation (relative error below 1.2e-9), for 0 < p < 1.
pub fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    const LOW: f64 = 0.02425;
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_cdf_hits_known_quantiles() {
        assert!(inverse_normal_cdf(0.5).abs() < 1e-12);
        assert!((inverse_normal_cdf(0.975) - 1.959963984540054).abs() < 1e-8);
        assert!((inverse_normal_cdf(0.001) + 3.090232306167814).abs() < 1e-8);
    }

    #[test]
    fn table_samples_have_the_requested_spread_and_no_bias() {
        let table = GaussianTable::new(2.0);
        let mut rng = Xorshift64::new(7);
        let n = 200_000;
        let (mut sum, mut sum_sq) = (0.0_f64, 0.0_f64);
        for _ in 0..n {
            let x = f64::from(table.sample(rng.next_u64()));
            sum += x;
            sum_sq += x * x;
        }
        let mean = sum / f64::from(n);
        let sigma = (sum_sq / f64::from(n) - mean * mean).sqrt();
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((sigma - 2.0).abs() < 0.02, "σ {sigma}");
    }
}
