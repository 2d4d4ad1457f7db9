//! From the raw samples of one sweep to its collapsed steady-state curve.
//!
//! In: a [`Sweep`] (samples in time order), the slip grid, the despike threshold and optionally
//! relaxation lengths. Out: a [`CollapsedSweep`]: the cleaned samples and one [`CurvePoint`] per
//! occupied grid cell of the swept slip (slip angle for cornering sweeps, longitudinal slip for
//! the others), inputs and outputs averaged.
//!
//! Steps:
//! 1. Drop samples with a non-finite input; sort by time.
//! 2. Despike every output channel: residual against a 7-sample running median; a sample more
//!    than `despike_sigmas` robust standard deviations (1.4826 MAD of the residuals) and more
//!    than 1 % of the channel's peak away is replaced by the median (the floor keeps the
//!    corners of noise-free sweeps, where a running median is not exact, from being touched).
//! 3. De-lag (optional): the tire's first-order lag `dF/dt = V/sigma (F_ss - F)` is inverted
//!    exactly, `F_ss = F + sigma/V dF/dt`, with `dF/dt` from a local quadratic regression over
//!    +-0.06 s. `Fx` uses `sigma_kappa(Fz)`; `Fy`, `Mz` and `Mx` use `sigma_alpha(Fz)`. The rig's
//!    measurement lag (a delay or filter in time, identified by the relaxation stage) adds its
//!    time to `sigma/V` (to first order both are a time shift on a slow sweep).
//! 4. Collapse: each sample is an up- or down-branch sample by the sign of the local slope of the
//!    swept slip; within each grid cell the mean of each branch is taken, then the mean of the
//!    two branch means (one branch only at the extremes). Up/down lag hysteresis cancels to first
//!    order and the remaining bias is second order in the lag (`tau^2 F''`). The point keeps each
//!    branch's mean operating point beside the averaged one ([`BranchInputs`]): the collapsed
//!    value is the mean of the two branches' values, so the model's prediction of it is the mean
//!    of the model at the two branches' inputs. The two differ where a loose load control swings
//!    `Fz` between passes (older rounds): the model at the averaged load misses the average of
//!    its values at the two loads by the curvature in load (second order in the swing).
//!
//! Deliberately not here: choosing which sweeps to use (the stage) and any model.

use std::collections::BTreeMap;

use super::{RelaxationLengths, Sample, Sweep, SweepKind, SweepNominal};
use crate::fit::noise_weights::high_frequency_scatter;
use crate::fit::output::Output;
use crate::numerics::stats::median;
use crate::tire_model::SlipInput;

/// The mean operating point of each branch (up, down) a collapsed value averages: one or two.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BranchInputs {
    inputs: [SlipInput; 2],
    n: usize,
}

impl BranchInputs {
    /// One operating point (a value that averages nothing, or one branch only).
    pub fn one(input: SlipInput) -> Self {
        BranchInputs {
            inputs: [input; 2],
            n: 1,
        }
    }

    /// Two branches' operating points.
    pub fn two(up: SlipInput, down: SlipInput) -> Self {
        BranchInputs {
            inputs: [up, down],
            n: 2,
        }
    }

    /// The operating points (one or two).
    pub fn as_slice(&self) -> &[SlipInput] {
        &self.inputs[..self.n]
    }

    /// The mean of `f` over the operating points: what a model predicts for the collapsed value.
    pub fn mean_of<T>(&self, mut f: impl FnMut(&SlipInput) -> T) -> T
    where
        T: std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
    {
        match self.n {
            1 => f(&self.inputs[0]),
            _ => (f(&self.inputs[0]) + f(&self.inputs[1])) * 0.5,
        }
    }
}

/// One point of a collapsed curve: averaged inputs and outputs (NaN if the channel is missing).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CurvePoint {
    /// Averaged operating point (the mean of the branches' operating points).
    pub input: SlipInput,
    /// Each averaged branch's mean operating point: the model's prediction of `outputs` is the
    /// mean of its values there ([`BranchInputs::mean_of`]).
    pub branches: BranchInputs,
    /// `[Fx, Fy, Mz, Mx]`, indexed like [`Output::ALL`].
    pub outputs: [f64; 4],
}

impl CurvePoint {
    /// The value of one output channel.
    pub fn output(&self, o: Output) -> f64 {
        self.outputs[o as usize]
    }
}

