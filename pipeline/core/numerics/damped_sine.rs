//! Nonlinear least-squares fit of a viscously damped sinusoid, whole-record and windowed.
//!
//! Model: `x(t) = c0 [+ c1 tau] + exp(-sigma tau) (B sin(omega_d tau) + C cos(omega_d tau))`,
//! `tau = t - t_ref`, with `omega_n = sqrt(omega_d^2 + sigma^2)` and `zeta = sigma / omega_n`.
//! In: samples `(t, x)` (any spacing) and a frequency seed. Out: [`DampedSineFit`] with the
//! covariance of all parameters, hence `u(omega_n)`. Windowed fits return one fit per window of a
//! given length, seeded from the whole-record fit, for amplitude-dependent corrections.
//! Deliberately no amplitude correction here (that is physics: see `inertia::swing`).

use nalgebra::{DMatrix, DVector};

use super::nonlinear_least_squares::{Bounds, LeastSquaresProblem, Options, minimize};
use super::{NumericsError, check_finite, least_squares};

/// Parameter order in the fit vector.
const OFFSET: usize = 0;
const SIN: usize = 1;
const COS: usize = 2;
const OMEGA: usize = 3;
const SIGMA: usize = 4;
const DRIFT: usize = 5;

struct Model<'a> {
    t: &'a [f64],
    x: &'a [f64],
    t_ref: f64,
    drift: bool,
}

impl Model<'_> {
    fn value(&self, p: &[f64], t: f64) -> f64 {
        let tau = t - self.t_ref;
        let e = (-p[SIGMA] * tau).exp();
        let (s, c) = (p[OMEGA] * tau).sin_cos();
        let d = if self.drift { p[DRIFT] * tau } else { 0.0 };
        p[OFFSET] + d + e * (p[SIN] * s + p[COS] * c)
    }
}

impl LeastSquaresProblem for Model<'_> {
    fn n_params(&self) -> usize {
        if self.drift { 6 } else { 5 }
    }

    fn n_residuals(&self) -> usize {
        self.t.len()
    }

    fn residuals(&self, p: &[f64], r: &mut [f64]) {
        for ((ri, &t), &x) in r.iter_mut().zip(self.t).zip(self.x) {
            *ri = self.value(p, t) - x;
        }
    }

    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        self.residuals(p, r);
        let n = self.n_params();
        for (&t, row) in self.t.iter().zip(jac.chunks_exact_mut(n)) {
            let tau = t - self.t_ref;
            let e = (-p[SIGMA] * tau).exp();
            let (s, c) = (p[OMEGA] * tau).sin_cos();
            row[OFFSET] = 1.0;
            row[SIN] = e * s;
            row[COS] = e * c;
            row[OMEGA] = e * tau * (p[SIN] * c - p[COS] * s);
            row[SIGMA] = -tau * e * (p[SIN] * s + p[COS] * c);
            if self.drift {
                row[DRIFT] = tau;
            }
        }
    }
}

/// A fitted damped sinusoid.
#[derive(Debug, Clone)]
pub struct DampedSineFit {
    /// Parameters `[c0, B, C, omega_d, sigma, (c1)]`.
    pub params: DVector<f64>,
    /// Their covariance.
    pub covariance: DMatrix<f64>,
    /// Time origin of `tau`.
    pub t_ref: f64,
    /// Root-mean-square residual (signal units).
    pub rmse: f64,
    /// Levenberg-Marquardt trial steps.
    pub iterations: usize,
    /// Whether the solver met a stopping test.
    pub converged: bool,
    /// Number of samples fitted.
    pub samples: usize,
}

impl DampedSineFit {
    /// Constant offset `c0` (signal units).
    pub fn offset(&self) -> f64 {
        self.params[OFFSET]
    }
    /// Damped angular frequency (rad/s).
    pub fn omega_d(&self) -> f64 {
        self.params[OMEGA]
    }
    /// Decay rate `sigma = zeta omega_n` (1/s).
    pub fn sigma(&self) -> f64 {
        self.params[SIGMA]
    }
    /// Undamped natural angular frequency `sqrt(omega_d^2 + sigma^2)` (rad/s).
    pub fn omega_n(&self) -> f64 {
        self.omega_d().hypot(self.sigma())
    }
    /// Standard uncertainty of `omega_n` from the fit covariance.
    pub fn u_omega_n(&self) -> f64 {
        let (w, s, wn) = (self.omega_d(), self.sigma(), self.omega_n());
        let (gw, gs) = (w / wn, s / wn);
        let c = &self.covariance;
        (gw * gw * c[(OMEGA, OMEGA)]
            + gs * gs * c[(SIGMA, SIGMA)]
            + 2.0 * gw * gs * c[(OMEGA, SIGMA)])
            .max(0.0)
            .sqrt()
    }
    /// Damping ratio.
    pub fn zeta(&self) -> f64 {
        self.sigma() / self.omega_n()
    }
    /// Oscillation amplitude `sqrt(B^2 + C^2) exp(-sigma (t - t_ref))` at time `t`.
    pub fn amplitude_at(&self, t: f64) -> f64 {
        self.params[SIN].hypot(self.params[COS]) * (-self.sigma() * (t - self.t_ref)).exp()
    }
    /// Model value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        let m = Model {
            t: &[],
            x: &[],
            t_ref: self.t_ref,
            drift: self.params.len() > DRIFT,
        };
        m.value(self.params.as_slice(), t)
    }
}

