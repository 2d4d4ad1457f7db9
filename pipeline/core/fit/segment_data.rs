//! What the spring-rate, thermal and relaxation stages read: segments with their samples.
//!
//! In: nothing (plain data types the command layer fills from the store's `segments` and
//! `samples` tables, `schemas/segments.toml` and `schemas/samples.toml`; tests and benches fill
//! them from a parsed run file and its segmenter output, [`MeasuredSegment::of_run`]). Out: [`MeasuredSegment`]
//! (identity, kind, nominal levels, [`Channels`]) and [`TireKey`] (the tire/rim/pressure a stage
//! groups by), plus small channel helpers every stage uses. Units and axes are the store's: SI,
//! ISO-W (`fz_n > 0` in compression, `alpha_rad` ISO-W), temperatures degC.
//!
//! Deliberately not here: reading Parquet (the `tirebase` crate), segmentation (the segmenter
//! decides `kind`), any fitting.

use std::fmt;
use std::ops::Range;

use crate::segment::Segment;
use crate::ttc::RunTable;

pub use crate::segment::{NominalLevels, SegmentKind};

/// The tire, rim and nominal pressure a stage result belongs to (a `.tir` file's identity).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TireKey {
    /// Tire name as in the store.
    pub tire: String,
    /// Rim width, whole inches (0 = unknown).
    pub rim_in: i64,
    /// Nominal inflation pressure, kPa.
    pub pressure_kpa_nom: i64,
}

impl fmt::Display for TireKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} on {} in rim at {} kPa",
            self.tire, self.rim_in, self.pressure_kpa_nom
        )
    }
}

/// The sample channels of one segment (equal lengths; a missing sample of a nullable column is
/// `NaN`, a column absent from the run is `None`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Channels {
    /// Elapsed time, s (increasing).
    pub et_s: Vec<f64>,
    /// Road speed V, km/h.
    pub speed_kph: Vec<f64>,
    /// Vertical load, N, positive in compression.
    pub fz_n: Vec<f64>,
    /// Longitudinal force, N (ISO-W).
    pub fx_n: Vec<f64>,
    /// Lateral force, N (ISO-W).
    pub fy_n: Vec<f64>,
    /// Aligning moment, N m (ISO-W).
    pub mz_nm: Vec<f64>,
    /// Slip angle, rad (ISO-W).
    pub alpha_rad: Vec<f64>,
    /// Inclination angle, rad.
    pub gamma_rad: Vec<f64>,
    /// Longitudinal slip (0 when the run has no SL channel).
    pub kappa: Vec<f64>,
    /// Inflation pressure as measured, kPa.
    pub pressure_kpa: Vec<f64>,
    /// Loaded radius RL, m.
    pub loaded_radius_m: Option<Vec<f64>>,
    /// Effective rolling radius RE, m.
    pub effective_radius_m: Option<Vec<f64>>,
    /// Wheel speed N, rpm.
    pub wheel_speed_rpm: Option<Vec<f64>>,
    /// Inner tread temperature (IR), degC.
    pub tread_inner_c: Option<Vec<f64>>,
    /// Centre tread temperature (IR), degC.
    pub tread_centre_c: Option<Vec<f64>>,
    /// Outer tread temperature (IR), degC.
    pub tread_outer_c: Option<Vec<f64>>,
    /// Ambient air temperature, degC.
    pub ambient_c: Option<Vec<f64>>,
}

impl Channels {
    /// Number of samples (the length of `et_s`).
    pub fn len(&self) -> usize {
        self.et_s.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.et_s.is_empty()
    }

