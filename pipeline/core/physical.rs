//! Physical ranges of the quantities tirebase reads from a run and writes into its tables and
//! `.tir` files, for the tires a flat-track rig tests (10 to 18 in wheels, 8 to 16 psi in the
//! consortium's rounds, car tires up to ~60 psi): a value outside is a unit error or a broken
//! channel, never a tire.
//!
//! Used by the unit cross-checks (`ttc::check`), segment QC (`out_of_range:pressure_kpa`) and the
//! spring-rate and PAC2002 stages (a radius or stiffness outside its range is a stage failure,
//! not a row). Deliberately wide: the checks that know more (the kinematic radius, a tire's
//! size) are tighter where they apply.

/// Tire radius (unloaded, loaded or effective), m: a 16 in tire under load down to a 48 in one.
/// A radius in inches read as cm lands below (0.08-0.13 m for 16-26 in tires).
pub const RADIUS_M: (f64, f64) = (0.15, 0.6);
/// Vertical stiffness, N/m.
pub const VERTICAL_STIFFNESS_N_PER_M: (f64, f64) = (2.0e4, 2.0e6);
/// Inflation pressure, kPa.
pub const PRESSURE_KPA: (f64, f64) = (20.0, 400.0);

/// True when `value` is finite and within `range` (inclusive).
pub fn within(value: f64, range: (f64, f64)) -> bool {
    value.is_finite() && (range.0..=range.1).contains(&value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_hold_the_tires_and_not_the_unit_errors() {
        // A 16x7.5-10 tire's radius, in m; the same read as cm (the 0.031 m), or as in.
        assert!(within(0.26, RADIUS_M));
        assert!(!within(0.031, RADIUS_M));
        assert!(!within(0.26 * 0.01 / 0.0254, RADIUS_M));
        assert!(!within(0.26 / 0.0254, RADIUS_M));
        assert!(within(1.2e5, VERTICAL_STIFFNESS_N_PER_M));
        assert!(!within(f64::NAN, VERTICAL_STIFFNESS_N_PER_M));
        // 12 psi, and 12 psi read as kPa.
        assert!(within(82.7, PRESSURE_KPA));
        assert!(!within(12.0, PRESSURE_KPA));
    }
}
