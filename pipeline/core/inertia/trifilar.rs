//! Trifilar (three-wire) torsional pendulum (methods section 3).
//!
//! In: the rig geometry (attachment radii top and bottom, vertical length between attachment
//! planes), local g, suspended masses and small-amplitude periods. Out: system inertia
//! `I = m g R_a R_b T^2 / (4 pi^2 h)`, the object inertia with the platform subtracted, and the
//! trifilar amplitude correction `T/T0 = 1 + (phi0^2/16)(1 - 3R^2/h^2 + 4 m R^4/(I h^2))`, which
//! is not the pendulum one. Deliberately no CG-offset (parallel axis) correction: the object is
//! assumed centred, as the rig requires.

use std::f64::consts::PI;

/// Trifilar rig geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrifilarRig {
    /// Radius of the top attachment circle (m).
    pub radius_top_m: f64,
    /// Radius of the platform attachment circle (m).
    pub radius_bottom_m: f64,
    /// Vertical distance between the attachment planes, loaded (m).
    pub length_m: f64,
    /// Local gravitational acceleration (m/s^2).
    pub g_m_s2: f64,
}

impl TrifilarRig {
    /// `K = g R_a R_b / (4 pi^2 h)` (m^2/s^2), so that `I = K m T^2`.
    pub fn k_constant(&self) -> f64 {
        self.g_m_s2 * self.radius_top_m * self.radius_bottom_m / (4.0 * PI * PI * self.length_m)
    }

    /// Inertia of everything suspended (kg m^2) from its mass and small-amplitude period.
    pub fn system_inertia(&self, mass_kg: f64, period_s: f64) -> f64 {
        self.k_constant() * mass_kg * period_s * period_s
    }

    /// Object inertia with the platform tare subtracted:
    /// `K (m_total T_total^2 - m_platform T_platform^2)`.
    pub fn object_inertia(&self, platform_mass_kg: f64, platform_period_s: f64, total_mass_kg: f64, total_period_s: f64) -> f64 {
        self.system_inertia(total_mass_kg, total_period_s) - self.system_inertia(platform_mass_kg, platform_period_s)
    }

    /// Period ratio `T(phi0) / T0` for swing amplitude `amplitude_rad` of a system whose
    /// small-amplitude period is `t0_s` (section 3.1; `R^2 = R_a R_b`, and `m R^4/(I h^2)`
    /// rewritten with `I = K m T0^2`).
    pub fn period_ratio(&self, amplitude_rad: f64, t0_s: f64) -> f64 {
        let r2 = self.radius_top_m * self.radius_bottom_m;
        let h = self.length_m;
        let inertia_term = 16.0 * PI * PI * r2 / (self.g_m_s2 * t0_s * t0_s * h);
        1.0 + amplitude_rad * amplitude_rad / 16.0 * (1.0 - 3.0 * r2 / (h * h) + inertia_term)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Validation case V3 (inertia-methods.md section 9): R = 0.45 m, h = 2 m.
    fn v3() -> TrifilarRig {
        TrifilarRig { radius_top_m: 0.45, radius_bottom_m: 0.45, length_m: 2.0, g_m_s2: 9.80665 }
    }

    #[test]
    fn v3_constants_and_object_inertia() {
        let rig = v3();
        assert!((rig.k_constant() - 0.025151041).abs() < 1e-9);
        let i = rig.object_inertia(8.0, 1.726842172, 28.0, 2.098088706);
        assert!((i - 2.5).abs() < 1e-6, "{i}");
    }

    #[test]
    fn v3b_amplitude_ratio_matches_exact_periods() {
        // Exact 10-degree periods from the methods document: x1.0026534 and x1.0023195.
        let rig = v3();
        let a = 10f64.to_radians();
        assert!((rig.period_ratio(a, 1.726842172) - 1.0026534).abs() < 3e-6);
        assert!((rig.period_ratio(a, 2.098088706) - 1.0023195).abs() < 3e-6);
    }
}
