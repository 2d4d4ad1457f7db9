//! Unit strings of TTC files and their conversion to tirebase's SI set.
//!
//! In: a unit cell as written on `.dat` line 3 or in a `.mat` `channel.units` cell. Out: a
//! [`Unit`] that knows its [`Quantity`], its [`UnitSystem`] and how to convert a column to the
//! canonical unit of that quantity (s, km/h, rpm, rad, m, kPa, N, N m, degC, 1). Matching ignores
//! case and repeated blanks, so `deg c`, `deg C` and `Deg  C` are one unit. Deliberately not
//! here: which channel has which quantity (see `channel.rs`) and axis signs (see `frame`).

use std::f64::consts::PI;

/// Exact conversion constants (international inch, pound-force as 4.4482216152605 N).
const MPH_TO_KPH: f64 = 1.609344;
const INCH_TO_M: f64 = 0.0254;
const CM_TO_M: f64 = 0.01;
const PSI_TO_KPA: f64 = 6.894_757_293_168_361;
const LBF_TO_N: f64 = 4.448_221_615_260_5;
const FT_LBF_TO_NM: f64 = LBF_TO_N * 0.3048;
const DEG_TO_RAD: f64 = PI / 180.0;

/// What a channel measures; decides which units are acceptable for it.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Quantity {
    Time,
    RoadSpeed,
    WheelSpeed,
    Angle,
    Length,
    Pressure,
    Force,
    Moment,
    Temperature,
    Ratio,
}

impl Quantity {
    /// The canonical (tirebase SI) unit every column of this quantity is converted to.
    pub fn canonical_unit_name(self) -> &'static str {
        match self {
            Quantity::Time => "s",
            Quantity::RoadSpeed => "km/h",
            Quantity::WheelSpeed => "rpm",
            Quantity::Angle => "rad",
            Quantity::Length => "m",
            Quantity::Pressure => "kPa",
            Quantity::Force => "N",
            Quantity::Moment => "N m",
            Quantity::Temperature => "degC",
            Quantity::Ratio => "1",
        }
    }
}

/// Which unit system a single column was recorded in.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum UnitSystem {
    /// kph, cm, kPa, N, N-m, deg C.
    Si,
    /// mph, in, psi, lb, ft-lb, deg F.
    Uscs,
    /// Units shared by both systems: s, rpm, deg, dimensionless.
    Neutral,
}

/// A unit seen in TTC files.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    Second,
    Mph,
    Kph,
    Rpm,
    Degree,
    Inch,
    Centimetre,
    Psi,
    KiloPascal,
    PoundForce,
    Newton,
    FootPound,
    NewtonMetre,
    DegC,
    DegF,
    Dimensionless,
}

