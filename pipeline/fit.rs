//! The fitting orchestration behind `tirebase fit` (and the nightly `run`): the store's live
//! segments in, per (tire, rim, nominal pressure) fitted models and stage tables out.
//!
//! ```text
//! plan_groups:  segments table (live rows) ─▶ one GroupPlan per (tire, rim, pressure) with the
//!               hash of everything its fit depends on
//! fit_groups:   rayon pool of `jobs` threads, one group per task:
//!               load samples ─▶ spring rate ─▶ PAC2002 (forces) ─▶ relaxation ─▶ PAC2002
//!               on de-lagged sweeps ─▶ relaxation ; thermal          (fit::group)
//!               ─▶ .tir text + lint (an error is a fit_failures row)   (fit::tir)
//!               ─▶ the group's sweeps collapsed for MF 6.1 (no samples kept)
//!               then, same pool, one (tire, rim) per task: MF 6.1 across its pressures
//!               ─▶ .tir text + lint                                   (fit::mf61)
//!               ─▶ tables in group order          (fit::tables)
//! write_outcome: OUT/<table>.parquet, OUT/tir/*.tir (atomic writes)
//! ```
//!
//! A failed group or stage is a row of `fit_failures` (and of [`FitResults::failures`]), never an
//! `Err`: `Err` is reserved for a store that cannot be read or an output that cannot be written.
//! With MF 6.1 on (`[fit] models`), the groups of one tire and rim are planned as one unit: each
//! group's input hash covers its siblings', so a change at one pressure refits them all and the
//! MF 6.1 model (keyed at its `NOMPRES`, one of the tested pressures) is carried over or refit
//! with them. Output is deterministic: groups are sorted by key, every stage is single-threaded and
//! deterministic within its group, so any `jobs` gives the same tables (the `seconds` column of
//! `fit_quality` and [`FitResults::stage_seconds`] are wall time and excepted).
//!
//! Deliberately not here: the fitting math (`tirebase_core::fit`), the command line and exit
//! codes (`commands::fit`), the store lock (the caller holds it), versioning (`run`).

mod group;
mod load;
mod mf61;
mod tables;
mod tir;

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use polars::prelude::*;
use rayon::prelude::*;
use tirebase_core::fit::mf61::Mf61Config;
use tirebase_core::fit::segment_data::TireKey;
use tirebase_core::fit::sweep_folds::OutOfSampleQuality;
use tirebase_core::naming::{sanitize_tire, unique_mf61_names, unique_tir_names};
use tirebase_core::numerics::cpu_clock::thread_cpu_seconds;
use tirebase_core::tire_model::tir::lint::Severity;

pub use crate::store::results::FitFailure;
pub use group::StageConfigs;
pub use load::{LoadedSegment, SegmentRow, judge_qc, live_segments, parse_qc_flag};

use crate::config::{Config, FitModel};
use crate::progress::Progress;
use crate::schema::TableName;
use crate::store::StoreError;
use crate::store::files::{ensure_dir, sha256_bytes, write_bytes_atomic};

/// Store-level errors of the fitting orchestration (per-group problems are data).
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The store could not be read or an output could not be written.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A table could not be built.
    #[error("fit: {0}")]
    Polars(#[from] PolarsError),
    /// The path is not a store.
    #[error("{0} is not a tirebase store (no runs/runs.parquet: ingest first)")]
    NotAStore(String),
    /// The segments table names a segment whose samples are missing.
    #[error("{path}: no samples of segment {segment} (store damaged? re-ingest the file)")]
    MissingSamples {
        /// The samples file.
        path: PathBuf,
        /// The segment.
        segment: String,
    },
    /// A result table could not be assembled.
    #[error("table {table}: {message}")]
    Table {
        /// The table.
        table: TableName,
        /// What went wrong.
        message: String,
    },
    /// The worker pool could not start.
    #[error("cannot start {jobs} worker threads: {message}")]
    Pool {
        /// Threads asked for.
        jobs: usize,
        /// Why.
        message: String,
    },
}

/// Why a `--stages` list was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum StageListError {
    /// A name that is no stage.
    #[error("unknown stage '{0}' (stages: {stages}, all)", stages = StageSet::NAMES.join(", "))]
    Unknown(String),
    /// The list names no stage.
    #[error("no stage given")]
    Empty,
}

/// Which stages to run.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct StageSet {
    /// PAC2002 steady-state fit and the `.tir` (coefficients, fit_quality, lint).
    pub pac2002: bool,
    /// Vertical stiffness, unloaded radius, effective rolling radius (spring_rate).
    pub spring_rate: bool,
    /// mu(T) from cold-to-warm tests (thermal, thermal_fit).
    pub thermal: bool,
    /// Relaxation lengths, contact length, carcass stiffness, PTY*/PTX* (relaxation).
    pub relaxation: bool,
}

impl Default for StageSet {
    fn default() -> Self {
        StageSet {
            pac2002: true,
            spring_rate: true,
            thermal: true,
            relaxation: true,
        }
    }
}

impl StageSet {
    /// Stage names, in run order.
    pub const NAMES: [&'static str; 4] = ["spring_rate", "pac2002", "relaxation", "thermal"];

    /// Parse a comma-separated list of stage names (`all` = every stage).
    ///
    /// ```
    /// use tirebase::fit::StageSet;
    /// let s = StageSet::parse("pac2002, thermal").unwrap();
    /// assert!(s.pac2002 && s.thermal && !s.spring_rate && !s.relaxation);
    /// assert_eq!(StageSet::parse("all").unwrap(), StageSet::default());
    /// assert!(StageSet::parse("pac").is_err());
    /// ```
    pub fn parse(list: &str) -> Result<StageSet, StageListError> {
        let mut s = StageSet {
            pac2002: false,
            spring_rate: false,
            thermal: false,
            relaxation: false,
        };
        for name in list.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            match name {
                "all" => s = StageSet::default(),
                "pac2002" => s.pac2002 = true,
                "spring_rate" => s.spring_rate = true,
                "thermal" => s.thermal = true,
                "relaxation" => s.relaxation = true,
                other => return Err(StageListError::Unknown(other.to_string())),
            }
        }
        if s.names().is_empty() {
            return Err(StageListError::Empty);
        }
        Ok(s)
    }

