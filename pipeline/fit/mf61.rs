//! The MF 6.1 model of one tire and rim across every tested pressure, after that combination's
//! per-pressure PAC2002 fits.
//!
//! In: per tested pressure an [`Mf61Part`] (its sweeps collapsed onto the slip grid, its written
//! PAC2002 model with the spring-rate vertical stiffness and unloaded radius), built by the group
//! run and kept small (no samples). Out: an [`Mf61Outcome`]: the `.tir` text
//! (`tir/<tire>__<rim>in__mf61.tir`, MF 6.1 layout, SI, ISO-W) with its coefficient rows and
//! lint, the fit (per pressure and family quality, in and out of sample), and failures as data
//! (keyed at the model's `NOMPRES`: a failed fit is a `fit_failures` row, never an `Err`; a
//! family flagged out of sample is a row keyed at the tested pressure it was flagged at).
//!
//! What goes where: the coefficients and `NOMPRES` (the tested pressure nearest the mean of the
//! tested ones), `PRESMIN`/`PRESMAX` (the measured range) and `PFZ1` (the trend of the
//! spring-rate stiffnesses over pressure) come from `tirebase_core::fit::mf61`; `RIM_WIDTH` from
//! the rim, `WIDTH`, `ASPECT_RATIO`, `RIM_RADIUS` from the size in the tire's name (left out
//! otherwise, as for PAC2002); `USE_MODE` that of the PAC2002 file nearest `NOMPRES`;
//! `BREFF`/`DREFF`/`FREFF` are that file's (the spring-rate stage's effective-radius law at that
//! pressure), with its origin, bound flag and reason.
//!
//! Deliberately not here: the fitting math (`tirebase_core::fit::mf61`), tables (`tables`).

use std::time::Instant;

use tirebase_core::fit::mf61::{
    self, CollapsedGroup, Mf61Config, Mf61Fit, Mf61Input, Mf61Sweep, Pac2002AtPressure,
};
use tirebase_core::fit::segment_data::TireKey;
use tirebase_core::fit::spring_rate::TirVertical;
use tirebase_core::fit::sweep_folds::OutOfSampleQuality;
use tirebase_core::naming::mf61_tir_file_name;
use tirebase_core::tire_model::tir::TirFile;
use tirebase_core::tire_model::tir::lint::Severity;
use tirebase_core::tire_model::{Coef, Section, Version};

use super::FitFailure;
use super::tir::{GEOMETRY, TirBuildError, WrittenCoefficient, WrittenModel, set_geometry};
use crate::config::FitModel;
use crate::store::results::{PRESSURE_TERMS_SCOPE, lint_scope};

/// Stage name in `fit_failures` and in the stage timings.
pub const STAGE: &str = "mf61";

/// What one tested pressure hands to the MF 6.1 stage.
#[derive(Clone, Debug)]
pub struct Mf61Part {
    /// The pressure group.
    pub key: TireKey,
    /// Its collapsed sweeps and PAC2002 start.
    pub group: CollapsedGroup,
    /// `USE_MODE` of its PAC2002 file.
    pub use_mode: Option<i64>,
    /// Its PAC2002 file's [`EFFECTIVE_RADIUS`] rows (origin, bound flag and note as written),
    /// which the MF 6.1 model takes from the tested pressure nearest `NOMPRES`.
    pub effective_radius: Vec<WrittenCoefficient>,
}

/// The effective-radius coefficients: not refined by the MF 6.1 fit, no pressure trend, so the
/// model holds the values of the PAC2002 file it starts from.
const EFFECTIVE_RADIUS: [Coef; 3] = [Coef::BREFF, Coef::DREFF, Coef::FREFF];

