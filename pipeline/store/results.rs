//! A version's result tables: the one place that reads and writes `versions/vNNNNNN/<table>.parquet`
//! (and a `tirebase fit --out` directory laid out the same way), generically for merging,
//! querying and diffing, and as typed rows for the readers that use their values (the report,
//! publishing's problems and worst fit).
//!
//! In: a result directory, or the tables a run has just built in memory. Out: DataFrames by
//! table name ([`read_table`], [`table_names`], [`write_table`]), [`Results`] (typed rows of the
//! tables the report shows, each checked for the columns it needs: a table without one is a
//! note naming the file and column, never a chart of NaN), the fit failures of some groups
//! ([`read_fit_failures`]), the groups with a model ([`model_groups`]), the `.tir` file name
//! of each ([`tir_names`]) and the parsed models of a `tir/` directory ([`read_tir_models`]).
//! [`Results`] also carries the rig-inertia results (`inertia`, no group columns) when the
//! version has them. Deliberately not here: computing the tables (fit) and what is done with
//! the rows.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};

use polars::prelude::*;
use tirebase_core::inertia::InertiaResult;
use tirebase_core::naming::{unique_mf61_names, unique_tir_names};
use tirebase_core::tire_model::Pac2002;
use tirebase_core::tire_model::tir::{TirFile, TirReadError};

use super::StoreError;
use super::columns::{opt_bool, opt_f64, opt_i64, opt_str, req_bool, req_f64, req_i64, req_str};
use super::files::{parquet_files_in, read_parquet, write_parquet_atomic};
use crate::schema::TableName;

/// A fit group: (tire, rim_in, pressure_kpa nominal).
pub type GroupKey = (String, i64, i64);

/// The columns every fit result table starts with, identifying its group.
pub const GROUP_COLUMNS: [&str; 3] = ["tire", "rim_in", "pressure_kpa"];

/// The file of table `name` in a result directory.
pub fn table_path(dir: &Path, name: impl AsRef<str>) -> PathBuf {
    dir.join(format!("{}.parquet", name.as_ref()))
}

/// Names of the tables a result directory holds, sorted.
pub fn table_names(dir: &Path) -> Result<Vec<String>, StoreError> {
    Ok(parquet_files_in(dir)?
        .iter()
        .filter_map(|p| p.file_stem().and_then(|s| s.to_str()).map(String::from))
        .collect())
}

/// Table `name` of a result directory; `None` when the directory has no such table.
pub fn read_table(dir: &Path, name: impl AsRef<str>) -> Result<Option<DataFrame>, StoreError> {
    let path = table_path(dir, name);
    if !path.is_file() {
        return Ok(None);
    }
    read_parquet(&path).map(Some)
}

/// Write table `name` into a result directory atomically.
pub fn write_table(
    dir: &Path,
    name: impl AsRef<str>,
    df: &mut DataFrame,
) -> Result<(), StoreError> {
    write_parquet_atomic(&table_path(dir, name), df)
}

/// The table has the group columns (every fit result table does; `inertia` does not).
pub fn has_group_columns(df: &DataFrame) -> bool {
    GROUP_COLUMNS.iter().all(|c| df.column(c).is_ok())
}

/// The rows of `df` whose (tire, rim_in, pressure_kpa) is in `keys`.
pub fn rows_of_groups(df: &DataFrame, keys: &BTreeSet<GroupKey>) -> PolarsResult<DataFrame> {
    let tire = df.column("tire")?.str()?;
    let rim = df.column("rim_in")?.i64()?;
    let p = df.column("pressure_kpa")?.i64()?;
    let mask: BooleanChunked = (0..df.height())
        .map(|i| match (tire.get(i), rim.get(i), p.get(i)) {
            (Some(t), Some(r), Some(p)) => keys.contains(&(t.to_string(), r, p)),
            _ => false,
        })
        .collect();
    df.filter(&mask)
}

/// A stage that failed for a group, or a part of it (a row of `fit_failures`).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct FitFailure {
    /// Tire name.
    pub tire: String,
    /// Rim width, in.
    pub rim_in: i64,
    /// Nominal pressure, kPa.
    pub pressure_kpa: i64,
    /// `load`, `spring_rate`, `pac2002`, `relaxation`, `thermal`.
    pub stage: String,
    /// The stage name for the whole stage, else the part (a family, a load, a segment).
    pub scope: String,
    /// The stage produced nothing for the group.
    pub fatal: bool,
    /// One-line reason.
    pub reason: String,
}

/// How a family flagged good in sample and bad out of sample is scoped in `fit_failures`
/// (`family Fy0 out of sample`): a quality flag of a published model, not a skipped part.
pub fn out_of_sample_scope(family: &str) -> String {
    format!("family {family}{OUT_OF_SAMPLE_SUFFIX}")
}

/// The end of every [`out_of_sample_scope`].
const OUT_OF_SAMPLE_SUFFIX: &str = " out of sample";