    /// The enabled stages, in run order.
    pub fn names(&self) -> Vec<&'static str> {
        StageSet::NAMES
            .into_iter()
            .filter(|n| match *n {
                "pac2002" => self.pac2002,
                "spring_rate" => self.spring_rate,
                "thermal" => self.thermal,
                _ => self.relaxation,
            })
            .collect()
    }
}

impl fmt::Display for StageSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.names().join(","))
    }
}

/// What to fit (default: every tire, every stage, one thread per core).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitOptions {
    /// Only this tire (its name as stored, or its sanitised file-name form).
    pub tire: Option<String>,
    /// Stages to run.
    pub stages: StageSet,
    /// Worker threads (0 = one per core). Results do not depend on it.
    pub jobs: usize,
}

/// One (tire, rim, nominal pressure) group and the hash of everything its fit depends on: the
/// sorted (segment_id, source_sha256, store part, qc_flags) of its usable segments (the part
/// names the segmentation settings and tool that computed them), the resolved stage
/// configurations, the stage set and the tool version.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GroupPlan {
    /// The group.
    pub key: TireKey,
    /// SHA-256 (hex) of the inputs.
    pub input_sha256: String,
    /// Live segments of kinds the enabled stages read (QC-flagged ones included: the stages
    /// decide what a flag excludes).
    pub n_segments: usize,
}

impl FitFailure {
    fn new(key: &TireKey, stage: &str, scope: &str, fatal: bool, reason: String) -> FitFailure {
        FitFailure {
            tire: key.tire.clone(),
            rim_in: key.rim_in,
            pressure_kpa: key.pressure_kpa_nom,
            stage: stage.to_string(),
            scope: scope.to_string(),
            fatal,
            reason: reason.replace('\n', " "),
        }
    }
}

/// The reason of a family's out-of-sample flag row (scoped by
/// [`crate::store::results::out_of_sample_scope`]), the same for PAC2002 and MF 6.1: it leads
/// with what raised the flag (the held-out error over the limit, folds that could not determine
/// the coefficients, or both), then the figures. `check` says how the folds were dealt
/// (`by sweep`); `limit` is [`OutOfSampleQuality::oos_flagged`]'s.
fn out_of_sample_reason(q: &impl OutOfSampleQuality, limit: f64, check: &str) -> String {
    let over = q.oos_ratio_over(limit);
    let (deficient, folds) = (q.oos_deficient_folds(), q.oos_folds());
    let undetermined = format!(
        "{deficient} of {folds} folds could not determine the coefficients without their \
         held-out sweeps (their held-out error is optimistic)"
    );
    let lead = match (over, deficient > 0) {
        (true, true) => format!("good in sample, bad out of sample, and {undetermined}"),
        (true, false) => "good in sample, bad out of sample".to_string(),
        (false, _) => undetermined,
    };
    let verdict = if over { "over" } else { "within" };
    format!(
        "{lead}: held-out sweeps RMSE {:.4} vs {:.4} in sample ({:.2}x, {verdict} the limit of \
         {limit}x plus 0.1 % of peak; {folds}-fold {check})",
        q.oos_rmse().unwrap_or(f64::NAN),
        q.rmse(),
        q.oos_ratio(),
    )
}

/// Effort of one group (wall time is not deterministic; for reports and benchmarks).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupStats {
    /// The group.
    pub key: Option<TireKey>,
    /// Wall time per stage (`load`, `spring_rate`, `pac2002`, `relaxation`, `thermal`), s.
    pub stage_seconds: BTreeMap<String, f64>,
    /// PAC2002 fits run (2 when refitted on de-lagged sweeps).
    pub pac2002_fits: usize,
    /// Model evaluations (residual vectors plus Jacobians) of those fits.
    pub pac2002_evaluations: usize,
    /// CPU time of the thread that ran the stages (load excluded), s; `None` where the OS
    /// does not tell (non-Linux). Unlike wall time it does not grow on a loaded machine.
    pub cpu_seconds: Option<f64>,
}

impl fmt::Display for GroupStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(k) = &self.key {
            write!(f, "{k}:")?;
        }
        for (stage, s) in &self.stage_seconds {
            write!(f, " {stage} {s:.3} s")?;
            if stage == "pac2002" {
                write!(
                    f,
                    " ({} fits, {} evaluations)",
                    self.pac2002_fits, self.pac2002_evaluations
                )?;
            }
            write!(f, ",")?;
        }
        let fitting: f64 = self
            .stage_seconds
            .iter()
            .filter(|(s, _)| s.as_str() != "load")
            .map(|(_, t)| t)
            .sum();
        write!(f, " all stages {fitting:.3} s wall")?;
        if let Some(cpu) = self.cpu_seconds {
            write!(f, ", {cpu:.2} s CPU")?;
        }
        Ok(())
    }
}

