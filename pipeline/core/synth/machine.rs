//! The virtual test machine: runs one [`Program`] on one truth tire and records every channel.
//!
//! In: a program (commanded ramps), the truth model of the tire at the run's pressure, its thermal
//! law, the realism knobs and a random stream. Out: [`RunSamples`]: SI channels with the tire
//! quantities in ISO-W, one value per sample at the file's rate, plus for each sample whether it
//! is a dwell and which piece it belongs to.
//!
//! Per sample: commanded state (+ load-servo wander) -> steady-state truth model (PAC2002, or
//! MF 6.1 at the true inflation pressure: commanded + servo wander) at the tread temperature's
//! grip scalings (`LMUX`, `LMUY` = `mu_rel(T)/mu_rel(T_ref)`), times the run-order drift's
//! friction and slip stiffness scalings (`LKX`, `LKY`) when it is on (`super::drift`: the
//! tire's history advances with every sample's slip energy and distance) -> first-order lag
//! (`Fy`, `Mz`, `Mx` with `sigma_alpha`; `Fx` with `sigma_kappa`) -> slip power heats the tread ->
//! radii, wheel speed, slips -> sensors (the load cell's channels through the rig's measurement
//! chain: a pure delay and a first-order filter in time, both off by default; noise, IR phase
//! lag, IR clipping).
//! Deliberately not here: units, axis conversion to SAE, decimals, file formats (`dat.rs`).

use crate::tire_model::{Coef, Mode, SlipInput};

use super::drift::{RunOrderDrift, TireHistory};
use super::noise::{Rng, Wander};
use super::physics::{FirstOrderLag, MeasurementChain, ThermalParams, Tread, slip_power_w};
use super::schedule::Program;
use super::tires::{ThermalTruth, TruthModel, V_REF_MPS};

/// Below this road speed the machine is "at standstill": no lag dynamics, RE and SR undefined.
pub const STANDSTILL_MPS: f64 = 0.3;

/// Realism knobs of the machine (see `config/default.toml`, `[synth.realism]`).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Realism {
    /// Multiplies every noise amplitude and servo wander (0 = noise-free).
    pub noise_scale: f64,
    /// First-order relaxation of the forces.
    pub lag: bool,
    /// Grip depends on tread temperature.
    pub heat: bool,
    /// Thermal constants.
    pub thermal: ThermalParams,
    /// Air temperature, degC.
    pub ambient_c: f64,
    /// Road (belt) surface temperature, degC.
    pub road_c: f64,
    /// Pure delay of the load cell's channels behind the slip and speed channels, s.
    pub measurement_delay_s: f64,
    /// First-order filter of the load cell's channels after the delay, s.
    pub measurement_filter_s: f64,
    /// Loose load control of older rounds (`None`: the servo holds the load).
    pub load_swing: Option<LoadSwing>,
    /// Run-order drift and the tire's history at the start of the run (`None`: no drift).
    pub drift: Option<(RunOrderDrift, TireHistory)>,
    /// The ringing of the load cell at the rig's slip-angle turnarounds (`None`: none).
    pub turnaround_ring: Option<TurnaroundRing>,
}

/// The rig's structure ringing at a slip-angle turnaround, seen by the load cell: from each of
/// the program's excitations ([`Program::rings`], `(t0, sign)`) the measured `Mz` and `Fy` get
/// `sign A exp(-(t - t0) / RING_DECAY_S) sin(2 pi RING_HZ (t - t0))`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TurnaroundRing {
    /// Amplitude on `Mz`, N m.
    pub mz_nm: f64,
    /// Amplitude on `Fy`, N.
    pub fy_n: f64,
}

/// Frequency of the turnaround ringing, Hz.
pub const RING_HZ: f64 = 9.0;
/// Decay time of the turnaround ringing, s.
pub const RING_DECAY_S: f64 = 0.1;