/// The scope of an MF 6.1 model written without pressure terms (one tested pressure): a limit
/// of the written model, not a part of the stage left out.
pub const PRESSURE_TERMS_SCOPE: &str = "pressure terms";

/// How an error the lint finds in a written `.tir` is scoped in `fit_failures`
/// (`lint <file> <code>`).
pub fn lint_scope(file_name: &str, code: &str) -> String {
    format!("{LINT_PREFIX}{file_name} {code}")
}

/// The start of every [`lint_scope`].
const LINT_PREFIX: &str = "lint ";

/// What a `fit_failures` row means for the version: one kind per row, decided by its `fatal`
/// flag and its scope.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum FailureKind {
    /// The stage produced nothing for the group.
    Failed,
    /// A part of the stage (a load, a sweep, a family) was left out; the rest was written.
    Skipped,
    /// The result was written whole and fits poorly (a family good in sample and bad out of
    /// sample).
    QualityFlag,
    /// The model was written whole and cannot carry something (an MF 6.1 model from one tested
    /// pressure has no pressure terms).
    ModelLimit,
    /// The written `.tir` has an error by the lint (a spike, a force against its slip, ..).
    LintError,
}

impl FailureKind {
    /// The prefix of its lines on stderr.
    pub fn label(self) -> &'static str {
        match self {
            FailureKind::Failed => "failed",
            FailureKind::Skipped => "skipped",
            FailureKind::QualityFlag => "fit quality",
            FailureKind::ModelLimit => "model limit",
            FailureKind::LintError => "tir lint error",
        }
    }
}

impl FitFailure {
    /// What the row means ([`FailureKind`]).
    pub fn kind(&self) -> FailureKind {
        if self.fatal {
            FailureKind::Failed
        } else if self.scope.ends_with(OUT_OF_SAMPLE_SUFFIX) {
            FailureKind::QualityFlag
        } else if self.scope == PRESSURE_TERMS_SCOPE {
            FailureKind::ModelLimit
        } else if self.scope.starts_with(LINT_PREFIX) {
            FailureKind::LintError
        } else {
            FailureKind::Skipped
        }
    }
}

impl fmt::Display for FitFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} on {} in rim at {} kPa: {}{}: {}",
            self.tire,
            self.rim_in,
            self.pressure_kpa,
            self.stage,
            if self.scope == self.stage {
                String::new()
            } else {
                format!(" ({})", self.scope)
            },
            self.reason
        )
    }
}

/// A row of the published `coefficients` table as read back for the report and `compare`, with
/// its group columns; a non-finite `std_error` reads as not estimated, a null `at_bound` as false.
/// The model writer's own form of the row (no group columns) is `fit::tir::WrittenCoefficient`.
#[derive(Clone, Debug, PartialEq)]
pub struct CoefficientRecord {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    pub model: String,
    pub family: String,
    pub name: String,
    pub value: f64,
    /// None when not estimated.
    pub std_error: Option<f64>,
    pub at_bound: bool,
}

/// A row of `fit_quality` as the report uses it. The measures are `None` where the table holds
/// null or (a table written before the column existed) does not have the column.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QualityRow {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    /// `pac2002` or `mf61` (`pac2002` in a table written before the column existed).
    pub model: String,
    pub channel: String,
    /// Out-of-sample RMSE (k-fold by sweep, for both models), its ratio to the in-sample one,
    /// the flag and the folds (`None` in a table written before the column existed).
    pub oos_rmse: Option<f64>,
    pub oos_ratio: Option<f64>,
    pub oos_flag: Option<bool>,
    pub oos_folds: Option<i64>,
    pub trend_dev_max: Option<f64>,
    pub trend_dev_pct_of_peak: Option<f64>,
    pub n_free: Option<i64>,
    pub jacobian_rank: Option<i64>,
    pub condition_number: Option<f64>,
    pub n: Option<i64>,
    pub rmse: Option<f64>,
    pub rmse_pct_of_peak: Option<f64>,
    pub r2: Option<f64>,
    pub sample_rmse: Option<f64>,
    pub initial_rmse: Option<f64>,
    pub iterations: Option<i64>,
    pub termination: Option<String>,
}

#[cfg(test)]
impl QualityRow {
    /// A PAC2002 row on a 7 in rim with only `rmse_pct_of_peak` (test fixtures).
    pub fn pct_of_peak_only(tire: &str, pressure_kpa: i64, channel: &str, pct: f64) -> QualityRow {
        QualityRow {
            tire: tire.into(),
            rim_in: 7,
            pressure_kpa,
            model: "pac2002".into(),
            channel: channel.into(),
            rmse_pct_of_peak: Some(pct),
            ..QualityRow::default()
        }
    }
}

impl QualityRow {
    /// The error a reader should judge the fit by, in percent of the channel's peak: the
    /// out-of-sample RMSE where the row has one (`rmse_pct_of_peak x oos_ratio`), else the
    /// in-sample `rmse_pct_of_peak`; `None` without either. The same for both models: their
    /// `oos_ratio` is k-fold by sweep (an mf61 row's leave-one-pressure-out figure, `lopo_ratio`,
    /// is not the headline).
    pub fn headline_pct_of_peak(&self) -> Option<f64> {
        self.oos_pct_of_peak()
            .or(self.rmse_pct_of_peak.filter(|v| v.is_finite()))
    }

