//! A version's `manifest.toml`: what went in (tool version, resolved configuration, input file
//! hashes, per-group input hashes and which version each result was computed in), what came out
//! (row counts per table, `.tir` files) and how long each stage took.
//!
//! In: values the nightly run collects. Out: the TOML file inside a version directory, and the
//! parsed struct for `versions`, `diff` and the next run's reuse decisions. Deliberately not here:
//! deciding what is reused (run.rs) or where versions live (store/).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::store::files::write_bytes_atomic;
use crate::store::tables::RunStatus;
use crate::store::{IoOp, StoreError};

/// File name of the manifest inside a version directory.
pub const MANIFEST_FILE: &str = "manifest.toml";

/// Manifest errors.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// The file could not be read or written.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The file is not a valid manifest.
    #[error("{path}: {message}")]
    Parse {
        /// Manifest path.
        path: PathBuf,
        /// What is wrong (toml names the line).
        message: String,
    },
}

/// Everything recorded about one published version.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Manifest {
    /// Version number.
    pub version: u32,
    /// Publication time, UTC, ISO 8601 (`2026-11-22T05:30:00Z`).
    pub created_utc: String,
    /// tirebase version that built it.
    pub tool_version: String,
    /// The version it was built on (0 = none).
    pub previous: u32,
    /// One line: what changed against the previous version.
    pub summary: String,
    /// Input locations and hashes of the non-file inputs.
    pub input: InputInfo,
    /// Counts of what went in and came out.
    pub counts: Counts,
    /// Wall time per stage, s (`ingest`, `plan`, `fit`, `inertia`, `report`, `publish`, `total`).
    pub timings_s: BTreeMap<String, f64>,
    /// Rows per published table.
    pub tables: BTreeMap<String, u64>,
    /// Raw input files.
    pub files: Vec<InputFile>,
    /// Files of the inertia sessions (path relative to the input's `inertia/`).
    pub inertia_files: Vec<HashedFile>,
    /// Fit groups (tire, rim, nominal pressure) and where their results come from.
    pub groups: Vec<GroupRecord>,
    /// Everything that failed or needs attention in this version, with its reason: failed and
    /// partial input files, file warnings, skipped directory entries, failed and skipped fit
    /// stages, failed inertia runs, a failed report (sorted by kind, then subject).
    pub problems: Vec<Problem>,
    /// The resolved configuration.
    pub config: toml::Table,
}

/// Where the inputs came from and the hashes of the non-file inputs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct InputInfo {
    /// Input directory as given.
    pub root: String,
    /// Catalog file, if any.
    pub catalog: String,
    /// SHA-256 of the catalog file ("" without one).
    pub catalog_sha256: String,
    /// SHA-256 of the resolved configuration's TOML text.
    pub config_sha256: String,
    /// SHA-256 of the store's runs table after ingest.
    pub runs_table_sha256: String,
}

/// Counts of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Counts {
    /// Raw files found under the input.
    pub files: u64,
    /// Of those, stored without error.
    pub files_ok: u64,
    /// Of those, stored although their rows stop early (`runs.status = partial`).
    pub files_partial: u64,
    /// Of those, failed (listed in the runs table and in `problems` with the reason).
    pub files_failed: u64,
    /// Of those, copies of a run another file holds (stored once).
    pub files_duplicate: u64,
    /// Of those, read and segmented by this run because their content was new or changed.
    pub files_ingested: u64,
    /// Of those, read and segmented again for new segmentation settings or a new tool.
    pub files_resegmented: u64,
    /// Of those, relabelled without a parse for a new catalog identity.
    pub files_relabelled: u64,
    /// Files of the previous version no longer in the input (removed from the store).
    pub files_removed: u64,
    /// Warnings of the input files (reader, segmentation, disagreeing copies).
    pub file_warnings: u64,
    /// Directory entries of the input that were not ingested (FIFOs, symlink loops).
    pub entries_skipped: u64,
    /// Live segments in the store, by kind.
    pub segments_by_kind: BTreeMap<String, u64>,
    /// Fit groups.
    pub groups: u64,
    /// Groups fitted by this run.
    pub groups_fitted: u64,
    /// Groups whose results were taken from an earlier version.
    pub groups_reused: u64,
    /// (group, stage) fits of this version (fitted or reused) that produced nothing.
    pub fit_failures: u64,
    /// Skipped parts of stages (one load, one sweep) whose stage result was still written.
    pub fit_skipped: u64,
    /// Quality flags of written results (a family good in sample, bad out of sample).
    pub fit_quality_flags: u64,
    /// Limits of written models (an MF 6.1 model without pressure terms).
    pub model_limits: u64,
    /// Lint errors of written `.tir` files.
    pub tir_lint_errors: u64,
    /// `.tir` files in this version.
    pub tir_files: u64,
    /// Inertia sessions processed.
    pub inertia_sessions: u64,
    /// Inertia result rows.
    pub inertia_results: u64,
    /// Inertia runs that failed.
    pub inertia_failed_runs: u64,
}

