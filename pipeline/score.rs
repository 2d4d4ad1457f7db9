//! How well a `.tir` model reproduces a store's measured samples: RMS errors of Fx, Fy and Mz
//! per source file and nominal pressure.
//!
//! In: a store root (the live `samples` table, as `query` sees it), a parsed `.tir` file and a
//! [`Selection`] of samples (by default the one of the real-data README: `|alpha| <= 12.5 deg`,
//! `Fz > 100 N`, `V > 5 km/h`, every 5th sample in time order of each source file). Out: one
//! [`ScoreRow`] per (tire, rim, source file, nominal pressure): sample count, RMSE of the model against the
//! measured Fx, Fy, Mz and the RMS of the measured values (for scale). The model is evaluated at
//! each sample's measured load, slip, inclination and speed (ISO-W, SI), combined slip, in the
//! chosen [`Mode`].
//!
//! Every sample of a run counts, whatever its segment (sweeps, transitions, warm-up): the score
//! says how well the model predicts the measurement, not how well it fits the sweeps it was
//! fitted on. An MF 6.x model is evaluated at each sample's measured inflation pressure (its
//! default pressure where none was measured); PAC2002 has no pressure terms. Deliberately not
//! here: fitting.

use std::collections::BTreeMap;
use std::path::Path;

use polars::prelude::*;
use tirebase_core::tire_model::tir::TirFile;
use tirebase_core::tire_model::{Evaluation, Mode, Pressures, SlipInput};

use crate::query::{self, QueryError};
use crate::store::StoreError;
use crate::store::columns::{req_f64, req_i64, req_str};

/// Which samples are scored.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// Only this tire (name as stored); every tire when `None`.
    pub tire: Option<String>,
    /// Only this rim width, whole inches (the `rim_in` partition); every rim when `None`. A
    /// model is one (tire, rim, pressure): a tire tested on two rims has two.
    pub rim_in: Option<i64>,
    /// Only samples of this nominal pressure partition, kPa; every pressure when `None`.
    pub pressure_kpa_nom: Option<i64>,
    /// Largest |slip angle| scored, deg.
    pub max_abs_alpha_deg: f64,
    /// Smallest load scored (ISO-W, compression positive), N.
    pub min_fz_n: f64,
    /// Smallest road speed scored, km/h.
    pub min_speed_kph: f64,
    /// Keep every n-th selected sample of each source file (1 = all), counted over the file's
    /// selected samples at every pressure: asking for one pressure keeps the same samples.
    pub every: usize,
}

impl Default for Selection {
    /// The selection of `shared/real/README.md`.
    fn default() -> Self {
        Selection {
            tire: None,
            rim_in: None,
            pressure_kpa_nom: None,
            max_abs_alpha_deg: 12.5,
            min_fz_n: 100.0,
            min_speed_kph: 5.0,
            every: 5,
        }
    }
}

/// The score of one model on one source file's samples at one nominal pressure.
#[derive(Clone, Debug, PartialEq)]
pub struct ScoreRow {
    /// Tire name as stored.
    pub tire: String,
    /// Rim width, whole inches (the `rim_in` partition; -1 when unknown).
    pub rim_in: i64,
    /// Source file name.
    pub source_file: String,
    /// Nominal pressure partition, kPa (`None` when not held: the partition's null).
    pub pressure_kpa_nom: Option<i64>,
    /// Samples scored.
    pub n_samples: usize,
    /// RMS of (model - measured) Fx, N (NaN when the model has no Fx, see
    /// [`modelled_channels`]).
    pub fx_rmse_n: f64,
    /// RMS of (model - measured) Fy, N (NaN when the model has no Fy).
    pub fy_rmse_n: f64,
    /// RMS of (model - measured) Mz, N m (NaN when the model has no Mz).
    pub mz_rmse_nm: f64,
    /// RMS of the measured Fx, N.
    pub fx_rms_n: f64,
    /// RMS of the measured Fy, N.
    pub fy_rms_n: f64,
    /// RMS of the measured Mz, N m.
    pub mz_rms_nm: f64,
}

