//! The coefficient families of a PAC2002 fit, in dependency order (the MF 6.1 stage refines the
//! same families), and what data each PAC2002 coefficient needs to be identifiable.
//!
//! In: nothing (static tables) and the levels present in the data ([`Levels`]). Out: per family
//! its channel and coefficients; per coefficient whether the data determine it and, if not, why and at which
//! value it is held. Deliberately not here: bounds that depend on signs found in the data
//! (`initial`), the residuals (`problem`).

use crate::tire_model::Channel;
use crate::tire_model::Coef::{self, *};

/// A family of coefficients fitted together against one channel: the unit of a staged fit in
/// both the PAC2002 and the MF 6.1 stage (which chooses its own free coefficients per family).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Pure lateral force `Fy0` (cornering sweeps).
    Fy0,
    /// Pure aligning moment `Mz0` (cornering sweeps; needs `Fy0`).
    Mz0,
    /// Pure longitudinal force `Fx0` (drive/brake sweeps).
    Fx0,
    /// Combined-slip longitudinal force `Fx = Gxa Fx0` (combined sweeps; needs `Fx0`).
    Fx,
    /// Combined-slip lateral force `Fy = Gyk Fy0 + SVyk` (drive/brake and combined; needs `Fy0`).
    Fy,
    /// Combined-slip aligning moment (the `s Fx` arm; needs all of the above).
    Mz,
    /// Overturning moment (all sweeps; needs `Fy`).
    Mx,
    /// Rolling resistance moment (TTC records no `My`: always a placeholder).
    My,
}

impl Family {
    /// Every family, in fit order.
    pub const FIT_ORDER: [Family; 8] = [
        Family::Fy0,
        Family::Mz0,
        Family::Fx0,
        Family::Fx,
        Family::Fy,
        Family::Mz,
        Family::Mx,
        Family::My,
    ];

    /// The families with a measured channel, in fit order: every family but `My` (TTC records no
    /// rolling resistance moment, so its coefficients are never fitted to data).
    pub const MEASURED: [Family; 7] = {
        let [fy0, mz0, fx0, fx, fy, mz, mx, _my] = Family::FIT_ORDER;
        [fy0, mz0, fx0, fx, fy, mz, mx]
    };

    /// Channel name used in the quality table (`Fy0`, `Mz0`, `Fx0`, `Fx`, `Fy`, `Mz`, `Mx`, `My`).
    pub const fn as_str(self) -> &'static str {
        match self {
            Family::Fy0 => "Fy0",
            Family::Mz0 => "Mz0",
            Family::Fx0 => "Fx0",
            Family::Fx => "Fx",
            Family::Fy => "Fy",
            Family::Mz => "Mz",
            Family::Mx => "Mx",
            Family::My => "My",
        }
    }

    /// The model channel the family is fitted against.
    pub const fn channel(self) -> Channel {
        match self {
            Family::Fy0 => Channel::Fy0,
            Family::Mz0 => Channel::Mz0,
            Family::Fx0 => Channel::Fx0,
            Family::Fx => Channel::Fx,
            Family::Fy => Channel::Fy,
            Family::Mz => Channel::Mz,
            Family::Mx => Channel::Mx,
            Family::My => Channel::My,
        }
    }

    /// The PAC2002 coefficients the family's own equations introduce ([`Channel::family`]).
    pub const fn coefficients(self) -> &'static [Coef] {
        self.channel().family()
    }
}

/// The distinct levels present in a family's data.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Levels {
    /// Distinct nominal loads.
    pub loads: usize,
    /// Distinct nominal inclination angles.
    pub cambers: usize,
    /// Inclination angles of both signs present (beyond +-0.25 deg).
    pub camber_both_signs: bool,
    /// Distinct nominal slip angles of the slip-ratio sweeps (0 included).
    pub alphas: usize,
    /// Slip-ratio sweeps at slip angles of both signs (beyond +-0.25 deg).
    pub alpha_both_signs: bool,
}

/// Data a coefficient needs: distinct loads, cambers, slip-angle levels, camber signs.
#[derive(Copy, Clone, Debug)]
struct Needs {
    loads: usize,
    cambers: usize,
    alphas: usize,
    camber_both_signs: bool,
    alpha_both_signs: bool,
}

const fn needs(loads: usize, cambers: usize) -> Needs {
    Needs {
        loads,
        cambers,
        alphas: 0,
        camber_both_signs: false,
        alpha_both_signs: false,
    }
}