impl Unit {
    /// Every spelling the readers accept (matched ignoring case, blanks collapsed).
    const SPELLINGS: &'static [(&'static str, Unit)] = &[
        ("s", Unit::Second),
        ("sec", Unit::Second),
        ("mph", Unit::Mph),
        ("kph", Unit::Kph),
        ("km/h", Unit::Kph),
        ("kmph", Unit::Kph),
        ("rpm", Unit::Rpm),
        ("deg", Unit::Degree),
        ("in", Unit::Inch),
        ("cm", Unit::Centimetre),
        ("psi", Unit::Psi),
        ("kPa", Unit::KiloPascal),
        ("lb", Unit::PoundForce),
        ("lbf", Unit::PoundForce),
        ("N", Unit::Newton),
        ("ft-lb", Unit::FootPound),
        ("ft-lbf", Unit::FootPound),
        ("lb-ft", Unit::FootPound),
        ("lbf-ft", Unit::FootPound),
        ("N-m", Unit::NewtonMetre),
        ("Nm", Unit::NewtonMetre),
        ("N m", Unit::NewtonMetre),
        ("N*m", Unit::NewtonMetre),
        ("deg C", Unit::DegC),
        ("degC", Unit::DegC),
        ("deg F", Unit::DegF),
        ("degF", Unit::DegF),
        ("none", Unit::Dimensionless),
        ("SAE", Unit::Dimensionless),
        ("-", Unit::Dimensionless),
    ];

    /// Every accepted spelling with its unit.
    pub fn spellings() -> impl Iterator<Item = (&'static str, Unit)> {
        Self::SPELLINGS.iter().copied()
    }

    /// Recognise a unit string; `None` if it is not one of the known spellings.
    ///
    /// ```
    /// use tirebase_core::ttc::Unit;
    /// assert_eq!(Unit::parse("deg C"), Some(Unit::DegC));
    /// assert_eq!(Unit::parse(" Deg  f "), Some(Unit::DegF));
    /// assert_eq!(Unit::parse("N-m"), Unit::parse("Nm"));
    /// assert_eq!(Unit::parse("furlong"), None);
    /// ```
    pub fn parse(text: &str) -> Option<Unit> {
        let normal = text.split_whitespace().collect::<Vec<_>>().join(" ");
        Self::SPELLINGS
            .iter()
            .find(|(spelling, _)| spelling.eq_ignore_ascii_case(&normal))
            .map(|&(_, unit)| unit)
    }

    /// The quantity this unit measures.
    pub fn quantity(self) -> Quantity {
        match self {
            Unit::Second => Quantity::Time,
            Unit::Mph | Unit::Kph => Quantity::RoadSpeed,
            Unit::Rpm => Quantity::WheelSpeed,
            Unit::Degree => Quantity::Angle,
            Unit::Inch | Unit::Centimetre => Quantity::Length,
            Unit::Psi | Unit::KiloPascal => Quantity::Pressure,
            Unit::PoundForce | Unit::Newton => Quantity::Force,
            Unit::FootPound | Unit::NewtonMetre => Quantity::Moment,
            Unit::DegC | Unit::DegF => Quantity::Temperature,
            Unit::Dimensionless => Quantity::Ratio,
        }
    }

    /// The unit system this unit belongs to.
    pub fn system(self) -> UnitSystem {
        match self {
            Unit::Mph
            | Unit::Inch
            | Unit::Psi
            | Unit::PoundForce
            | Unit::FootPound
            | Unit::DegF => UnitSystem::Uscs,
            Unit::Kph
            | Unit::Centimetre
            | Unit::KiloPascal
            | Unit::Newton
            | Unit::NewtonMetre
            | Unit::DegC => UnitSystem::Si,
            Unit::Second | Unit::Rpm | Unit::Degree | Unit::Dimensionless => UnitSystem::Neutral,
        }
    }

    /// Convert one value to the canonical unit of [`Unit::quantity`].
    pub fn to_canonical(self, value: f64) -> f64 {
        match self {
            Unit::Second | Unit::Kph | Unit::Rpm | Unit::KiloPascal => value,
            Unit::Newton | Unit::NewtonMetre | Unit::DegC | Unit::Dimensionless => value,
            Unit::Mph => value * MPH_TO_KPH,
            Unit::Degree => value * DEG_TO_RAD,
            Unit::Inch => value * INCH_TO_M,
            Unit::Centimetre => value * CM_TO_M,
            Unit::Psi => value * PSI_TO_KPA,
            Unit::PoundForce => value * LBF_TO_N,
            Unit::FootPound => value * FT_LBF_TO_NM,
            Unit::DegF => (value - 32.0) * (5.0 / 9.0),
        }
    }

    /// The inverse of [`Unit::to_canonical`]: a canonical value expressed in this unit (what a
    /// writer of US customary files needs).
    pub fn from_canonical(self, value: f64) -> f64 {
        match self {
            Unit::Second | Unit::Kph | Unit::Rpm | Unit::KiloPascal => value,
            Unit::Newton | Unit::NewtonMetre | Unit::DegC | Unit::Dimensionless => value,
            Unit::Mph => value / MPH_TO_KPH,
            Unit::Degree => value / DEG_TO_RAD,
            Unit::Inch => value / INCH_TO_M,
            Unit::Centimetre => value / CM_TO_M,
            Unit::Psi => value / PSI_TO_KPA,
            Unit::PoundForce => value / LBF_TO_N,
            Unit::FootPound => value / FT_LBF_TO_NM,
            Unit::DegF => value * (9.0 / 5.0) + 32.0,
        }
    }

    /// Convert a whole column in place to the canonical unit.
    pub fn convert_in_place(self, column: &mut [f64]) {
        if self.is_canonical() {
            return;
        }
        column.iter_mut().for_each(|v| *v = self.to_canonical(*v));
    }

    /// Whether values in this unit are already canonical (conversion is the identity).
    pub fn is_canonical(self) -> bool {
        matches!(
            self,
            Unit::Second
                | Unit::Kph
                | Unit::Rpm
                | Unit::KiloPascal
                | Unit::Newton
                | Unit::NewtonMetre
                | Unit::DegC
                | Unit::Dimensionless
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spelling_from_the_format_doc_is_known() {
        let lines = [
            "sec mph rpm deg deg in in psi lb lb lb ft-lb ft-lb none none none SAE",
            "sec kph rpm deg deg cm cm kPa N N N N-m N-m none none none",
            "s mph rpm deg deg in in psi lb lb lb ft-lb ft-lb none none SAE",
            "s kph rpm deg deg cm cm kPa N N N Nm Nm none none SAE",
        ];
        for line in lines {
            for word in line.split(' ') {
                assert!(Unit::parse(word).is_some(), "{word:?} in {line:?}");
            }
        }
        for temp in ["deg F", "deg f", "deg C", "deg c"] {
            assert_eq!(Unit::parse(temp).unwrap().quantity(), Quantity::Temperature);
        }
    }

    #[test]
    fn conversions_hit_known_values() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
        assert!(close(
            Unit::PoundForce.to_canonical(250.0),
            1_112.055_403_815_125
        ));
        assert!(close(Unit::Psi.to_canonical(12.0), 82.737_087_518_020_33));
        assert!(close(Unit::Mph.to_canonical(25.0), 40.2336));
        assert!(close(Unit::Inch.to_canonical(10.0), 0.254));
        assert!(close(Unit::Centimetre.to_canonical(22.5), 0.225));
        assert!(close(
            Unit::FootPound.to_canonical(1.0),
            1.355_817_948_331_400_4
        ));
        assert!(close(Unit::DegF.to_canonical(212.0), 100.0));
        assert!(close(Unit::DegF.to_canonical(-40.0), -40.0));
        assert!(close(Unit::Degree.to_canonical(180.0), PI));
    }

    #[test]
    fn from_canonical_inverts_to_canonical() {
        for (_, unit) in Unit::spellings() {
            for value in [-273.0, -1.5, 0.0, 0.25, 98.6, 1557.0] {
                let back = unit.to_canonical(unit.from_canonical(value));
                assert!(
                    (back - value).abs() <= 1e-12 * value.abs().max(1.0),
                    "{unit:?} {value}"
                );
            }
        }
    }

    #[test]
    fn unit_systems() {
        assert_eq!(Unit::DegF.system(), UnitSystem::Uscs);
        assert_eq!(Unit::NewtonMetre.system(), UnitSystem::Si);
        assert_eq!(Unit::Second.system(), UnitSystem::Neutral);
    }
}
