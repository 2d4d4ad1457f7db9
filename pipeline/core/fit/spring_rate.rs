//! Spring-rate stage: vertical stiffness and unloaded radius (seed 8.4, D.6), the same from the
//! free-rolling zero crossings of every slip sweep (the thesis's future work), and the effective
//! rolling radius law (`BREFF`, `DREFF`, `FREFF`) for the `.tir`.
//!
//! In: [`MeasuredSegment`]s of one or more tires (spring-rate holds, cornering/drive-brake/speed
//! sweeps; other kinds are ignored) and `FNOMIN` per tire (the PAC2002 fit's nominal load, which
//! normalises the RE law). Out: [`SpringRateOutput`]: one [`SpringRateRow`] per (tire, rim,
//! pressure, IA, condition[, speed]), one [`TirVertical`] per tire/rim/pressure (the `.tir`'s
//! VERTICAL_STIFFNESS, UNLOADED_RADIUS, BREFF/DREFF/FREFF) and the failures as data.
//!
//! Method: `RL = R0 - Fz/Cz` by linear least squares of the loaded radius on the load (the load is
//! measured ~100x more precisely, relative to its span, than RL, so RL is the dependent variable
//! and one fit gives both numbers: the thesis's two `polyfit`s disagree under noise). Holds use
//! every sample; sweeps use the samples within `free_rolling_alpha_rad`/`free_rolling_kappa` of
//! zero slip, pooled over the loads of one (pressure, IA, speed). The RE law
//! `RE = R0 - (Fz0/Cz)(DREFF atan(BREFF Fz/Fz0) + FREFF Fz/Fz0)` is fitted with `R0`, `Cz` from
//! the dynamic fit: `DREFF`, `FREFF` are linear given `BREFF`, so `BREFF` alone is searched
//! (variable projection, grid + Brent).
//!
//! Deliberately not here: reading the store, writing tables or `.tir` files, PAC2002 fitting.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use super::pac2002::FitContext;
use super::scalar::{self, ScalarOptions};
use super::segment_data::{MeasuredSegment, SegmentKind, StageFailure, TireKey, finite_mean};
use crate::numerics::{NumericsError, least_squares};
use crate::physical::{RADIUS_M, VERTICAL_STIFFNESS_N_PER_M, within};

/// Where a stiffness comes from.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Condition {
    /// Spring-rate hold at standstill.
    Static,
    /// Spring-rate hold rolling at road speed.
    Dynamic,
    /// Free-rolling zero crossings of slip sweeps across loads.
    Sweep,
}

impl Condition {
    /// The `condition` column value.
    pub fn as_str(self) -> &'static str {
        match self {
            Condition::Static => "static",
            Condition::Dynamic => "dynamic",
            Condition::Sweep => "sweep",
        }
    }
}

/// Stage knobs.
#[derive(Copy, Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpringRateConfig {
    /// A sweep sample is free rolling when `|alpha|` is below this, rad.
    pub free_rolling_alpha_rad: f64,
    /// ... and `|kappa|` below this.
    pub free_rolling_kappa: f64,
    /// Samples with less load than this are ignored (tire barely touching), N.
    pub min_fz_n: f64,
    /// A fit needs at least this many samples.
    pub min_samples: usize,
    /// ... spread over at least this load span, N.
    pub min_load_span_n: f64,
    /// RE samples need at least this road speed, km/h.
    pub min_rolling_speed_kph: f64,
    /// Sweep samples count for the RE law when their speed is within this fraction of the
    /// dynamic holds' speed.
    pub re_speed_tolerance: f64,
    /// Search interval of `BREFF`.
    pub breff_range: (f64, f64),
}

impl Default for SpringRateConfig {
    fn default() -> Self {
        SpringRateConfig {
            free_rolling_alpha_rad: 0.25_f64.to_radians(),
            free_rolling_kappa: 0.005,
            min_fz_n: 20.0,
            min_samples: 20,
            min_load_span_n: 200.0,
            min_rolling_speed_kph: 5.0,
            re_speed_tolerance: 0.1,
            breff_range: (0.05, 200.0),
        }
    }
}

