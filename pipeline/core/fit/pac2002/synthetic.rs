//! Test-only: TTC-like rounds generated from a known PAC2002 truth, and the accuracy of a fitted
//! model against that truth over the tested envelope.
//!
//! In: truth coefficients and a [`RoundSpec`] (noise, lag, seed). Out: a [`FitInput`] laid out
//! like a TTC round (cornering SA sweeps SAE -4 -> +12 -> -12 -> +3 deg, i.e. ISO-W
//! +4 -> -12 -> +12 -> -3 deg, at 4 deg/s and IA 0..4 deg x 5 loads 222..1557 N; drive/brake and
//! combined slip sweeps 0 -> +0.2 -> -0.2 -> +0.2 -> 0 at 0.15/s, at SA 0, 3, 6 deg (ISO-W) x
//! IA 0/2/4 deg x 4 loads; 100 Hz, 11.176 m/s), and [`envelope_errors`]. Deliberately simple
//! next to the virtual test machine (branch `synth`): no heat, no load control dynamics.

use crate::fit::pac2002::{
    FitContext, FitInput, RelaxationLengths, RelaxationTable, Sample, Sweep, SweepKind,
    SweepNominal,
};
use crate::numerics::random::SplitMix64;
use crate::tire_model::{Coef, Coefs, Mode, Pac2002, SlipInput};

/// The `fsae-demo` reference tire (coefficients in SI, as in the file).
pub fn fsae_demo() -> Coefs<f64> {
    coefs_from_tir(include_str!(
        "../../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002.tir"
    ))
}

/// Minimal `.tir` line reader for SI files: `KEY = number` lines whose key is a [`Coef`].
pub fn coefs_from_tir(text: &str) -> Coefs<f64> {
    let mut c = Coefs::defaults();
    for line in text.lines() {
        let line = line.split('$').next().unwrap_or("");
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        if let (Some(coef), Ok(v)) = (Coef::from_name(key), value.trim().parse::<f64>()) {
            c[coef] = v;
        }
    }
    c
}

/// A standard normal draw by Box-Muller in this generator's own form, `sqrt(-2 ln u1)
/// cos(2 pi u2)` (not [`SplitMix64::gaussian`]'s `ln(1 - u1)`: the rounds the tests were tuned on
/// come from this stream).
fn normal(rng: &mut SplitMix64) -> f64 {
    let u1 = rng.uniform().max(1e-300);
    let u2 = rng.uniform();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Measurement realism of a generated round.
#[derive(Copy, Clone, Debug)]
pub struct RoundSpec {
    /// Gaussian noise on forces/moments, fraction of the sweep's peak of that channel.
    pub noise_of_peak: f64,
    /// Probability of a spike per sample and channel.
    pub spike_probability: f64,
    /// Spike size, fraction of the sweep's peak (sign and 50-150 % of it random).
    pub spike_of_peak: f64,
    /// Noise on the measured inputs: slip angle and inclination (rad), load (fraction), slip.
    pub input_noise: (f64, f64, f64, f64),
    /// Apply the first-order lag `dF/dt = V/sigma (F_ss - F)`.
    pub lag: bool,
    /// Seed.
    pub seed: u64,
}

impl RoundSpec {
    /// Noise-free, lag-free.
    pub fn ideal() -> Self {
        RoundSpec {
            noise_of_peak: 0.0,
            spike_probability: 0.0,
            spike_of_peak: 0.0,
            input_noise: (0.0, 0.0, 0.0, 0.0),
            lag: false,
            seed: 1,
        }
    }

    /// ~1 % of peak Gaussian noise, a few spikes, input noise and lag.
    pub fn realistic(seed: u64) -> Self {
        RoundSpec {
            noise_of_peak: 0.01,
            spike_probability: 0.002,
            spike_of_peak: 0.2,
            input_noise: (0.02_f64.to_radians(), 0.02_f64.to_radians(), 0.005, 0.0005),
            lag: true,
            seed,
        }
    }
}

/// Test speed, m/s (25 mph).
pub const SPEED_MPS: f64 = 11.176;
const RATE_HZ: f64 = 100.0;
const CORNERING_LOADS: [f64; 5] = [222.0, 445.0, 667.0, 1112.0, 1557.0];
const CORNERING_IA_DEG: [f64; 5] = [0.0, 1.0, 2.0, 3.0, 4.0];
const SLIP_LOADS: [f64; 4] = [222.0, 667.0, 1112.0, 1557.0];
const SLIP_IA_DEG: [f64; 3] = [0.0, 2.0, 4.0];
const SLIP_SA_DEG: [f64; 3] = [0.0, 3.0, 6.0];

/// The truth relaxation lengths used for the lag: `sigma_alpha` 0.2..0.45 m and `sigma_kappa`
/// 0.12..0.25 m over the load range.
pub fn truth_relaxation() -> RelaxationLengths {
    RelaxationLengths {
        sigma_alpha: RelaxationTable {
            by_load: vec![(200.0, 0.2), (1600.0, 0.45)],
        },
        sigma_kappa: RelaxationTable {
            by_load: vec![(200.0, 0.12), (1600.0, 0.25)],
        },
        measurement_lag_s: 0.0,
    }
}

/// Piecewise-linear path through `points` at `rate` per second, sampled at 100 Hz.
fn path(points: &[f64], rate: f64) -> Vec<f64> {
    let mut out = vec![points[0]];
    for w in points.windows(2) {
        let n = (((w[1] - w[0]).abs() / rate) * RATE_HZ).round().max(1.0) as usize;
        for k in 1..=n {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / n as f64);
        }
    }
    out
}

