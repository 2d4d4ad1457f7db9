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
//!
//! [[run]]
//! file = "drivebrake.mat"   # a file whose name and header state no project and run
//! tire = "Hoosier 20.5x7.0-13 R25B"
//! rim_in = 7
//! ```
//!
//! In: a TOML file. Out: lookups by file name, else by (project, run), checked: each entry keyed
//! by `file` (a file name, no directory) or by `project` and `run` (both keys at once only when
//! the file name states that project and run), a non-empty tire name (trimmed), a positive
//! whole-inch rim (rim widths are integers in every table; 7.5 is refused rather than rounded to
//! 8), a known kind. `tirebase synth round` writes this format.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use tirebase_core::ttc::TtcFileName;

use crate::config::{TomlFileError, parse_toml, read_toml_text};

/// One catalogued run.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CatalogEntry {
    /// Calspan project number (with `run`).
    #[serde(default)]
    pub project: Option<u32>,
    /// Run number (with `project`).
    #[serde(default)]
    pub run: Option<u32>,
    /// File name (no directory), for a file whose name and header state no project and run.
    #[serde(default)]
    pub file: Option<String>,
    /// Tire name.
    pub tire: String,
    /// Rim width, inches.
    pub rim_in: f64,
    /// Optional run kind hint.
    #[serde(default)]
    pub kind: Option<String>,
}

impl CatalogEntry {
    /// How errors name the entry: `project 1320 run 54`, `file "drivebrake.mat"`, or by its
    /// position when its key is missing.
    fn label(&self, index: usize) -> String {
        match (self.project, self.run, &self.file) {
            (Some(p), Some(r), _) => format!("project {p} run {r}"),
            (_, _, Some(f)) => format!("file {f:?}"),
            _ => format!("entry {} ([[run]] number {})", self.tire.trim(), index + 1),
        }
    }
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
    /// Two entries for one (project, run) or one file name disagree.
    #[error("{path}: {entry} is catalogued twice with different tires")]
    Conflict {
        /// Catalog path.
        path: String,
        /// The entry (`project 1320 run 54`, `file "drivebrake.mat"`).
        entry: String,
    },
    /// A value out of range (names the entry and the key).
    #[error("{path}: {entry}: {key} {message}")]
    Invalid {
        /// Catalog path.
        path: String,
        /// The entry (`project 1320 run 54`, `file "drivebrake.mat"`).
        entry: String,
        /// The key.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A kind hint is not one of the known kinds.
    #[error(
        "{path}: {entry}: kind {kind:?} is not one of cornering, drive_brake, warmup, transient"
    )]
    Kind {
        /// Catalog path.
        path: String,
        /// The entry (`project 1320 run 54`, `file "drivebrake.mat"`).
        entry: String,
        /// The bad kind.
        kind: String,
    },
}

/// Known run kind hints.
pub const KINDS: &[&str] = &["cornering", "drive_brake", "warmup", "transient"];

/// Runs by (project, run) and by file name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Catalog {
    entries: BTreeMap<(u32, u32), CatalogEntry>,
    files: BTreeMap<String, CatalogEntry>,
}

/// The entry's key, checked: a file name, a project and run, or both when the name states them.
fn check_key(e: &CatalogEntry) -> Result<(), (&'static str, String)> {
    let file = e.file.as_deref().map(str::trim);
    if let Some(f) = file
        && (f.is_empty() || f.contains(['/', '\\']))
    {
        return Err((
            "file",
            format!("= {f:?}: give the file's name alone (as in the input directory)"),
        ));
    }
    match (e.project, e.run, file) {
        (Some(_), Some(_), None) | (None, None, Some(_)) => Ok(()),
        (None, None, None) => Err((
            "project",
            "and run, or file, missing: key the entry by project = <n> and run = <n>, or by \
             file = \"<file name>\""
                .to_string(),
        )),
        (Some(_), None, _) | (None, Some(_), _) => Err((
            if e.project.is_none() {
                "project"
            } else {
                "run"
            },
            "missing: project and run go together (or key the entry by file = \"<file name>\" \
             alone)"
                .to_string(),
        )),
        (Some(p), Some(r), Some(f)) => match TtcFileName::parse(f) {
            Some(n) if (n.project, n.run) == (p, r) => Ok(()),
            Some(n) => Err((
                "file",
                format!(
                    "= {f:?} names project {} run {}, not project {p} run {r}: give file or \
                     project and run",
                    n.project, n.run
                ),
            )),
            None => Err((
                "file",
                format!(
                    "= {f:?} states no project and run, so project {p} run {r} cannot be \
                     checked against it: give file or project and run, not both"
                ),
            )),
        },
    }
}

