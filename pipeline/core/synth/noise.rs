//! Deterministic random numbers for the virtual test machine.
//!
//! In: a 64-bit seed and a stream key (tire, run). Out: a [`Rng`] (xoshiro256++, seeded through
//! splitmix64) with uniform and Gaussian draws, and the two noise processes sensors need: white
//! noise and a first-order auto-regressive (AR(1)) wander for set-point servo errors.
//!
//! The generator is written here (30 lines, public-domain algorithms by Blackman and Vigna)
//! rather than taken from a crate so that the bytes of a generated round never change with a
//! dependency upgrade. Every run file owns one stream, keyed by `(seed, tire, run)`, so files can
//! be generated in parallel in any order and still come out byte-identical.
//! Deliberately not here: anything physical (noise amplitudes are chosen by the caller).

/// splitmix64 step: the recommended way to expand one seed into xoshiro state.
fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// xoshiro256++ pseudo-random generator.
#[derive(Clone, Debug)]
pub struct Rng {
    s: [u64; 4],
    spare_normal: Option<f64>,
}

impl Rng {
    /// A generator for one stream: the round seed mixed with a key (e.g. tire index and run).
    pub fn for_stream(seed: u64, key: &[u64]) -> Rng {
        let mut mix = seed ^ 0x5DEE_CE66_D1CE_5EED;
        for &k in key {
            mix = splitmix64(&mut mix) ^ k.wrapping_mul(0xD6E8_FEB8_6659_FD93);
        }
        let mut sm = mix;
        let s = [
            splitmix64(&mut sm),
            splitmix64(&mut sm),
            splitmix64(&mut sm),
            splitmix64(&mut sm),
        ];
        Rng {
            s,
            spare_normal: None,
        }
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform integer in `0..n` (`n > 0`; the modulo bias is below 2^-40 for the small `n` used).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }

    /// Standard normal draw (Marsaglia polar method; the second value is kept for the next call).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        loop {
            let u = 2.0 * self.uniform() - 1.0;
            let v = 2.0 * self.uniform() - 1.0;
            let s = u * u + v * v;
            if s > 0.0 && s < 1.0 {
                let f = (-2.0 * s.ln() / s).sqrt();
                self.spare_normal = Some(v * f);
                return u * f;
            }
        }
    }

    /// Normal draw with standard deviation `sigma` (exactly 0 when `sigma` is 0, drawing nothing,
    /// so a noise-free configuration does not depend on the stream).
    pub fn gauss(&mut self, sigma: f64) -> f64 {
        if sigma == 0.0 {
            0.0
        } else {
            sigma * self.normal()
        }
    }
}

/// A stationary first-order auto-regressive process: `x[k+1] = r x[k] + sqrt(1 - r^2) sigma w`,
/// the discrete twin of a Gauss-Markov wander with correlation time `tau_s`.
#[derive(Clone, Debug)]
pub struct Wander {
    value: f64,
    r: f64,
    innovation: f64,
}

impl Wander {
    /// A wander of standard deviation `sigma` and correlation time `tau_s` sampled every `dt_s`.
    pub fn new(sigma: f64, tau_s: f64, dt_s: f64) -> Wander {
        let r = if tau_s > 0.0 {
            (-dt_s / tau_s).exp()
        } else {
            0.0
        };
        Wander {
            value: 0.0,
            r,
            innovation: sigma * (1.0 - r * r).sqrt(),
        }
    }

    /// Advance one sample and return the new value.
    pub fn step(&mut self, rng: &mut Rng) -> f64 {
        self.value = self.r * self.value + rng.gauss(self.innovation);
        self.value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = {
            let mut r = Rng::for_stream(7, &[1, 2]);
            (0..4).map(|_| r.next_u64()).collect()
        };
        let b: Vec<u64> = {
            let mut r = Rng::for_stream(7, &[1, 2]);
            (0..4).map(|_| r.next_u64()).collect()
        };
        let c: Vec<u64> = {
            let mut r = Rng::for_stream(7, &[2, 1]);
            (0..4).map(|_| r.next_u64()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn normal_has_unit_variance() {
        let mut r = Rng::for_stream(1, &[0]);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "variance {var}");
    }

    #[test]
    fn wander_keeps_its_variance() {
        let mut r = Rng::for_stream(3, &[0]);
        let mut w = Wander::new(2.0, 0.5, 0.01);
        let xs: Vec<f64> = (0..400_000).map(|_| w.step(&mut r)).collect();
        let var = xs.iter().map(|x| x * x).sum::<f64>() / xs.len() as f64;
        assert!((var.sqrt() - 2.0).abs() < 0.1, "sd {}", var.sqrt());
    }
}
