//! The 22 TTC channels: names, the quantity each measures, which ones a run must have.
//!
//! In: a channel name from `.dat` line 2 or a `.mat` variable name. Out: a [`Channel`] (matched
//! case-insensitively, so `AmbTmp` is `AMBTMP`). Deliberately not here: units (see `units.rs`)
//! and what the readers do with unknown names (they keep them as extra channels).

use super::error::printable;
use super::units::{Quantity, Unit};

/// A channel Calspan TIRF records.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Channel {
    Et,
    V,
    N,
    Sa,
    Ia,
    Rl,
    Re,
    P,
    Fx,
    Fy,
    Fz,
    Mx,
    Mz,
    Nfx,
    Nfy,
    Rst,
    Tsti,
    Tstc,
    Tsto,
    Ambtmp,
    Sr,
    Sl,
}

/// A unit string that does not fit its channel; the message lists the accepted spellings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UnitError {
    /// A known unit of another quantity.
    #[error("unit {unit:?} measures {measures:?}, the channel needs {needs:?} (one of: {known})")]
    WrongQuantity {
        /// The unit as written.
        unit: String,
        /// What it measures.
        measures: Quantity,
        /// What the channel measures.
        needs: Quantity,
        /// The accepted spellings, comma-separated.
        known: String,
    },
    /// A spelling no reader knows.
    #[error("unknown unit string {unit:?} (expected one of: {known})")]
    Unknown {
        /// The unit as written, non-printable characters escaped.
        unit: String,
        /// The accepted spellings, comma-separated.
        known: String,
    },
}

impl Channel {
    /// All channels in the order TIRF files list them.
    pub const ALL: [Channel; 22] = [
        Channel::Et,
        Channel::V,
        Channel::N,
        Channel::Sa,
        Channel::Ia,
        Channel::Rl,
        Channel::Re,
        Channel::P,
        Channel::Fx,
        Channel::Fy,
        Channel::Fz,
        Channel::Mx,
        Channel::Mz,
        Channel::Nfx,
        Channel::Nfy,
        Channel::Rst,
        Channel::Tsti,
        Channel::Tstc,
        Channel::Tsto,
        Channel::Ambtmp,
        Channel::Sr,
        Channel::Sl,
    ];

    /// Channels without which a file is rejected: what a stored sample needs (time, speed,
    /// pressure, slip and inclination angle, the five forces and moments). The others are
    /// optional and come out as `None` when absent.
    pub const REQUIRED: [Channel; 10] = [
        Channel::Et,
        Channel::V,
        Channel::P,
        Channel::Sa,
        Channel::Ia,
        Channel::Fx,
        Channel::Fy,
        Channel::Fz,
        Channel::Mx,
        Channel::Mz,
    ];

