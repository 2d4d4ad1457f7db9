//! PAC2002 / MF 5.2 coefficient catalogue: every numeric key a PAC2002 `.tir` file carries,
//! with its section, the default used when a file omits it, and its description.
//!
//! In: nothing (static tables). Out: [`Coef`] (a typed index), [`Coefs`] (a dense vector of all
//! values, generic over the scalar so the evaluator can run on dual numbers) and lookups by name.
//! Deliberately not here: string-valued keys (`PROPERTY_FILE_FORMAT`, `TYRESIDE`, `[UNITS]`),
//! which live with the `.tir` file model, and MF 6.x-only keys (kept by the reader as extras).
//!
//! Defaults follow MFeval 4.3.1's reader where it matters numerically: scaling factors are 1,
//! `QSX4..QSX11` take MFeval's defaults (with `QSX7 = QSX8 = QSX10 = 0` the extra overturning
//! terms vanish, so a file without them evaluates the PAC2002 core `Mx`), ranges default to
//! "unlimited", everything else to 0.

use std::ops::{Index, IndexMut};

/// The `.tir` section a coefficient belongs to.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Section {
    /// `[MODEL]`
    Model,
    /// `[DIMENSION]`
    Dimension,
    /// `[VERTICAL]`
    Vertical,
    /// `[LONG_SLIP_RANGE]`
    LongSlipRange,
    /// `[SLIP_ANGLE_RANGE]`
    SlipAngleRange,
    /// `[INCLINATION_ANGLE_RANGE]`
    InclinationAngleRange,
    /// `[VERTICAL_FORCE_RANGE]`
    VerticalForceRange,
    /// `[SCALING_COEFFICIENTS]`
    Scaling,
    /// `[LONGITUDINAL_COEFFICIENTS]`
    Longitudinal,
    /// `[OVERTURNING_COEFFICIENTS]`
    Overturning,
    /// `[LATERAL_COEFFICIENTS]`
    Lateral,
    /// `[ROLLING_COEFFICIENTS]`
    Rolling,
    /// `[ALIGNING_COEFFICIENTS]`
    Aligning,
}

impl Section {
    /// The section name as written between brackets in a `.tir` file.
    pub const fn tir_name(self) -> &'static str {
        match self {
            Section::Model => "MODEL",
            Section::Dimension => "DIMENSION",
            Section::Vertical => "VERTICAL",
            Section::LongSlipRange => "LONG_SLIP_RANGE",
            Section::SlipAngleRange => "SLIP_ANGLE_RANGE",
            Section::InclinationAngleRange => "INCLINATION_ANGLE_RANGE",
            Section::VerticalForceRange => "VERTICAL_FORCE_RANGE",
            Section::Scaling => "SCALING_COEFFICIENTS",
            Section::Longitudinal => "LONGITUDINAL_COEFFICIENTS",
            Section::Overturning => "OVERTURNING_COEFFICIENTS",
            Section::Lateral => "LATERAL_COEFFICIENTS",
            Section::Rolling => "ROLLING_COEFFICIENTS",
            Section::Aligning => "ALIGNING_COEFFICIENTS",
        }
    }
}

macro_rules! coefficients {
    ($( $name:ident, $section:ident, $default:expr, $doc:literal; )*) => {
        /// Typed index of one numeric PAC2002 key (the enum's name is the `.tir` key).
        #[allow(non_camel_case_types, clippy::upper_case_acronyms)]
        #[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr(u16)]
        pub enum Coef { $( #[doc = $doc] $name, )* }

        impl Coef {
            /// Every coefficient, in canonical file order (section by section).
            pub const ALL: &'static [Coef] = &[ $( Coef::$name, )* ];

            /// The `.tir` key, upper case.
            pub const fn name(self) -> &'static str {
                match self { $( Coef::$name => stringify!($name), )* }
            }

            /// The section the key is written in.
            pub const fn section(self) -> Section {
                match self { $( Coef::$name => Section::$section, )* }
            }

            /// Value used when a file does not carry the key.
            pub const fn default_value(self) -> f64 {
                match self { $( Coef::$name => $default, )* }
            }

            /// One-line description (written as the trailing `$` comment).
            pub const fn description(self) -> &'static str {
                match self { $( Coef::$name => $doc, )* }
            }
        }
    };
}

