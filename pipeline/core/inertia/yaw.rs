//! Yaw inertia on an air-bearing table driven by a falling mass (methods section 2).
//!
//! In: indexed encoder events (time, band index), the event spacing, and the rig constants.
//! Out: the table's angular acceleration (constant-alpha quadratic fit, or the drag-aware
//! `ln cosh` fit), the loaded inertia from the exact torque balance
//! `J alpha = m g r - tau_f` with `J = I_tot + I_eq + m r^2`, the friction/tare identifications
//! (tare + calibration body, multi-mass regression, the thesis's multiplicative factor as a
//! flagged comparison) and the thesis's simplified formula `r g (m - m_drag) / alpha` for
//! comparison. Deliberately pure: the caller chooses which runs combine.

use nalgebra::{DMatrix, DVector};

use super::MethodError;
use crate::numerics::least_squares::{self, polyfit_centered};
use crate::numerics::nonlinear_least_squares::{Bounds, LeastSquaresProblem, Options, minimize};

/// Angular acceleration estimate from one run.
#[derive(Debug, Clone, PartialEq)]
pub struct AccelerationFit {
    /// Acceleration at zero speed, alpha or alpha0 (rad/s^2).
    pub alpha_rad_s2: f64,
    /// Its standard uncertainty from the fit covariance.
    pub u_alpha_rad_s2: f64,
    /// Drag constant `c = k_a / J` (1/rad) of the ln cosh model; 0 for the quadratic model.
    pub drag_c_per_rad: f64,
    /// Standard uncertainty of `c`. When the `ln cosh` fit leaves `c` on its bound 0 (no drag
    /// seen), the uncertainty of `c` with the bound released (see [`fit_lncosh`]): how large a
    /// drag the run cannot tell from none. NaN only when the fit's normal matrix is singular.
    pub u_drag_c_per_rad: f64,
    /// Number of events used.
    pub events: usize,
    /// RMS angle residual (rad).
    pub residual_rms_rad: f64,
    /// Highest speed reached in the fitted span (rad/s).
    pub peak_omega_rad_s: f64,
    /// Slope of the local acceleration `alpha_k` against `omega^2`, relative to alpha (1/rad);
    /// about `-c` when aerodynamic drag acts.
    pub alpha_slope_vs_omega2: f64,
}

/// Event angles (rad) from band indices.
pub fn event_angles(index: &[i64], spacing_rad: f64) -> Vec<f64> {
    index
        .iter()
        .map(|&k| (k - index[0]) as f64 * spacing_rad)
        .collect()
}

/// Constant-acceleration fit `theta = a tau^2 + b tau + c`, `tau = t - mean(t)`, `alpha = 2a`.
/// The quadratic space is shift invariant, so no time-offset search is needed (section 2.2).
pub fn fit_constant_alpha(
    times_s: &[f64],
    angles_rad: &[f64],
) -> Result<AccelerationFit, MethodError> {
    let fit = polyfit_centered(times_s, angles_rad, 2)?;
    let alpha = 2.0 * fit.coeffs[2];
    let peak = times_s
        .iter()
        .map(|&t| fit.derivative(t).abs())
        .fold(0.0, f64::max);
    Ok(AccelerationFit {
        alpha_rad_s2: alpha,
        u_alpha_rad_s2: 2.0 * fit.fit.std_err(2),
        drag_c_per_rad: 0.0,
        u_drag_c_per_rad: 0.0,
        events: times_s.len(),
        residual_rms_rad: fit.fit.rms(),
        peak_omega_rad_s: peak,
        alpha_slope_vs_omega2: local_alpha_slope(times_s, angles_rad, alpha),
    })
}