/// First-order lag with the exact first-order-hold update (the virtual machine's).
fn lag(values: &[f64], tau: f64, dt: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len());
    let mut y = values[0];
    out.push(y);
    let decay = (-dt / tau).exp();
    for w in values.windows(2) {
        let slope = (w[1] - w[0]) / dt;
        y = w[1] - tau * slope + (y - w[0] + tau * slope) * decay;
        out.push(y);
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn sweep(
    truth: &Pac2002,
    spec: &RoundSpec,
    rng: &mut SplitMix64,
    id: String,
    kind: SweepKind,
    fz: f64,
    gamma: f64,
    alpha_path: &[f64],
    kappa_path: &[f64],
    t0: f64,
) -> Sweep {
    let n = alpha_path.len().max(kappa_path.len());
    let at = |v: &[f64], k: usize| if v.len() == 1 { v[0] } else { v[k] };
    let inputs: Vec<SlipInput> = (0..n)
        .map(|k| SlipInput {
            fz_n: fz,
            kappa: at(kappa_path, k),
            alpha_rad: at(alpha_path, k),
            gamma_rad: gamma,
            vx_mps: SPEED_MPS,
        })
        .collect();
    let evals: Vec<_> = inputs.iter().map(|i| truth.eval(i, Mode::Limits)).collect();
    let mut ch: Vec<Vec<f64>> = vec![
        evals.iter().map(|e| e.fx_n).collect(),
        evals.iter().map(|e| e.fy_n).collect(),
        evals.iter().map(|e| e.mz_nm).collect(),
        evals.iter().map(|e| e.mx_nm).collect(),
    ];
    let dt = 1.0 / RATE_HZ;
    if spec.lag {
        let relax = truth_relaxation();
        let ta = relax.sigma_alpha.at(fz).unwrap_or(0.3) / SPEED_MPS;
        let tk = relax.sigma_kappa.at(fz).unwrap_or(0.2) / SPEED_MPS;
        for (j, values) in ch.iter_mut().enumerate() {
            *values = lag(values, if j == 0 { tk } else { ta }, dt);
        }
    }
    for values in ch.iter_mut() {
        let peak = values.iter().map(|v| v.abs()).fold(0.0, f64::max);
        for v in values.iter_mut() {
            *v += spec.noise_of_peak * peak * normal(rng);
            if spec.spike_probability > 0.0 && rng.uniform() < spec.spike_probability {
                let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                *v += sign * spec.spike_of_peak * peak * (0.5 + rng.uniform());
            }
        }
    }
    let (na, ng, nf, nk) = spec.input_noise;
    let samples = (0..n)
        .map(|k| Sample {
            et_s: t0 + k as f64 * dt,
            fz_n: fz * (1.0 + nf * normal(rng)),
            kappa: inputs[k].kappa + nk * normal(rng),
            alpha_rad: inputs[k].alpha_rad + na * normal(rng),
            gamma_rad: gamma + ng * normal(rng),
            vx_mps: SPEED_MPS,
            fx_n: ch[0][k],
            fy_n: ch[1][k],
            mz_nm: ch[2][k],
            mx_nm: ch[3][k],
            loaded_radius_m: None,
            tread_c: f64::NAN,
        })
        .collect();
    Sweep {
        id,
        kind,
        nominal: SweepNominal {
            fz_n: fz,
            gamma_rad: gamma,
            alpha_rad: if kind == SweepKind::Cornering {
                0.0
            } else {
                at(alpha_path, 0)
            },
        },
        qc_ok: true,
        samples,
    }
}

/// A whole TTC-like round of one tire and pressure from `truth`.
pub fn ttc_round(truth: &Coefs<f64>, spec: &RoundSpec) -> FitInput {
    let tire = Pac2002::new(truth.clone());
    let mut rng = SplitMix64::new(spec.seed);
    let mut sweeps = Vec::new();
    let mut t0 = 0.0;
    let alpha = path(
        &[0.0, 4.0, -12.0, 12.0, -3.0, 0.0].map(f64::to_radians),
        4f64.to_radians(),
    );
    for ia in CORNERING_IA_DEG {
        for fz in CORNERING_LOADS {
            let id = format!("cornering-ia{ia}-fz{fz}");
            let s = sweep(
                &tire,
                spec,
                &mut rng,
                id,
                SweepKind::Cornering,
                fz,
                ia.to_radians(),
                &alpha,
                &[0.0],
                t0,
            );
            t0 += s.samples.len() as f64 / RATE_HZ + 12.0;
            sweeps.push(s);
        }
    }
    let kappa = path(&[0.0, 0.2, -0.2, 0.2, 0.0], 0.15);
    for sa in SLIP_SA_DEG {
        for ia in SLIP_IA_DEG {
            for fz in SLIP_LOADS {
                let kind = if sa == 0.0 {
                    SweepKind::DriveBrake
                } else {
                    SweepKind::Combined
                };
                let id = format!("{}-sa{sa}-ia{ia}-fz{fz}", kind.as_str());
                let s = sweep(
                    &tire,
                    spec,
                    &mut rng,
                    id,
                    kind,
                    fz,
                    ia.to_radians(),
                    &[sa.to_radians()],
                    &kappa,
                    t0,
                );
                t0 += s.samples.len() as f64 / RATE_HZ + 12.0;
                sweeps.push(s);
            }
        }
    }
    FitInput {
        context: FitContext {
            tire: "synthetic".to_string(),
            rim_in: 7.0,
            pressure_kpa_nom: 83.0,
            test_speed_mps: SPEED_MPS,
            vertical_stiffness_n_per_m: Some(truth[Coef::VERTICAL_STIFFNESS]),
            unloaded_radius_m: Some(truth[Coef::UNLOADED_RADIUS]),
            relaxation: None,
        },
        sweeps,
    }
}

/// RMS error of a fitted model against the truth, % of the truth's peak of each channel.
#[derive(Copy, Clone, Debug, Default)]
pub struct EnvelopeErrors {
    /// Over the cornering matrix (kappa = 0): `[Fx, Fy, Mz, Mx]`.
    pub cornering: [f64; 4],
    /// Over the drive/brake conditions (alpha = 0).
    pub drive_brake: [f64; 4],
    /// Over the combined conditions (alpha = 3, 6 deg).
    pub combined: [f64; 4],
    /// Over all of them together.
    pub all: [f64; 4],
}

/// Errors of `fitted` against `truth` over the tested envelope (both evaluated as MFeval does,
/// with their own input limits).
pub fn envelope_errors(truth: &Coefs<f64>, fitted: &Pac2002) -> EnvelopeErrors {
    let truth = Pac2002::new(truth.clone());
    let mut groups: [Vec<SlipInput>; 3] = Default::default();
    for ia in CORNERING_IA_DEG {
        for fz in CORNERING_LOADS {
            for k in 0..=48 {
                groups[0].push(SlipInput {
                    fz_n: fz,
                    kappa: 0.0,
                    alpha_rad: (-12.0 + 0.5 * k as f64).to_radians(),
                    gamma_rad: ia.to_radians(),
                    vx_mps: SPEED_MPS,
                });
            }
        }
    }
    for sa in SLIP_SA_DEG {
        for ia in SLIP_IA_DEG {
            for fz in SLIP_LOADS {
                for k in 0..=40 {
                    let g = if sa == 0.0 { 1 } else { 2 };
                    groups[g].push(SlipInput {
                        fz_n: fz,
                        kappa: -0.2 + 0.01 * k as f64,
                        alpha_rad: sa.to_radians(),
                        gamma_rad: ia.to_radians(),
                        vx_mps: SPEED_MPS,
                    });
                }
            }
        }
    }
    let errs = |inputs: &[SlipInput]| -> [f64; 4] {
        let mut ss = [0.0; 4];
        let mut peak = [0.0f64; 4];
        for i in inputs {
            let t = truth.eval(i, Mode::Limits);
            let f = fitted.eval(i, Mode::Limits);
            let tv = [t.fx_n, t.fy_n, t.mz_nm, t.mx_nm];
            let fv = [f.fx_n, f.fy_n, f.mz_nm, f.mx_nm];
            for k in 0..4 {
                ss[k] += (fv[k] - tv[k]).powi(2);
                peak[k] = peak[k].max(tv[k].abs());
            }
        }
        let n = inputs.len() as f64;
        std::array::from_fn(|k| 100.0 * (ss[k] / n).sqrt() / peak[k])
    };
    let all: Vec<SlipInput> = groups.iter().flatten().copied().collect();
    EnvelopeErrors {
        cornering: errs(&groups[0]),
        drive_brake: errs(&groups[1]),
        combined: errs(&groups[2]),
        all: errs(&all),
    }
}
