//! Starting values of every family, the robust way the thesis fitted by hand (seed section 8.2,
//! appendix D.2): per sweep a single curve, then the load and camber laws of its factors.
//!
//! In: the collapsed sweeps of a family, the coefficients fitted so far (earlier families), the
//! nominal load and unloaded radius, and which coefficients are free. Out: starting values
//! written into the coefficient vector (free coefficients only; held ones keep their value).
//!
//! - Pure forces (`Fy0`, `Fx0`): per sweep a Magic Formula curve with separate curvature on each
//!   side of its centre ([`MfCurve`]: `K C D E+ E- SH SV`, `B = K/(C D)`), started from the
//!   thesis's estimates (peak from the extremes, `SV` from their mean, `K` and `SH` from a line
//!   through the points near zero force); then `mu = D/Fz`, `K`, `SH`, `SV/Fz`, `E` are fitted
//!   against load and camber by linear least squares (`PKY2` and `PKX3` by a 1-D scan).
//! - Pure aligning moment: per sweep the residual torque peak `Dr` is `Mz` where `Fy0` crosses
//!   zero, the trail `t = (Dr - Mz)/Fy0` where `|Fy0|` is large, and a trail curve
//!   ([`TrailCurve`]: `Dt Bt Ct Et SHt`) is fitted to it; then their load and camber laws; `QBZ9`
//!   by a scan.
//! - Combined forces: `Gxa = Fx/Fx0` and the even part of `Fy(kappa)` over `Fy0` give the weighting
//!   slope (`1/B^2` is linear in slip squared); the odd part of `Fy(kappa)` gives `SVyk` by a scan
//!   of its shape and a linear fit of its amplitude.
//! - `Mx`: linear least squares of the core form.
//!
//! Deliberately not here: the joint refinement (these values only need to be in the right basin).

use crate::fit::output::Output;
use crate::numerics::nonlinear_least_squares::Bounds;
use crate::numerics::stats::finite_median;
use crate::tire_model::pac2002::{load, pure_fy0};
use crate::tire_model::{Coef, Coef::*, Coefs, Real, SlipInput};

use super::collapse::CollapsedSweep;
use super::family::Family;
use super::linear::{CurveModel, fit_curve, lstsq};
use super::problem::{FIT_MODE, channel_value};

/// Why a family has no starting values: no sweep gave the per-sweep curve its load and camber
/// laws are read from.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("no {sweeps} sweep gave a {curve} curve")]
pub struct NoSweepCurve {
    /// The sweeps tried (`cornering`, `drive/brake`).
    pub sweeps: &'static str,
    /// The curve looked for (`Magic Formula`, `pneumatic-trail`).
    pub curve: &'static str,
}

/// What the starting-value functions need besides the sweeps.
pub struct Setup<'a> {
    /// Free coefficients of the family (others keep their value).
    pub free: &'a [Coef],
    /// Nominal load `FNOMIN`, N.
    pub fz0: f64,
    /// Unloaded radius, m.
    pub r0: f64,
}

impl Setup<'_> {
    fn is_free(&self, c: Coef) -> bool {
        self.free.contains(&c)
    }

    /// Sets `c[coef] = v` if the coefficient is free and `v` finite.
    fn set(&self, coefs: &mut Coefs<f64>, coef: Coef, v: f64) {
        if self.is_free(coef) && v.is_finite() {
            coefs[coef] = v;
        }
    }

    fn dfz(&self, fz: f64) -> f64 {
        (fz - self.fz0) / self.fz0
    }
}

/// Linear least squares over the columns whose coefficient is free (`None` = always used);
/// returns one value per column, 0 for dropped columns.
fn linear_fit(
    setup: &Setup<'_>,
    cols: &[Option<Coef>],
    rows: &[Vec<f64>],
    y: &[f64],
) -> Option<Vec<f64>> {
    let active: Vec<usize> = (0..cols.len())
        .filter(|&j| cols[j].is_none_or(|c| setup.is_free(c)))
        .collect();
    let design: Vec<f64> = rows
        .iter()
        .flat_map(|r| active.iter().map(move |&j| r[j]))
        .collect();
    let b = lstsq(&design, active.len(), y)?;
    let mut out = vec![0.0; cols.len()];
    for (k, &j) in active.iter().enumerate() {
        out[j] = b[k];
    }
    Some(out)
}

/// The median of the finite values, NaN without any.
fn median(v: Vec<f64>) -> f64 {
    finite_median(v).unwrap_or(f64::NAN)
}