    /// The out-of-sample (k-fold by sweep) RMSE in percent of the channel's peak,
    /// `rmse_pct_of_peak x oos_ratio`; `None` without both.
    pub fn oos_pct_of_peak(&self) -> Option<f64> {
        let pct = self.rmse_pct_of_peak.filter(|v| v.is_finite())?;
        Some(pct * self.oos_ratio.filter(|r| r.is_finite())?)
    }
}

/// A row of the published `spring_rate` table as read back for the report and `compare`: the
/// columns they show, strings for the enums. The row the stage computes (every column, typed) is
/// `tirebase_core::fit::spring_rate::SpringRateRow`.
#[derive(Clone, Debug, PartialEq)]
pub struct SpringRateRecord {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    /// Held inclination, hundredths of a degree; None when the inclination was swept (the
    /// table's null; a held -1 deg is `Some(-100)`).
    pub ia_cdeg_nom: Option<i64>,
    pub condition: String,
    pub stiffness_n_per_m: f64,
}

/// A row of `thermal` as the report uses it.
#[derive(Clone, Debug, PartialEq)]
pub struct ThermalRow {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    /// The cold-to-warm test (segment) the sweep belongs to.
    pub segment_id: String,
    pub quadrant: String,
    /// Time of the sweep's peak, s (NaN when not recorded).
    pub et_peak_s: f64,
    pub t_centre_peak_c: f64,
    pub mu_peak: f64,
}

/// A row of the published `thermal_fit` table as read back for the report and `compare`: the
/// columns they show, a null `converged` read as converged. The row the stage computes is
/// `tirebase_core::fit::thermal::ThermalFitRow`.
#[derive(Clone, Debug, PartialEq)]
pub struct ThermalFitRecord {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    pub t_peak_c: f64,
    /// Relative gain of peak grip at `t_peak_c` over the cold reference.
    pub gain_peak_over_cold: f64,
    pub t_cold_c: f64,
    pub k_cold_per_c2: f64,
    /// NaN when the hot side was not resolved.
    pub hot_falloff: f64,
    pub mu_peak_mean: f64,
    /// The mu(T) fit converged (a null reads as converged).
    pub converged: bool,
}

/// A row of the published `relaxation` table as read back for the report and `compare`: the
/// columns they show, strings for the enums, a null `converged` read as converged. The row the
/// stage computes is `tirebase_core::fit::relaxation::RelaxationRow`.
#[derive(Clone, Debug, PartialEq)]
pub struct RelaxationRecord {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    pub direction: String,
    pub method: String,
    pub fz_n_mean: f64,
    pub sigma_m: f64,
    pub converged: bool,
}

/// A row of `lint`.
#[derive(Clone, Debug, PartialEq)]
pub struct LintRow {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    /// `pac2002` or `mf61` (`pac2002` in a table written before the column existed).
    pub model: String,
    pub file: String,
    pub severity: String,
    pub code: String,
    pub message: String,
}

/// The result tables the report shows, typed; `None` for a table the results do not have (or
/// that could not be read: [`Results::notes`] says why).
#[derive(Clone, Debug, Default)]
pub struct Results {
    pub coefficients: Option<Vec<CoefficientRecord>>,
    pub fit_quality: Option<Vec<QualityRow>>,
    pub spring_rate: Option<Vec<SpringRateRecord>>,
    pub thermal: Option<Vec<ThermalRow>>,
    pub thermal_fit: Option<Vec<ThermalFitRecord>>,
    pub relaxation: Option<Vec<RelaxationRecord>>,
    pub lint: Option<Vec<LintRow>>,
    pub fit_failures: Option<Vec<FitFailure>>,
    /// The rig-inertia results (`None` when the results have none: not every result set comes
    /// with rig sessions, so a missing `inertia.parquet` is no note; an unreadable one is).
    pub inertia: Option<Vec<InertiaResult>>,
    /// One line per table that is not present or could not be read.
    pub notes: Vec<String>,
}

/// The rig-inertia results table of a version (not a fit table: no group columns).
pub const INERTIA_TABLE: TableName = TableName::Inertia;

/// The fit tables [`Results`] holds (besides [`INERTIA_TABLE`]).
pub const RESULT_TABLES: [TableName; 8] = [
    TableName::Coefficients,
    TableName::FitQuality,
    TableName::SpringRate,
    TableName::Thermal,
    TableName::ThermalFit,
    TableName::Relaxation,
    TableName::Lint,
    TableName::FitFailures,
];

