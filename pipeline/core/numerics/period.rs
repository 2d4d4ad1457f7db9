//! Period and frequency helpers: the arithmetic-geometric mean (exact large-amplitude pendulum
//! period), zero-crossing detection with hysteresis, a zero-crossing period seed and the
//! zero-crossing least-squares period estimator (the thesis's method, kept for comparison).
//!
//! In: sampled signals `(t, x)`. Out: crossing times, periods in seconds, frequency seeds in rad/s.
//! Deliberately no spectral estimators: the damped-sine fit in [`super::damped_sine`] is the
//! precise estimator; these only seed it or serve as a cross-check.

use super::{NumericsError, check_finite, least_squares};

/// Arithmetic-geometric mean of two positive numbers (quadratic convergence, <= 10 iterations).
pub fn agm(mut a: f64, mut b: f64) -> f64 {
    for _ in 0..64 {
        let (an, bn) = (0.5 * (a + b), (a * b).sqrt());
        if (an - bn).abs() <= 1e-16 * an {
            return an;
        }
        a = an;
        b = bn;
    }
    0.5 * (a + b)
}

/// Exact period ratio `T(theta0) / T0 = 1 / AGM(1, cos(theta0 / 2))` of a rigid pendulum
/// swinging with amplitude `amplitude_rad` (Carvalhaes and Suppes 2008).
pub fn pendulum_period_ratio(amplitude_rad: f64) -> f64 {
    1.0 / agm(1.0, (0.5 * amplitude_rad).cos())
}

/// Times at which `x - level` changes sign, linearly interpolated, with hysteresis: after a
/// crossing the signal must move beyond `level -/+ hysteresis` before the next one counts.
pub fn zero_crossings(t: &[f64], x: &[f64], level: f64, hysteresis: f64) -> Vec<f64> {
    let mut out = Vec::new();
    // state: +1 above level + hyst, -1 below level - hyst, 0 unknown
    let mut state = 0i8;
    let mut last_index_on_side = 0usize;
    for i in 0..x.len() {
        let v = x[i] - level;
        let side = if v > hysteresis {
            1
        } else if v < -hysteresis {
            -1
        } else {
            0
        };
        if side != 0 {
            if state != 0 && side != state {
                // find the sign change between last_index_on_side and i
                let mut k = last_index_on_side;
                while k < i {
                    let (a, b) = (x[k] - level, x[k + 1] - level);
                    if (a <= 0.0) != (b <= 0.0) {
                        break;
                    }
                    k += 1;
                }
                let (a, b) = (x[k] - level, x[k + 1] - level);
                let frac = if (b - a).abs() > 0.0 {
                    -a / (b - a)
                } else {
                    0.5
                };
                out.push(t[k] + frac * (t[k + 1] - t[k]));
            }
            state = side;
            last_index_on_side = i;
        }
    }
    out
}

/// A frequency seed in rad/s from zero crossings of the mean-removed signal (hysteresis 10 % of
/// the robust half-range). Errors when fewer than 4 crossings are found.
pub fn seed_omega(t: &[f64], x: &[f64]) -> Result<f64, NumericsError> {
    check_finite("oscillation signal", x)?;
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    let mut sorted: Vec<f64> = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    if sorted.is_empty() {
        return Err(NumericsError::TooFewPoints {
            what: "oscillation signal",
            needed: 8,
            found: 0,
        });
    }
    let half_range = 0.5 * (q(0.99) - q(0.01));
    if half_range <= 0.0 {
        return Err(NumericsError::Degenerate {
            what: "oscillation signal",
            reason: "signal is flat".into(),
        });
    }
    let crossings = zero_crossings(t, x, mean, 0.1 * half_range);
    if crossings.len() < 4 {
        return Err(NumericsError::TooFewPoints {
            what: "zero crossings",
            needed: 4,
            found: crossings.len(),
        });
    }
    let span = crossings[crossings.len() - 1] - crossings[0];
    let half_period = span / (crossings.len() - 1) as f64;
    Ok(std::f64::consts::PI / half_period)
}

/// Zero-crossing period estimate: twice the least-squares slope of crossing time against
/// crossing index, about `level`. Returns `(period_s, standard uncertainty_s)`.
pub fn zero_crossing_period(
    t: &[f64],
    x: &[f64],
    level: f64,
    hysteresis: f64,
) -> Result<(f64, f64), NumericsError> {
    let crossings = zero_crossings(t, x, level, hysteresis);
    if crossings.len() < 4 {
        return Err(NumericsError::TooFewPoints {
            what: "zero crossings",
            needed: 4,
            found: crossings.len(),
        });
    }
    let idx: Vec<f64> = (0..crossings.len()).map(|i| i as f64).collect();
    let fit = least_squares::polyfit_centered(&idx, &crossings, 1)?;
    Ok((2.0 * fit.coeffs[1], 2.0 * fit.fit.std_err(1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agm_matches_methods_table() {
        // inertia-methods.md section 4.4: T/T0 at 3, 10, 20 degrees.
        for (deg, ratio) in [(3.0, 1.000171), (10.0, 1.001907), (20.0, 1.007669)] {
            let r = pendulum_period_ratio(f64::to_radians(deg));
            assert!((r - ratio).abs() < 1e-6, "{deg} deg: {r}");
        }
        // series 1 + t^2/16 + 11 t^4/3072 at a small angle
        let a: f64 = 0.05;
        let series = 1.0 + a * a / 16.0 + 11.0 * a.powi(4) / 3072.0 + 173.0 * a.powi(6) / 737280.0;
        assert!((pendulum_period_ratio(a) - series).abs() < 1e-14);
    }

    #[test]
    fn zero_crossing_period_of_sine() {
        let t: Vec<f64> = (0..5000).map(|i| i as f64 * 0.01).collect();
        let x: Vec<f64> = t.iter().map(|t| (2.0 * t + 0.3).sin() + 0.2).collect();
        let (p, _) = zero_crossing_period(&t, &x, 0.2, 0.05).unwrap();
        assert!((p - std::f64::consts::PI).abs() < 1e-4, "{p}");
        assert!((seed_omega(&t, &x).unwrap() - 2.0).abs() < 1e-3);
    }
}