/// One row of `spring_rate.parquet`.
#[derive(Clone, Debug, PartialEq)]
pub struct SpringRateRow {
    /// Tire, rim, nominal pressure.
    pub key: TireKey,
    /// Mean measured pressure of the samples used, kPa.
    pub pressure_kpa_mean: f64,
    /// Nominal inclination angle, hundredths of a degree; `None` when not held (swept).
    pub ia_cdeg_nom: Option<i64>,
    /// Static, dynamic or sweep.
    pub condition: Condition,
    /// Vertical stiffness `Cz`, N/m.
    pub stiffness_n_per_m: f64,
    /// Standard uncertainty of `Cz`, N/m.
    pub stiffness_std_n_per_m: f64,
    /// Unloaded radius `R0` (the RL intercept at zero load), m.
    pub unloaded_radius_m: f64,
    /// Standard uncertainty of `R0`, m.
    pub unloaded_radius_std_m: f64,
    /// Samples used.
    pub n: usize,
    /// Segments the samples come from.
    pub n_segments: usize,
    /// Coefficient of determination of RL on Fz.
    pub r2: f64,
    /// RMS residual of RL, m.
    pub residual_rms_m: f64,
    /// Mean road speed of the samples, km/h.
    pub speed_kph: f64,
    /// Load range used, N.
    pub fz_n_min: f64,
    /// Load range used, N.
    pub fz_n_max: f64,
}

/// Why a spring-rate row, the `.tir` vertical numbers or the effective-radius law could not be
/// produced (recorded as a [`StageFailure`] reason).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpringRateError {
    /// Too few samples with both a loaded radius and a load.
    #[error("{n} usable samples (loaded radius and load), need {need}")]
    TooFewSamples {
        /// Usable samples.
        n: usize,
        /// `min_samples`.
        need: usize,
    },
    /// The load did not vary enough to fit a line.
    #[error("load span {span_n:.0} N, need {need_n:.0} N")]
    LoadSpan {
        /// Load span of the pool, N.
        span_n: f64,
        /// `min_load_span_n`.
        need_n: f64,
    },
    /// The loaded radius grows with the load.
    #[error("loaded radius grows with load (slope {slope_m_per_n:.3e} m/N)")]
    RadiusGrows {
        /// Fitted slope, m/N.
        slope_m_per_n: f64,
    },
    /// The fitted unloaded radius is no tire's.
    #[error(
        "unloaded radius {r0_m:.4} m outside a tire's {}..{} m (loaded radius in another unit?)",
        RADIUS_M.0,
        RADIUS_M.1
    )]
    Radius {
        /// Fitted unloaded radius, m.
        r0_m: f64,
    },
    /// The fitted vertical stiffness is no tire's.
    #[error(
        "vertical stiffness {cz_n_per_m:.0} N/m outside a tire's {:.0}..{:.0} N/m",
        VERTICAL_STIFFNESS_N_PER_M.0,
        VERTICAL_STIFFNESS_N_PER_M.1
    )]
    Stiffness {
        /// Fitted vertical stiffness, N/m.
        cz_n_per_m: f64,
    },
    /// The straight-line fit failed.
    #[error(transparent)]
    Line(#[from] NumericsError),
    /// No row to take `VERTICAL_STIFFNESS` and `UNLOADED_RADIUS` from.
    #[error("no dynamic spring-rate or sweep row")]
    NoVerticalRow,
    /// No `FNOMIN` to fit the effective-radius law with.
    #[error("no FNOMIN for this tire")]
    NoFnomin,
    /// Too few rolling samples with an effective radius.
    #[error("{n} rolling samples with RE, need {need}")]
    TooFewRolling {
        /// Usable samples.
        n: usize,
        /// `min_samples`.
        need: usize,
    },
    /// The search over `BREFF` failed.
    #[error(transparent)]
    Search(#[from] scalar::ScalarError),
    /// The effective-radius design is singular.
    #[error("RE law: degenerate design (one load only?)")]
    DegenerateReLaw,
}

/// The PAC2002 stage's context of tire `key` tested at `test_speed_mps`, with `Cz` and `R0`
/// from the spring-rate stage's [`TirVertical`] when it produced one (the fit estimates them
/// otherwise) and no relaxation lengths.
pub fn pac2002_context(
    key: &TireKey,
    test_speed_mps: f64,
    vertical: Option<&TirVertical>,
) -> FitContext {
    FitContext {
        tire: key.tire.clone(),
        rim_in: key.rim_in as f64,
        pressure_kpa_nom: key.pressure_kpa_nom as f64,
        test_speed_mps,
        vertical_stiffness_n_per_m: vertical.map(|v| v.vertical_stiffness_n_per_m),
        unloaded_radius_m: vertical.map(|v| v.unloaded_radius_m),
        relaxation: None,
    }
}

/// What the `.tir` VERTICAL and DIMENSION sections need, per tire/rim/pressure.
#[derive(Clone, Debug, PartialEq)]
pub struct TirVertical {
    /// Tire, rim, nominal pressure.
    pub key: TireKey,
    /// `VERTICAL_STIFFNESS`: dynamic (rolling at test speed), N/m.
    pub vertical_stiffness_n_per_m: f64,
    /// `UNLOADED_RADIUS`: dynamic (rolling at test speed), m.
    pub unloaded_radius_m: f64,
    /// Which rows the two numbers come from (`dynamic ia 0`, `dynamic mean`, `sweep`).
    pub source: String,
    /// Speed of those rows, km/h.
    pub speed_kph: f64,
    /// Effective rolling radius law, `None` when it could not be fitted (see failures).
    pub effective_radius: Option<EffectiveRadiusLaw>,
}

/// `BREFF`, `DREFF`, `FREFF` and how well they reproduce RE.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectiveRadiusLaw {
    /// `BREFF`.
    pub breff: f64,
    /// `DREFF`.
    pub dreff: f64,
    /// `FREFF`.
    pub freff: f64,
    /// `FNOMIN` used to normalise the load, N.
    pub fnomin_n: f64,
    /// RMS residual of RE, m.
    pub rmse_m: f64,
    /// Samples used.
    pub n: usize,
    /// `BREFF` hit its search bound (the law is then poorly determined).
    pub at_bound: bool,
}