/// One raw input file: identity for the stat-based up-to-date check and its content hash.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct InputFile {
    /// File name (the store's `source_file`).
    pub name: String,
    /// Path relative to the input directory.
    pub path: String,
    /// Size, bytes.
    pub size: u64,
    /// Modification time, ns since the Unix epoch.
    pub mtime_ns: i64,
    /// SHA-256 of the content ("" if it could not be read).
    pub sha256: String,
    /// Its `runs.status`, written as in the runs table (`ok`, `partial`, `failed`, `duplicate`);
    /// `None`, written `""`, for a file the runs table has no row of.
    #[serde(with = "file_status")]
    pub status: Option<RunStatus>,
}

/// [`InputFile::status`] as the runs table's name, `""` for none.
mod file_status {
    use serde::de::Error as _;
    use serde::{Deserialize, Deserializer, Serializer};

    use crate::store::tables::RunStatus;

    pub fn serialize<S: Serializer>(status: &Option<RunStatus>, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(status.map_or("", RunStatus::as_str))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<RunStatus>, D::Error> {
        let name = String::deserialize(d)?;
        if name.is_empty() {
            return Ok(None);
        }
        RunStatus::parse(&name)
            .map(Some)
            .ok_or_else(|| D::Error::custom(format!("unknown file status '{name}'")))
    }
}

#[cfg(test)]
impl InputFile {
    /// A stored `ok` file of 10 bytes under `raw/` (for tests).
    pub(crate) fn ok_for_test(name: &str, sha: &str) -> InputFile {
        InputFile {
            name: name.into(),
            path: format!("raw/{name}"),
            size: 10,
            mtime_ns: 5,
            sha256: sha.into(),
            status: Some(RunStatus::Ok),
        }
    }
}

/// A file and its content hash.
#[derive(Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(default)]
pub struct HashedFile {
    /// Relative path.
    pub path: String,
    /// SHA-256 of the content.
    pub sha256: String,
}

/// One fit group of the version.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct GroupRecord {
    /// Tire name.
    pub tire: String,
    /// Rim width, in.
    pub rim_in: i64,
    /// Nominal pressure, kPa.
    pub pressure_kpa: i64,
    /// Hash of everything the group's fit depends on.
    pub input_sha256: String,
    /// Usable segments of the group.
    pub n_segments: u64,
    /// The version whose run computed these results (this version when fitted now).
    pub from_version: u32,
}