impl TurnaroundRing {
    /// The unit ringing (times the amplitudes) at `t_s` of the excitations `rings`.
    pub fn unit_at(rings: &[(f64, f64)], t_s: f64) -> f64 {
        rings
            .iter()
            .take_while(|(t0, _)| *t0 <= t_s)
            .filter(|(t0, _)| t_s - t0 < 10.0 * RING_DECAY_S)
            .map(|(t0, sign)| {
                let u = t_s - t0;
                sign * (-u / RING_DECAY_S).exp() * (std::f64::consts::TAU * RING_HZ * u).sin()
            })
            .sum()
    }
}

/// Loose load control: while the tire slips, FZ swings around its set-point,
/// `FZ = FZ_set (1 + frac s sin(2 pi t / period + phase))`, `s = min(1, |alpha| / 2 deg +
/// |kappa| / 0.02)` of the commanded slip: the full swing in a sweep, none at zero slip (a
/// spring-rate hold stays clean whatever the camber thrust).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LoadSwing {
    /// Amplitude as a fraction of the set-point, -.
    pub frac: f64,
    /// Period, s.
    pub period_s: f64,
    /// Phase at t = 0, rad.
    pub phase_rad: f64,
}

impl Default for Realism {
    fn default() -> Self {
        Realism {
            noise_scale: 1.0,
            lag: true,
            heat: true,
            thermal: ThermalParams::default(),
            ambient_c: 24.0,
            road_c: 27.0,
            measurement_delay_s: 0.0,
            measurement_filter_s: 0.0,
            load_swing: None,
            drift: None,
            turnaround_ring: None,
        }
    }
}

impl Realism {
    /// Noise-free, lag-free, heat-free: the files hold the truth model exactly (up to decimals).
    pub fn ideal() -> Realism {
        Realism {
            noise_scale: 0.0,
            lag: false,
            heat: false,
            ..Realism::default()
        }
    }
}

/// Sensor noise standard deviations at `noise_scale = 1`, SI.
#[derive(Copy, Clone, Debug)]
struct SensorNoise {
    force_x_n: f64,
    force_y_n: f64,
    force_z_n: f64,
    moment_x_nm: f64,
    moment_z_nm: f64,
    angle_rad: f64,
    speed_mps: f64,
    radius_m: f64,
    pressure_kpa: f64,
    temperature_c: f64,
    slip: f64,
    wheel_rpm: f64,
}

const NOISE: SensorNoise = SensorNoise {
    force_x_n: 5.0,
    force_y_n: 6.0,
    force_z_n: 4.0,
    moment_x_nm: 0.8,
    moment_z_nm: 0.4,
    angle_rad: 0.005 * std::f64::consts::PI / 180.0,
    speed_mps: 0.01,
    radius_m: 0.00004,
    pressure_kpa: 0.15,
    temperature_c: 0.25,
    slip: 0.0002,
    wheel_rpm: 0.05,
};

/// One run's channels, SI, tire quantities ISO-W. Temperatures degC, pressure kPa.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunSamples {
    pub et_s: Vec<f64>,
    pub v_mps: Vec<f64>,
    pub n_rpm: Vec<f64>,
    pub alpha_rad: Vec<f64>,
    pub gamma_rad: Vec<f64>,
    pub rl_m: Vec<f64>,
    pub re_m: Vec<f64>,
    pub p_kpa: Vec<f64>,
    pub fx_n: Vec<f64>,
    pub fy_n: Vec<f64>,
    pub fz_n: Vec<f64>,
    pub mx_nm: Vec<f64>,
    pub mz_nm: Vec<f64>,
    pub road_c: Vec<f64>,
    pub tread_inner_c: Vec<f64>,
    pub tread_centre_c: Vec<f64>,
    pub tread_outer_c: Vec<f64>,
    pub ambient_c: Vec<f64>,
    /// Calspan's control slip (loaded-radius based).
    pub sr: Vec<f64>,
    /// Longitudinal slip (effective-radius based) = kappa.
    pub sl: Vec<f64>,
    /// The true tread surface temperature at the contact (no sensor effects), degC.
    pub surface_true_c: Vec<f64>,
    /// The lateral grip scaling applied (`LMUY`).
    pub grip_scale: Vec<f64>,
    /// Sample lies in a dwell piece.
    pub dwell: Vec<bool>,
    /// Piece index of the sample.
    pub piece: Vec<u32>,
    /// The run-order drift's friction and slip stiffness scalings per sample (empty without
    /// drift).
    pub drift_scales: Vec<(f64, f64)>,
    /// The tire's history at the end of the run: the start's (zero without drift) plus the run's
    /// slip energy and distance.
    pub history_end: TireHistory,
}

