//! Everything the report reads, loaded once and forgivingly.
//!
//! In: a store root (live `segments` and the `samples` of the slip tests: cornering, drive/brake,
//! combined, read through `store::tables`), the typed result tables (`store::results::Results`:
//! read from a result directory, or handed over in memory by publishing) and a `tir/`
//! directory. Out: [`ReportData`]: typed result rows, parsed models by `.tir` file name, QC-clean
//! segments with their samples decimated for plotting, and [`ReportData::notes`], one line per
//! thing that could not be read. A missing or unreadable table (one without a column the report
//! needs included) or model is a note, never an error: the pages show "no data" where it was
//! needed.
//!
//! Deliberately not here: what is plotted (pages.rs) and any fitting.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::store::StoreError;
use crate::store::columns::{req_f64, req_i64};
use crate::store::results::{Results, TirModel, read_tir_models, tir_names};
use crate::store::tables::{self, SegmentRecord};

/// Segment kinds whose samples are plotted.
pub const SLIP_KINDS: [&str; 3] = ["cornering", "drive_brake", "combined"];

/// Samples kept per segment for plotting (evenly strided).
pub const MAX_POINTS_PER_SEGMENT: usize = 100;

/// One plotted sample (SI, ISO-W).
#[derive(Clone, Copy, Debug, Default)]
pub struct PlotSample {
    /// Slip angle, rad.
    pub alpha_rad: f64,
    /// Longitudinal slip.
    pub kappa: f64,
    /// Longitudinal force, N.
    pub fx_n: f64,
    /// Lateral force, N.
    pub fy_n: f64,
    /// Vertical load, N (> 0).
    pub fz_n: f64,
    /// Aligning moment, N m.
    pub mz_nm: f64,
}

/// Peak and slope measured on a segment's full-rate samples (before decimation).
#[derive(Clone, Copy, Debug, Default)]
pub struct SegmentStats {
    /// Mean of the 5 largest |Fy|/Fz (a noise-robust peak mu), NaN if too few samples.
    pub mu_y_peak: f64,
    /// Least-squares dFy/dalpha over |alpha| < 1 deg, N/rad (ISO-W, negative), NaN if too few.
    pub cornering_stiffness_n_per_rad: f64,
}

/// A QC-clean slip-test segment with its decimated samples.
#[derive(Clone, Debug)]
pub struct PlotSegment {
    /// Its row of the segments table (cornering, drive_brake or combined).
    pub segment: SegmentRecord,
    /// Decimated samples in sample order.
    pub samples: Vec<PlotSample>,
    /// Statistics of the full-rate samples.
    pub stats: SegmentStats,
}

/// Everything loaded for one report.
#[derive(Default)]
pub struct ReportData {
    /// The result tables, typed (`None` for one not present or unreadable: a note says which).
    pub results: Results,
    /// Models (and their `USE_MODE`) by `.tir` file name.
    pub models: BTreeMap<String, TirModel>,
    /// The `.tir` file name of each (tire, rim, nominal pressure) with a model (names are unique
    /// per result set, see `naming::unique_tir_names`).
    pub tir_names: BTreeMap<(String, i64, i64), String>,
    /// Slip-test segments, sorted by (tire, rim, pressure, kind, id).
    pub segments: Vec<PlotSegment>,
    /// Tires seen anywhere (segments, tables), sorted.
    pub tires: Vec<String>,
    /// (rim, nominal pressure) groups each tire has rows for in any result table.
    pub result_groups: BTreeMap<String, BTreeSet<(i64, i64)>>,
    /// What could not be read, one line each.
    pub notes: Vec<String>,
}

/// Load the results, the models of `tir_dir` and the store; see the module doc for what
/// becomes a note.
pub fn load(
    store: &Path,
    results: &Results,
    tir_dir: &Path,
) -> Result<ReportData, super::ReportError> {
    let mut data = ReportData {
        notes: results.notes.clone(),
        ..ReportData::default()
    };
    data.tir_names = tir_names(&results.model_groups()).0;
    for (tire, rim, p) in results.groups() {
        data.result_groups.entry(tire).or_default().insert((rim, p));
    }
    data.results = results.clone();
    load_models(tir_dir, &mut data);
    load_segments(store, &mut data)?;
    let mut tires: BTreeSet<String> = data
        .segments
        .iter()
        .map(|s| s.segment.tire.clone())
        .collect();
    tires.extend(data.result_groups.keys().cloned());
    data.tires = tires.into_iter().collect();
    Ok(data)
}

fn load_models(dir: &Path, data: &mut ReportData) {
    let (models, notes) = read_tir_models(dir);
    data.models = models;
    data.notes.extend(notes);
}

