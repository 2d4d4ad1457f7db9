//! Magic Formula coefficient catalogue: every numeric key a PAC2002 / MF 5.2 or MF 6.1 / 6.2
//! `.tir` file carries that the model, its fit or its relaxation lengths use, with its section,
//! the default used when a file omits it, its description and which model versions carry it.
//!
//! In: nothing (static tables). Out: [`Coef`] (a typed index), [`Coefs`] (a dense vector of all
//! values, generic over the scalar so the evaluator can run on dual numbers), lookups by name and
//! [`Coef::carried_by`] (PAC2002-only keys such as `LGAY`, `PHY3`, `PTX1`; MF 6.x-only keys such
//! as the pressure terms `PPX1..`, `PKY4..PKY7`, `QSY5..QSY8`). Deliberately not here:
//! string-valued keys (`PROPERTY_FILE_FORMAT`, `TYRESIDE`, `[UNITS]`), which live with the
//! `.tir` file model, and keys no equation here uses (inertia, turn slip, contact patch, MF 6.2
//! vertical keys: kept by the reader as extras).
//!
//! Defaults follow MFeval 4.3.1's reader where it matters numerically: scaling factors are 1,
//! `QSX4..QSX11` take MFeval's defaults (with `QSX7 = QSX8 = QSX10 = 0` the extra overturning
//! terms vanish, so a file without them evaluates the PAC2002 core `Mx`), the MF 6.x keys take
//! MFeval's (`PKY4 = 2`, `PKY6 = -1`, `QSY7 = 0.85`, `QSY8 = -0.4`, `NOMPRES = 220 kPa`, ...),
//! ranges (pressure range included) default to "unlimited", everything else to 0.

use std::ops::{Index, IndexMut};

use super::version::Version;