/// A single Magic Formula curve with side-dependent curvature:
/// `p = [K, C, D, E+, E-, SH, SV]`, `y = D sin(C atan(B x' - E (B x' - atan(B x')))) + SV`,
/// `x' = x + SH`, `B = K/(C D)`, `E = E+` for `x' >= 0`, else `E-`.
pub struct MfCurve;

impl CurveModel for MfCurve {
    fn n_params(&self) -> usize {
        7
    }
    fn eval<T: Real>(&self, p: &[T], x: f64) -> T {
        let xs = p[5] + x;
        let b = p[0] / (p[1] * p[2]);
        let e = if xs.value() >= 0.0 { p[3] } else { p[4] };
        let bx = b * xs;
        p[2] * (p[1] * (bx - e * (bx - bx.atan())).atan()).sin() + p[6]
    }
}

/// Factors of one sweep's Magic Formula curve.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MfShape {
    /// Slope at the centre `K = B C D`.
    pub k: f64,
    /// Shape factor.
    pub c: f64,
    /// Peak factor (sign of `K`).
    pub d: f64,
    /// Curvature on the positive side.
    pub e_pos: f64,
    /// Curvature on the negative side.
    pub e_neg: f64,
    /// Horizontal shift.
    pub sh: f64,
    /// Vertical shift.
    pub sv: f64,
}

/// Extracts `K C D E+ E- SH SV` from one curve (`x` sorted). `None` if the curve is too short
/// or flat.
pub fn extract_mf(x: &[f64], y: &[f64]) -> Option<MfShape> {
    if x.len() < 8 {
        return None;
    }
    let ymax = y.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let ymin = y.iter().copied().fold(f64::INFINITY, f64::min);
    let sv0 = 0.5 * (ymax + ymin);
    let d0 = 0.5 * (ymax - ymin);
    if d0 <= 0.0 || !d0.is_finite() {
        return None;
    }
    let mut near: Vec<usize> = (0..x.len())
        .filter(|&i| (y[i] - sv0).abs() < 0.35 * d0)
        .collect();
    if near.len() < 3 {
        let mut order: Vec<usize> = (0..x.len()).collect();
        order.sort_by(|&a, &b| (y[a] - sv0).abs().total_cmp(&(y[b] - sv0).abs()));
        near = order.into_iter().take(5).collect();
        near.sort_unstable();
    }
    let design: Vec<f64> = near.iter().flat_map(|&i| [1.0, x[i]]).collect();
    let yn: Vec<f64> = near.iter().map(|&i| y[i]).collect();
    let line = lstsq(&design, 2, &yn)?;
    let k0 = line[1];
    if k0 == 0.0 || !k0.is_finite() {
        return None;
    }
    let s = k0.signum();
    let span = x[x.len() - 1] - x[0];
    let sh0 = ((line[0] - sv0) / k0).clamp(-0.2 * span, 0.2 * span);
    let (dlo, dhi) = if s > 0.0 {
        (0.3 * d0, 4.0 * d0)
    } else {
        (-4.0 * d0, -0.3 * d0)
    };
    let (klo, khi) = if s > 0.0 {
        (k0 / 30.0, k0 * 30.0)
    } else {
        (k0 * 30.0, k0 / 30.0)
    };
    let bounds = Bounds {
        lower: vec![klo, 0.5, dlo, -30.0, -30.0, -0.25 * span, -d0],
        upper: vec![khi, 2.5, dhi, 1.0, 1.0, 0.25 * span, d0],
    };
    let mut best: Option<(f64, Vec<f64>)> = None;
    for c0 in [1.3, 1.8] {
        let start = [k0, c0, s * d0, 0.0, 0.0, sh0, sv0];
        let out = fit_curve(&MfCurve, x, y, &start, &bounds);
        if best.as_ref().is_none_or(|(cost, _)| out.cost < *cost) {
            best = Some((out.cost, out.params));
        }
    }
    let (_, p) = best?;
    Some(MfShape {
        k: p[0],
        c: p[1],
        d: p[2],
        e_pos: p[3],
        e_neg: p[4],
        sh: p[5],
        sv: p[6],
    })
}

/// Per-sweep shapes of a pure-force family, with the sweep's mean load and inclination.
fn sweep_shapes(sweeps: &[&CollapsedSweep], output: Output) -> Vec<(MfShape, f64, f64)> {
    let mut out = Vec::new();
    for s in sweeps {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.output(output).is_finite())
            .map(|p| (s.swept(p), p.output(output)))
            .collect();
        let x: Vec<f64> = pts.iter().map(|p| p.0).collect();
        let y: Vec<f64> = pts.iter().map(|p| p.1).collect();
        if let Some(shape) = extract_mf(&x, &y) {
            out.push((shape, s.mean_fz(), s.mean_gamma()));
        }
    }
    out
}