/// Everything a fit produced.
#[derive(Clone, Debug, Default)]
pub struct FitResults {
    /// Result tables by name: `coefficients`, `fit_quality`, `spring_rate`, `thermal`,
    /// `thermal_fit`, `relaxation`, `lint`, `fit_failures`. Every table has the columns `tire`
    /// (str), `rim_in` (i64), `pressure_kpa` (i64, nominal). Sorted deterministically;
    /// conformed to `schemas/<name>.toml`.
    pub tables: BTreeMap<String, DataFrame>,
    /// `.tir` files: (file name from `tirebase_core::naming::unique_tir_names` over the fitted
    /// groups, or `unique_mf61_names` over the fitted tires and rims, text): the PAC2002 files
    /// in group order, then the MF 6.1 files in (tire, rim) order.
    pub tir_files: Vec<(String, String)>,
    /// The group of each entry of `tir_files` (an MF 6.1 file's: its tire, rim and `NOMPRES`).
    pub tir_keys: Vec<TireKey>,
    /// The model of each entry of `tir_files`.
    pub tir_models: Vec<FitModel>,
    /// One line per `.tir` whose name was disambiguated (tires whose names sanitise alike).
    pub tir_name_notes: Vec<String>,
    /// Failures, fatal and partial, in group order.
    pub failures: Vec<FitFailure>,
    /// Wall time per stage summed over groups (plus `load`), s.
    pub stage_seconds: BTreeMap<String, f64>,
    /// Per group (in group order): wall time per stage and PAC2002 effort.
    pub group_stats: Vec<GroupStats>,
    /// Groups fitted (planned).
    pub groups: usize,
    /// Groups with at least one fatal failure.
    pub groups_failed: usize,
    /// Groups for which no stage produced anything.
    pub groups_empty: usize,
}

impl FitResults {
    /// Count one tire and rim's MF 6.1 stage: its failures (fatal: no model; partial: a family
    /// flagged out of sample, one tested pressure, lint errors) become `fit_failures` rows and
    /// its wall time the `mf61` stage's.
    fn add_mf61(&mut self, o: &mf61::Mf61Outcome) {
        self.failures.extend(o.failures.iter().cloned());
        *self
            .stage_seconds
            .entry(mf61::STAGE.to_string())
            .or_default() += o.seconds;
    }

    /// The fatal failures.
    pub fn fatal(&self) -> impl Iterator<Item = &FitFailure> {
        self.failures.iter().filter(|f| f.fatal)
    }

    /// A one-line summary.
    pub fn summary(&self) -> String {
        let rows = |t: &str| self.tables.get(t).map_or(0, DataFrame::height);
        let mf61 = self
            .tir_models
            .iter()
            .filter(|m| **m == FitModel::Mf61)
            .count();
        format!(
            "{} groups: {} .tir files ({mf61} MF 6.1), {} spring-rate rows, {} relaxation rows, {} thermal fits; \
             {} groups with failed stages ({} fatal failures, {} partial)",
            self.groups,
            self.tir_files.len(),
            rows("spring_rate"),
            rows("relaxation"),
            rows("thermal_fit"),
            self.groups_failed,
            self.fatal().count(),
            self.failures.len() - self.fatal().count()
        )
    }
}

/// The resolved configuration of every stage: `[fit]` for PAC2002, `[fit.spring_rate]`,
/// `[fit.thermal]`, `[fit.relaxation]` for the others.
pub fn stage_configs(config: &Config) -> StageConfigs {
    StageConfigs {
        pac2002: config.fit.pac2002(),
        spring_rate: config.fit.spring_rate,
        thermal: config.fit.thermal,
        relaxation: config.fit.relaxation,
    }
}

fn tire_matches(wanted: &str, tire: &str) -> bool {
    wanted == tire || sanitize_tire(wanted) == sanitize_tire(tire)
}

/// Group the store's live segments by (tire, rim, nominal pressure); only groups with a segment
/// some enabled stage reads, sorted by key. Segments without a held pressure are not fitted.
pub fn plan_groups(
    store: &Path,
    config: &Config,
    opts: &FitOptions,
) -> Result<Vec<GroupPlan>, FitError> {
    let rows = live_segments(store)?;
    let cfg = stage_configs(config);
    let mut groups: BTreeMap<TireKey, Vec<&SegmentRow>> = BTreeMap::new();
    for row in &rows {
        if !group::used_by(&opts.stages, &cfg, row.kind)
            || opts
                .tire
                .as_deref()
                .is_some_and(|t| !tire_matches(t, &row.key.tire))
        {
            continue;
        }
        groups.entry(row.key.clone()).or_default().push(row);
    }
    let config_text = format!(
        "{}\n{:?}\nstages {}\ntirebase {}\n",
        toml::to_string(&config.fit).unwrap_or_default(),
        cfg.pac2002,
        opts.stages,
        env!("CARGO_PKG_VERSION")
    );
    let plans: Vec<GroupPlan> = groups
        .into_iter()
        .map(|(key, segs)| {
            let mut lines: Vec<String> = segs
                .iter()
                .map(|s| {
                    format!(
                        "{}\t{}\t{}\t{}\n",
                        s.segment_id, s.source_sha256, s.part, s.qc_flags
                    )
                })
                .collect();
            lines.sort();
            let text = format!("{key}\n{}{config_text}", lines.concat());
            GroupPlan {
                key,
                input_sha256: sha256_bytes(text.as_bytes()),
                n_segments: segs.len(),
            }
        })
        .collect();
    Ok(
        if opts.stages.pac2002 && config.fit.writes(FitModel::Mf61) {
            with_sibling_hashes(plans)
        } else {
            plans
        },
    )
}

/// Each group's hash extended by those of every group of its tire and rim (the MF 6.1 model
/// reads them all): a change at one pressure refits the tire and rim's every group.
fn with_sibling_hashes(plans: Vec<GroupPlan>) -> Vec<GroupPlan> {
    let mut siblings: BTreeMap<(String, i64), String> = BTreeMap::new();
    for p in &plans {
        siblings
            .entry((p.key.tire.clone(), p.key.rim_in))
            .or_default()
            .push_str(&format!("{} {}\n", p.key, p.input_sha256));
    }
    plans
        .into_iter()
        .map(|mut p| {
            let all = &siblings[&(p.key.tire.clone(), p.key.rim_in)];
            p.input_sha256 =
                sha256_bytes(format!("{}\nmf61 over\n{all}", p.input_sha256).as_bytes());
            p
        })
        .collect()
}