impl Catalog {
    /// Parse catalog TOML text; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Catalog, CatalogError> {
        let file: CatalogFile = parse_toml(text, path)?;
        let mut entries = BTreeMap::new();
        let mut files = BTreeMap::new();
        for (index, mut e) in file.run.into_iter().enumerate() {
            let entry = e.label(index);
            let invalid = |key: &'static str, message: String| CatalogError::Invalid {
                path: path.to_string(),
                entry: entry.clone(),
                key,
                message,
            };
            if let Err((key, message)) = check_key(&e) {
                return Err(invalid(key, message));
            }
            e.file = e.file.map(|f| f.trim().to_string());
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
                    entry,
                    kind: kind.clone(),
                });
            }
            let conflict = |entry: String| CatalogError::Conflict {
                path: path.to_string(),
                entry,
            };
            if let (Some(p), Some(r)) = (e.project, e.run) {
                if entries.get(&(p, r)).is_some_and(|old| old != &e) {
                    return Err(conflict(format!("project {p} run {r}")));
                }
                entries.insert((p, r), e.clone());
            }
            if let Some(f) = e.file.clone() {
                if files.get(&f).is_some_and(|old| old != &e) {
                    return Err(conflict(format!("file {f:?}")));
                }
                files.insert(f, e);
            }
        }
        Ok(Catalog { entries, files })
    }

    /// Read a catalog file.
    pub fn read(path: &Path) -> Result<Catalog, CatalogError> {
        let (text, name) = read_toml_text(path)?;
        Catalog::parse(&text, &name)
    }

    /// The entry for a run, if catalogued by project and run.
    pub fn get(&self, project: u32, run: u32) -> Option<&CatalogEntry> {
        self.entries.get(&(project, run))
    }

    /// The entry for a file: by its name (the last component of `source_name`), else by the
    /// project and run it states.
    pub fn lookup(
        &self,
        source_name: &str,
        project: Option<u32>,
        run: Option<u32>,
    ) -> Option<&CatalogEntry> {
        let name = source_name
            .rsplit(['/', '\\'])
            .next()
            .unwrap_or(source_name);
        self.files.get(name).or_else(|| self.get(project?, run?))
    }

    /// Number of catalogued runs and files.
    pub fn len(&self) -> usize {
        self.entries.len() + self.files.values().filter(|e| e.project.is_none()).count()
    }

    /// Whether the catalog is empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty() && self.files.is_empty()
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
    fn an_entry_keyed_by_file_name_is_found_before_project_and_run() {
        let c = Catalog::parse(
            "[[run]]\nfile = \"drivebrake.mat\"\ntire = \"A\"\nrim_in = 7\n\
             [[run]]\nproject = 1320\nrun = 54\ntire = \"B\"\nrim_in = 8\n\
             [[run]]\nfile = \"B1320run55.mat\"\nproject = 1320\nrun = 55\ntire = \"C\"\nrim_in = 6\n",
            "c.toml",
        )
        .unwrap();
        let tire = |name: &str, p: Option<u32>, r: Option<u32>| {
            c.lookup(name, p, r).map(|e| e.tire.clone())
        };
        assert_eq!(tire("raw/drivebrake.mat", None, None).as_deref(), Some("A"));
        assert_eq!(
            tire("drivebrake.mat", Some(1320), Some(54)).as_deref(),
            Some("A")
        );
        assert_eq!(
            tire("other.mat", Some(1320), Some(54)).as_deref(),
            Some("B")
        );
        assert_eq!(
            tire("other.mat", Some(1320), Some(55)).as_deref(),
            Some("C")
        );
        assert_eq!(tire("Drivebrake.mat", None, None), None);
        assert_eq!(c.len(), 3);
    }

    #[test]
    fn an_entry_needs_one_consistent_key() {
        let entry = |keys: &str| {
            Catalog::parse(
                &format!("[[run]]\n{keys}\ntire = \"T\"\nrim_in = 7\n"),
                "c.toml",
            )
            .map(|_| ())
            .map_err(|e| e.to_string())
        };
        for (keys, wanted) in [
            (
                "",
                "c.toml: entry T ([[run]] number 1): project and run, or file, missing",
            ),
            (
                "project = 1",
                "c.toml: entry T ([[run]] number 1): run missing",
            ),
            ("run = 1", "project missing"),
            (
                "file = \"a/b.mat\"",
                "file = \"a/b.mat\": give the file's name alone",
            ),
            ("file = \" \"", "give the file's name alone"),
            (
                "file = \"B1320run5.mat\"\nproject = 1320\nrun = 6",
                "c.toml: project 1320 run 6: file = \"B1320run5.mat\" names project 1320 run 5",
            ),
            (
                "file = \"drivebrake.mat\"\nproject = 1320\nrun = 6",
                "states no project and run",
            ),
        ] {
            let err = entry(keys).unwrap_err();
            assert!(err.contains(wanted), "{keys:?}: {err}");
        }
        assert_eq!(
            entry("file = \"B1320run5.mat\"\nproject = 1320\nrun = 5"),
            Ok(())
        );
        let twice = Catalog::parse(
            "[[run]]\nfile = \"x.mat\"\ntire = \"A\"\nrim_in = 7\n\
             [[run]]\nfile = \"x.mat\"\ntire = \"B\"\nrim_in = 7\n",
            "c.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            twice.contains("file \"x.mat\" is catalogued twice"),
            "{twice}"
        );
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