/// Everything the stage produces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpringRateOutput {
    /// Rows sorted by (key, condition, IA, speed).
    pub rows: Vec<SpringRateRow>,
    /// One per tire/rim/pressure with a usable dynamic or sweep row.
    pub vertical: Vec<TirVertical>,
    /// Parts that could not run.
    pub failures: Vec<StageFailure>,
}

/// Samples of one group: `(fz, rl, re, speed, pressure)` and the segment count.
#[derive(Default)]
struct Pool {
    fz: Vec<f64>,
    rl: Vec<f64>,
    re: Vec<f64>,
    speed: Vec<f64>,
    pressure: Vec<f64>,
    segments: usize,
}

/// Group key: tire, condition, IA, speed bin (sweeps only).
/// How far from zero (hundredths of a degree) a held inclination still counts as upright for
/// the `.tir` vertical numbers.
const UPRIGHT_CDEG: i64 = 50;

/// A held inclination level as printed in a scope or source (`1.6`, `-1`), `swept` when none.
fn ia_text(ia_cdeg: Option<i64>) -> String {
    ia_cdeg.map_or_else(|| "swept".to_string(), crate::segment::ia_cdeg_text)
}

type GroupKey = (TireKey, Condition, Option<i64>, i64);

/// Run the stage over every tire in `segments`. `fnomin_n` gives the nominal load per tire; a
/// tire without one gets rows but no RE law (recorded as a failure).
pub fn run(
    segments: &[MeasuredSegment],
    fnomin_n: &BTreeMap<TireKey, f64>,
    cfg: &SpringRateConfig,
) -> SpringRateOutput {
    let mut out = SpringRateOutput::default();
    let mut groups: BTreeMap<GroupKey, Pool> = BTreeMap::new();
    for seg in segments {
        if let Some(mismatch) = seg.channels.length_mismatch() {
            out.failures.push(StageFailure {
                key: seg.key.clone(),
                scope: format!("segment {}", seg.segment_id),
                reason: format!(
                    "channel {} has {} samples, et_s has {}",
                    mismatch.0,
                    mismatch.1,
                    seg.channels.len()
                ),
            });
            continue;
        }
        let Some(condition) = condition_of(seg.kind) else {
            continue;
        };
        let ia = seg.nominal.ia_cdeg;
        let speed_bin = match condition {
            Condition::Sweep => seg.nominal.speed_kph.unwrap_or(-1),
            _ => 0,
        };
        let pool = groups
            .entry((seg.key.clone(), condition, ia, speed_bin))
            .or_default();
        if collect(seg, condition, cfg, pool) > 0 {
            pool.segments += 1;
        }
    }
    for ((key, condition, ia, speed_bin), pool) in &groups {
        match fit_group(key, *condition, *ia, pool, cfg) {
            Ok(row) => out.rows.push(row),
            Err(reason) => out.failures.push(StageFailure {
                key: key.clone(),
                // Sweeps are pooled per nominal speed: name it (a speed sweep at one load is
                // the usual skip, not the main-speed sweeps).
                scope: match condition {
                    Condition::Sweep => format!("sweep ia {} at {speed_bin} km/h", ia_text(*ia)),
                    _ => format!("{} ia {}", condition.as_str(), ia_text(*ia)),
                },
                reason: reason.to_string(),
            }),
        }
    }
    out.rows.sort_by(|a, b| {
        (&a.key, a.condition, a.ia_cdeg_nom)
            .cmp(&(&b.key, b.condition, b.ia_cdeg_nom))
            .then(a.speed_kph.total_cmp(&b.speed_kph))
    });
    let keys: Vec<TireKey> = {
        let mut k: Vec<TireKey> = groups.keys().map(|g| g.0.clone()).collect();
        k.dedup();
        k
    };
    for key in keys {
        match tir_vertical(&key, &out.rows, &groups, fnomin_n.get(&key).copied(), cfg) {
            Ok((vertical, re_failure)) => {
                if let Some(reason) = re_failure {
                    out.failures.push(StageFailure {
                        key: key.clone(),
                        scope: "effective radius".to_string(),
                        reason: reason.to_string(),
                    });
                }
                out.vertical.push(vertical);
            }
            Err(reason) => out.failures.push(StageFailure {
                key,
                scope: "tir vertical".to_string(),
                reason: reason.to_string(),
            }),
        }
    }
    out
}

