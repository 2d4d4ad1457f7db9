//! Publishing a version: the fitted groups' results, the reused groups' results of the previous
//! version, the rig-inertia results, the report and the manifest, made visible by one rename.
//!
//! In: a [`Publication`] (what the run found and computed: input files and their problems,
//! the group plan, the fit outcome of the changed groups, the previous version). Out:
//! `STORE/versions/vNNNNNN/` with every result table, `tir/*.tir`, `report/` and
//! `manifest.toml`, and a [`RunReport`]. The version is built in a hidden staging directory
//! ([`VersionBuilder`]); a crash at any point leaves earlier versions untouched and the next run
//! removes the leftovers. Every problem of the version (failed and partial files, file warnings,
//! skipped entries, fit failures and skipped parts, failed inertia runs, a failed report) goes
//! into the manifest with its reason, built from typed results (the runs table, the fit
//! outcome, the previous version's `fit_failures` rows of the reused groups, the inertia
//! outcome), not by reading back as text the tables this module wrote. Deliberately not here:
//! deciding what is refit (run.rs) and printing.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use polars::prelude::*;

use crate::config::FitModel;
use crate::fit::{FitFailure, FitResults, GroupPlan};
use crate::inertia::{InertiaRun, process_sessions};
use crate::ingest::{FileStatus, IngestReport};
use crate::manifest::{
    Counts, GroupRecord, InputFile, InputInfo, Manifest, Problem, ProblemKind, now_utc,
};
use crate::progress::Progress;
use crate::report;
use crate::run::{Fingerprint, RunError, RunOptions, count_duplicates};
use crate::schema::TableName;
use crate::store::results::{
    self, FailureKind, GROUP_COLUMNS, INERTIA_TABLE, MF61, Results, TirNames, has_group_columns,
    is_model, mf61_groups, mf61_names, model_groups, rows_of_groups, tir_names,
};
use crate::store::tables::{self, RunStatus};
use crate::store::versions::VersionBuilder;
use crate::store::{IoOp, StoreError};

pub use crate::store::results::GroupKey;

/// Everything a run hands to publishing.
pub struct Publication<'a> {
    /// The run's options (store, input, catalog, config, jobs).
    pub opts: &'a RunOptions<'a>,
    /// When the run started (the manifest records the total time).
    pub started: Instant,
    /// The latest version: (number, directory, manifest).
    pub previous: Option<&'a (u32, PathBuf, Manifest)>,
    /// Hashes of the inputs.
    pub fingerprint: &'a Fingerprint,
    /// Input files with their hash and status.
    pub files: Vec<InputFile>,
    /// Problems of the input files (failed, partial, warnings, skipped entries).
    pub file_problems: Vec<Problem>,
    /// What ingest did.
    pub ingest: &'a IngestReport,
    /// Every fit group of the version.
    pub plan: &'a [GroupPlan],
    /// Groups fitted by this run.
    pub groups_fitted: usize,
    /// Groups whose results the previous version holds, with the version that computed them.
    pub reused: &'a BTreeMap<GroupKey, u32>,
    /// The fit of the changed groups.
    pub outcome: FitResults,
    /// Wall time per stage so far, s.
    pub timings: BTreeMap<String, f64>,
}

/// What a publishing run did.
#[derive(Debug, Default)]
pub struct RunReport {
    /// The manifest written (or that would have been written): counts and every problem.
    pub manifest: Manifest,
    /// The published version's directory.
    pub version_dir: Option<PathBuf>,
    /// The worst fit by quality, one line.
    pub worst_fit: Option<String>,
}

impl RunReport {
    /// True when something failed but a version was still published.
    pub fn partial(&self) -> bool {
        self.manifest.problems.iter().any(|p| p.kind.is_failure())
    }

    /// Why the report could not be written, if it could not.
    pub fn report_error(&self) -> Option<&str> {
        self.manifest
            .problems
            .iter()
            .find(|p| p.kind == ProblemKind::Report)
            .map(|p| p.reason.as_str())
    }
}