/// Live, QC-clean slip-test segments with their samples.
///
/// Samples are read straight from the partition file each segment lives in (its kind, tire,
/// rim and nominal levels name the directory, its store part the file) with only the
/// numeric columns plotted, and split by the segment's sample-index range: far cheaper than a
/// hive scan with string columns, which matters because the report runs after every fit.
fn load_segments(store: &Path, data: &mut ReportData) -> Result<(), super::ReportError> {
    let records = match tables::live_segments(store) {
        Ok(r) => r,
        Err(e) => {
            data.notes.push(format!("store segments unreadable: {e}"));
            return Ok(());
        }
    };
    let mut segments = build_segments(
        records
            .into_iter()
            .filter(|r| r.qc_ok && SLIP_KINDS.contains(&r.kind.as_str())),
    );

    let mut by_file: BTreeMap<PathBuf, Vec<usize>> = BTreeMap::new();
    for (i, (_, src)) in segments.iter().enumerate() {
        by_file.entry(store.join(&src.file)).or_default().push(i);
    }
    // Plain scoped threads, not rayon: polars runs its own pool, and a rayon worker waiting on
    // it can steal further reads onto its stack (a stack overflow on a full round).
    let files: Vec<(&PathBuf, &Vec<usize>)> = by_file.iter().collect();
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, 4);
    let chunk = files.len().div_ceil(threads).max(1);
    let segments_ref = &segments;
    let results: Vec<Vec<FileResult>> = std::thread::scope(|scope| {
        let handles: Vec<_> = files
            .chunks(chunk)
            .map(|part| {
                std::thread::Builder::new()
                    .stack_size(16 << 20)
                    .spawn_scoped(scope, move || {
                        part.iter()
                            .map(|(path, members)| read_members(path, members, segments_ref))
                            .collect()
                    })
                    .expect("spawn a report reader thread")
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("report reader thread"))
            .collect()
    });
    for result in results.into_iter().flatten() {
        match result {
            Ok(members) => {
                for (i, stats, samples) in members {
                    segments[i].0.stats = stats;
                    segments[i].0.samples = samples;
                }
            }
            Err((path, e)) => data.notes.push(format!(
                "store {}: unreadable: {e}",
                path.strip_prefix(store).unwrap_or(&path).display()
            )),
        }
    }
    data.segments = segments.into_iter().map(|(s, _)| s).collect();
    Ok(())
}

/// Per member segment of one file: (index, statistics, decimated samples); or the file and why
/// it could not be read.
type FileResult = Result<Vec<(usize, SegmentStats, Vec<PlotSample>)>, (PathBuf, StoreError)>;

/// Read one partition file and cut out its member segments.
fn read_members(
    path: &Path,
    members: &[usize],
    segments: &[(PlotSegment, SampleSource)],
) -> FileResult {
    let file = read_samples(path).map_err(|e| (path.to_path_buf(), e))?;
    Ok(members
        .iter()
        .map(|&i| {
            let full = file.rows(segments[i].1.sample_range);
            (
                i,
                segment_stats(&full),
                decimate(&full, MAX_POINTS_PER_SEGMENT),
            )
        })
        .collect())
}

/// Where a segment's samples are.
struct SampleSource {
    /// Partition file, relative to the store root.
    file: PathBuf,
    /// Sample indices `[start, end)` in the raw file.
    sample_range: (i64, i64),
}

/// The plotted columns of one partition file, in file order.
struct FileSamples {
    sample_index: Vec<i64>,
    samples: Vec<PlotSample>,
}

impl FileSamples {
    /// Samples whose index lies in `[start, end)`, ordered by index.
    fn rows(&self, (start, end): (i64, i64)) -> Vec<PlotSample> {
        if self.sample_index.is_sorted() {
            let lo = self.sample_index.partition_point(|&k| k < start);
            let hi = self.sample_index.partition_point(|&k| k < end);
            return self.samples[lo..hi.max(lo)].to_vec();
        }
        let mut rows: Vec<(i64, PlotSample)> = self
            .sample_index
            .iter()
            .zip(&self.samples)
            .filter(|(k, _)| (start..end).contains(*k))
            .map(|(k, s)| (*k, *s))
            .collect();
        rows.sort_by_key(|(k, _)| *k);
        rows.into_iter().map(|(_, s)| s).collect()
    }
}

