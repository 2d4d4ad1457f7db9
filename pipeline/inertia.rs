//! The rig-inertia stage as a library function: session directories in, the `inertia` result
//! table out (schema `schemas/inertia.toml`), with every session's outcome and failed runs.
//!
//! Used by `tirebase inertia` (writes OUT/inertia.parquet) and `tirebase run` (publishes it with
//! the tire results). Rows are sorted by (session, run, object, axis, quantity, method), so the
//! table does not depend on the thread count. Deliberately not here: the analysis (that is
//! `tirebase_core::inertia`), printing, and where the table is written.

use std::fs;
use std::path::{Path, PathBuf};

use polars::prelude::*;
use rayon::prelude::*;
use tirebase_core::inertia::analysis::{SessionOutcome, analyze_session};
use tirebase_core::inertia::session::{SESSION_FILE, Session, SessionError};
use tirebase_core::inertia::{InertiaResult, InertiaRunError};

use crate::schema::{self, TableName};
use crate::store::StoreError;

/// The processed sessions.
#[derive(Debug)]
pub struct InertiaRun {
    /// One outcome per session directory, in the order given.
    pub outcomes: Vec<SessionOutcome>,
    /// Every result row, sorted.
    pub results: Vec<InertiaResult>,
}

impl InertiaRun {
    /// Every failed run of every session.
    pub fn errors(&self) -> impl Iterator<Item = &InertiaRunError> {
        self.outcomes.iter().flat_map(|o| o.errors.iter())
    }

    /// Runs declared over all sessions.
    pub fn runs(&self) -> usize {
        self.outcomes.iter().map(|o| o.runs).sum()
    }

    /// The result rows as the `inertia` table, conformed to its schema.
    pub fn table(&self) -> Result<DataFrame, StoreError> {
        results_frame(&self.results)
    }
}

/// Session directories below `root`: every directory holding a `session.toml` (sorted; empty
/// when `root` does not exist).
pub fn find_sessions(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    // Directories already searched: a symlink back up the tree is not followed again.
    let mut visited = std::collections::BTreeSet::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        if fs::metadata(&dir).is_ok_and(|m| !visited.insert(dir_identity(&m))) {
            continue;
        }
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        if dir.join(SESSION_FILE).is_file() {
            out.push(dir.clone());
            continue;
        }
        // Searched in name order, so a directory reached by two paths is always found by the
        // same one.
        let mut dirs: Vec<PathBuf> = entries
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.is_dir())
            .collect();
        dirs.sort();
        stack.extend(dirs.into_iter().rev());
    }
    out.sort();
    out
}

/// What identifies a directory however it is reached (device and inode on Unix).
#[cfg(unix)]
fn dir_identity(meta: &fs::Metadata) -> (u64, u64) {
    use std::os::unix::fs::MetadataExt;
    (meta.dev(), meta.ino())
}

/// Without inodes every directory is new (no symlink loops to guard against).
#[cfg(not(unix))]
fn dir_identity(_: &fs::Metadata) -> (u64, u64) {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    (0, NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed))
}

/// Analyse every session (in parallel on the current rayon pool). A session id given by two
/// directories keeps the first and fails the others.
pub fn process_sessions(dirs: &[PathBuf]) -> InertiaRun {
    let mut outcomes: Vec<SessionOutcome> = dirs.par_iter().map(|d| process_dir(d)).collect();
    reject_duplicate_ids(&mut outcomes, dirs);
    let mut results: Vec<InertiaResult> = outcomes
        .iter()
        .flat_map(|o| o.results.iter().cloned())
        .collect();
    results.sort_by(|a, b| sort_key(a).cmp(&sort_key(b)));
    InertiaRun { outcomes, results }
}

fn sort_key(r: &InertiaResult) -> (&str, &str, &str, &str, &str, &str) {
    (
        &r.session,
        &r.run,
        &r.object,
        &r.axis,
        &r.quantity,
        &r.method,
    )
}

fn reject_duplicate_ids(outcomes: &mut [SessionOutcome], dirs: &[PathBuf]) {
    for k in 1..outcomes.len() {
        if let Some(first) = (0..k).find(|&j| {
            outcomes[j].session == outcomes[k].session && !outcomes[j].results.is_empty()
        }) {
            let o = &mut outcomes[k];
            o.results.clear();
            o.errors = vec![InertiaRunError {
                session: o.session.clone(),
                run: "session.toml".into(),
                message: format!(
                    "{}: session id already used by {}",
                    dirs[k].display(),
                    dirs[first].display()
                ),
            }];
        }
    }
}

/// A reader of run files relative to a session directory.
fn load_dir_reader(dir: &Path) -> impl Fn(&str) -> Result<String, SessionError> + Sync + '_ {
    move |rel: &str| {
        let path: PathBuf = dir.join(rel);
        std::fs::read_to_string(&path).map_err(|e| SessionError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }
}

/// Reads and parses `DIR/session.toml`.
fn load_session(dir: &Path) -> Result<Session, SessionError> {
    let path = dir.join(SESSION_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| SessionError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    Session::parse(&text)
}

fn process_dir(dir: &Path) -> SessionOutcome {
    let label = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    match load_session(dir) {
        Ok(session) => {
            let read = load_dir_reader(dir);
            // A FIFO or device named as a run file is refused: reading it could block forever.
            let regular = |rel: &str| match fs::metadata(dir.join(rel)) {
                Ok(m) if !m.is_file() => Err(SessionError::Io {
                    path: dir.join(rel).display().to_string(),
                    message: "not a regular file".to_string(),
                }),
                _ => read(rel),
            };
            analyze_session(&session, &regular)
        }
        Err(e) => SessionOutcome {
            session: label.clone(),
            results: Vec::new(),
            errors: vec![InertiaRunError {
                session: label,
                run: "session.toml".into(),
                message: e.to_string(),
            }],
            runs: 0,
        },
    }
}

/// The `inertia` table of some result rows, in schema order.
pub fn results_frame(rows: &[InertiaResult]) -> Result<DataFrame, StoreError> {
    let text = |f: fn(&InertiaResult) -> &str| {
        rows.iter()
            .map(|r| f(r).to_owned())
            .collect::<Vec<String>>()
    };
    let df = df!(
        "session" => text(|r| &r.session),
        "run" => text(|r| &r.run),
        "object" => text(|r| &r.object),
        "axis" => text(|r| &r.axis),
        "quantity" => text(|r| &r.quantity),
        "method" => text(|r| &r.method),
        "value" => rows.iter().map(|r| r.value).collect::<Vec<f64>>(),
        "uncertainty" => rows.iter().map(|r| r.uncertainty).collect::<Vec<f64>>(),
        "units" => text(|r| &r.units),
        "diagnostics" => text(|r| &r.diagnostics),
    )
    .map_err(|e| StoreError::Schema {
        table: "inertia".into(),
        message: e.to_string(),
    })?;
    schema::table(TableName::Inertia).conform(df)
}