fn condition_of(kind: SegmentKind) -> Option<Condition> {
    match kind {
        SegmentKind::SpringRateStatic => Some(Condition::Static),
        SegmentKind::SpringRateDynamic => Some(Condition::Dynamic),
        SegmentKind::Cornering
        | SegmentKind::DriveBrake
        | SegmentKind::Conditioning
        | SegmentKind::SpeedSweep => Some(Condition::Sweep),
        _ => None,
    }
}

/// Add the usable samples of `seg` to `pool`; returns how many.
fn collect(
    seg: &MeasuredSegment,
    condition: Condition,
    cfg: &SpringRateConfig,
    pool: &mut Pool,
) -> usize {
    let c = &seg.channels;
    let Some(rl) = c.loaded_radius_m.as_ref() else {
        return 0;
    };
    let mut added = 0;
    for i in 0..c.len() {
        let usable = rl[i].is_finite()
            && rl[i] > 0.0
            && c.fz_n[i].is_finite()
            && c.fz_n[i] >= cfg.min_fz_n
            && match condition {
                Condition::Static | Condition::Dynamic => true,
                Condition::Sweep => {
                    c.alpha_rad[i].abs() <= cfg.free_rolling_alpha_rad
                        && c.kappa[i].abs() <= cfg.free_rolling_kappa
                        && c.speed_kph[i] >= cfg.min_rolling_speed_kph
                }
            };
        if !usable {
            continue;
        }
        pool.fz.push(c.fz_n[i]);
        pool.rl.push(rl[i]);
        pool.re.push(
            c.effective_radius_m
                .as_ref()
                .map_or(f64::NAN, |re| if re[i] > 0.0 { re[i] } else { f64::NAN }),
        );
        pool.speed.push(c.speed_kph[i]);
        pool.pressure.push(c.pressure_kpa[i]);
        added += 1;
    }
    added
}

/// `RL = R0 - Fz/Cz` over a pool.
fn fit_group(
    key: &TireKey,
    condition: Condition,
    ia: Option<i64>,
    pool: &Pool,
    cfg: &SpringRateConfig,
) -> Result<SpringRateRow, SpringRateError> {
    let n = pool.fz.len();
    if n < cfg.min_samples {
        return Err(SpringRateError::TooFewSamples {
            n,
            need: cfg.min_samples,
        });
    }
    let fz_min = pool.fz.iter().copied().fold(f64::INFINITY, f64::min);
    let fz_max = pool.fz.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if fz_max - fz_min < cfg.min_load_span_n {
        return Err(SpringRateError::LoadSpan {
            span_n: fz_max - fz_min,
            need_n: cfg.min_load_span_n,
        });
    }
    let line = LineFit::new(&pool.fz, &pool.rl)?;
    if line.slope >= 0.0 {
        return Err(SpringRateError::RadiusGrows {
            slope_m_per_n: line.slope,
        });
    }
    let stiffness = -1.0 / line.slope;
    // A radius or stiffness no tire has (a radius channel in another unit) is not a row.
    if !within(line.intercept, RADIUS_M) {
        return Err(SpringRateError::Radius {
            r0_m: line.intercept,
        });
    }
    if !within(stiffness, VERTICAL_STIFFNESS_N_PER_M) {
        return Err(SpringRateError::Stiffness {
            cz_n_per_m: stiffness,
        });
    }
    Ok(SpringRateRow {
        key: key.clone(),
        pressure_kpa_mean: finite_mean(pool.pressure.iter().copied()).unwrap_or(f64::NAN),
        ia_cdeg_nom: ia,
        condition,
        stiffness_n_per_m: stiffness,
        stiffness_std_n_per_m: line.slope_std * stiffness * stiffness,
        unloaded_radius_m: line.intercept,
        unloaded_radius_std_m: line.intercept_std,
        n,
        n_segments: pool.segments,
        r2: line.r2,
        residual_rms_m: line.rms,
        speed_kph: finite_mean(pool.speed.iter().copied()).unwrap_or(f64::NAN),
        fz_n_min: fz_min,
        fz_n_max: fz_max,
    })
}

