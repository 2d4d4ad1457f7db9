//! Swing record -> small-amplitude, undamped natural period (methods sections 4.4 and 5).
//!
//! In: a sampled angle (rad) or angular rate (rad/s) of a free oscillation, analysis options and
//! the rig's amplitude law `T(A)/T0` (AGM for a rigid pendulum, the trifilar formula for a
//! trifilar). Out: [`SwingPeriod`]: `T0` with its uncertainty (the larger of the fit covariance
//! and the spread between windows), damping, amplitudes, cycles, the backbone slope and the
//! uncorrected period. Pipeline: zero-crossing seed, whole-record damped-sine NLS,
//! `T_n = 2 pi / sqrt(omega_d^2 + sigma^2)`, then per-window fits each corrected at its own
//! amplitude. Deliberately no spectral beating detection beyond the fit-quality check.

use super::MethodError;
use crate::numerics::damped_sine::{self, DampedSineFit};
use crate::numerics::least_squares::polyfit_centered;
use crate::numerics::period;
use std::f64::consts::TAU;

/// What the swing sensor measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignalKind {
    /// Angle (rad).
    Angle,
    /// Angular rate (rad/s), e.g. a gyro; amplitude in angle is `A_rate / omega`.
    Rate,
}

/// Period estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeriodMethod {
    /// Damped-sine nonlinear least squares (recommended).
    Nls,
    /// Zero-crossing least-squares slope (the thesis's method), for comparison.
    ZeroCrossing,
}

/// Where the amplitude correction is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CorrectionScope {
    /// No amplitude correction (damping correction only).
    None,
    /// One correction at the record's RMS amplitude.
    Whole,
    /// Per-window fits, each corrected at its centre amplitude, then averaged.
    Windowed,
}

/// Swing analysis options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingOptions {
    /// Period estimator.
    pub method: PeriodMethod,
    /// Amplitude-correction scope.
    pub correction: CorrectionScope,
    /// Window length in cycles for windowed fits.
    pub window_cycles: f64,
    /// Cycles skipped after release.
    pub discard_initial_cycles: f64,
    /// Minimum cycles required in the analysed record.
    pub min_cycles: f64,
}

impl Default for SwingOptions {
    fn default() -> Self {
        Self {
            method: PeriodMethod::Nls,
            correction: CorrectionScope::Windowed,
            window_cycles: 3.0,
            discard_initial_cycles: 1.0,
            min_cycles: 10.0,
        }
    }
}

/// The period of a swing record.
#[derive(Debug, Clone, PartialEq)]
pub struct SwingPeriod {
    /// Small-amplitude undamped natural period `T0` (s).
    pub period_s: f64,
    /// Its standard uncertainty (s).
    pub u_period_s: f64,
    /// Undamped period before amplitude correction (s).
    pub period_uncorrected_s: f64,
    /// Damping ratio.
    pub zeta: f64,
    /// Amplitude at the start and end of the analysed record (rad).
    pub amplitude_start_rad: f64,
    /// Amplitude at the end of the analysed record (rad).
    pub amplitude_end_rad: f64,
    /// Cycles analysed.
    pub cycles: f64,
    /// Windows used (0 unless windowed).
    pub windows: usize,
    /// Backbone slope `d(omega_n/omega_0)/d(A^2)` (1/rad^2), about -1/16 for a rigid pendulum;
    /// NaN with fewer than 3 windows.
    pub backbone_slope_per_rad2: f64,
    /// Whole-record fit RMS residual (signal units).
    pub residual_rms: f64,
}

fn not_found(reason: impl Into<String>) -> MethodError {
    MethodError::PeriodNotFound {
        reason: reason.into(),
    }
}

fn amplitude_rad(fit: &DampedSineFit, t: f64, kind: SignalKind) -> f64 {
    match kind {
        SignalKind::Angle => fit.amplitude_at(t),
        SignalKind::Rate => fit.amplitude_at(t) / fit.omega_d(),
    }
}

/// Corrects an undamped period `tn` at amplitude `a` with the rig's law `ratio(a, t0)`.
fn correct(tn: f64, a: f64, ratio: &dyn Fn(f64, f64) -> f64) -> f64 {
    let mut t0 = tn;
    for _ in 0..4 {
        t0 = tn / ratio(a, t0);
    }
    t0
}

