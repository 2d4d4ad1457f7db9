//! Writing a virtual round to disk: the run files, truth and catalog of a planned round
//! (rendered in parallel, each file written atomically) and the demo car's rig sessions.
//!
//! In: a resolved [`SynthConfig`] and an output directory. Out: the round directory and the
//! counts of what was written ([`RoundWritten`]); the commands (`synth round`, the embedded
//! round of `run`) format the summary. All simulation is in `tirebase_core::synth`; this module
//! only parallelises over run files (rayon; every run has its own random stream, so the bytes do
//! not depend on the thread count) and writes the files.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::core::synth::inertia::{SyntheticSession, demo_car_sessions};
use crate::core::synth::round::{
    OutFile, RoundError, RunSummary, SynthConfig, plan_round, render_run, render_truth,
};

/// Why a round or a rig session could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SynthWriteError {
    /// A file or directory could not be created, written, renamed or replaced.
    #[error("{path}: {action}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was attempted ("cannot write", "cannot replace", ...).
        action: &'static str,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The rayon worker pool did not start.
    #[error("cannot start worker threads")]
    Pool(#[source] rayon::ThreadPoolBuildError),
    /// The round could not be planned, or a run file or the truth not rendered.
    #[error(transparent)]
    Round(#[from] RoundError),
}

/// `map_err` helper: an IO error on `path` while doing `action`.
fn io_err(path: &Path, action: &'static str) -> impl FnOnce(std::io::Error) -> SynthWriteError {
    let path = path.to_path_buf();
    move |source| SynthWriteError::Io {
        path,
        action,
        source,
    }
}

/// What [`write_round`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct RoundWritten {
    /// Run files (raw/).
    pub run_files: usize,
    /// Data rows over every run file.
    pub rows: usize,
    /// Bytes over every run file.
    pub run_bytes: usize,
    /// Tire/rim combinations tested.
    pub combos: usize,
    /// Truth models written (truth/).
    pub truths: usize,
    /// Test segments over every run file.
    pub segments: usize,
    /// Injected defects over every run file.
    pub defects: usize,
    /// Rig sessions of the demo car (inertia/).
    pub rig_sessions: usize,
    /// Wall time from planning to the last file written.
    pub elapsed: Duration,
}

/// Generate a whole virtual round into `out` (raw/, truth/ and catalog.toml are replaced; the
/// demo car's rig sessions are written into inertia/, replacing only their own directories)
/// with `jobs` worker threads (None = one per core).
pub fn write_round(
    cfg: &SynthConfig,
    out: &Path,
    jobs: Option<usize>,
) -> Result<RoundWritten, SynthWriteError> {
    let started = Instant::now();
    let plan = plan_round(cfg)?;
    for owned in ["raw", "truth"] {
        let dir = out.join(owned);
        if dir.exists() {
            fs::remove_dir_all(&dir).map_err(io_err(&dir, "cannot replace"))?;
        }
    }
    for sub in ["raw", "truth/tir"] {
        let dir = out.join(sub);
        fs::create_dir_all(&dir).map_err(io_err(&dir, "cannot create"))?;
    }

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or(0))
        .build()
        .map_err(SynthWriteError::Pool)?;
    let results: Vec<Result<(RunSummary, usize), SynthWriteError>> = pool.install(|| {
        (0..plan.runs.len())
            .into_par_iter()
            .map(|i| {
                let output = render_run(&plan, i)?;
                let bytes = output.file.bytes.len();
                write_atomic(out, &output.file)?;
                Ok((output.summary, bytes))
            })
            .collect()
    });
    let mut summaries = Vec::with_capacity(results.len());
    let mut run_bytes = 0usize;
    for r in results {
        let (s, b) = r?;
        run_bytes += b;
        summaries.push(s);
    }
    summaries.sort_by_key(|s| s.spec.run);
    for file in render_truth(&plan, &summaries)? {
        write_atomic(out, &file)?;
    }
    let sessions = demo_car_sessions(cfg.seed);
    for s in &sessions {
        write_session(&out.join(crate::run::INERTIA_DIR), s)?;
    }
    Ok(RoundWritten {
        run_files: summaries.len(),
        rows: summaries.iter().map(|s| s.rows).sum(),
        run_bytes,
        combos: plan.combos.len(),
        truths: plan.truths.len(),
        segments: summaries.iter().map(|s| s.segments.len()).sum(),
        defects: summaries.iter().map(|s| s.defects.len()).sum(),
        rig_sessions: sessions.len(),
        elapsed: started.elapsed(),
    })
}

