//! Reading what the fitting stages need from the store: the live segments table and, per group,
//! the samples of the chosen segments.
//!
//! In: a store root (`runs/runs.parquet`, `segments/*.parquet`, hive-partitioned `samples/`).
//! Out: [`SegmentRow`]s (one per live segment: identity, kind, nominal levels, QC) and
//! [`LoadedSegment`]s (a [`MeasuredSegment`] with its samples in time order, plus `Mx`, which
//! the stage data type does not carry). "Live" is what the runs table has committed
//! (`store::tables`, the same rule as `query` and the report): rows of a crashed or superseded
//! ingest are never read. A segment's samples are read from the one partition file its (kind,
//! tire, rim, nominal levels, part) names, so a group reads only its own files.
//!
//! Deliberately not here: choosing which segments a stage uses (`fit::group`), any fitting.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use polars::prelude::*;
use tirebase_core::fit::segment_data::{
    Channels, MeasuredSegment, NominalLevels, SegmentKind, TireKey,
};
use tirebase_core::segment::{Level, QcFlag};

use super::FitError;
use crate::store::columns::{opt_bool, req_bool, req_f64, req_i64, req_str};
use crate::store::tables;

/// One live row of the segments table (`schemas/segments.toml`).
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentRow {
    /// Name of the store part the row was read from (it names everything the segment was
    /// derived from: content, tire, rim, segmentation settings, tool).
    pub part: String,
    /// The samples file holding the segment's rows, relative to the store root.
    pub samples_file: PathBuf,
    /// `segment_id`.
    pub segment_id: String,
    /// Raw file name.
    pub source_file: String,
    /// Content hash of the raw file.
    pub source_sha256: String,
    /// Position in its run.
    pub segment_index: i64,
    /// Segment kind (rows with a kind this build does not know are skipped).
    pub kind: SegmentKind,
    /// Tire, rim, nominal pressure.
    pub key: TireKey,
    /// Nominal levels.
    pub nominal: NominalLevels,
    /// Measured mean road speed, km/h (NaN when unknown).
    pub speed_kph_mean: f64,
    /// `qc_flags` as stored (comma separated, empty when clean).
    pub qc_flags: String,
    /// No QC flag spoils the force and slip channels ([`QcFlag::spoils_forces`]).
    pub forces_ok: bool,
    /// No QC flag concerns a tread-temperature channel either.
    pub temperatures_ok: bool,
}

/// A segment with its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedSegment {
    /// The stage view (identity, kind, nominal levels, channels).
    pub segment: MeasuredSegment,
    /// Overturning moment, N m (ISO-W), one per sample.
    pub mx_nm: Vec<f64>,
    /// The run recorded a longitudinal slip channel.
    pub kappa_measured: bool,
    /// The run had no SL channel but swept its slip ratio: `kappa` was derived from N and V.
    /// (Neither flag: `kappa` is 0 throughout.)
    pub kappa_derived: bool,
    /// The segments-table row it was loaded for.
    pub row: SegmentRow,
}

/// Parse one stored QC flag (the `Display` spelling of [`QcFlag`]); `None` for a spelling this
/// build does not know.
pub fn parse_qc_flag(text: &str) -> Option<QcFlag> {
    let level = |s: &str| {
        [
            Level::Pressure,
            Level::Inclination,
            Level::Load,
            Level::SlipAngle,
            Level::Speed,
        ]
        .into_iter()
        .find(|l| l.as_str() == s)
    };
    Some(match text.split_once(':') {
        None => match text {
            "zero_pressure" => QcFlag::ZeroPressure,
            "non_monotonic_et" => QcFlag::NonMonotonicEt,
            "duplicated_et" => QcFlag::DuplicatedEt,
            "too_short" => QcFlag::TooShort,
            "load_drift" => QcFlag::LoadDrift,
            _ => return None,
        },
        Some(("zeroed_channel", c)) => QcFlag::ZeroedChannel(c.to_string()),
        Some(("saturated_channel", c)) => QcFlag::SaturatedChannel(c.to_string()),
        Some(("off_nominal", l)) => QcFlag::OffNominal(level(l)?),
        Some(("out_of_range", c)) => QcFlag::OutOfRange(c.to_string()),
        Some(_) => return None,
    })
}

/// `(forces_ok, temperatures_ok)` of a stored `qc_flags` value. An unknown flag counts as
/// spoiling both (a flag nobody can interpret is not evidence that the data are fine).
pub fn judge_qc(qc_flags: &str) -> (bool, bool) {
    let mut forces_ok = true;
    let mut temperatures_ok = true;
    for text in qc_flags.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        match parse_qc_flag(text) {
            Some(flag) => {
                if flag.spoils_forces() {
                    forces_ok = false;
                    temperatures_ok = false;
                }
                if let QcFlag::ZeroedChannel(c) | QcFlag::SaturatedChannel(c) = &flag
                    && c.starts_with("tread")
                {
                    temperatures_ok = false;
                }
            }
            None => {
                forces_ok = false;
                temperatures_ok = false;
            }
        }
    }
    (forces_ok, temperatures_ok)
}

