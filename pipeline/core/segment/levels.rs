//! Pass 5a, learned set-points: the measured means of one run's held stretches -> the run's own
//! nominal levels of pressure, inclination, load, speed and held slip angle.
//!
//! In: one value per detection and channel (the measured mean over a stretch that holds the
//! channel, weighted by its sample count) and the [`LevelConfig`] tolerances. Out: a
//! [`RunLevels`]: per channel, the clusters of those values and an integer label for each;
//! [`RunLevels::bin_all`] maps any measured mean to the label of the cluster it falls in.
//!
//! How: the values of one channel are sorted and split at their largest gap until every cluster
//! spans at most `2 * tol(centre)` and has no gap wider than `tol(centre)` (a divisive
//! single-link clustering: levels a test plan holds are far apart, the scatter of one level's
//! means is small). A cluster's centre is the
//! sample-weighted mean of its values. Its label is the consortium's standard level nearest the
//! centre when within the channel's label tolerance (`83.4 kPa` -> `83`, 12 psi), else the
//! centre rounded (`1092.4 N` -> `1092`, a de-identified load off every standard level). A mean
//! belongs to the cluster whose value range, widened by `tol`, holds it (the nearest one when
//! several do); a mean outside every cluster has no level.
//!
//! Deliberately not here: which detections hold which channel (the caller says), and anything
//! across runs (each run learns its own levels).

use super::config::{LevelConfig, Tolerance};
use super::output::{MeasuredLevels, NominalLevels, ia_cdeg_label};

/// 1 psi in kPa.
const KPA_PER_PSI: f64 = 6.894_757;
/// 1 lbf in N.
const N_PER_LBF: f64 = 4.448_222;
/// 1 mph in km/h.
const KPH_PER_MPH: f64 = 1.609_344;

/// The consortium's standard inflation pressures, psi: labels only.
const STANDARD_PSI: [f64; 5] = [8.0, 10.0, 12.0, 14.0, 16.0];
/// The consortium's standard loads, lbf: labels only.
const STANDARD_LB: [f64; 7] = [50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0];
/// The consortium's standard road speeds, mph: labels only.
const STANDARD_MPH: [f64; 4] = [0.0, 15.0, 25.0, 45.0];

/// One learned level of a channel.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Cluster {
    /// Sample-weighted mean of the member values.
    pub centre: f64,
    /// Smallest and largest member value.
    pub lo: f64,
    pub hi: f64,
    /// Number of member values (detections).
    pub members: usize,
    /// The integer nominal level (a standard level near the centre, else the rounded centre).
    pub label: i64,
}

/// The learned levels of one channel, sorted by centre.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct LevelSet {
    pub clusters: Vec<Cluster>,
    tol: Option<Tolerance>,
}

impl LevelSet {
    /// Cluster `values` within `tol` ([`Self::cluster`]) and label each cluster with the nearest
    /// of `standard` within `label_tol`, else its rounded centre.
    pub fn learn(
        values: &[(f64, f64)],
        tol: Tolerance,
        standard: &[f64],
        label_tol: Tolerance,
    ) -> LevelSet {
        LevelSet::cluster(values, tol).labelled_by(|centre| label(centre, standard, label_tol))
    }

    /// Cluster `values` (`(value, weight)`, non-finite values ignored) within `tol`, each cluster
    /// labelled by its rounded centre until [`Self::labelled_by`] labels it otherwise.
    pub fn cluster(values: &[(f64, f64)], tol: Tolerance) -> LevelSet {
        let mut v: Vec<(f64, f64)> = values
            .iter()
            .copied()
            .filter(|(x, w)| x.is_finite() && w.is_finite() && *w > 0.0)
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut clusters = Vec::new();
        split(&v, tol, &mut clusters);
        for c in &mut clusters {
            c.label = c.centre.round() as i64;
        }
        LevelSet {
            clusters,
            tol: Some(tol),
        }
    }

    /// The label of the cluster `value` falls in (its member range widened by `tol`), if any.
    pub fn label_of(&self, value: f64) -> Option<i64> {
        let tol = self.tol?;
        if !value.is_finite() {
            return None;
        }
        self.clusters
            .iter()
            .filter(|c| value >= c.lo - tol.at(c.centre) && value <= c.hi + tol.at(c.centre))
            .min_by(|a, b| {
                (a.centre - value)
                    .abs()
                    .total_cmp(&(b.centre - value).abs())
            })
            .map(|c| c.label)
    }