/// Write `bytes` to the file `path`; an error names that file ("cannot write").
fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), SynthWriteError> {
    fs::write(path, bytes).map_err(io_err(path, "cannot write"))
}

/// Write `file` under `root` via a temporary name and a rename.
fn write_atomic(root: &Path, file: &OutFile) -> Result<(), SynthWriteError> {
    let path: PathBuf = root.join(&file.path);
    let tmp = path.with_extension("tmp-synth");
    write_file(&tmp, &file.bytes)?;
    fs::rename(&tmp, &path).map_err(io_err(&path, "cannot rename"))?;
    Ok(())
}

/// Write session `s` into `root/<name>/` (that directory is replaced): session.toml,
/// expected.toml and its run files; returns the directory.
pub fn write_session(root: &Path, s: &SyntheticSession) -> Result<PathBuf, SynthWriteError> {
    let dir = root.join(&s.name);
    if dir.exists() {
        fs::remove_dir_all(&dir).map_err(io_err(&dir, "cannot replace"))?;
    }
    fs::create_dir_all(&dir).map_err(io_err(&dir, "cannot create"))?;
    write_file(&dir.join("session.toml"), &s.session_toml)?;
    write_file(&dir.join("expected.toml"), s.expected_toml())?;
    for (rel, contents) in &s.files {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            fs::create_dir_all(parent).map_err(io_err(parent, "cannot create"))?;
        }
        write_file(&path, contents)?;
    }
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An unwritable root is an `Io` error naming the directory and the action, and the printed
    /// line (`commands::error_line`, as `main` prints it) ends with the OS error.
    #[test]
    fn session_under_a_file_is_an_io_error_naming_the_path() {
        let tmp = std::env::temp_dir().join(format!("tirebase-synth-round-{}", std::process::id()));
        fs::create_dir_all(&tmp).unwrap();
        let root = tmp.join("not-a-dir");
        fs::write(&root, b"x").unwrap();
        let session = demo_car_sessions(1).into_iter().next().unwrap();
        let err = write_session(&root, &session).unwrap_err();
        let dir = root.join(&session.name);
        assert!(
            matches!(&err, SynthWriteError::Io { path, action: "cannot create", .. } if *path == dir),
            "{err:?}"
        );
        let printed = crate::commands::error_line(&anyhow::Error::from(err));
        assert!(
            printed.starts_with(&format!("{}: cannot create: ", dir.display())),
            "{printed}"
        );
        fs::remove_dir_all(&tmp).unwrap();
    }

    /// A file that cannot be written is named, with the same action as every other write
    /// ("cannot write"): here a run file whose path is a directory another run file created.
    #[test]
    fn unwritable_session_file_is_named_with_cannot_write() {
        let tmp =
            std::env::temp_dir().join(format!("tirebase-synth-session-{}", std::process::id()));
        let mut session = demo_car_sessions(1).into_iter().next().unwrap();
        session.files.push(("sub/a.csv".into(), "x".into()));
        session.files.push(("sub".into(), "x".into()));
        let err = write_session(&tmp, &session).unwrap_err();
        let file = tmp.join(&session.name).join("sub");
        fs::remove_dir_all(&tmp).unwrap();
        assert!(
            matches!(&err, SynthWriteError::Io { path, action: "cannot write", .. } if *path == file),
            "{err:?}"
        );
        let printed = crate::commands::error_line(&anyhow::Error::from(err));
        assert!(
            printed.starts_with(&format!("{}: cannot write: ", file.display())),
            "{printed}"
        );
    }
}
