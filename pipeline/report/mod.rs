//! The HTML report of a fitted round: `index.html` plus one page per tire, self-contained
//! (inline CSS and SVG, no script, nothing fetched from a network or another file except the
//! links between the pages).
//!
//! In: a store (the measured samples and segments), the results (a result directory as
//! `fit::write_outcome` writes it: `<table>.parquet`, `tir/*.tir`; or the typed tables a run
//! has just merged, `store::results::Results`, and its `tir/` directory) and the car the tires
//! are chosen for. Out: the pages in `out_dir` and a [`ReportSummary`]. The index opens with
//! the tire selection (`selection.rs`: every tire at the car's conditions, charts and the
//! ranked comparison), then the tires, the rig-inertia results, fit quality, lint warnings,
//! failures. Each tire page shows data against model for Fy-SA, Mz-SA and Fx-SL
//! per load and inclination (the seed's figures 18-19), the friction envelope (figure 22), peak
//! mu and cornering stiffness against load per pressure (figures 23-24), vertical stiffness
//! against pressure and inclination, mu against tread temperature (figure 29), relaxation length
//! against load, fit quality, coefficients at a bound, lint warnings and failures. A missing
//! table, column or model leaves a "no data" note where its chart would be, never an error.
//!
//! Deliberately not here: fitting, deciding pass/fail of a round, anything interactive.

mod data;
mod pages;
mod plots;
mod selection;
pub mod svg;

use std::path::{Path, PathBuf};

use tirebase_core::compare::Objective;

pub use data::ReportData;

use crate::compare::car::Car;
use crate::compare::round::RoundResults;
use crate::compare::{TireFilter, compare};
use crate::store::results::Results;

/// Report errors: only the inputs as a whole being unusable or the output being unwritable.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The result directory does not exist.
    #[error("{path}: result directory not found")]
    NoResults {
        /// The directory.
        path: PathBuf,
    },
    /// The store could not be opened.
    #[error("{path}: cannot read the store: {source}")]
    Store {
        /// The store root.
        path: PathBuf,
        /// Why.
        source: crate::query::QueryError,
    },
    /// A page could not be written.
    #[error("{path}: cannot write the report: {source}")]
    Write {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: crate::store::StoreError,
    },
}

/// What a report contains.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReportSummary {
    /// Pages written (index first), absolute or as given by `out_dir`.
    pub pages: Vec<PathBuf>,
    /// Tires with a page.
    pub tires: usize,
    /// Charts drawn.
    pub plots: usize,
    /// Chart slots shown as a "no data" note.
    pub plots_without_data: usize,
    /// Total bytes written.
    pub bytes: u64,
    /// Inputs that were missing or unreadable (also listed on the index page).
    pub notes: Vec<String>,
}

/// Writes a self-contained HTML report (index.html + one page per tire, inline SVG, no network)
/// into `out_dir` from the store's samples/segments and a finished result directory laid out as
/// write_outcome writes it (tables as `<name>.parquet`, `tir/*.tir`); the index opens with the
/// tire selection for `car`.
pub fn write_report(
    store: &Path,
    results: &Path,
    out_dir: &Path,
    car: &Car,
) -> Result<ReportSummary, ReportError> {
    if !results.is_dir() {
        return Err(ReportError::NoResults {
            path: results.to_path_buf(),
        });
    }
    write_report_from(
        store,
        &Results::read(results),
        &results.join("tir"),
        out_dir,
        car,
    )
}

/// [`write_report`] from typed result tables and the `.tir` files of `tir_dir`.
pub fn write_report_from(
    store: &Path,
    results: &Results,
    tir_dir: &Path,
    out_dir: &Path,
    car: &Car,
) -> Result<ReportSummary, ReportError> {
    let data = data::load(store, results, tir_dir)?;
    let round = RoundResults::new("this round", data.results.clone(), data.models.clone());
    let comparison = compare(&[round], car, Objective::Lateral, &TireFilter::default());
    let built = pages::build(&data, &comparison);
    crate::store::files::ensure_dir(out_dir).map_err(|source| ReportError::Write {
        path: out_dir.to_path_buf(),
        source,
    })?;
    let mut summary = ReportSummary {
        tires: built.pages.len() - 1,
        plots: built.plots,
        plots_without_data: built.plots_without_data,
        notes: data.notes.clone(),
        ..Default::default()
    };
    for (name, html) in &built.pages {
        let path = out_dir.join(name);
        crate::store::files::write_bytes_atomic(&path, html.as_bytes()).map_err(|source| {
            ReportError::Write {
                path: path.clone(),
                source,
            }
        })?;
        summary.bytes += html.len() as u64;
        summary.pages.push(path);
    }
    Ok(summary)
}
