//! `[UNITS]` of a `.tir` file and which PAC2002 keys carry a physical dimension.
//!
//! In: unit names as `.tir` files write them (`'meter'`, `'mm'`, `'pound_force'`, `'deg'`,
//! `'psi'`, ...; case-insensitive). Out: [`Units`] (SI factors per base quantity) and
//! [`dimension`] of each coefficient, so that `value_SI = value_file * Units::factor(dim)`.
//!
//! The rule (Adams / MF-Tyre convention): `[UNITS]` applies to the dimensional parameters only:
//! speeds (`LONGVL`, `VXLOW`), sizes (`UNLOADED_RADIUS`, `WIDTH`, `RIM_RADIUS`, `RIM_WIDTH`),
//! loads (`FNOMIN`, `FZMIN`, `FZMAX`), `VERTICAL_STIFFNESS`, `VERTICAL_DAMPING`, the angle
//! ranges, `MBELT` and the pressures. Magic Formula coefficients (`P*`, `Q*`, `R*`, `S*`, the
//! scaling factors `L*`) are dimensionless by construction (loads enter as `Fz/Fz0`, lengths as
//! multiples of `R0`) and are defined per radian whatever `ANGLE` says; they are never
//! converted. Placeholders `|x| >= 1e20` ("no limit", e.g. `FZMAX = 1e30`) are not converted.
//! Deliberately not here: reading lines (see `read.rs`).

use super::super::params::Coef;

/// Values at or beyond this magnitude are "no limit" placeholders, never unit-converted.
pub const PLACEHOLDER: f64 = 1e20;

/// Physical dimension of a `.tir` key.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Dim {
    /// Dimensionless (every Magic Formula coefficient).
    None,
    /// Length.
    Length,
    /// Force.
    Force,
    /// Angle.
    Angle,
    /// Mass.
    Mass,
    /// Length / time.
    Speed,
    /// Force / length.
    Stiffness,
    /// Force * time / length.
    Damping,
    /// Pressure.
    Pressure,
}

/// The dimension of a coefficient's value in a `.tir` file.
pub const fn dimension(c: Coef) -> Dim {
    use Coef::*;
    match c {
        LONGVL | VXLOW => Dim::Speed,
        UNLOADED_RADIUS | WIDTH | RIM_RADIUS | RIM_WIDTH => Dim::Length,
        FNOMIN | FZMIN | FZMAX => Dim::Force,
        VERTICAL_STIFFNESS => Dim::Stiffness,
        VERTICAL_DAMPING => Dim::Damping,
        ALPMIN | ALPMAX | CAMMIN | CAMMAX => Dim::Angle,
        MBELT => Dim::Mass,
        _ => Dim::None,
    }
}

/// SI value of one unit of each base quantity as the file declares it.
#[derive(Clone, Debug, PartialEq)]
pub struct Units {
    /// Metres per file length unit.
    pub length_m: f64,
    /// Newtons per file force unit.
    pub force_n: f64,
    /// Radians per file angle unit.
    pub angle_rad: f64,
    /// Kilograms per file mass unit.
    pub mass_kg: f64,
    /// Seconds per file time unit.
    pub time_s: f64,
    /// Pascals per file pressure unit (`None`: force unit / length unit squared).
    pub pressure_pa: Option<f64>,
    /// The names as the file wrote them, in the order LENGTH, FORCE, ANGLE, MASS, TIME,
    /// PRESSURE (`None` where the file did not say).
    pub names: [Option<String>; 6],
}

/// The `[UNITS]` keys, in the order of [`Units::names`].
pub const UNIT_KEYS: [&str; 6] = ["LENGTH", "FORCE", "ANGLE", "MASS", "TIME", "PRESSURE"];

impl Units {
    /// SI (what the writer declares and what a file without `[UNITS]` is taken to be).
    pub const SI: Units = Units {
        length_m: 1.0,
        force_n: 1.0,
        angle_rad: 1.0,
        mass_kg: 1.0,
        time_s: 1.0,
        pressure_pa: None,
        names: [None, None, None, None, None, None],
    };

    /// Is every factor 1 (nothing to convert)?
    pub fn is_si(&self) -> bool {
        let one = |x: f64| (x - 1.0).abs() < 1e-15;
        one(self.length_m)
            && one(self.force_n)
            && one(self.angle_rad)
            && one(self.mass_kg)
            && one(self.time_s)
            && one(self
                .pressure_pa
                .unwrap_or(self.force_n / (self.length_m * self.length_m)))
    }