impl Mf61Part {
    /// The part of one group: its sweeps collapsed with `cfg`, its written PAC2002 file (if it
    /// has one) and the spring-rate stage's vertical numbers.
    pub fn new(
        key: &TireKey,
        sweeps: &[Mf61Sweep],
        pac2002: Option<&WrittenModel>,
        vertical: Option<&TirVertical>,
        cfg: &Mf61Config,
    ) -> Mf61Part {
        let nominal_pa = key.pressure_kpa_nom as f64 * 1e3;
        Mf61Part {
            key: key.clone(),
            group: CollapsedGroup {
                pressure_kpa_nom: key.pressure_kpa_nom,
                points: mf61::collapse_group(sweeps, &cfg.collapse),
                pac2002: pac2002.map(|m| Pac2002AtPressure {
                    p_pa: m
                        .file
                        .pressure
                        .inflation_pa
                        .filter(|p| p.is_finite() && *p > 0.0)
                        .unwrap_or(nominal_pa),
                    model: m.file.model(),
                    vertical_stiffness_n_per_m: vertical.map(|v| v.vertical_stiffness_n_per_m),
                    unloaded_radius_m: vertical.map(|v| v.unloaded_radius_m),
                }),
            },
            use_mode: pac2002.and_then(|m| m.file.use_mode),
            effective_radius: pac2002.map_or_else(Vec::new, |m| {
                m.coefficients
                    .iter()
                    .filter(|r| EFFECTIVE_RADIUS.contains(&r.coef))
                    .cloned()
                    .collect()
            }),
        }
    }
}

/// What the MF 6.1 stage produced for one tire and rim.
#[derive(Clone, Debug)]
pub struct Mf61Outcome {
    /// (tire, rim, `NOMPRES` in kPa): the key of its rows.
    pub key: TireKey,
    /// The file to write (`None` when the fit failed).
    pub model: Option<WrittenModel>,
    /// The fit.
    pub fit: Option<Mf61Fit>,
    /// Failures (fatal: no model) and skipped parts.
    pub failures: Vec<FitFailure>,
    /// Wall time, s.
    pub seconds: f64,
}

/// Fit the MF 6.1 model of one tire and rim from the parts of its tested pressures (any order).
pub fn run(tire: &str, rim_in: i64, parts: &[Mf61Part], cfg: &Mf61Config) -> Mf61Outcome {
    let started = Instant::now();
    let with_data: Vec<i64> = parts
        .iter()
        .filter(|p| !p.group.points.is_empty() || p.group.pac2002.is_some())
        .map(|p| p.key.pressure_kpa_nom)
        .collect();
    let all: Vec<i64> = parts.iter().map(|p| p.key.pressure_kpa_nom).collect();
    let nominal_pa = Mf61Input::nominal_for(if with_data.is_empty() {
        &all
    } else {
        &with_data
    });
    let key = TireKey {
        tire: tire.to_string(),
        rim_in,
        pressure_kpa_nom: (nominal_pa / 1e3).round() as i64,
    };
    let mut out = Mf61Outcome {
        key: key.clone(),
        model: None,
        fit: None,
        failures: Vec::new(),
        seconds: 0.0,
    };
    let fail = |out: &mut Mf61Outcome, scope: &str, fatal: bool, reason: String| {
        out.failures
            .push(FitFailure::new(&key, STAGE, scope, fatal, reason));
    };
    if parts.iter().all(|p| p.group.points.is_empty()) {
        fail(
            &mut out,
            STAGE,
            true,
            "no force-clean cornering, drive/brake or combined sweep at any tested pressure"
                .to_string(),
        );
        out.seconds = started.elapsed().as_secs_f64();
        return out;
    }
    let groups: Vec<CollapsedGroup> = parts.iter().map(|p| p.group.clone()).collect();
    let fit = match mf61::fit_collapsed(tire, rim_in as f64, nominal_pa, &groups, cfg) {
        Ok(fit) => fit,
        Err(e) => {
            fail(&mut out, STAGE, true, e.to_string());
            out.seconds = started.elapsed().as_secs_f64();
            return out;
        }
    };
    record_out_of_sample_flags(&mut out, &key, &fit, cfg.oos_ratio_limit);
    if with_data.len() < 2 {
        fail(
            &mut out,
            PRESSURE_TERMS_SCOPE,
            false,
            "one tested pressure: the model has no pressure terms (all 0)".to_string(),
        );
    }
    let use_mode = parts
        .iter()
        .filter(|p| p.use_mode.is_some())
        .min_by_key(|p| (p.key.pressure_kpa_nom - key.pressure_kpa_nom).abs())
        .and_then(|p| p.use_mode);
    let tested: Vec<i64> = {
        let mut v = with_data.clone();
        v.sort_unstable();
        v.dedup();
        v
    };
    let reference = parts
        .iter()
        .find(|p| p.key.pressure_kpa_nom == fit.start_reference_kpa);
    match build(&key, &fit, use_mode, &tested, reference) {
        Ok(m) => {
            for f in m
                .lint
                .findings
                .iter()
                .filter(|f| f.severity == Severity::Error)
            {
                fail(
                    &mut out,
                    &lint_scope(&m.file_name, f.code),
                    false,
                    f.message.clone(),
                );
            }
            out.model = Some(m);
        }
        Err(reason) => fail(&mut out, STAGE, true, reason.to_string()),
    }
    out.fit = Some(fit);
    out.seconds = started.elapsed().as_secs_f64();
    out
}

