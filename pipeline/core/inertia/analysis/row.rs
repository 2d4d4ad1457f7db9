//! The closed vocabularies of the `inertia` table (axis, quantity with its unit, method) and a
//! result row built from them.
//!
//! In: what the analysis measured or combined. Out: [`Row`], which [`super::Ctx`] stamps with
//! the session id into an [`InertiaResult`] (whose columns are text, as the table stores them).
//! Each quantity has exactly one SI unit, so a row cannot pair a quantity with the wrong unit.
//! The names are the table's values (`schemas/inertia.toml`); changing one changes the table.

use crate::inertia::InertiaResult;
use crate::inertia::session::{FrictionMethod, PendulumAxis};

/// Inertia axis of a result (for CG rows the pendulum axis of the test).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Axis {
    Yaw,
    Pitch,
    Roll,
}

impl Axis {
    fn name(self) -> &'static str {
        match self {
            Axis::Yaw => "yaw",
            Axis::Pitch => "pitch",
            Axis::Roll => "roll",
        }
    }
}

impl From<PendulumAxis> for Axis {
    fn from(axis: PendulumAxis) -> Self {
        match axis {
            PendulumAxis::Pitch => Axis::Pitch,
            PendulumAxis::Roll => Axis::Roll,
        }
    }
}

/// What a row measures; each has one unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Quantity {
    /// Yaw drop: acceleration at zero speed (rad/s^2).
    AngularAcceleration,
    /// Swing: small-amplitude natural period (s).
    PeriodNatural,
    /// Static tilt: first moment along the platform x axis (kg m).
    FirstMomentX,
    /// Static tilt: first moment along the platform y axis (kg m).
    FirstMomentY,
    /// Static tilt: inclinometer zero offset (rad).
    InclinometerOffset,
    /// Inertia about the rig axis (kg m^2).
    Inertia,
    /// Multi-mass: table plus load (kg m^2).
    RotatingInertia,
    /// Yaw table bearing friction (N m).
    FrictionTorque,
    /// The thesis's multiplicative factor (dimensionless).
    CalibrationFactor,
    /// `ln cosh` drag coefficient times the rotating inertia (N m s^2).
    AeroDragCoefficient,
    /// Pendulum platform inertia about the pivot (kg m^2).
    InertiaPivot,
    /// Vehicle inertia about its CG (kg m^2).
    InertiaCg,
    /// CG height above the deck (m).
    CgHeight,
    /// CG offset along the platform x axis (m).
    CgOffsetX,
}

impl Quantity {
    fn name(self) -> &'static str {
        match self {
            Quantity::AngularAcceleration => "angular_acceleration",
            Quantity::PeriodNatural => "period_natural",
            Quantity::FirstMomentX => "first_moment_x",
            Quantity::FirstMomentY => "first_moment_y",
            Quantity::InclinometerOffset => "inclinometer_offset",
            Quantity::Inertia => "inertia",
            Quantity::RotatingInertia => "rotating_inertia",
            Quantity::FrictionTorque => "friction_torque",
            Quantity::CalibrationFactor => "calibration_factor",
            Quantity::AeroDragCoefficient => "aero_drag_coefficient",
            Quantity::InertiaPivot => "inertia_pivot",
            Quantity::InertiaCg => "inertia_cg",
            Quantity::CgHeight => "cg_height",
            Quantity::CgOffsetX => "cg_offset_x",
        }
    }

    fn units(self) -> &'static str {
        match self {
            Quantity::AngularAcceleration => "rad/s^2",
            Quantity::PeriodNatural => "s",
            Quantity::FirstMomentX | Quantity::FirstMomentY => "kg*m",
            Quantity::InclinometerOffset => "rad",
            Quantity::Inertia
            | Quantity::RotatingInertia
            | Quantity::InertiaPivot
            | Quantity::InertiaCg => "kg*m^2",
            Quantity::FrictionTorque => "N*m",
            Quantity::CalibrationFactor => "1",
            Quantity::AeroDragCoefficient => "N*m*s^2",
            Quantity::CgHeight | Quantity::CgOffsetX => "m",
        }
    }
}

/// How a row was estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Method {
    /// Constant-acceleration (quadratic) fit of a yaw drop.
    Quadratic,
    /// Aerodynamic-drag `ln cosh` fit of a yaw drop.
    LnCosh,
    /// Damped-sine least squares of a swing.
    DampedSineNls,
    /// Zero crossings of a swing.
    ZeroCrossing,
    /// Least squares over static tilt configurations.
    StaticTiltLs,
    /// Yaw table identified by a friction method.
    FallingMass(FrictionMethod),
    /// Exact torque balance of a vehicle drop.
    FallingMassExact,
    /// The thesis's simplified formula.
    ThesisSimplified,
    /// The thesis's calibration factor.
    ThesisCalibrationFactor,
    /// Trifilar pendulum.
    Trifilar,
    /// Compound pendulum.
    CompoundPendulum,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Quadratic => "quadratic",
            Method::LnCosh => "ln_cosh",
            Method::DampedSineNls => "damped_sine_nls",
            Method::ZeroCrossing => "zero_crossing",
            Method::StaticTiltLs => "static_tilt_ls",
            Method::FallingMass(FrictionMethod::Given) => "falling_mass_given",
            Method::FallingMass(FrictionMethod::TareCalibration) => "falling_mass_tare_calibration",
            Method::FallingMass(FrictionMethod::MultiMass) => "falling_mass_multi_mass",
            Method::FallingMass(FrictionMethod::CalibrationFactor) => {
                "falling_mass_calibration_factor"
            }
            Method::FallingMassExact => "falling_mass_exact",
            Method::ThesisSimplified => "thesis_simplified",
            Method::ThesisCalibrationFactor => "thesis_calibration_factor",
            Method::Trifilar => "trifilar",
            Method::CompoundPendulum => "compound_pendulum",
        }
    }
}

/// One result of a session before it is stamped with the session id.
#[derive(Debug, Clone)]
pub(super) struct Row<'a> {
    /// Run id, or the ids of the runs combined joined with `+`.
    pub run: &'a str,
    /// What was measured: vehicle id, `table`, `platform`, a calibration body id.
    pub object: &'a str,
    pub axis: Axis,
    pub quantity: Quantity,
    pub method: Method,
    /// Value and standard uncertainty in the quantity's unit.
    pub value: (f64, f64),
    /// `key=value` pairs separated by `; `.
    pub diagnostics: String,
}

impl Row<'_> {
    /// The table row of this result in session `session`.
    pub(super) fn into_result(self, session: &str) -> InertiaResult {
        InertiaResult {
            session: session.into(),
            run: self.run.into(),
            object: self.object.into(),
            axis: self.axis.name().into(),
            quantity: self.quantity.name().into(),
            method: self.method.name().into(),
            value: self.value.0,
            uncertainty: self.value.1,
            units: self.quantity.units().into(),
            diagnostics: self.diagnostics,
        }
    }
}