    /// The same clusters labelled by `label` of their centre (inclination: hundredths of a
    /// degree, so a level tested at 1.6 deg is not labelled 2).
    pub fn labelled_by(mut self, label: impl Fn(f64) -> i64) -> LevelSet {
        for c in &mut self.clusters {
            c.label = label(c.centre);
        }
        self
    }

    /// Labels carried by more than one cluster (levels the integer labels cannot tell apart).
    pub fn shared_labels(&self) -> Vec<(i64, Vec<f64>)> {
        let mut out: Vec<(i64, Vec<f64>)> = Vec::new();
        for c in &self.clusters {
            match out.iter_mut().find(|(l, _)| *l == c.label) {
                Some((_, centres)) => centres.push(c.centre),
                None => out.push((c.label, vec![c.centre])),
            }
        }
        out.retain(|(_, centres)| centres.len() > 1);
        out
    }
}

/// Split sorted `(value, weight)` at the largest gap until no part spans more than
/// `2 tol(centre)` or has a gap wider than `tol(centre)`.
fn split(v: &[(f64, f64)], tol: Tolerance, out: &mut Vec<Cluster>) {
    let (Some(first), Some(last)) = (v.first(), v.last()) else {
        return;
    };
    let weight: f64 = v.iter().map(|p| p.1).sum();
    let centre = v.iter().map(|p| p.0 * p.1).sum::<f64>() / weight;
    let (cut, gap) = (1..v.len())
        .map(|k| (k, v[k].0 - v[k - 1].0))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((1, 0.0));
    let one_level = last.0 - first.0 <= 2.0 * tol.at(centre) && gap <= tol.at(centre);
    if one_level || v.len() < 2 {
        out.push(Cluster {
            centre,
            lo: first.0,
            hi: last.0,
            members: v.len(),
            label: 0,
        });
        return;
    }
    split(&v[..cut], tol, out);
    split(&v[cut..], tol, out);
}

/// The nearest standard level within `label_tol` (rounded), else the rounded centre.
fn label(centre: f64, standard: &[f64], label_tol: Tolerance) -> i64 {
    standard
        .iter()
        .copied()
        .filter(|s| (s - centre).abs() <= label_tol.at(*s))
        .min_by(|a, b| (a - centre).abs().total_cmp(&(b - centre).abs()))
        .unwrap_or(centre)
        .round() as i64
}

/// One run's learned levels, every channel.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct RunLevels {
    pub pressure_kpa: LevelSet,
    pub ia_deg: LevelSet,
    pub fz_n: LevelSet,
    pub speed_kph: LevelSet,
    pub alpha_deg: LevelSet,
}

/// The values a run learns its levels from, per channel: `(measured mean, sample count)` of the
/// stretches that hold that channel.
#[derive(Clone, Debug, Default)]
pub(crate) struct HeldValues {
    pub pressure_kpa: Vec<(f64, f64)>,
    pub ia_deg: Vec<(f64, f64)>,
    pub fz_n: Vec<(f64, f64)>,
    pub speed_kph: Vec<(f64, f64)>,
    pub alpha_deg: Vec<(f64, f64)>,
}

impl RunLevels {
    /// Learn every channel's levels.
    pub fn learn(held: &HeldValues, cfg: &LevelConfig) -> RunLevels {
        let kpa: Vec<f64> = STANDARD_PSI.iter().map(|p| p * KPA_PER_PSI).collect();
        let n: Vec<f64> = STANDARD_LB.iter().map(|l| l * N_PER_LBF).collect();
        let kph: Vec<f64> = STANDARD_MPH.iter().map(|v| v * KPH_PER_MPH).collect();
        RunLevels {
            pressure_kpa: LevelSet::learn(
                &held.pressure_kpa,
                cfg.pressure_tol,
                &kpa,
                cfg.pressure_label_tol,
            ),
            ia_deg: LevelSet::cluster(&held.ia_deg, cfg.ia_tol).labelled_by(ia_cdeg_label),
            fz_n: LevelSet::learn(&held.fz_n, cfg.fz_tol, &n, cfg.fz_label_tol),
            speed_kph: LevelSet::learn(&held.speed_kph, cfg.speed_tol, &kph, cfg.speed_label_tol),
            alpha_deg: LevelSet::cluster(&held.alpha_deg, cfg.alpha_tol),
        }
    }

