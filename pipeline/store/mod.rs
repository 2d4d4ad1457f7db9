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

/// Store errors; each names the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// Operating-system error on a path. (The OS error is part of the message, not a separate
    /// `source`, so a printed error chain names it once.)
    #[error("{path}: {error}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        error: std::io::Error,
    },
    /// polars failed to read or write a table.
    #[error("{path}: {error}")]
    Polars {
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
    /// A table does not have the columns its schema requires.
    #[error("{table}: {message}")]
    Schema {
        /// Table name.
        table: String,
        /// What is wrong.
        message: String,
    },
}

impl StoreError {
    /// Wrap an I/O error with its path.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        StoreError::Io {
            path: path.to_path_buf(),
            error: source,
        }
    }

    /// Wrap a polars error with its path.
    pub fn polars(path: &Path, source: polars::error::PolarsError) -> Self {
        StoreError::Polars {
            path: path.to_path_buf(),
            error: source,
        }
    }
}
