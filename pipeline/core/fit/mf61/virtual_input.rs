//! Test and bench support: one tire's [`Mf61Input`] from a virtual round whose truth is one MF 6.1
//! model (`[synth] truth = "mf61"`), through the raw files.
//!
//! In: a catalogue tire and rim. Out: [`Prepared`]: the MF 6.1 input, the truth model and each
//! tested pressure's envelope. `synth` renders the tire's runs of the full round (default
//! realism: sensor noise, servo wander, relaxation lag, tread heating with mu(T)), the TTC reader
//! parses each file, the segmenter cuts it, and per pressure the spring-rate and PAC2002 stages
//! run on the segments as the pipeline's group runner does (without de-lagging). Not covered: the
//! store (Parquet), ingest's per-segment QC (every sweep is taken as force-clean), `Mx` (the
//! core's segments carry no overturning moment). Written against `crate::` paths only, so the
//! `fit_mf61` bench compiles it too (with re-exporting shims).

use std::collections::BTreeMap;

use crate::fit::mf61::{Mf61Input, Mf61Sweep, PressureGroup, PressureModel};
use crate::fit::pac2002::{self, FitConfig, FitContext, FitInput, Sweep, SweepKind};
use crate::fit::segment_data::{Channels, MeasuredSegment, NominalLevels, TireKey};
use crate::fit::spring_rate::{self, SpringRateConfig};
use crate::segment::{self, RunSignals, SegmentConfig};
use crate::synth::round::{Size, SynthConfig, plan_round, render_run};
use crate::synth::tires::{CATALOGUE, KPA_PER_PSI, TruthForm, V_REF_MPS};
use crate::tire_model::{MagicFormula, SlipInput};
use crate::ttc::{RunTable, read_run};

/// One tire's MF 6.1 input from a virtual round, and its truth.
pub struct Prepared {
    /// The stage's input (every tested pressure).
    pub input: Mf61Input,
    /// The MF 6.1 truth of the tire.
    pub truth: MagicFormula,
    /// Per tested pressure (kPa, nominal): the commanded pressure (Pa) and the tested envelope
    /// (every sweep at its nominal load and inclination, and held slip angle, over the slip range
    /// it covered; `vx_mps` 0: the caller sets the speed).
    pub envelopes: BTreeMap<i64, (f64, Vec<SlipInput>)>,
}

fn channels(table: &RunTable, r: std::ops::Range<usize>) -> Channels {
    let slice = |v: &[f64]| v[r.clone()].to_vec();
    let opt = |v: &Option<Vec<f64>>| v.as_ref().map(|v| slice(v));
    let t = &table.tire;
    Channels {
        et_s: slice(&table.et_s),
        speed_kph: slice(&table.speed_kph),
        fz_n: slice(&t.fz_n),
        fx_n: slice(&t.fx_n),
        fy_n: slice(&t.fy_n),
        mz_nm: slice(&t.mz_nm),
        alpha_rad: slice(&t.alpha_rad),
        gamma_rad: slice(&t.gamma_rad),
        kappa: slice(&t.kappa),
        pressure_kpa: slice(&table.pressure_kpa),
        loaded_radius_m: opt(&table.loaded_radius_m),
        effective_radius_m: opt(&table.effective_radius_m),
        wheel_speed_rpm: opt(&table.wheel_speed_rpm),
        tread_inner_c: opt(&table.tread_inner_temp_c),
        tread_centre_c: opt(&table.tread_centre_temp_c),
        tread_outer_c: opt(&table.tread_outer_temp_c),
        ambient_c: opt(&table.ambient_temp_c),
    }
}

