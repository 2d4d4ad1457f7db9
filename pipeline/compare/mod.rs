//! Tire selection across a round (or several): every fitted tire, rim and pressure evaluated at
//! the car's conditions, ranked by a stated objective without hiding ties.
//!
//! In: one or more rounds' results ([`round::RoundResults`]: a published version's tables and
//! `.tir` models), a [`car::Car`], an [`Objective`] and tire-name patterns. Out: a [`Comparison`]
//! (one [`CompareRow`] per round, tire, rim and allowed tested pressure, with its figures from
//! `tirebase_core::compare`, the thermal window, the objective's error, rank and ties, the best
//! pressure, the cross-round spread) and the `compare` table of `schemas/compare.toml`.
//!
//! Uncertainty: an objective's error is the fit's own relative error ([`round::fit_error`])
//! times the value. Two rows are tied when their difference is within the uncertainty of that
//! difference, `sqrt(e_i^2 + e_j^2)`; rows of different rounds add the round-to-round spread
//! (the largest spread of a tire, rim and pressure tested in several rounds; unknown when no
//! tire is shared, which makes every cross-round pair a tie). Pressure: the best tested
//! pressure of each tire and rim (and those tied with it) is flagged; a model continuous in
//! pressure (MF 6.1) will search the allowed range instead (`tirebase_core::compare::pressure`).
//!
//! Deliberately not here: reading command lines, printing, the report's charts.

pub mod car;
pub mod round;
pub mod table;

use std::collections::BTreeMap;

use car::Car;
use rayon::prelude::*;
use round::{FitUncertainty, GroupKey, RoundResults, ThermalWindow, TirModel};
use tirebase_core::compare::rank::{difference_tolerance, rank};
use tirebase_core::compare::{self as figures_of, Figures, Objective, Pac2002Tire};

/// Which tires to keep: case-insensitive; a pattern with `*` or `?` matches the whole name as
/// a glob, any other pattern is a substring. No pattern keeps every tire.
#[derive(Clone, Debug, Default)]
pub struct TireFilter {
    patterns: Vec<String>,
}

impl TireFilter {
    /// A filter of `patterns` (any matching one keeps a tire).
    pub fn new(patterns: &[String]) -> TireFilter {
        TireFilter {
            patterns: patterns.iter().map(|p| p.to_lowercase()).collect(),
        }
    }

    /// Does `tire` pass?
    ///
    /// ```
    /// use tirebase::compare::TireFilter;
    /// let f = TireFilter::new(&["hoosier*r25b".into(), "lco".into()]);
    /// assert!(f.matches("Hoosier 16.0x7.5-10 R25B"));
    /// assert!(f.matches("Hoosier 18.0x7.5-10 LCO"));
    /// assert!(!f.matches("Avon 7.0/20.0-13 A45"));
    /// assert!(TireFilter::new(&[]).matches("anything"));
    /// ```
    pub fn matches(&self, tire: &str) -> bool {
        let name = tire.to_lowercase();
        self.patterns.is_empty()
            || self.patterns.iter().any(|p| {
                if p.contains(['*', '?']) {
                    glob(p.as_bytes(), name.as_bytes())
                } else {
                    name.contains(p.as_str())
                }
            })
    }
}

/// `*` (any run) and `?` (any one byte) glob match of the whole text.
fn glob(p: &[u8], t: &[u8]) -> bool {
    match (p.first(), t.first()) {
        (None, None) => true,
        (Some(b'*'), _) => glob(&p[1..], t) || (!t.is_empty() && glob(p, &t[1..])),
        (Some(b'?'), Some(_)) => glob(&p[1..], &t[1..]),
        (Some(a), Some(b)) if a == b => glob(&p[1..], &t[1..]),
        _ => false,
    }
}

/// One round, tire, rim and tested pressure.
#[derive(Clone, Debug)]
pub struct CompareRow {
    /// The round's label.
    pub round: String,
    /// Tire name.
    pub tire: String,
    /// Rim width, in.
    pub rim_in: i64,
    /// Nominal pressure, kPa.
    pub pressure_kpa: i64,
    /// The figures at the car's conditions.
    pub figures: Figures,
    /// The measured thermal window.
    pub thermal: ThermalWindow,
    /// The objective's value.
    pub objective: f64,
    /// Its standard error (NaN when unknown).
    pub objective_error: f64,
    /// Where the error comes from.
    pub error_source: String,
    /// `1 +` the rows better beyond doubt; None when the objective is unknown.
    pub rank: Option<usize>,
    /// Indices (into [`Comparison::rows`]) of the rows tied with this one.
    pub tied_with: Vec<usize>,
    /// Best tested pressure of its round, tire and rim (or tied with it).
    pub best_pressure: bool,
    /// Rounds holding this tire, rim and pressure.
    pub rounds_tested: usize,
    /// Spread of the objective over those rounds (None: one round).
    pub objective_spread: Option<f64>,
}