coefficients! {
    LONGVL, Model, 16.7, "Measurement speed";
    VXLOW, Model, 1.0, "Threshold for scaling down forces and moments";
    UNLOADED_RADIUS, Dimension, 0.0, "Free tyre radius";
    WIDTH, Dimension, 0.0, "Nominal section width of the tyre";
    ASPECT_RATIO, Dimension, 0.0, "Nominal aspect ratio";
    RIM_RADIUS, Dimension, 0.0, "Nominal rim radius";
    RIM_WIDTH, Dimension, 0.0, "Rim width";
    FNOMIN, Vertical, 0.0, "Nominal wheel load";
    VERTICAL_STIFFNESS, Vertical, 0.0, "Tyre vertical stiffness";
    VERTICAL_DAMPING, Vertical, 0.0, "Tyre vertical damping";
    BREFF, Vertical, 0.0, "Low load stiffness e.r.r.";
    DREFF, Vertical, 0.0, "Peak value of e.r.r.";
    FREFF, Vertical, 0.0, "High load stiffness e.r.r.";
    KPUMIN, LongSlipRange, -1.5, "Minimum valid wheel slip";
    KPUMAX, LongSlipRange, 1.5, "Maximum valid wheel slip";
    ALPMIN, SlipAngleRange, -std::f64::consts::FRAC_PI_2, "Minimum valid slip angle";
    ALPMAX, SlipAngleRange, std::f64::consts::FRAC_PI_2, "Maximum valid slip angle";
    CAMMIN, InclinationAngleRange, -std::f64::consts::FRAC_PI_2, "Minimum valid camber angle";
    CAMMAX, InclinationAngleRange, std::f64::consts::FRAC_PI_2, "Maximum valid camber angle";
    FZMIN, VerticalForceRange, 0.0, "Minimum allowed wheel load";
    FZMAX, VerticalForceRange, 1e+30, "Maximum allowed wheel load";
    LFZO, Scaling, 1.0, "Scale factor of nominal (rated) load";
    LCX, Scaling, 1.0, "Scale factor of Fx shape factor";
    LMUX, Scaling, 1.0, "Scale factor of Fx peak friction coefficient";
    LEX, Scaling, 1.0, "Scale factor of Fx curvature factor";
    LKX, Scaling, 1.0, "Scale factor of Fx slip stiffness";
    LHX, Scaling, 1.0, "Scale factor of Fx horizontal shift";
    LVX, Scaling, 1.0, "Scale factor of Fx vertical shift";
    LGAX, Scaling, 1.0, "Scale factor of camber for Fx";
    LCY, Scaling, 1.0, "Scale factor of Fy shape factor";
    LMUY, Scaling, 1.0, "Scale factor of Fy peak friction coefficient";
    LEY, Scaling, 1.0, "Scale factor of Fy curvature factor";
    LKY, Scaling, 1.0, "Scale factor of Fy cornering stiffness";
    LHY, Scaling, 1.0, "Scale factor of Fy horizontal shift";
    LVY, Scaling, 1.0, "Scale factor of Fy vertical shift";
    LGAY, Scaling, 1.0, "Scale factor of camber for Fy";
    LTR, Scaling, 1.0, "Scale factor of peak of pneumatic trail";
    LRES, Scaling, 1.0, "Scale factor of offset of residual torque";
    LGAZ, Scaling, 1.0, "Scale factor of camber for Mz";
    LXAL, Scaling, 1.0, "Scale factor of alpha influence on Fx";
    LYKA, Scaling, 1.0, "Scale factor of kappa influence on Fy";
    LVYKA, Scaling, 1.0, "Scale factor of kappa induced Fy";
    LS, Scaling, 1.0, "Scale factor of moment arm of Fx";
    LSGKP, Scaling, 1.0, "Scale factor of relaxation length of Fx";
    LSGAL, Scaling, 1.0, "Scale factor of relaxation length of Fy";
    LGYR, Scaling, 1.0, "Scale factor of gyroscopic torque";
    LMX, Scaling, 1.0, "Scale factor of overturning couple";
    LVMX, Scaling, 1.0, "Scale factor of Mx vertical shift";
    LMY, Scaling, 1.0, "Scale factor of rolling resistance torque";
    PCX1, Longitudinal, 0.0, "Shape factor Cfx for longitudinal force";
    PDX1, Longitudinal, 0.0, "Longitudinal friction Mux at Fznom";
    PDX2, Longitudinal, 0.0, "Variation of friction Mux with load";
    PDX3, Longitudinal, 0.0, "Variation of friction Mux with camber squared";
    PEX1, Longitudinal, 0.0, "Longitudinal curvature Efx at Fznom";
    PEX2, Longitudinal, 0.0, "Variation of curvature Efx with load";
    PEX3, Longitudinal, 0.0, "Variation of curvature Efx with load squared";
    PEX4, Longitudinal, 0.0, "Factor in curvature Efx while driving";
    PKX1, Longitudinal, 0.0, "Longitudinal slip stiffness Kfx/Fz at Fznom";
    PKX2, Longitudinal, 0.0, "Variation of slip stiffness Kfx/Fz with load";
    PKX3, Longitudinal, 0.0, "Exponent in slip stiffness Kfx/Fz with load";
    PHX1, Longitudinal, 0.0, "Horizontal shift Shx at Fznom";
    PHX2, Longitudinal, 0.0, "Variation of shift Shx with load";
    PVX1, Longitudinal, 0.0, "Vertical shift Svx/Fz at Fznom";
    PVX2, Longitudinal, 0.0, "Variation of shift Svx/Fz with load";
    RBX1, Longitudinal, 0.0, "Slope factor for combined slip Fx reduction";
    RBX2, Longitudinal, 0.0, "Variation of slope Fx reduction with kappa";
    RCX1, Longitudinal, 0.0, "Shape factor for combined slip Fx reduction";
    REX1, Longitudinal, 0.0, "Curvature factor of combined Fx";
    REX2, Longitudinal, 0.0, "Curvature factor of combined Fx with load";
    RHX1, Longitudinal, 0.0, "Shift factor for combined slip Fx reduction";
    PTX1, Longitudinal, 0.0, "Relaxation length SigKap0/Fz at Fznom";
    PTX2, Longitudinal, 0.0, "Variation of SigKap0/Fz with load";
    PTX3, Longitudinal, 0.0, "Variation of SigKap0/Fz with exponent of load";
    QSX1, Overturning, 0.0, "Lateral force induced overturning moment";
    QSX2, Overturning, 0.0, "Camber induced overturning couple";
    QSX3, Overturning, 0.0, "Fy induced overturning couple";
    QSX4, Overturning, 5.0, "Mixed load, lateral force, and camber on Mx";
    QSX5, Overturning, 1.0, "Load effect on Mx with lateral force and camber";
    QSX6, Overturning, 10.0, "B-factor of load with Mx";
    QSX7, Overturning, 0.0, "Camber with load on Mx";
    QSX8, Overturning, 0.0, "Lateral force with load on Mx";
    QSX9, Overturning, 0.4, "B-factor of lateral force with load on Mx";
    QSX10, Overturning, 0.0, "Vertical force with camber on Mx";
    QSX11, Overturning, 5.0, "B-factor of vertical force with camber on Mx";
    PCY1, Lateral, 0.0, "Shape factor Cfy for lateral forces";
    PDY1, Lateral, 0.0, "Lateral friction Muy";
    PDY2, Lateral, 0.0, "Variation of friction Muy with load";
    PDY3, Lateral, 0.0, "Variation of friction Muy with squared camber";
    PEY1, Lateral, 0.0, "Lateral curvature Efy at Fznom";
    PEY2, Lateral, 0.0, "Variation of curvature Efy with load";
    PEY3, Lateral, 0.0, "Zero order camber dependency of curvature Efy";
    PEY4, Lateral, 0.0, "Variation of curvature Efy with camber";
    PKY1, Lateral, 0.0, "Maximum value of stiffness Kfy/Fznom";
    PKY2, Lateral, 0.0, "Load at which Kfy reaches maximum value";
    PKY3, Lateral, 0.0, "Variation of Kfy/Fznom with camber";
    PHY1, Lateral, 0.0, "Horizontal shift Shy at Fznom";
    PHY2, Lateral, 0.0, "Variation of shift Shy with load";
    PHY3, Lateral, 0.0, "Variation of shift Shy with camber";
    PVY1, Lateral, 0.0, "Vertical shift in Svy/Fz at Fznom";
    PVY2, Lateral, 0.0, "Variation of shift Svy/Fz with load";
    PVY3, Lateral, 0.0, "Variation of shift Svy/Fz with camber";
    PVY4, Lateral, 0.0, "Variation of shift Svy/Fz with camber and load";
    RBY1, Lateral, 0.0, "Slope factor for combined Fy reduction";
    RBY2, Lateral, 0.0, "Variation of slope Fy reduction with alpha";
    RBY3, Lateral, 0.0, "Shift term for alpha in slope Fy reduction";
    RCY1, Lateral, 0.0, "Shape factor for combined Fy reduction";
    REY1, Lateral, 0.0, "Curvature factor of combined Fy";
    REY2, Lateral, 0.0, "Curvature factor of combined Fy with load";
    RHY1, Lateral, 0.0, "Shift factor for combined Fy reduction";
    RHY2, Lateral, 0.0, "Shift factor for combined Fy reduction with load";
    RVY1, Lateral, 0.0, "Kappa induced side force Svyk/Muy*Fz at Fznom";
    RVY2, Lateral, 0.0, "Variation of Svyk/Muy*Fz with load";
    RVY3, Lateral, 0.0, "Variation of Svyk/Muy*Fz with camber";
    RVY4, Lateral, 0.0, "Variation of Svyk/Muy*Fz with alpha";
    RVY5, Lateral, 0.0, "Variation of Svyk/Muy*Fz with kappa";
    RVY6, Lateral, 0.0, "Variation of Svyk/Muy*Fz with atan(kappa)";
    PTY1, Lateral, 0.0, "Peak value of relaxation length SigAlp0/R0";
    PTY2, Lateral, 0.0, "Value of Fz/Fznom where SigAlp0 is extreme";
    QSY1, Rolling, 0.0, "Rolling resistance torque coefficient";
    QSY2, Rolling, 0.0, "Rolling resistance torque depending on Fx";
    QSY3, Rolling, 0.0, "Rolling resistance torque depending on speed";
    QSY4, Rolling, 0.0, "Rolling resistance torque depending on speed ^4";
    QBZ1, Aligning, 0.0, "Trail slope factor for trail Bpt at Fznom";
    QBZ2, Aligning, 0.0, "Variation of slope Bpt with load";
    QBZ3, Aligning, 0.0, "Variation of slope Bpt with load squared";
    QBZ4, Aligning, 0.0, "Variation of slope Bpt with camber";
    QBZ5, Aligning, 0.0, "Variation of slope Bpt with absolute camber";
    QBZ9, Aligning, 0.0, "Slope factor Br of residual torque Mzr";
    QBZ10, Aligning, 0.0, "Slope factor Br of residual torque Mzr";
    QCZ1, Aligning, 0.0, "Shape factor Cpt for pneumatic trail";
    QDZ1, Aligning, 0.0, "Peak trail Dpt'' = Dpt*(Fz/Fznom*R0)";
    QDZ2, Aligning, 0.0, "Variation of peak Dpt with load";
    QDZ3, Aligning, 0.0, "Variation of peak Dpt with camber";
    QDZ4, Aligning, 0.0, "Variation of peak Dpt with camber squared";
    QDZ6, Aligning, 0.0, "Peak residual torque Dmr = Dmr/(Fz*R0)";
    QDZ7, Aligning, 0.0, "Variation of peak factor Dmr with load";
    QDZ8, Aligning, 0.0, "Variation of peak factor Dmr with camber";
    QDZ9, Aligning, 0.0, "Variation of peak factor Dmr with camber and load";
    QEZ1, Aligning, 0.0, "Trail curvature Ept at Fznom";
    QEZ2, Aligning, 0.0, "Variation of curvature Ept with load";
    QEZ3, Aligning, 0.0, "Variation of curvature Ept with load squared";
    QEZ4, Aligning, 0.0, "Variation of curvature Ept with sign of Alpha-t";
    QEZ5, Aligning, 0.0, "Variation of Ept with camber and sign Alpha-t";
    QHZ1, Aligning, 0.0, "Trail horizontal shift Sht at Fznom";
    QHZ2, Aligning, 0.0, "Variation of shift Sht with load";
    QHZ3, Aligning, 0.0, "Variation of shift Sht with camber";
    QHZ4, Aligning, 0.0, "Variation of shift Sht with camber and load";
    SSZ1, Aligning, 0.0, "Nominal value of s/R0: effect of Fx on Mz";
    SSZ2, Aligning, 0.0, "Variation of distance s/R0 with Fy/Fznom";
    SSZ3, Aligning, 0.0, "Variation of distance s/R0 with camber";
    SSZ4, Aligning, 0.0, "Variation of distance s/R0 with load and camber";
    QTZ1, Aligning, 0.0, "Gyration torque constant";
    MBELT, Aligning, 0.0, "Belt mass of the wheel";
}

