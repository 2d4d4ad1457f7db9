//! The segmenter's input: one run's channels as borrowed slices, SI-ish units, ISO-W frame.
//!
//! In: slices from whatever reader produced the run (`.dat`, `.mat`, the virtual machine).
//! Out: [`RunSignals::validate`] checks lengths and finiteness once, so the passes can index
//! freely. Deliberately not here: unit or frame conversion (readers and [`crate::frame`] do that);
//! this struct only documents and checks what it is given.

use crate::frame::{IsoW, TireChannels};

use super::SegmentError;

/// Tread surface temperatures (IR sensors), degC.
#[derive(Copy, Clone, Debug)]
pub struct TreadTemps<'a> {
    /// Inner shoulder, degC.
    pub inner_c: &'a [f64],
    /// Centre, degC.
    pub centre_c: &'a [f64],
    /// Outer shoulder, degC.
    pub outer_c: &'a [f64],
}

/// One run, column-wise. Every slice has one value per sample, in time order as recorded.
#[derive(Clone, Debug)]
pub struct RunSignals<'a> {
    /// Elapsed time, s (may jump at cut dwells; may repeat or step back in damaged files).
    pub et_s: &'a [f64],
    /// Road speed, km/h.
    pub speed_kph: &'a [f64],
    /// Inflation pressure, kPa.
    pub pressure_kpa: &'a [f64],
    /// Normal load, N, ISO-W: positive = compression.
    pub fz_n: &'a [f64],
    /// Slip angle, rad, ISO-W (= -SA of the SAE file).
    pub alpha_rad: &'a [f64],
    /// Inclination angle, rad (same sign in SAE and ISO-W).
    pub gamma_rad: &'a [f64],
    /// Longitudinal slip SL, -. May be all zero (cornering runs) or empty when `has_kappa` is
    /// false. When a file has no SL, pass Calspan's SR here: only the sweep shape is used.
    pub kappa: &'a [f64],
    /// Whether `kappa` carries a real slip signal.
    pub has_kappa: bool,
    /// Lateral force, N, ISO-W.
    pub fy_n: &'a [f64],
    /// Longitudinal force, N.
    pub fx_n: &'a [f64],
    /// Loaded radius, m.
    pub loaded_radius_m: &'a [f64],
    /// Tread temperatures, when the file has them.
    pub tread_temps: Option<TreadTemps<'a>>,
    /// Further channels checked by QC only (zeroed, saturated), e.g. `("mz_nm", &mz)`.
    pub extra: Vec<(&'a str, &'a [f64])>,
}

impl<'a> RunSignals<'a> {
    /// Borrow the frame-dependent channels from typed ISO-W columns (the frame cannot be wrong),
    /// plus the frame-free ones. `channels.kappa` may be empty (then `has_kappa` is false).
    pub fn from_iso_w(
        channels: &'a TireChannels<IsoW>,
        et_s: &'a [f64],
        speed_kph: &'a [f64],
        pressure_kpa: &'a [f64],
        loaded_radius_m: &'a [f64],
    ) -> Self {
        let has_kappa = channels.kappa.iter().any(|k| k.abs() > 0.0);
        let mut extra: Vec<(&'a str, &'a [f64])> = Vec::new();
        if !channels.mz_nm.is_empty() {
            extra.push(("mz_nm", &channels.mz_nm));
        }
        if !channels.mx_nm.is_empty() {
            extra.push(("mx_nm", &channels.mx_nm));
        }
        RunSignals {
            et_s,
            speed_kph,
            pressure_kpa,
            fz_n: &channels.fz_n,
            alpha_rad: &channels.alpha_rad,
            gamma_rad: &channels.gamma_rad,
            kappa: &channels.kappa,
            has_kappa,
            fy_n: &channels.fy_n,
            fx_n: &channels.fx_n,
            loaded_radius_m,
            tread_temps: None,
            extra,
        }
    }

    /// Number of samples (length of `et_s`).
    pub fn len(&self) -> usize {
        self.et_s.len()
    }

    /// True when the run has no samples.
    pub fn is_empty(&self) -> bool {
        self.et_s.is_empty()
    }

    /// Every named channel that must have one value per sample, in a fixed order.
    pub(crate) fn required(&self) -> Vec<(&'a str, &'a [f64])> {
        let mut out: Vec<(&'a str, &'a [f64])> = vec![
            ("et_s", self.et_s),
            ("speed_kph", self.speed_kph),
            ("pressure_kpa", self.pressure_kpa),
            ("fz_n", self.fz_n),
            ("alpha_rad", self.alpha_rad),
            ("gamma_rad", self.gamma_rad),
            ("fy_n", self.fy_n),
            ("fx_n", self.fx_n),
            ("loaded_radius_m", self.loaded_radius_m),
        ];
        if self.has_kappa {
            out.push(("kappa", self.kappa));
        }
        if let Some(t) = self.tread_temps {
            out.push(("tread_inner_c", t.inner_c));
            out.push(("tread_centre_c", t.centre_c));
            out.push(("tread_outer_c", t.outer_c));
        }
        out.extend(self.extra.iter().copied());
        out
    }

    /// Check equal lengths and finite values; the error names the channel and sample.
    pub fn validate(&self) -> Result<(), SegmentError> {
        let n = self.len();
        for (name, column) in self.required() {
            if column.len() != n {
                return Err(SegmentError::LengthMismatch {
                    channel: name.to_string(),
                    expected: n,
                    found: column.len(),
                });
            }
            if column.iter().fold(true, |ok, v| ok & v.is_finite()) {
                continue;
            }
            if let Some(index) = column.iter().position(|v| !v.is_finite()) {
                return Err(SegmentError::NonFinite {
                    channel: name.to_string(),
                    index,
                });
            }
        }
        Ok(())
    }
}
