//! Tire axis frames as types: the one place where SAE and ISO-W (TYDEX W) meet.
//!
//! TTC files are in SAE J2047 axes (x forward, y right, z down: loads are negative). PAC2002 and
//! everything tirebase stores use ISO-W / TYDEX W (x forward, y left, z up: `Fz > 0` in
//! compression). ISO-W is SAE turned 180° about x, so components along y and z and angles about z
//! change sign, components along x and angles about x do not:
//!
//! | quantity | ISO-W from SAE |
//! |---|---|
//! | `Fx`, `Mx`, slip ratio, inclination angle | same |
//! | `Fy`, `Fz`, `My`, `Mz`, slip angle | negated |
//!
//! Column sets carry their frame as a type parameter, so a value cannot be used in the wrong
//! frame by accident: the fitter takes `TireChannels<IsoW>`, the TTC readers produce
//! `TireChannels<Sae>` and the only way across is [`TireChannels::into_iso_w`] /
//! [`TireChannels::into_sae`]. Deliberately not here: unit conversion (that is the readers' job,
//! and happens before the frame change).

use std::marker::PhantomData;

/// Marker: SAE J2047 tire axes (z down), as Calspan TIRF records them.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Sae;

/// Marker: ISO-W / TYDEX W tire axes (z up), as PAC2002 and tirebase's store use them.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct IsoW;

/// A tire axis frame (sealed to [`Sae`] and [`IsoW`]).
pub trait Frame: sealed::Sealed + Copy + std::fmt::Debug + Send + Sync + 'static {
    /// Short name used in messages and metadata.
    const NAME: &'static str;
}

impl Frame for Sae {
    const NAME: &'static str = "SAE";
}

impl Frame for IsoW {
    const NAME: &'static str = "ISO-W";
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::Sae {}
    impl Sealed for super::IsoW {}
}

/// The frame-dependent channels of a run, column-wise, SI units, in frame `F`.
///
/// Frame-independent channels (speed, pressure, radii, temperatures, slip ratio as a magnitude
/// convention shared by both frames) are not here; they need no conversion.
#[derive(Clone, Debug, PartialEq)]
pub struct TireChannels<F: Frame> {
    /// Longitudinal force, N (same in both frames).
    pub fx_n: Vec<f64>,
    /// Lateral force, N (sign flips between frames).
    pub fy_n: Vec<f64>,
    /// Vertical force, N (SAE: negative under load; ISO-W: positive under load).
    pub fz_n: Vec<f64>,
    /// Overturning moment, N m (same in both frames).
    pub mx_nm: Vec<f64>,
    /// Rolling resistance moment, N m (sign flips); TTC files do not record it, so often empty.
    pub my_nm: Vec<f64>,
    /// Aligning moment, N m (sign flips).
    pub mz_nm: Vec<f64>,
    /// Slip angle, rad (sign flips).
    pub alpha_rad: Vec<f64>,
    /// Inclination angle, rad (same in both frames: top of wheel to the right is positive).
    pub gamma_rad: Vec<f64>,
    /// Longitudinal slip (same in both frames).
    pub kappa: Vec<f64>,
    frame: PhantomData<F>,
}

impl<F: Frame> TireChannels<F> {
    /// Assemble channels already known to be in frame `F`. Columns may be empty when a file does
    /// not carry the channel; non-empty columns must all have the same length.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        fx_n: Vec<f64>,
        fy_n: Vec<f64>,
        fz_n: Vec<f64>,
        mx_nm: Vec<f64>,
        my_nm: Vec<f64>,
        mz_nm: Vec<f64>,
        alpha_rad: Vec<f64>,
        gamma_rad: Vec<f64>,
        kappa: Vec<f64>,
    ) -> Self {
        TireChannels {
            fx_n,
            fy_n,
            fz_n,
            mx_nm,
            my_nm,
            mz_nm,
            alpha_rad,
            gamma_rad,
            kappa,
            frame: PhantomData,
        }
    }

    /// The frame's name, for messages and metadata.
    pub fn frame_name(&self) -> &'static str {
        F::NAME
    }

    /// Flip the sign of every frame-dependent column and relabel the frame.
    fn flip<G: Frame>(mut self) -> TireChannels<G> {
        for column in [
            &mut self.fy_n,
            &mut self.fz_n,
            &mut self.my_nm,
            &mut self.mz_nm,
            &mut self.alpha_rad,
        ] {
            column.iter_mut().for_each(|v| *v = -*v);
        }
        TireChannels {
            fx_n: self.fx_n,
            fy_n: self.fy_n,
            fz_n: self.fz_n,
            mx_nm: self.mx_nm,
            my_nm: self.my_nm,
            mz_nm: self.mz_nm,
            alpha_rad: self.alpha_rad,
            gamma_rad: self.gamma_rad,
            kappa: self.kappa,
            frame: PhantomData,
        }
    }
}

