//! The store's disk layout, as pure functions from keys to paths. The only place that knows
//! where anything lives under a store root.
//!
//! ```text
//! STORE/
//!   runs/runs.parquet                        one row per ingested file (the ingest commit point)
//!   segments/<source>-<key12>.parquet        one file per ingested source file
//!   samples/test=<kind>/tire=<tire>/rim_in=<in>/pressure_kpa_nom=<kPa>/ia_cdeg_nom=<cdeg>/fz_n_nom=<N>/
//!           <source>-<key12>.parquet         the samples of one source file in that partition
//!                                            (<key12>: runs.parts_sha256, see store::tables)
//!   versions/v000001/ ...                    immutable published versions
//!   store.lock                               held while a command writes
//! ```
//!
//! The nominal-level keys carry a `_nom` suffix (the same names as in the `segments` table): a
//! partition key named like a column inside the files (`fz_n`, `pressure_kpa`: the measured
//! per-sample values) is shadowed by the directory value in polars and is a duplicate-column
//! error in DuckDB, so the measured load would silently become the nominal one.
//!
//! Partition values are integers or strings (never floats). The inclination is keyed in
//! hundredths of a degree (`ia_cdeg_nom=160` is 1.6 deg, `-100` is -1 deg: negative camber is a
//! tested level, so no number can mean "swept"). A level that does not apply (a swept or
//! unlevelled inclination, a swept load in a spring-rate hold, a pressure not held) is the hive
//! null, [`HIVE_NULL`], which polars, pyarrow and Spark read back as a null of the integer
//! column; an unknown rim is `0`. String
//! values are percent-encoded exactly like polars, pyarrow and DuckDB expect (`/`, `=`, `%`, `:`,
//! space and control characters), so every hive reader decodes the original tire name.

use std::path::{Path, PathBuf};

/// Sub-directory holding the per-sample table.
pub const SAMPLES_DIR: &str = "samples";
/// Sub-directory holding the per-segment table.
pub const SEGMENTS_DIR: &str = "segments";
/// Sub-directory holding the per-file table.
pub const RUNS_DIR: &str = "runs";
/// File name of the runs table inside [`RUNS_DIR`].
pub const RUNS_FILE: &str = "runs.parquet";
/// Sub-directory holding published versions.
pub const VERSIONS_DIR: &str = "versions";
/// The store's lock file.
pub const LOCK_FILE: &str = "store.lock";
/// Suffix of files being written; never matched by `*.parquet` globs.
pub const TEMP_SUFFIX: &str = ".tmp";

/// The hive partition value of a null (the Hive convention; polars, pyarrow and Spark read it
/// as null whatever the column's type): the key of a level that was swept or not held.
pub const HIVE_NULL: &str = "__HIVE_DEFAULT_PARTITION__";

/// Samples partition directories of the previous layout (store layout 2): a swept or unheld
/// pressure or load was keyed `-1` instead of [`HIVE_NULL`].
pub const OLD_SWEPT_DIRS: [&str; 2] = ["pressure_kpa_nom=-1", "fz_n_nom=-1"];

/// The inclination partition key's name. Stores whose samples were keyed `ia_deg_nom` (whole
/// degrees, `-1` for swept) are an older layout ([`OLD_IA_KEY`]).
pub const IA_KEY: &str = "ia_cdeg_nom";

/// The inclination key of the previous layout (rounded whole degrees, `-1` for swept).
pub const OLD_IA_KEY: &str = "ia_deg_nom";

/// The hive partition of one segment's samples.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PartitionKey {
    /// Segment kind (`cornering`, `drive_brake`, ...).
    pub test: String,
    /// Tire name as catalogued (any characters).
    pub tire: String,
    /// Rim width, whole inches (0 = unknown).
    pub rim_in: i64,
    /// Nominal inflation pressure, kPa (`None` if not held: [`HIVE_NULL`]).
    pub pressure_kpa_nom: Option<i64>,
    /// Nominal inclination angle, hundredths of a degree (`None` if swept: [`HIVE_NULL`]).
    pub ia_cdeg_nom: Option<i64>,
    /// Nominal vertical load, N (`None` if stepped or swept: [`HIVE_NULL`]).
    pub fz_n_nom: Option<i64>,
}

/// Percent-encode a hive partition value the way polars writes it (and DuckDB, pyarrow and
/// Spark decode it): control characters, `/`, `\`, `=`, `%`, `:` and space become `%XX`.
///
/// ```
/// use tirebase::store::layout::hive_encode;
/// assert_eq!(hive_encode("Hoosier 20.5x7.0-13 R25B"), "Hoosier%2020.5x7.0-13%20R25B");
/// assert_eq!(hive_encode("a/b=c%"), "a%2Fb%3Dc%25");
/// ```
pub fn hive_encode(value: &str) -> String {
    let mut out = String::with_capacity(value.len());
    for ch in value.chars() {
        let escape = ch.is_ascii_control() || matches!(ch, '/' | '\\' | '=' | '%' | ':' | ' ');
        if escape {
            out.push_str(&format!("%{:02X}", ch as u32));
        } else {
            out.push(ch);
        }
    }
    out
}

