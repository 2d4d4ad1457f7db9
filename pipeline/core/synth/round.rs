//! A whole virtual round: configuration, the run list, one run file at a time, and the truth.
//!
//! In: a [`SynthConfig`] (seed, size, realism, schedule knobs, defects on/off). Out:
//! [`plan_round`] -> [`RoundPlan`] (tires, truth models, runs); [`render_run`] -> one run file's
//! bytes plus its truth rows ([`RunOutput`]), pure and independent of every other run (its own
//! random stream keyed by seed, tire, rim and run), so the command layer may render runs in
//! parallel in any order; [`render_truth`] -> the truth `.tir`s, the truth TOMLs, `catalog.toml`,
//! `segments.csv`, `defects.csv` and `round.toml` ([`OutFile`]s with paths relative to the round
//! directory). Deliberately not here: the file system (the `synth round` command writes).
//!
//! Layout of a round directory: `raw/<files>`, `catalog.toml`, `truth/segments.csv`,
//! `truth/defects.csv`, `truth/round.toml`, `truth/<tire>__<rim>in.toml`, `truth/unit_errors.csv`
//! (only with the older-round quirk, [`super::quirks`]),
//! `truth/tir/<tire>__<rim>in__<P>kPa.tir` (names from [`crate::naming`]), and with
//! `truth = "mf61"` ([`TruthForm::Mf61`]) `truth/tir/<tire>__<rim>in__mf61.tir` (the one MF 6.1
//! model of every pressure; the per-pressure files are the same model with `INFLPRES` set).
//!
//! With run-order drift ([`super::drift`], `[synth.quirks.drift]`) each run starts from the
//! history its tire's earlier runs left ([`RunFileSpec::history`], from a noise-free pass in
//! [`plan_round`], so runs stay independent), and the per-pressure truth files are the tire as
//! that pressure's block of runs saw it ([`block_truth`]); the MF 6.1 truth file is the settled
//! tire.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::naming::{tir_file_name, tire_rim_stem};
use crate::tire_model::tir::{TirFile, TyrePressure};
use crate::tire_model::{Coef, Coefs};
use crate::ttc::dat::render_dat;
use crate::ttc::mat::{Compression, MatWriter};

use super::dat::{
    ChannelTable, Container, FileStyle, HeaderFields, STYLE_CYCLE, channel_table, header_line,
};
use super::defects::{DefectKind, DefectRecord, apply_to_table, apply_to_text};
use super::drift::{BlockDrift, TireHistory};
use super::machine::{LoadSwing, Realism, RunSamples, simulate};
use super::noise::Rng;
use super::physics::ThermalParams;
use super::quirks::{self, QuirksConfig, UnitErrorRow};
use super::schedule::{
    Program, RunKind, ScheduleConfig, SegmentKind, cornering_program, drive_brake_program,
    nominal_n,
};
use super::tires::{
    CATALOGUE, KPA_PER_PSI, P_REF_KPA, ThermalTruth, TruthForm, TruthModel, V_REF_MPS, base_coefs,
    mf61_truth, thermal_truth, truth_model, truth_model_mf61,
};

/// Why a round cannot be planned or a file not rendered.
#[derive(Debug, thiserror::Error)]
pub enum RoundError {
    /// The committed base `.tir` does not read (a build problem, never user input).
    #[error("synth/tires/fsae_demo_pac2002.tir: {message}")]
    BaseTire { message: String },
    /// A configuration value is out of range.
    #[error("[synth] {key} = {value}: {message}")]
    Config {
        key: &'static str,
        value: String,
        message: &'static str,
    },
    /// The `.tir` writer refused a truth model.
    #[error("{file}: {message}")]
    Tir { file: String, message: String },
    /// The MAT writer refused a variable.
    #[error("{file}: {message}")]
    Mat { file: String, message: String },
    /// A truth TOML could not be serialised.
    #[error("{file}: {message}")]
    Toml { file: String, message: String },
}

/// Round size.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Size {
    /// 4 tire/rim combinations (three tires, one of them on two rims), 2 pressures, every test
    /// kind (the main job's default data set).
    #[default]
    Demo,
    /// 12 tire/rim combinations, 4-5 pressure runs each, cornering and drive/brake.
    Full,
}

/// `[synth]` of the configuration file (every key optional; defaults below).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthConfig {
    /// Seed of every random stream.
    pub seed: u64,
    /// `demo` or `full`.
    pub size: Size,
    /// Calspan project number the round's files carry.
    pub project: u32,
    /// Inject the defects of a real round (recorded in `truth/defects.csv`).
    pub defects: bool,
    /// Truth model: `pac2002` (one PAC2002 set per pressure with the pressure effects folded in;
    /// not exactly one MF 6.1 model across pressures) or `mf61` (one MF 6.1 model per tire and
    /// rim with pressure terms, evaluated at each sample's true pressure; written as
    /// `truth/tir/<tire>__<rim>in__mf61.tir` too).
    pub truth: TruthForm,
    /// Catalogue tires to keep, by exact name (empty: every tire of the size); with `rims_in`, a
    /// smaller round for one tire, e.g. `size = "full"` with every pressure of that tire.
    pub tires: Vec<String>,
    /// Rim widths to keep, in (empty: every rim of the kept tires).
    pub rims_in: Vec<f64>,
    /// Realism knobs.
    pub realism: RealismConfig,
    /// Schedule knobs.
    pub schedule: ScheduleSettings,
    /// Quirks of real rounds (all off: the clean demo round).
    pub quirks: QuirksConfig,
}

impl Default for SynthConfig {
    fn default() -> Self {
        SynthConfig {
            seed: 2024,
            size: Size::Demo,
            project: 2410,
            defects: false,
            truth: TruthForm::Pac2002,
            tires: Vec::new(),
            rims_in: Vec::new(),
            realism: RealismConfig::default(),
            schedule: ScheduleSettings::default(),
            quirks: QuirksConfig::default(),
        }
    }
}

/// `[synth.realism]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RealismConfig {
    /// Multiplies every sensor noise and servo wander (0 = noise-free).
    pub noise_scale: f64,
    /// First-order relaxation of the forces with the truth relaxation lengths.
    pub lag: bool,
    /// Grip depends on the tread temperature (mu(T)).
    pub heat: bool,
    /// Air temperature, degC (also the cold tire's temperature).
    pub ambient_c: f64,
    /// Road (belt) temperature, degC.
    pub road_c: f64,
    /// Pure delay of the load cell's channels (Fx, Fy, Fz, Mx, Mz) behind the slip and speed
    /// channels: the rig's measurement chain, in time (0 = off), s.
    pub measurement_delay_s: f64,
    /// First-order filter time constant of the same channels after the delay (0 = off), s.
    pub measurement_filter_s: f64,
}