/// Run `program` on `truth` at `rate_hz`, drawing noise from `rng`.
pub fn simulate(
    program: &Program,
    truth: &TruthModel,
    thermal: &ThermalTruth,
    realism: &Realism,
    rate_hz: f64,
    rng: &mut Rng,
) -> RunSamples {
    let dt = 1.0 / rate_hz;
    let n = (program.duration_s() * rate_hz).floor() as usize + 1;
    let ns = realism.noise_scale;
    let mut model = truth.model.clone();
    let mf6 = model.version.is_mf6();
    let mut out = RunSamples::default();
    reserve(&mut out, n);

    let mut load_wander = Wander::new(0.006, 0.3, dt);
    let mut load_offset = Wander::new(3.0, 0.3, dt);
    let mut pressure_wander = Wander::new(0.3, 5.0, dt);
    let mut road_wander = Wander::new(0.3, 30.0, dt);
    let mut air_wander = Wander::new(0.2, 60.0, dt);
    let mut lag_fx = FirstOrderLag::default();
    let mut lag_fy = FirstOrderLag::default();
    let mut lag_mz = FirstOrderLag::default();
    let mut lag_mx = FirstOrderLag::default();
    let mut tread = Tread::cold(thermal.t_cold_c);
    // The load cell's chain: fx, fy, fz, mx, mz.
    let mut chain: [MeasurementChain; 5] = std::array::from_fn(|_| {
        MeasurementChain::new(
            realism.measurement_delay_s,
            realism.measurement_filter_s,
            dt,
        )
    });
    let mut hint = (0usize, 0.0f64);
    let mut history = realism.drift.map(|d| d.1).unwrap_or_default();
    let (lkx, lky) = (model.coefs[Coef::LKX], model.coefs[Coef::LKY]);

    for k in 0..n {
        let t = k as f64 * dt;
        let (cmd, piece) = program.command_at(t, &mut hint);
        let swing = realism.load_swing.map_or(0.0, |w| {
            let share = (cmd.alpha_rad.abs() / 2f64.to_radians() + cmd.kappa.abs() / 0.02).min(1.0);
            w.frac * share * (std::f64::consts::TAU * t / w.period_s + w.phase_rad).sin()
        });
        let fz = cmd.fz_n * (1.0 + ns * load_wander.step(rng) + swing) + ns * load_offset.step(rng);
        let v = cmd.v_mps;
        let (grip_x, grip_y) = if realism.heat {
            thermal.grip_scale(tread.surface_c)
        } else {
            (1.0, 1.0)
        };
        model.coefs[Coef::LMUX] = grip_x;
        model.coefs[Coef::LMUY] = grip_y;
        if let Some((drift, _)) = &realism.drift {
            let (mu, k) = drift.scales(&history);
            model.coefs[Coef::LMUX] *= mu;
            model.coefs[Coef::LMUY] *= mu;
            model.coefs[Coef::LKX] = lkx * k;
            model.coefs[Coef::LKY] = lky * k;
            out.drift_scales.push((mu, k));
        }
        // An MF 6.x truth sees the true inflation pressure, so the servo's wander is drawn before
        // the forces; a PAC2002 truth has no pressure term and keeps the draw order of older
        // rounds (wander drawn with the pressure channel below).
        let early_wander = mf6.then(|| ns * pressure_wander.step(rng));
        let p_true_pa = (program.pressure_kpa() + early_wander.unwrap_or(0.0)) * 1e3;
        let ss = model.eval_at(
            &SlipInput {
                fz_n: fz,
                kappa: cmd.kappa,
                alpha_rad: cmd.alpha_rad,
                gamma_rad: cmd.gamma_rad,
                vx_mps: v,
            },
            p_true_pa,
            Mode::Limits,
        );
        // The reference tire's relaxation lengths: the drift leaves the relaxation law alone (the
        // grip scalings do not enter it).
        let (sigma_kappa, sigma_alpha) =
            truth
                .model
                .relaxation_lengths_at(fz, cmd.gamma_rad, p_true_pa);
        let (tau_x, tau_y) = if realism.lag && v > STANDSTILL_MPS {
            (sigma_kappa / v, sigma_alpha / v)
        } else {
            (0.0, 0.0)
        };
        let fx = lag_fx.step(ss.fx_n, dt, tau_x);
        let fy = lag_fy.step(ss.fy_n, dt, tau_y);
        let mz = lag_mz.step(ss.mz_nm, dt, tau_y);
        let mx = lag_mx.step(ss.mx_nm, dt, tau_y);

        let road = realism.road_c + ns * road_wander.step(rng);
        let air = realism.ambient_c + ns * air_wander.step(rng);
        let power = slip_power_w(fx, fy, cmd.kappa, cmd.alpha_rad, v);
        tread.step(&realism.thermal, power, fz, v, V_REF_MPS, road, air, dt);
        history.slip_energy_j += power * dt;
        history.distance_m += v.abs() * dt;

        let rl = truth.vertical.loaded_radius(fz, v);
        let (re, omega, sr) = if v > STANDSTILL_MPS {
            let re = truth.effective_radius(fz, v);
            let omega = v * (1.0 + cmd.kappa) / re;
            (re, omega, omega * rl / v - 1.0)
        } else {
            (0.0, 0.0, 0.0)
        };

        out.et_s.push(t);
        // Speed and wheel speed are magnitudes: never negative, not noisy at standstill.
        let moving = if v > STANDSTILL_MPS { ns } else { 0.0 };
        out.v_mps
            .push((v + rng.gauss(moving * NOISE.speed_mps)).max(0.0));
        out.n_rpm.push(
            (omega * 60.0 / std::f64::consts::TAU + rng.gauss(moving * NOISE.wheel_rpm)).max(0.0),
        );
        out.alpha_rad
            .push(cmd.alpha_rad + rng.gauss(ns * NOISE.angle_rad));
        out.gamma_rad
            .push(cmd.gamma_rad + rng.gauss(ns * NOISE.angle_rad));
        out.rl_m.push(rl + rng.gauss(ns * NOISE.radius_m));
        out.re_m.push(if re > 0.0 {
            re + rng.gauss(ns * NOISE.radius_m)
        } else {
            0.0
        });
        let wander = match early_wander {
            Some(w) => w,
            None => ns * pressure_wander.step(rng),
        };
        out.p_kpa
            .push(program.pressure_kpa() + wander + rng.gauss(ns * NOISE.pressure_kpa));
        let [fx_m, mut fy_m, fz_m, mx_m, mut mz_m] = [
            chain[0].step(fx),
            chain[1].step(fy),
            chain[2].step(fz),
            chain[3].step(mx),
            chain[4].step(mz),
        ];
        if let Some(ring) = realism.turnaround_ring {
            let unit = TurnaroundRing::unit_at(&program.rings, t);
            fy_m += ring.fy_n * unit;
            mz_m += ring.mz_nm * unit;
        }
        out.fx_n.push(fx_m + rng.gauss(ns * NOISE.force_x_n));
        out.fy_n.push(fy_m + rng.gauss(ns * NOISE.force_y_n));
        out.fz_n.push(fz_m + rng.gauss(ns * NOISE.force_z_n));
        out.mx_nm.push(mx_m + rng.gauss(ns * NOISE.moment_x_nm));
        out.mz_nm.push(mz_m + rng.gauss(ns * NOISE.moment_z_nm));
        out.road_c.push(road + rng.gauss(ns * NOISE.temperature_c));
        out.ambient_c
            .push(air + rng.gauss(ns * NOISE.temperature_c));
        out.sr.push(if v > STANDSTILL_MPS {
            sr + rng.gauss(ns * NOISE.slip)
        } else {
            0.0
        });
        out.sl.push(cmd.kappa + rng.gauss(ns * NOISE.slip));
        out.surface_true_c.push(tread.surface_c);
        out.grip_scale.push(grip_y);
        out.dwell.push(program.pieces[piece].dwell);
        out.piece.push(piece as u32);
        // IR channels are filled below from the surface history (phase lag).
        let _ = re;
    }
    infrared(&mut out, realism, rng);
    out.history_end = history;
    out
}

