//! The run catalog: which tire and rim a raw file belongs to (old rounds' `.dat` files name no
//! tire), like the consortium's run guide.
//!
//! ```toml
//! [[run]]
//! project = 1320
//! run = 54
//! tire = "Hoosier 20.5x7.0-13 R25B"
//! rim_in = 7
//! kind = "cornering"        # optional hint: cornering | drive_brake | warmup | transient
//! ```
//!
//! In: a TOML file. Out: lookups by (project, run), checked: a non-empty tire name (trimmed), a
//! positive whole-inch rim (rim widths are integers in every table; 7.5 is refused rather than
//! rounded to 8), a known kind. `tirebase synth round` writes this format.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use crate::config::{TomlFileError, parse_toml, read_toml_text};

/// One catalogued run.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CatalogEntry {
    /// Calspan project number.
    pub project: u32,
    /// Run number.
    pub run: u32,
    /// Tire name.
    pub tire: String,
    /// Rim width, inches.
    pub rim_in: f64,
    /// Optional run kind hint.
    #[serde(default)]
    pub kind: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogFile {
    #[serde(default)]
    run: Vec<CatalogEntry>,
}

/// Catalog errors.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    File(#[from] TomlFileError),
    /// Two entries for one (project, run) disagree.
    #[error("{path}: project {project} run {run} is catalogued twice with different tires")]
    Conflict {
        /// Catalog path.
        path: String,
        /// Project.
        project: u32,
        /// Run.
        run: u32,
    },
    /// A value out of range (names the entry and the key).
    #[error("{path}: project {project} run {run}: {key} {message}")]
    Invalid {
        /// Catalog path.
        path: String,
        /// Project.
        project: u32,
        /// Run.
        run: u32,
        /// The key.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A kind hint is not one of the known kinds.
    #[error(
        "{path}: project {project} run {run}: kind {kind:?} is not one of cornering, drive_brake, warmup, transient"
    )]
    Kind {
        /// Catalog path.
        path: String,
        /// Project.
        project: u32,
        /// Run.
        run: u32,
        /// The bad kind.
        kind: String,
    },
}

/// Known run kind hints.
pub const KINDS: &[&str] = &["cornering", "drive_brake", "warmup", "transient"];

/// Runs by (project, run).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Catalog {
    entries: BTreeMap<(u32, u32), CatalogEntry>,
}

impl Catalog {
    /// Parse catalog TOML text; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Catalog, CatalogError> {
        let file: CatalogFile = parse_toml(text, path)?;
        let mut entries = BTreeMap::new();
        for mut e in file.run {
            let invalid = |key: &'static str, message: String| CatalogError::Invalid {
                path: path.to_string(),
                project: e.project,
                run: e.run,
                key,
                message,
            };
            if e.tire.trim().is_empty() {
                return Err(invalid("tire", "is empty: name the tire".to_string()));
            }
            e.tire = e.tire.trim().to_string();
            if !(e.rim_in.is_finite() && e.rim_in > 0.0) {
                return Err(invalid(
                    "rim_in",
                    format!(
                        "= {}: a rim width must be a positive number of inches",
                        e.rim_in
                    ),
                ));
            }
            if e.rim_in.fract() != 0.0 {
                // Rim widths are stored, grouped and named in whole inches; rounding 7.5 to 8
                // would silently put the run on another rim.
                return Err(invalid(
                    "rim_in",
                    format!(
                        "= {}: rim widths are whole inches in the store (every table and .tir \
                         name); rounding would put the run on another rim, so it is refused",
                        e.rim_in
                    ),
                ));
            }
            if let Some(kind) = &e.kind
                && !KINDS.contains(&kind.as_str())
            {
                return Err(CatalogError::Kind {
                    path: path.to_string(),
                    project: e.project,
                    run: e.run,
                    kind: kind.clone(),
                });
            }
            if let Some(old) = entries.get(&(e.project, e.run))
                && old != &e
            {
                return Err(CatalogError::Conflict {
                    path: path.to_string(),
                    project: e.project,
                    run: e.run,
                });
            }
            entries.insert((e.project, e.run), e);
        }
        Ok(Catalog { entries })
    }

    /// Read a catalog file.
    pub fn read(path: &Path) -> Result<Catalog, CatalogError> {
        let (text, name) = read_toml_text(path)?;
        Catalog::parse(&text, &name)
    }

    /// The entry for a run, if catalogued.
    pub fn get(&self, project: u32, run: u32) -> Option<&CatalogEntry> {
        self.entries.get(&(project, run))
    }

    /// Number of catalogued runs.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the catalog is empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_format() {
        let c = Catalog::parse(
            "[[run]]\nproject = 1320\nrun = 54\ntire = \"Hoosier 20.5x7.0-13 R25B\"\nrim_in = 7\nkind = \"cornering\"\n",
            "catalog.toml",
        )
        .unwrap();
        let e = c.get(1320, 54).unwrap();
        assert_eq!(
            (e.tire.as_str(), e.rim_in),
            ("Hoosier 20.5x7.0-13 R25B", 7.0)
        );
        assert!(c.get(1320, 55).is_none());
    }

    #[test]
    fn issue20_rims_and_tires_are_checked() {
        let entry = |tire: &str, rim: &str| {
            Catalog::parse(
                &format!("[[run]]\nproject = 1\nrun = 2\ntire = \"{tire}\"\nrim_in = {rim}\n"),
                "c.toml",
            )
        };
        for (tire, rim, wanted) in [
            ("Hoosier", "0", "rim_in = 0: a rim width must be a positive"),
            (
                "Hoosier",
                "-7",
                "rim_in = -7: a rim width must be a positive",
            ),
            ("Hoosier", "nan", "rim_in = NaN"),
            (
                "Hoosier",
                "7.5",
                "rim_in = 7.5: rim widths are whole inches",
            ),
            ("", "7", "tire is empty"),
            ("   ", "7", "tire is empty"),
        ] {
            let err = entry(tire, rim).unwrap_err().to_string();
            assert!(
                err.starts_with("c.toml: project 1 run 2: ") && err.contains(wanted),
                "{tire:?} {rim}: {err}"
            );
        }
        let ok = entry(" Hoosier R25B ", "7").unwrap();
        assert_eq!(ok.get(1, 2).unwrap().tire, "Hoosier R25B");
        assert_eq!(ok.get(1, 2).unwrap().rim_in, 7.0);
    }

    #[test]
    fn errors_name_the_problem() {
        let err = Catalog::parse("[[run]]\nproject = 1\nrun = 2\ntire = 3\n", "c.toml")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("c.toml:"), "{err}");
        let err = Catalog::parse(
            "[[run]]\nproject = 1\nrun = 2\ntire = \"x\"\nrim_in = 7\nkind = \"skidpad\"\n",
            "c.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("skidpad"), "{err}");
        let err = Catalog::parse(
            "[[run]]\nproject = 1\nrun = 2\ntire = \"x\"\nrim_in = 7\ncolour = 1\n",
            "c.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("colour"), "{err}");
    }
}