impl Default for RealismConfig {
    fn default() -> Self {
        let r = Realism::default();
        RealismConfig {
            noise_scale: r.noise_scale,
            lag: r.lag,
            heat: r.heat,
            ambient_c: r.ambient_c,
            road_c: r.road_c,
            measurement_delay_s: r.measurement_delay_s,
            measurement_filter_s: r.measurement_filter_s,
        }
    }
}

impl RealismConfig {
    /// Noise-free, lag-free, heat-free (what `--ideal` selects).
    pub fn ideal() -> RealismConfig {
        RealismConfig {
            noise_scale: 0.0,
            lag: false,
            heat: false,
            ..RealismConfig::default()
        }
    }

    fn resolve(&self) -> Realism {
        Realism {
            noise_scale: self.noise_scale,
            lag: self.lag,
            heat: self.heat,
            thermal: ThermalParams::default(),
            ambient_c: self.ambient_c,
            road_c: self.road_c,
            measurement_delay_s: self.measurement_delay_s,
            measurement_filter_s: self.measurement_filter_s,
            load_swing: None,
            drift: None,
            turnaround_ring: None,
        }
    }
}

/// `[synth.schedule]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScheduleSettings {
    /// Cooling dwell before every matrix and slip-ratio sweep, s.
    pub dwell_s: f64,
    /// Slip-angle rate of matrix, conditioning and speed sweeps, deg/s.
    pub sweep_rate_deg_s: f64,
    /// Slip-angle rate of the cold-to-warm sweeps, deg/s.
    pub cold_to_warm_rate_deg_s: f64,
    /// Slip-ratio rate of drive/brake sweeps, 1/s.
    pub slip_rate_per_s: f64,
    /// Hold time of each spring-rate load step, s.
    pub spring_step_s: f64,
}

impl Default for ScheduleSettings {
    fn default() -> Self {
        let s = ScheduleConfig::default();
        ScheduleSettings {
            dwell_s: s.dwell_s,
            sweep_rate_deg_s: s.sweep_rate_deg_s,
            cold_to_warm_rate_deg_s: s.cold_to_warm_rate_deg_s,
            slip_rate_per_s: s.slip_rate_per_s,
            spring_step_s: s.spring_step_s,
        }
    }
}

impl ScheduleSettings {
    fn resolve(&self) -> ScheduleConfig {
        ScheduleConfig {
            dwell_s: self.dwell_s,
            sweep_rate_deg_s: self.sweep_rate_deg_s,
            cold_to_warm_rate_deg_s: self.cold_to_warm_rate_deg_s,
            slip_rate_per_s: self.slip_rate_per_s,
            spring_step_s: self.spring_step_s,
        }
    }
}

impl SynthConfig {
    /// Check every value; the error names the key.
    pub fn validate(&self) -> Result<(), RoundError> {
        let bad = |key, value: f64, message| {
            Err(RoundError::Config {
                key,
                value: value.to_string(),
                message,
            })
        };
        let r = &self.realism;
        let s = &self.schedule;
        if !(r.noise_scale.is_finite() && r.noise_scale >= 0.0) {
            return bad(
                "realism.noise_scale",
                r.noise_scale,
                "must be a finite number >= 0",
            );
        }
        for (key, v, lo, hi) in [
            ("realism.ambient_c", r.ambient_c, -20.0, 50.0),
            ("realism.road_c", r.road_c, -20.0, 70.0),
            (
                "realism.measurement_delay_s",
                r.measurement_delay_s,
                0.0,
                0.5,
            ),
            (
                "realism.measurement_filter_s",
                r.measurement_filter_s,
                0.0,
                0.5,
            ),
            ("schedule.dwell_s", s.dwell_s, 0.0, 600.0),
            ("schedule.sweep_rate_deg_s", s.sweep_rate_deg_s, 0.5, 20.0),
            (
                "schedule.cold_to_warm_rate_deg_s",
                s.cold_to_warm_rate_deg_s,
                0.5,
                30.0,
            ),
            ("schedule.slip_rate_per_s", s.slip_rate_per_s, 0.01, 2.0),
            ("schedule.spring_step_s", s.spring_step_s, 0.2, 10.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return bad(key, v, "out of range (see config/default.toml)");
            }
        }
        if let Some((key, value, message)) = self.quirks.invalid() {
            return bad(key, value, message);
        }
        if let Some(name) = self
            .tires
            .iter()
            .find(|n| !CATALOGUE.iter().any(|t| t.name == n.as_str()))
        {
            return Err(RoundError::Config {
                key: "tires",
                value: format!("{name:?}"),
                message: "not a catalogue tire (synth::tires::CATALOGUE)",
            });
        }
        if let Some(rim) = self.rims_in.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
            return bad("rims_in", *rim, "must be a positive rim width, in");
        }
        if !(1..=99_999).contains(&self.project) {
            return bad(
                "project",
                f64::from(self.project),
                "must be between 1 and 99999",
            );
        }
        Ok(())
    }
}

/// A tire on a rim.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Combo {
    /// Index into [`CATALOGUE`].
    pub tire_index: usize,
    /// Rim width, in.
    pub rim_in: f64,
}

impl Combo {
    /// The tire's name.
    pub fn tire(&self) -> &'static str {
        CATALOGUE[self.tire_index].name
    }
}

/// One run file of the round.
#[derive(Clone, Debug, PartialEq)]
pub struct RunFileSpec {
    /// Run number (unique in the round, 1-based, at most 255: `.mat` stores RUN as uint8).
    pub run: u32,
    /// Index into [`RoundPlan::combos`].
    pub combo: usize,
    /// Commanded pressure, psi.
    pub pressure_psi: f64,
    /// Cornering or drive/brake.
    pub kind: RunKind,
    /// File format.
    pub style: FileStyle,
    /// File name (under `raw/`).
    pub file: String,
    /// Defects to inject (empty unless enabled).
    pub defects: Vec<DefectKind>,
    /// The tire's history at the start of the run (zero without run-order drift).
    pub history: TireHistory,
}

/// The round to generate.
#[derive(Clone, Debug)]
pub struct RoundPlan {
    /// The validated configuration.
    pub config: SynthConfig,
    /// Tire/rim combinations.
    pub combos: Vec<Combo>,
    /// Runs in run-number order.
    pub runs: Vec<RunFileSpec>,
    /// Truth per combination and distinct nominal pressure, ordered by (combo, pressure).
    pub truths: Vec<TruthModel>,
    /// Thermal truth per combination.
    pub thermal: Vec<ThermalTruth>,
    realism: Realism,
    schedule: ScheduleConfig,
}