impl Results {
    /// Read the tables of a result directory (a missing or unreadable one is a note).
    pub fn read(dir: &Path) -> Results {
        let mut frames = BTreeMap::new();
        let mut unreadable = BTreeMap::new();
        for name in RESULT_TABLES {
            match read_table(dir, name) {
                Ok(Some(df)) => {
                    frames.insert(name.to_string(), df);
                }
                Ok(None) => {}
                Err(e) => {
                    unreadable.insert(name.as_str(), e.to_string());
                }
            }
        }
        let mut out = Results::build(&frames, &unreadable);
        match read_table(dir, INERTIA_TABLE) {
            Ok(Some(df)) => out.set_inertia(&df),
            Ok(None) => {}
            Err(e) => out
                .notes
                .push(format!("{INERTIA_TABLE}.parquet: unreadable: {e}")),
        }
        out
    }

    /// Type the rig-inertia results (`inertia` table) beside the fit tables; a frame without a
    /// column the report needs is a note.
    pub fn set_inertia(&mut self, df: &DataFrame) {
        let file = format!("{INERTIA_TABLE}.parquet");
        match inertia_rows(df, Path::new(&file)) {
            Ok(rows) => self.inertia = Some(rows),
            Err(e) => {
                self.inertia = None;
                self.notes.push(format!("{file}: unreadable: {e}"));
            }
        }
    }

    /// Type the tables a run holds in memory (by table name).
    pub fn from_frames(frames: &BTreeMap<String, DataFrame>) -> Results {
        Results::build(frames, &BTreeMap::new())
    }

    fn build(frames: &BTreeMap<String, DataFrame>, unreadable: &BTreeMap<&str, String>) -> Results {
        let mut out = Results::default();
        macro_rules! take {
            ($field:ident, $conv:ident) => {{
                let name = stringify!($field);
                let file = format!("{name}.parquet");
                match frames.get(name) {
                    None => out.notes.push(match unreadable.get(name) {
                        Some(e) => format!("{file}: unreadable: {e}"),
                        None => format!("{file}: not present"),
                    }),
                    Some(df) => match $conv(df, Path::new(&file)) {
                        Ok(rows) => out.$field = Some(rows),
                        Err(e) => out.notes.push(format!("{file}: unreadable: {e}")),
                    },
                }
            }};
        }
        take!(coefficients, coefficient_rows);
        take!(fit_quality, quality_rows);
        take!(spring_rate, spring_rate_rows);
        take!(thermal, thermal_rows);
        take!(thermal_fit, thermal_fit_rows);
        take!(relaxation, relaxation_rows);
        take!(lint, lint_rows);
        take!(fit_failures, fit_failure_rows);
        out
    }

    /// Every (tire, rim, nominal pressure) any table has rows for.
    pub fn groups(&self) -> BTreeSet<GroupKey> {
        fn keys<'a, T: 'a>(
            rows: &'a Option<Vec<T>>,
            key: impl Fn(&T) -> GroupKey + 'a,
        ) -> impl Iterator<Item = GroupKey> + 'a {
            rows.iter().flatten().map(key)
        }
        let k = |t: &String, r: i64, p: i64| (t.clone(), r, p);
        keys(&self.coefficients, |x| k(&x.tire, x.rim_in, x.pressure_kpa))
            .chain(keys(&self.fit_quality, |x| {
                k(&x.tire, x.rim_in, x.pressure_kpa)
            }))
            .chain(keys(&self.spring_rate, |x| {
                k(&x.tire, x.rim_in, x.pressure_kpa)
            }))
            .chain(keys(&self.thermal, |x| {
                k(&x.tire, x.rim_in, x.pressure_kpa)
            }))
            .chain(keys(&self.thermal_fit, |x| {
                k(&x.tire, x.rim_in, x.pressure_kpa)
            }))
            .chain(keys(&self.relaxation, |x| {
                k(&x.tire, x.rim_in, x.pressure_kpa)
            }))
            .chain(keys(&self.lint, |x| k(&x.tire, x.rim_in, x.pressure_kpa)))
            .chain(keys(&self.fit_failures, |x| {
                k(&x.tire, x.rim_in, x.pressure_kpa)
            }))
            .collect()
    }

    /// The groups with a PAC2002 model: those of the `coefficients` rows of model `pac2002`.
    pub fn model_groups(&self) -> BTreeSet<GroupKey> {
        self.groups_of_model(PAC2002)
    }

    /// The tires and rims with an MF 6.1 model, keyed at its `NOMPRES` (kPa).
    pub fn mf61_groups(&self) -> BTreeSet<GroupKey> {
        self.groups_of_model(MF61)
    }

    fn groups_of_model(&self, model: &str) -> BTreeSet<GroupKey> {
        self.coefficients
            .iter()
            .flatten()
            .filter(|c| is_model(&c.model, model))
            .map(|c| (c.tire.clone(), c.rim_in, c.pressure_kpa))
            .collect()
    }

    /// The `fit_quality` rows of PAC2002 models (the per-pressure models the report and the
    /// tire selection rank).
    pub fn pac2002_quality(&self) -> Option<Vec<QualityRow>> {
        self.fit_quality.as_ref().map(|rows| {
            rows.iter()
                .filter(|q| is_model(&q.model, PAC2002))
                .cloned()
                .collect()
        })
    }
}