/// Straight line `y = intercept + slope x` with uncertainties.
struct LineFit {
    intercept: f64,
    slope: f64,
    intercept_std: f64,
    slope_std: f64,
    r2: f64,
    rms: f64,
}

impl LineFit {
    fn new(x: &[f64], y: &[f64]) -> Result<LineFit, NumericsError> {
        let design = DMatrix::from_fn(x.len(), 2, |i, j| if j == 0 { 1.0 } else { x[i] });
        let fit = least_squares::solve(&design, &DVector::from_column_slice(y))?;
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
        Ok(LineFit {
            intercept: fit.params[0],
            slope: fit.params[1],
            intercept_std: fit.std_err(0),
            slope_std: fit.std_err(1),
            r2: if tss > 0.0 {
                1.0 - fit.rss / tss
            } else {
                f64::NAN
            },
            rms: fit.rms(),
        })
    }
}

/// The `.tir` vertical numbers of one tire/rim/pressure, plus the RE-law failure reason if any.
fn tir_vertical(
    key: &TireKey,
    rows: &[SpringRateRow],
    groups: &BTreeMap<GroupKey, Pool>,
    fnomin_n: Option<f64>,
    cfg: &SpringRateConfig,
) -> Result<(TirVertical, Option<SpringRateError>), SpringRateError> {
    let mine: Vec<&SpringRateRow> = rows.iter().filter(|r| &r.key == key).collect();
    let dynamic: Vec<&&SpringRateRow> = mine
        .iter()
        .filter(|r| r.condition == Condition::Dynamic)
        .collect();
    // The upright row: the held inclination nearest zero, within half a degree.
    let upright = dynamic
        .iter()
        .filter_map(|r| r.ia_cdeg_nom.map(|ia| (ia.abs(), r)))
        .filter(|(abs, _)| *abs <= UPRIGHT_CDEG)
        .min_by_key(|(abs, _)| *abs);
    let (cz, r0, speed, source) = if let Some((_, r)) = upright {
        (
            r.stiffness_n_per_m,
            r.unloaded_radius_m,
            r.speed_kph,
            format!("dynamic ia {}", ia_text(r.ia_cdeg_nom)),
        )
    } else if !dynamic.is_empty() {
        let k = dynamic.len() as f64;
        (
            dynamic.iter().map(|r| r.stiffness_n_per_m).sum::<f64>() / k,
            dynamic.iter().map(|r| r.unloaded_radius_m).sum::<f64>() / k,
            dynamic.iter().map(|r| r.speed_kph).sum::<f64>() / k,
            "dynamic mean".to_string(),
        )
    } else if let Some(r) = mine
        .iter()
        .filter(|r| r.condition == Condition::Sweep)
        .max_by_key(|r| r.n)
    {
        (
            r.stiffness_n_per_m,
            r.unloaded_radius_m,
            r.speed_kph,
            "sweep".to_string(),
        )
    } else {
        return Err(SpringRateError::NoVerticalRow);
    };
    let mut vertical = TirVertical {
        key: key.clone(),
        vertical_stiffness_n_per_m: cz,
        unloaded_radius_m: r0,
        source,
        speed_kph: speed,
        effective_radius: None,
    };
    let Some(fz0) = fnomin_n.filter(|f| *f > 0.0) else {
        return Ok((vertical, Some(SpringRateError::NoFnomin)));
    };
    let (fz, re) = re_samples(key, groups, speed, cfg);
    match fit_effective_radius(&fz, &re, r0, cz, fz0, cfg) {
        Ok(law) => {
            vertical.effective_radius = Some(law);
            Ok((vertical, None))
        }
        Err(reason) => Ok((vertical, Some(reason))),
    }
}