/// A sweep after cleaning and collapsing.
#[derive(Clone, Debug)]
pub struct CollapsedSweep {
    /// The sweep's id ([`Sweep::id`]).
    pub id: String,
    /// What was swept.
    pub kind: SweepKind,
    /// Nominal levels.
    pub nominal: SweepNominal,
    /// Cleaned samples (despiked, de-lagged), time order.
    pub samples: Vec<Sample>,
    /// Collapsed curve, ordered by the swept slip.
    pub points: Vec<CurvePoint>,
    /// Samples replaced by the despike test.
    pub spikes: usize,
    /// Per output ([`Output::ALL`] order): the robust standard deviation of its high-frequency
    /// scatter ([`high_frequency_scatter`]) in the despiked samples before de-lagging (the
    /// de-lag's time derivative amplifies the noise by the sweep's own relaxation length, which
    /// says nothing about the sensor); `None` when too few samples carry it.
    pub scatter: [Option<f64>; 4],
}

impl CollapsedSweep {
    /// Mean load of the curve, N.
    pub fn mean_fz(&self) -> f64 {
        mean(self.points.iter().map(|p| p.input.fz_n))
    }

    /// Mean inclination of the curve, rad.
    pub fn mean_gamma(&self) -> f64 {
        mean(self.points.iter().map(|p| p.input.gamma_rad))
    }

    /// Mean slip angle of the curve, rad.
    pub fn mean_alpha(&self) -> f64 {
        mean(self.points.iter().map(|p| p.input.alpha_rad))
    }

    /// Largest `|value|` of one output along the curve (0 if missing).
    pub fn peak(&self, o: Output) -> f64 {
        self.points
            .iter()
            .map(|p| p.output(o).abs())
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    }

    /// One output's noise level ([`CollapsedSweep::scatter`]).
    pub fn scatter(&self, o: Output) -> Option<f64> {
        self.scatter[o as usize]
    }

    /// The swept slip of a point.
    pub fn swept(&self, p: &CurvePoint) -> f64 {
        swept(self.kind, &p.input)
    }
}

fn swept(kind: SweepKind, input: &SlipInput) -> f64 {
    match kind {
        SweepKind::Cornering => input.alpha_rad,
        SweepKind::DriveBrake | SweepKind::Combined => input.kappa,
    }
}

fn mean(it: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = it.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// How to collapse.
#[derive(Copy, Clone, Debug)]
pub struct CollapseSettings<'a> {
    /// Grid step of the swept slip (rad for cornering, 1 for slip ratio).
    pub bin: f64,
    /// Despike threshold in robust standard deviations.
    pub despike_sigmas: f64,
    /// Relaxation lengths to de-lag with.
    pub relaxation: Option<&'a RelaxationLengths>,
}

/// Cleans and collapses one sweep.
pub fn collapse(sweep: &Sweep, settings: &CollapseSettings<'_>) -> CollapsedSweep {
    let mut samples: Vec<Sample> = sweep
        .samples
        .iter()
        .filter(|s| {
            [s.et_s, s.fz_n, s.kappa, s.alpha_rad, s.gamma_rad, s.vx_mps]
                .iter()
                .all(|v| v.is_finite())
        })
        .copied()
        .collect();
    samples.sort_by(|a, b| a.et_s.total_cmp(&b.et_s));
    let mut spikes = 0;
    for o in Output::ALL {
        spikes += despike(&mut samples, o, settings.despike_sigmas);
    }
    let scatter = Output::ALL.map(|o| {
        let values: Vec<f64> = samples.iter().map(|s| s.output(o)).collect();
        high_frequency_scatter(&values)
    });
    if let Some(relax) = settings.relaxation {
        delag(&mut samples, relax);
    }
    let points = branch_average(sweep.kind, &samples, settings.bin);
    CollapsedSweep {
        id: sweep.id.clone(),
        kind: sweep.kind,
        nominal: sweep.nominal,
        samples,
        points,
        spikes,
        scatter,
    }
}