/// Relative directory of a samples partition.
///
/// ```
/// use tirebase::store::layout::{partition_dir, PartitionKey};
/// let key = PartitionKey {
///     test: "cornering".into(), tire: "Hoosier R25B".into(), rim_in: 7,
///     pressure_kpa_nom: Some(83), ia_cdeg_nom: Some(160), fz_n_nom: Some(1112),
/// };
/// assert_eq!(
///     partition_dir(&key).to_str().unwrap(),
///     "samples/test=cornering/tire=Hoosier%20R25B/rim_in=7/pressure_kpa_nom=83/ia_cdeg_nom=160/fz_n_nom=1112"
/// );
/// let swept = PartitionKey { ia_cdeg_nom: None, fz_n_nom: None, ..key };
/// assert!(partition_dir(&swept).ends_with(
///     "pressure_kpa_nom=83/ia_cdeg_nom=__HIVE_DEFAULT_PARTITION__/fz_n_nom=__HIVE_DEFAULT_PARTITION__"
/// ));
/// ```
pub fn partition_dir(key: &PartitionKey) -> PathBuf {
    let mut p = PathBuf::from(SAMPLES_DIR);
    p.push(format!("test={}", hive_encode(&key.test)));
    p.push(format!("tire={}", hive_encode(&key.tire)));
    p.push(format!("rim_in={}", key.rim_in));
    p.push(level_dir("pressure_kpa_nom", key.pressure_kpa_nom));
    p.push(level_dir(IA_KEY, key.ia_cdeg_nom));
    p.push(level_dir("fz_n_nom", key.fz_n_nom));
    p
}

/// `name=value` of an integer level, `name=`[`HIVE_NULL`] when it does not apply.
fn level_dir(name: &str, value: Option<i64>) -> String {
    match value {
        Some(v) => format!("{name}={v}"),
        None => format!("{name}={HIVE_NULL}"),
    }
}

/// File name used for everything one ingested source file contributes: the source's stem
/// (sanitised) plus the first 12 hex digits of its parts key (`store::tables::parts_sha256`).
///
/// ```
/// use tirebase::store::layout::source_part_name;
/// assert_eq!(
///     source_part_name("raw/B1320run54.dat", "0123456789abcdef0123"),
///     "B1320run54_dat-0123456789ab.parquet"
/// );
/// ```
pub fn source_part_name(source_file: &str, sha256_hex: &str) -> String {
    let base = Path::new(source_file)
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| source_file.to_string());
    let stem: String = base
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let hash = &sha256_hex[..sha256_hex.len().min(12)];
    format!("{stem}-{hash}.parquet")
}

/// Relative path of a source file's segments table.
pub fn segments_file(source_file: &str, sha256_hex: &str) -> PathBuf {
    Path::new(SEGMENTS_DIR).join(source_part_name(source_file, sha256_hex))
}

/// Relative path of the runs table.
pub fn runs_file() -> PathBuf {
    Path::new(RUNS_DIR).join(RUNS_FILE)
}

/// Directory name of published version `n`.
///
/// ```
/// use tirebase::store::layout::version_dir;
/// assert_eq!(version_dir(3).to_str().unwrap(), "versions/v000003");
/// ```
pub fn version_dir(n: u32) -> PathBuf {
    Path::new(VERSIONS_DIR).join(format!("v{n:06}"))
}

/// Parse a version directory name (`v000003` -> 3).
pub fn parse_version_dir(name: &str) -> Option<u32> {
    let digits = name.strip_prefix('v')?;
    if digits.len() == 6 && digits.bytes().all(|b| b.is_ascii_digit()) {
        digits.parse().ok()
    } else {
        None
    }
}

/// The temporary sibling a file is written to before its atomic rename: hidden (leading `.`,
/// skipped by pyarrow and Spark directory reads) and not ending in `.parquet` (skipped by
/// `*.parquet` globs).
pub fn temp_path(final_path: &Path, unique: &str) -> PathBuf {
    let name = final_path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    final_path.with_file_name(format!(".{name}.{unique}{TEMP_SUFFIX}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hive_encoding_keeps_utf8_and_escapes_separators() {
        assert_eq!(hive_encode("Pirelli Ø 10"), "Pirelli%20Ø%2010");
        assert_eq!(hive_encode("plain-name_1.0"), "plain-name_1.0");
        assert_eq!(hive_encode("a:b\tc"), "a%3Ab%09c");
    }

    #[test]
    fn version_names_round_trip() {
        for n in [1, 42, 999_999] {
            let dir = version_dir(n);
            let name = dir.file_name().unwrap().to_str().unwrap();
            assert_eq!(parse_version_dir(name), Some(n));
        }
        assert_eq!(parse_version_dir("v12"), None);
        assert_eq!(parse_version_dir("x000001"), None);
    }

    #[test]
    fn temp_names_do_not_match_parquet_globs() {
        let t = temp_path(Path::new("segments/a.parquet"), "1234");
        assert!(!t.to_str().unwrap().ends_with(".parquet"));
        assert_eq!(t.parent(), Some(Path::new("segments")));
    }
}