/// Number of coefficients in [`Coef::ALL`].
pub const N_COEFS: usize = Coef::ALL.len();

impl Coef {
    /// Position in a [`Coefs`] vector.
    #[inline]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Case-insensitive lookup of a `.tir` key (surrounding whitespace ignored).
    pub fn from_name(name: &str) -> Option<Coef> {
        let name = name.trim();
        Coef::ALL
            .iter()
            .copied()
            .find(|c| c.name().eq_ignore_ascii_case(name))
    }
}

/// A dense vector holding a value for every [`Coef`], indexed by `Coef`.
///
/// Generic over the scalar so the same evaluator code runs on `f64` and on dual numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Coefs<T>(pub [T; N_COEFS]);

impl Coefs<f64> {
    /// All coefficients at their defaults (see the module docs).
    pub fn defaults() -> Self {
        let mut values = [0.0; N_COEFS];
        for c in Coef::ALL {
            values[c.index()] = c.default_value();
        }
        Coefs(values)
    }
}

impl<T> Index<Coef> for Coefs<T> {
    type Output = T;
    #[inline]
    fn index(&self, c: Coef) -> &T {
        &self.0[c.index()]
    }
}

impl<T> IndexMut<Coef> for Coefs<T> {
    #[inline]
    fn index_mut(&mut self, c: Coef) -> &mut T {
        &mut self.0[c.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_are_unique() {
        for (i, c) in Coef::ALL.iter().enumerate() {
            assert_eq!(c.index(), i);
            assert_eq!(Coef::from_name(&c.name().to_lowercase()), Some(*c));
        }
    }

    #[test]
    fn scaling_defaults_are_one() {
        let d = Coefs::defaults();
        for c in Coef::ALL.iter().filter(|c| c.section() == Section::Scaling) {
            assert_eq!(d[*c], 1.0, "{}", c.name());
        }
    }
}