    /// Every level of a stretch's measured means, whether or not its kind will keep it.
    pub fn bin_all(&self, m: &MeasuredLevels) -> NominalLevels {
        NominalLevels {
            pressure_kpa: self.pressure_kpa.label_of(m.pressure_kpa.mean),
            ia_cdeg: self.ia_deg.label_of(m.ia_deg.mean),
            fz_n: self.fz_n.label_of(m.fz_n.mean),
            alpha_deg: self.alpha_deg.label_of(m.alpha_deg.mean),
            speed_kph: self.speed_kph.label_of(m.speed_kph.mean),
        }
    }

    /// One line per label shared by distinct levels (run warnings).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (name, set) in [
            ("pressure_kpa", &self.pressure_kpa),
            ("ia_deg", &self.ia_deg),
            ("fz_n", &self.fz_n),
            ("speed_kph", &self.speed_kph),
            ("alpha_deg", &self.alpha_deg),
        ] {
            for (label, centres) in set.shared_labels() {
                let shown: Vec<String> = centres.iter().map(|c| format!("{c:.2}")).collect();
                out.push(format!(
                    "levels {} of {name} share the nominal label {label}",
                    shown.join(", ")
                ));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixed(x: f64) -> Tolerance {
        Tolerance::fixed(x)
    }

    #[test]
    fn standard_levels_label_near_clusters_others_keep_their_rounded_centre() {
        let cfg = LevelConfig::default();
        let kpa: Vec<f64> = STANDARD_PSI.iter().map(|p| p * KPA_PER_PSI).collect();
        let values: Vec<(f64, f64)> = [69.6, 69.7, 83.4, 83.3, 97.2, 110.6, 75.4]
            .iter()
            .map(|v| (*v, 100.0))
            .collect();
        let set = LevelSet::learn(&values, cfg.pressure_tol, &kpa, cfg.pressure_label_tol);
        let labels: Vec<i64> = set.clusters.iter().map(|c| c.label).collect();
        assert_eq!(labels, vec![69, 75, 83, 97, 110]);
        assert_eq!(set.label_of(84.0), Some(83));
        assert_eq!(set.label_of(90.0), None, "between levels");
    }

    #[test]
    fn loads_off_the_standard_list_are_their_own_levels() {
        let cfg = LevelConfig::default();
        let n: Vec<f64> = STANDARD_LB.iter().map(|l| l * N_PER_LBF).collect();
        let values: Vec<(f64, f64)> = [
            2728.0, 2195.0, 1641.0, 522.0, 2739.0, 1082.0, 2182.0, 1655.0, 530.0, 2756.0, 1094.0,
        ]
        .iter()
        .map(|v| (*v, 1.0))
        .collect();
        let set = LevelSet::learn(&values, cfg.fz_tol, &n, cfg.fz_label_tol);
        let labels: Vec<i64> = set.clusters.iter().map(|c| c.label).collect();
        // 1088 N (a de-identified 100 lb) is within 3 % of 250 lb (1112 N): labelled so.
        assert_eq!(labels, vec![526, 1112, 1648, 2189, 2741]);
        let off = LevelSet::learn(
            &[(1070.0, 1.0), (1074.0, 1.0)],
            cfg.fz_tol,
            &n,
            cfg.fz_label_tol,
        );
        assert_eq!(
            off.clusters[0].label, 1072,
            "42 N from 250 lb: its own label"
        );
        let std = LevelSet::learn(
            &[(1110.0, 1.0), (1114.0, 1.0)],
            cfg.fz_tol,
            &n,
            cfg.fz_label_tol,
        );
        assert_eq!(std.clusters[0].label, 1112, "250 lb");
    }

    #[test]
    fn the_largest_gap_splits_first_and_shared_labels_are_reported() {
        let set = LevelSet::learn(
            &[(0.0, 1.0), (0.1, 1.0), (1.6, 1.0), (1.62, 1.0), (2.4, 1.0)],
            fixed(0.3),
            &[],
            fixed(0.25),
        );
        let centres: Vec<f64> = set.clusters.iter().map(|c| c.centre).collect();
        assert_eq!(centres.len(), 3);
        assert!((centres[1] - 1.61).abs() < 1e-9);
        assert_eq!(set.shared_labels(), vec![(2, vec![1.61, 2.4])]);
        assert!(LevelSet::default().label_of(1.0).is_none());
    }
}