/// Every live segment of the store (`store::tables` says what is live), sorted by (tire, rim,
/// pressure, source file, index). Rows of a kind this build does not know are skipped, and rows
/// without a held pressure (no tire/rim/pressure group fits them).
pub fn live_segments(store: &Path) -> Result<Vec<SegmentRow>, FitError> {
    if !tables::has_runs(store) {
        return Err(FitError::NotAStore(store.display().to_string()));
    }
    let mut rows: Vec<SegmentRow> = tables::live_segments(store)?
        .into_iter()
        .filter_map(|r| {
            let kind = SegmentKind::parse(&r.kind)?;
            let (forces_ok, temperatures_ok) = judge_qc(&r.qc_flags);
            Some(SegmentRow {
                samples_file: r.samples_file(),
                part: r.part,
                segment_id: r.segment_id,
                source_file: r.source_file,
                source_sha256: r.source_sha256,
                segment_index: r.segment_index,
                kind,
                key: TireKey {
                    tire: r.tire,
                    rim_in: r.rim_in,
                    pressure_kpa_nom: r.pressure_kpa_nom?,
                },
                nominal: NominalLevels {
                    pressure_kpa: r.pressure_kpa_nom,
                    ia_cdeg: r.ia_cdeg_nom,
                    fz_n: r.fz_n_nom,
                    alpha_deg: r.alpha_deg_nom,
                    speed_kph: r.speed_kph_nom,
                },
                speed_kph_mean: r.speed_kph_mean,
                qc_flags: r.qc_flags,
                forces_ok,
                temperatures_ok,
            })
        })
        .collect();
    rows.sort_by(|a, b| {
        (&a.key, &a.source_file, a.segment_index).cmp(&(&b.key, &b.source_file, b.segment_index))
    });
    Ok(rows)
}

/// The samples file holding a segment's rows.
fn samples_file(store: &Path, row: &SegmentRow) -> PathBuf {
    store.join(&row.samples_file)
}

/// Load the samples of `rows` (any order); the result follows the order of `rows`.
pub fn load_segments(store: &Path, rows: &[&SegmentRow]) -> Result<Vec<LoadedSegment>, FitError> {
    let mut by_file: BTreeMap<PathBuf, Vec<usize>> = BTreeMap::new();
    for (k, row) in rows.iter().enumerate() {
        by_file.entry(samples_file(store, row)).or_default().push(k);
    }
    let mut out: Vec<Option<LoadedSegment>> = vec![None; rows.len()];
    for (path, wanted) in &by_file {
        if !path.exists() {
            return Err(FitError::MissingSamples {
                path: path.clone(),
                segment: rows[wanted[0]].segment_id.clone(),
            });
        }
        let df = read_sample_columns(path)?;
        let file = SampleColumns::read(&df, path)?;
        for &k in wanted {
            out[k] = Some(file.segment(rows[k], path)?);
        }
    }
    Ok(out.into_iter().flatten().collect())
}

/// Read the columns the stages use from one samples file.
fn read_sample_columns(path: &Path) -> Result<DataFrame, FitError> {
    let columns: Vec<&str> = ["segment_id", "sample_index", "kappa_measured"]
        .into_iter()
        .chain(REQUIRED)
        .chain(OPTIONAL)
        .collect();
    // Stores written before `kappa_derived` existed lack the column (read as false).
    Ok(tables::read_sample_columns(
        path,
        &columns,
        &["kappa_derived"],
        true,
    )?)
}

/// The columns of one samples file.
struct SampleColumns {
    /// Row indices of each segment, in file order.
    rows_of: BTreeMap<String, Vec<usize>>,
    sample_index: Vec<Option<i64>>,
    kappa_measured: Vec<Option<bool>>,
    kappa_derived: Vec<Option<bool>>,
    required: BTreeMap<&'static str, Vec<Option<f64>>>,
    optional: BTreeMap<&'static str, Vec<Option<f64>>>,
}

const REQUIRED: [&str; 11] = [
    "et_s",
    "speed_kph",
    "fz_n",
    "fx_n",
    "fy_n",
    "mz_nm",
    "mx_nm",
    "alpha_rad",
    "gamma_rad",
    "kappa",
    "pressure_kpa",
];
const OPTIONAL: [&str; 7] = [
    "loaded_radius_m",
    "effective_radius_m",
    "wheel_speed_rpm",
    "tread_inner_c",
    "tread_centre_c",
    "tread_outer_c",
    "ambient_c",
];