    /// Set one `[UNITS]` key from its value; `Err` with a one-line reason for an unknown unit,
    /// `Ok(false)` when the key is not a unit key.
    pub fn set(&mut self, key: &str, value: &str) -> Result<bool, UnknownUnit> {
        let Some(slot) = UNIT_KEYS.iter().position(|k| k.eq_ignore_ascii_case(key)) else {
            return Ok(false);
        };
        let factor = unit_factor(slot, value).ok_or_else(|| UnknownUnit {
            key: UNIT_KEYS[slot],
            value: value.to_string(),
            known: KNOWN[slot],
        })?;
        match slot {
            0 => self.length_m = factor,
            1 => self.force_n = factor,
            2 => self.angle_rad = factor,
            3 => self.mass_kg = factor,
            4 => self.time_s = factor,
            _ => self.pressure_pa = Some(factor),
        }
        self.names[slot] = Some(value.to_string());
        Ok(true)
    }

    /// SI value of one file unit of dimension `dim`.
    pub fn factor(&self, dim: Dim) -> f64 {
        match dim {
            Dim::None => 1.0,
            Dim::Length => self.length_m,
            Dim::Force => self.force_n,
            Dim::Angle => self.angle_rad,
            Dim::Mass => self.mass_kg,
            Dim::Speed => self.length_m / self.time_s,
            Dim::Stiffness => self.force_n / self.length_m,
            Dim::Damping => self.force_n * self.time_s / self.length_m,
            Dim::Pressure => self
                .pressure_pa
                .unwrap_or(self.force_n / (self.length_m * self.length_m)),
        }
    }

    /// A file value of dimension `dim` in SI (placeholders `|x| >= 1e20` unchanged).
    pub fn to_si(&self, x: f64, dim: Dim) -> f64 {
        let f = self.factor(dim);
        let inverse = 1.0 / f;
        if x.abs() >= PLACEHOLDER {
            x
        } else if f < 1.0 && (inverse - inverse.round()).abs() < 1e-9 * inverse {
            // mm, cm, ms, ...: dividing by the exact integer gives the correctly rounded
            // value (204.5 mm -> 0.2045 m, not 0.20450000000000002).
            x / inverse.round()
        } else {
            x * f
        }
    }
}

impl Default for Units {
    fn default() -> Self {
        Units::SI
    }
}

/// A `[UNITS]` value that is not a known unit of its key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unknown {key} unit '{value}' (known: {known})")]
pub struct UnknownUnit {
    /// The unit key (`LENGTH`, `FORCE`, ...).
    pub key: &'static str,
    /// The value as written.
    pub value: String,
    /// The accepted spellings.
    pub known: &'static str,
}

/// Accepted spellings per unit key (for error messages).
const KNOWN: [&str; 6] = [
    "meter, millimeter, centimeter, kilometer, inch, foot, mile",
    "newton, kilonewton, millinewton, dekanewton, pound_force, kpound_force, kilogram_force, ounce_force, dyne",
    "radians, degrees, grad",
    "kg, gram, tonne, pound_mass, kpound_mass, slug, ounce_mass",
    "second, millisecond, minute, hour",
    "pascal, kilopascal, megapascal, bar, millibar, psi, ksi, atm",
];