impl CompareRow {
    /// `tire rim in/pressure kPa`, plus ` [round]` when `with_round`.
    pub fn label(&self, with_round: bool) -> String {
        let base = format!("{} {}in/{}kPa", self.tire, self.rim_in, self.pressure_kpa);
        if with_round {
            format!("{base} [{}]", self.round)
        } else {
            base
        }
    }
}

/// A whole comparison.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Rows in rank order (then objective, round, tire, rim, pressure).
    pub rows: Vec<CompareRow>,
    /// The objective ranked.
    pub objective: Objective,
    /// The car.
    pub car: Car,
    /// Round labels in input order.
    pub rounds: Vec<String>,
    /// The round-to-round spread used for cross-round pairs (None: one round, or unknown).
    pub cross_round_spread: Option<f64>,
    /// What was left out or could not be read, one line each.
    pub notes: Vec<String>,
}

impl Comparison {
    /// More than one round?
    pub fn cross_round(&self) -> bool {
        self.rounds.len() > 1
    }
}

/// The fit_quality channels behind each objective.
fn error_channels(objective: Objective) -> &'static [&'static str] {
    match objective {
        Objective::Lateral => &["Fy0"],
        Objective::Longitudinal => &["Fx0"],
        Objective::Envelope => &["Fx", "Fy"],
    }
}

/// The column a ranking ranks.
pub fn objective_column(objective: Objective) -> &'static str {
    match objective {
        Objective::Lateral => "lateral_mu",
        Objective::Longitudinal => "longitudinal_mu",
        Objective::Envelope => "envelope_area_kn2",
    }
}

/// The objective in its column's unit (the envelope area in kN^2).
fn objective_value(objective: Objective, figures: &Figures) -> f64 {
    match objective {
        Objective::Envelope => objective.of(figures) * 1e-6,
        _ => objective.of(figures),
    }
}

/// A group to evaluate.
struct Candidate<'a> {
    round: &'a RoundResults,
    key: GroupKey,
    model: &'a TirModel,
}

/// Evaluate and rank every allowed group of `rounds` for `car`.
pub fn compare(
    rounds: &[RoundResults],
    car: &Car,
    objective: Objective,
    filter: &TireFilter,
) -> Comparison {
    let mut notes: Vec<String> = rounds.iter().flat_map(|r| r.notes.clone()).collect();
    let (lo, hi) = car.pressure_kpa;
    let mut candidates = Vec::new();
    let mut outside = 0;
    for r in rounds {
        for key in r.groups() {
            if !filter.matches(&key.0) {
                continue;
            }
            if !((lo..=hi).contains(&(key.2 as f64))) {
                outside += 1;
                continue;
            }
            match r.model(&key) {
                Ok(model) => candidates.push(Candidate {
                    round: r,
                    key,
                    model,
                }),
                Err(missing) => notes.push(format!(
                    "{}: {} {} in {} kPa: {missing}, left out",
                    r.label, key.0, key.1, key.2
                )),
            }
        }
    }
    if outside > 0 {
        notes.push(format!(
            "{outside} tested groups outside the car's pressures {lo:.0}..{hi:.0} kPa left out"
        ));
    }
    let max_load = car
        .conditions
        .loads_n
        .iter()
        .copied()
        .fold(car.conditions.nominal_load_n, f64::max);
    let mut rows: Vec<CompareRow> = candidates
        .par_iter()
        .map(|c| {
            let tire = Pac2002Tire::new(&c.model.model, c.model.use_mode, max_load);
            let figures = figures_of::evaluate(&tire, &car.conditions);
            let FitUncertainty { relative, source } =
                round::fit_error(&c.round.results, &c.key, error_channels(objective));
            let value = objective_value(objective, &figures);
            CompareRow {
                round: c.round.label.clone(),
                tire: c.key.0.clone(),
                rim_in: c.key.1,
                pressure_kpa: c.key.2,
                thermal: round::thermal_window(&c.round.results, &c.key),
                objective: value,
                objective_error: value.abs() * relative,
                error_source: source,
                figures,
                rank: None,
                tied_with: Vec::new(),
                best_pressure: false,
                rounds_tested: 1,
                objective_spread: None,
            }
        })
        .collect();
    let cross_round_spread = cross_round(&mut rows, rounds.len());
    rank_rows(&mut rows, cross_round_spread, rounds.len() > 1);
    flag_best_pressures(&mut rows);
    sort_rows(&mut rows);
    if rounds.len() > 1 && cross_round_spread.is_none() {
        notes.push(
            "no tire, rim and pressure is in more than one round: cross-round differences \
             cannot be judged and are shown as ties"
                .to_string(),
        );
    }
    Comparison {
        rows,
        objective,
        car: car.clone(),
        rounds: rounds.iter().map(|r| r.label.clone()).collect(),
        cross_round_spread,
        notes,
    }
}