impl SampleColumns {
    fn read(df: &DataFrame, path: &Path) -> Result<SampleColumns, FitError> {
        let mut required = BTreeMap::new();
        for name in REQUIRED {
            required.insert(name, req_f64(df, name, path)?);
        }
        let mut optional = BTreeMap::new();
        for name in OPTIONAL {
            optional.insert(name, req_f64(df, name, path)?);
        }
        let mut rows_of: BTreeMap<String, Vec<usize>> = BTreeMap::new();
        for (i, id) in req_str(df, "segment_id", path)?.into_iter().enumerate() {
            rows_of.entry(id.unwrap_or_default()).or_default().push(i);
        }
        Ok(SampleColumns {
            rows_of,
            sample_index: req_i64(df, "sample_index", path)?,
            kappa_measured: req_bool(df, "kappa_measured", path)?,
            kappa_derived: opt_bool(df, "kappa_derived", path)?
                .unwrap_or_else(|| vec![None; df.height()]),
            required,
            optional,
        })
    }

    /// The rows of one segment, in sample order.
    fn segment(&self, row: &SegmentRow, path: &Path) -> Result<LoadedSegment, FitError> {
        let mut idx = self
            .rows_of
            .get(&row.segment_id)
            .cloned()
            .unwrap_or_default();
        if idx.is_empty() {
            return Err(FitError::MissingSamples {
                path: path.to_path_buf(),
                segment: row.segment_id.clone(),
            });
        }
        idx.sort_by_key(|&i| self.sample_index[i].unwrap_or(i64::MAX));
        let req = |name: &str| -> Vec<f64> {
            let c = &self.required[name];
            idx.iter().map(|&i| c[i].unwrap_or(f64::NAN)).collect()
        };
        let opt = |name: &str| -> Option<Vec<f64>> {
            let c = &self.optional[name];
            idx.iter()
                .any(|&i| c[i].is_some())
                .then(|| idx.iter().map(|&i| c[i].unwrap_or(f64::NAN)).collect())
        };
        let channels = Channels {
            et_s: req("et_s"),
            speed_kph: req("speed_kph"),
            fz_n: req("fz_n"),
            fx_n: req("fx_n"),
            fy_n: req("fy_n"),
            mz_nm: req("mz_nm"),
            alpha_rad: req("alpha_rad"),
            gamma_rad: req("gamma_rad"),
            kappa: req("kappa"),
            pressure_kpa: req("pressure_kpa"),
            loaded_radius_m: opt("loaded_radius_m"),
            effective_radius_m: opt("effective_radius_m"),
            wheel_speed_rpm: opt("wheel_speed_rpm"),
            tread_inner_c: opt("tread_inner_c"),
            tread_centre_c: opt("tread_centre_c"),
            tread_outer_c: opt("tread_outer_c"),
            ambient_c: opt("ambient_c"),
        };
        Ok(LoadedSegment {
            segment: MeasuredSegment {
                segment_id: row.segment_id.clone(),
                kind: row.kind,
                source_file: row.source_file.clone(),
                segment_index: row.segment_index,
                key: row.key.clone(),
                nominal: row.nominal,
                channels,
            },
            mx_nm: req("mx_nm"),
            kappa_measured: idx.iter().all(|&i| self.kappa_measured[i].unwrap_or(false)),
            kappa_derived: idx.iter().all(|&i| self.kappa_derived[i].unwrap_or(false)),
            row: row.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qc_flags_round_trip_and_judgement() {
        for flag in [
            QcFlag::ZeroPressure,
            QcFlag::ZeroedChannel("fy_n".into()),
            QcFlag::NonMonotonicEt,
            QcFlag::DuplicatedEt,
            QcFlag::TooShort,
            QcFlag::LoadDrift,
            QcFlag::SaturatedChannel("tread_centre_c".into()),
            QcFlag::OffNominal(Level::SlipAngle),
            QcFlag::OutOfRange("pressure_kpa".into()),
        ] {
            assert_eq!(parse_qc_flag(&flag.to_string()), Some(flag));
        }
        assert_eq!(judge_qc(""), (true, true));
        assert_eq!(judge_qc("off_nominal:ia"), (true, true));
        assert_eq!(judge_qc("saturated_channel:tread_outer_c"), (true, false));
        assert_eq!(judge_qc("off_nominal:fz,load_drift"), (true, true));
        assert_eq!(judge_qc("too_short,zero_pressure"), (false, false));
        assert_eq!(judge_qc("something_new"), (false, false));
        assert_eq!(judge_qc("out_of_range:pressure_kpa"), (false, false));
    }
}
