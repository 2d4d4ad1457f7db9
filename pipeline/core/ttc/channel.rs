//! The 22 TTC channels: names, the quantity each measures, which ones a run must have.
//!
//! In: a channel name from `.dat` line 2 or a `.mat` variable name. Out: a [`TtcChannel`]
//! (matched case-insensitively, so `AmbTmp` is `AMBTMP`). Deliberately not here: units (see
//! `units.rs`) and what the readers do with unknown names (they keep them as extra channels).
//! Not [`crate::tire_model::Channel`], which is a model output a fit evaluates.

use super::error::printable;
use super::units::{Quantity, Unit};

/// A channel Calspan TIRF records.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TtcChannel {
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

impl TtcChannel {
    /// All channels in the order TIRF files list them.
    pub const ALL: [TtcChannel; 22] = [
        TtcChannel::Et,
        TtcChannel::V,
        TtcChannel::N,
        TtcChannel::Sa,
        TtcChannel::Ia,
        TtcChannel::Rl,
        TtcChannel::Re,
        TtcChannel::P,
        TtcChannel::Fx,
        TtcChannel::Fy,
        TtcChannel::Fz,
        TtcChannel::Mx,
        TtcChannel::Mz,
        TtcChannel::Nfx,
        TtcChannel::Nfy,
        TtcChannel::Rst,
        TtcChannel::Tsti,
        TtcChannel::Tstc,
        TtcChannel::Tsto,
        TtcChannel::Ambtmp,
        TtcChannel::Sr,
        TtcChannel::Sl,
    ];

    /// Channels without which a file is rejected: what a stored sample needs (time, speed,
    /// pressure, slip and inclination angle, the five forces and moments). The others are
    /// optional and come out as `None` when absent.
    pub const REQUIRED: [TtcChannel; 10] = [
        TtcChannel::Et,
        TtcChannel::V,
        TtcChannel::P,
        TtcChannel::Sa,
        TtcChannel::Ia,
        TtcChannel::Fx,
        TtcChannel::Fy,
        TtcChannel::Fz,
        TtcChannel::Mx,
        TtcChannel::Mz,
    ];

    /// The name as TIRF writes it (upper case; `AMBTMP` for the ambient temperature).
    pub fn name(self) -> &'static str {
        match self {
            TtcChannel::Et => "ET",
            TtcChannel::V => "V",
            TtcChannel::N => "N",
            TtcChannel::Sa => "SA",
            TtcChannel::Ia => "IA",
            TtcChannel::Rl => "RL",
            TtcChannel::Re => "RE",
            TtcChannel::P => "P",
            TtcChannel::Fx => "FX",
            TtcChannel::Fy => "FY",
            TtcChannel::Fz => "FZ",
            TtcChannel::Mx => "MX",
            TtcChannel::Mz => "MZ",
            TtcChannel::Nfx => "NFX",
            TtcChannel::Nfy => "NFY",
            TtcChannel::Rst => "RST",
            TtcChannel::Tsti => "TSTI",
            TtcChannel::Tstc => "TSTC",
            TtcChannel::Tsto => "TSTO",
            TtcChannel::Ambtmp => "AMBTMP",
            TtcChannel::Sr => "SR",
            TtcChannel::Sl => "SL",
        }
    }

    /// Match a name case-insensitively, ignoring surrounding blanks.
    ///
    /// ```
    /// use tirebase_core::ttc::TtcChannel;
    /// assert_eq!(TtcChannel::from_name("AmbTmp"), Some(TtcChannel::Ambtmp));
    /// assert_eq!(TtcChannel::from_name(" fz "), Some(TtcChannel::Fz));
    /// assert_eq!(TtcChannel::from_name("RUN"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<TtcChannel> {
        let name = name.trim();
        TtcChannel::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(name))
    }

    /// What the channel measures.
    pub fn quantity(self) -> Quantity {
        match self {
            TtcChannel::Et => Quantity::Time,
            TtcChannel::V => Quantity::RoadSpeed,
            TtcChannel::N => Quantity::WheelSpeed,
            TtcChannel::Sa | TtcChannel::Ia => Quantity::Angle,
            TtcChannel::Rl | TtcChannel::Re => Quantity::Length,
            TtcChannel::P => Quantity::Pressure,
            TtcChannel::Fx | TtcChannel::Fy | TtcChannel::Fz => Quantity::Force,
            TtcChannel::Mx | TtcChannel::Mz => Quantity::Moment,
            TtcChannel::Nfx | TtcChannel::Nfy | TtcChannel::Sr | TtcChannel::Sl => Quantity::Ratio,
            TtcChannel::Rst
            | TtcChannel::Tsti
            | TtcChannel::Tstc
            | TtcChannel::Tsto
            | TtcChannel::Ambtmp => Quantity::Temperature,
        }
    }

    /// Whether a run file must contain this channel.
    pub fn is_required(self) -> bool {
        TtcChannel::REQUIRED.contains(&self)
    }

    /// Parse a unit string written for this channel: it must be a known spelling of a unit of
    /// the channel's quantity. The error text lists the accepted spellings.
    ///
    /// ```
    /// use tirebase_core::ttc::{TtcChannel, Unit};
    /// assert_eq!(TtcChannel::Fz.parse_unit("lb"), Ok(Unit::PoundForce));
    /// let err = TtcChannel::Fz.parse_unit("psi").unwrap_err();
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
        for channel in TtcChannel::ALL {
            assert_eq!(TtcChannel::from_name(channel.name()), Some(channel));
            assert_eq!(
                TtcChannel::from_name(&channel.name().to_ascii_lowercase()),
                Some(channel)
            );
            let spelled = Unit::parse(channel.si_fallback_spelling()).unwrap();
            assert_eq!(spelled, channel.si_fallback_unit());
            assert_eq!(spelled.quantity(), channel.quantity(), "{channel:?}");
        }
    }
}