/// Rounds per tire, rim and pressure and the objective's spread over them; returns the
/// round-to-round spread for cross-round pairs (the largest one seen).
fn cross_round(rows: &mut [CompareRow], n_rounds: usize) -> Option<f64> {
    let mut by_group: BTreeMap<(String, i64, i64), Vec<usize>> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        by_group
            .entry((r.tire.clone(), r.rim_in, r.pressure_kpa))
            .or_default()
            .push(i);
    }
    let mut largest: Option<f64> = None;
    for members in by_group.values() {
        let values: Vec<f64> = members
            .iter()
            .map(|&i| rows[i].objective)
            .filter(|v| v.is_finite())
            .collect();
        let spread = (values.len() > 1).then(|| {
            values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - values.iter().copied().fold(f64::INFINITY, f64::min)
        });
        for &i in members {
            rows[i].rounds_tested = members.len();
            rows[i].objective_spread = spread;
        }
        if let Some(s) = spread {
            largest = Some(largest.map_or(s, |l: f64| l.max(s)));
        }
    }
    if n_rounds > 1 { largest } else { None }
}

/// Rank every row; pairs from different rounds add the round-to-round spread (unknown: tie).
fn rank_rows(rows: &mut [CompareRow], spread: Option<f64>, several_rounds: bool) {
    let values: Vec<f64> = rows.iter().map(|r| r.objective).collect();
    let tolerance = |i: usize, j: usize| {
        let own = difference_tolerance(rows[i].objective_error, rows[j].objective_error);
        if several_rounds && rows[i].round != rows[j].round {
            match spread {
                Some(s) => own.hypot(s),
                None => f64::NAN,
            }
        } else {
            own
        }
    };
    let ranked = rank(&values, &tolerance);
    for (row, r) in rows.iter_mut().zip(ranked) {
        row.rank = r.rank;
        row.tied_with = r.tied_with;
    }
}

/// Flag, per round, tire and rim, the tested pressure with the best objective and the
/// pressures tied with it.
fn flag_best_pressures(rows: &mut [CompareRow]) {
    let mut groups: BTreeMap<(String, String, i64), Vec<usize>> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        groups
            .entry((r.round.clone(), r.tire.clone(), r.rim_in))
            .or_default()
            .push(i);
    }
    for members in groups.values() {
        let tested: Vec<(f64, f64)> = members
            .iter()
            .map(|&i| (rows[i].pressure_kpa as f64, rows[i].objective))
            .collect();
        let Some(best) =
            figures_of::pressure::best_tested(&tested, (f64::NEG_INFINITY, f64::INFINITY))
        else {
            continue;
        };
        let best = members[best];
        for &i in members {
            if i == best || rows[best].tied_with.contains(&i) {
                rows[i].best_pressure = true;
            }
        }
    }
}