/// Plan the round: combinations, truth models, run list, style and defect assignment.
pub fn plan_round(config: &SynthConfig) -> Result<RoundPlan, RoundError> {
    config.validate()?;
    let base = base_coefs()?;
    let (combos, n_pressures): (Vec<Combo>, Option<usize>) = match config.size {
        Size::Demo => (
            vec![
                Combo {
                    tire_index: 0,
                    rim_in: 7.0,
                },
                Combo {
                    tire_index: 1,
                    rim_in: 7.0,
                },
                Combo {
                    tire_index: 1,
                    rim_in: 8.0,
                },
                Combo {
                    tire_index: 5,
                    rim_in: 7.0,
                },
            ],
            Some(2),
        ),
        Size::Full => (
            CATALOGUE
                .iter()
                .enumerate()
                .flat_map(|(i, t)| {
                    t.rims_in.iter().map(move |&rim_in| Combo {
                        tire_index: i,
                        rim_in,
                    })
                })
                .collect(),
            None,
        ),
    };
    let combos: Vec<Combo> = combos
        .into_iter()
        .filter(|c| config.tires.is_empty() || config.tires.iter().any(|t| t == c.tire()))
        .filter(|c| {
            config.rims_in.is_empty() || config.rims_in.iter().any(|r| (r - c.rim_in).abs() < 1e-9)
        })
        .collect();
    if combos.is_empty() {
        return Err(RoundError::Config {
            key: "tires",
            value: format!("{:?} with rims_in = {:?}", config.tires, config.rims_in),
            message: "no tire and rim of the round's size matches",
        });
    }
    let mut runs = Vec::new();
    let mut truths = Vec::new();
    let mut thermal = Vec::new();
    for (ci, combo) in combos.iter().enumerate() {
        let tire = &CATALOGUE[combo.tire_index];
        let pressures = &config
            .quirks
            .pressures_psi(&tire.pressures_psi[..n_pressures.unwrap_or(tire.pressures_psi.len())]);
        let mut distinct: Vec<f64> = pressures.to_vec();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        let mf61 = match config.truth {
            TruthForm::Pac2002 => None,
            TruthForm::Mf61 => Some(mf61_truth(&base, combo.tire_index, combo.rim_in)?),
        };
        for &p in &distinct {
            truths.push(match &mf61 {
                None => truth_model(&base, combo.tire_index, combo.rim_in, p),
                Some(m) => truth_model_mf61(m, combo.tire_index, combo.rim_in, p),
            });
        }
        thermal.push(thermal_truth(INITIAL_T_PEAK_C, config.realism.ambient_c));
        for &p in pressures {
            for kind in [RunKind::Cornering, RunKind::DriveBrake] {
                let run = runs.len() as u32 + 1;
                let style = STYLE_CYCLE[(run as usize - 1 + ci) % STYLE_CYCLE.len()];
                runs.push(RunFileSpec {
                    run,
                    combo: ci,
                    pressure_psi: p,
                    kind,
                    style,
                    file: style.file_name(config.project, run),
                    defects: Vec::new(),
                    history: TireHistory::default(),
                });
            }
        }
    }
    if config.defects {
        let dat: Vec<usize> = (0..runs.len())
            .filter(|&i| runs[i].style.container == Container::Dat)
            .collect();
        for (k, kind) in DefectKind::ALL.iter().enumerate() {
            let i = dat[k % dat.len()];
            runs[i].defects.push(*kind);
        }
    }
    let mut plan = RoundPlan {
        config: config.clone(),
        combos,
        runs,
        truths,
        thermal,
        realism: config.realism.resolve(),
        schedule: config.schedule.resolve(),
    };
    if plan.realism.heat {
        let calibrated: Vec<ThermalTruth> = (0..plan.combos.len())
            .into_par_iter()
            .map(|ci| calibrate_thermal(&plan, ci))
            .collect();
        plan.thermal = calibrated;
    }
    if !plan.config.quirks.drift.is_off() {
        let histories = plan_histories(&plan);
        for (spec, h) in plan.runs.iter_mut().zip(histories) {
            spec.history = h;
        }
    }
    Ok(plan)
}

/// The tire's history at the start of every run (run order), for run-order drift: each
/// combination's runs simulated noise-free at 50 Hz in run order, each from the history its
/// predecessors left. The rendered runs add their own (noisy) slip energy live.
fn plan_histories(plan: &RoundPlan) -> Vec<TireHistory> {
    let drift = plan.config.quirks.drift;
    let per_combo: Vec<Vec<(usize, TireHistory)>> = (0..plan.combos.len())
        .into_par_iter()
        .map(|ci| {
            let mut h = TireHistory::default();
            let mut out = Vec::new();
            for (i, spec) in plan.runs.iter().enumerate().filter(|(_, s)| s.combo == ci) {
                out.push((i, h));
                let realism = Realism {
                    noise_scale: 0.0,
                    drift: Some((drift, h)),
                    ..plan.realism
                };
                let mut rng = Rng::for_stream(0, &[]);
                let truth = plan.truth(ci, spec.pressure_psi);
                let s = simulate(
                    &plan.program(spec),
                    truth,
                    &plan.thermal[ci],
                    &realism,
                    50.0,
                    &mut rng,
                );
                h = s.history_end;
            }
            out
        })
        .collect();
    let mut histories = vec![TireHistory::default(); plan.runs.len()];
    for (i, h) in per_combo.into_iter().flatten() {
        histories[i] = h;
    }
    histories
}

/// Whether a segment kind is a fitted sweep, and whether lateral (cornering) or longitudinal
/// (drive/brake, combined).
fn fitted_sweep(kind: SegmentKind) -> Option<bool> {
    match kind {
        SegmentKind::Cornering => Some(true),
        SegmentKind::DriveBrake | SegmentKind::Combined => Some(false),
        _ => None,
    }
}

/// The drift of a run over its fitted sweeps (`|F|/Fz`-weighted, as the thermal calibration).
fn block_drift(program: &Program, s: &RunSamples) -> BlockDrift {
    let mut b = BlockDrift::default();
    for seg in &program.segments {
        let Some(lateral) = fitted_sweep(seg.kind) else {
            continue;
        };
        for i in 0..s.et_s.len().min(s.drift_scales.len()) {
            let p = s.piece[i] as usize;
            if p >= seg.first_piece && p < seg.end_piece {
                let w = s.fx_n[i].hypot(s.fy_n[i]) / s.fz_n[i].max(1.0);
                let (mu, k) = s.drift_scales[i];
                b.add(lateral, w, mu, k);
            }
        }
    }
    b
}

/// The truth of a tested pressure as its block of runs saw it: `t` (the settled tire) with the
/// run-order drift's mean scalings over the block's fitted sweeps (`runs`: the round's run
/// summaries) folded into `LMUY`, `LKY` (cornering sweeps) and `LMUX`, `LKX` (drive/brake and
/// combined sweeps). `t` itself without drift.
pub fn block_truth(plan: &RoundPlan, runs: &[RunSummary], t: &TruthModel) -> TruthModel {
    let mut m = t.clone();
    if let Some(((mu_y, k_y), (mu_x, k_x))) = block_means(plan, runs, t) {
        m.model.coefs[Coef::LMUY] *= mu_y;
        m.model.coefs[Coef::LKY] *= k_y;
        m.model.coefs[Coef::LMUX] *= mu_x;
        m.model.coefs[Coef::LKX] *= k_x;
    }
    m
}

