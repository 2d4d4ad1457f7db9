//! The measured output channels a fitting stage reads from a sweep: `Fx`, `Fy`, `Mz`, `Mx`.
//!
//! One enum for the PAC2002 and MF 6.1 stages, which both keep a point's outputs as a `[f64; 4]`
//! indexed by `Output as usize` (the order of [`Output::ALL`]).

/// A measured output channel (ISO-W, SI: N or N m).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Output {
    /// Longitudinal force, N.
    Fx,
    /// Lateral force, N.
    Fy,
    /// Aligning moment, N m.
    Mz,
    /// Overturning moment, N m.
    Mx,
}

impl Output {
    /// Every output, in index order.
    pub const ALL: [Output; 4] = [Output::Fx, Output::Fy, Output::Mz, Output::Mx];

    /// `Fx`, `Fy`, `Mz`, `Mx`.
    pub const fn name(self) -> &'static str {
        match self {
            Output::Fx => "Fx",
            Output::Fy => "Fy",
            Output::Mz => "Mz",
            Output::Mx => "Mx",
        }
    }
}