/// Local-alpha diagnostic (section 2.2): `alpha_k` from mid-interval speeds, regressed on
/// `omega^2`; returns the slope divided by `alpha` (1/rad). NaN with fewer than 6 events.
pub fn local_alpha_slope(times_s: &[f64], angles_rad: &[f64], alpha: f64) -> f64 {
    if times_s.len() < 6 {
        return f64::NAN;
    }
    let mids: Vec<(f64, f64)> = times_s
        .windows(2)
        .zip(angles_rad.windows(2))
        .map(|(t, a)| (0.5 * (t[0] + t[1]), (a[1] - a[0]) / (t[1] - t[0])))
        .collect();
    let (mut w2, mut ak) = (Vec::new(), Vec::new());
    for k in 1..mids.len() {
        let (t0, w0) = mids[k - 1];
        let (t1, w1) = mids[k];
        w2.push((0.5 * (w0 + w1)).powi(2));
        ak.push((w1 - w0) / (t1 - t0));
    }
    match polyfit_centered(&w2, &ak, 1) {
        Ok(line) => line.coeffs[1] / alpha,
        Err(_) => f64::NAN,
    }
}

/// `ln cosh x` without overflow and without cancellation near 0.
fn ln_cosh(x: f64) -> f64 {
    let a = x.abs();
    if a < 1.0 {
        (2.0 * (0.5 * a).sinh().powi(2)).ln_1p()
    } else {
        a + (-2.0 * a).exp().ln_1p() - std::f64::consts::LN_2
    }
}

/// Angle of the drag-aware model `theta1 + ln cosh(sqrt(alpha0 c) (t - t1)) / c`, with the series
/// `0.5 alpha0 x^2 (1 - u/6 + 2 u^2 / 45)`, `u = alpha0 c x^2`, near `c = 0`.
pub fn lncosh_angle(t: f64, theta1: f64, t1: f64, alpha0: f64, c: f64) -> f64 {
    let x = t - t1;
    let u = alpha0 * c * x * x;
    if u.abs() < 1e-9 {
        theta1 + 0.5 * alpha0 * x * x * (1.0 - u / 6.0 + 2.0 * u * u / 45.0)
    } else {
        theta1 + ln_cosh(u.sqrt() * x.signum()) / c
    }
}

struct LnCosh<'a> {
    t: &'a [f64],
    theta: &'a [f64],
    scale: [f64; 4],
}

impl LeastSquaresProblem for LnCosh<'_> {
    fn n_params(&self) -> usize {
        4
    }
    fn n_residuals(&self) -> usize {
        self.t.len()
    }
    fn residuals(&self, p: &[f64], r: &mut [f64]) {
        for ((ri, &t), &th) in r.iter_mut().zip(self.t).zip(self.theta) {
            *ri = lncosh_angle(t, p[0], p[1], p[2], p[3]) - th;
        }
    }
    /// Central differences, one-sided at `c = 0` (the series of [`lncosh_angle`] holds only for
    /// `c >= 0`).
    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        self.residuals(p, r);
        let m = self.t.len();
        let (mut r_hi, mut r_lo) = (vec![0.0; m], vec![0.0; m]);
        for k in 0..4 {
            let h = 1e-6 * p[k].abs().max(self.scale[k]);
            let (mut lo, mut hi) = ([p[0], p[1], p[2], p[3]], [p[0], p[1], p[2], p[3]]);
            hi[k] += h;
            lo[k] -= h;
            let width = if k == 3 && lo[k] < 0.0 {
                lo[k] = p[k];
                h
            } else {
                2.0 * h
            };
            self.residuals(&hi, &mut r_hi);
            self.residuals(&lo, &mut r_lo);
            for (i, (a, b)) in r_hi.iter().zip(&r_lo).enumerate() {
                jac[i * 4 + k] = (a - b) / width;
            }
        }
    }
}

/// Standard uncertainty of `c` at a fit that ended on the bound `c = 0`, where the solver gives
/// no covariance: `c` treated as free, from `s^2 (J^T J)^-1` of all four parameters at the
/// solution (`s^2` over `n - 4` degrees of freedom), the one-sided derivative in `c` standing
/// for the model's. `None` when the normal matrix is singular or there is no spare point.
fn u_drag_on_bound(model: &LnCosh, p: &[f64]) -> Option<f64> {
    let m = model.t.len();
    if m <= 4 {
        return None;
    }
    let (mut r, mut jac) = (vec![0.0; m], vec![0.0; m * 4]);
    model.residuals_and_jacobian(p, &mut r, &mut jac);
    let j = DMatrix::from_row_slice(m, 4, &jac);
    // Unit-diagonal scaling before inverting: the parameters differ by orders of magnitude.
    let normal = j.transpose() * &j;
    let d = DVector::from_fn(4, |k, _| normal[(k, k)].sqrt());
    if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    let scaled = DMatrix::from_fn(4, 4, |a, b| normal[(a, b)] / (d[a] * d[b]));
    let inv = scaled.cholesky()?.inverse();
    let s2 = r.iter().map(|x| x * x).sum::<f64>() / (m - 4) as f64;
    let var = s2 * inv[(3, 3)] / (d[3] * d[3]);
    (var.is_finite() && var >= 0.0).then(|| var.sqrt())
}