/// What one group produced, before the tables are assembled.
struct GroupOutput {
    result: group::GroupResult,
    model: Option<tir::WrittenModel>,
    mf61: Option<mf61::Mf61Part>,
    cpu_seconds: Option<f64>,
}

/// One group's stages: its result, its PAC2002 file (when written) and its MF 6.1 part (when
/// MF 6.1 is fitted).
struct GroupRun {
    result: group::GroupResult,
    model: Option<tir::WrittenModel>,
    mf61: Option<mf61::Mf61Part>,
}

/// Which models are written.
#[derive(Clone, Debug)]
struct Models {
    pac2002: bool,
    mf61: Option<Mf61Config>,
}

impl Models {
    fn of(config: &Config, stages: &StageSet) -> Models {
        Models {
            pac2002: config.fit.writes(FitModel::Pac2002),
            mf61: (stages.pac2002 && config.fit.writes(FitModel::Mf61)).then(|| config.fit.mf61()),
        }
    }
}

fn fit_one(
    store: &Path,
    rows: &[SegmentRow],
    plan: &GroupPlan,
    opts: &FitOptions,
    cfg: &StageConfigs,
    models: &Models,
) -> Result<GroupOutput, FitError> {
    let started = std::time::Instant::now();
    let mine: Vec<&SegmentRow> = rows
        .iter()
        .filter(|r| r.key == plan.key && group::used_by(&opts.stages, cfg, r.kind))
        .collect();
    // polars parallelises reads on its own rayon pool. Called from a worker of our pool, that
    // `install` would let the waiting worker steal and run *another group* meanwhile (nested
    // groups, their memory held at once, time charged to the wrong group). A plain scoped thread
    // makes the wait a real block.
    let segments = std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(crate::WORKER_STACK_BYTES)
            .spawn_scoped(s, || load::load_segments(store, &mine))
            .map_err(|e| FitError::Pool {
                jobs: opts.jobs,
                message: format!("spawning a reader thread: {e}"),
            })?
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })?;
    let load_seconds = started.elapsed().as_secs_f64();
    let cpu0 = thread_cpu_seconds();
    let GroupRun {
        mut result,
        model,
        mf61,
    } = guarded(&plan.key, || {
        let mut result = group::run(&plan.key, &segments, &opts.stages, cfg);
        let mut model = None;
        if opts.stages.pac2002
            && let Some(fit) = &result.pac2002
        {
            match tir::build(&result, &fit.notes) {
                Ok(m) => {
                    // A written model the lint calls physically wrong (a spike, a force against
                    // its slip, friction above 4, ...) is never silent: one row per error.
                    for f in m
                        .lint
                        .findings
                        .iter()
                        .filter(|f| models.pac2002 && f.severity == Severity::Error)
                    {
                        result.failures.push(FitFailure::new(
                            &plan.key,
                            "pac2002",
                            &crate::store::results::lint_scope(&m.file_name, f.code),
                            false,
                            f.message.clone(),
                        ));
                    }
                    model = Some(m);
                }
                Err(reason) => result.failures.push(FitFailure::new(
                    &plan.key,
                    "pac2002",
                    "pac2002",
                    true,
                    reason.to_string(),
                )),
            }
        }
        let mf61 = models.mf61.as_ref().map(|c| {
            let vertical = result.spring_rate.as_ref().and_then(|s| s.vertical.first());
            mf61::Mf61Part::new(
                &plan.key,
                &group::mf61_sweeps(&segments, &result, cfg),
                model.as_ref(),
                vertical,
                c,
            )
        });
        GroupRun {
            result,
            model: model.filter(|_| models.pac2002),
            mf61,
        }
    });
    let cpu_seconds = cpu0.zip(thread_cpu_seconds()).map(|(a, b)| b - a);
    result
        .stage_seconds
        .insert("load".to_string(), load_seconds);
    Ok(GroupOutput {
        result,
        model,
        mf61,
        cpu_seconds,
    })
}

/// Run one group's stages; a bug in a stage must not take the other groups down, so a panic
/// becomes a fatal failure of this group (the default hook also prints the panic message).
fn guarded(key: &TireKey, stages: impl FnOnce() -> GroupRun) -> GroupRun {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(stages)).unwrap_or_else(|panic| {
        let mut result = group::GroupResult::new(key);
        result
            .failures
            .push(panic_failure(key, "fit", panic.as_ref()));
        GroupRun {
            result,
            model: None,
            mf61: None,
        }
    })
}

/// A panic of a stage as a fatal failure (the default hook also prints the panic message).
fn panic_failure(key: &TireKey, stage: &str, panic: &(dyn std::any::Any + Send)) -> FitFailure {
    let message = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string());
    FitFailure::new(
        key,
        stage,
        "panic",
        true,
        format!("internal error (a bug; please report): {message}"),
    )
}

/// The MF 6.1 stage of one tire and rim; a panic becomes a fatal failure of it.
fn fit_mf61(
    tire: &str,
    rim_in: i64,
    parts: &[mf61::Mf61Part],
    cfg: &Mf61Config,
) -> mf61::Mf61Outcome {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        mf61::run(tire, rim_in, parts, cfg)
    }))
    .unwrap_or_else(|panic| {
        let pressures: Vec<i64> = parts.iter().map(|p| p.key.pressure_kpa_nom).collect();
        let key = TireKey {
            tire: tire.to_string(),
            rim_in,
            pressure_kpa_nom: (tirebase_core::fit::mf61::Mf61Input::nominal_for(&pressures) / 1e3)
                .round() as i64,
        };
        mf61::Mf61Outcome {
            failures: vec![panic_failure(&key, mf61::STAGE, panic.as_ref())],
            key,
            model: None,
            fit: None,
            seconds: 0.0,
        }
    })
}