fn reserve(out: &mut RunSamples, n: usize) {
    for v in [
        &mut out.et_s,
        &mut out.v_mps,
        &mut out.n_rpm,
        &mut out.alpha_rad,
        &mut out.gamma_rad,
        &mut out.rl_m,
        &mut out.re_m,
        &mut out.p_kpa,
        &mut out.fx_n,
        &mut out.fy_n,
        &mut out.fz_n,
        &mut out.mx_nm,
        &mut out.mz_nm,
        &mut out.road_c,
        &mut out.tread_inner_c,
        &mut out.tread_centre_c,
        &mut out.tread_outer_c,
        &mut out.ambient_c,
        &mut out.sr,
        &mut out.sl,
        &mut out.surface_true_c,
        &mut out.grip_scale,
    ] {
        v.reserve_exact(n);
    }
}

/// IR phase lag: the sensors see the tread 3/4 revolution after it leaves the road.
pub fn ir_delay_s(re_m: f64, v_mps: f64) -> f64 {
    if v_mps > STANDSTILL_MPS && re_m > 0.0 {
        0.75 * std::f64::consts::TAU * re_m / v_mps
    } else {
        0.0
    }
}

/// Inner/outer offsets per degree of inclination, degC/deg (inner shoulder loaded by +IA).
const IR_INNER_PER_DEG: f64 = 1.8;
const IR_OUTER_PER_DEG: f64 = -1.2;
/// Lateral deflection (|Fy|/Fz) at which the inner sensor's spot leaves the tread.
const IR_INNER_CLIP_MU: f64 = 1.9;
/// ... and the outer one (less exposed).
const IR_OUTER_CLIP_MU: f64 = 2.4;