impl TireChannels<Sae> {
    /// SAE -> ISO-W: negate Fy, Fz, My, Mz and the slip angle.
    pub fn into_iso_w(self) -> TireChannels<IsoW> {
        self.flip()
    }
}

impl TireChannels<IsoW> {
    /// ISO-W -> SAE: negate Fy, Fz, My, Mz and the slip angle.
    pub fn into_sae(self) -> TireChannels<Sae> {
        self.flip()
    }
}

/// One tire state (forces, moments, slips) in frame `F`; the scalar twin of [`TireChannels`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TirePoint<F: Frame> {
    /// Longitudinal force, N.
    pub fx_n: f64,
    /// Lateral force, N.
    pub fy_n: f64,
    /// Vertical force, N.
    pub fz_n: f64,
    /// Overturning moment, N m.
    pub mx_nm: f64,
    /// Rolling resistance moment, N m.
    pub my_nm: f64,
    /// Aligning moment, N m.
    pub mz_nm: f64,
    /// Slip angle, rad.
    pub alpha_rad: f64,
    /// Inclination angle, rad.
    pub gamma_rad: f64,
    /// Longitudinal slip.
    pub kappa: f64,
    frame: PhantomData<F>,
}

impl<F: Frame> TirePoint<F> {
    /// A point known to be in frame `F`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        fx_n: f64,
        fy_n: f64,
        fz_n: f64,
        mx_nm: f64,
        my_nm: f64,
        mz_nm: f64,
        alpha_rad: f64,
        gamma_rad: f64,
        kappa: f64,
    ) -> Self {
        TirePoint {
            fx_n,
            fy_n,
            fz_n,
            mx_nm,
            my_nm,
            mz_nm,
            alpha_rad,
            gamma_rad,
            kappa,
            frame: PhantomData,
        }
    }

    fn flip<G: Frame>(self) -> TirePoint<G> {
        TirePoint {
            fx_n: self.fx_n,
            fy_n: -self.fy_n,
            fz_n: -self.fz_n,
            mx_nm: self.mx_nm,
            my_nm: -self.my_nm,
            mz_nm: -self.mz_nm,
            alpha_rad: -self.alpha_rad,
            gamma_rad: self.gamma_rad,
            kappa: self.kappa,
            frame: PhantomData,
        }
    }
}

impl TirePoint<Sae> {
    /// SAE -> ISO-W.
    pub fn into_iso_w(self) -> TirePoint<IsoW> {
        self.flip()
    }
}

impl TirePoint<IsoW> {
    /// ISO-W -> SAE.
    pub fn into_sae(self) -> TirePoint<Sae> {
        self.flip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sae_to_iso_w_negates_y_z_and_slip_angle_only() {
        let sae = TirePoint::<Sae>::new(1.0, 2.0, -3.0, 4.0, 5.0, 6.0, 0.1, 0.02, 0.05);
        let iso = sae.into_iso_w();
        assert_eq!(
            (
                iso.fx_n, iso.fy_n, iso.fz_n, iso.mx_nm, iso.my_nm, iso.mz_nm
            ),
            (1.0, -2.0, 3.0, 4.0, -5.0, -6.0)
        );
        assert_eq!(
            (iso.alpha_rad, iso.gamma_rad, iso.kappa),
            (-0.1, 0.02, 0.05)
        );
        assert_eq!(iso.into_sae(), sae);
    }

    #[test]
    fn columns_round_trip() {
        let sae = TireChannels::<Sae>::new(
            vec![1.0],
            vec![2.0],
            vec![-1000.0],
            vec![3.0],
            vec![],
            vec![4.0],
            vec![0.1],
            vec![0.05],
            vec![0.0],
        );
        let iso = sae.clone().into_iso_w();
        assert_eq!(iso.fz_n, vec![1000.0]);
        assert_eq!(iso.alpha_rad, vec![-0.1]);
        assert_eq!(iso.frame_name(), "ISO-W");
        assert_eq!(iso.into_sae(), sae);
    }
}
