//! The measured points the MF 6.1 fit runs on: every sweep of every tested pressure, collapsed
//! onto a slip grid.
//!
//! In: [`Mf61Sweep`]s (samples in ISO-W SI with the measured inflation pressure). Out:
//! [`Point`]s: per sweep and slip bin the median of each travel direction's samples, then the
//! mean of the two directions (the lag hysteresis of a sweep run up and down cancels to first
//! order, a spike cannot move a median), with the bin's mean load, inclination, speed and
//! pressure; each point's weight (every sweep counts the same whatever its length, relative
//! to its own peak) and its sweep's high-frequency scatter per channel (the noise level the
//! `Mz` family weighs sweeps by).
//!
//! Deliberately not here: de-lagging with relaxation lengths (the PAC2002 stage does it; the
//! up/down average is enough for a model spanning pressures), QC (the caller passes clean
//! sweeps).

use crate::fit::noise_weights::high_frequency_scatter;
use crate::fit::output::Output;
use crate::fit::pac2002::{Sweep, SweepKind};
use crate::fit::segment_data::MeasuredSegment;
use crate::tire_model::SlipInput;

/// One measured sample, ISO-W, SI. Channels not recorded are NaN.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Mf61Sample {
    /// Vertical load, N.
    pub fz_n: f64,
    /// Longitudinal slip.
    pub kappa: f64,
    /// Slip angle, rad.
    pub alpha_rad: f64,
    /// Inclination, rad.
    pub gamma_rad: f64,
    /// Road speed, m/s.
    pub vx_mps: f64,
    /// Measured inflation pressure, Pa.
    pub p_pa: f64,
    /// Longitudinal force, N.
    pub fx_n: f64,
    /// Lateral force, N.
    pub fy_n: f64,
    /// Aligning moment, N m.
    pub mz_nm: f64,
    /// Overturning moment, N m.
    pub mx_nm: f64,
}

/// One sweep of one tested pressure.
#[derive(Clone, Debug, PartialEq)]
pub struct Mf61Sweep {
    /// Identifier (segment id).
    pub id: String,
    /// What is swept.
    pub kind: SweepKind,
    /// Samples in time order.
    pub samples: Vec<Mf61Sample>,
}

impl Mf61Sweep {
    /// The sweep of a segment the PAC2002 stage takes ([`Sweep::from_segment`]: cornering,
    /// drive/brake and combined segments with a nominal load and inclination), each sample with
    /// its measured inflation pressure. `mx_nm`: the overturning moment per sample (NaN when
    /// absent).
    pub fn from_segment(seg: &MeasuredSegment, mx_nm: Option<&[f64]>) -> Option<Mf61Sweep> {
        let sweep = Sweep::from_segment(seg, mx_nm, true)?;
        Some(Mf61Sweep {
            id: sweep.id,
            kind: sweep.kind,
            samples: sweep
                .samples
                .iter()
                .zip(&seg.channels.pressure_kpa)
                .map(|(s, p_kpa)| Mf61Sample {
                    fz_n: s.fz_n,
                    kappa: s.kappa,
                    alpha_rad: s.alpha_rad,
                    gamma_rad: s.gamma_rad,
                    vx_mps: s.vx_mps,
                    p_pa: p_kpa * 1e3,
                    fx_n: s.fx_n,
                    fy_n: s.fy_n,
                    mz_nm: s.mz_nm,
                    mx_nm: s.mx_nm,
                })
                .collect(),
        })
    }
}

/// One collapsed point.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Point {
    /// Operating point (bin means; the swept slip is the bin's median slip).
    pub input: SlipInput,
    /// Mean measured inflation pressure, Pa.
    pub p_pa: f64,
    /// Index of the tested pressure group the point belongs to.
    pub group: usize,
    /// Index of its sweep among all sweeps.
    pub sweep: usize,
    /// What the sweep sweeps.
    pub kind: SweepKind,
    /// `Fx, Fy, Mz, Mx` (NaN when not measured).
    pub values: [f64; 4],
    /// Per output: `1 / (sweep peak * sqrt(points of the sweep))`, so every sweep weighs the
    /// same relative to its own peak.
    pub weights: [f64; 4],
    /// Per output: the sweep's high-frequency scatter in its samples
    /// ([`high_frequency_scatter`], NaN when too few samples carry the channel).
    pub scatter: [f64; 4],
}

