//! TEMPORARY SHIM of the report API (owner: helper `report`, INTERFACES.md) so the nightly run
//! compiles before the real module lands on main; deleted when `main` is merged. Writes a
//! placeholder index.html only.

use std::path::Path;

use crate::store::StoreError;

/// Report errors.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The store could not be read or written.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// What the report holds.
#[derive(Clone, Debug, Default)]
pub struct ReportSummary {
    pub pages: usize,
}

/// Placeholder report.
pub fn write_report(
    _store: &Path,
    _results: &Path,
    out_dir: &Path,
) -> Result<ReportSummary, ReportError> {
    crate::store::files::write_bytes_atomic(
        &out_dir.join("index.html"),
        b"<!doctype html><title>shim</title>",
    )?;
    Ok(ReportSummary { pages: 1 })
}