/// Starting values of `Fy0` (`PCY1 ... PVY4`). Err if no sweep gives a curve.
pub fn pure_lateral(
    sweeps: &[&CollapsedSweep],
    setup: &Setup<'_>,
    c: &mut Coefs<f64>,
) -> Result<(), NoSweepCurve> {
    let shapes = sweep_shapes(sweeps, Output::Fy);
    if shapes.is_empty() {
        return Err(NoSweepCurve {
            sweeps: "cornering",
            curve: "Magic Formula",
        });
    }
    let dfz: Vec<f64> = shapes.iter().map(|s| setup.dfz(s.1)).collect();
    let gam: Vec<f64> = shapes.iter().map(|s| s.2).collect();
    let n = shapes.len();
    // Friction: mu = (PDY1 + PDY2 dfz)(1 - PDY3 g^2) ~ a + b dfz + c g^2.
    let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i], gam[i].powi(2)]).collect();
    let mu: Vec<f64> = shapes.iter().map(|s| s.0.d / s.1).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PDY2), Some(PDY3)], &rows, &mu) {
        setup.set(c, PDY1, b[0]);
        setup.set(c, PDY2, b[1]);
        setup.set(c, PDY3, -b[2] / b[0]);
    }
    // Cornering stiffness: scan PKY2, linear in (PKY1, -PKY1 PKY3).
    let k: Vec<f64> = shapes.iter().map(|s| s.0.k).collect();
    let scan: Vec<f64> = if setup.is_free(PKY2) {
        (0..60)
            .map(|i| 0.3 * (60.0f64).powf(i as f64 / 59.0))
            .collect()
    } else {
        vec![c[PKY2]]
    };
    let mut best: Option<(f64, f64, Vec<f64>)> = None;
    for pky2 in scan {
        let f: Vec<f64> = shapes
            .iter()
            .map(|s| setup.fz0 * (s.1 / (pky2 * setup.fz0)).sin_2atan())
            .collect();
        let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![f[i], f[i] * gam[i].abs()]).collect();
        let Some(b) = linear_fit(setup, &[None, Some(PKY3)], &rows, &k) else {
            continue;
        };
        let ssr: f64 = (0..n)
            .map(|i| (b[0] * rows[i][0] + b[1] * rows[i][1] - k[i]).powi(2))
            .sum();
        if best.as_ref().is_none_or(|(s, _, _)| ssr < *s) {
            best = Some((ssr, pky2, b));
        }
    }
    if let Some((_, pky2, b)) = best {
        setup.set(c, PKY2, pky2);
        setup.set(c, PKY1, b[0]);
        setup.set(c, PKY3, -b[1] / b[0]);
    }
    let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i], gam[i]]).collect();
    let sh: Vec<f64> = shapes.iter().map(|s| s.0.sh).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PHY2), Some(PHY3)], &rows, &sh) {
        setup.set(c, PHY1, b[0]);
        setup.set(c, PHY2, b[1]);
        setup.set(c, PHY3, b[2]);
    }
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| vec![1.0, dfz[i], gam[i], dfz[i] * gam[i]])
        .collect();
    let sv: Vec<f64> = shapes.iter().map(|s| s.0.sv / s.1).collect();
    let cols = [None, Some(PVY2), Some(PVY3), Some(PVY4)];
    if let Some(b) = linear_fit(setup, &cols, &rows, &sv) {
        for (coef, v) in [PVY1, PVY2, PVY3, PVY4].into_iter().zip(b) {
            setup.set(c, coef, v);
        }
    }
    setup.set(c, PCY1, median(shapes.iter().map(|s| s.0.c).collect()));
    let (e_mean, e_split) = curvature_split(&shapes);
    let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i]]).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PEY2)], &rows, &e_mean) {
        setup.set(c, PEY1, b[0].min(0.9));
        setup.set(c, PEY2, b[1]);
    }
    let keep: Vec<usize> = (0..n).filter(|&i| e_split[i].is_finite()).collect();
    if !keep.is_empty() {
        let rows: Vec<Vec<f64>> = keep.iter().map(|&i| vec![1.0, gam[i]]).collect();
        let y: Vec<f64> = keep.iter().map(|&i| e_split[i]).collect();
        if let Some(b) = linear_fit(setup, &[None, Some(PEY4)], &rows, &y) {
            setup.set(c, PEY3, b[0]);
            setup.set(c, PEY4, b[1]);
        }
    }
    Ok(())
}