    /// The first channel whose length differs from `et_s`, as `(name, length)`.
    pub fn length_mismatch(&self) -> Option<(&'static str, usize)> {
        let n = self.et_s.len();
        let required: [(&'static str, usize); 9] = [
            ("speed_kph", self.speed_kph.len()),
            ("fz_n", self.fz_n.len()),
            ("fx_n", self.fx_n.len()),
            ("fy_n", self.fy_n.len()),
            ("mz_nm", self.mz_nm.len()),
            ("alpha_rad", self.alpha_rad.len()),
            ("gamma_rad", self.gamma_rad.len()),
            ("kappa", self.kappa.len()),
            ("pressure_kpa", self.pressure_kpa.len()),
        ];
        let optional: [(&'static str, Option<usize>); 7] = [
            (
                "loaded_radius_m",
                self.loaded_radius_m.as_ref().map(Vec::len),
            ),
            (
                "effective_radius_m",
                self.effective_radius_m.as_ref().map(Vec::len),
            ),
            (
                "wheel_speed_rpm",
                self.wheel_speed_rpm.as_ref().map(Vec::len),
            ),
            ("tread_inner_c", self.tread_inner_c.as_ref().map(Vec::len)),
            ("tread_centre_c", self.tread_centre_c.as_ref().map(Vec::len)),
            ("tread_outer_c", self.tread_outer_c.as_ref().map(Vec::len)),
            ("ambient_c", self.ambient_c.as_ref().map(Vec::len)),
        ];
        required.into_iter().find(|(_, len)| *len != n).or_else(|| {
            optional
                .into_iter()
                .filter_map(|(name, len)| len.map(|l| (name, l)))
                .find(|(_, len)| *len != n)
        })
    }

    /// Road speed of sample `i`, m/s.
    pub fn speed_mps(&self, i: usize) -> f64 {
        self.speed_kph[i] / 3.6
    }
}

/// One segment of a run with its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredSegment {
    /// `segments.segment_id`.
    pub segment_id: String,
    /// What the segmenter classified it as.
    pub kind: SegmentKind,
    /// Raw file the segment comes from (a run: segments of one file share a thermal history).
    pub source_file: String,
    /// Position of the segment within its run.
    pub segment_index: i64,
    /// Tire, rim and nominal pressure.
    pub key: TireKey,
    /// Nominal levels, as in the `segments` table (pressure included: the level `key` groups
    /// by).
    pub nominal: NominalLevels,
    /// The samples.
    pub channels: Channels,
}

impl MeasuredSegment {
    /// Segment `seg` of the parsed run file `source_file` (its segmenter output), of tire `key`:
    /// `segment_id` is `<source_file>-<index>`, the samples are the run's over the segment's range.
    pub fn of_run(table: &RunTable, source_file: &str, seg: &Segment, key: TireKey) -> Self {
        MeasuredSegment {
            segment_id: format!("{source_file}-{}", seg.index),
            kind: seg.kind,
            source_file: source_file.to_string(),
            segment_index: seg.index as i64,
            key,
            nominal: seg.nominal,
            channels: Channels::of_run(table, seg.samples.clone()),
        }
    }
}

impl Channels {
    /// The channels of a parsed run file over sample range `r`.
    pub fn of_run(table: &RunTable, r: Range<usize>) -> Self {
        let cut = |v: &[f64]| v[r.clone()].to_vec();
        let opt = |v: &Option<Vec<f64>>| v.as_ref().map(|v| cut(v));
        let t = &table.tire;
        Channels {
            et_s: cut(&table.et_s),
            speed_kph: cut(&table.speed_kph),
            fz_n: cut(&t.fz_n),
            fx_n: cut(&t.fx_n),
            fy_n: cut(&t.fy_n),
            mz_nm: cut(&t.mz_nm),
            alpha_rad: cut(&t.alpha_rad),
            gamma_rad: cut(&t.gamma_rad),
            kappa: cut(&t.kappa),
            pressure_kpa: cut(&table.pressure_kpa),
            loaded_radius_m: opt(&table.loaded_radius_m),
            effective_radius_m: opt(&table.effective_radius_m),
            wheel_speed_rpm: opt(&table.wheel_speed_rpm),
            tread_inner_c: opt(&table.tread_inner_temp_c),
            tread_centre_c: opt(&table.tread_centre_temp_c),
            tread_outer_c: opt(&table.tread_outer_temp_c),
            ambient_c: opt(&table.ambient_temp_c),
        }
    }
}

/// A stage part that could not run, with the reason (failures are data).
#[derive(Clone, Debug, PartialEq)]
pub struct StageFailure {
    /// Tire, rim, nominal pressure.
    pub key: TireKey,
    /// What could not be produced (`static ia 0`, `effective radius`, ...).
    pub scope: String,
    /// Why.
    pub reason: String,
}

/// Arithmetic mean of the finite values, `None` when there is none.
pub fn finite_mean(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Median of the finite values, `None` when there is none.
pub fn finite_median(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let mut v: Vec<f64> = values.into_iter().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    })
}

/// Centred moving average over `2 half + 1` samples (shrinking at the ends); non-finite samples
/// are skipped.
pub fn moving_average(x: &[f64], half: usize) -> Vec<f64> {
    let n = x.len();
    let mut prefix = vec![(0.0, 0usize); n + 1];
    for (i, v) in x.iter().enumerate() {
        let (s, c) = prefix[i];
        prefix[i + 1] = if v.is_finite() {
            (s + v, c + 1)
        } else {
            (s, c)
        };
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half + 1).min(n);
            let (s, c) = (prefix[hi].0 - prefix[lo].0, prefix[hi].1 - prefix[lo].1);
            if c > 0 { s / c as f64 } else { f64::NAN }
        })
        .collect()
}

/// Linear interpolation of `y(t)` at `t_query` (`t` increasing); `None` outside `[t0, t_end]`.
pub fn interpolate(t: &[f64], y: &[f64], t_query: f64) -> Option<f64> {
    if t.is_empty() || !(t_query >= t[0] && t_query <= t[t.len() - 1]) {
        return None;
    }
    let j = t.partition_point(|&v| v <= t_query);
    if j == 0 {
        return Some(y[0]);
    }
    if j >= t.len() {
        return Some(y[t.len() - 1]);
    }
    let (t0, t1) = (t[j - 1], t[j]);
    let f = if t1 > t0 {
        (t_query - t0) / (t1 - t0)
    } else {
        0.0
    };
    Some(y[j - 1] + f * (y[j] - y[j - 1]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moving_average_is_exact_on_a_line_inside_and_skips_nan() {
        let x: Vec<f64> = (0..20).map(|i| 2.0 * i as f64 + 1.0).collect();
        let m = moving_average(&x, 3);
        for i in 3..17 {
            assert!((m[i] - x[i]).abs() < 1e-12);
        }
        let m = moving_average(&[1.0, f64::NAN, 3.0], 1);
        assert!((m[1] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn interpolate_inside_and_outside() {
        let t = [0.0, 1.0, 2.0];
        let y = [0.0, 10.0, 30.0];
        assert!((interpolate(&t, &y, 1.5).unwrap() - 20.0).abs() < 1e-12);
        assert!((interpolate(&t, &y, 2.0).unwrap() - 30.0).abs() < 1e-12);
        assert!(interpolate(&t, &y, 2.1).is_none());
        assert!(interpolate(&t, &y, -0.1).is_none());
    }

    #[test]
    fn median_and_mean_ignore_non_finite() {
        assert_eq!(finite_median([3.0, f64::NAN, 1.0, 2.0]), Some(2.0));
        assert_eq!(finite_mean([f64::NAN]), None);
    }
}
