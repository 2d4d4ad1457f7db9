//! Longitudinal slip for files without SL: kappa derived as SL is defined.
//!
//! In: a converted, cross-checked [`RunTable`] whose SL is missing or all zero. Out: when the
//! run sweeps its slip ratio (Calspan's control slip SR spans at least [`SWEEP_SPAN`] while
//! rolling) and a wheel speed is known, `kappa = Omega Re(Fz) / V - 1` per sample, where
//! `Omega / V` comes from N and V (else from SR and RL: `V / Omega = RL / (1 + SR)`), and
//! `Re(Fz)`, the effective rolling radius, is `V / Omega` where FX crosses zero in free rolling
//! (slip angle under 1 deg), fitted as a straight line in Fz over every such crossing. That is
//! SL's definition (RE-based, SL = 0 gives FX ~ 0); the result is marked derived, not measured.
//!
//! Deliberately not here: anything when SL was recorded, or when the run never sweeps its slip
//! ratio (a cornering run keeps kappa = 0, not measured).

use super::RunTable;

/// Minimum span (2nd to 98th percentile) of SR while rolling for a slip-ratio sweep to exist.
pub(crate) const SWEEP_SPAN: f64 = 0.1;
/// Road speed above which slip is defined, km/h.
const ROLLING_MIN_KPH: f64 = 5.0;
/// Load above which a zero crossing of FX counts, N.
const LOADED_MIN_N: f64 = 100.0;
/// Free rolling: |slip angle| below this, rad (1 deg).
const FREE_ALPHA_RAD: f64 = 0.017_453_292_519_943_295;
/// Fewest zero crossings for the radius line (else the median radius of the crossings).
const MIN_CROSSINGS_LINE: usize = 20;
/// Fewest zero crossings at all.
const MIN_CROSSINGS: usize = 3;

/// The derived kappa and a one-line account of how, or `None` when it cannot or need not be
/// derived.
pub(crate) fn derive_kappa(t: &RunTable) -> Option<(Vec<f64>, String)> {
    let n = t.len();
    let rolling = |i: usize| t.speed_kph[i] > ROLLING_MIN_KPH;
    let sr = t.sr.as_ref()?;
    let mut span: Vec<f64> = (0..n)
        .filter(|&i| rolling(i) && sr[i].is_finite())
        .map(|i| sr[i])
        .collect();
    if span.len() < 10 {
        return None;
    }
    span.sort_by(f64::total_cmp);
    let (lo, hi) = (
        span[span.len() / 50],
        span[span.len() - 1 - span.len() / 50],
    );
    if hi - lo < SWEEP_SPAN {
        return None;
    }
    // V / Omega per sample, m.
    let (q, source): (Vec<f64>, &str) = match (&t.wheel_speed_rpm, &t.loaded_radius_m) {
        (Some(rpm), _) => (
            (0..n)
                .map(|i| (t.speed_kph[i] / 3.6) / (rpm[i] * std::f64::consts::TAU / 60.0))
                .collect(),
            "N and V",
        ),
        (None, Some(rl)) => ((0..n).map(|i| rl[i] / (1.0 + sr[i])).collect(), "SR and RL"),
        (None, None) => return None,
    };
    let crossings = zero_crossings(t, &q);
    if crossings.len() < MIN_CROSSINGS {
        return None;
    }
    let (a, b) = radius_line(&crossings);
    let kappa: Vec<f64> = (0..n)
        .map(|i| {
            let k = (a + b * t.tire.fz_n[i]) / q[i] - 1.0;
            if rolling(i) && k.is_finite() { k } else { 0.0 }
        })
        .collect();
    let note = format!(
        "no SL recorded: kappa derived from {source} with the effective rolling radius where FX crosses zero in free rolling (Re = {a:.4} m {} {:.3e} m/N Fz, {} crossings), kappa_measured = false",
        if b < 0.0 { "-" } else { "+" },
        b.abs(),
        crossings.len()
    );
    Some((kappa, note))
}

/// `(Fz, V / Omega)` at every sign change of FX between two rolling, loaded, free-rolling
/// samples, interpolated to FX = 0.
fn zero_crossings(t: &RunTable, q: &[f64]) -> Vec<(f64, f64)> {
    let fx = &t.tire.fx_n;
    let ok = |i: usize| {
        t.speed_kph[i] > ROLLING_MIN_KPH
            && t.tire.fz_n[i] > LOADED_MIN_N
            && t.tire.alpha_rad[i].abs() < FREE_ALPHA_RAD
            && q[i].is_finite()
            && q[i] > 0.0
    };
    let mut out = Vec::new();
    for i in 1..t.len() {
        if !(ok(i - 1) && ok(i)) || fx[i - 1] * fx[i] >= 0.0 {
            continue;
        }
        let f = fx[i - 1] / (fx[i - 1] - fx[i]);
        let lerp = |x: &[f64]| x[i - 1] + f * (x[i] - x[i - 1]);
        out.push((lerp(&t.tire.fz_n), lerp(q)));
    }
    out
}

/// Least-squares line `Re = a + b Fz` through the crossings, refitted once without the points
/// more than 3 robust deviations away; a constant (the median) with fewer than
/// [`MIN_CROSSINGS_LINE`] crossings.
fn radius_line(points: &[(f64, f64)]) -> (f64, f64) {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let constant = median(points.iter().map(|p| p.1).collect());
    if points.len() < MIN_CROSSINGS_LINE {
        return (constant, 0.0);
    }
    let fit = |pts: &[(f64, f64)]| {
        let n = pts.len() as f64;
        let (mx, my) = pts
            .iter()
            .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
        let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |(a, b), p| {
            (a + (p.0 - mx) * (p.1 - my), b + (p.0 - mx) * (p.0 - mx))
        });
        if sxx <= 0.0 {
            return (my, 0.0);
        }
        let b = sxy / sxx;
        (my - b * mx, b)
    };
    let (a, b) = fit(points);
    let residuals: Vec<f64> = points.iter().map(|p| (p.1 - a - b * p.0).abs()).collect();
    let mad = 1.4826 * median(residuals.clone());
    if mad <= 0.0 {
        return (a, b);
    }
    let kept: Vec<(f64, f64)> = points
        .iter()
        .zip(&residuals)
        .filter(|(_, r)| **r <= 3.0 * mad)
        .map(|(p, _)| *p)
        .collect();
    if kept.len() < MIN_CROSSINGS_LINE {
        return (a, b);
    }
    fit(&kept)
}