/// The group key of a plan entry.
pub fn plan_key(g: &GroupPlan) -> GroupKey {
    (g.key.tire.clone(), g.key.rim_in, g.key.pressure_kpa_nom)
}

/// Build, fill and commit the next version.
pub fn publish(p: Publication, progress: &dyn Progress) -> Result<RunReport, RunError> {
    let Publication {
        opts,
        started,
        previous,
        fingerprint,
        files,
        file_problems,
        ingest,
        plan,
        groups_fitted,
        reused,
        outcome,
        mut timings,
    } = p;
    let builder = VersionBuilder::begin(opts.store)?;
    let number = builder.number();
    let staging = builder.dir().to_path_buf();
    let reused_keys: BTreeSet<GroupKey> = reused.keys().cloned().collect();
    let prev_dir = previous.map(|(_, d, _)| d.as_path());

    let t = Instant::now();
    let (tir_names, tir_notes) = publish_tir(
        FitModel::Pac2002,
        &outcome,
        prev_dir,
        &reused_keys,
        &staging,
    )?;
    let (mf61_names, mf61_notes) =
        publish_tir(FitModel::Mf61, &outcome, prev_dir, &reused_keys, &staging)?;
    let tir_files = crate::store::files::files_in(&staging.join("tir"))?.len();
    let merged = merge_tables(
        &outcome,
        prev_dir,
        &reused_keys,
        (&tir_names, &mf61_names),
        &staging,
        progress,
    )?;
    let mut tables: BTreeMap<String, u64> = merged
        .iter()
        .map(|(name, df)| (name.clone(), df.height() as u64))
        .collect();
    let mut results = Results::from_frames(&merged);
    drop(merged);
    let reused_failures = match prev_dir {
        Some(dir) => results::read_fit_failures(dir, &reused_keys)?,
        None => Vec::new(),
    };
    timings.insert("merge".to_string(), t.elapsed().as_secs_f64());

    let t = Instant::now();
    let inertia = inertia_stage(&fingerprint.inertia_sessions, opts.jobs, &staging, progress)?;
    if let Some((_, df)) = &inertia {
        tables.insert(INERTIA_TABLE.to_string(), df.height() as u64);
        results.set_inertia(df);
    }
    timings.insert("inertia".to_string(), t.elapsed().as_secs_f64());

    let t = Instant::now();
    let report_error = report_stage(opts.store, &results, &staging, opts.jobs, progress);
    timings.insert("report".to_string(), t.elapsed().as_secs_f64());

    let mut problems = file_problems;
    problems.extend(
        tir_notes
            .into_iter()
            .chain(mf61_notes)
            .map(|((t, r, p), note)| {
                Problem::new(
                    ProblemKind::TirName,
                    format!("{t} on {r} in rim at {p} kPa"),
                    note,
                )
            }),
    );
    let mut failures: Vec<&FitFailure> = outcome.failures.iter().chain(&reused_failures).collect();
    failures.sort();
    problems.extend(failures.iter().map(|f| fit_problem(f)));
    if let Some((done, _)) = &inertia {
        problems.extend(done.errors().map(|e| {
            Problem::new(
                ProblemKind::InertiaRun,
                format!("{}/{}", e.session, e.run),
                e.message.clone(),
            )
        }));
    }
    if let Some(e) = report_error {
        problems.push(Problem::new(ProblemKind::Report, "report", e));
    }
    problems.sort();
    let count = |k: ProblemKind| problems.iter().filter(|p| p.kind == k).count() as u64;
    let groups: Vec<GroupRecord> = plan
        .iter()
        .map(|g| GroupRecord {
            tire: g.key.tire.clone(),
            rim_in: g.key.rim_in,
            pressure_kpa: g.key.pressure_kpa_nom,
            input_sha256: g.input_sha256.clone(),
            n_segments: g.n_segments as u64,
            from_version: reused.get(&plan_key(g)).copied().unwrap_or(number),
        })
        .collect();
    let status = |s: RunStatus| files.iter().filter(|f| f.status == Some(s)).count() as u64;
    let done = |s: FileStatus| ingest.count(|x| *x == s) as u64;
    let counts = Counts {
        files: files.len() as u64,
        files_ok: status(RunStatus::Ok),
        files_partial: status(RunStatus::Partial),
        files_failed: status(RunStatus::Failed),
        files_duplicate: count_duplicates(&files),
        files_ingested: done(FileStatus::Ingested),
        files_resegmented: done(FileStatus::Resegmented),
        files_relabelled: done(FileStatus::Relabelled),
        files_removed: ingest.removed.len() as u64,
        file_warnings: count(ProblemKind::FileWarning),
        entries_skipped: count(ProblemKind::SkippedEntry),
        segments_by_kind: segments_by_kind(opts.store),
        groups: plan.len() as u64,
        groups_fitted: groups_fitted as u64,
        groups_reused: reused.len() as u64,
        fit_failures: count(ProblemKind::FitFailure),
        fit_skipped: count(ProblemKind::FitSkipped),
        fit_quality_flags: count(ProblemKind::FitQuality),
        model_limits: count(ProblemKind::ModelLimit),
        tir_lint_errors: count(ProblemKind::TirLint),
        tir_files: tir_files as u64,
        inertia_sessions: fingerprint.inertia_sessions.len() as u64,
        inertia_results: inertia.as_ref().map_or(0, |(d, _)| d.results.len() as u64),
        inertia_failed_runs: count(ProblemKind::InertiaRun),
    };
    let mut manifest = Manifest {
        version: number,
        created_utc: now_utc(),
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        previous: previous.map_or(0, |(n, _, _)| *n),
        summary: String::new(),
        input: InputInfo {
            root: opts.input.display().to_string(),
            catalog: opts
                .catalog
                .map(|p| p.display().to_string())
                .unwrap_or_default(),
            catalog_sha256: fingerprint.catalog_sha256.clone(),
            config_sha256: fingerprint.config_sha256.clone(),
            runs_table_sha256: tables::runs_sha256(opts.store)?,
        },
        counts,
        timings_s: timings,
        tables,
        files,
        inertia_files: fingerprint.inertia_files.clone(),
        groups,
        problems,
        config: toml::from_str(&opts.config.to_toml()).unwrap_or_default(),
    };
    manifest.summary = describe_changes(previous.map(|(_, _, m)| m), &manifest);

    // Publish: the manifest records the time up to its own writing; the rename is instant.
    manifest
        .timings_s
        .insert("total".to_string(), started.elapsed().as_secs_f64());
    manifest.write(&staging)?;
    let worst_fit = worst_fit(&results);
    let dir = builder.commit()?;
    Ok(RunReport {
        manifest,
        version_dir: Some(dir),
        worst_fit,
    })
}