impl Point {
    /// The measured value of `output`.
    pub fn value(&self, output: Output) -> f64 {
        self.values[output as usize]
    }
}

/// Collapse knobs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CollapseConfig {
    /// Slip-angle bin width, rad.
    pub alpha_bin_rad: f64,
    /// Longitudinal-slip bin width.
    pub kappa_bin: f64,
    /// At most this many points per sweep (evenly spaced along it).
    pub max_points_per_sweep: usize,
}

impl Default for CollapseConfig {
    fn default() -> Self {
        CollapseConfig {
            alpha_bin_rad: 0.25_f64.to_radians(),
            kappa_bin: 0.0025,
            max_points_per_sweep: 40,
        }
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn mean(v: &[f64]) -> f64 {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if finite.is_empty() {
        f64::NAN
    } else {
        finite.iter().sum::<f64>() / finite.len() as f64
    }
}

/// Collapse one sweep into points (unweighted: weights are set by [`collapse`]).
fn collapse_sweep(
    sweep: &Mf61Sweep,
    group: usize,
    index: usize,
    cfg: &CollapseConfig,
) -> Vec<Point> {
    let along_kappa = sweep.kind != SweepKind::Cornering;
    let slip = |s: &Mf61Sample| if along_kappa { s.kappa } else { s.alpha_rad };
    let bin = if along_kappa {
        cfg.kappa_bin
    } else {
        cfg.alpha_bin_rad
    };
    let samples: Vec<&Mf61Sample> = sweep
        .samples
        .iter()
        .filter(|s| {
            [s.fz_n, s.kappa, s.alpha_rad, s.gamma_rad, s.vx_mps, s.p_pa]
                .iter()
                .all(|v| v.is_finite())
                && s.fz_n > 0.0
        })
        .collect();
    if samples.len() < 3 {
        return Vec::new();
    }
    // Travel direction of each sample from its neighbours.
    let n = samples.len();
    let up: Vec<bool> = (0..n)
        .map(|i| {
            let a = slip(samples[i.saturating_sub(1)]);
            let b = slip(samples[(i + 1).min(n - 1)]);
            b >= a
        })
        .collect();
    let mut bins: std::collections::BTreeMap<i64, [Vec<usize>; 2]> = Default::default();
    for (i, s) in samples.iter().enumerate() {
        let k = (slip(s) / bin).round() as i64;
        bins.entry(k).or_default()[usize::from(up[i])].push(i);
    }
    let scatter = [
        |s: &Mf61Sample| s.fx_n,
        |s: &Mf61Sample| s.fy_n,
        |s: &Mf61Sample| s.mz_nm,
        |s: &Mf61Sample| s.mx_nm,
    ]
    .map(|f| {
        let values: Vec<f64> = samples.iter().map(|s| f(s)).collect();
        high_frequency_scatter(&values).unwrap_or(f64::NAN)
    });
    let mut points = Vec::new();
    for branches in bins.values() {
        let used: Vec<&Vec<usize>> = branches.iter().filter(|b| !b.is_empty()).collect();
        if used.is_empty() {
            continue;
        }
        let branch_median = |f: &dyn Fn(&Mf61Sample) -> f64| {
            let meds: Vec<f64> = used
                .iter()
                .map(|b| {
                    let mut v: Vec<f64> = b
                        .iter()
                        .map(|&i| f(samples[i]))
                        .filter(|x| x.is_finite())
                        .collect();
                    median(&mut v)
                })
                .collect();
            mean(&meds)
        };
        let all: Vec<usize> = used.iter().flat_map(|b| b.iter().copied()).collect();
        let avg = |f: &dyn Fn(&Mf61Sample) -> f64| {
            mean(&all.iter().map(|&i| f(samples[i])).collect::<Vec<_>>())
        };
        let input = SlipInput {
            fz_n: avg(&|s| s.fz_n),
            kappa: if along_kappa {
                branch_median(&|s| s.kappa)
            } else {
                avg(&|s| s.kappa)
            },
            alpha_rad: if along_kappa {
                avg(&|s| s.alpha_rad)
            } else {
                branch_median(&|s| s.alpha_rad)
            },
            gamma_rad: avg(&|s| s.gamma_rad),
            vx_mps: avg(&|s| s.vx_mps),
        };
        points.push(Point {
            input,
            p_pa: avg(&|s| s.p_pa),
            group,
            sweep: index,
            kind: sweep.kind,
            values: [
                branch_median(&|s| s.fx_n),
                branch_median(&|s| s.fy_n),
                branch_median(&|s| s.mz_nm),
                branch_median(&|s| s.mx_nm),
            ],
            weights: [0.0; 4],
            scatter,
        });
    }
    // Thin evenly along the sweep.
    let cap = cfg.max_points_per_sweep.max(2);
    if points.len() > cap {
        let step = points.len() as f64 / cap as f64;
        points = (0..cap)
            .map(|i| points[((i as f64 + 0.5) * step) as usize])
            .collect();
    }
    points
}

/// Collapse every sweep of every pressure group (`groups[g]` holds group `g`'s sweeps) and set
/// the weights. Sweeps are numbered in input order.
pub fn collapse(groups: &[&[Mf61Sweep]], cfg: &CollapseConfig) -> Vec<Point> {
    let mut out = Vec::new();
    let mut index = 0;
    for (g, sweeps) in groups.iter().enumerate() {
        for sweep in sweeps.iter() {
            let mut pts = collapse_sweep(sweep, g, index, cfg);
            index += 1;
            for o in Output::ALL {
                let k = o as usize;
                let finite: Vec<f64> = pts
                    .iter()
                    .map(|p| p.values[k])
                    .filter(|v| v.is_finite())
                    .collect();
                let peak = finite.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                let w = if finite.is_empty() || peak <= 0.0 {
                    0.0
                } else {
                    1.0 / (peak * (finite.len() as f64).sqrt())
                };
                for p in &mut pts {
                    p.weights[k] = if p.values[k].is_finite() { w } else { 0.0 };
                }
            }
            out.extend(pts);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(alpha: f64, fy: f64) -> Mf61Sample {
        Mf61Sample {
            fz_n: 1000.0,
            kappa: 0.0,
            alpha_rad: alpha,
            gamma_rad: 0.0,
            vx_mps: 11.0,
            p_pa: 83e3,
            fx_n: f64::NAN,
            fy_n: fy,
            mz_nm: 0.0,
            mx_nm: f64::NAN,
        }
    }

    /// Up and down branches with a lag (+-50 N) collapse onto the lag-free curve; a spike moves
    /// its bin's median by at most one rank (half a sample step of the ramp, 5 N here, instead of
    /// pulling it towards 1e5 N); an unmeasured channel stays NaN with weight 0.
    #[test]
    fn up_down_average_cancels_lag_and_spikes() {
        let mut samples = Vec::new();
        for i in -160..=160 {
            let a = i as f64 * 0.0005;
            samples.push(sample(a, -20000.0 * a - 50.0));
        }
        for i in (-160..=160).rev() {
            let a = i as f64 * 0.0005;
            samples.push(sample(a, -20000.0 * a + 50.0));
        }
        samples[40].fy_n = 1e5;
        let sweep = Mf61Sweep {
            id: "s".into(),
            kind: SweepKind::Cornering,
            samples,
        };
        let cfg = CollapseConfig {
            max_points_per_sweep: 1000,
            ..Default::default()
        };
        let pts = collapse(&[std::slice::from_ref(&sweep)], &cfg);
        assert!(pts.len() > 30);
        for p in &pts {
            let fy = p.value(Output::Fy);
            let spiked_bin = (p.input.alpha_rad + 0.06).abs() < cfg.alpha_bin_rad;
            let tol = if spiked_bin { 5.0 + 1e-6 } else { 1e-6 };
            assert!((fy + 20000.0 * p.input.alpha_rad).abs() < tol, "{p:?}");
            assert!(p.value(Output::Fx).is_nan() && p.weights[Output::Fx as usize] == 0.0);
            assert!(p.weights[Output::Fy as usize] > 0.0);
        }
    }
}