    /// The name as TIRF writes it (upper case; `AMBTMP` for the ambient temperature).
    pub fn name(self) -> &'static str {
        match self {
            Channel::Et => "ET",
            Channel::V => "V",
            Channel::N => "N",
            Channel::Sa => "SA",
            Channel::Ia => "IA",
            Channel::Rl => "RL",
            Channel::Re => "RE",
            Channel::P => "P",
            Channel::Fx => "FX",
            Channel::Fy => "FY",
            Channel::Fz => "FZ",
            Channel::Mx => "MX",
            Channel::Mz => "MZ",
            Channel::Nfx => "NFX",
            Channel::Nfy => "NFY",
            Channel::Rst => "RST",
            Channel::Tsti => "TSTI",
            Channel::Tstc => "TSTC",
            Channel::Tsto => "TSTO",
            Channel::Ambtmp => "AMBTMP",
            Channel::Sr => "SR",
            Channel::Sl => "SL",
        }
    }

    /// Match a name case-insensitively, ignoring surrounding blanks.
    ///
    /// ```
    /// use tirebase_core::ttc::Channel;
    /// assert_eq!(Channel::from_name("AmbTmp"), Some(Channel::Ambtmp));
    /// assert_eq!(Channel::from_name(" fz "), Some(Channel::Fz));
    /// assert_eq!(Channel::from_name("RUN"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Channel> {
        let name = name.trim();
        Channel::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(name))
    }

    /// What the channel measures.
    pub fn quantity(self) -> Quantity {
        match self {
            Channel::Et => Quantity::Time,
            Channel::V => Quantity::RoadSpeed,
            Channel::N => Quantity::WheelSpeed,
            Channel::Sa | Channel::Ia => Quantity::Angle,
            Channel::Rl | Channel::Re => Quantity::Length,
            Channel::P => Quantity::Pressure,
            Channel::Fx | Channel::Fy | Channel::Fz => Quantity::Force,
            Channel::Mx | Channel::Mz => Quantity::Moment,
            Channel::Nfx | Channel::Nfy | Channel::Sr | Channel::Sl => Quantity::Ratio,
            Channel::Rst | Channel::Tsti | Channel::Tstc | Channel::Tsto | Channel::Ambtmp => {
                Quantity::Temperature
            }
        }
    }

    /// Whether a run file must contain this channel.
    pub fn is_required(self) -> bool {
        Channel::REQUIRED.contains(&self)
    }

    /// Parse a unit string written for this channel: it must be a known spelling of a unit of
    /// the channel's quantity. The error text lists the accepted spellings.
    ///
    /// ```
    /// use tirebase_core::ttc::{Channel, Unit};
    /// assert_eq!(Channel::Fz.parse_unit("lb"), Ok(Unit::PoundForce));
    /// let err = Channel::Fz.parse_unit("psi").unwrap_err();
    /// assert!(err.to_string().contains("measures Pressure"));
    /// ```
    pub fn parse_unit(self, unit_raw: &str) -> Result<Unit, UnitError> {
        let expected = self.quantity();
        let known: Vec<&str> = Unit::spellings()
            .filter(|(_, u)| u.quantity() == expected)
            .map(|(s, _)| s)
            .collect();
        match Unit::parse(unit_raw) {
            Some(unit) if unit.quantity() == expected => Ok(unit),
            Some(unit) => Err(UnitError::WrongQuantity {
                unit: unit_raw.to_string(),
                measures: unit.quantity(),
                needs: expected,
                known: known.join(", "),
            }),
            None => Err(UnitError::Unknown {
                unit: printable(unit_raw),
                known: known.join(", "),
            }),
        }
    }

    /// The unit assumed when a `.mat` file carries no `channel.units` entry for this channel:
    /// the SI spellings of `.mat` files (`sec kph rpm deg deg cm cm kPa N N N N-m N-m none none
    /// deg C ...`).
    pub fn si_fallback_unit(self) -> Unit {
        match self.quantity() {
            Quantity::Time => Unit::Second,
            Quantity::RoadSpeed => Unit::Kph,
            Quantity::WheelSpeed => Unit::Rpm,
            Quantity::Angle => Unit::Degree,
            Quantity::Length => Unit::Centimetre,
            Quantity::Pressure => Unit::KiloPascal,
            Quantity::Force => Unit::Newton,
            Quantity::Moment => Unit::NewtonMetre,
            Quantity::Temperature => Unit::DegC,
            Quantity::Ratio => Unit::Dimensionless,
        }
    }

    /// The fallback unit as `.mat` files spell it.
    pub fn si_fallback_spelling(self) -> &'static str {
        match self.si_fallback_unit() {
            Unit::Second => "sec",
            Unit::Kph => "kph",
            Unit::Rpm => "rpm",
            Unit::Degree => "deg",
            Unit::Centimetre => "cm",
            Unit::KiloPascal => "kPa",
            Unit::Newton => "N",
            Unit::NewtonMetre => "N-m",
            Unit::DegC => "deg C",
            _ => "none",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_fallback_units_fit_their_channel() {
        for channel in Channel::ALL {
            assert_eq!(Channel::from_name(channel.name()), Some(channel));
            assert_eq!(
                Channel::from_name(&channel.name().to_ascii_lowercase()),
                Some(channel)
            );
            let spelled = Unit::parse(channel.si_fallback_spelling()).unwrap();
            assert_eq!(spelled, channel.si_fallback_unit());
            assert_eq!(spelled.quantity(), channel.quantity(), "{channel:?}");
        }
    }
}