/// Families flagged out of sample ([`OutOfSampleQuality::oos_flagged`], the PAC2002 stage's
/// rule) as partial failures, one per tested pressure and family, keyed at that pressure.
fn record_out_of_sample_flags(out: &mut Mf61Outcome, key: &TireKey, fit: &Mf61Fit, limit: f64) {
    for q in fit.family_quality.iter().filter(|q| q.oos_flagged(limit)) {
        let at = TireKey {
            pressure_kpa_nom: q.pressure_kpa_nom,
            ..key.clone()
        };
        let lopo = q.lopo_rmse.map_or(String::new(), |l| {
            format!(
                "; leaving this pressure out: {l:.4} ({:.2}x)",
                q.lopo_ratio()
            )
        });
        let reason = super::out_of_sample_reason(q, limit, "by sweep over every tested pressure");
        out.failures.push(FitFailure::new(
            &at,
            STAGE,
            &crate::store::results::out_of_sample_scope(q.family.as_str()),
            false,
            format!("{reason}{lopo}"),
        ));
    }
}

/// The note of the rolling resistance rows (origin `placeholder`).
const MY_PLACEHOLDER_NOTE: &str = "placeholder, not fitted: TTC records no rolling resistance \
     moment (My); the value of the PAC2002 start, whose QSY1 is [fit] \
     rolling_resistance_placeholder (0 by default: My = 0)";

/// The coefficients table's family of a coefficient the refinement did not fit.
fn family_of_start(c: Coef) -> &'static str {
    match c {
        Coef::LONGITUDINAL_STIFFNESS
        | Coef::LATERAL_STIFFNESS
        | Coef::PCFX1
        | Coef::PCFX2
        | Coef::PCFX3
        | Coef::PCFY1
        | Coef::PCFY2
        | Coef::PCFY3 => "relaxation",
        _ => match c.section() {
            Section::Vertical | Section::Structural => "vertical",
            Section::Longitudinal => "longitudinal",
            Section::Lateral => "lateral",
            Section::Aligning => "aligning",
            Section::Overturning => "overturning",
            Section::Rolling => "rolling",
            _ => "scalar",
        },
    }
}