fn read_samples(path: &Path) -> Result<FileSamples, StoreError> {
    let columns = [
        "sample_index",
        "alpha_rad",
        "kappa",
        "fx_n",
        "fy_n",
        "fz_n",
        "mz_nm",
    ];
    let df = tables::read_sample_columns(path, &columns, &[], false)?;
    let sample_index: Vec<i64> = req_i64(&df, "sample_index", path)?
        .into_iter()
        .map(|v| v.unwrap_or(-1))
        .collect();
    let f = |c: &str| -> Result<Vec<f64>, StoreError> {
        Ok(req_f64(&df, c, path)?
            .into_iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    };
    let (alpha, kappa, fx, fy, fz, mz) = (
        f("alpha_rad")?,
        f("kappa")?,
        f("fx_n")?,
        f("fy_n")?,
        f("fz_n")?,
        f("mz_nm")?,
    );
    let samples = (0..df.height())
        .map(|i| PlotSample {
            alpha_rad: alpha[i],
            kappa: kappa[i],
            fx_n: fx[i],
            fy_n: fy[i],
            fz_n: fz[i],
            mz_nm: mz[i],
        })
        .collect();
    Ok(FileSamples {
        sample_index,
        samples,
    })
}

/// Segments (without samples yet) and where their samples are, sorted by
/// (tire, rim, pressure, kind, id).
fn build_segments(
    records: impl Iterator<Item = SegmentRecord>,
) -> Vec<(PlotSegment, SampleSource)> {
    let mut out: Vec<(PlotSegment, SampleSource)> = records
        .map(|r| {
            let src = SampleSource {
                file: r.samples_file(),
                sample_range: (r.sample_start, r.sample_end),
            };
            let seg = PlotSegment {
                segment: r,
                samples: Vec::new(),
                stats: SegmentStats {
                    mu_y_peak: f64::NAN,
                    cornering_stiffness_n_per_rad: f64::NAN,
                },
            };
            (seg, src)
        })
        .collect();
    out.sort_by(|(a, _), (b, _)| {
        let (a, b) = (&a.segment, &b.segment);
        (
            &a.tire,
            a.rim_in,
            a.pressure_kpa_nom,
            &a.kind,
            &a.segment_id,
        )
            .cmp(&(
                &b.tire,
                b.rim_in,
                b.pressure_kpa_nom,
                &b.kind,
                &b.segment_id,
            ))
    });
    out
}

/// Every k-th sample so that at most `max` remain (the first always kept).
pub fn decimate<T: Copy>(v: &[T], max: usize) -> Vec<T> {
    if v.len() <= max || max == 0 {
        return v.to_vec();
    }
    let stride = v.len().div_ceil(max);
    v.iter().step_by(stride).copied().collect()
}

/// Peak mu (mean of the 5 largest |Fy|/Fz with Fz > 50 N) and the small-slip cornering
/// stiffness (least squares of Fy on alpha over |alpha| < 1 deg, at least 10 samples).
fn segment_stats(samples: &[PlotSample]) -> SegmentStats {
    let mut mus: Vec<f64> = samples
        .iter()
        .filter(|s| s.fz_n > 50.0)
        .map(|s| (s.fy_n / s.fz_n).abs())
        .filter(|m| m.is_finite())
        .collect();
    let mu_y_peak = if mus.len() >= 20 {
        let k = mus.len() - 5;
        mus.select_nth_unstable_by(k, f64::total_cmp);
        mus[k..].iter().sum::<f64>() / 5.0
    } else {
        f64::NAN
    };
    let lin: Vec<(f64, f64)> = samples
        .iter()
        .filter(|s| s.alpha_rad.abs() < 1f64.to_radians() && s.fy_n.is_finite())
        .map(|s| (s.alpha_rad, s.fy_n))
        .collect();
    let cornering_stiffness_n_per_rad = if lin.len() >= 10 {
        slope(&lin)
    } else {
        f64::NAN
    };
    SegmentStats {
        mu_y_peak,
        cornering_stiffness_n_per_rad,
    }
}

/// Least-squares slope of y on x (NaN when x does not vary).
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 1e-12 { f64::NAN } else { sxy / sxx }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_first_and_bounds_the_count() {
        let v: Vec<usize> = (0..1000).collect();
        let d = decimate(&v, 160);
        assert!(d.len() <= 160 && d.len() >= 140, "{}", d.len());
        assert_eq!(d[0], 0);
        assert_eq!(decimate(&v[..10], 160).len(), 10);
    }

    #[test]
    fn stats_recover_a_linear_slope_and_peak() {
        let samples: Vec<PlotSample> = (-100..=100)
            .map(|i| {
                let a = (i as f64 * 0.1).to_radians();
                PlotSample {
                    alpha_rad: a,
                    fy_n: -30_000.0 * a,
                    fz_n: 1000.0,
                    ..Default::default()
                }
            })
            .collect();
        let s = segment_stats(&samples);
        assert!((s.cornering_stiffness_n_per_rad + 30_000.0).abs() < 1e-6);
        // The five largest |alpha| are 10, 10, 9.9, 9.9, 9.8 deg: mean 9.92 deg.
        let top = 30.0 * (9.92f64).to_radians();
        assert!((s.mu_y_peak - top).abs() < 1e-9, "{}", s.mu_y_peak);
    }
}