/// What kind of problem a [`Problem`] is.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProblemKind {
    /// An input file that could not be read, parsed or segmented (`runs.status = failed`).
    FailedFile,
    /// An input file stored although its rows stop early (`runs.status = partial`).
    PartialFile,
    /// A fit stage that produced nothing for a group (`fit_failures.fatal`).
    FitFailure,
    /// An inertia run that failed.
    InertiaRun,
    /// The report could not be written.
    Report,
    /// A reader or segmentation warning of an input file, or copies of one run that disagree.
    FileWarning,
    /// A directory entry of the input that was not ingested (a FIFO, a symlink loop).
    SkippedEntry,
    /// A skipped part of a fit stage whose result was still written.
    FitSkipped,
    /// A quality flag of a written fit result (a family good in sample, bad out of sample).
    FitQuality,
    /// A `.tir` written under a disambiguated name (tires whose names sanitise alike).
    TirName,
    /// A written model that cannot carry something (an MF 6.1 model from one tested pressure
    /// has no pressure terms).
    ModelLimit,
    /// An error the lint finds in a written `.tir` (the file is still written, and the run
    /// exits 1: a spike, a sign flip or an unphysical friction is a defect a driver would feel,
    /// so a nightly job's exit code must show it).
    TirLint,
}

impl ProblemKind {
    /// Every kind, in report order.
    pub const ALL: [ProblemKind; 12] = [
        ProblemKind::FailedFile,
        ProblemKind::PartialFile,
        ProblemKind::FitFailure,
        ProblemKind::InertiaRun,
        ProblemKind::Report,
        ProblemKind::FileWarning,
        ProblemKind::SkippedEntry,
        ProblemKind::TirLint,
        ProblemKind::FitSkipped,
        ProblemKind::FitQuality,
        ProblemKind::ModelLimit,
        ProblemKind::TirName,
    ];

    /// A failure (the run exits 1), rather than a warning.
    pub fn is_failure(self) -> bool {
        matches!(
            self,
            ProblemKind::FailedFile
                | ProblemKind::PartialFile
                | ProblemKind::FitFailure
                | ProblemKind::InertiaRun
                | ProblemKind::Report
                | ProblemKind::TirLint
        )
    }

    /// The prefix of its stderr lines.
    pub fn label(self) -> &'static str {
        match self {
            ProblemKind::FailedFile => "failed file",
            ProblemKind::PartialFile => "partial file",
            ProblemKind::FitFailure => "failed fit",
            ProblemKind::InertiaRun => "failed inertia run",
            ProblemKind::Report => "report failed",
            ProblemKind::FileWarning => "warning",
            ProblemKind::SkippedEntry => "skipped entry",
            ProblemKind::FitSkipped => "warning: skipped",
            ProblemKind::FitQuality => "warning: fit quality",
            ProblemKind::TirName => "renamed .tir",
            ProblemKind::ModelLimit => "warning: model limit",
            ProblemKind::TirLint => ".tir lint error",
        }
    }

    /// What a group of them is called (after its count).
    pub fn plural(self) -> &'static str {
        match self {
            ProblemKind::FailedFile => "input files failed",
            ProblemKind::PartialFile => "input files stored with rows missing",
            ProblemKind::FitFailure => "fit stages produced nothing",
            ProblemKind::InertiaRun => "inertia runs failed",
            ProblemKind::Report => "report failures",
            ProblemKind::FileWarning => "input file warnings",
            ProblemKind::SkippedEntry => "input entries skipped",
            ProblemKind::FitSkipped => "parts of fit stages skipped",
            ProblemKind::FitQuality => "fit-quality flags",
            ProblemKind::TirName => ".tir file names disambiguated",
            ProblemKind::ModelLimit => "model limits (written, without a part)",
            ProblemKind::TirLint => ".tir lint errors (files written)",
        }
    }
}

/// One thing that failed or needs attention.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Problem {
    /// Its kind.
    pub kind: ProblemKind,
    /// What it concerns: a file, a directory entry, a fit group, an inertia session.
    pub subject: String,
    /// One-line reason.
    pub reason: String,
}

impl Problem {
    /// A problem of `kind` about `subject`.
    pub fn new(kind: ProblemKind, subject: impl Into<String>, reason: impl Into<String>) -> Self {
        Problem {
            kind,
            subject: subject.into(),
            reason: reason.into().replace('\n', " "),
        }
    }
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.subject.is_empty() {
            write!(f, "{}: {}", self.kind.label(), self.reason)
        } else {
            write!(
                f,
                "{}: {}: {}",
                self.kind.label(),
                self.subject,
                self.reason
            )
        }
    }
}