/// The `model` value of PAC2002 rows.
pub const PAC2002: &str = "pac2002";
/// The `model` value of MF 6.1 rows.
pub const MF61: &str = "mf61";

/// `value` names `model` (case-insensitive: tables of earlier versions wrote `PAC2002`).
pub fn is_model(value: &str, model: &str) -> bool {
    value.eq_ignore_ascii_case(model)
}

impl Results {}

/// The three group columns of a table.
type Keys = (Vec<String>, Vec<i64>, Vec<i64>);

fn group_keys(df: &DataFrame, path: &Path) -> Result<Keys, StoreError> {
    let tire = req_str(df, "tire", path)?;
    let rim = req_i64(df, "rim_in", path)?;
    let p = req_i64(df, "pressure_kpa", path)?;
    Ok((
        tire.into_iter().map(Option::unwrap_or_default).collect(),
        rim.into_iter().map(|v| v.unwrap_or(0)).collect(),
        p.into_iter().map(|v| v.unwrap_or(0)).collect(),
    ))
}

fn strings(v: Vec<Option<String>>) -> Vec<String> {
    v.into_iter().map(Option::unwrap_or_default).collect()
}

fn floats(v: Vec<Option<f64>>) -> Vec<f64> {
    v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect()
}

fn coefficient_rows(df: &DataFrame, path: &Path) -> Result<Vec<CoefficientRecord>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let (model, family, name) = (
        strings(req_str(df, "model", path)?),
        strings(req_str(df, "family", path)?),
        strings(req_str(df, "name", path)?),
    );
    let value = floats(req_f64(df, "value", path)?);
    let std_error = req_f64(df, "std_error", path)?;
    let at_bound = req_bool(df, "at_bound", path)?;
    Ok((0..df.height())
        .map(|i| CoefficientRecord {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            model: model[i].clone(),
            family: family[i].clone(),
            name: name[i].clone(),
            value: value[i],
            std_error: std_error[i].filter(|v| v.is_finite()),
            at_bound: at_bound[i].unwrap_or(false),
        })
        .collect())
}

fn quality_rows(df: &DataFrame, path: &Path) -> Result<Vec<QualityRow>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let channel = strings(req_str(df, "channel", path)?);
    let h = df.height();
    let f = |n: &str| -> Result<Vec<Option<f64>>, StoreError> {
        Ok(opt_f64(df, n, path)?.unwrap_or_else(|| vec![None; h]))
    };
    let i = |n: &str| -> Result<Vec<Option<i64>>, StoreError> {
        Ok(opt_i64(df, n, path)?.unwrap_or_else(|| vec![None; h]))
    };
    let termination = opt_str(df, "termination", path)?.unwrap_or_else(|| vec![None; h]);
    let model = opt_str(df, "model", path)?.unwrap_or_else(|| vec![None; h]);
    let (n, iterations, folds) = (i("n")?, i("iterations")?, i("oos_folds")?);
    let (n_free, rank) = (i("n_free")?, i("jacobian_rank")?);
    let (oos_rmse, oos_ratio, trend, trend_pct, condition) = (
        f("oos_rmse")?,
        f("oos_ratio")?,
        f("trend_dev_max")?,
        f("trend_dev_pct_of_peak")?,
        f("condition_number")?,
    );
    let oos_flag = opt_bool(df, "oos_flag", path)?.unwrap_or_else(|| vec![None; h]);
    let (rmse, pct, r2, sample, initial) = (
        f("rmse")?,
        f("rmse_pct_of_peak")?,
        f("r2")?,
        f("sample_rmse")?,
        f("initial_rmse")?,
    );
    Ok((0..h)
        .map(|k| QualityRow {
            tire: tire[k].clone(),
            rim_in: rim[k],
            pressure_kpa: p[k],
            model: model[k].clone().unwrap_or_else(|| PAC2002.to_string()),
            channel: channel[k].clone(),
            oos_rmse: oos_rmse[k],
            oos_ratio: oos_ratio[k],
            oos_flag: oos_flag[k],
            oos_folds: folds[k],
            trend_dev_max: trend[k],
            trend_dev_pct_of_peak: trend_pct[k],
            n_free: n_free[k],
            jacobian_rank: rank[k],
            condition_number: condition[k],
            n: n[k],
            rmse: rmse[k],
            rmse_pct_of_peak: pct[k],
            r2: r2[k],
            sample_rmse: sample[k],
            initial_rmse: initial[k],
            iterations: iterations[k],
            termination: termination[k].clone(),
        })
        .collect())
}