/// Errors of [`score`].
#[derive(Debug, thiserror::Error)]
pub enum ScoreError {
    /// The store could not be read.
    #[error(transparent)]
    Query(#[from] QueryError),
    /// A column was missing or of the wrong type.
    #[error("{store}: samples: {source}")]
    Polars {
        store: String,
        #[source]
        source: PolarsError,
    },
    /// The selection is empty or invalid.
    #[error("selection: {0}")]
    Selection(String),
    /// A column of the samples read could not be read as its type.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// Columns read from the samples table: where a sample belongs, then its values
/// ([`MEASURED`]).
const KEY_COLUMNS: [&str; 5] = [
    "tire",
    "rim_in",
    "source_file",
    "sample_index",
    "pressure_kpa_nom",
];

/// The measured values of a sample (read into [`Measured`]).
const MEASURED: [&str; 9] = [
    "fz_n",
    "kappa",
    "alpha_rad",
    "gamma_rad",
    "speed_kph",
    "pressure_kpa",
    "fx_n",
    "fy_n",
    "mz_nm",
];

/// One measured sample and where it belongs.
#[derive(Clone, Debug)]
struct Measured {
    point: SlipInput,
    pressure_kpa: f64,
    fx_n: f64,
    fy_n: f64,
    mz_nm: f64,
}

/// Score `tir` on the store's samples chosen by `selection`; rows sorted by (tire, rim, source
/// file, pressure).
pub fn score(
    store: &Path,
    tir: &TirFile,
    selection: &Selection,
    mode: Mode,
) -> Result<Vec<ScoreRow>, ScoreError> {
    if selection.every == 0 {
        return Err(ScoreError::Selection("every must be >= 1".into()));
    }
    let [fx_used, fy_used, mz_used] = modelled_channels(tir.use_mode);
    let groups = selected_samples(store, selection)?;
    let mut rows = Vec::with_capacity(groups.len());
    for ((tire, rim_in, source_file, pressure_kpa_nom), samples) in groups {
        let points: Vec<SlipInput> = samples.iter().map(|s| s.point).collect();
        let pressures: Vec<f64> = samples.iter().map(|s| s.pressure_kpa).collect();
        let model = evaluate(tir, &points, &pressures, mode);
        let rmse = |used: bool, f: fn(&Evaluation<f64>) -> f64, m: fn(&Measured) -> f64| match used
        {
            true => rms(model.iter().zip(&samples).map(|(e, s)| f(e) - m(s))),
            false => f64::NAN,
        };
        rows.push(ScoreRow {
            tire,
            rim_in,
            source_file,
            pressure_kpa_nom,
            n_samples: samples.len(),
            fx_rmse_n: rmse(fx_used, |e| e.fx_n, |s| s.fx_n),
            fy_rmse_n: rmse(fy_used, |e| e.fy_n, |s| s.fy_n),
            mz_rmse_nm: rmse(mz_used, |e| e.mz_nm, |s| s.mz_nm),
            fx_rms_n: rms(samples.iter().map(|s| s.fx_n)),
            fy_rms_n: rms(samples.iter().map(|s| s.fy_n)),
            mz_rms_nm: rms(samples.iter().map(|s| s.mz_nm)),
        });
    }
    Ok(rows)
}

/// Which of Fx, Fy, Mz the file's `USE_MODE` models (last digit 1: Fx only, 2: Fy and Mz
/// only, 0: none; no `USE_MODE` or another digit: all). A channel the model does not carry has
/// no error to report: its evaluated value (zero or NaN) is no prediction.
pub fn modelled_channels(use_mode: Option<i64>) -> [bool; 3] {
    match use_mode.map(|m| m.unsigned_abs() % 10) {
        Some(0) => [false; 3],
        Some(1) => [true, false, false],
        Some(2) => [false, true, true],
        _ => [true; 3],
    }
}

/// The model's forces and moments at `points`, each at its measured inflation pressure (kPa;
/// MF 6.x only, the model's default pressure where not finite).
fn evaluate(
    tir: &TirFile,
    points: &[SlipInput],
    pressures_kpa: &[f64],
    mode: Mode,
) -> Vec<Evaluation<f64>> {
    let model = tir.model();
    let fallback = model.default_pressure_pa();
    let pressures_pa: Vec<f64> = pressures_kpa
        .iter()
        .map(|p| {
            if p.is_finite() && *p > 0.0 {
                p * 1e3
            } else {
                fallback
            }
        })
        .collect();
    let mut out = vec![Evaluation::default(); points.len()];
    model.eval_batch_at(points, Pressures::PerPoint(&pressures_pa), mode, &mut out);
    out
}

/// Root mean square of the finite values (NaN when none).
fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        (sum / n as f64).sqrt()
    }
}

/// (tire, rim width in, source file, nominal pressure kPa).
type GroupKey = (String, i64, String, Option<i64>);