/// Mean curvature and relative split `(E- - E+)/(E- + E+)` (NaN when the mean is near 0).
fn curvature_split(shapes: &[(MfShape, f64, f64)]) -> (Vec<f64>, Vec<f64>) {
    shapes
        .iter()
        .map(|s| {
            let mean = 0.5 * (s.0.e_pos + s.0.e_neg);
            let split = if mean.abs() > 0.05 {
                (s.0.e_neg - s.0.e_pos) / (s.0.e_neg + s.0.e_pos)
            } else {
                f64::NAN
            };
            (mean, split)
        })
        .unzip()
}

/// Starting values of `Fx0` (`PCX1 ... PVX2`).
pub fn pure_longitudinal(
    sweeps: &[&CollapsedSweep],
    setup: &Setup<'_>,
    c: &mut Coefs<f64>,
) -> Result<(), NoSweepCurve> {
    let shapes = sweep_shapes(sweeps, Output::Fx);
    if shapes.is_empty() {
        return Err(NoSweepCurve {
            sweeps: "drive/brake",
            curve: "Magic Formula",
        });
    }
    let n = shapes.len();
    let dfz: Vec<f64> = shapes.iter().map(|s| setup.dfz(s.1)).collect();
    let gam: Vec<f64> = shapes.iter().map(|s| s.2).collect();
    let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i], gam[i].powi(2)]).collect();
    let mu: Vec<f64> = shapes.iter().map(|s| s.0.d / s.1).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PDX2), Some(PDX3)], &rows, &mu) {
        setup.set(c, PDX1, b[0]);
        setup.set(c, PDX2, b[1]);
        setup.set(c, PDX3, -b[2] / b[0]);
    }
    // Kx/Fz = (PKX1 + PKX2 dfz) exp(PKX3 dfz): scan PKX3, linear in PKX1, PKX2.
    let kfz: Vec<f64> = shapes.iter().map(|s| s.0.k / s.1).collect();
    let scan: Vec<f64> = if setup.is_free(PKX3) {
        (0..81).map(|i| -2.0 + 0.05 * i as f64).collect()
    } else {
        vec![c[PKX3]]
    };
    let mut best: Option<(f64, f64, Vec<f64>)> = None;
    for pkx3 in scan {
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let e = (pkx3 * dfz[i]).exp();
                vec![e, dfz[i] * e]
            })
            .collect();
        let Some(b) = linear_fit(setup, &[None, Some(PKX2)], &rows, &kfz) else {
            continue;
        };
        let ssr: f64 = (0..n)
            .map(|i| (b[0] * rows[i][0] + b[1] * rows[i][1] - kfz[i]).powi(2))
            .sum();
        if best.as_ref().is_none_or(|(s, _, _)| ssr < *s) {
            best = Some((ssr, pkx3, b));
        }
    }
    if let Some((_, pkx3, b)) = best {
        setup.set(c, PKX3, pkx3);
        setup.set(c, PKX1, b[0]);
        setup.set(c, PKX2, b[1]);
    }
    let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i]]).collect();
    let sh: Vec<f64> = shapes.iter().map(|s| s.0.sh).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PHX2)], &rows, &sh) {
        setup.set(c, PHX1, b[0]);
        setup.set(c, PHX2, b[1]);
    }
    let sv: Vec<f64> = shapes.iter().map(|s| s.0.sv / s.1).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PVX2)], &rows, &sv) {
        setup.set(c, PVX1, b[0]);
        setup.set(c, PVX2, b[1]);
    }
    setup.set(c, PCX1, median(shapes.iter().map(|s| s.0.c).collect()));
    let (e_mean, e_split) = curvature_split(&shapes);
    let rows: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i], dfz[i] * dfz[i]]).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(PEX2), Some(PEX3)], &rows, &e_mean) {
        setup.set(c, PEX1, b[0].min(0.9));
        setup.set(c, PEX2, b[1]);
        setup.set(c, PEX3, b[2]);
    }
    setup.set(c, PEX4, median(e_split));
    Ok(())
}

/// A pneumatic-trail curve: `p = [Dt, Bt, Ct, Et, SHt]`,
/// `t = Dt cos(Ct atan(Bt a - Et (Bt a - atan(Bt a))))`, `a = x + SHt`.
pub struct TrailCurve;

impl CurveModel for TrailCurve {
    fn n_params(&self) -> usize {
        5
    }
    fn eval<T: Real>(&self, p: &[T], x: f64) -> T {
        let bx = p[1] * (p[4] + x);
        p[0] * (p[2] * (bx - p[3] * (bx - bx.atan())).atan()).cos()
    }
}