/// Replaces spikes of one channel by the running median; returns how many.
fn despike(samples: &mut [Sample], o: Output, sigmas: f64) -> usize {
    const HALF: usize = 3;
    let n = samples.len();
    let values: Vec<f64> = samples.iter().map(|s| s.output(o)).collect();
    let mut med = vec![f64::NAN; n];
    let mut window = Vec::with_capacity(2 * HALF + 1);
    for (i, m) in med.iter_mut().enumerate() {
        // Symmetric windows only (shrinking at the ends): a running median is then exact on
        // monotone data, however steep.
        window.clear();
        let half = HALF.min(i).min(n - 1 - i);
        let (lo, hi) = (i - half, i + half + 1);
        window.extend(values[lo..hi].iter().copied().filter(|v| v.is_finite()));
        *m = median(&mut window).unwrap_or(f64::NAN);
    }
    let mut abs_res: Vec<f64> = values
        .iter()
        .zip(&med)
        .map(|(v, m)| (v - m).abs())
        .filter(|r| r.is_finite())
        .collect();
    if abs_res.is_empty() {
        return 0;
    }
    let scale = 1.4826 * median(&mut abs_res).unwrap_or(f64::NAN);
    let peak = med
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    let threshold = (sigmas * scale).max(0.01 * peak);
    let mut count = 0;
    for (i, s) in samples.iter_mut().enumerate() {
        if (values[i] - med[i]).abs() > threshold {
            s.set_output(o, med[i]);
            count += 1;
        }
    }
    count
}

/// Local polynomial derivative `d y / d t` at every sample (degree 2, or 1 when `degree == 1`),
/// over the samples within `half_s` seconds (at least 2 each side where available).
fn local_slope(t: &[f64], y: &[f64], half_s: f64, degree: usize) -> Vec<f64> {
    let n = t.len();
    let mut out = vec![0.0; n];
    for i in 0..n {
        let mut lo = i;
        while lo > 0 && (t[i] - t[lo - 1] <= half_s || i - lo < 2) {
            lo -= 1;
        }
        let mut hi = i;
        while hi + 1 < n && (t[hi + 1] - t[i] <= half_s || hi - i < 2) {
            hi += 1;
        }
        // Normal equations of y = a + b u (+ c u^2), u = t - t_i.
        let mut s = [0.0f64; 5];
        let mut r = [0.0f64; 3];
        let mut count = 0;
        for k in lo..=hi {
            if !y[k].is_finite() {
                continue;
            }
            let u = t[k] - t[i];
            let mut p = 1.0;
            for (j, sj) in s.iter_mut().enumerate() {
                *sj += p;
                if j < 3 {
                    r[j] += p * y[k];
                }
                p *= u;
            }
            count += 1;
        }
        let deg = if count > 3 { degree } else { 1 };
        out[i] = if deg == 1 {
            let det = s[0] * s[2] - s[1] * s[1];
            if count >= 2 && det.abs() > 0.0 {
                (s[0] * r[1] - s[1] * r[0]) / det
            } else {
                0.0
            }
        } else {
            let m = nalgebra::Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
            match m.lu().solve(&nalgebra::Vector3::new(r[0], r[1], r[2])) {
                Some(x) if x[1].is_finite() => x[1],
                _ => 0.0,
            }
        };
    }
    out
}

/// Inverts the first-order lag of every output channel in place.
fn delag(samples: &mut [Sample], relax: &RelaxationLengths) {
    let t: Vec<f64> = samples.iter().map(|s| s.et_s).collect();
    for o in Output::ALL {
        let law = match o {
            Output::Fx => &relax.sigma_kappa,
            _ => &relax.sigma_alpha,
        };
        let rig = relax.measurement_lag_s.max(0.0);
        if law.by_load.is_empty() && rig == 0.0 {
            continue;
        }
        let y: Vec<f64> = samples.iter().map(|s| s.output(o)).collect();
        let dy = local_slope(&t, &y, 0.06, 2);
        for (k, s) in samples.iter_mut().enumerate() {
            let sigma = law.at(s.fz_n).unwrap_or(0.0);
            let tau = sigma / s.vx_mps.abs().max(0.1) + rig;
            if y[k].is_finite() {
                s.set_output(o, y[k] + tau * dy[k]);
            }
        }
    }
}

/// Running sums of one grid cell and branch.
#[derive(Copy, Clone, Debug, Default)]
struct Acc {
    n: usize,
    inputs: [f64; 5],
    outputs: [f64; 4],
    output_n: [usize; 4],
}

impl Acc {
    fn add(&mut self, s: &Sample) {
        self.n += 1;
        for (a, v) in
            self.inputs
                .iter_mut()
                .zip([s.fz_n, s.kappa, s.alpha_rad, s.gamma_rad, s.vx_mps])
        {
            *a += v;
        }
        for (k, o) in Output::ALL.iter().enumerate() {
            let v = s.output(*o);
            if v.is_finite() {
                self.outputs[k] += v;
                self.output_n[k] += 1;
            }
        }
    }
}