/// The block means `((mu, k) lateral, (mu, k) longitudinal)` of `t`'s pressure, `None` without
/// drift.
fn block_means(
    plan: &RoundPlan,
    runs: &[RunSummary],
    t: &TruthModel,
) -> Option<((f64, f64), (f64, f64))> {
    if plan.config.quirks.drift.is_off() {
        return None;
    }
    let mut b = BlockDrift::default();
    for r in runs {
        let c = plan.combos[r.spec.combo];
        if c.tire_index == t.tire_index
            && (c.rim_in - t.rim_in).abs() < 1e-9
            && (r.spec.pressure_psi - t.pressure_psi).abs() < 1e-9
            && let Some(d) = &r.drift
        {
            b.merge(d);
        }
    }
    Some(b.means())
}

/// Peak temperature the calibration starts from, degC.
const INITIAL_T_PEAK_C: f64 = 55.0;

/// Centre combination `ci`'s thermal law on its test temperatures: simulate (noise-free) its
/// cornering and drive/brake runs at the first planned pressure and collect the tread
/// temperatures of the fitted sweeps ([`ThermalTruth::centred_on`]).
fn calibrate_thermal(plan: &RoundPlan, ci: usize) -> ThermalTruth {
    let tire = &CATALOGUE[plan.combos[ci].tire_index];
    let pressure = tire.pressures_psi[0];
    let truth = plan.truth(ci, pressure);
    let realism = Realism {
        noise_scale: 0.0,
        ..plan.realism
    };
    let mut lateral = Vec::new();
    let mut longitudinal = Vec::new();
    for mut program in [
        cornering_program(tire, pressure, &plan.schedule),
        drive_brake_program(tire, pressure, &plan.schedule),
    ] {
        quirks::apply_to_program(&mut program, &plan.config.quirks);
        let mut rng = Rng::for_stream(0, &[]);
        let s = simulate(&program, truth, &plan.thermal[ci], &realism, 50.0, &mut rng);
        for seg in program.segments.iter().filter(|g| {
            matches!(
                g.kind,
                SegmentKind::Cornering | SegmentKind::DriveBrake | SegmentKind::Combined
            )
        }) {
            let into = if seg.kind == SegmentKind::Cornering {
                &mut lateral
            } else {
                &mut longitudinal
            };
            for i in 0..s.et_s.len() {
                let p = s.piece[i] as usize;
                if p >= seg.first_piece && p < seg.end_piece {
                    let w = s.fx_n[i].hypot(s.fy_n[i]) / s.fz_n[i].max(1.0);
                    into.push((s.surface_true_c[i], w));
                }
            }
        }
    }
    plan.thermal[ci].centred_on(&lateral, &longitudinal)
}

impl RoundPlan {
    /// The truth model of a combination at a nominal pressure.
    pub fn truth(&self, combo: usize, pressure_psi: f64) -> &TruthModel {
        let c = &self.combos[combo];
        self.truths
            .iter()
            .find(|t| {
                t.tire_index == c.tire_index
                    && (t.rim_in - c.rim_in).abs() < 1e-9
                    && (t.pressure_psi - pressure_psi).abs() < 1e-9
            })
            .expect("every planned pressure has a truth model")
    }

    /// The commanded program of a run.
    pub fn program(&self, spec: &RunFileSpec) -> Program {
        let tire = &CATALOGUE[self.combos[spec.combo].tire_index];
        let mut program = match spec.kind {
            RunKind::Cornering => cornering_program(tire, spec.pressure_psi, &self.schedule),
            RunKind::DriveBrake => drive_brake_program(tire, spec.pressure_psi, &self.schedule),
        };
        quirks::apply_to_program(&mut program, &self.config.quirks);
        program
    }

    /// The resolved machine realism.
    pub fn realism(&self) -> &Realism {
        &self.realism
    }
}

/// A file to write, path relative to the round directory (`/`-separated).
#[derive(Clone, Debug, PartialEq)]
pub struct OutFile {
    pub path: String,
    pub bytes: Vec<u8>,
}

/// One truth row of `segments.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthSegmentRow {
    pub file: String,
    pub project: u32,
    pub run: u32,
    pub kind: SegmentKind,
    pub et_start_s: f64,
    pub et_end_s: f64,
    pub pressure_kpa_nom: f64,
    pub ia_deg_nom: Option<f64>,
    pub fz_n_nom: Option<f64>,
    pub alpha_deg_nom: Option<f64>,
    pub speed_kph_nom: Option<f64>,
    pub tire: String,
    pub rim_in: f64,
    pub n_samples: usize,
    /// First data row (1-based) of the segment in the file.
    pub row_first: usize,
}

/// Everything about one run except its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub spec: RunFileSpec,
    pub rows: usize,
    pub segments: Vec<TruthSegmentRow>,
    pub defects: Vec<DefectRecord>,
    /// Radius channels written in a wrong unit (older-round quirk).
    pub unit_errors: Vec<UnitErrorRow>,
    /// The run-order drift over the run's fitted sweeps (`None` without drift).
    pub drift: Option<BlockDrift>,
}

/// One rendered run file.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOutput {
    pub file: OutFile,
    pub summary: RunSummary,
}