/// The `.tir` section a coefficient belongs to.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Section {
    /// `[MODEL]`
    Model,
    /// `[DIMENSION]`
    Dimension,
    /// `[OPERATING_CONDITIONS]` (MF 6.x)
    OperatingConditions,
    /// `[VERTICAL]`
    Vertical,
    /// `[STRUCTURAL]` (MF 6.x)
    Structural,
    /// `[INFLATION_PRESSURE_RANGE]` (MF 6.x)
    InflationPressureRange,
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
            Section::OperatingConditions => "OPERATING_CONDITIONS",
            Section::Vertical => "VERTICAL",
            Section::Structural => "STRUCTURAL",
            Section::InflationPressureRange => "INFLATION_PRESSURE_RANGE",
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
    INFLPRES, OperatingConditions, 220000.0, "Tyre inflation pressure";
    NOMPRES, OperatingConditions, 220000.0, "Nominal tyre inflation pressure";
    FNOMIN, Vertical, 0.0, "Nominal wheel load";
    VERTICAL_STIFFNESS, Vertical, 0.0, "Tyre vertical stiffness";
    VERTICAL_DAMPING, Vertical, 0.0, "Tyre vertical damping";
    BREFF, Vertical, 0.0, "Low load stiffness e.r.r.";
    DREFF, Vertical, 0.0, "Peak value of e.r.r.";
    FREFF, Vertical, 0.0, "High load stiffness e.r.r.";
    Q_RE0, Vertical, 1.0, "Ratio of free tyre radius with nominal tyre radius";
    Q_V1, Vertical, 0.0, "Tyre radius increase with speed";
    Q_V2, Vertical, 0.0, "Vertical stiffness increase with speed";
    Q_FZ2, Vertical, 1.0e-4, "Quadratic term in load vs. deflection";
    Q_FCX, Vertical, 0.0, "Longitudinal force influence on vertical stiffness";
    Q_FCY, Vertical, 0.0, "Lateral force influence on vertical stiffness";
    Q_CAM, Vertical, 0.0, "Stiffness reduction due to camber";
    PFZ1, Vertical, 0.0, "Pressure effect on vertical stiffness";
    BOTTOM_OFFST, Vertical, 0.01, "Distance to rim when bottoming starts to occur";
    BOTTOM_STIFF, Vertical, 2.0e6, "Vertical stiffness of bottomed tyre";
    LONGITUDINAL_STIFFNESS, Structural, 3.0e5, "Tyre overall longitudinal stiffness";
    LATERAL_STIFFNESS, Structural, 1.0e5, "Tyre overall lateral stiffness";
    PCFX1, Structural, 0.0, "Tyre overall longitudinal stiffness vertical deflection dependency linear term";
    PCFX2, Structural, 0.0, "Tyre overall longitudinal stiffness vertical deflection dependency quadratic term";
    PCFX3, Structural, 0.0, "Tyre overall longitudinal stiffness pressure dependency";
    PCFY1, Structural, 0.0, "Tyre overall lateral stiffness vertical deflection dependency linear term";
    PCFY2, Structural, 0.0, "Tyre overall lateral stiffness vertical deflection dependency quadratic term";
    PCFY3, Structural, 0.0, "Tyre overall lateral stiffness pressure dependency";
    PRESMIN, InflationPressureRange, 0.0, "Minimum valid tyre inflation pressure";
    PRESMAX, InflationPressureRange, 1e+30, "Maximum valid tyre inflation pressure";
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
    LKYC, Scaling, 1.0, "Scale factor of camber force stiffness";
    LKZC, Scaling, 1.0, "Scale factor of camber torque stiffness";
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
    PPX1, Longitudinal, 0.0, "Linear influence of inflation pressure on longitudinal slip stiffness";
    PPX2, Longitudinal, 0.0, "Quadratic influence of inflation pressure on longitudinal slip stiffness";
    PPX3, Longitudinal, 0.0, "Linear influence of inflation pressure on peak longitudinal friction";
    PPX4, Longitudinal, 0.0, "Quadratic influence of inflation pressure on peak longitudinal friction";
    RBX1, Longitudinal, 0.0, "Slope factor for combined slip Fx reduction";
    RBX2, Longitudinal, 0.0, "Variation of slope Fx reduction with kappa";
    RBX3, Longitudinal, 0.0, "Influence of camber on stiffness for Fx combined";
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
    QSX12, Overturning, 0.0, "Camber squared induced overturning moment";
    QSX13, Overturning, 0.0, "Lateral force induced overturning moment";
    QSX14, Overturning, 0.0, "Lateral force induced overturning moment with camber";
    PPMX1, Overturning, 0.0, "Influence of inflation pressure on overturning moment";
    PCY1, Lateral, 0.0, "Shape factor Cfy for lateral forces";
    PDY1, Lateral, 0.0, "Lateral friction Muy";
    PDY2, Lateral, 0.0, "Variation of friction Muy with load";
    PDY3, Lateral, 0.0, "Variation of friction Muy with squared camber";
    PEY1, Lateral, 0.0, "Lateral curvature Efy at Fznom";
    PEY2, Lateral, 0.0, "Variation of curvature Efy with load";
    PEY3, Lateral, 0.0, "Zero order camber dependency of curvature Efy";
    PEY4, Lateral, 0.0, "Variation of curvature Efy with camber";
    PEY5, Lateral, 0.0, "Variation of curvature Efy with camber squared";
    PKY1, Lateral, 0.0, "Maximum value of stiffness Kfy/Fznom";
    PKY2, Lateral, 0.0, "Load at which Kfy reaches maximum value";
    PKY3, Lateral, 0.0, "Variation of Kfy/Fznom with camber";
    PKY4, Lateral, 2.0, "Curvature of stiffness Kfy";
    PKY5, Lateral, 0.0, "Peak stiffness variation with camber squared";
    PKY6, Lateral, -1.0, "Fy camber stiffness factor";
    PKY7, Lateral, 0.0, "Vertical load dependency of camber stiffness";
    PHY1, Lateral, 0.0, "Horizontal shift Shy at Fznom";
    PHY2, Lateral, 0.0, "Variation of shift Shy with load";
    PHY3, Lateral, 0.0, "Variation of shift Shy with camber";
    PVY1, Lateral, 0.0, "Vertical shift in Svy/Fz at Fznom";
    PVY2, Lateral, 0.0, "Variation of shift Svy/Fz with load";
    PVY3, Lateral, 0.0, "Variation of shift Svy/Fz with camber";
    PVY4, Lateral, 0.0, "Variation of shift Svy/Fz with camber and load";
    PPY1, Lateral, 0.0, "Influence of inflation pressure on cornering stiffness";
    PPY2, Lateral, 0.0, "Influence of inflation pressure on dependency of nominal tyre load on cornering stiffness";
    PPY3, Lateral, 0.0, "Linear influence of inflation pressure on lateral peak friction";
    PPY4, Lateral, 0.0, "Quadratic influence of inflation pressure on lateral peak friction";
    PPY5, Lateral, 0.0, "Influence of inflation pressure on camber stiffness";
    RBY1, Lateral, 0.0, "Slope factor for combined Fy reduction";
    RBY2, Lateral, 0.0, "Variation of slope Fy reduction with alpha";
    RBY3, Lateral, 0.0, "Shift term for alpha in slope Fy reduction";
    RBY4, Lateral, 0.0, "Influence of camber on stiffness of Fy combined";
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
    QSY5, Rolling, 0.0, "Rolling resistance torque depending on camber squared";
    QSY6, Rolling, 0.0, "Rolling resistance torque depending on load and camber squared";
    QSY7, Rolling, 0.85, "Rolling resistance torque coefficient load dependency";
    QSY8, Rolling, -0.4, "Rolling resistance torque coefficient pressure dependency";
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
    QDZ10, Aligning, 0.0, "Variation of peak factor Dmr with camber squared";
    QDZ11, Aligning, 0.0, "Variation of Dmr with camber squared and load";
    QEZ1, Aligning, 0.0, "Trail curvature Ept at Fznom";
    QEZ2, Aligning, 0.0, "Variation of curvature Ept with load";
    QEZ3, Aligning, 0.0, "Variation of curvature Ept with load squared";
    QEZ4, Aligning, 0.0, "Variation of curvature Ept with sign of Alpha-t";
    QEZ5, Aligning, 0.0, "Variation of Ept with camber and sign Alpha-t";
    QHZ1, Aligning, 0.0, "Trail horizontal shift Sht at Fznom";
    QHZ2, Aligning, 0.0, "Variation of shift Sht with load";
    QHZ3, Aligning, 0.0, "Variation of shift Sht with camber";
    QHZ4, Aligning, 0.0, "Variation of shift Sht with camber and load";
    PPZ1, Aligning, 0.0, "Effect of inflation pressure on length of pneumatic trail";
    PPZ2, Aligning, 0.0, "Influence of inflation pressure on residual aligning torque";
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

    /// Is this key part of `version`'s parameter set? PAC2002-only keys (the camber scalings
    /// `LGAX/LGAY/LGAZ`, `PHY3`, the relaxation coefficients `PTX1..PTY2` with `LSGKP/LSGAL`,
    /// `LGYR`, `QTZ1`, `MBELT`) and MF 6.x-only keys (pressure terms, `PKY4..7`, `PEY5`,
    /// `RBX3`, `RBY4`, `QSX12..14`, `QSY5..8`, `QDZ10/11`, `LKYC/LKZC`, the MF 6.x vertical and
    /// structural keys, pressures and pressure range) are carried by one family only.
    pub const fn carried_by(self, version: Version) -> bool {
        use Coef::*;
        let pac2002_only = matches!(
            self,
            LGAX | LGAY
                | LGAZ
                | LSGKP
                | LSGAL
                | LGYR
                | PTX1
                | PTX2
                | PTX3
                | PHY3
                | PTY1
                | PTY2
                | QTZ1
                | MBELT
        );
        let mf6_only = matches!(
            self,
            INFLPRES
                | NOMPRES
                | Q_RE0
                | Q_V1
                | Q_V2
                | Q_FZ2
                | Q_FCX
                | Q_FCY
                | Q_CAM
                | PFZ1
                | BOTTOM_OFFST
                | BOTTOM_STIFF
                | LONGITUDINAL_STIFFNESS
                | LATERAL_STIFFNESS
                | PCFX1
                | PCFX2
                | PCFX3
                | PCFY1
                | PCFY2
                | PCFY3
                | PRESMIN
                | PRESMAX
                | LKYC
                | LKZC
                | PPX1
                | PPX2
                | PPX3
                | PPX4
                | RBX3
                | QSX12
                | QSX13
                | QSX14
                | PPMX1
                | PEY5
                | PKY4
                | PKY5
                | PKY6
                | PKY7
                | PPY1
                | PPY2
                | PPY3
                | PPY4
                | PPY5
                | RBY4
                | QSY5
                | QSY6
                | QSY7
                | QSY8
                | QDZ10
                | QDZ11
                | PPZ1
                | PPZ2
        );
        if version.is_mf6() {
            !pac2002_only
        } else {
            !mf6_only
        }
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

    /// The same values with every key `version` does not carry set to its default (so an
    /// MF 6.x model's `LGAY` is 1 and a PAC2002 model's pressure terms are 0).
    pub fn restricted_to(mut self, version: Version) -> Self {
        for c in Coef::ALL {
            if !c.carried_by(version) {
                self[*c] = c.default_value();
            }
        }
        self
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
    fn versions_share_the_core_keys() {
        for c in [Coef::FNOMIN, Coef::PCY1, Coef::QSX4, Coef::QDZ9, Coef::LMUY] {
            for v in [Version::Pac2002, Version::Mf61, Version::Mf62] {
                assert!(c.carried_by(v), "{}", c.name());
            }
        }
        assert!(!Coef::PPY1.carried_by(Version::Pac2002));
        assert!(Coef::PPY1.carried_by(Version::Mf62));
        assert!(!Coef::PHY3.carried_by(Version::Mf61));
        let c = Coefs::defaults();
        let mut x = c.clone();
        x[Coef::LGAY] = 0.5;
        x[Coef::PPY1] = 0.3;
        assert_eq!(x.clone().restricted_to(Version::Mf61)[Coef::LGAY], 1.0);
        assert_eq!(x.clone().restricted_to(Version::Mf61)[Coef::PPY1], 0.3);
        assert_eq!(x.restricted_to(Version::Pac2002)[Coef::PPY1], 0.0);
    }

    #[test]
    fn scaling_defaults_are_one() {
        let d = Coefs::defaults();
        for c in Coef::ALL.iter().filter(|c| c.section() == Section::Scaling) {
            assert_eq!(d[*c], 1.0, "{}", c.name());
        }
    }
}
