//! Run-order drift: a tire whose friction and slip stiffness change with its history on the
//! machine, so the block of runs tested first differs from later ones by more than pressure.
//!
//! In: a [`RunOrderDrift`] (`[synth.quirks.drift]`, off by default) and a tire's history
//! ([`TireHistory`]: slip energy dissipated and distance rolled since it was mounted, over its
//! runs in run order). Out: the scalings the machine applies per sample ([`RunOrderDrift::scales`])
//! and, per run, their weighted means over the fitted sweeps ([`BlockDrift`]), from which the
//! truth of each tested pressure is made.
//!
//! The law (two mechanisms, each decaying to the settled tire):
//! - scrub-in / wear: the peak frictions (`LMUX`, `LMUY`) of a fresh tread are
//!   `1 + mu_frac exp(-E / scrub_energy_kj)` times the settled tire's, `E` the slip energy
//!   dissipated so far;
//! - carcass temperature settling: the slip stiffnesses (`LKX`, `LKY`) of a tire early in its
//!   session are `1 + stiffness_frac exp(-D / settle_distance_km)` times the settled tire's, `D`
//!   the distance rolled so far (a cooler carcass and tread are stiffer).
//!
//! The relaxation lengths stay the reference tire's (the truth's relaxation law is unchanged).
//! The runs follow the plan's order, which tests the middle pressure first (the catalogue's
//! 12 / 10 / 14 / 8 psi, as Calspan's rounds do): the first block sits above both its
//! neighbours in pressure, as on real rounds.
//!
//! What the truth is under drift: the truth `.tir` of a tested pressure is the tire as that
//! pressure's block of runs saw it: the reference (settled) tire with `LMUY`, `LKY` scaled by the
//! drift's mean over the block's cornering sweeps and `LMUX`, `LKX` by its mean over the block's
//! drive/brake and combined sweeps (means weighted by `|F|/Fz`, as the thermal law's
//! references). That is all a per-pressure fit can know. The MF 6.1 truth of every pressure
//! (`<tire>__<rim>in__mf61.tir`) is the settled tire: no block is exactly that tire, and no
//! smooth pressure law reproduces every block.
//!
//! Deliberately not here: the machine's physics (`machine.rs` applies the scalings), the truth
//! files (`round.rs`).

use serde::{Deserialize, Serialize};

/// `[synth.quirks.drift]`: friction and slip stiffness that change with the tire's history
/// (both fractions 0: off).
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunOrderDrift {
    /// Peak friction of a fresh tread above the settled tire's, fraction.
    pub mu_frac: f64,
    /// Slip energy over which the fresh tread's excess friction decays, kJ.
    pub scrub_energy_kj: f64,
    /// Slip stiffness at the start of the session above the settled tire's, fraction.
    pub stiffness_frac: f64,
    /// Distance rolled over which the excess slip stiffness decays, km.
    pub settle_distance_km: f64,
}

impl Default for RunOrderDrift {
    fn default() -> Self {
        RunOrderDrift {
            mu_frac: 0.0,
            scrub_energy_kj: 1500.0,
            stiffness_frac: 0.0,
            settle_distance_km: 10.0,
        }
    }
}

impl RunOrderDrift {
    /// The drift of the every-quirk round: a fresh tread 6 % grippier and an early-session tire
    /// 6 % stiffer than the settled one (the real drive/brake round's first block: friction and
    /// slip stiffness some 5-10 % above both neighbouring pressures).
    pub fn typical() -> RunOrderDrift {
        RunOrderDrift {
            mu_frac: 0.06,
            stiffness_frac: 0.06,
            ..RunOrderDrift::default()
        }
    }

    /// Whether the drift changes anything.
    pub fn is_off(&self) -> bool {
        self.mu_frac == 0.0 && self.stiffness_frac == 0.0
    }