/// Drag-aware fit of `theta1 + ln cosh(sqrt(alpha0 c)(t - t1)) / c` (section 2.3), seeded from
/// the quadratic fit. `alpha0` is the acceleration at zero speed, so the torque balance applies
/// to it unchanged, and `k_a = c J`. A fit that ends on `c = 0` reports the uncertainty of `c`
/// with the bound released ([`AccelerationFit::u_drag_c_per_rad`]).
pub fn fit_lncosh(times_s: &[f64], angles_rad: &[f64]) -> Result<AccelerationFit, MethodError> {
    let quad = polyfit_centered(times_s, angles_rad, 2)?;
    let (a, b, c0) = (quad.coeffs[2], quad.coeffs[1], quad.coeffs[0]);
    if a <= 0.0 {
        return Err(MethodError::NonPhysical {
            reason: "table is not accelerating".into(),
        });
    }
    let t1 = quad.t_center - b / (2.0 * a);
    let theta1 = c0 - b * b / (4.0 * a);
    let span = angles_rad.iter().copied().fold(0.0, f64::max).max(1e-3);
    let model = LnCosh {
        t: times_s,
        theta: angles_rad,
        scale: [1.0, 1.0, 2.0 * a, 1e-3 / span],
    };
    // alpha0 > 0 and c >= 0: the model is defined for them only.
    let bounds = Bounds {
        lower: vec![f64::NEG_INFINITY, f64::NEG_INFINITY, 1e-12, 0.0],
        upper: vec![f64::INFINITY; 4],
    };
    let out = minimize(
        &model,
        &[theta1, t1, 2.0 * a, 0.01 / span],
        &bounds,
        &Options {
            max_iterations: 500,
            ..Options::default()
        },
    );
    if !out.params.iter().all(|v| v.is_finite()) {
        return Err(MethodError::NonPhysical {
            reason: "ln cosh fit diverged".into(),
        });
    }
    let p = &out.params;
    let peak = times_s
        .iter()
        .map(|&t| {
            let s = (p[2] * p[3]).sqrt();
            if s > 0.0 {
                (p[2] / p[3]).sqrt() * (s * (t - p[1])).tanh()
            } else {
                p[2] * (t - p[1])
            }
        })
        .fold(0.0, f64::max);
    Ok(AccelerationFit {
        alpha_rad_s2: p[2],
        u_alpha_rad_s2: out.std_errors[2].unwrap_or(f64::NAN),
        drag_c_per_rad: p[3],
        u_drag_c_per_rad: out.std_errors[3]
            .or_else(|| {
                out.at_bounds[3]
                    .then(|| u_drag_on_bound(&model, p))
                    .flatten()
            })
            .unwrap_or(f64::NAN),
        events: times_s.len(),
        residual_rms_rad: out.rmse,
        peak_omega_rad_s: peak,
        alpha_slope_vs_omega2: local_alpha_slope(times_s, angles_rad, p[2]),
    })
}

/// Torque the falling mass applies through the string, `F r = m r (g - r alpha)` (N m).
pub fn string_torque(mass_kg: f64, radius_m: f64, g: f64, alpha: f64) -> f64 {
    mass_kg * radius_m * (g - radius_m * alpha)
}

/// Exact torque balance: everything rotating with the table (table + load), excluding an idler
/// pulley's reflected inertia `i_eq`: `(m r (g - r alpha) - tau_f) / alpha - i_eq`.
pub fn rotating_inertia_exact(
    mass_kg: f64,
    radius_m: f64,
    g: f64,
    alpha: f64,
    friction_n_m: f64,
    i_eq: f64,
) -> f64 {
    (string_torque(mass_kg, radius_m, g, alpha) - friction_n_m) / alpha - i_eq
}