/// Say where the [`EFFECTIVE_RADIUS`] rows of origin `start` come from: the PAC2002 file of
/// `reference` (the tested pressure the start was lifted from). Where that file holds the same
/// value, the row takes its origin, bound flag and reason (a `BREFF` on an end of the
/// spring-rate stage's search interval stays marked); the note names the pressure either way.
fn attribute_effective_radius(
    rows: &mut [WrittenCoefficient],
    reference_kpa: i64,
    reference: Option<&Mf61Part>,
) {
    let whence = format!(
        "the PAC2002 file's value at {reference_kpa} kPa (the tested pressure nearest NOMPRES), \
         not refined over pressure"
    );
    for r in rows
        .iter_mut()
        .filter(|r| r.origin == "start" && EFFECTIVE_RADIUS.contains(&r.coef))
    {
        let source = reference
            .and_then(|p| p.effective_radius.iter().find(|s| s.coef == r.coef))
            .filter(|s| s.value == r.value);
        match source {
            Some(s) => {
                r.origin = s.origin.clone();
                r.at_bound = s.at_bound;
                r.note = Some(match &s.note {
                    Some(n) => format!("{whence}; there {n}"),
                    None => whence.clone(),
                });
            }
            None => r.note = Some(format!("lifted from {whence}")),
        }
    }
}

/// The `.tir` of a fit; `Err` (a one-line reason) when it cannot be rendered or read back.
/// `reference` is the part the start was lifted from (`Mf61Fit::start_reference_kpa`).
fn build(
    key: &TireKey,
    fit: &Mf61Fit,
    use_mode: Option<i64>,
    tested_kpa: &[i64],
    reference: Option<&Mf61Part>,
) -> Result<WrittenModel, TirBuildError> {
    let mut file = TirFile::from_coefs_as(fit.model.coefs.clone(), Version::Mf61);
    let mut rows: Vec<WrittenCoefficient> = fit
        .coefficients
        .iter()
        .map(|c| WrittenCoefficient {
            coef: c.coef,
            family: c.family.map_or_else(
                || family_of_start(c.coef).to_string(),
                |f| f.as_str().into(),
            ),
            value: c.value,
            std_error: c.std_error,
            at_bound: c.at_bound,
            origin: c.origin.to_string(),
            note: if c.origin == "placeholder" {
                Some(MY_PLACEHOLDER_NOTE.to_string())
            } else if c.note.is_some() {
                c.note.clone()
            } else {
                c.at_bound
                    .then(|| mf61::bound_note(c.coef, c.value))
                    .flatten()
            },
        })
        .collect();
    rows.retain(|r| !GEOMETRY.contains(&r.coef));
    attribute_effective_radius(&mut rows, fit.start_reference_kpa, reference);
    set_geometry(&mut file, &mut rows, &key.tire, key.rim_in);
    rows.sort_by_key(|r| r.coef);
    file.use_mode = use_mode.or(Some(4));
    file.header_comments = header_comments(key, fit, tested_kpa);
    WrittenModel::checked(
        FitModel::Mf61,
        &file,
        mf61_tir_file_name(&key.tire, key.rim_in as f64),
        rows,
    )
}

fn header_comments(key: &TireKey, fit: &Mf61Fit, tested_kpa: &[i64]) -> Vec<String> {
    let comment = |text: &str| format!("! : COMMENT :       {text}");
    let pressures: Vec<String> = tested_kpa.iter().map(|p| p.to_string()).collect();
    let families: Vec<String> = fit
        .families
        .iter()
        .map(|f| format!("{} rmse {:.4}", f.family.as_str(), f.rmse))
        .collect();
    let mut out = vec![format!("! : TIRE :          {}", key.tire)];
    out.extend(super::tir::rim_width_line(key.rim_in));
    out.extend([
        format!("! : NOMPRES_KPA :   {}", key.pressure_kpa_nom),
        comment(&format!(
            "{} on {}, MF 6.1 across {} kPa, fitted by tirebase fit {} on the \
             per-pressure PAC2002 fits",
            key.tire,
            super::tir::rim_phrase(key.rim_in),
            pressures.join(" / "),
            env!("CARGO_PKG_VERSION"),
        )),
        comment(&format!("families: {}", families.join(", "))),
    ]);
    out.extend(fit.notes.iter().map(|n| comment(&n.replace('\n', " "))));
    out
}