/// Fill TSTI/TSTC/TSTO from the true surface history: delay by `ir_delay_s`, add the
/// inclination offsets, clip the inner (outer) spot to sidewall temperature when the carcass
/// deflects far, add sensor noise.
fn infrared(out: &mut RunSamples, realism: &Realism, rng: &mut Rng) {
    let n = out.et_s.len();
    let ns = realism.noise_scale;
    let dt = if n > 1 {
        out.et_s[1] - out.et_s[0]
    } else {
        1.0
    };
    for k in 0..n {
        let re = out.re_m[k];
        let v = out.v_mps[k];
        let back = ir_delay_s(re, v) / dt;
        let pos = (k as f64 - back).max(0.0);
        let i = pos.floor() as usize;
        let f = pos - i as f64;
        let j = (i + 1).min(n - 1);
        let centre = out.surface_true_c[i] * (1.0 - f) + out.surface_true_c[j] * f;
        let ia_deg = out.gamma_rad[k].to_degrees();
        let mu_y = out.fy_n[k] / out.fz_n[k].max(50.0);
        let sidewall = realism.ambient_c + 6.0;
        let clip = |x: f64| ((x - 1.0) / 0.1).clamp(0.0, 1.0);
        let c_in = clip(-mu_y / IR_INNER_CLIP_MU);
        let c_out = clip(mu_y / IR_OUTER_CLIP_MU);
        let inner = centre + IR_INNER_PER_DEG * ia_deg;
        let outer = centre + IR_OUTER_PER_DEG * ia_deg;
        out.tread_centre_c
            .push(centre + rng.gauss(ns * NOISE.temperature_c));
        out.tread_inner_c
            .push(inner * (1.0 - c_in) + sidewall * c_in + rng.gauss(ns * NOISE.temperature_c));
        out.tread_outer_c
            .push(outer * (1.0 - c_out) + sidewall * c_out + rng.gauss(ns * NOISE.temperature_c));
    }
}