/// Branch means per grid cell, then the mean of the branch means.
fn branch_average(kind: SweepKind, samples: &[Sample], bin: f64) -> Vec<CurvePoint> {
    let t: Vec<f64> = samples.iter().map(|s| s.et_s).collect();
    let x: Vec<f64> = samples
        .iter()
        .map(|s| swept(kind, &s.slip_input()))
        .collect();
    let dx = local_slope(&t, &x, 0.03, 1);
    let mut cells: BTreeMap<i64, [Acc; 2]> = BTreeMap::new();
    for (k, s) in samples.iter().enumerate() {
        let branch = if dx[k] > 0.0 {
            0
        } else if dx[k] < 0.0 {
            1
        } else {
            continue;
        };
        let key = (x[k] / bin).round() as i64;
        cells.entry(key).or_default()[branch].add(s);
    }
    cells
        .values()
        .map(|branches| {
            let present: Vec<&Acc> = branches.iter().filter(|a| a.n > 0).collect();
            let branch_input = |a: &Acc| {
                let m = a.inputs.map(|v| v / a.n as f64);
                SlipInput {
                    fz_n: m[0],
                    kappa: m[1],
                    alpha_rad: m[2],
                    gamma_rad: m[3],
                    vx_mps: m[4],
                }
            };
            let mut inputs = [0.0; 5];
            for a in &present {
                for (v, s) in inputs.iter_mut().zip(a.inputs) {
                    *v += s / a.n as f64 / present.len() as f64;
                }
            }
            let branch_inputs = match present.as_slice() {
                [up, down] => BranchInputs::two(branch_input(up), branch_input(down)),
                [one] => BranchInputs::one(branch_input(one)),
                _ => unreachable!("a grid cell holds at least one sample"),
            };
            let mut outputs = [0.0; 4];
            for (k, out) in outputs.iter_mut().enumerate() {
                let means: Vec<f64> = branches
                    .iter()
                    .filter(|a| a.output_n[k] > 0)
                    .map(|a| a.outputs[k] / a.output_n[k] as f64)
                    .collect();
                *out = if means.is_empty() {
                    f64::NAN
                } else {
                    means.iter().sum::<f64>() / means.len() as f64
                };
            }
            CurvePoint {
                input: SlipInput {
                    fz_n: inputs[0],
                    kappa: inputs[1],
                    alpha_rad: inputs[2],
                    gamma_rad: inputs[3],
                    vx_mps: inputs[4],
                },
                branches: branch_inputs,
                outputs,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, alpha: f64, fy: f64) -> Sample {
        Sample {
            et_s: t,
            fz_n: 1000.0,
            kappa: 0.0,
            alpha_rad: alpha,
            gamma_rad: 0.0,
            vx_mps: 11.0,
            fx_n: 0.0,
            fy_n: fy,
            mz_nm: 0.0,
            mx_nm: 0.0,
            loaded_radius_m: None,
            tread_c: f64::NAN,
        }
    }

    fn sweep(samples: Vec<Sample>) -> Sweep {
        Sweep {
            id: "s".into(),
            kind: SweepKind::Cornering,
            nominal: SweepNominal {
                fz_n: 1000.0,
                gamma_rad: 0.0,
                alpha_rad: 0.0,
            },
            qc_ok: true,
            samples,
        }
    }

    /// A linear curve with a constant +-offset on the up/down branches collapses exactly, and a
    /// spike is removed.
    #[test]
    fn hysteresis_cancels_and_spikes_go() {
        let mut s = Vec::new();
        let dt = 0.01;
        let rate = 0.07; // rad/s
        let mut t = 0.0;
        let mut a = -0.2;
        // A lag-like offset that changes sign smoothly after each turnaround.
        let offset = |t: f64, t_turn: f64, up: bool| {
            if up {
                -30.0
            } else {
                -30.0 + 60.0 * ((t - t_turn) / 0.05).tanh()
            }
        };
        while a < 0.2 {
            s.push(sample(t, a, -1000.0 * a + offset(t, 0.0, true)));
            a += rate * dt;
            t += dt;
        }
        let t_turn = t;
        while a > -0.2 {
            s.push(sample(t, a, -1000.0 * a + offset(t, t_turn, false)));
            a -= rate * dt;
            t += dt;
        }
        s[100].fy_n += 400.0;
        let c = collapse(
            &sweep(s),
            &CollapseSettings {
                bin: 0.005,
                despike_sigmas: 6.0,
                relaxation: None,
            },
        );
        assert_eq!(c.spikes, 1);
        let inner: Vec<&CurvePoint> = c
            .points
            .iter()
            .filter(|p| p.input.alpha_rad.abs() < 0.19)
            .collect();
        assert!(inner.len() > 60);
        for p in inner {
            let err = p.output(Output::Fy) + 1000.0 * p.input.alpha_rad;
            assert!(err.abs() < 2.0, "alpha {} err {err}", p.input.alpha_rad);
        }
    }

    /// A load that differs between the up and down passes (loose load control): each point
    /// keeps both branches' operating points, and the mean of a load-curved channel at them is
    /// the collapsed value, where the channel at the averaged load is not.
    #[test]
    fn branch_inputs_carry_each_pass_load() {
        let curve = |alpha: f64, fz: f64| -alpha * fz * (2.0 - fz / 2000.0);
        let (dt, rate) = (0.01, 0.07);
        let mut s = Vec::new();
        let (mut t, mut a) = (0.0, -0.2);
        while a < 0.2 {
            let mut x = sample(t, a, curve(a, 1200.0));
            x.fz_n = 1200.0;
            s.push(x);
            a += rate * dt;
            t += dt;
        }
        while a > -0.2 {
            let mut x = sample(t, a, curve(a, 800.0));
            x.fz_n = 800.0;
            s.push(x);
            a -= rate * dt;
            t += dt;
        }
        let c = collapse(
            &sweep(s),
            &CollapseSettings {
                bin: 0.005,
                despike_sigmas: 6.0,
                relaxation: None,
            },
        );
        let inner: Vec<&CurvePoint> = c
            .points
            .iter()
            .filter(|p| p.input.alpha_rad.abs() < 0.19)
            .collect();
        assert!(inner.len() > 60);
        let mut worst_mean_input = 0.0f64;
        for p in inner {
            let loads: Vec<f64> = p.branches.as_slice().iter().map(|b| b.fz_n).collect();
            assert_eq!(loads, [1200.0, 800.0], "alpha {}", p.input.alpha_rad);
            assert!((p.input.fz_n - 1000.0).abs() < 1e-9);
            let y = p.output(Output::Fy);
            let by_branch = p.branches.mean_of(|b| curve(b.alpha_rad, b.fz_n));
            assert!(
                (by_branch - y).abs() < 1e-6 * y.abs().max(1.0),
                "{by_branch} vs {y}"
            );
            worst_mean_input =
                worst_mean_input.max((curve(p.input.alpha_rad, p.input.fz_n) - y).abs());
        }
        // The curvature in load: |alpha| * 200^2 / 2000 = 20 N per rad of slip angle.
        assert!(worst_mean_input > 3.0, "{worst_mean_input}");
    }

    /// De-lagging a first-order-lagged ramp recovers the steady state.
    #[test]
    fn delag_inverts_first_order_lag() {
        let dt = 0.01;
        let tau = 0.03;
        let mut y = 0.0;
        let mut s = Vec::new();
        for k in 0..400 {
            let t = k as f64 * dt;
            let u = 500.0 * (1.5 * t).sin();
            let decay = (-dt / tau).exp();
            // Exact first-order-hold update (same as the virtual machine's).
            if k > 0 {
                let u_prev = 500.0 * (1.5 * (t - dt)).sin();
                let slope = (u - u_prev) / dt;
                y = u - tau * slope + (y - u_prev + tau * slope) * decay;
            } else {
                y = u;
            }
            s.push(sample(t, 0.0, y));
        }
        let relax = RelaxationLengths {
            sigma_alpha: super::super::RelaxationTable {
                by_load: vec![(0.0, tau * 11.0)],
            },
            sigma_kappa: Default::default(),
            measurement_lag_s: 0.0,
        };
        delag(&mut s, &relax);
        for (k, x) in s.iter().enumerate().skip(50).take(300) {
            let u = 500.0 * (1.5 * k as f64 * dt).sin();
            assert!((x.fy_n - u).abs() < 0.5, "k {k}: {} vs {u}", x.fy_n);
        }
    }
}