fn spring_rate_rows(df: &DataFrame, path: &Path) -> Result<Vec<SpringRateRecord>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    if df.schema().contains("ia_deg_nom") && !df.schema().contains("ia_cdeg_nom") {
        return Err(StoreError::Schema {
            table: path.display().to_string(),
            message: "written by an older tirebase (inclination ia_deg_nom in whole degrees, -1 \
                      for swept): re-ingest the store (`tirebase ingest --store STORE RAW...`) \
                      and fit again"
                .to_string(),
        });
    }
    let ia = req_i64(df, "ia_cdeg_nom", path)?;
    let condition = strings(req_str(df, "condition", path)?);
    let cz = floats(req_f64(df, "stiffness_n_per_m", path)?);
    Ok((0..df.height())
        .map(|i| SpringRateRecord {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            ia_cdeg_nom: ia[i],
            condition: condition[i].clone(),
            stiffness_n_per_m: cz[i],
        })
        .collect())
}

fn thermal_rows(df: &DataFrame, path: &Path) -> Result<Vec<ThermalRow>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let segment_id = strings(req_str(df, "segment_id", path)?);
    let quadrant = strings(req_str(df, "quadrant", path)?);
    let et = floats(req_f64(df, "et_peak_s", path)?);
    let t = floats(req_f64(df, "t_centre_peak_c", path)?);
    let mu = floats(req_f64(df, "mu_peak", path)?);
    Ok((0..df.height())
        .map(|i| ThermalRow {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            segment_id: segment_id[i].clone(),
            quadrant: quadrant[i].clone(),
            et_peak_s: et[i],
            t_centre_peak_c: t[i],
            mu_peak: mu[i],
        })
        .collect())
}

fn thermal_fit_rows(df: &DataFrame, path: &Path) -> Result<Vec<ThermalFitRecord>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let f = |n: &str| req_f64(df, n, path).map(floats);
    let (t_peak, gain, t_cold, k, hot, mu) = (
        f("t_peak_c")?,
        f("gain_peak_over_cold")?,
        f("t_cold_c")?,
        f("k_cold_per_c2")?,
        f("hot_falloff")?,
        f("mu_peak_mean")?,
    );
    let converged = req_bool(df, "converged", path)?;
    Ok((0..df.height())
        .map(|i| ThermalFitRecord {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            t_peak_c: t_peak[i],
            gain_peak_over_cold: gain[i],
            t_cold_c: t_cold[i],
            k_cold_per_c2: k[i],
            hot_falloff: hot[i],
            mu_peak_mean: mu[i],
            converged: converged[i].unwrap_or(true),
        })
        .collect())
}

fn relaxation_rows(df: &DataFrame, path: &Path) -> Result<Vec<RelaxationRecord>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let (direction, method) = (
        strings(req_str(df, "direction", path)?),
        strings(req_str(df, "method", path)?),
    );
    let fz = floats(req_f64(df, "fz_n_mean", path)?);
    let sigma = floats(req_f64(df, "sigma_m", path)?);
    let converged = req_bool(df, "converged", path)?;
    Ok((0..df.height())
        .map(|i| RelaxationRecord {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            direction: direction[i].clone(),
            method: method[i].clone(),
            fz_n_mean: fz[i],
            sigma_m: sigma[i],
            converged: converged[i].unwrap_or(true),
        })
        .collect())
}

fn lint_rows(df: &DataFrame, path: &Path) -> Result<Vec<LintRow>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let s = |n: &str| req_str(df, n, path).map(strings);
    let (file, severity, code, message) = (s("file")?, s("severity")?, s("code")?, s("message")?);
    let model = opt_str(df, "model", path)?.unwrap_or_else(|| vec![None; df.height()]);
    Ok((0..df.height())
        .map(|i| LintRow {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            model: model[i].clone().unwrap_or_else(|| PAC2002.to_string()),
            file: file[i].clone(),
            severity: severity[i].clone(),
            code: code[i].clone(),
            message: message[i].clone(),
        })
        .collect())
}

fn inertia_rows(df: &DataFrame, path: &Path) -> Result<Vec<InertiaResult>, StoreError> {
    let s = |n: &str| req_str(df, n, path).map(strings);
    let (session, run, object, axis, quantity, method, units) = (
        s("session")?,
        s("run")?,
        s("object")?,
        s("axis")?,
        s("quantity")?,
        s("method")?,
        s("units")?,
    );
    // optional: the report does not show it, and test tables may leave it out
    let diagnostics = opt_str(df, "diagnostics", path)?
        .map(strings)
        .unwrap_or_else(|| vec![String::new(); df.height()]);
    let value = floats(req_f64(df, "value", path)?);
    let uncertainty = floats(req_f64(df, "uncertainty", path)?);
    Ok((0..df.height())
        .map(|i| InertiaResult {
            session: session[i].clone(),
            run: run[i].clone(),
            object: object[i].clone(),
            axis: axis[i].clone(),
            quantity: quantity[i].clone(),
            method: method[i].clone(),
            value: value[i],
            uncertainty: uncertainty[i],
            units: units[i].clone(),
            diagnostics: diagnostics[i].clone(),
        })
        .collect())
}