/// The thesis's simplified formula (Appendix A.2): `r g (m - m_drag) / alpha`, string tension
/// taken as the static weight. Too high by exactly `m r^2` (plus `I_eq`).
pub fn rotating_inertia_thesis(
    mass_kg: f64,
    drag_mass_kg: f64,
    radius_m: f64,
    g: f64,
    alpha: f64,
) -> f64 {
    radius_m * g * (mass_kg - drag_mass_kg) / alpha
}

/// One run for the rig-level identifications: falling mass and measured acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropRun {
    /// Falling mass (kg).
    pub mass_kg: f64,
    /// Angular acceleration (rad/s^2).
    pub alpha_rad_s2: f64,
}

/// Table tare and friction from an empty-table run and a calibration-body run (section 2.4,
/// option 2). Returns `(I_table, tau_f)`; `I_table` excludes `i_eq`.
pub fn tare_and_friction(
    tare: DropRun,
    calibration: DropRun,
    calibration_inertia: f64,
    radius_m: f64,
    g: f64,
    i_eq: f64,
) -> Result<(f64, f64), MethodError> {
    let f1 = string_torque(tare.mass_kg, radius_m, g, tare.alpha_rad_s2);
    let f2 = string_torque(calibration.mass_kg, radius_m, g, calibration.alpha_rad_s2);
    let d_alpha = tare.alpha_rad_s2 - calibration.alpha_rad_s2;
    if d_alpha.abs() < 1e-9 * tare.alpha_rad_s2.abs() {
        return Err(MethodError::NonPhysical {
            reason: "tare and calibration runs have the same acceleration".into(),
        });
    }
    let x = (f1 - f2 + calibration_inertia * calibration.alpha_rad_s2) / d_alpha;
    Ok((x - i_eq, f1 - x * tare.alpha_rad_s2))
}

/// Multi-mass regression on one loaded table (section 2.4, option 3): `F_j r = J alpha_j + tau_f`.
/// Returns `(I_tot, tau_f)` with `I_tot = J - i_eq` (table plus load).
pub fn multi_mass(
    runs: &[DropRun],
    radius_m: f64,
    g: f64,
    i_eq: f64,
) -> Result<(f64, f64), MethodError> {
    if runs.len() < 2 {
        return Err(MethodError::NonPhysical {
            reason: format!("multi-mass needs >= 2 runs, got {}", runs.len()),
        });
    }
    let design = DMatrix::from_fn(runs.len(), 2, |i, k| {
        if k == 0 { runs[i].alpha_rad_s2 } else { 1.0 }
    });
    let torque = DVector::from_iterator(
        runs.len(),
        runs.iter()
            .map(|r| string_torque(r.mass_kg, radius_m, g, r.alpha_rad_s2)),
    );
    let fit = least_squares::solve(&design, &torque)?;
    Ok((fit.params[0] - i_eq, fit.params[1]))
}