/// Fit the given groups in parallel (a rayon pool of `opts.jobs` threads, 0 = one per core); a
/// failed group or stage is a row in `failures`, never an `Err` (`Err` only for store-level
/// problems).
pub fn fit_groups(
    store: &Path,
    config: &Config,
    groups: &[GroupPlan],
    opts: &FitOptions,
    progress: &dyn Progress,
) -> Result<FitResults, FitError> {
    let rows = live_segments(store)?;
    let cfg = stage_configs(config);
    let models = Models::of(config, &opts.stages);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
        .map_err(|e| FitError::Pool {
            jobs: opts.jobs,
            message: e.to_string(),
        })?;
    let bar = progress.stage("fit", "groups", groups.len() as u64);
    let outputs: Vec<Result<GroupOutput, FitError>> = pool.install(|| {
        groups
            .par_iter()
            .map(|plan| {
                let out = fit_one(store, &rows, plan, opts, &cfg, &models);
                bar.inc(1);
                out
            })
            .collect()
    });
    let mut results = Vec::with_capacity(outputs.len());
    let mut written = Vec::new();
    let mut parts: BTreeMap<(String, i64), Vec<mf61::Mf61Part>> = BTreeMap::new();
    let mut outcome = FitResults {
        groups: groups.len(),
        ..FitResults::default()
    };
    for out in outputs {
        let GroupOutput {
            result,
            model,
            mf61,
            cpu_seconds,
        } = out?;
        if let Some(part) = mf61 {
            parts
                .entry((result.key.tire.clone(), result.key.rim_in))
                .or_default()
                .push(part);
        }
        for (stage, s) in &result.stage_seconds {
            *outcome.stage_seconds.entry(stage.clone()).or_default() += s;
        }
        outcome.group_stats.push(GroupStats {
            key: Some(result.key.clone()),
            stage_seconds: result.stage_seconds.clone(),
            pac2002_fits: result.pac2002_fits,
            pac2002_evaluations: result.pac2002_evaluations,
            cpu_seconds,
        });
        let produced = model.is_some()
            || (opts.stages.spring_rate
                && result
                    .spring_rate
                    .as_ref()
                    .is_some_and(|s| !s.rows.is_empty()))
            || (opts.stages.thermal && result.thermal.as_ref().is_some_and(|t| !t.rows.is_empty()))
            || result
                .relaxation
                .as_ref()
                .is_some_and(|r| !r.rows.is_empty());
        if !produced {
            outcome.groups_empty += 1;
        }
        outcome.failures.extend(result.failures.iter().cloned());
        if let Some(m) = model {
            written.push((result.key.clone(), m));
        }
        results.push(result);
    }
    bar.finish(&format!("{} groups", outcome.groups));
    let write_pac2002 = models.pac2002;
    let mf61_outcomes = match &models.mf61 {
        Some(c) if !parts.is_empty() => fit_combinations(&pool, parts, c, progress),
        _ => Vec::new(),
    };
    let mut models = written;
    // File names unique over the groups (tires whose names differ only in case or punctuation
    // would overwrite each other's `.tir`).
    let keys: Vec<(&str, f64, f64)> = models
        .iter()
        .map(|(k, _)| (k.tire.as_str(), k.rim_in as f64, k.pressure_kpa_nom as f64))
        .collect();
    let names = unique_tir_names(&keys);
    for ((_, m), (name, note)) in models.iter_mut().zip(names) {
        m.file_name = name;
        outcome.tir_name_notes.extend(note);
    }
    let mut mf61_models: Vec<(TireKey, tir::WrittenModel)> = mf61_outcomes
        .iter()
        .filter_map(|o| o.model.clone().map(|m| (o.key.clone(), m)))
        .collect();
    let tires: Vec<(&str, f64)> = mf61_models
        .iter()
        .map(|(k, _)| (k.tire.as_str(), k.rim_in as f64))
        .collect();
    let mf61_names = unique_mf61_names(&tires);
    for ((_, m), (name, note)) in mf61_models.iter_mut().zip(mf61_names) {
        m.file_name = name;
        outcome.tir_name_notes.extend(note);
    }
    for o in &mf61_outcomes {
        outcome.add_mf61(o);
    }
    let fatal: std::collections::BTreeSet<(&str, i64, i64)> = outcome
        .fatal()
        .map(|f| (f.tire.as_str(), f.rim_in, f.pressure_kpa))
        .collect();
    outcome.groups_failed = fatal.len();
    models.extend(mf61_models);
    outcome.tir_files = models
        .iter()
        .map(|(_, m)| (m.file_name.clone(), m.text.clone()))
        .collect();
    outcome.tir_keys = models.iter().map(|(k, _)| k.clone()).collect();
    outcome.tir_models = models.iter().map(|(_, m)| m.model).collect();
    let mut tables = BTreeMap::new();
    if opts.stages.pac2002 {
        tables.insert("coefficients".to_string(), tables::coefficients(&models)?);
        tables.insert(
            "fit_quality".to_string(),
            tables::fit_quality(
                &results,
                write_pac2002,
                &mf61_outcomes,
                cfg.pac2002.oos_ratio_limit,
            )?,
        );
        tables.insert("lint".to_string(), tables::lint(&models)?);
    }
    if opts.stages.spring_rate {
        tables.insert("spring_rate".to_string(), tables::spring_rate(&results)?);
    }
    if opts.stages.thermal {
        tables.insert("thermal".to_string(), tables::thermal(&results)?);
        tables.insert("thermal_fit".to_string(), tables::thermal_fit(&results)?);
    }
    if opts.stages.relaxation {
        tables.insert("relaxation".to_string(), tables::relaxation(&results)?);
    }
    tables.insert(
        "fit_failures".to_string(),
        tables::fit_failures(&outcome.failures)?,
    );
    outcome.tables = tables;
    Ok(outcome)
}