/// A fit failure as a problem of the version: fatal ones and `.tir` lint errors are failures;
/// skipped parts, quality flags and model limits warnings of their own kinds
/// ([`results::FitFailure::kind`]).
fn fit_problem(f: &FitFailure) -> Problem {
    let part = if f.scope.is_empty() || f.scope == f.stage {
        f.stage.clone()
    } else {
        format!("{} ({})", f.stage, f.scope)
    };
    Problem::new(
        match f.kind() {
            FailureKind::Failed => ProblemKind::FitFailure,
            FailureKind::Skipped => ProblemKind::FitSkipped,
            FailureKind::QualityFlag => ProblemKind::FitQuality,
            FailureKind::ModelLimit => ProblemKind::ModelLimit,
            FailureKind::LintError => ProblemKind::TirLint,
        },
        format!(
            "{} on {} in rim at {} kPa",
            f.tire, f.rim_in, f.pressure_kpa
        ),
        format!("{part}: {}", f.reason),
    )
}

/// Merge this run's tables with the reused groups' rows of the previous version and write them
/// into the staging directory. Returns the merged tables.
fn merge_tables(
    outcome: &FitResults,
    prev_dir: Option<&Path>,
    reused: &BTreeSet<GroupKey>,
    tir_names: (&BTreeMap<GroupKey, String>, &BTreeMap<GroupKey, String>),
    staging: &Path,
    progress: &dyn Progress,
) -> Result<BTreeMap<String, DataFrame>, RunError> {
    let mut names: BTreeSet<String> = outcome.tables.keys().cloned().collect();
    if let Some(dir) = prev_dir {
        names.extend(
            results::table_names(dir)?
                .into_iter()
                .filter(|n| n != INERTIA_TABLE.as_str()),
        );
    }
    let mut out = BTreeMap::new();
    for name in names {
        let table_err = |source| RunError::Table {
            table: name.clone(),
            source,
        };
        let fresh = outcome.tables.get(&name);
        let old = match prev_dir {
            Some(dir) if !reused.is_empty() => match results::read_table(dir, &name)? {
                None => None,
                Some(df) if has_group_columns(&df) => {
                    Some(rows_of_groups(&df, reused).map_err(table_err)?)
                }
                Some(_) => {
                    progress.note(&format!(
                        "warning: {name}: previous table has no tire/rim_in/pressure_kpa columns; its rows are not carried over"
                    ));
                    None
                }
            },
            _ => None,
        };
        let merged = match (fresh, old) {
            (Some(f), Some(o)) => f.vstack(&o).map_err(table_err)?,
            (Some(f), None) => f.clone(),
            (None, Some(o)) => o,
            (None, None) => continue,
        };
        let mut merged = if has_group_columns(&merged) {
            merged
                .sort(
                    GROUP_COLUMNS,
                    SortMultipleOptions::default().with_maintain_order(true),
                )
                .map_err(table_err)?
        } else {
            merged
        };
        if name == TableName::Lint.as_str() {
            merged = rename_lint_files(&merged, tir_names).map_err(table_err)?;
        }
        results::write_table(staging, &name, &mut merged)?;
        out.insert(name, merged);
    }
    Ok(out)
}