/// Problems grouped by kind in report order: (kind, its problems), empty kinds left out.
pub fn group_problems(problems: &[Problem]) -> Vec<(ProblemKind, Vec<&Problem>)> {
    ProblemKind::ALL
        .into_iter()
        .map(|k| {
            (
                k,
                problems.iter().filter(|p| p.kind == k).collect::<Vec<_>>(),
            )
        })
        .filter(|(_, v)| !v.is_empty())
        .collect()
}

impl GroupRecord {
    /// (tire, rim_in, pressure_kpa).
    pub fn key(&self) -> (&str, i64, i64) {
        (&self.tire, self.rim_in, self.pressure_kpa)
    }
}

impl Manifest {
    /// Read `DIR/manifest.toml`.
    pub fn read(version_dir: &Path) -> Result<Manifest, ManifestError> {
        let path = version_dir.join(MANIFEST_FILE);
        let text =
            std::fs::read_to_string(&path).map_err(|e| StoreError::io(IoOp::Read, &path, e))?;
        toml::from_str(&text).map_err(|e| ManifestError::Parse {
            path,
            message: e.to_string().trim().replace('\n', " "),
        })
    }

    /// Render as TOML.
    pub fn to_toml(&self) -> Result<String, ManifestError> {
        toml::to_string(self).map_err(|e| ManifestError::Parse {
            path: PathBuf::from(MANIFEST_FILE),
            message: e.to_string(),
        })
    }

    /// Write `DIR/manifest.toml` atomically.
    pub fn write(&self, version_dir: &Path) -> Result<(), ManifestError> {
        let text = self.to_toml()?;
        write_bytes_atomic(&version_dir.join(MANIFEST_FILE), text.as_bytes())?;
        Ok(())
    }
}

/// The current time as `YYYY-MM-DDTHH:MM:SSZ` (UTC).
pub fn now_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    format_utc(secs)
}

/// Seconds since the Unix epoch as `YYYY-MM-DDTHH:MM:SSZ` (proleptic Gregorian, UTC).
///
/// ```
/// use tirebase::manifest::format_utc;
/// assert_eq!(format_utc(0), "1970-01-01T00:00:00Z");
/// assert_eq!(format_utc(951_782_400), "2000-02-29T00:00:00Z");
/// assert_eq!(format_utc(1_795_000_000), "2026-11-18T11:06:40Z");
/// ```
pub fn format_utc(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_round_trips_through_toml() {
        let mut m = Manifest {
            version: 3,
            created_utc: format_utc(1_700_000_000),
            tool_version: "0.1.0".into(),
            previous: 2,
            summary: "1 group refit".into(),
            ..Default::default()
        };
        m.timings_s.insert("fit".into(), 1.5);
        m.tables.insert("coefficients".into(), 120);
        m.counts.segments_by_kind.insert("cornering".into(), 12);
        m.files.push(InputFile {
            name: "a.dat".into(),
            path: "raw/a.dat".into(),
            size: 10,
            mtime_ns: 1_700_000_000_123_456_789,
            sha256: "ab".into(),
            status: Some(RunStatus::Ok),
        });
        m.groups.push(GroupRecord {
            tire: "Hoosier R25B".into(),
            rim_in: 7,
            pressure_kpa: 83,
            input_sha256: "cd".into(),
            n_segments: 4,
            from_version: 1,
        });
        m.problems.push(Problem::new(
            ProblemKind::FailedFile,
            "b.dat",
            "b.dat: line 8, column 11 (FZ): non-finite value \"NaN\"",
        ));
        m.problems.push(Problem::new(
            ProblemKind::InertiaRun,
            "yaw/run3",
            "too short",
        ));
        m.config = toml::from_str("[fit]\nkappa_bin = 0.01\n").unwrap();
        let dir = tempfile::tempdir().unwrap();
        m.write(dir.path()).unwrap();
        assert_eq!(Manifest::read(dir.path()).unwrap(), m);
    }
}