/// Rank order (unranked last), then objective (higher first), round, tire, rim, pressure; tie
/// indices follow the rows.
fn sort_rows(rows: &mut Vec<CompareRow>) {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| {
        let (ra, rb) = (&rows[a], &rows[b]);
        ra.rank
            .unwrap_or(usize::MAX)
            .cmp(&rb.rank.unwrap_or(usize::MAX))
            .then(rb.objective.total_cmp(&ra.objective))
            .then_with(|| ra.round.cmp(&rb.round))
            .then_with(|| ra.tire.cmp(&rb.tire))
            .then(ra.rim_in.cmp(&rb.rim_in))
            .then(ra.pressure_kpa.cmp(&rb.pressure_kpa))
    });
    let mut new_index = vec![0; rows.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new;
    }
    let mut sorted: Vec<CompareRow> = order.iter().map(|&i| rows[i].clone()).collect();
    for row in &mut sorted {
        row.tied_with = row.tied_with.iter().map(|&i| new_index[i]).collect();
        row.tied_with.sort_unstable();
    }
    *rows = sorted;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::results::QualityRow;
    use tirebase_core::naming::tir_file_name;
    use tirebase_core::synth::tires::{base_coefs, truth_model};

    /// A round of the virtual machine's truth models (tires 0 and 1 on 7 in at 10 and 12 psi),
    /// with a fit_quality row per group giving the Fy0 error `pct`.
    fn truth_round(label: &str, pct: f64, mu_scale: f64) -> RoundResults {
        let base = base_coefs().unwrap();
        let mut r = RoundResults {
            label: label.to_string(),
            ..Default::default()
        };
        let (mut t, mut p, mut ch, mut e) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for tire in [0, 1] {
            for psi in [10.0, 12.0] {
                let mut m = truth_model(&base, tire, 7.0, psi);
                for k in [
                    tirebase_core::tire_model::Coef::PDY1,
                    tirebase_core::tire_model::Coef::PDY2,
                ] {
                    m.model.coefs[k] *= mu_scale;
                }
                let name = tirebase_core::synth::tires::CATALOGUE[tire]
                    .name
                    .to_string();
                let kpa = m.pressure_kpa().round() as i64;
                r.models.insert(
                    tir_file_name(&name, 7.0, kpa as f64),
                    TirModel {
                        model: m.model.clone(),
                        use_mode: Some(14),
                    },
                );
                t.push(name);
                p.push(kpa);
                ch.push("Fy0");
                e.push(pct);
            }
        }
        r.results.fit_quality = Some(quality_rows(&t, &p, &ch, &e));
        r
    }

    /// fit_quality rows of 7 in rims with only `rmse_pct_of_peak`.
    fn quality_rows(tires: &[String], p: &[i64], ch: &[&str], pct: &[f64]) -> Vec<QualityRow> {
        (0..tires.len())
            .map(|i| QualityRow::pct_of_peak_only(&tires[i], p[i], ch[i], pct[i]))
            .collect()
    }

    #[test]
    fn rows_rank_by_the_objective_and_flag_the_best_pressure() {
        let car = Car::builtin();
        let c = compare(
            &[truth_round("r1", 0.01, 1.0)],
            &car,
            Objective::Lateral,
            &TireFilter::default(),
        );
        assert_eq!(c.rows.len(), 4);
        let values: Vec<f64> = c.rows.iter().map(|r| r.objective).collect();
        assert!(values.windows(2).all(|w| w[0] >= w[1]), "{values:?}");
        assert_eq!(c.rows[0].rank, Some(1));
        // Grip falls with pressure in the truth: 69 kPa is each tire's best.
        for r in &c.rows {
            assert_eq!(r.best_pressure, r.pressure_kpa == 69, "{}", r.label(false));
            assert!((r.objective_error - r.objective * 1e-4).abs() < 1e-12);
        }
        assert!(c.rows.iter().all(|r| r.objective_spread.is_none()));
    }

    #[test]
    fn large_errors_make_ties_and_never_hide_them() {
        let car = Car::builtin();
        let c = compare(
            &[truth_round("r1", 50.0, 1.0)],
            &car,
            Objective::Lateral,
            &TireFilter::default(),
        );
        assert!(c.rows.iter().all(|r| r.rank == Some(1)));
        assert!(c.rows.iter().all(|r| r.tied_with.len() == 3));
        assert!(c.rows.iter().all(|r| r.best_pressure));
    }

    #[test]
    fn a_second_round_gives_spreads_and_cross_round_tolerances() {
        let car = Car::builtin();
        let rounds = [truth_round("r1", 0.01, 1.0), truth_round("r2", 0.01, 1.02)];
        let c = compare(&rounds, &car, Objective::Lateral, &TireFilter::default());
        assert_eq!(c.rows.len(), 8);
        assert!(c.rows.iter().all(|r| r.rounds_tested == 2));
        let spread = c.cross_round_spread.unwrap();
        for r in &c.rows {
            let s = r.objective_spread.unwrap();
            assert!((s / r.objective - 0.02).abs() < 0.005, "{s}");
            assert!(s <= spread);
        }
        // The same tire in two rounds 2 % apart is within the round-to-round spread: a tie.
        for (i, r) in c.rows.iter().enumerate() {
            let twin = c
                .rows
                .iter()
                .position(|o| o.round != r.round && o.label(false) == r.label(false))
                .unwrap();
            assert!(r.tied_with.contains(&twin), "{i}: {:?}", r.tied_with);
        }
        let only = compare(
            &rounds,
            &car,
            Objective::Lateral,
            &TireFilter::new(&["20.5".to_string()]),
        );
        assert!(only.rows.iter().all(|r| r.tire.contains("20.5")));
        assert_eq!(only.rows.len(), 4);
    }

    #[test]
    fn disjoint_rounds_cannot_be_judged_against_each_other() {
        let car = Car::builtin();
        let mut r2 = truth_round("r2", 0.01, 1.0);
        r2.results.fit_quality = Some(quality_rows(
            &["Other tire".to_string()],
            &[69],
            &["Fy0"],
            &[0.01],
        ));
        r2.models = BTreeMap::from([(
            tir_file_name("Other tire", 7.0, 69.0),
            r2.models.values().next().unwrap().clone(),
        )]);
        let c = compare(
            &[truth_round("r1", 0.01, 1.0), r2],
            &car,
            Objective::Lateral,
            &TireFilter::default(),
        );
        assert!(c.cross_round_spread.is_none());
        let other = c.rows.iter().position(|r| r.tire == "Other tire").unwrap();
        assert_eq!(c.rows[other].tied_with.len(), 4);
        assert!(c.notes.iter().any(|n| n.contains("cannot be judged")));
    }
}