/// The MF 6.1 stage of every tire and rim, in parallel on `pool`, in (tire, rim) order.
fn fit_combinations(
    pool: &rayon::ThreadPool,
    parts: BTreeMap<(String, i64), Vec<mf61::Mf61Part>>,
    cfg: &Mf61Config,
    progress: &dyn Progress,
) -> Vec<mf61::Mf61Outcome> {
    let combos: Vec<((String, i64), Vec<mf61::Mf61Part>)> = parts.into_iter().collect();
    let bar = progress.stage("mf61", "tires", combos.len() as u64);
    let out: Vec<mf61::Mf61Outcome> = pool.install(|| {
        combos
            .par_iter()
            .map(|((tire, rim), parts)| {
                let o = fit_mf61(tire, *rim, parts, cfg);
                bar.inc(1);
                o
            })
            .collect()
    });
    let written = out.iter().filter(|o| o.model.is_some()).count();
    bar.finish(&format!("{written} MF 6.1 models"));
    out
}

/// Writes `OUT/<table>.parquet` for every table and `OUT/tir/*.tir` (atomic writes). Files of
/// tables or models this outcome does not hold are left alone.
pub fn write_outcome(outcome: &FitResults, out: &Path) -> Result<(), FitError> {
    ensure_dir(out)?;
    for (name, df) in &outcome.tables {
        let mut df = df.clone();
        crate::store::results::write_table(out, name, &mut df)?;
    }
    if !outcome.tir_files.is_empty() {
        let dir = out.join("tir");
        ensure_dir(&dir)?;
        for (name, text) in &outcome.tir_files {
            write_bytes_atomic(&dir.join(name), text.as_bytes())?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A family's quality figures for [`out_of_sample_reason`].
    struct Figures {
        oos: f64,
        folds: usize,
        deficient: usize,
    }

    impl OutOfSampleQuality for Figures {
        fn rmse(&self) -> f64 {
            10.0
        }
        fn rmse_pct_of_peak(&self) -> f64 {
            1.0
        }
        fn oos_rmse(&self) -> Option<f64> {
            Some(self.oos)
        }
        fn oos_folds(&self) -> usize {
            self.folds
        }
        fn oos_deficient_folds(&self) -> usize {
            self.deficient
        }
    }

    /// The flag row's reason leads with what raised the flag: the error over the limit, folds
    /// that could not determine the coefficients (the error within the limit), or both.
    #[test]
    fn out_of_sample_reason_leads_with_what_raised_the_flag() {
        let over = Figures {
            oos: 15.0,
            folds: 5,
            deficient: 0,
        };
        assert!(over.oos_flagged(1.2));
        assert_eq!(
            out_of_sample_reason(&over, 1.2, "by sweep"),
            "good in sample, bad out of sample: held-out sweeps RMSE 15.0000 vs 10.0000 in \
             sample (1.50x, over the limit of 1.2x plus 0.1 % of peak; 5-fold by sweep)"
        );
        let deficient = Figures {
            oos: 9.2,
            folds: 5,
            deficient: 5,
        };
        assert!(deficient.oos_flagged(1.2) && !deficient.oos_ratio_over(1.2));
        assert_eq!(
            out_of_sample_reason(&deficient, 1.2, "by sweep over every tested pressure"),
            "5 of 5 folds could not determine the coefficients without their held-out sweeps \
             (their held-out error is optimistic): held-out sweeps RMSE 9.2000 vs 10.0000 in \
             sample (0.92x, within the limit of 1.2x plus 0.1 % of peak; 5-fold by sweep over \
             every tested pressure)"
        );
        let both = Figures {
            oos: 15.0,
            folds: 5,
            deficient: 2,
        };
        assert_eq!(
            out_of_sample_reason(&both, 1.2, "by sweep"),
            "good in sample, bad out of sample, and 2 of 5 folds could not determine the \
             coefficients without their held-out sweeps (their held-out error is optimistic): \
             held-out sweeps RMSE 15.0000 vs 10.0000 in sample (1.50x, over the limit of 1.2x \
             plus 0.1 % of peak; 5-fold by sweep)"
        );
        // Over the ratio but within the 0.1 %-of-peak floor (peak 1000, floor 1): not over.
        let floor = Figures {
            oos: 12.5,
            folds: 5,
            deficient: 1,
        };
        assert!(!floor.oos_ratio_over(1.2));
        assert!(out_of_sample_reason(&floor, 1.2, "by sweep").starts_with("1 of 5 folds"));
    }

    #[test]
    fn a_panicking_group_becomes_a_fatal_failure() {
        let key = TireKey {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa_nom: 83,
        };
        let GroupRun { result, model, .. } = guarded(&key, || panic!("index out of bounds"));
        assert!(model.is_none());
        assert_eq!(result.failures.len(), 1);
        let f = &result.failures[0];
        assert!(f.fatal && f.stage == "fit", "{f:?}");
        assert!(f.reason.contains("index out of bounds"), "{f:?}");
    }

    /// One cornering sweep at `p_kpa`: 41 samples from -0.2 to 0.2 rad at 1000 N.
    fn cornering_sweep(p_kpa: i64) -> tirebase_core::fit::mf61::Mf61Sweep {
        use tirebase_core::fit::mf61::{Mf61Sample, Mf61Sweep};
        Mf61Sweep {
            id: format!("run1-{p_kpa}"),
            kind: tirebase_core::fit::pac2002::SweepKind::Cornering,
            samples: (0..41)
                .map(|i| {
                    let alpha = -0.2 + 0.01 * i as f64;
                    Mf61Sample {
                        fz_n: 1000.0,
                        kappa: 0.0,
                        alpha_rad: alpha,
                        gamma_rad: 0.0,
                        vx_mps: 11.0,
                        p_pa: p_kpa as f64 * 1e3,
                        fx_n: 0.0,
                        fy_n: -2500.0 * (8.0 * alpha).atan() / 1.5,
                        mz_nm: 0.0,
                        mx_nm: 0.0,
                    }
                })
                .collect(),
        }
    }

    /// An MF 6.1 fit that fails reaches `fit_failures` as a fatal row of stage `mf61`, keyed at
    /// the tire, rim and `NOMPRES` it would have had. The case: a tire and rim whose every
    /// tested pressure had too few sweeps for its PAC2002 fit (one cornering sweep each), so
    /// no pressure hands the MF 6.1 stage a PAC2002 model to start from.
    #[test]
    fn a_failed_mf61_fit_is_a_fatal_fit_failures_row() {
        let cfg = Config::default().fit.mf61();
        let parts: Vec<mf61::Mf61Part> = [69, 83, 97]
            .iter()
            .map(|&p| {
                let key = TireKey {
                    tire: "T".into(),
                    rim_in: 7,
                    pressure_kpa_nom: p,
                };
                mf61::Mf61Part::new(&key, &[cornering_sweep(p)], None, None, &cfg)
            })
            .collect();
        // the sweeps are there: what fails is the fit, not the input
        assert!(parts.iter().all(|p| !p.group.points.is_empty()));
        let o = fit_mf61("T", 7, &parts, &cfg);
        assert!(o.model.is_none());
        let mut results = FitResults::default();
        results.add_mf61(&o);
        assert_eq!(results.fatal().count(), 1, "{:?}", results.failures);
        let df = tables::fit_failures(&results.failures).unwrap();
        assert_eq!(df.height(), 1);
        let cell = |c: &str| df.column(c).unwrap().get(0).unwrap().to_string();
        assert_eq!(cell("tire"), "\"T\"");
        assert_eq!(cell("rim_in"), "7");
        assert_eq!(cell("pressure_kpa"), "83", "keyed at NOMPRES");
        assert_eq!(cell("stage"), format!("\"{}\"", mf61::STAGE));
        assert_eq!(cell("fatal"), "true");
        assert!(cell("reason").contains("PAC2002 fit to start from"), "{df}");
    }

    /// A tire and rim without a usable sweep at any pressure fails its MF 6.1 stage as well.
    #[test]
    fn an_mf61_stage_without_sweeps_is_a_fatal_fit_failures_row() {
        let cfg = Config::default().fit.mf61();
        let key = TireKey {
            tire: "T".into(),
            rim_in: 8,
            pressure_kpa_nom: 83,
        };
        let parts = [mf61::Mf61Part::new(&key, &[], None, None, &cfg)];
        let mut results = FitResults::default();
        results.add_mf61(&fit_mf61("T", 8, &parts, &cfg));
        let df = tables::fit_failures(&results.failures).unwrap();
        assert_eq!(df.height(), 1);
        let reason = df.column("reason").unwrap().get(0).unwrap().to_string();
        assert!(reason.contains("no force-clean"), "{reason}");
        assert_eq!(results.fatal().count(), 1);
        assert!(results.stage_seconds.contains_key(mf61::STAGE));
    }

    /// One tested pressure (83 kPa) of tire `T` on a 7 in rim: cornering sweeps at three loads
    /// generated from a PAC2002 file, which is also the start (as the group's PAC2002 fit would
    /// be), with `effective_radius` as its PAC2002 file's BREFF/DREFF/FREFF rows.
    fn one_pressure_part(
        cfg: &tirebase_core::fit::mf61::Mf61Config,
        effective_radius: impl Fn(
            &tirebase_core::tire_model::MagicFormula,
        ) -> Vec<tir::WrittenCoefficient>,
    ) -> mf61::Mf61Part {
        use tirebase_core::fit::mf61::{CollapsedGroup, Mf61Sample, Mf61Sweep, Pac2002AtPressure};
        use tirebase_core::tire_model::tir::TirFile;
        use tirebase_core::tire_model::{Mode, SlipInput};
        let text = include_str!("../tests/fixtures/tir/mf52_fittyp6.tir");
        let model = TirFile::parse(text).unwrap().0.model();
        let p_kpa = 83;
        let sweeps: Vec<Mf61Sweep> = [600.0, 1100.0, 1600.0]
            .iter()
            .enumerate()
            .map(|(k, &fz_n)| Mf61Sweep {
                id: format!("run1-{k}"),
                kind: tirebase_core::fit::pac2002::SweepKind::Cornering,
                samples: (0..81)
                    .map(|i| {
                        let alpha_rad = -0.2 + 0.005 * i as f64;
                        let input = SlipInput {
                            fz_n,
                            kappa: 0.0,
                            alpha_rad,
                            gamma_rad: 0.0,
                            vx_mps: 11.0,
                        };
                        let e = model.eval(&input, Mode::Limits);
                        Mf61Sample {
                            fz_n,
                            kappa: 0.0,
                            alpha_rad,
                            gamma_rad: 0.0,
                            vx_mps: 11.0,
                            p_pa: p_kpa as f64 * 1e3,
                            fx_n: e.fx_n,
                            fy_n: e.fy_n,
                            mz_nm: e.mz_nm,
                            mx_nm: e.mx_nm,
                        }
                    })
                    .collect(),
            })
            .collect();
        let key = TireKey {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa_nom: p_kpa,
        };
        mf61::Mf61Part {
            key: key.clone(),
            group: CollapsedGroup {
                pressure_kpa_nom: p_kpa,
                points: tirebase_core::fit::mf61::collapse_group(&sweeps, &cfg.collapse),
                pac2002: Some(Pac2002AtPressure {
                    p_pa: p_kpa as f64 * 1e3,
                    model: model.clone(),
                    vertical_stiffness_n_per_m: None,
                    unloaded_radius_m: None,
                }),
            },
            use_mode: Some(4),
            effective_radius: effective_radius(&model),
        }
    }

    /// A fitted MF 6.1 model that is deficient (one tested pressure: no pressure terms) is
    /// written and reaches `fit_failures` as a partial (non-fatal) row keyed at its pressure.
    #[test]
    fn a_deficient_mf61_fit_is_a_partial_fit_failures_row() {
        let cfg = Config::default().fit.mf61();
        let p_kpa = 83;
        let part = one_pressure_part(&cfg, |_| Vec::new());
        let o = fit_mf61("T", 7, &[part], &cfg);
        assert!(o.model.is_some(), "{:?}", o.failures);
        let mut results = FitResults::default();
        results.add_mf61(&o);
        assert_eq!(results.fatal().count(), 0, "{:?}", results.failures);
        let df = tables::fit_failures(&results.failures).unwrap();
        let scopes: Vec<String> = (0..df.height())
            .map(|i| df.column("scope").unwrap().get(i).unwrap().to_string())
            .collect();
        let row = scopes
            .iter()
            .position(|s| s == "\"pressure terms\"")
            .unwrap_or_else(|| panic!("no pressure-terms row in {df}"));
        let cell = |c: &str| df.column(c).unwrap().get(row).unwrap().to_string();
        assert_eq!(cell("stage"), format!("\"{}\"", mf61::STAGE));
        assert_eq!(cell("fatal"), "false");
        assert_eq!(cell("pressure_kpa"), p_kpa.to_string());
        assert!(cell("reason").contains("no pressure terms"), "{df}");
    }

    /// The MF 6.1 model's BREFF/DREFF/FREFF are the PAC2002 file's at the tested pressure
    /// nearest NOMPRES: their rows say so, and keep that file's origin and its bound flag and
    /// reason (a BREFF on an end of the spring-rate search interval).
    #[test]
    fn mf61_effective_radius_rows_say_where_they_come_from() {
        use tirebase_core::tire_model::Coef;
        let cfg = Config::default().fit.mf61();
        let part = one_pressure_part(&cfg, |model| {
            [Coef::BREFF, Coef::DREFF, Coef::FREFF]
                .into_iter()
                .map(|coef| tir::WrittenCoefficient {
                    coef,
                    family: "vertical".into(),
                    value: model.coefs[coef],
                    std_error: None,
                    at_bound: coef == Coef::BREFF,
                    origin: "spring_rate".into(),
                    note: (coef == Coef::BREFF).then(|| "on an end of its search interval".into()),
                })
                .collect()
        });
        let o = fit_mf61("T", 7, &[part], &cfg);
        let m = o.model.expect("a model");
        let row = |c: Coef| m.coefficients.iter().find(|r| r.coef == c).unwrap();
        let breff = row(Coef::BREFF);
        assert_eq!(breff.origin, "spring_rate", "{breff:?}");
        assert!(breff.at_bound, "{breff:?}");
        let note = breff.note.as_deref().unwrap_or_default();
        assert!(note.contains("at 83 kPa"), "{note}");
        assert!(note.contains("on an end of its search interval"), "{note}");
        for c in [Coef::DREFF, Coef::FREFF] {
            let r = row(c);
            assert_eq!(r.origin, "spring_rate", "{r:?}");
            assert!(!r.at_bound, "{r:?}");
            assert!(
                r.note.as_deref().is_some_and(|n| n.contains("at 83 kPa")),
                "{r:?}"
            );
        }
        // without the PAC2002 file's rows the origin stays `start`, with the pressure named
        let o = fit_mf61("T", 7, &[one_pressure_part(&cfg, |_| Vec::new())], &cfg);
        let m = o.model.expect("a model");
        let breff = m
            .coefficients
            .iter()
            .find(|r| r.coef == Coef::BREFF)
            .unwrap();
        assert_eq!(breff.origin, "start");
        assert!(!breff.at_bound);
        assert!(
            breff
                .note
                .as_deref()
                .is_some_and(|n| n.contains("at 83 kPa")),
            "{breff:?}"
        );
    }

    /// The MF 6.1 model's rolling resistance terms are labelled placeholders (rows and file),
    /// never `start` values that read as if they were known.
    #[test]
    fn mf61_my_terms_are_labelled_placeholders() {
        use tirebase_core::tire_model::Coef;
        let cfg = Config::default().fit.mf61();
        let o = fit_mf61("T", 7, &[one_pressure_part(&cfg, |_| Vec::new())], &cfg);
        let m = o.model.expect("a model");
        let qsy1 = m
            .coefficients
            .iter()
            .find(|r| r.coef == Coef::QSY1)
            .unwrap();
        assert_eq!(qsy1.origin, "placeholder", "{qsy1:?}");
        assert!(
            qsy1.note
                .as_deref()
                .is_some_and(|n| n.contains("TTC records no"))
        );
        assert!(
            m.text.contains("My not fitted"),
            "no My note in the file header"
        );
    }

    #[test]
    fn stage_sets_print_and_parse_back() {
        for list in [
            "pac2002",
            "spring_rate,thermal",
            "all",
            "relaxation, pac2002",
        ] {
            let s = StageSet::parse(list).unwrap();
            assert_eq!(StageSet::parse(&s.to_string()).unwrap(), s);
        }
        assert!(StageSet::parse("").is_err());
    }
}