/// Starting values of `Mz0` (`QBZ*`, `QCZ1`, `QDZ*`, `QEZ*`, `QHZ*`); needs the `Fy0` family.
pub fn pure_aligning(
    sweeps: &[&CollapsedSweep],
    setup: &Setup<'_>,
    c: &mut Coefs<f64>,
) -> Result<(), NoSweepCurve> {
    struct Row {
        dt: f64,
        bt: f64,
        ct: f64,
        et: f64,
        sht: f64,
        dr: f64,
        fz: f64,
        gamma: f64,
    }
    let mut rows_out = Vec::new();
    for s in sweeps {
        let pts: Vec<(f64, f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.output(Output::Mz).is_finite())
            .map(|p| {
                let fy0 = channel_value(c, &p.input, Family::Fy0);
                (p.input.alpha_rad, p.output(Output::Mz), fy0)
            })
            .collect();
        if pts.len() < 8 {
            continue;
        }
        // Residual torque peak: Mz where Fy0 crosses zero.
        let dr = pts
            .windows(2)
            .find(|w| w[0].2 == 0.0 || w[0].2.signum() != w[1].2.signum())
            .map(|w| {
                let f = if w[1].2 == w[0].2 {
                    0.0
                } else {
                    w[0].2 / (w[0].2 - w[1].2)
                };
                w[0].1 + f * (w[1].1 - w[0].1)
            })
            .unwrap_or(0.0);
        let fy_peak = pts.iter().map(|p| p.2.abs()).fold(0.0, f64::max);
        let valid: Vec<&(f64, f64, f64)> =
            pts.iter().filter(|p| p.2.abs() > 0.15 * fy_peak).collect();
        if valid.len() < 6 {
            continue;
        }
        let x: Vec<f64> = valid.iter().map(|p| p.0).collect();
        let t: Vec<f64> = valid.iter().map(|p| (dr - p.1) / p.2).collect();
        let i0 = (0..x.len())
            .min_by(|&a, &b| x[a].abs().total_cmp(&x[b].abs()))
            .unwrap_or(0);
        let dt0 = 1.2 * t[i0];
        if dt0 == 0.0 || !dt0.is_finite() {
            continue;
        }
        let (dlo, dhi) = if dt0 > 0.0 {
            (0.2 * dt0, 5.0 * dt0)
        } else {
            (5.0 * dt0, 0.2 * dt0)
        };
        let bounds = Bounds {
            lower: vec![dlo, 0.5, 0.5, -20.0, -0.05],
            upper: vec![dhi, 100.0, 2.5, 1.0, 0.05],
        };
        let out = fit_curve(&TrailCurve, &x, &t, &[dt0, 10.0, 1.2, -0.5, 0.0], &bounds);
        let p = out.params;
        rows_out.push(Row {
            dt: p[0],
            bt: p[1],
            ct: p[2],
            et: p[3],
            sht: p[4],
            dr,
            fz: s.mean_fz(),
            gamma: s.mean_gamma(),
        });
    }
    if rows_out.is_empty() {
        return Err(NoSweepCurve {
            sweeps: "cornering",
            curve: "pneumatic-trail",
        });
    }
    let n = rows_out.len();
    let dfz: Vec<f64> = rows_out.iter().map(|r| setup.dfz(r.fz)).collect();
    let gam: Vec<f64> = rows_out.iter().map(|r| r.gamma).collect();
    let design: Vec<Vec<f64>> = (0..n)
        .map(|i| vec![1.0, dfz[i], gam[i], gam[i] * gam[i]])
        .collect();
    let ydt: Vec<f64> = rows_out
        .iter()
        .map(|r| r.dt * setup.fz0 / (r.fz * setup.r0))
        .collect();
    let cols = [None, Some(QDZ2), Some(QDZ3), Some(QDZ4)];
    if let Some(b) = linear_fit(setup, &cols, &design, &ydt) {
        setup.set(c, QDZ1, b[0]);
        setup.set(c, QDZ2, b[1]);
        setup.set(c, QDZ3, b[2] / b[0]);
        setup.set(c, QDZ4, b[3] / b[0]);
    }
    let design: Vec<Vec<f64>> = (0..n)
        .map(|i| vec![1.0, dfz[i], dfz[i] * dfz[i], gam[i], gam[i].abs()])
        .collect();
    let ybt: Vec<f64> = rows_out.iter().map(|r| r.bt).collect();
    let cols = [None, Some(QBZ2), Some(QBZ3), Some(QBZ4), Some(QBZ5)];
    if let Some(b) = linear_fit(setup, &cols, &design, &ybt) {
        setup.set(c, QBZ1, b[0]);
        setup.set(c, QBZ2, b[1]);
        setup.set(c, QBZ3, b[2]);
        setup.set(c, QBZ4, b[3] / b[0]);
        setup.set(c, QBZ5, b[4] / b[0]);
    }
    setup.set(c, QCZ1, median(rows_out.iter().map(|r| r.ct).collect()));
    let design: Vec<Vec<f64>> = (0..n).map(|i| vec![1.0, dfz[i], dfz[i] * dfz[i]]).collect();
    let yet: Vec<f64> = rows_out.iter().map(|r| r.et).collect();
    if let Some(b) = linear_fit(setup, &[None, Some(QEZ2), Some(QEZ3)], &design, &yet) {
        setup.set(c, QEZ1, b[0].min(0.9));
        setup.set(c, QEZ2, b[1]);
        setup.set(c, QEZ3, b[2]);
    }
    setup.set(c, QEZ4, 0.0);
    setup.set(c, QEZ5, 0.0);
    let design: Vec<Vec<f64>> = (0..n)
        .map(|i| vec![1.0, dfz[i], gam[i], dfz[i] * gam[i]])
        .collect();
    let ysh: Vec<f64> = rows_out.iter().map(|r| r.sht).collect();
    let cols = [None, Some(QHZ2), Some(QHZ3), Some(QHZ4)];
    if let Some(b) = linear_fit(setup, &cols, &design, &ysh) {
        for (coef, v) in [QHZ1, QHZ2, QHZ3, QHZ4].into_iter().zip(b) {
            setup.set(c, coef, v);
        }
    }
    let ydr: Vec<f64> = rows_out.iter().map(|r| r.dr / (r.fz * setup.r0)).collect();
    let cols = [None, Some(QDZ7), Some(QDZ8), Some(QDZ9)];
    if let Some(b) = linear_fit(setup, &cols, &design, &ydr) {
        for (coef, v) in [QDZ6, QDZ7, QDZ8, QDZ9].into_iter().zip(b) {
            setup.set(c, coef, v);
        }
    }
    // Residual-torque slope: scan QBZ9 with QBZ10 = 0.
    setup.set(c, QBZ10, 0.0);
    if setup.is_free(QBZ9) {
        let mut best = (f64::INFINITY, 1.0);
        for qbz9 in [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0] {
            c[QBZ9] = qbz9;
            let cost = family_cost(sweeps, c, Family::Mz0, Output::Mz);
            if cost < best.0 {
                best = (cost, qbz9);
            }
        }
        c[QBZ9] = best.1;
    }
    Ok(())
}