/// Write this run's `.tir` files of one model and link the reused ones from the previous
/// version, each under its name among all the version's models of that model (a reused file is
/// renamed when a new tire's name now collides with it). PAC2002 files are keyed by group, MF 6.1
/// files by tire, rim and `NOMPRES`. Returns the names by key and the disambiguation notes.
fn publish_tir(
    model: FitModel,
    outcome: &FitResults,
    prev_dir: Option<&Path>,
    reused: &BTreeSet<GroupKey>,
    staging: &Path,
) -> Result<TirNames, StoreError> {
    let groups_of = |dir: &Path| match model {
        FitModel::Pac2002 => model_groups(dir),
        FitModel::Mf61 => mf61_groups(dir),
    };
    let names_of = |groups: &BTreeSet<GroupKey>| match model {
        FitModel::Pac2002 => tir_names(groups),
        FitModel::Mf61 => mf61_names(groups),
    };
    let dir = staging.join("tir");
    crate::store::files::ensure_dir(&dir)?;
    let fitted: Vec<(GroupKey, &String)> = outcome
        .tir_keys
        .iter()
        .zip(&outcome.tir_models)
        .zip(&outcome.tir_files)
        .filter(|((_, m), _)| **m == model)
        .map(|((k, _), (_, text))| ((k.tire.clone(), k.rim_in, k.pressure_kpa_nom), text))
        .collect();
    let (prev_models, prev_names) = match prev_dir {
        Some(prev) => {
            let groups = groups_of(prev);
            let (names, _) = names_of(&groups);
            (groups, names)
        }
        None => Default::default(),
    };
    let reused_models: Vec<&GroupKey> =
        reused.iter().filter(|k| prev_models.contains(*k)).collect();
    let all: BTreeSet<GroupKey> = fitted
        .iter()
        .map(|(k, _)| k.clone())
        .chain(reused_models.iter().map(|k| (*k).clone()))
        .collect();
    let (names, notes) = names_of(&all);
    for (key, text) in &fitted {
        crate::store::files::write_bytes_atomic(&dir.join(&names[key]), text.as_bytes())?;
    }
    if let Some(prev) = prev_dir {
        for key in reused_models {
            let from = prev.join("tir").join(&prev_names[key]);
            let to = dir.join(&names[key]);
            if from.is_file() && !to.exists() && fs::hard_link(&from, &to).is_err() {
                fs::copy(&from, &to).map_err(|e| StoreError::io(IoOp::Copy, &to, e))?;
            }
        }
    }
    Ok((names, notes))
}

