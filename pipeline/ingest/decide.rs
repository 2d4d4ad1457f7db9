//! The up-to-date decision for one input file, as one pure function of what the store holds for
//! it and what it depends on now.
//!
//! In: the file's runs row (if any) and [`Now`]: its stat, its content hash once read, the
//! identity the catalog gives its run, the segmentation settings and the tool version. Out: a
//! [`Decision`]. What the store holds for a file (its runs row, segments and samples) is a
//! function of the content, the identity (tire, rim, kind), the resolved `[segment]`
//! configuration and the tool version; the decision recomputes exactly the part whose inputs
//! changed: a new identity relabels the stored parts (no parse), new segmentation settings or a
//! new tool re-segment, new content re-ingests. A file that failed last time is always tried
//! again (a permission problem or a full disk is not a property of the file). Deliberately not
//! here: reading, hashing or writing anything (`ingest` acts on the decision).

use super::{FileStamp, Identity};
use crate::store::tables::{RunRow, RunStatus};

/// What the file and its settings are now.
#[derive(Clone, Debug)]
pub struct Now<'a> {
    /// Path the file is found at.
    pub path: &'a str,
    /// Its size and modification time.
    pub stamp: FileStamp,
    /// SHA-256 of its content, once read (`None` before).
    pub sha256: Option<&'a str>,
    /// The catalog's identity for the run the stored row holds (its project and run), if the
    /// catalog has an entry for it.
    pub catalog: Option<&'a Identity>,
    /// SHA-256 of the resolved `[segment]` configuration.
    pub segment_config_sha256: &'a str,
    /// This tool's version.
    pub tool_version: &'a str,
    /// Hash the content even when path, size and modification time are unchanged.
    pub rehash: bool,
    /// For a duplicate: the copy that holds its run is still stored and present.
    pub canonical_present: bool,
}

/// What to do with one file.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// The store holds exactly what these inputs give: nothing to do.
    UpToDate,
    /// Read and hash the content, then decide again with the hash.
    Hash,
    /// Read, parse, identify, segment and store (new or changed content, or a retry).
    Ingest,
    /// Same content, other segmentation settings or tool (or the file's own tire fields are
    /// needed again): parse and segment again.
    Resegment,
    /// Same content and segmentation; only the identity changed: relabel the stored parts.
    Relabel(Identity),
}

/// The identity the store holds for a row.
fn stored_identity(row: &RunRow) -> Option<(String, Option<i64>, String)> {
    Some((row.tire.clone()?, row.rim_in, row.tire_source.clone()?))
}