/// Sum over sweeps of the mean squared error relative to the sweep's peak.
pub fn family_cost(
    sweeps: &[&CollapsedSweep],
    c: &Coefs<f64>,
    family: Family,
    output: Output,
) -> f64 {
    sweeps
        .iter()
        .map(|s| {
            let peak = s.peak(output).max(1e-9);
            let (sum, n) = s
                .points
                .iter()
                .filter(|p| p.output(output).is_finite())
                .fold((0.0, 0usize), |(acc, n), p| {
                    let e = (channel_value(c, &p.input, family) - p.output(output)) / peak;
                    (acc + e * e, n + 1)
                });
            if n == 0 { 0.0 } else { sum / n as f64 }
        })
        .sum()
}

/// Starting values of combined `Fx` (`RBX1 RBX2`; `RCX1 = 1`, others 0); needs `Fx0`.
pub fn combined_longitudinal(sweeps: &[&CollapsedSweep], setup: &Setup<'_>, c: &mut Coefs<f64>) {
    let mut design = Vec::new();
    let mut y = Vec::new();
    for s in sweeps {
        let peak = s
            .points
            .iter()
            .map(|p| channel_value(c, &p.input, Family::Fx0).abs())
            .fold(0.0, f64::max);
        for p in &s.points {
            let fx = p.output(Output::Fx);
            let fx0 = channel_value(c, &p.input, Family::Fx0);
            let alpha = p.input.alpha_rad.abs();
            if !fx.is_finite() || fx0.abs() < 0.2 * peak || alpha < 1e-3 {
                continue;
            }
            let g = fx / fx0;
            if !(0.05..0.98).contains(&g) {
                continue;
            }
            let bxa = g.acos().tan() / alpha;
            design.extend([1.0, p.input.kappa * p.input.kappa]);
            y.push(1.0 / (bxa * bxa));
        }
    }
    let cols = [None, Some(RBX2)];
    let rows: Vec<Vec<f64>> = design.chunks(2).map(|r| r.to_vec()).collect();
    let (mut rbx1, mut rbx2) = (10.0, 5.0);
    if let Some(b) = linear_fit(setup, &cols, &rows, &y)
        && b[0] > 0.0
    {
        rbx1 = 1.0 / b[0].sqrt();
        rbx2 = (b[1] / b[0]).max(0.0).sqrt();
    }
    setup.set(c, RBX1, rbx1);
    setup.set(c, RBX2, rbx2);
    setup.set(c, RCX1, 1.0);
    for coef in [REX1, REX2, RHX1] {
        setup.set(c, coef, 0.0);
    }
}