    /// `(friction scale, slip stiffness scale)` of a tire with history `h`.
    pub fn scales(&self, h: &TireHistory) -> (f64, f64) {
        let mu = 1.0 + self.mu_frac * (-h.slip_energy_j / (1e3 * self.scrub_energy_kj)).exp();
        let k = 1.0 + self.stiffness_frac * (-h.distance_m / (1e3 * self.settle_distance_km)).exp();
        (mu, k)
    }

    /// The range problem of a value, if any: `(key, value, message)`.
    pub fn invalid(&self) -> Option<(&'static str, f64, &'static str)> {
        let in_range = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
        for (key, v, lo, hi, message) in [
            (
                "quirks.drift.mu_frac",
                self.mu_frac,
                -0.3,
                0.3,
                "must be in -0.3..0.3",
            ),
            (
                "quirks.drift.stiffness_frac",
                self.stiffness_frac,
                -0.3,
                0.3,
                "must be in -0.3..0.3",
            ),
            (
                "quirks.drift.scrub_energy_kj",
                self.scrub_energy_kj,
                1.0,
                1e6,
                "must be in 1..1e6",
            ),
            (
                "quirks.drift.settle_distance_km",
                self.settle_distance_km,
                0.01,
                1e3,
                "must be in 0.01..1000",
            ),
        ] {
            if !in_range(v, lo, hi) {
                return Some((key, v, message));
            }
        }
        None
    }
}

/// What a tire has been through on the machine since it was mounted.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct TireHistory {
    /// Slip energy dissipated in the contact patch, J.
    pub slip_energy_j: f64,
    /// Distance rolled, m.
    pub distance_m: f64,
}

/// The drift of one run over its fitted sweeps: `|F|/Fz`-weighted sums of the friction and
/// stiffness scalings, lateral (cornering sweeps) and longitudinal (drive/brake and combined
/// sweeps). Sums, so the runs of a block add up.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct BlockDrift {
    /// (weight, weight x friction scale, weight x stiffness scale) of the cornering sweeps.
    pub lateral: [f64; 3],
    /// The same over the drive/brake and combined sweeps.
    pub longitudinal: [f64; 3],
}

impl BlockDrift {
    /// Add one sample of weight `w` with scalings `(mu, k)`.
    pub fn add(&mut self, lateral: bool, w: f64, mu: f64, k: f64) {
        let s = if lateral {
            &mut self.lateral
        } else {
            &mut self.longitudinal
        };
        s[0] += w;
        s[1] += w * mu;
        s[2] += w * k;
    }

    /// Add another run's sums.
    pub fn merge(&mut self, other: &BlockDrift) {
        for k in 0..3 {
            self.lateral[k] += other.lateral[k];
            self.longitudinal[k] += other.longitudinal[k];
        }
    }

    /// `(mu, k)` means of the lateral and longitudinal sweeps (1 where there are none).
    pub fn means(&self) -> ((f64, f64), (f64, f64)) {
        let mean = |s: &[f64; 3]| {
            if s[0] > 0.0 {
                (s[1] / s[0], s[2] / s[0])
            } else {
                (1.0, 1.0)
            }
        };
        (mean(&self.lateral), mean(&self.longitudinal))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drift_decays_to_the_settled_tire() {
        let d = RunOrderDrift::typical();
        let fresh = d.scales(&TireHistory::default());
        assert!((fresh.0 - 1.06).abs() < 1e-12 && (fresh.1 - 1.06).abs() < 1e-12);
        let used = d.scales(&TireHistory {
            slip_energy_j: 1e9,
            distance_m: 1e7,
        });
        assert!((used.0 - 1.0).abs() < 1e-9 && (used.1 - 1.0).abs() < 1e-9);
        assert!(RunOrderDrift::default().is_off());
        assert!(d.invalid().is_none() && RunOrderDrift::default().invalid().is_none());
        let mut b = BlockDrift::default();
        b.add(true, 1.0, 1.02, 1.04);
        b.add(true, 3.0, 1.06, 1.0);
        let ((mu, k), long) = b.means();
        assert!((mu - 1.05).abs() < 1e-12 && (k - 1.01).abs() < 1e-12);
        assert_eq!(long, (1.0, 1.0));
    }
}