/// Decide what a file needs (see the module doc). Never returns [`Decision::Hash`] when
/// `now.sha256` is given.
pub fn decide(stored: Option<&RunRow>, now: &Now) -> Decision {
    let Some(row) = stored else {
        return Decision::Ingest;
    };
    let stat_unchanged = !now.rehash
        && row.source_path == now.path
        && row.size_bytes == Some(now.stamp.size_bytes)
        && row.mtime_ns == Some(now.stamp.mtime_ns);
    match row.status {
        RunStatus::Ok | RunStatus::Partial if row.data_sha256.is_some() => {}
        RunStatus::Duplicate => {
            if !now.canonical_present {
                return Decision::Ingest;
            }
            return match now.sha256 {
                None if stat_unchanged => Decision::UpToDate,
                None => Decision::Hash,
                Some(sha) if sha == row.sha256 => Decision::UpToDate,
                Some(_) => Decision::Ingest,
            };
        }
        // Failed (environmental or not), or a row without data: try again.
        _ => return Decision::Ingest,
    }
    let content_same = match now.sha256 {
        None if stat_unchanged => true,
        None => return Decision::Hash,
        Some(sha) => row.data_sha256.as_deref() == Some(sha),
    };
    if !content_same {
        return Decision::Ingest;
    }
    if row.segment_config_sha256.as_deref() != Some(now.segment_config_sha256)
        || row.tool_version.as_deref() != Some(now.tool_version)
        || row.run_class.is_none()
    {
        return Decision::Resegment;
    }
    let Some(stored) = stored_identity(row) else {
        return Decision::Resegment;
    };
    let wanted = match now.catalog {
        Some(id) => id.clone(),
        // The catalog no longer names this run: the file's own tire fields apply again, and
        // only a parse can read them.
        None if stored.2 == "catalog" => return Decision::Resegment,
        None => return Decision::UpToDate,
    };
    let kind_hint = wanted.kind_hint.clone().or_else(|| row.run_class.clone());
    if (
        wanted.tire.clone(),
        wanted.rim_in,
        wanted.source.to_string(),
    ) == stored
        && kind_hint == row.kind_hint
    {
        Decision::UpToDate
    } else {
        Decision::Relabel(wanted)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::tables::RunStatus;

    const SEG: &str = "seg-config-1";
    const TOOL: &str = "0.1.0";

    fn stored() -> RunRow {
        RunRow {
            source_file: "B2410run2.dat".into(),
            source_path: "/in/raw/B2410run2.dat".into(),
            sha256: "c1".into(),
            data_sha256: Some("c1".into()),
            status: RunStatus::Ok,
            project: Some(2410),
            run: Some(2),
            tire: Some("Hoosier R25B".into()),
            rim_in: Some(7),
            tire_source: Some("catalog".into()),
            kind_hint: Some("drive_brake".into()),
            run_class: Some("drive_brake".into()),
            size_bytes: Some(100),
            mtime_ns: Some(5),
            segment_config_sha256: Some(SEG.into()),
            tool_version: Some(TOOL.into()),
            parts_sha256: Some("p1".into()),
            ..RunRow::default()
        }
    }

    fn catalog(tire: &str, rim: i64, kind: Option<&str>) -> Identity {
        Identity {
            tire: tire.into(),
            rim_in: Some(rim),
            source: "catalog",
            kind_hint: kind.map(String::from),
        }
    }

    fn now<'a>(id: Option<&'a Identity>, sha: Option<&'a str>) -> Now<'a> {
        Now {
            path: "/in/raw/B2410run2.dat",
            stamp: FileStamp {
                size_bytes: 100,
                mtime_ns: 5,
            },
            sha256: sha,
            catalog: id,
            segment_config_sha256: SEG,
            tool_version: TOOL,
            rehash: false,
            canonical_present: true,
        }
    }

    #[test]
    fn a_new_file_is_ingested() {
        assert_eq!(decide(None, &now(None, None)), Decision::Ingest);
    }

    #[test]
    fn nothing_changed_is_up_to_date_without_reading() {
        let id = catalog("Hoosier R25B", 7, Some("drive_brake"));
        assert_eq!(
            decide(Some(&stored()), &now(Some(&id), None)),
            Decision::UpToDate
        );
    }

    #[test]
    fn a_new_stat_or_rehash_reads_the_content_and_same_bytes_are_no_change() {
        let id = catalog("Hoosier R25B", 7, Some("drive_brake"));
        let mut n = now(Some(&id), None);
        n.stamp.mtime_ns = 6;
        assert_eq!(decide(Some(&stored()), &n), Decision::Hash);
        n.sha256 = Some("c1");
        assert_eq!(decide(Some(&stored()), &n), Decision::UpToDate);
        let mut r = now(Some(&id), None);
        r.rehash = true;
        assert_eq!(decide(Some(&stored()), &r), Decision::Hash);
        let mut moved = now(Some(&id), None);
        moved.path = "/elsewhere/B2410run2.dat";
        assert_eq!(decide(Some(&stored()), &moved), Decision::Hash);
    }

    #[test]
    fn new_content_is_ingested() {
        let id = catalog("Hoosier R25B", 7, Some("drive_brake"));
        let mut n = now(Some(&id), Some("c2"));
        n.stamp.size_bytes = 101;
        assert_eq!(decide(Some(&stored()), &n), Decision::Ingest);
    }

    #[test]
    fn a_catalog_edit_relabels_without_a_parse() {
        let renamed = catalog("Hoosier R25B (2024)", 7, Some("drive_brake"));
        assert_eq!(
            decide(Some(&stored()), &now(Some(&renamed), None)),
            Decision::Relabel(renamed.clone())
        );
        let other_rim = catalog("Hoosier R25B", 8, Some("drive_brake"));
        assert_eq!(
            decide(Some(&stored()), &now(Some(&other_rim), None)),
            Decision::Relabel(other_rim.clone())
        );
        // The kind hint alone is a label too; without a catalog kind the detected class applies.
        let no_kind = catalog("Hoosier R25B", 7, None);
        assert_eq!(
            decide(Some(&stored()), &now(Some(&no_kind), None)),
            Decision::UpToDate
        );
        let cornering = catalog("Hoosier R25B", 7, Some("cornering"));
        assert_eq!(
            decide(Some(&stored()), &now(Some(&cornering), None)),
            Decision::Relabel(cornering.clone())
        );
    }

    #[test]
    fn a_run_dropped_from_the_catalog_is_parsed_again_for_its_own_tire_fields() {
        assert_eq!(
            decide(Some(&stored()), &now(None, None)),
            Decision::Resegment
        );
        // A file named by its own fields never depended on the catalog.
        let mut own = stored();
        own.tire_source = Some("tire_name".into());
        assert_eq!(decide(Some(&own), &now(None, None)), Decision::UpToDate);
        // ...until the catalog names its run.
        let id = catalog("Catalogued", 7, None);
        assert_eq!(
            decide(Some(&own), &now(Some(&id), None)),
            Decision::Relabel(id.clone())
        );
    }

    #[test]
    fn new_segmentation_settings_or_tool_resegment() {
        let id = catalog("Hoosier R25B", 7, Some("drive_brake"));
        let mut n = now(Some(&id), None);
        n.segment_config_sha256 = "seg-config-2";
        assert_eq!(decide(Some(&stored()), &n), Decision::Resegment);
        let mut n = now(Some(&id), None);
        n.tool_version = "0.2.0";
        assert_eq!(decide(Some(&stored()), &n), Decision::Resegment);
        // A row from before these columns existed.
        let mut legacy = stored();
        legacy.segment_config_sha256 = None;
        legacy.tool_version = None;
        legacy.run_class = None;
        assert_eq!(
            decide(Some(&legacy), &now(Some(&id), None)),
            Decision::Resegment
        );
        // New content wins over new settings.
        let mut n = now(Some(&id), Some("c2"));
        n.segment_config_sha256 = "seg-config-2";
        assert_eq!(decide(Some(&stored()), &n), Decision::Ingest);
    }

    #[test]
    fn failures_are_retried_every_time() {
        let id = catalog("Hoosier R25B", 7, Some("drive_brake"));
        let mut failed = stored();
        failed.status = RunStatus::Failed;
        failed.sha256 = String::new();
        failed.error = Some("Permission denied".into());
        assert_eq!(
            decide(Some(&failed), &now(Some(&id), None)),
            Decision::Ingest
        );
        let mut never = failed.clone();
        never.data_sha256 = None;
        assert_eq!(
            decide(Some(&never), &now(Some(&id), None)),
            Decision::Ingest
        );
    }

    #[test]
    fn a_partial_file_is_kept_like_an_ok_one() {
        let id = catalog("Hoosier R25B", 7, Some("drive_brake"));
        let mut partial = stored();
        partial.status = RunStatus::Partial;
        assert_eq!(
            decide(Some(&partial), &now(Some(&id), None)),
            Decision::UpToDate
        );
    }

    #[test]
    fn a_duplicate_stays_one_while_its_canonical_copy_is_there() {
        let mut dup = stored();
        dup.status = RunStatus::Duplicate;
        dup.data_sha256 = None;
        dup.parts_sha256 = None;
        assert_eq!(decide(Some(&dup), &now(None, None)), Decision::UpToDate);
        let mut n = now(None, None);
        n.stamp.mtime_ns = 9;
        assert_eq!(decide(Some(&dup), &n), Decision::Hash);
        n.sha256 = Some("c1");
        assert_eq!(decide(Some(&dup), &n), Decision::UpToDate);
        n.sha256 = Some("c9");
        assert_eq!(decide(Some(&dup), &n), Decision::Ingest);
        let mut gone = now(None, None);
        gone.canonical_present = false;
        assert_eq!(decide(Some(&dup), &gone), Decision::Ingest);
    }
}