/// Point the `lint` table's `file` column at each model's file name in this version (PAC2002
/// rows by group, MF 6.1 rows by tire, rim and `NOMPRES`).
fn rename_lint_files(
    df: &DataFrame,
    (names, mf61_names): (&BTreeMap<GroupKey, String>, &BTreeMap<GroupKey, String>),
) -> PolarsResult<DataFrame> {
    if df.column("file").is_err() || !has_group_columns(df) {
        return Ok(df.clone());
    }
    let tire = df.column("tire")?.str()?;
    let rim = df.column("rim_in")?.i64()?;
    let p = df.column("pressure_kpa")?.i64()?;
    let old = df.column("file")?.str()?;
    let model = match df.column("model") {
        Ok(c) => Some(c.str()?.clone()),
        Err(_) => None,
    };
    let files: Vec<Option<String>> = (0..df.height())
        .map(|i| {
            let mf61 = model
                .as_ref()
                .and_then(|m| m.get(i))
                .is_some_and(|m| is_model(m, MF61));
            let names = if mf61 { mf61_names } else { names };
            match (tire.get(i), rim.get(i), p.get(i)) {
                (Some(t), Some(r), Some(p)) => names
                    .get(&(t.to_string(), r, p))
                    .cloned()
                    .or_else(|| old.get(i).map(str::to_string)),
                _ => old.get(i).map(str::to_string),
            }
        })
        .collect();
    let mut out = df.clone();
    out.with_column(Column::new("file".into(), files))?;
    Ok(out)
}

/// Process the rig sessions (if any) into `staging/inertia.parquet`; the outcome and the table.
fn inertia_stage(
    sessions: &[PathBuf],
    jobs: usize,
    staging: &Path,
    progress: &dyn Progress,
) -> Result<Option<(InertiaRun, DataFrame)>, RunError> {
    if sessions.is_empty() {
        return Ok(None);
    }
    let stage = progress.stage("inertia", "sessions", sessions.len() as u64);
    let done = with_pool(jobs, || process_sessions(sessions));
    let mut df = done.table()?;
    results::write_table(staging, INERTIA_TABLE, &mut df)?;
    stage.inc(sessions.len() as u64);
    stage.finish(&format!(
        "{} results, {} failed runs",
        done.results.len(),
        done.errors().count()
    ));
    Ok(Some((done, df)))
}

/// Write the HTML report into `staging/report/`; the one-line error if it failed (a failed
/// report does not stop the publish).
fn report_stage(
    store: &Path,
    results: &Results,
    staging: &Path,
    jobs: usize,
    progress: &dyn Progress,
) -> Option<String> {
    let stage = progress.stage("report", "reports", 1);
    let car = crate::compare::car::Car::builtin();
    let write = || {
        report::write_report_from(
            store,
            results,
            &staging.join("tir"),
            &staging.join("report"),
            &car,
        )
    };
    let written = match rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
    {
        Ok(pool) => pool.install(write),
        Err(_) => write(),
    };
    match written {
        Ok(_) => {
            stage.inc(1);
            stage.finish("written");
            None
        }
        Err(e) => {
            stage.finish("failed");
            Some(e.to_string().replace('\n', " "))
        }
    }
}

