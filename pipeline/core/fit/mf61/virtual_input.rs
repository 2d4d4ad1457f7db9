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

use crate::fit::mf61::{Mf61Input, Mf61Sweep, Pac2002AtPressure, PressureGroup};
use crate::fit::pac2002::{self, FitConfig, FitInput, Sweep, SweepKind};
use crate::fit::segment_data::{MeasuredSegment, TireKey};
use crate::fit::spring_rate::{self, SpringRateConfig};
use crate::segment::{self, RunSignals, SegmentConfig};
use crate::synth::round::{Size, SynthConfig, block_truth, plan_round, render_run};
use crate::synth::tires::{CATALOGUE, KPA_PER_PSI, TruthForm, V_REF_MPS};
use crate::tire_model::{MagicFormula, SlipInput};
use crate::ttc::read_run;

/// One tire's MF 6.1 input from a virtual round, and its truth.
pub struct Prepared {
    /// The stage's input (every tested pressure).
    pub input: Mf61Input,
    /// The truth of the tire: its MF 6.1 model (under the default PAC2002 truth: the first
    /// tested pressure's PAC2002 set), settled (without run-order drift).
    pub truth: MagicFormula,
    /// The truth model of each tested pressure (kPa, nominal), `INFLPRES` set.
    pub pressure_truths: BTreeMap<i64, MagicFormula>,
    /// Per tested pressure (kPa, nominal): the commanded pressure (Pa) and the tested envelope
    /// (every sweep at its nominal load and inclination, and held slip angle, over the slip range
    /// it covered; `vx_mps` 0: the caller sets the speed).
    pub envelopes: BTreeMap<i64, (f64, Vec<SlipInput>)>,
}

/// The segments of every run of catalogue tire `tire_index` on rim `rim_in` (that tire and rim
/// of the full round of `config`), keyed by (tire, rim, nominal pressure), the truth of each
/// nominal pressure (kPa; under run-order drift the tire as that pressure's block saw it),
/// each nominal pressure's commanded pressure (kPa) and the settled tire's model (the first
/// tested pressure's truth without drift).
#[allow(clippy::type_complexity)]
fn segments(
    tire_index: usize,
    rim_in: f64,
    config: SynthConfig,
) -> (
    BTreeMap<TireKey, Vec<MeasuredSegment>>,
    BTreeMap<i64, MagicFormula>,
    BTreeMap<i64, f64>,
    MagicFormula,
) {
    let plan = plan_round(&SynthConfig {
        size: Size::Full,
        tires: vec![CATALOGUE[tire_index].name.to_string()],
        rims_in: vec![rim_in],
        ..config
    })
    .expect("plan");
    let combo = plan
        .combos
        .iter()
        .position(|c| c.tire_index == tire_index && (c.rim_in - rim_in).abs() < 1e-9)
        .expect("the tire and rim are in the full round");
    let mut out: BTreeMap<TireKey, Vec<MeasuredSegment>> = BTreeMap::new();
    let mut summaries = Vec::new();
    for (index, spec) in plan.runs.iter().enumerate() {
        if spec.combo != combo {
            continue;
        }
        let rendered = render_run(&plan, index).expect("render");
        summaries.push(rendered.summary.clone());
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
            out.entry(key.clone())
                .or_default()
                .push(MeasuredSegment::of_run(
                    &table,
                    &rendered.file.path,
                    &seg,
                    key.clone(),
                ));
        }
    }
    let truths = plan
        .truths
        .iter()
        .filter(|t| t.tire_index == tire_index && (t.rim_in - rim_in).abs() < 1e-9)
        .map(|t| {
            (
                t.pressure_kpa().round() as i64,
                block_truth(&plan, &summaries, t).model,
            )
        })
        .collect();
    let own: Vec<_> = plan
        .truths
        .iter()
        .filter(|t| t.tire_index == tire_index && (t.rim_in - rim_in).abs() < 1e-9)
        .collect();
    let commanded = own
        .iter()
        .map(|t| (t.pressure_kpa().round() as i64, t.pressure_kpa()))
        .collect();
    let settled = own.first().expect("a tested pressure").model.clone();
    (out, truths, commanded, settled)
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
        let gamma = (seg.nominal.ia_cdeg.unwrap_or(0) as f64 / 100.0).to_radians();
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
        context: spring_rate::pac2002_context(key, V_REF_MPS, vertical),
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
        pac2002: pac.map(|f| Pac2002AtPressure {
            p_pa,
            model: f.model,
            vertical_stiffness_n_per_m: vertical.map(|v| v.vertical_stiffness_n_per_m),
            unloaded_radius_m: vertical.map(|v| v.unloaded_radius_m),
        }),
    };
    (group, env)
}

/// Catalogue tire `tire_index` on rim `rim_in` of a round with an MF 6.1 truth: its runs
/// rendered, read, segmented and fitted per pressure (PAC2002), as the MF 6.1 stage's input.
pub fn prepare(tire_index: usize, rim_in: f64) -> Prepared {
    prepare_with(tire_index, rim_in, TruthForm::Mf61)
}

/// [`prepare`] with the truth form of the round.
pub fn prepare_with(tire_index: usize, rim_in: f64, form: TruthForm) -> Prepared {
    prepare_config(
        tire_index,
        rim_in,
        SynthConfig {
            truth: form,
            ..SynthConfig::default()
        },
    )
}

/// [`prepare`] from a round of `config` (its size, tires and rims set to the one tire and rim
/// of the full round). `truth` is the settled tire's model (the first tested pressure's under a
/// PAC2002 truth), `pressure_truths` each pressure's block (they differ under run-order drift).
pub fn prepare_config(tire_index: usize, rim_in: f64, config: SynthConfig) -> Prepared {
    let (per_key, pressure_truths, commanded_kpa, truth) = segments(tire_index, rim_in, config);
    let mut groups = Vec::new();
    let mut envelopes = BTreeMap::new();
    for (key, segs) in &per_key {
        let (group, env) = pressure_group(key, segs);
        let commanded = commanded_kpa[&key.pressure_kpa_nom];
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
        pressure_truths,
        envelopes,
    }
}