/// Simulate and encode run `index` of the plan (pure; independent of every other run).
pub fn render_run(plan: &RoundPlan, index: usize) -> Result<RunOutput, RoundError> {
    let spec = &plan.runs[index];
    let combo = plan.combos[spec.combo];
    let truth = plan.truth(spec.combo, spec.pressure_psi);
    let thermal = &plan.thermal[spec.combo];
    let program = plan.program(spec);
    let key = [
        combo.tire_index as u64,
        (combo.rim_in * 10.0).round() as u64,
        u64::from(spec.run),
    ];
    let mut rng = Rng::for_stream(plan.config.seed, &key);
    let q = &plan.config.quirks;
    let rate = q.rate_hz(&spec.style);
    let mut realism = plan.realism;
    if q.older_round && q.load_swing_frac > 0.0 {
        let mut swing_rng = Rng::for_stream(plan.config.seed, &[key[0], key[1], key[2], 0x5157]);
        realism.load_swing = Some(LoadSwing {
            frac: q.load_swing_frac,
            period_s: 0.5 + 1.5 * swing_rng.uniform(),
            phase_rad: std::f64::consts::TAU * swing_rng.uniform(),
        });
    }
    if !q.drift.is_off() {
        realism.drift = Some((q.drift, spec.history));
    }
    realism.turnaround_ring = q.turnaround_ring();
    let samples = simulate(&program, truth, thermal, &realism, rate, &mut rng);
    let drift = realism.drift.map(|_| block_drift(&program, &samples));

    let keep: Vec<usize> = (0..samples.et_s.len())
        .filter(|&i| spec.style.raw || !samples.dwell[i])
        .collect();
    let with_sl = !q.older_round
        && (spec.style.container == Container::Mat || spec.kind == RunKind::DriveBrake);
    let mut table = channel_table(&samples, &keep, &spec.style, with_sl);
    let unit_errors = quirks::apply_to_table(&mut table, &spec.style, &spec.file, q);
    round_to_decimals(&mut table);
    let segments = segment_rows(plan, spec, &program, &samples.piece, &keep, &table);

    let mut defects = Vec::new();
    for (k, kind) in spec.defects.iter().enumerate() {
        if kind.on_table() {
            let seg = &segments[(segments.len() * (3 + k) / 10).min(segments.len() - 1)];
            let at = seg.row_first - 1 + seg.n_samples / 2;
            defects.push(apply_to_table(&mut table, *kind, at, &spec.file));
        }
    }

    let mut meta_rng = Rng::for_stream(plan.config.seed, &[key[0], key[1], key[2], 0x1D]);
    let bytes = match spec.style.container {
        Container::Dat => {
            let (date, time) = run_date_time(spec.run);
            let id = file_id(&mut meta_rng);
            let line1 = header_line(
                &spec.style,
                &HeaderFields {
                    project: plan.config.project,
                    run: spec.run,
                    date: &date,
                    time: &time,
                    tire_name: combo.tire(),
                    rim_in: combo.rim_in,
                    id: &id,
                },
            );
            let mut bytes = render_dat(&line1, &table.columns);
            for kind in spec.defects.iter().filter(|k| !k.on_table()) {
                defects.push(apply_to_text(&mut bytes, *kind, &table, &spec.file));
            }
            bytes
        }
        Container::Mat => render_mat(plan, spec, &table)?,
    };
    Ok(RunOutput {
        file: OutFile {
            path: format!("raw/{}", spec.file),
            bytes,
        },
        summary: RunSummary {
            spec: spec.clone(),
            rows: table.rows(),
            segments,
            defects,
            unit_errors,
            drift,
        },
    })
}

/// Round every column to its decimals, so `.mat` holds what `.dat` prints.
fn round_to_decimals(table: &mut ChannelTable) {
    for c in &mut table.columns {
        let scale = 10f64.powi(i32::from(c.decimals));
        for v in &mut c.values {
            *v = (*v * scale).round() / scale;
        }
    }
}

fn segment_rows(
    plan: &RoundPlan,
    spec: &RunFileSpec,
    program: &Program,
    piece_of_sample: &[u32],
    keep: &[usize],
    table: &ChannelTable,
) -> Vec<TruthSegmentRow> {
    let combo = plan.combos[spec.combo];
    let et = &table.column("ET").expect("ET").values;
    let mut rows = Vec::new();
    for seg in &program.segments {
        let inside = |row: &usize| {
            let p = piece_of_sample[keep[*row]] as usize;
            p >= seg.first_piece && p < seg.end_piece
        };
        let Some(first) = (0..keep.len()).find(inside) else {
            continue;
        };
        let last = (first..keep.len())
            .take_while(|r| inside(r))
            .last()
            .unwrap_or(first);
        rows.push(TruthSegmentRow {
            file: spec.file.clone(),
            project: plan.config.project,
            run: spec.run,
            kind: seg.kind,
            et_start_s: et[first],
            et_end_s: et[last],
            pressure_kpa_nom: seg.nominal.pressure_kpa,
            ia_deg_nom: seg.nominal.ia_deg,
            fz_n_nom: seg.nominal.fz_n,
            alpha_deg_nom: seg.nominal.alpha_deg,
            speed_kph_nom: seg.nominal.speed_kph,
            tire: combo.tire().to_string(),
            rim_in: combo.rim_in,
            n_samples: last - first + 1,
            row_first: first + 1,
        });
    }
    rows
}

/// Deterministic test date and time of a run (`MM-DD-YYYY`, `HH:MM`).
fn run_date_time(run: u32) -> (String, String) {
    let day = 3 + (run - 1) / 12;
    let minutes = 8 * 60 + ((run - 1) % 12) * 47;
    (
        format!("03-{day:02}-2024"),
        format!("{:02}:{:02}", minutes / 60, minutes % 60),
    )
}

/// A 7-character ID like the ones in round-8/9 headers.
fn file_id(rng: &mut Rng) -> String {
    const ALPHABET: &[u8] = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    (0..7)
        .map(|_| ALPHABET[rng.below(ALPHABET.len() as u64) as usize] as char)
        .collect()
}

/// `tireid` text: `<tire>, <rim> inch rim`.
fn tire_id(combo: &Combo) -> String {
    format!(
        "{}, {} inch rim",
        combo.tire(),
        crate::naming::rim_label(combo.rim_in)
    )
}

fn render_mat(
    plan: &RoundPlan,
    spec: &RunFileSpec,
    table: &ChannelTable,
) -> Result<Vec<u8>, RoundError> {
    let combo = plan.combos[spec.combo];
    let err = |e: crate::ttc::mat::MatWriteError| RoundError::Mat {
        file: spec.file.clone(),
        message: e.to_string(),
    };
    let compression = if spec.style.raw {
        Compression::Zlib
    } else {
        Compression::None
    };
    let (date, _) = run_date_time(spec.run);
    let mut w = MatWriter::new(&format!(
        "MATLAB 5.0 MAT-file, Platform: PCWIN64, Created on: {date} (tirebase synth)"
    ));
    for c in &table.columns {
        w.push_column(&c.name, &c.values, compression)
            .map_err(err)?;
    }
    let run_u8 = u8::try_from(spec.run).unwrap_or(u8::MAX);
    w.push_uint8_column("RUN", &vec![run_u8; table.rows()], compression)
        .map_err(err)?;
    let names: Vec<&str> = table.columns.iter().map(|c| c.name.as_str()).collect();
    let units: Vec<&str> = table.columns.iter().map(|c| c.unit.as_str()).collect();
    // Older rounds' .mat files carry no unit metadata at all.
    if !plan.config.quirks.older_round {
        w.push_struct_of_text_cells(
            "channel",
            &[("name", &names), ("units", &units)],
            compression,
        )
        .map_err(err)?;
    }
    let source = spec.file.replace(".mat", ".dat");
    w.push_text("source", &source, compression).map_err(err)?;
    w.push_text("testid", spec.kind.test_id(), compression)
        .map_err(err)?;
    w.push_text("tireid", &tire_id(&combo), compression)
        .map_err(err)?;
    Ok(w.finish())
}

/// The style name recorded in `catalog.toml` comments and `round.toml`.
fn style_label(style: &FileStyle) -> String {
    let round = style.round.label();
    format!(
        "{round} {} {:?} {} Hz {}",
        match style.container {
            Container::Dat => "dat",
            Container::Mat => "mat",
        },
        style.units,
        style.rate_hz(),
        if style.raw { "raw" } else { "run" }
    )
}