/// Run `f` on a rayon pool of `jobs` threads (0 = one per core).
fn with_pool<T: Send>(jobs: usize, f: impl FnOnce() -> T + Send) -> T {
    match rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .stack_size(crate::WORKER_STACK_BYTES)
        .build()
    {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// The worst row of `fit_quality` by its out-of-sample RMSE in percent of the channel's peak
/// (the in-sample one where a row has none: [`results::QualityRow::headline_pct_of_peak`], the
/// same rule for PAC2002 and MF 6.1 rows), as one line naming the model, group and channel.
fn worst_fit(results: &Results) -> Option<String> {
    let (q, pct) = results
        .fit_quality
        .iter()
        .flatten()
        .filter_map(|q| Some((q, q.headline_pct_of_peak()?)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let model = if q.model == FitModel::Mf61.as_str() {
        "MF 6.1"
    } else if q.model == FitModel::Pac2002.as_str() {
        "PAC2002"
    } else {
        q.model.as_str()
    };
    let what = match (q.oos_ratio.is_some_and(f64::is_finite), q.oos_folds) {
        (true, Some(k)) if k > 0 => format!("out-of-sample ({k}-fold by sweep) rmse_pct_of_peak"),
        (true, _) => "out-of-sample rmse_pct_of_peak".to_string(),
        (false, _) => "rmse_pct_of_peak".to_string(),
    };
    Some(format!(
        "{model} {what} = {pct:.4} (tire={}, rim_in={}, pressure_kpa={}, model={}, channel={})",
        q.tire, q.rim_in, q.pressure_kpa, q.model, q.channel
    ))
}

/// Live segments by kind (empty when the store has none or cannot be read).
fn segments_by_kind(store: &Path) -> BTreeMap<String, u64> {
    let mut out = BTreeMap::new();
    for s in tables::live_segments(store).unwrap_or_default() {
        *out.entry(s.kind).or_default() += 1;
    }
    out
}

/// How `now` differs from `prev` by key: (added, changed, removed) counts, a key present in both
/// counting as changed when `differs(prev, now)`.
fn key_changes<K: Ord, V>(
    prev: &BTreeMap<K, V>,
    now: &BTreeMap<K, V>,
    differs: impl Fn(&V, &V) -> bool,
) -> (usize, usize, usize) {
    let added = now.keys().filter(|k| !prev.contains_key(*k)).count();
    let removed = prev.keys().filter(|k| !now.contains_key(*k)).count();
    let changed = now
        .iter()
        .filter(|(k, v)| prev.get(*k).is_some_and(|p| differs(p, v)))
        .count();
    (added, changed, removed)
}

/// "n what" for each of (added, changed, removed) that is not zero.
fn push_counts(parts: &mut Vec<String>, counts: (usize, usize, usize), what: [&str; 3]) {
    let (added, changed, removed) = counts;
    for (n, what) in [added, changed, removed].into_iter().zip(what) {
        if n > 0 {
            parts.push(format!("{n} {what}"));
        }
    }
}

/// One line: what `now` changed against `prev`.
pub fn describe_changes(prev: Option<&Manifest>, now: &Manifest) -> String {
    let Some(prev) = prev else {
        return format!(
            "first version: {} files, {} groups fitted",
            now.files.len(),
            now.counts.groups_fitted
        );
    };
    let mut parts = Vec::new();
    let files_prev: BTreeMap<&str, &str> = prev
        .files
        .iter()
        .map(|f| (f.name.as_str(), f.sha256.as_str()))
        .collect();
    let files_now: BTreeMap<&str, &str> = now
        .files
        .iter()
        .map(|f| (f.name.as_str(), f.sha256.as_str()))
        .collect();
    let files = key_changes(&files_prev, &files_now, |p, v| p != v);
    push_counts(
        &mut parts,
        files,
        ["files added", "files changed", "files removed"],
    );
    if prev.tool_version != now.tool_version {
        parts.push(format!(
            "tool {} -> {}",
            prev.tool_version, now.tool_version
        ));
    }
    if prev.input.config_sha256 != now.input.config_sha256 {
        parts.push("config changed".to_string());
    }
    if prev.input.catalog_sha256 != now.input.catalog_sha256 {
        parts.push("catalog changed".to_string());
    }
    if prev.inertia_files != now.inertia_files {
        parts.push("inertia sessions changed".to_string());
    }
    let keys_prev: BTreeMap<_, _> = prev.groups.iter().map(|g| (g.key(), g)).collect();
    let keys_now: BTreeMap<_, _> = now.groups.iter().map(|g| (g.key(), g)).collect();
    let groups = key_changes(&keys_prev, &keys_now, |p, g| {
        p.input_sha256 != g.input_sha256
    });
    let (g_added, g_refit, _) = groups;
    push_counts(
        &mut parts,
        groups,
        ["groups added", "groups refit", "groups removed"],
    );
    let reused = now.groups.len() - g_added - g_refit;
    parts.push(format!("{reused} groups reused"));
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(tire: &str, p: i64, sha: &str) -> GroupRecord {
        GroupRecord {
            tire: tire.into(),
            rim_in: 7,
            pressure_kpa: p,
            input_sha256: sha.into(),
            n_segments: 3,
            from_version: 1,
        }
    }

    fn file(name: &str, sha: &str) -> InputFile {
        InputFile::ok_for_test(name, sha)
    }

    #[test]
    fn change_summary_names_files_config_and_groups() {
        let prev = Manifest {
            tool_version: "0.1.0".into(),
            files: vec![file("a.dat", "1"), file("b.dat", "2")],
            groups: vec![group("T", 69, "x"), group("T", 83, "y")],
            ..Default::default()
        };
        let mut now = prev.clone();
        now.files = vec![file("a.dat", "1"), file("b.dat", "3"), file("c.dat", "4")];
        now.groups = vec![
            group("T", 69, "x"),
            group("T", 83, "z"),
            group("U", 69, "w"),
        ];
        now.input.config_sha256 = "other".into();
        assert_eq!(
            describe_changes(Some(&prev), &now),
            "1 files added, 1 files changed, config changed, 1 groups added, 1 groups refit, 1 groups reused"
        );
        assert!(describe_changes(None, &now).starts_with("first version: 3 files"));
    }

    #[test]
    fn rows_of_reused_groups_are_selected_by_key() {
        let df = df!(
            "tire" => ["T", "T", "U"],
            "rim_in" => [7i64, 7, 7],
            "pressure_kpa" => [69i64, 83, 69],
            "value" => [1.0, 2.0, 3.0],
        )
        .unwrap();
        let keys = BTreeSet::from([("T".to_string(), 7, 83), ("U".to_string(), 7, 69)]);
        let out = rows_of_groups(&df, &keys).unwrap();
        let v: Vec<f64> = out
            .column("value")
            .unwrap()
            .f64()
            .unwrap()
            .into_no_null_iter()
            .collect();
        assert_eq!(v, vec![2.0, 3.0]);
        assert!(has_group_columns(&df));
    }

    #[test]
    fn out_of_sample_flags_are_quality_problems_not_skips() {
        let flag = FitFailure {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa: 83,
            stage: "pac2002".into(),
            scope: results::out_of_sample_scope("Fy0"),
            fatal: false,
            reason: "good in sample, bad out of sample".into(),
        };
        let p = fit_problem(&flag);
        assert_eq!(p.kind, ProblemKind::FitQuality);
        assert_eq!(
            p.to_string(),
            "warning: fit quality: T on 7 in rim at 83 kPa: pac2002 (family Fy0 out of sample): \
             good in sample, bad out of sample"
        );
        assert_eq!(ProblemKind::FitQuality.plural(), "fit-quality flags");
        let skip = FitFailure {
            scope: "sweep 4".into(),
            ..flag
        };
        assert_eq!(fit_problem(&skip).kind, ProblemKind::FitSkipped);
    }

    /// An MF 6.1 model without pressure terms is a warning and a lint error of a written `.tir`
    /// a failure, each of its own kind, not skipped parts.
    #[test]
    fn model_limits_and_lint_errors_are_not_skipped_parts() {
        let limit = FitFailure {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa: 83,
            stage: "mf61".into(),
            scope: results::PRESSURE_TERMS_SCOPE.into(),
            fatal: false,
            reason: "one tested pressure: the model has no pressure terms (all 0)".into(),
        };
        let p = fit_problem(&limit);
        assert_eq!(p.kind, ProblemKind::ModelLimit);
        assert!(p.to_string().starts_with("warning: model limit: "), "{p}");
        let lint = FitFailure {
            stage: "pac2002".into(),
            scope: results::lint_scope("T__7in__83kPa.tir", "fy-sign"),
            reason: "Fy against its slip".into(),
            ..limit.clone()
        };
        let p = fit_problem(&lint);
        assert_eq!(p.kind, ProblemKind::TirLint);
        assert!(p.kind.is_failure());
        assert!(p.to_string().starts_with(".tir lint error: "), "{p}");
        let fatal = FitFailure {
            fatal: true,
            ..limit
        };
        assert_eq!(fit_problem(&fatal).kind, ProblemKind::FitFailure);
    }

    #[test]
    fn reused_groups_keep_their_fit_failures_as_typed_problems() {
        let dir = tempfile::tempdir().unwrap();
        let failures = vec![
            FitFailure {
                tire: "T".into(),
                rim_in: 7,
                pressure_kpa: 83,
                stage: "thermal".into(),
                scope: "thermal".into(),
                fatal: true,
                reason: "3 peaks, need 4".into(),
            },
            FitFailure {
                tire: "U".into(),
                rim_in: 7,
                pressure_kpa: 69,
                stage: "spring_rate".into(),
                scope: "sweep ia 0".into(),
                fatal: false,
                reason: "load span 27 N".into(),
            },
        ];
        let df = df!(
            "tire" => failures.iter().map(|f| f.tire.as_str()).collect::<Vec<_>>(),
            "rim_in" => failures.iter().map(|f| f.rim_in).collect::<Vec<_>>(),
            "pressure_kpa" => failures.iter().map(|f| f.pressure_kpa).collect::<Vec<_>>(),
            "stage" => failures.iter().map(|f| f.stage.as_str()).collect::<Vec<_>>(),
            "scope" => failures.iter().map(|f| f.scope.as_str()).collect::<Vec<_>>(),
            "fatal" => failures.iter().map(|f| f.fatal).collect::<Vec<_>>(),
            "reason" => failures.iter().map(|f| f.reason.as_str()).collect::<Vec<_>>(),
        )
        .unwrap();
        let mut df = crate::schema::table(TableName::FitFailures)
            .conform(df)
            .unwrap();
        results::write_table(dir.path(), TableName::FitFailures, &mut df).unwrap();
        let all = BTreeSet::from([("T".to_string(), 7, 83), ("U".to_string(), 7, 69)]);
        assert_eq!(
            results::read_fit_failures(dir.path(), &all).unwrap(),
            failures
        );
        let one = BTreeSet::from([("U".to_string(), 7, 69)]);
        let read = results::read_fit_failures(dir.path(), &one).unwrap();
        assert_eq!(read, failures[1..].to_vec());
        assert_eq!(
            fit_problem(&read[0]).to_string(),
            "warning: skipped: U on 7 in rim at 69 kPa: spring_rate (sweep ia 0): load span 27 N"
        );
        assert_eq!(
            fit_problem(&failures[0]).to_string(),
            "failed fit: T on 7 in rim at 83 kPa: thermal: 3 peaks, need 4"
        );
    }
}