/// `f(kappa)` of a collapsed curve by linear interpolation (`None` outside its range).
fn interpolate(points: &[(f64, f64)], x: f64) -> Option<f64> {
    let k = points.partition_point(|p| p.0 < x);
    if k == 0 || k == points.len() {
        return None;
    }
    let (a, b) = (points[k - 1], points[k]);
    if b.0 == a.0 {
        return Some(a.1);
    }
    Some(a.1 + (x - a.0) / (b.0 - a.0) * (b.1 - a.1))
}

/// Starting values of combined `Fy` (`RBY*`, `RVY*`; `RCY1 = 1`, others 0); needs `Fy0`.
/// `sweeps` are the slip-ratio sweeps (drive/brake and combined).
pub fn combined_lateral(sweeps: &[&CollapsedSweep], setup: &Setup<'_>, c: &mut Coefs<f64>) {
    struct Odd {
        kappa: Vec<f64>,
        value: Vec<f64>,
        mu_fz: f64,
        dfz: f64,
        gamma: f64,
        alpha: f64,
    }
    let mut by_rows = Vec::new();
    let mut by_y = Vec::new();
    let mut odd = Vec::new();
    for s in sweeps {
        let curve: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.output(Output::Fy).is_finite())
            .map(|p| (p.input.kappa, p.output(Output::Fy)))
            .collect();
        let alpha = s.mean_alpha();
        let mean_input = SlipInput {
            fz_n: s.mean_fz(),
            kappa: 0.0,
            alpha_rad: alpha,
            gamma_rad: s.mean_gamma(),
            vx_mps: s.points.first().map_or(10.0, |p| p.input.vx_mps),
        };
        let l = load(c, &mean_input, FIT_MODE);
        let py = pure_fy0(c, &l);
        let mut o = Odd {
            kappa: Vec::new(),
            value: Vec::new(),
            mu_fz: py.muy * mean_input.fz_n,
            dfz: setup.dfz(mean_input.fz_n),
            gamma: mean_input.gamma_rad,
            alpha,
        };
        for &(kappa, fy) in curve.iter().filter(|p| p.0 > 0.0) {
            let Some(mirror) = interpolate(&curve, -kappa) else {
                continue;
            };
            o.kappa.push(kappa);
            o.value.push(0.5 * (fy - mirror));
            let even = 0.5 * (fy + mirror);
            if s.kind == super::SweepKind::Combined && py.fy0.abs() > 0.0 {
                let g = even / py.fy0;
                if (0.05..0.98).contains(&g) {
                    let byk = g.acos().tan() / kappa;
                    by_rows.push(vec![1.0, alpha * alpha]);
                    by_y.push(1.0 / (byk * byk));
                }
            }
        }
        if !o.kappa.is_empty() {
            odd.push(o);
        }
    }
    let (mut rby1, mut rby2) = (10.0, 5.0);
    if let Some(b) = linear_fit(setup, &[None, Some(RBY2)], &by_rows, &by_y)
        && b[0] > 0.0
    {
        rby1 = 1.0 / b[0].sqrt();
        rby2 = (b[1] / b[0]).max(0.0).sqrt();
    }
    setup.set(c, RBY1, rby1);
    setup.set(c, RBY2, rby2);
    setup.set(c, RCY1, 1.0);
    for coef in [RBY3, REY1, REY2, RHY1, RHY2] {
        setup.set(c, coef, 0.0);
    }
    // SVyk shape: scan (RVY5, RVY6), amplitude per sweep by least squares.
    let mut best: Option<(f64, f64, f64, Vec<f64>)> = None;
    for rvy5 in [0.5, 1.0, 1.5, 1.9, 2.3] {
        for rvy6 in [1.0, 2.5, 5.0, 10.0, 20.0, 40.0] {
            let mut ssr = 0.0;
            let mut amps = Vec::new();
            for o in &odd {
                let shape: Vec<f64> = o
                    .kappa
                    .iter()
                    .map(|k| (rvy5 * (rvy6 * k).atan()).sin())
                    .collect();
                let ss: f64 = shape.iter().map(|v| v * v).sum();
                let amp = if ss > 0.0 {
                    shape.iter().zip(&o.value).map(|(a, b)| a * b).sum::<f64>() / ss
                } else {
                    0.0
                };
                ssr += shape
                    .iter()
                    .zip(&o.value)
                    .map(|(a, b)| (amp * a - b).powi(2))
                    .sum::<f64>();
                amps.push(amp);
            }
            if best.as_ref().is_none_or(|(s, ..)| ssr < *s) {
                best = Some((ssr, rvy5, rvy6, amps));
            }
        }
    }
    let Some((_, rvy5, rvy6, amps)) = best else {
        return;
    };
    setup.set(c, RVY5, rvy5);
    setup.set(c, RVY6, rvy6);
    // Amplitude / (mu_y Fz) = (RVY1 + RVY2 dfz + RVY3 g) cos(atan(RVY4 alpha)): scan RVY4.
    let keep: Vec<usize> = (0..odd.len()).filter(|&i| odd[i].mu_fz != 0.0).collect();
    let y: Vec<f64> = keep.iter().map(|&i| amps[i] / odd[i].mu_fz).collect();
    let scan: Vec<f64> = if setup.is_free(RVY4) {
        vec![0.0, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
    } else {
        vec![c[RVY4]]
    };
    let mut best: Option<(f64, f64, Vec<f64>)> = None;
    for rvy4 in scan {
        let rows: Vec<Vec<f64>> = keep
            .iter()
            .map(|&i| {
                let w = (rvy4 * odd[i].alpha).cos_atan();
                vec![w, w * odd[i].dfz, w * odd[i].gamma]
            })
            .collect();
        let Some(b) = linear_fit(setup, &[None, Some(RVY2), Some(RVY3)], &rows, &y) else {
            continue;
        };
        let ssr: f64 = rows
            .iter()
            .zip(&y)
            .map(|(r, yi)| (r[0] * b[0] + r[1] * b[1] + r[2] * b[2] - yi).powi(2))
            .sum();
        if best.as_ref().is_none_or(|(s, ..)| ssr < *s) {
            best = Some((ssr, rvy4, b));
        }
    }
    if let Some((_, rvy4, b)) = best {
        setup.set(c, RVY4, rvy4);
        setup.set(c, RVY1, b[0]);
        setup.set(c, RVY2, b[1]);
        setup.set(c, RVY3, b[2]);
    }
}