/// The segments of every run of catalogue tire `tire_index` on rim `rim_in` (full round, MF 6.1
/// truth), keyed by (tire, rim, nominal pressure), and the truth.
fn segments(
    tire_index: usize,
    rim_in: f64,
) -> (BTreeMap<TireKey, Vec<MeasuredSegment>>, MagicFormula) {
    let plan = plan_round(&SynthConfig {
        size: Size::Full,
        truth: TruthForm::Mf61,
        ..SynthConfig::default()
    })
    .expect("plan");
    let combo = plan
        .combos
        .iter()
        .position(|c| c.tire_index == tire_index && (c.rim_in - rim_in).abs() < 1e-9)
        .expect("the tire and rim are in the full round");
    let mut out: BTreeMap<TireKey, Vec<MeasuredSegment>> = BTreeMap::new();
    for (index, spec) in plan.runs.iter().enumerate() {
        if spec.combo != combo {
            continue;
        }
        let rendered = render_run(&plan, index).expect("render");
        let table = read_run(&rendered.file.bytes, &rendered.file.path).expect("read");
        let empty: Vec<f64> = Vec::new();
        let rl = table.loaded_radius_m.as_ref().unwrap_or(&empty);
        let signals = RunSignals::from_iso_w(
            &table.tire,
            &table.et_s,
            &table.speed_kph,
            &table.pressure_kpa,
            rl,
        );
        let (segs, _) = segment::run(&signals, &SegmentConfig::default()).expect("segment");
        let key = TireKey {
            tire: CATALOGUE[tire_index].name.to_string(),
            rim_in: rim_in.round() as i64,
            pressure_kpa_nom: (spec.pressure_psi * KPA_PER_PSI).round() as i64,
        };
        for seg in segs {
            out.entry(key.clone()).or_default().push(MeasuredSegment {
                segment_id: format!("{}-{}", rendered.file.path, seg.index),
                kind: seg.kind,
                source_file: rendered.file.path.clone(),
                segment_index: seg.index as i64,
                key: key.clone(),
                nominal: NominalLevels {
                    ia_deg: seg.nominal.ia_deg.map(i64::from),
                    fz_n: seg.nominal.fz_n.map(i64::from),
                    alpha_deg: seg.nominal.alpha_deg.map(i64::from),
                    speed_kph: seg.nominal.speed_kph.map(i64::from),
                },
                channels: channels(&table, seg.samples.clone()),
            });
        }
    }
    let truth = plan
        .truths
        .iter()
        .find(|t| t.tire_index == tire_index && (t.rim_in - rim_in).abs() < 1e-9)
        .expect("truth")
        .model
        .clone();
    (out, truth)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn envelope(sweeps: &[(Mf61Sweep, &MeasuredSegment)]) -> Vec<SlipInput> {
    let mut out = Vec::new();
    for (sweep, seg) in sweeps {
        let fz = seg.nominal.fz_n.unwrap_or(0) as f64;
        let gamma = (seg.nominal.ia_deg.unwrap_or(0) as f64).to_radians();
        let alpha = (seg.nominal.alpha_deg.unwrap_or(0) as f64).to_radians();
        let cornering = sweep.kind == SweepKind::Cornering;
        let slip: Vec<f64> = sweep
            .samples
            .iter()
            .map(|s| if cornering { s.alpha_rad } else { s.kappa })
            .collect();
        let lo = slip.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = slip.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for k in 0..=40 {
            let x = lo + (hi - lo) * k as f64 / 40.0;
            out.push(SlipInput {
                fz_n: fz,
                kappa: if cornering { 0.0 } else { x },
                alpha_rad: if cornering { x } else { alpha },
                gamma_rad: gamma,
                vx_mps: 0.0,
            });
        }
    }
    out
}

/// The per-pressure stages of one group: spring rate, then PAC2002 with its `Cz`, `R0`.
fn pressure_group(key: &TireKey, segs: &[MeasuredSegment]) -> (PressureGroup, Vec<SlipInput>) {
    let sr = spring_rate::run(segs, &BTreeMap::new(), &SpringRateConfig::default());
    let vertical = sr.vertical.first();
    let used: Vec<&MeasuredSegment> = segs
        .iter()
        .filter(|s| Sweep::from_segment(s, None, true).is_some())
        .collect();
    let input = FitInput {
        context: FitContext {
            tire: key.tire.clone(),
            rim_in: key.rim_in as f64,
            pressure_kpa_nom: key.pressure_kpa_nom as f64,
            test_speed_mps: V_REF_MPS,
            vertical_stiffness_n_per_m: vertical.map(|v| v.vertical_stiffness_n_per_m),
            unloaded_radius_m: vertical.map(|v| v.unloaded_radius_m),
            relaxation: None,
        },
        sweeps: used
            .iter()
            .filter_map(|s| Sweep::from_segment(s, None, true))
            .collect(),
    };
    let pac = pac2002::fit(&input, &FitConfig::default()).ok();
    let p_pa = 1e3
        * median(
            used.iter()
                .flat_map(|s| s.channels.pressure_kpa.iter().copied())
                .collect(),
        );
    let sweeps: Vec<(Mf61Sweep, &MeasuredSegment)> = used
        .iter()
        .filter_map(|s| Mf61Sweep::from_segment(s, None).map(|m| (m, *s)))
        .collect();
    let env = envelope(&sweeps);
    let group = PressureGroup {
        pressure_kpa_nom: key.pressure_kpa_nom,
        sweeps: sweeps.into_iter().map(|(m, _)| m).collect(),
        pac2002: pac.map(|f| PressureModel {
            p_pa,
            model: f.model,
            vertical_stiffness_n_per_m: vertical.map(|v| v.vertical_stiffness_n_per_m),
            unloaded_radius_m: vertical.map(|v| v.unloaded_radius_m),
        }),
    };
    (group, env)
}

/// Catalogue tire `tire_index` on rim `rim_in`: its runs rendered, read, segmented and fitted
/// per pressure (PAC2002), as the MF 6.1 stage's input.
pub fn prepare(tire_index: usize, rim_in: f64) -> Prepared {
    let (per_key, truth) = segments(tire_index, rim_in);
    let mut groups = Vec::new();
    let mut envelopes = BTreeMap::new();
    for (key, segs) in &per_key {
        let (group, env) = pressure_group(key, segs);
        let commanded = CATALOGUE[tire_index]
            .pressures_psi
            .iter()
            .map(|psi| psi * KPA_PER_PSI)
            .find(|kpa| kpa.round() as i64 == key.pressure_kpa_nom)
            .expect("a planned pressure");
        envelopes.insert(key.pressure_kpa_nom, (commanded * 1e3, env));
        groups.push(group);
    }
    let pressures: Vec<i64> = groups.iter().map(|g| g.pressure_kpa_nom).collect();
    Prepared {
        input: Mf61Input {
            tire: CATALOGUE[tire_index].name.to_string(),
            rim_in,
            nominal_pa: Mf61Input::nominal_for(&pressures),
            groups,
        },
        truth,
        envelopes,
    }
}