/// Fits the damped sine to `(t, x)` from a frequency seed `omega_seed` (rad/s) and decay seed
/// `sigma_seed` (1/s). Amplitudes and offset are seeded by linear least squares.
pub fn fit(
    t: &[f64],
    x: &[f64],
    t_ref: f64,
    omega_seed: f64,
    sigma_seed: f64,
    drift: bool,
) -> Result<DampedSineFit, NumericsError> {
    if t.len() != x.len() {
        return Err(NumericsError::LengthMismatch {
            what: "damped sine fit",
            left: t.len(),
            right: x.len(),
        });
    }
    let n_par = if drift { 6 } else { 5 };
    if t.len() < 2 * n_par {
        return Err(NumericsError::TooFewPoints {
            what: "damped sine fit",
            needed: 2 * n_par,
            found: t.len(),
        });
    }
    check_finite("damped sine samples", x)?;
    check_finite("damped sine times", t)?;
    // Linear seed for c0, B, C (and c1) at the seeded frequency and decay.
    let cols = if drift { 4 } else { 3 };
    let design = DMatrix::from_fn(t.len(), cols, |i, k| {
        let tau = t[i] - t_ref;
        let e = (-sigma_seed * tau).exp();
        match k {
            0 => 1.0,
            1 => e * (omega_seed * tau).sin(),
            2 => e * (omega_seed * tau).cos(),
            _ => tau,
        }
    });
    let lin = least_squares::solve(&design, &DVector::from_column_slice(x))?;
    let mut p0 = vec![0.0; n_par];
    p0[OFFSET] = lin.params[0];
    p0[SIN] = lin.params[1];
    p0[COS] = lin.params[2];
    p0[OMEGA] = omega_seed;
    p0[SIGMA] = sigma_seed;
    if drift {
        p0[DRIFT] = lin.params[3];
    }
    let model = Model { t, x, t_ref, drift };
    let out = minimize(&model, &p0, &Bounds::unbounded(n_par), &Options::default());
    Ok(DampedSineFit {
        converged: out.termination.converged(),
        params: DVector::from_vec(out.params),
        covariance: out.covariance,
        t_ref,
        rmse: out.rmse,
        iterations: out.iterations,
        samples: t.len(),
    })
}

/// Fits consecutive, non-overlapping windows of `window_s` seconds (the last partial window is
/// dropped), each seeded from `seed` and referenced to its own centre time.
pub fn fit_windows(
    t: &[f64],
    x: &[f64],
    window_s: f64,
    seed: &DampedSineFit,
    drift: bool,
) -> Result<Vec<DampedSineFit>, NumericsError> {
    let mut out = Vec::new();
    if t.is_empty() || window_s <= 0.0 {
        return Ok(out);
    }
    let mut start = 0usize;
    let t_end = t[t.len() - 1];
    while start < t.len() {
        let t0 = t[start];
        if t0 + window_s > t_end + 1e-12 {
            break;
        }
        let stop = start + t[start..].partition_point(|&ti| ti < t0 + window_s);
        let fit = fit(
            &t[start..stop],
            &x[start..stop],
            t0 + 0.5 * window_s,
            seed.omega_d(),
            seed.sigma(),
            drift,
        )?;
        out.push(fit);
        start = stop;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::nonlinear_least_squares::finite_difference_jacobian;

    fn synth(n: usize, dt: f64, wd: f64, sigma: f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let x = t
            .iter()
            .map(|t| 0.1 + (-sigma * t).exp() * (2.0 * (wd * t + 0.7).sin()))
            .collect();
        (t, x)
    }

    #[test]
    fn recovers_frequency_and_decay() {
        let (t, x) = synth(6000, 0.01, 2.66, 0.008);
        let fit = fit(&t, &x, 30.0, 2.6, 0.0, false).unwrap();
        assert!(fit.converged);
        assert!((fit.omega_d() - 2.66).abs() < 1e-10, "{}", fit.omega_d());
        assert!((fit.sigma() - 0.008).abs() < 1e-10);
        assert!((fit.offset() - 0.1).abs() < 1e-10);
        assert!((fit.amplitude_at(0.0) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn analytic_jacobian_matches_finite_differences() {
        let (t, x) = synth(300, 0.02, 3.0, 0.05);
        let model = Model {
            t: &t,
            x: &x,
            t_ref: 3.0,
            drift: true,
        };
        let p = [0.1, 1.2, -0.4, 3.1, 0.04, 0.01];
        let fd = finite_difference_jacobian(&model, &p, 1e-6);
        let mut r = vec![0.0; t.len()];
        let mut an = vec![0.0; fd.len()];
        model.residuals_and_jacobian(&p, &mut r, &mut an);
        let worst = fd
            .iter()
            .zip(&an)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn windows_cover_the_record() {
        let (t, x) = synth(6000, 0.01, 2.66, 0.008);
        let whole = fit(&t, &x, 30.0, 2.6, 0.0, false).unwrap();
        let windows = fit_windows(&t, &x, 7.0, &whole, false).unwrap();
        assert_eq!(windows.len(), 8);
        for w in &windows {
            assert!((w.omega_d() - 2.66).abs() < 1e-9);
        }
    }
}