/// `fit_failures` rows. A table written before the `fatal` column existed has only fatal rows.
fn fit_failure_rows(df: &DataFrame, path: &Path) -> Result<Vec<FitFailure>, StoreError> {
    let (tire, rim, p) = group_keys(df, path)?;
    let s = |n: &str| req_str(df, n, path).map(strings);
    let (stage, scope, reason) = (s("stage")?, s("scope")?, s("reason")?);
    let fatal = opt_bool(df, "fatal", path)?.unwrap_or_else(|| vec![Some(true); df.height()]);
    Ok((0..df.height())
        .map(|i| FitFailure {
            tire: tire[i].clone(),
            rim_in: rim[i],
            pressure_kpa: p[i],
            stage: stage[i].clone(),
            scope: scope[i].clone(),
            fatal: fatal[i].unwrap_or(true),
            reason: reason[i].clone(),
        })
        .collect())
}

/// The `fit_failures` rows of a result directory that belong to `groups`.
pub fn read_fit_failures(
    dir: &Path,
    groups: &BTreeSet<GroupKey>,
) -> Result<Vec<FitFailure>, StoreError> {
    if groups.is_empty() {
        return Ok(Vec::new());
    }
    let Some(df) = read_table(dir, TableName::FitFailures)? else {
        return Ok(Vec::new());
    };
    Ok(
        fit_failure_rows(&df, &table_path(dir, TableName::FitFailures))?
            .into_iter()
            .filter(|f| groups.contains(&(f.tire.clone(), f.rim_in, f.pressure_kpa)))
            .collect(),
    )
}

/// The groups of a result directory that have a PAC2002 `.tir`: those of its `coefficients`
/// rows of model `pac2002` (every row of a table without the column; empty when it has none or
/// it cannot be read).
pub fn model_groups(dir: &Path) -> BTreeSet<GroupKey> {
    groups_with_model(dir, PAC2002)
}

/// The tires and rims of a result directory that have an MF 6.1 `.tir`, keyed at its `NOMPRES`
/// (kPa): its `coefficients` rows of model `mf61`.
pub fn mf61_groups(dir: &Path) -> BTreeSet<GroupKey> {
    groups_with_model(dir, MF61)
}

fn groups_with_model(dir: &Path, model: &str) -> BTreeSet<GroupKey> {
    let Ok(Some(df)) = read_table(dir, TableName::Coefficients) else {
        return BTreeSet::new();
    };
    let path = table_path(dir, TableName::Coefficients);
    let (Ok(tire), Ok(rim), Ok(p), Ok(models)) = (
        req_str(&df, "tire", &path),
        req_i64(&df, "rim_in", &path),
        req_i64(&df, "pressure_kpa", &path),
        opt_str(&df, "model", &path),
    ) else {
        return BTreeSet::new();
    };
    let models = models.unwrap_or_else(|| vec![Some(PAC2002.to_string()); df.height()]);
    tire.into_iter()
        .zip(rim)
        .zip(p)
        .zip(models)
        .filter(|(_, m)| m.as_deref().is_some_and(|m| is_model(m, model)))
        .filter_map(|(((t, r), p), _)| Some((t?, r?, p?)))
        .collect()
}

/// The MF 6.1 `.tir` file name of every tire and rim of a set (keyed at `NOMPRES`:
/// `naming::unique_mf61_names`), with the notes of the disambiguated ones.
pub fn mf61_names(groups: &BTreeSet<GroupKey>) -> TirNames {
    let keys: Vec<&GroupKey> = groups.iter().collect();
    let args: Vec<(&str, f64)> = keys
        .iter()
        .map(|(t, r, _)| (t.as_str(), *r as f64))
        .collect();
    by_group(keys, unique_mf61_names(&args))
}

/// A fitted model as a result directory's `tir/` holds it.
#[derive(Clone, Debug)]
pub struct TirModel {
    /// The model.
    pub model: Pac2002,
    /// `[MODEL] USE_MODE` of the file.
    pub use_mode: Option<i64>,
}

/// Why a `.tir` file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum TirModelError {
    /// The file could not be read.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The file is not a readable `.tir`.
    #[error(transparent)]
    Read(#[from] TirReadError),
}

/// Read one `.tir` file.
pub fn read_tir_model(path: &Path) -> Result<TirModel, TirModelError> {
    let bytes = std::fs::read(path)?;
    let (tir, _) = TirFile::parse_bytes(&bytes)?;
    Ok(TirModel {
        model: tir.model(),
        use_mode: tir.use_mode,
    })
}

/// Every `.tir` of a result directory's `tir_dir` by file name, and one note per file that
/// cannot be read (`tir/<name>: unreadable: ...`; `tir/: no .tir directory` when there is none).
pub fn read_tir_models(tir_dir: &Path) -> (BTreeMap<String, TirModel>, Vec<String>) {
    let mut models = BTreeMap::new();
    let mut notes = Vec::new();
    let Ok(entries) = std::fs::read_dir(tir_dir) else {
        notes.push("tir/: no .tir directory".to_string());
        return (models, notes);
    };
    let mut paths: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "tir"))
        .collect();
    paths.sort();
    for path in paths {
        let name = path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        match read_tir_model(&path) {
            Ok(m) => {
                models.insert(name, m);
            }
            Err(e) => notes.push(format!("tir/{name}: unreadable: {e}")),
        }
    }
    (models, notes)
}