fn needs_of(c: Coef) -> Needs {
    match c {
        PDY2 | PEY2 | PKY2 | PHY2 | PVY2 => needs(2, 1),
        PDY3 | PEY4 | PKY3 | PHY3 | PVY3 => needs(1, 2),
        PVY4 => needs(2, 2),
        QBZ2 | QBZ10 | QDZ2 | QDZ7 | QEZ2 | QHZ2 => needs(2, 1),
        QBZ3 | QEZ3 => needs(3, 1),
        QBZ4 | QDZ3 | QDZ8 | QEZ5 | QHZ3 => needs(1, 2),
        QBZ5 => Needs {
            camber_both_signs: true,
            ..needs(1, 2)
        },
        QDZ4 => needs(1, 3),
        QDZ9 | QHZ4 => needs(2, 2),
        PDX2 | PEX2 | PKX2 | PHX2 | PVX2 => needs(2, 1),
        PEX3 | PKX3 => needs(3, 1),
        PDX3 => needs(1, 2),
        REX2 | REY2 | RHY2 | RVY2 => needs(2, 1),
        RVY3 => needs(1, 2),
        RBY2 | RVY4 => Needs {
            alphas: 2,
            ..needs(1, 1)
        },
        // Shifts of the combined-slip weighting in slip angle: with combined sweeps on one
        // side of zero slip angle only (TTC's SA -3, -6) a shift trades with the slope.
        RBY3 | RHX1 => Needs {
            alphas: 3,
            alpha_both_signs: true,
            ..needs(1, 1)
        },
        SSZ3 => needs(1, 2),
        SSZ4 => needs(2, 2),
        QSX2 => needs(1, 2),
        QSX7 | QSX10 => needs(1, 2),
        _ => needs(1, 1),
    }
}

/// Why `c` cannot be determined from data with `levels`, or `None` if it can.
pub fn unidentifiable(c: Coef, levels: &Levels) -> Option<String> {
    let n = needs_of(c);
    if levels.loads < n.loads {
        return Some(format!(
            "needs {} load levels, data have {}",
            n.loads, levels.loads
        ));
    }
    if levels.cambers < n.cambers {
        return Some(format!(
            "needs {} inclination levels, data have {}",
            n.cambers, levels.cambers
        ));
    }
    if n.camber_both_signs && !levels.camber_both_signs {
        return Some("inclination of one sign only: not separable from QBZ4".to_string());
    }
    if n.alpha_both_signs && !levels.alpha_both_signs {
        return Some(
            "combined slip at slip angles of one sign only: a shift is not separable from the \
             weighting's slope"
                .to_string(),
        );
    }
    if levels.alphas < n.alphas {
        return Some(format!(
            "needs {} slip-angle levels in the slip-ratio sweeps, data have {}",
            n.alphas, levels.alphas
        ));
    }
    None
}

/// True for a camber term: a coefficient that needs two or more inclination levels, or
/// inclinations of both signs, to be identified.
#[cfg(test)]
pub fn is_camber_term(c: Coef) -> bool {
    let n = needs_of(c);
    n.cambers >= 2 || n.camber_both_signs
}

/// The value an unidentifiable coefficient is held at: neutral for load/camber variations,
/// a typical value for shape parameters the data cannot reach.
pub fn held_value(c: Coef) -> f64 {
    match c {
        PKY2 => 2.0,
        QSX4 => Coef::QSX4.default_value(),
        QSX5 => Coef::QSX5.default_value(),
        QSX6 => Coef::QSX6.default_value(),
        QSX9 => Coef::QSX9.default_value(),
        QSX11 => Coef::QSX11.default_value(),
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn families_partition_the_model_coefficients_they_name() {
        let mut all: Vec<Coef> = Family::FIT_ORDER
            .iter()
            .flat_map(|f| f.coefficients().iter().copied())
            .collect();
        let n = all.len();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), n, "a coefficient is in two families");
    }

    #[test]
    fn one_camber_sign_holds_qbz5() {
        let levels = Levels {
            loads: 5,
            cambers: 5,
            camber_both_signs: false,
            alphas: 3,
            alpha_both_signs: false,
        };
        assert!(unidentifiable(QBZ5, &levels).is_some());
        assert!(unidentifiable(QBZ4, &levels).is_none());
        let one_load = Levels { loads: 1, ..levels };
        assert!(unidentifiable(PDY2, &one_load).is_some());
    }
}