/// Starting values of `Mx`, core form `QSX1..QSX3`, by linear least squares on
/// `Mx / (R0 Fz) = QSX1 - QSX2 g + QSX3 Fy/Fz0` with the model's `Fy`.
pub fn overturning(sweeps: &[&CollapsedSweep], setup: &Setup<'_>, c: &mut Coefs<f64>) {
    let mut rows = Vec::new();
    let mut y = Vec::new();
    for s in sweeps {
        for p in &s.points {
            let mx = p.output(Output::Mx);
            if !mx.is_finite() || p.input.fz_n <= 0.0 {
                continue;
            }
            let fy = channel_value(c, &p.input, Family::Fy);
            rows.push(vec![1.0, -p.input.gamma_rad, fy / setup.fz0]);
            y.push(mx / (setup.r0 * p.input.fz_n));
        }
    }
    if let Some(b) = linear_fit(setup, &[None, Some(QSX2), Some(QSX3)], &rows, &y) {
        setup.set(c, QSX1, b[0]);
        setup.set(c, QSX2, b[1]);
        setup.set(c, QSX3, b[2]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_curve_extraction_recovers_factors() {
        let truth = [-30000.0, 1.45, -2500.0, -0.3, 0.2, 0.003, 40.0];
        let x: Vec<f64> = (0..97)
            .map(|i| (-12.0 + 0.25 * i as f64).to_radians())
            .collect();
        let y: Vec<f64> = x.iter().map(|v| MfCurve.eval(&truth, *v)).collect();
        let s = extract_mf(&x, &y).unwrap();
        let got = [s.k, s.c, s.d, s.e_pos, s.e_neg, s.sh, s.sv];
        for (g, t) in got.iter().zip(truth) {
            assert!(
                (g - t).abs() <= 1e-4 * t.abs().max(1.0),
                "{got:?} vs {truth:?}"
            );
        }
    }
}