/// The selected samples, grouped by (tire, rim, source file, nominal pressure), each group in
/// time order of its file.
fn selected_samples(
    store: &Path,
    selection: &Selection,
) -> Result<BTreeMap<GroupKey, Vec<Measured>>, ScoreError> {
    let polars_err = |source: PolarsError| ScoreError::Polars {
        store: store.display().to_string(),
        source,
    };
    let mut ctx = query::context(store)?;
    let mut frame = ctx
        .execute("SELECT * FROM samples")
        .map_err(polars_err)?
        .select(
            KEY_COLUMNS
                .iter()
                .chain(&MEASURED)
                .map(|c| col(*c))
                .collect::<Vec<_>>(),
        );
    if let Some(tire) = &selection.tire {
        frame = frame.filter(col("tire").eq(lit(tire.clone())));
    }
    if let Some(rim_in) = selection.rim_in {
        frame = frame.filter(col("rim_in").eq(lit(rim_in)));
    }
    let df = frame
        .sort(
            ["source_file", "sample_index"],
            SortMultipleOptions::default(),
        )
        .collect()
        .map_err(polars_err)?;
    let text = |name: &str| -> Result<Vec<String>, StoreError> {
        Ok(req_str(&df, name, store)?
            .into_iter()
            .map(Option::unwrap_or_default)
            .collect())
    };
    let number = |name: &str| -> Result<Vec<f64>, StoreError> {
        Ok(req_f64(&df, name, store)?
            .into_iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    };
    // A partition key absent from a sample's path (null) is unknown: -1.
    let whole = |name: &str| -> Result<Vec<i64>, StoreError> {
        Ok(req_i64(&df, name, store)?
            .into_iter()
            .map(|v| v.unwrap_or(-1))
            .collect())
    };
    let (tire, file) = (text("tire")?, text("source_file")?);
    let p_nom = req_i64(&df, "pressure_kpa_nom", store)?;
    let rim = whole("rim_in")?;
    let [fz, kappa, alpha, gamma, v, p, fx, fy, mz] = MEASURED.map(number);
    let (fz, kappa, alpha, gamma, v, p, fx, fy, mz) =
        (fz?, kappa?, alpha?, gamma?, v?, p?, fx?, fy?, mz?);
    let max_alpha = selection.max_abs_alpha_deg.to_radians();
    let mut seen: BTreeMap<(String, String), usize> = BTreeMap::new();
    let mut groups: BTreeMap<GroupKey, Vec<Measured>> = BTreeMap::new();
    for i in 0..df.height() {
        let keep = alpha[i].abs() <= max_alpha
            && fz[i] > selection.min_fz_n
            && v[i] > selection.min_speed_kph;
        if !keep {
            continue;
        }
        let count = seen.entry((tire[i].clone(), file[i].clone())).or_default();
        let take = (*count).is_multiple_of(selection.every);
        *count += 1;
        if !take {
            continue;
        }
        let nominal = p_nom[i];
        // After the decimation: the chosen samples do not depend on the pressure asked for.
        if selection
            .pressure_kpa_nom
            .is_some_and(|p| Some(p) != nominal)
        {
            continue;
        }
        groups
            .entry((tire[i].clone(), rim[i], file[i].clone(), nominal))
            .or_default()
            .push(Measured {
                point: SlipInput {
                    fz_n: fz[i],
                    kappa: if kappa[i].is_finite() { kappa[i] } else { 0.0 },
                    alpha_rad: alpha[i],
                    gamma_rad: gamma[i],
                    vx_mps: v[i] / 3.6,
                },
                pressure_kpa: p[i],
                fx_n: fx[i],
                fy_n: fy[i],
                mz_nm: mz[i],
            });
    }
    Ok(groups)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_channels_use_mode_declares_are_scored() {
        assert_eq!(modelled_channels(Some(1)), [true, false, false]);
        assert_eq!(modelled_channels(Some(11)), [true, false, false]);
        assert_eq!(modelled_channels(Some(2)), [false, true, true]);
        assert_eq!(modelled_channels(Some(0)), [false; 3]);
        assert_eq!(modelled_channels(Some(14)), [true; 3]);
        assert_eq!(modelled_channels(Some(3)), [true; 3]);
        assert_eq!(modelled_channels(None), [true; 3]);
    }

    #[test]
    fn rms_skips_non_finite() {
        assert!((rms([3.0, 4.0, f64::NAN].into_iter()) - (12.5f64).sqrt()).abs() < 1e-12);
        assert!(rms(std::iter::empty()).is_nan());
    }
}