/// RE samples at the dynamic speed: dynamic holds and free-rolling sweeps (upright, IA 0 within
/// half a degree, when there are enough, else every IA).
fn re_samples(
    key: &TireKey,
    groups: &BTreeMap<GroupKey, Pool>,
    speed_kph: f64,
    cfg: &SpringRateConfig,
) -> (Vec<f64>, Vec<f64>) {
    let gather = |upright_only: bool| {
        let (mut fz, mut re) = (Vec::new(), Vec::new());
        for ((k, condition, ia, _), pool) in groups {
            if k != key || *condition == Condition::Static {
                continue;
            }
            if upright_only && !ia.is_some_and(|ia| ia.abs() <= UPRIGHT_CDEG) {
                continue;
            }
            for i in 0..pool.fz.len() {
                let near = (pool.speed[i] - speed_kph).abs() <= cfg.re_speed_tolerance * speed_kph;
                if near && pool.re[i].is_finite() && pool.speed[i] >= cfg.min_rolling_speed_kph {
                    fz.push(pool.fz[i]);
                    re.push(pool.re[i]);
                }
            }
        }
        (fz, re)
    };
    let ia0 = gather(true);
    if ia0.0.len() >= cfg.min_samples {
        ia0
    } else {
        gather(false)
    }
}

/// Fit `BREFF, DREFF, FREFF` to RE samples given `R0`, `Cz`, `Fz0`.
pub fn fit_effective_radius(
    fz_n: &[f64],
    re_m: &[f64],
    r0_m: f64,
    cz_n_per_m: f64,
    fnomin_n: f64,
    cfg: &SpringRateConfig,
) -> Result<EffectiveRadiusLaw, SpringRateError> {
    let n = fz_n.len();
    if n < cfg.min_samples {
        return Err(SpringRateError::TooFewRolling {
            n,
            need: cfg.min_samples,
        });
    }
    let rho: Vec<f64> = fz_n.iter().map(|f| f / fnomin_n).collect();
    // y = (R0 - RE) Cz/Fz0 = DREFF atan(BREFF rho) + FREFF rho.
    let y: Vec<f64> = re_m
        .iter()
        .map(|re| (r0_m - re) * cz_n_per_m / fnomin_n)
        .collect();
    let inner = |b: f64| -> Option<(f64, f64, f64)> {
        let (mut saa, mut sab, mut sbb, mut say, mut sby) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let a = (b * rho[i]).atan();
            let r = rho[i];
            saa += a * a;
            sab += a * r;
            sbb += r * r;
            say += a * y[i];
            sby += r * y[i];
        }
        let det = saa * sbb - sab * sab;
        if det.abs() <= 1e-14 * saa * sbb {
            return None;
        }
        let d = (say * sbb - sby * sab) / det;
        let f = (saa * sby - sab * say) / det;
        let rss: f64 = (0..n)
            .map(|i| (y[i] - d * (b * rho[i]).atan() - f * rho[i]).powi(2))
            .sum();
        Some((d, f, rss))
    };
    let cost = |b: f64| inner(b).map_or(f64::INFINITY, |(_, _, rss)| rss);
    let (lo, hi) = cfg.breff_range;
    let m = scalar::minimize(&cost, lo, hi, &ScalarOptions::default())?;
    let (dreff, freff, rss) = inner(m.x).ok_or(SpringRateError::DegenerateReLaw)?;
    let rmse_m = (rss / n as f64).sqrt() * fnomin_n / cz_n_per_m;
    Ok(EffectiveRadiusLaw {
        breff: m.x,
        dreff,
        freff,
        fnomin_n,
        rmse_m,
        n,
        at_bound: m.at_bound,
    })
}

/// `RE(Fz)` of a law, m (the inverse of the fit, for checks and reports).
pub fn effective_radius_m(law: &EffectiveRadiusLaw, r0_m: f64, cz_n_per_m: f64, fz_n: f64) -> f64 {
    let rho = fz_n / law.fnomin_n;
    r0_m - law.fnomin_n / cz_n_per_m * (law.dreff * (law.breff * rho).atan() + law.freff * rho)
}

#[cfg(test)]
mod tests;
