//! The only code that touches the store's disk layout: paths, atomic Parquet files, the lock,
//! the store's tables and what of them is live (`tables`), versions, and the result tables of a
//! version (`results`, typed for the readers that use their values).
//!
//! In: DataFrames and keys. Out: files under a store root that polars, pandas, DuckDB and Spark
//! read directly (hive-partitioned Parquet). Deliberately not here: what a table contains (the
//! schemas and the stages decide) and any computation on the data.

pub mod columns;
pub mod files;
pub mod layout;
pub mod lock;
pub mod results;
pub mod tables;
pub mod versions;

use std::path::{Path, PathBuf};

/// Store errors; each names the file it concerns (an OS error also what was being done to it).
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// Operating-system error on a path, e.g. `writing /store/runs.parquet.tmp: No space left on
    /// device`. (The OS error is part of the message, not a separate `source`, so a printed error
    /// chain names it once.)
    #[error("{op} {path}: {error}")]
    Io {
        /// What was being done.
        op: IoOp,
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// polars failed to read or write a table, e.g. `reading /store/runs.parquet: parquet: File
    /// out of specification`.
    #[error("{op} {path}: {error}")]
    Polars {
        /// What was being done.
        op: IoOp,
        /// The table file.
        path: PathBuf,
        /// The polars error.
        error: polars::error::PolarsError,
    },
    /// Another process holds the store lock.
    #[error(
        "store {root} is locked by another tirebase process ({holder}); try again when it finishes"
    )]
    Locked {
        /// The store root.
        root: PathBuf,
        /// The holder's description from the lock file.
        holder: String,
    },
    /// The store's live parts were written with an older layout: the inclination keyed
    /// `ia_deg_nom` (rounded whole degrees, `-1` for swept) instead of `ia_cdeg_nom`, or a swept
    /// pressure or load keyed `-1` instead of null.
    #[error(
        "store {root} was written by an older tirebase: {what} ({file}); re-ingest the raw files \
         into it with `tirebase ingest --store {root} <raw files or directories>` (or `tirebase \
         run --store {root} --input ROUND`), which segments every file again and removes the old \
         parts"
    )]
    OldLayout {
        /// The store root.
        root: PathBuf,
        /// A part file written with the old key.
        file: PathBuf,
        /// How the old layout differs.
        what: &'static str,
    },
    /// A table does not have the columns its schema requires.
    #[error("{table}: {message}")]
    Schema {
        /// Table name.
        table: String,
        /// What is wrong.
        message: String,
    },
}

/// What the store was doing on a path when the operating system refused: the verb of a
/// [`StoreError::Io`] message.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum IoOp {
    /// Reading (or hashing) a file.
    Read,
    /// Writing a file (or the temporary sibling it is written through).
    Write,
    /// Creating a directory and its parents.
    CreateDir,
    /// Listing a directory.
    List,
    /// Renaming a finished temporary file or directory onto the path.
    Rename,
    /// Copying a file to the path.
    Copy,
    /// Removing a file or directory.
    Remove,
    /// Opening or taking the store lock file.
    Lock,
    /// Flushing the filesystem holding the path to disk.
    Sync,
}

impl std::fmt::Display for IoOp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            IoOp::Read => "reading",
            IoOp::Write => "writing",
            IoOp::CreateDir => "creating directory",
            IoOp::List => "listing directory",
            IoOp::Rename => "renaming onto",
            IoOp::Copy => "copying to",
            IoOp::Remove => "removing",
            IoOp::Lock => "locking",
            IoOp::Sync => "syncing the filesystem of",
        })
    }
}

impl StoreError {
    /// Wrap an I/O error with what was being done and its path.
    pub fn io(op: IoOp, path: &Path, source: std::io::Error) -> Self {
        StoreError::Io {
            op,
            path: path.to_path_buf(),
            error: source,
        }
    }

    /// Wrap a polars error with what was being done and its path.
    pub fn polars(op: IoOp, path: &Path, source: polars::error::PolarsError) -> Self {
        StoreError::Polars {
            op,
            path: path.to_path_buf(),
            error: source,
        }
    }
}