/// SI factor of a unit name for unit key `slot` (index into [`UNIT_KEYS`]).
fn unit_factor(slot: usize, name: &str) -> Option<f64> {
    let n: String = name
        .trim()
        .to_ascii_lowercase()
        .chars()
        .filter(|c| !matches!(c, ' ' | '_' | '-' | '.'))
        .collect();
    let lbf = 4.448_221_615_260_5;
    let f = match (slot, n.as_str()) {
        (0, "meter" | "meters" | "metre" | "metres" | "m") => 1.0,
        (0, "millimeter" | "millimeters" | "millimetre" | "millimetres" | "mm") => 1e-3,
        (0, "centimeter" | "centimeters" | "centimetre" | "centimetres" | "cm") => 1e-2,
        (0, "kilometer" | "kilometers" | "kilometre" | "kilometres" | "km") => 1e3,
        (0, "inch" | "inches" | "in") => 0.0254,
        (0, "foot" | "feet" | "ft") => 0.3048,
        (0, "mile" | "miles" | "mi") => 1609.344,
        (1, "newton" | "newtons" | "n") => 1.0,
        (1, "kilonewton" | "kilonewtons" | "knewton" | "kn") => 1e3,
        (1, "millinewton" | "millinewtons" | "mn") => 1e-3,
        (1, "dekanewton" | "decanewton" | "dan") => 10.0,
        (1, "poundforce" | "poundf" | "lbf" | "lbsf" | "pound" | "pounds" | "lb" | "lbs") => lbf,
        (1, "kpoundforce" | "kpoundf" | "kip" | "kips" | "klbf") => 1e3 * lbf,
        (1, "kilogramforce" | "kgforce" | "kgf") => 9.806_65,
        (1, "ounceforce" | "ozf") => lbf / 16.0,
        (1, "dyne" | "dyn") => 1e-5,
        (2, "radian" | "radians" | "rad") => 1.0,
        (2, "degree" | "degrees" | "deg") => std::f64::consts::PI / 180.0,
        (2, "grad" | "gradian" | "gon") => std::f64::consts::PI / 200.0,
        (3, "kg" | "kilogram" | "kilograms") => 1.0,
        (3, "gram" | "grams" | "g") => 1e-3,
        (3, "tonne" | "tonnes" | "t" | "megagram") => 1e3,
        (3, "poundmass" | "poundm" | "lbm" | "pound" | "pounds" | "lb" | "lbs") => 0.453_592_37,
        (3, "kpoundmass" | "kpoundm") => 453.592_37,
        (3, "slug" | "slugs") => 14.593_902_937_206_364,
        (3, "ouncemass" | "ouncem" | "oz") => 0.028_349_523_125,
        (4, "second" | "seconds" | "sec" | "s") => 1.0,
        (4, "millisecond" | "milliseconds" | "msec" | "ms") => 1e-3,
        (4, "minute" | "minutes" | "min") => 60.0,
        (4, "hour" | "hours" | "h" | "hr") => 3600.0,
        (5, "pascal" | "pascals" | "pa" | "nm2" | "n/m2" | "n/m^2") => 1.0,
        (5, "kilopascal" | "kilopascals" | "kpa") => 1e3,
        (5, "megapascal" | "megapascals" | "mpa" | "nmm2" | "n/mm2" | "n/mm^2") => 1e6,
        (5, "bar") => 1e5,
        (5, "millibar" | "mbar") => 1e2,
        (5, "psi" | "lbf/in2" | "lbf/in^2") => lbf / (0.0254 * 0.0254),
        (5, "ksi") => 1e3 * lbf / (0.0254 * 0.0254),
        (5, "atm" | "atmosphere") => 101_325.0,
        _ => return None,
    };
    Some(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_names_are_case_and_punctuation_insensitive() {
        let mut u = Units::SI;
        assert_eq!(
            u.set("length", "'ignored'").unwrap_err().to_string(),
            "unknown LENGTH unit ''ignored'' (known: meter, millimeter, centimeter, kilometer, inch, foot, mile)"
        );
        assert_eq!(u.set("LENGTH", "Millimeter"), Ok(true));
        assert_eq!(u.set("FORCE", "Pound_Force"), Ok(true));
        assert_eq!(u.set("ANGLE", "DEG"), Ok(true));
        assert_eq!(u.set("COLOUR", "red"), Ok(false));
        assert!((u.factor(Dim::Length) - 1e-3).abs() < 1e-18);
        assert!((u.factor(Dim::Stiffness) - 4.4482216152605e3).abs() < 1e-9);
        assert!((u.factor(Dim::Angle) - 0.017453292519943295).abs() < 1e-18);
        assert!(!u.is_si());
        assert_eq!(u.to_si(1e30, Dim::Force), 1e30);
        assert_eq!(u.to_si(204.5, Dim::Length), 0.2045);
        assert!(Units::SI.is_si());
    }

    #[test]
    fn only_dimensional_keys_convert() {
        assert_eq!(dimension(Coef::PDY1), Dim::None);
        assert_eq!(dimension(Coef::PHY3), Dim::None);
        assert_eq!(dimension(Coef::FNOMIN), Dim::Force);
        assert_eq!(dimension(Coef::ALPMAX), Dim::Angle);
        assert_eq!(dimension(Coef::LONGVL), Dim::Speed);
    }
}