/// Truth TOML of one tire and rim.
#[derive(Serialize)]
struct TruthToml {
    tire: String,
    rim_in: f64,
    generator: &'static str,
    reference_speed_mps: f64,
    reference_pressure_kpa: f64,
    /// `mf61` under [`TruthForm::Mf61`] (absent for the default PAC2002 truth).
    #[serde(skip_serializing_if = "Option::is_none")]
    truth: Option<&'static str>,
    /// The MF 6.1 truth file of every pressure (`tir/<tire>__<rim>in__mf61.tir`).
    #[serde(skip_serializing_if = "Option::is_none")]
    mf61_tir: Option<String>,
    pressure: Vec<PressureTruthToml>,
    relaxation: RelaxationLawToml,
    thermal: ThermalToml,
    realism: RealismConfig,
}

#[derive(Serialize)]
struct PressureTruthToml {
    pressure_kpa_nom: f64,
    pressure_psi: f64,
    tir: String,
    vertical_stiffness_static_n_per_m: f64,
    vertical_stiffness_dynamic_n_per_m: f64,
    unloaded_radius_static_m: f64,
    unloaded_radius_dynamic_m: f64,
    fnomin_n: f64,
    /// PAC2002 relaxation coefficients (absent for an MF 6.1 truth: its lengths are `|Kx/Cx|`,
    /// `|Ky/Cy|`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pty1: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pty2: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pky3: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ptx1: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ptx2: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ptx3: Option<f64>,
    /// sigma_alpha at the nominal loads, IA 0, m.
    sigma_alpha_m: BTreeMap<String, f64>,
    /// sigma_kappa at the nominal loads, m.
    sigma_kappa_m: BTreeMap<String, f64>,
    /// Run-order drift: the block's mean scalings folded into the truth `.tir` (absent without
    /// drift).
    #[serde(skip_serializing_if = "Option::is_none")]
    run_order_drift: Option<BlockDriftToml>,
}

/// The scalings of a pressure's block (`LMUY`, `LKY` over its cornering sweeps; `LMUX`, `LKX`
/// over its drive/brake and combined sweeps) and the history its first run started from.
#[derive(Serialize)]
struct BlockDriftToml {
    lmuy: f64,
    lky: f64,
    lmux: f64,
    lkx: f64,
    /// The tested order of the block's first run among its tire's runs (1 = tested first).
    first_run_order: usize,
    /// Slip energy dissipated before the block's first run, kJ.
    slip_energy_before_kj: f64,
    /// Distance rolled before the block's first run, km.
    distance_before_km: f64,
}

#[derive(Serialize)]
struct RelaxationLawToml {
    lateral: &'static str,
    longitudinal: &'static str,
    lag: &'static str,
    dynamic_radius: &'static str,
    effective_radius: &'static str,
}

#[derive(Serialize)]
struct ThermalToml {
    t_peak_c: f64,
    gain_peak_over_cold: f64,
    t_cold_c: f64,
    hot_falloff: f64,
    t_matrix_ref_c: f64,
    t_ref_longitudinal_c: f64,
    mu_rel_floor: f64,
    law: &'static str,
    applied_as: &'static str,
    temperature_seen_by_grip: &'static str,
    ir_phase_lag: &'static str,
    surface_gain_k_per_j: f64,
    bulk_gain_k_per_j: f64,
    surface_to_bulk_per_s: f64,
    bulk_to_surface_per_s: f64,
    road_cooling_per_s: f64,
    road_cooling_standstill_per_s: f64,
    air_cooling_per_s: f64,
    bulk_cooling_per_s: f64,
    rolling_loss: f64,
    ambient_c: f64,
    road_c: f64,
}

/// The truth and index files of the round, from the plan and every run's summary.
pub fn render_truth(plan: &RoundPlan, runs: &[RunSummary]) -> Result<Vec<OutFile>, RoundError> {
    let mut out = Vec::new();
    let drift = !plan.config.quirks.drift.is_off();
    for t in &plan.truths {
        let combo_name = CATALOGUE[t.tire_index].name;
        let name = tir_file_name(combo_name, t.rim_in, t.pressure_kpa());
        let file = truth_tir(
            &block_truth(plan, runs, t),
            &format!(
                "at {:.1} psi ({:.0} kPa){}",
                t.pressure_psi,
                t.pressure_kpa(),
                if drift {
                    ", as its block of runs saw it (run-order drift)"
                } else {
                    ""
                }
            ),
        );
        out.push(render_tir(&file, &name)?);
    }
    if plan.config.truth == TruthForm::Mf61 {
        for combo in &plan.combos {
            let t = plan
                .truths
                .iter()
                .find(|t| {
                    t.tire_index == combo.tire_index && (t.rim_in - combo.rim_in).abs() < 1e-9
                })
                .expect("every combination has a truth");
            let mut model = t.clone();
            model.model.coefs[Coef::INFLPRES] = model.model.coefs[Coef::NOMPRES];
            let name = mf61_tir_file_name(combo.tire(), combo.rim_in);
            let file = truth_tir(
                &model,
                if drift {
                    "at every pressure (MF 6.1, INFLPRES = NOMPRES), settled (no run-order drift)"
                } else {
                    "at every pressure (MF 6.1, INFLPRES = NOMPRES)"
                },
            );
            out.push(render_tir(&file, &name)?);
        }
    }
    for (ci, combo) in plan.combos.iter().enumerate() {
        let path = format!("truth/{}.toml", tire_rim_stem(combo.tire(), combo.rim_in));
        let toml = truth_toml(plan, ci, runs);
        let text = toml::to_string(&toml).map_err(|e| RoundError::Toml {
            file: path.clone(),
            message: e.to_string(),
        })?;
        out.push(OutFile {
            path,
            bytes: text.into_bytes(),
        });
    }
    out.push(OutFile {
        path: "catalog.toml".to_string(),
        bytes: catalog_toml(plan).into_bytes(),
    });
    out.push(OutFile {
        path: "truth/segments.csv".to_string(),
        bytes: segments_csv(runs).into_bytes(),
    });
    out.push(OutFile {
        path: "truth/defects.csv".to_string(),
        bytes: defects_csv(runs).into_bytes(),
    });
    let unit_errors: Vec<UnitErrorRow> = runs
        .iter()
        .flat_map(|r| r.unit_errors.iter().cloned())
        .collect();
    if !unit_errors.is_empty() {
        out.push(OutFile {
            path: "truth/unit_errors.csv".to_string(),
            bytes: quirks::unit_errors_csv(&unit_errors).into_bytes(),
        });
    }
    let round = toml::to_string(&RoundToml::of(&plan.config)).map_err(|e| RoundError::Toml {
        file: "truth/round.toml".to_string(),
        message: e.to_string(),
    })?;
    out.push(OutFile {
        path: "truth/round.toml".to_string(),
        bytes: round.into_bytes(),
    });
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// The truth `.tir` of `t`; `at` says which pressure(s) it describes.
fn truth_tir(t: &TruthModel, at: &str) -> TirFile {
    let combo_name = CATALOGUE[t.tire_index].name;
    let mut file = if t.model.version.is_mf6() {
        // MF 6.x carries NOMPRES and INFLPRES as coefficients.
        TirFile::from_coefs_as(t.model.coefs.clone(), t.model.version)
    } else {
        let mut file = TirFile::from_coefs(t.model.coefs.clone());
        file.pressure = TyrePressure {
            inflation_pa: Some(t.pressure_kpa() * 1000.0),
            nominal_pa: Some(P_REF_KPA * 1000.0),
        };
        file
    };
    file.header_comments = vec![
        format!(
            "! : COMMENT :       {combo_name} on a {} in rim {at}",
            t.rim_in
        ),
        "! : COMMENT :       TRUTH model of the tirebase virtual test machine (synthetic, not measured)".to_string(),
    ];
    file
}

fn render_tir(file: &TirFile, name: &str) -> Result<OutFile, RoundError> {
    let text = file.render().map_err(|e| RoundError::Tir {
        file: name.to_string(),
        message: e.to_string(),
    })?;
    Ok(OutFile {
        path: format!("truth/tir/{name}"),
        bytes: text.into_bytes(),
    })
}

/// The file name of a tire's MF 6.1 truth: `<tire>__<rim>in__mf61.tir`.
pub fn mf61_tir_file_name(tire: &str, rim_in: f64) -> String {
    format!("{}__mf61.tir", tire_rim_stem(tire, rim_in))
}

/// `round.toml`: the resolved `[synth]` table. `truth`, `tires` and `rims_in` are written only
/// when they are not the defaults, so a default round's files keep the bytes they had before
/// those options existed.
#[derive(Serialize)]
struct RoundToml<'a> {
    synth: RoundSynthToml<'a>,
}