/// Analyses one swing record; `ratio(A, T0)` is the rig's period ratio `T(A)/T0`.
pub fn analyze(
    t_s: &[f64],
    signal: &[f64],
    kind: SignalKind,
    opts: &SwingOptions,
    ratio: &dyn Fn(f64, f64) -> f64,
) -> Result<SwingPeriod, MethodError> {
    if t_s.len() < 20 {
        return Err(not_found(format!(
            "{} samples, need at least 20",
            t_s.len()
        )));
    }
    let omega_seed = period::seed_omega(t_s, signal).map_err(|e| not_found(e.to_string()))?;
    let t_start = t_s[0] + opts.discard_initial_cycles * TAU / omega_seed;
    let first = t_s.partition_point(|&t| t < t_start);
    let (t, x) = (&t_s[first..], &signal[first..]);
    let duration = t.last().copied().unwrap_or(t_start) - t_start;
    let cycles = duration * omega_seed / TAU;
    if cycles < opts.min_cycles {
        return Err(not_found(format!(
            "only {cycles:.1} cycles after the first {} discarded, need {}",
            opts.discard_initial_cycles, opts.min_cycles
        )));
    }
    let t_mid = 0.5 * (t[0] + t[t.len() - 1]);
    let whole = damped_sine::fit(t, x, t_mid, omega_seed, 0.0, false)
        .map_err(|e| not_found(e.to_string()))?;
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64;
    let explained = 1.0 - whole.rmse * whole.rmse / var.max(1e-300);
    if !whole.converged || explained < 0.5 || whole.omega_d() <= 0.0 {
        return Err(not_found(format!(
            "damped-sine fit explains {:.0} % of the signal variance (converged: {})",
            100.0 * explained,
            whole.converged
        )));
    }
    let omega_n = whole.omega_n();
    let tn_whole = TAU / omega_n;
    let u_whole = tn_whole * whole.u_omega_n() / omega_n;
    let a_start = amplitude_rad(&whole, t[0], kind);
    let a_end = amplitude_rad(&whole, t[t.len() - 1], kind);
    let a_rms = (x.len() as f64).recip()
        * t.iter()
            .map(|&ti| amplitude_rad(&whole, ti, kind).powi(2))
            .sum::<f64>();
    let a_rms = a_rms.sqrt();
    let mut out = SwingPeriod {
        period_s: tn_whole,
        u_period_s: u_whole,
        period_uncorrected_s: tn_whole,
        zeta: whole.zeta(),
        amplitude_start_rad: a_start,
        amplitude_end_rad: a_end,
        cycles,
        windows: 0,
        backbone_slope_per_rad2: f64::NAN,
        residual_rms: whole.rmse,
    };
    if opts.method == PeriodMethod::ZeroCrossing {
        let hyst = 0.2 * amplitude_rad(&whole, t[t.len() - 1], SignalKind::Angle);
        let (td, u_td) = period::zero_crossing_period(t, x, whole.offset(), hyst)
            .map_err(|e| not_found(e.to_string()))?;
        let damping = (1.0 - out.zeta * out.zeta).sqrt();
        out.period_uncorrected_s = td * damping;
        out.u_period_s = u_td * damping;
        out.period_s = match opts.correction {
            CorrectionScope::None => out.period_uncorrected_s,
            _ => correct(out.period_uncorrected_s, a_rms, ratio),
        };
        return Ok(out);
    }
    match opts.correction {
        CorrectionScope::None => {}
        CorrectionScope::Whole => out.period_s = correct(tn_whole, a_rms, ratio),
        CorrectionScope::Windowed => {
            let window_s = opts.window_cycles * TAU / whole.omega_d();
            let windows = damped_sine::fit_windows(t, x, window_s, &whole, false)
                .map_err(|e| not_found(e.to_string()))?;
            let windows: Vec<&DampedSineFit> = windows
                .iter()
                .filter(|w| w.converged && w.omega_n() > 0.0)
                .collect();
            if windows.len() < 2 {
                out.period_s = correct(tn_whole, a_rms, ratio);
            } else {
                let mut num = 0.0;
                let mut den = 0.0;
                let mut t0s = Vec::new();
                let (mut amp2, mut wn) = (Vec::new(), Vec::new());
                for w in &windows {
                    let a = amplitude_rad(w, w.t_ref, kind);
                    let tn = TAU / w.omega_n();
                    let t0 = correct(tn, a, ratio);
                    let u = (tn * w.u_omega_n() / w.omega_n()).max(1e-15 * tn);
                    num += t0 / (u * u);
                    den += 1.0 / (u * u);
                    t0s.push(t0);
                    amp2.push(a * a);
                    wn.push(w.omega_n());
                }
                let t0 = num / den;
                let n = t0s.len() as f64;
                let mean = t0s.iter().sum::<f64>() / n;
                let spread = (t0s.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0))
                    .sqrt()
                    / n.sqrt();
                out.period_s = t0;
                out.u_period_s = u_whole.max(spread).max(den.recip().sqrt());
                out.windows = windows.len();
                if windows.len() >= 3
                    && let Ok(line) = polyfit_centered(&amp2, &wn, 1)
                {
                    out.backbone_slope_per_rad2 = line.coeffs[1] / line.eval(0.0);
                }
            }
        }
    }
    Ok(out)
}