/// The thesis's multiplicative correction (section 2.4, option 5), kept only as a flagged
/// comparison: `k = I_cal / I_cal,raw` where raw ignores friction. Biased when the calibration
/// body's acceleration differs from the vehicle's.
pub fn calibration_factor(
    calibration: DropRun,
    calibration_inertia: f64,
    table_inertia: f64,
    radius_m: f64,
    g: f64,
    i_eq: f64,
) -> f64 {
    let raw = rotating_inertia_exact(
        calibration.mass_kg,
        radius_m,
        g,
        calibration.alpha_rad_s2,
        0.0,
        i_eq,
    ) - table_inertia;
    calibration_inertia / raw
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lncosh_series_and_closed_form_agree() {
        for &(alpha0, c, x) in &[
            (0.0744f64, 1e-9f64, 10.0f64),
            (0.0744, 1e-10, 8.0),
            (0.5, 1e-10, 3.0),
        ] {
            let u = alpha0 * c * x * x;
            let closed = ln_cosh(u.sqrt()) / c;
            let series = 0.5 * alpha0 * x * x * (1.0 - u / 6.0 + 2.0 * u * u / 45.0);
            assert!((closed - lncosh_angle(x, 0.0, 0.0, alpha0, c)).abs() <= 1e-12 * closed.abs());
            assert!(
                (closed - series).abs() <= 1e-12 * closed.abs(),
                "{closed} {series} (u = {u})"
            );
        }
    }

    #[test]
    fn drag_on_its_bound_has_the_uncertainty_of_the_released_fit() {
        // A drop without drag whose noise bends the other way (a small `+x^4` term the model
        // cannot follow with c >= 0): the fit ends on c = 0.
        let (alpha, t0) = (0.0744, 0.3);
        let times: Vec<f64> = (0..240).map(|k| t0 + 0.04 * k as f64).collect();
        let angles: Vec<f64> = times
            .iter()
            .enumerate()
            .map(|(k, &t)| {
                let noise = 2e-4 * ((k as f64 * 1.7).sin() + 0.5 * (k as f64 * 0.61).cos());
                0.5 * alpha * t * t + 1e-7 * t.powi(4) + noise
            })
            .collect();
        let fit = fit_lncosh(&times, &angles).unwrap();
        assert_eq!(fit.drag_c_per_rad, 0.0, "the fit should end on c = 0");
        let u = fit.u_drag_c_per_rad;
        assert!(u.is_finite() && u > 0.0, "u(c) = {u}");

        // At c = 0 the model moves, to first order, in the span of 1, x, x^2 and
        // -alpha0^2 x^4 / 12 (x = t - t1): u(c) is 12 / alpha0^2 times the standard error of the
        // x^4 coefficient of that linear regression, with the bound fit's residual variance.
        let quad = polyfit_centered(&times, &angles, 2).unwrap();
        let (a, b) = (quad.coeffs[2], quad.coeffs[1]);
        let t1 = quad.t_center - b / (2.0 * a);
        let n = times.len();
        let design = DMatrix::from_fn(n, 4, |i, k| (times[i] - t1).powi([0, 1, 2, 4][k]));
        let reg = least_squares::solve(&design, &DVector::from_column_slice(&angles)).unwrap();
        let rss_bound = quad.fit.rms().powi(2) * n as f64;
        let expected =
            12.0 / fit.alpha_rad_s2.powi(2) * reg.std_err(3) * (rss_bound / reg.rss).sqrt();
        assert!(
            (u - expected).abs() <= 1e-4 * expected,
            "u(c) {u} vs the linearised regression's {expected}"
        );
        // The automatic model choice keeps the quadratic fit: c is not above 5 u(c).
        assert!(fit.drag_c_per_rad <= 5.0 * u);
    }

    #[test]
    fn thesis_formula_is_high_by_m_r_squared() {
        let (m, r, g, tau) = (6.0, 0.15, 9.80665, 0.04);
        let alpha = (m * g * r - tau) / (118.0 + m * r * r);
        let exact = rotating_inertia_exact(m, r, g, alpha, tau, 0.0);
        let thesis = rotating_inertia_thesis(m, tau / (g * r), r, g, alpha);
        assert!((exact - 118.0).abs() < 1e-10);
        assert!((thesis - exact - m * r * r).abs() < 1e-10);
    }

    #[test]
    fn thesis_formula_cancels_when_the_tare_uses_it_too() {
        // V1: with I_table itself "measured" by the thesis formula (8.135) from an empty-table
        // run with the same m and r, the thesis result for the vehicle is exactly 110.000.
        let (m, r, g, tau) = (6.0, 0.15, 9.80665, 0.04);
        let alpha = |load: f64| (m * g * r - tau) / (8.0 + load + m * r * r);
        let m_drag = tau / (g * r);
        let table = rotating_inertia_thesis(m, m_drag, r, g, alpha(0.0));
        assert!((table - 8.135).abs() < 1e-9, "{table}");
        let veh = rotating_inertia_thesis(m, m_drag, r, g, alpha(110.0)) - table;
        assert!((veh - 110.0).abs() < 1e-9, "{veh}");
    }
}