#[derive(Serialize)]
struct RoundSynthToml<'a> {
    seed: u64,
    size: Size,
    project: u32,
    defects: bool,
    #[serde(skip_serializing_if = "TruthForm::is_pac2002")]
    truth: TruthForm,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    tires: &'a [String],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    rims_in: &'a [f64],
    realism: &'a RealismConfig,
    schedule: &'a ScheduleSettings,
    quirks: &'a QuirksConfig,
}

impl<'a> RoundToml<'a> {
    fn of(c: &'a SynthConfig) -> RoundToml<'a> {
        let SynthConfig {
            seed,
            size,
            project,
            defects,
            truth,
            tires,
            rims_in,
            realism,
            schedule,
            quirks,
        } = c;
        RoundToml {
            synth: RoundSynthToml {
                seed: *seed,
                size: *size,
                project: *project,
                defects: *defects,
                truth: *truth,
                tires,
                rims_in,
                realism,
                schedule,
                quirks,
            },
        }
    }
}

fn truth_toml(plan: &RoundPlan, ci: usize, runs: &[RunSummary]) -> TruthToml {
    let combo = plan.combos[ci];
    let mf61 = plan.config.truth == TruthForm::Mf61;
    let th = plan.thermal[ci];
    let p = plan.realism.thermal;
    let ten = CATALOGUE[combo.tire_index].ten_inch();
    let loads_lb: &[f64] = if ten {
        &[50.0, 100.0, 150.0, 200.0, 250.0]
    } else {
        &[50.0, 100.0, 150.0, 250.0, 350.0]
    };
    let pressure = plan
        .truths
        .iter()
        .filter(|t| t.tire_index == combo.tire_index && (t.rim_in - combo.rim_in).abs() < 1e-9)
        .map(|t| {
            let c: &Coefs<f64> = &t.model.coefs;
            let mut sa = BTreeMap::new();
            let mut sk = BTreeMap::new();
            for &lb in loads_lb {
                let fz = nominal_n(lb);
                let (k, a) = t.model.relaxation_lengths(fz, 0.0);
                sa.insert(format!("{fz:.0}"), a);
                sk.insert(format!("{fz:.0}"), k);
            }
            let pac = !t.model.version.is_mf6();
            let pac_coef = |k: Coef| pac.then_some(c[k]);
            PressureTruthToml {
                pressure_kpa_nom: t.pressure_kpa().round(),
                pressure_psi: t.pressure_psi,
                tir: format!(
                    "tir/{}",
                    tir_file_name(combo.tire(), combo.rim_in, t.pressure_kpa())
                ),
                vertical_stiffness_static_n_per_m: t.vertical.cz_static_n_per_m,
                vertical_stiffness_dynamic_n_per_m: t.vertical.cz_dynamic_n_per_m,
                unloaded_radius_static_m: t.vertical.r0_static_m,
                unloaded_radius_dynamic_m: t.vertical.r0_dynamic_m,
                fnomin_n: c[Coef::FNOMIN],
                pty1: pac_coef(Coef::PTY1),
                pty2: pac_coef(Coef::PTY2),
                pky3: pac_coef(Coef::PKY3),
                ptx1: pac_coef(Coef::PTX1),
                ptx2: pac_coef(Coef::PTX2),
                ptx3: pac_coef(Coef::PTX3),
                sigma_alpha_m: sa,
                sigma_kappa_m: sk,
                run_order_drift: block_means(plan, runs, t).map(|((lmuy, lky), (lmux, lkx))| {
                    let own: Vec<&RunFileSpec> =
                        plan.runs.iter().filter(|r| r.combo == ci).collect();
                    let first = own
                        .iter()
                        .position(|r| (r.pressure_psi - t.pressure_psi).abs() < 1e-9)
                        .unwrap_or(0);
                    let h = own.get(first).map(|r| r.history).unwrap_or_default();
                    BlockDriftToml {
                        lmuy,
                        lky,
                        lmux,
                        lkx,
                        first_run_order: first + 1,
                        slip_energy_before_kj: h.slip_energy_j / 1e3,
                        distance_before_km: h.distance_m / 1e3,
                    }
                }),
            }
        })
        .collect();
    TruthToml {
        tire: combo.tire().to_string(),
        rim_in: combo.rim_in,
        generator: "tirebase synth (virtual TTC test machine)",
        reference_speed_mps: V_REF_MPS,
        reference_pressure_kpa: P_REF_KPA,
        truth: mf61.then_some(TruthForm::Mf61.as_str()),
        mf61_tir: mf61.then(|| format!("tir/{}", mf61_tir_file_name(combo.tire(), combo.rim_in))),
        pressure,
        relaxation: RelaxationLawToml {
            lateral: if mf61 {
                "sigma_alpha = |Ky/Cy|, Cy = LATERAL_STIFFNESS (1 + PCFY1 dfz + PCFY2 dfz^2)(1 + PCFY3 dpi) (MF 6.1, as in the truth .tir, at the sample's true pressure)"
            } else {
                "sigma_alpha = PTY1 sin(2 atan(Fz/(PTY2 FNOMIN))) (1 - PKY3 |gamma|) R0, R0 = unloaded_radius_dynamic_m (PAC2002, as in the truth .tir)"
            },
            longitudinal: if mf61 {
                "sigma_kappa = |Kx/Cx|, Cx = LONGITUDINAL_STIFFNESS (1 + PCFX1 dfz + PCFX2 dfz^2)(1 + PCFX3 dpi) (MF 6.1)"
            } else {
                "sigma_kappa = Fz (PTX1 + PTX2 dfz) exp(-PTX3 dfz) R0/FNOMIN, dfz = (Fz - FNOMIN)/FNOMIN (PAC2002)"
            },
            lag: "dF/dt = V/sigma (F_ss - F), exact first-order-hold steps; Fy, Mz and Mx with sigma_alpha, Fx with sigma_kappa",
            dynamic_radius: "RL = R0(V) - Fz/Cz(V); R0(V) = r0_static + (r0_dynamic - r0_static)(V/V_ref)^2; Cz(V) = cz_static + (cz_dynamic - cz_static) V/V_ref",
            effective_radius: "RE = R0(V) - (FNOMIN/Cz(V)) (DREFF atan(BREFF Fz/FNOMIN) + FREFF Fz/FNOMIN); SL = kappa; SR = Omega RL/V - 1, Omega = V (1 + kappa)/RE",
        },
        thermal: ThermalToml {
            t_peak_c: th.t_peak_c,
            gain_peak_over_cold: th.gain_peak_over_cold,
            t_cold_c: th.t_cold_c,
            hot_falloff: th.hot_falloff,
            t_matrix_ref_c: th.t_matrix_ref_c,
            t_ref_longitudinal_c: th.t_ref_longitudinal_c,
            mu_rel_floor: super::tires::MU_REL_FLOOR,
            law: "mu_rel(T) = 1 - a ((T - t_peak)/(t_peak - t_cold))^2, a = 1 - 1/(1 + gain) below t_peak and hot_falloff a above, floored at mu_rel_floor",
            applied_as: "LMUY = mu_rel(T)/mu_rel(t_matrix_ref), LMUX = mu_rel(T)/mu_rel(t_ref_longitudinal); t_peak is centred on the cornering matrix and each reference is where mu_rel equals the |F|/Fz-weighted mean mu_rel of its sweeps, so the truth .tir has no thermal bias on average",
            temperature_seen_by_grip: "tread surface temperature at the contact",
            ir_phase_lag: "TSTC(t) = surface(t - 0.75 * 2 pi RE/V); TSTI/TSTO offset +1.8/-1.2 degC per deg IA; clip to ambient+6 when |Fy|/Fz exceeds 1.9 (inner, Fy < 0 ISO-W) or 2.4 (outer)",
            surface_gain_k_per_j: p.surface_gain_k_per_j,
            bulk_gain_k_per_j: p.bulk_gain_k_per_j,
            surface_to_bulk_per_s: p.surface_to_bulk_per_s,
            bulk_to_surface_per_s: p.bulk_to_surface_per_s,
            road_cooling_per_s: p.road_cooling_per_s,
            road_cooling_standstill_per_s: p.road_cooling_standstill_per_s,
            air_cooling_per_s: p.air_cooling_per_s,
            bulk_cooling_per_s: p.bulk_cooling_per_s,
            rolling_loss: p.rolling_loss,
            ambient_c: plan.realism.ambient_c,
            road_c: plan.realism.road_c,
        },
        realism: plan.config.realism.clone(),
    }
}

/// `catalog.toml` in the ingest issue's format (`[[run]] project, run, tire, rim_in, kind`).
fn catalog_toml(plan: &RoundPlan) -> String {
    let mut s = String::from(
        "# Run guide of a tirebase virtual round: which tire and rim each run file holds.\n",
    );
    for r in &plan.runs {
        let combo = plan.combos[r.combo];
        let _ = write!(
            s,
            "\n# {} ({}), {:.0} kPa\n[[run]]\nproject = {}\nrun = {}\ntire = \"{}\"\nrim_in = {}\nkind = \"{}\"\n",
            r.file,
            style_label(&r.style),
            r.pressure_psi * KPA_PER_PSI,
            plan.config.project,
            r.run,
            combo.tire(),
            crate::naming::rim_label(combo.rim_in),
            r.kind.as_str()
        );
    }
    s
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or(String::new(), |x| format!("{x:.decimals$}"))
}

/// `segments.csv`: one row per generated segment, sorted by file and start time.
pub fn segments_csv(runs: &[RunSummary]) -> String {
    let mut rows: Vec<&TruthSegmentRow> = runs.iter().flat_map(|r| &r.segments).collect();
    rows.sort_by(|a, b| {
        (a.run, a.file.as_str())
            .cmp(&(b.run, b.file.as_str()))
            .then(a.et_start_s.total_cmp(&b.et_start_s))
    });
    let mut s = String::from(
        "file,project,run,kind,et_start_s,et_end_s,pressure_kpa_nom,ia_deg_nom,fz_n_nom,alpha_deg_nom,speed_kph_nom,tire,rim_in,n_samples,row_first\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{:.3},{:.3},{:.0},{},{},{},{},{},{},{},{}",
            r.file,
            r.project,
            r.run,
            r.kind.as_str(),
            r.et_start_s,
            r.et_end_s,
            r.pressure_kpa_nom,
            r.ia_deg_nom
                .map_or(String::new(), |v| crate::segment::ia_cdeg_text(
                    crate::segment::ia_cdeg_label(v)
                )),
            opt(r.fz_n_nom, 0),
            opt(r.alpha_deg_nom, 0),
            opt(r.speed_kph_nom, 2),
            r.tire,
            crate::naming::rim_label(r.rim_in),
            r.n_samples,
            r.row_first
        );
    }
    s
}

/// `defects.csv`: one row per injected defect.
pub fn defects_csv(runs: &[RunSummary]) -> String {
    let mut rows: Vec<&DefectRecord> = runs.iter().flat_map(|r| &r.defects).collect();
    rows.sort_by(|a, b| (a.file.as_str(), a.kind).cmp(&(b.file.as_str(), b.kind)));
    let mut s = String::from("file,kind,channel,et_start_s,et_end_s,row_first,row_last\n");
    for d in rows {
        let _ = writeln!(
            s,
            "{},{},{},{:.3},{:.3},{},{}",
            d.file,
            d.kind.as_str(),
            d.channel,
            d.et_start_s,
            d.et_end_s,
            d.row_first,
            d.row_last
        );
    }
    s
}
