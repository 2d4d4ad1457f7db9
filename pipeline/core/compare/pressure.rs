//! The pressure to run a tire at: the pressure that maximises a selection objective.
//!
//! Two sources. A round fitted per pressure (PAC2002, one model per tested pressure) only knows
//! its tested pressures: the best of them is [`best_tested`]. A model continuous in pressure
//! (MF 6.1 carries the pressure terms `PPX*`, `PPY*`, ...) implements [`PressureModel`], and
//! [`optimum`] searches the allowed range (within the model's fitted pressure range: no
//! extrapolation in pressure) for the maximum and evaluates every figure there.
//!
//! In: models or tested objective values, the car's [`Conditions`], the allowed pressure range.
//! Out: the chosen pressure with its figures. Deliberately not here: reading files.

use super::{Conditions, Figures, Objective, SteadyStateTire, evaluate, maximise};

/// A tire model continuous in inflation pressure.
pub trait PressureModel {
    /// The tire at inflation pressure `p_kpa`, kPa.
    fn at_pressure(&self, p_kpa: f64) -> Box<dyn SteadyStateTire + '_>;
    /// The pressures the model was fitted over, kPa `(lo, hi)`.
    fn pressure_range_kpa(&self) -> (f64, f64);
}

/// The pressure a continuous model is best at.
#[derive(Clone, Debug, PartialEq)]
pub struct PressureOptimum {
    /// The pressure, kPa.
    pub pressure_kpa: f64,
    /// The objective's value there.
    pub objective: f64,
    /// The maximum lies on an end of the searched range (the allowed range within the model's).
    pub at_bound: bool,
    /// Every figure at that pressure.
    pub figures: Figures,
}

/// Grid points of the pressure search before Brent.
const PRESSURE_GRID: usize = 9;

/// Search `allowed_kpa` (clipped to the model's pressure range) for the pressure maximising
/// `objective`; `None` when the two ranges do not overlap.
pub fn optimum(
    model: &dyn PressureModel,
    cond: &Conditions,
    objective: Objective,
    allowed_kpa: (f64, f64),
) -> Option<PressureOptimum> {
    let (m_lo, m_hi) = model.pressure_range_kpa();
    let lo = allowed_kpa.0.max(m_lo);
    let hi = allowed_kpa.1.min(m_hi);
    if lo.is_nan() || hi.is_nan() || lo > hi {
        return None;
    }
    let value = |p: f64| objective.value_of(model.at_pressure(p).as_ref(), cond);
    let (p, v, at_bound) = maximise(&value, lo, hi, PRESSURE_GRID);
    Some(PressureOptimum {
        pressure_kpa: p,
        objective: v,
        at_bound,
        figures: evaluate(model.at_pressure(p).as_ref(), cond),
    })
}

/// Index of the best of the tested `(pressure_kpa, objective)` pairs inside `allowed_kpa`
/// (the lowest pressure among equal values); `None` when none is allowed and finite.
pub fn best_tested(tested: &[(f64, f64)], allowed_kpa: (f64, f64)) -> Option<usize> {
    tested
        .iter()
        .enumerate()
        .filter(|(_, (p, v))| v.is_finite() && (allowed_kpa.0..=allowed_kpa.1).contains(p))
        .max_by(|(_, a), (_, b)| a.1.total_cmp(&b.1).then(b.0.total_cmp(&a.0)))
        .map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::Pac2002Tire;
    use crate::synth::tires::{KPA_PER_PSI, base_coefs, truth_model};
    use crate::tire_model::{Coef, Pac2002};

    fn cond() -> Conditions {
        Conditions {
            loads_n: vec![400.0, 800.0, 1100.0],
            nominal_load_n: 800.0,
            speed_mps: 11.0,
            camber_rad: (0.0, 3f64.to_radians()),
        }
    }

    /// The virtual machine's truth is continuous in pressure (MF 6.1 pressure terms folded into
    /// PAC2002 coefficients): a stand-in for a fitted MF 6.1 model.
    struct TruthFamily;

    impl PressureModel for TruthFamily {
        fn at_pressure(&self, p_kpa: f64) -> Box<dyn SteadyStateTire + '_> {
            let t = truth_model(&base_coefs().unwrap(), 1, 7.0, p_kpa / KPA_PER_PSI);
            Box::new(Pac2002Tire::new(&t.model, Some(14), 2000.0))
        }
        fn pressure_range_kpa(&self) -> (f64, f64) {
            (8.0 * KPA_PER_PSI, 14.0 * KPA_PER_PSI)
        }
    }

    /// Grip peaking at a known pressure: PDY1/PDY2 scaled by `1 - 0.3 ((p - p0)/p0)^2`.
    struct PeakedAt(f64);

    impl PressureModel for PeakedAt {
        fn at_pressure(&self, p_kpa: f64) -> Box<dyn SteadyStateTire + '_> {
            let mut c = base_coefs().unwrap();
            let s = 1.0 - 0.3 * ((p_kpa - self.0) / self.0).powi(2);
            c[Coef::PDY1] *= s;
            c[Coef::PDY2] *= s;
            Box::new(Pac2002Tire::new(&Pac2002::new(c), Some(14), 2000.0))
        }
        fn pressure_range_kpa(&self) -> (f64, f64) {
            (50.0, 110.0)
        }
    }

    #[test]
    fn an_interior_optimum_is_found() {
        let o = optimum(&PeakedAt(76.0), &cond(), Objective::Lateral, (40.0, 120.0)).unwrap();
        assert!((o.pressure_kpa - 76.0).abs() < 0.05, "{}", o.pressure_kpa);
        assert!(!o.at_bound);
        assert!((o.figures.lateral_mu - o.objective).abs() < 1e-12);
    }

    #[test]
    fn the_truth_loses_grip_with_pressure_so_the_lowest_allowed_wins() {
        // Lateral grip falls with pressure over 8-14 psi (PPY3 < 0): the optimum is the lowest
        // pressure allowed, flagged as a bound, and never below the model's range.
        let o = optimum(&TruthFamily, &cond(), Objective::Lateral, (60.0, 100.0)).unwrap();
        assert!((o.pressure_kpa - 60.0).abs() < 0.01, "{}", o.pressure_kpa);
        assert!(o.at_bound);
        let o = optimum(&TruthFamily, &cond(), Objective::Lateral, (20.0, 100.0)).unwrap();
        assert!((o.pressure_kpa - 8.0 * KPA_PER_PSI).abs() < 0.01);
        assert!(optimum(&TruthFamily, &cond(), Objective::Lateral, (120.0, 130.0)).is_none());
    }

    #[test]
    fn best_tested_respects_the_allowed_range() {
        let tested = [(55.0, 2.5), (69.0, 2.6), (83.0, 2.55), (97.0, 2.7)];
        assert_eq!(best_tested(&tested, (50.0, 90.0)), Some(1));
        assert_eq!(best_tested(&tested, (50.0, 100.0)), Some(3));
        assert_eq!(best_tested(&tested, (100.0, 110.0)), None);
        assert_eq!(
            best_tested(&[(69.0, 2.0), (55.0, 2.0)], (0.0, 100.0)),
            Some(1)
        );
    }
}