/// `.tir` file names by group, and the notes of the disambiguated ones.
pub type TirNames = (BTreeMap<GroupKey, String>, Vec<(GroupKey, String)>);

/// Names of `keys` (in their order) as [`TirNames`]: each key's name, and its note when the
/// name was disambiguated.
fn by_group(keys: Vec<&GroupKey>, named: Vec<(String, Option<String>)>) -> TirNames {
    let mut names = BTreeMap::new();
    let mut notes = Vec::new();
    for (key, (name, note)) in keys.into_iter().zip(named) {
        if let Some(n) = note {
            notes.push((key.clone(), n));
        }
        names.insert(key.clone(), name);
    }
    (names, notes)
}

/// The `.tir` file name of every group of a set (`naming::unique_tir_names`: a version names
/// each model among all of its models), with the notes of the disambiguated ones.
pub fn tir_names(groups: &BTreeSet<GroupKey>) -> TirNames {
    let keys: Vec<&GroupKey> = groups.iter().collect();
    let args: Vec<(&str, f64, f64)> = keys
        .iter()
        .map(|(t, r, p)| (t.as_str(), *r as f64, *p as f64))
        .collect();
    by_group(keys, unique_tir_names(&args))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_become_typed_rows_and_a_missing_column_is_a_note_naming_it() {
        let mut frames = BTreeMap::new();
        frames.insert(
            "relaxation".to_string(),
            df!(
                "tire" => ["X"], "rim_in" => [7i64], "pressure_kpa" => [83i64],
                "direction" => ["lateral"], "method" => ["step"], "fz_n_mean" => [1000.0],
                "sigma_m" => [0.2], "converged" => [true],
            )
            .unwrap(),
        );
        frames.insert(
            "spring_rate".to_string(),
            df!("tire" => ["X"], "something" => [1.0]).unwrap(),
        );
        let r = Results::from_frames(&frames);
        let relax = r.relaxation.as_ref().unwrap();
        assert_eq!(relax.len(), 1);
        assert_eq!(relax[0].sigma_m, 0.2);
        assert!(r.spring_rate.is_none());
        assert!(
            r.notes
                .iter()
                .any(|n| n.starts_with("spring_rate.parquet: unreadable") && n.contains("rim_in")),
            "{:?}",
            r.notes
        );
        assert!(r.notes.iter().any(|n| n == "thermal.parquet: not present"));
        assert_eq!(r.groups(), BTreeSet::from([("X".to_string(), 7, 83)]));
    }

    /// A held negative inclination is a level, not "swept": only the table's null reads as None.
    #[test]
    fn a_negative_held_inclination_is_kept() {
        let df = df!(
            "tire" => ["X", "X", "X"], "rim_in" => [7i64, 7, 7], "pressure_kpa" => [83i64, 83, 83],
            "ia_cdeg_nom" => [Some(-100i64), None, Some(160)],
            "condition" => ["dynamic", "sweep", "dynamic"],
            "stiffness_n_per_m" => [1.0e5, 1.0e5, 1.0e5],
        )
        .unwrap();
        let rows = spring_rate_rows(&df, Path::new("spring_rate.parquet")).unwrap();
        let ia: Vec<Option<i64>> = rows.iter().map(|r| r.ia_cdeg_nom).collect();
        assert_eq!(ia, vec![Some(-100), None, Some(160)]);
    }

    /// A table of an older layout names what to do instead of a missing column.
    #[test]
    fn an_old_inclination_key_asks_for_a_re_ingest() {
        let df = df!(
            "tire" => ["X"], "rim_in" => [7i64], "pressure_kpa" => [83i64],
            "ia_deg_nom" => [-1i64], "condition" => ["sweep"], "stiffness_n_per_m" => [1.0e5],
        )
        .unwrap();
        let err = spring_rate_rows(&df, Path::new("spring_rate.parquet")).unwrap_err();
        assert!(err.to_string().contains("tirebase ingest"), "{err}");
    }

    #[test]
    fn fit_failures_without_the_fatal_column_are_fatal() {
        let df = df!(
            "tire" => ["X", "Y"], "rim_in" => [7i64, 8], "pressure_kpa" => [83i64, 97],
            "stage" => ["pac2002", "thermal"], "scope" => ["pac2002", "fy"],
            "reason" => ["no data", "too few"],
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        write_table(dir.path(), "fit_failures", &mut df.clone()).unwrap();
        let only_y = BTreeSet::from([("Y".to_string(), 8, 97)]);
        let rows = read_fit_failures(dir.path(), &only_y).unwrap();
        assert_eq!(rows.len(), 1);
        assert!(rows[0].fatal);
        assert_eq!(rows[0].scope, "fy");
    }
}
