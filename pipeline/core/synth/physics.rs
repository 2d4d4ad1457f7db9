//! The virtual machine's physics beyond the steady-state PAC2002 model: transient lag and tread
//! temperature.
//!
//! In: per time step, steady-state forces, speed, slip and power. Out: lagged forces
//! ([`FirstOrderLag`]) and the tread temperature state ([`Tread`]) with its IR-visible history.
//!
//! - Lag: `dF/dt = V/sigma (F_ss - F)`, integrated *exactly* for a steady-state input that varies
//!   linearly over the step (first-order hold). A zero-order hold would delay the response by half
//!   a sample, i.e. add `V dt/2` (5.6 cm at 100 Hz and 25 mph, 13 % of a relaxation length) to the
//!   apparent sigma; with the exact update the relaxation stage sees the truth sigma.
//! - Heat: two lumped temperatures. The tread *surface* (what grip and the IR sensors see) takes
//!   a share of the slip power, exchanges heat with the tread *bulk*, and is cooled by the road
//!   (stronger when rolling) and the air; the bulk takes the rest of the slip power and the
//!   rolling loss and cools slowly to ambient. Numbers in [`ThermalParams::default`].
//!
//! Deliberately not here: the steady-state model (tire_model), the grip law (tires.rs), sensors.

/// First-order lag with exact first-order-hold steps.
#[derive(Copy, Clone, Debug, Default)]
pub struct FirstOrderLag {
    value: f64,
    input: f64,
    started: bool,
}

impl FirstOrderLag {
    /// Advance by `dt_s` to the new steady-state input `u_now` with time constant `tau_s`
    /// (`sigma/V`); returns the lagged value. The first call returns `u_now` (a settled start).
    pub fn step(&mut self, u_now: f64, dt_s: f64, tau_s: f64) -> f64 {
        if !self.started || tau_s <= 0.0 || dt_s <= 0.0 {
            self.started = true;
            self.value = u_now;
            self.input = u_now;
            return u_now;
        }
        let slope = (u_now - self.input) / dt_s;
        let decay = (-dt_s / tau_s).exp();
        self.value = u_now - tau_s * slope + (self.value - self.input + tau_s * slope) * decay;
        self.input = u_now;
        self.value
    }

    /// The current lagged value.
    pub fn value(&self) -> f64 {
        self.value
    }
}

/// A measurement chain in time: a pure delay (linear interpolation between samples), then a
/// first-order filter with exact first-order-hold steps. Both in seconds, so unlike the tire's
/// relaxation (a length) the lag they add grows with road speed: `V (delay + filter)` of apparent
/// relaxation length on a slow sweep.
#[derive(Clone, Debug)]
pub struct MeasurementChain {
    delay_samples: f64,
    filter_s: f64,
    dt_s: f64,
    history: std::collections::VecDeque<f64>,
    filter: FirstOrderLag,
}

impl MeasurementChain {
    /// A chain at a fixed sample step `dt_s`; both times 0 passes values through unchanged.
    pub fn new(delay_s: f64, filter_s: f64, dt_s: f64) -> MeasurementChain {
        MeasurementChain {
            delay_samples: (delay_s / dt_s).max(0.0),
            filter_s: filter_s.max(0.0),
            dt_s,
            history: std::collections::VecDeque::new(),
            filter: FirstOrderLag::default(),
        }
    }

    /// The chain's output for the next input sample (a settled start: before the first sample
    /// the input is taken as constant).
    pub fn step(&mut self, u: f64) -> f64 {
        let whole = self.delay_samples.floor() as usize;
        let frac = self.delay_samples - whole as f64;
        if self.history.is_empty() {
            self.history.extend(std::iter::repeat_n(u, whole + 2));
        }
        self.history.push_back(u);
        while self.history.len() > whole + 2 {
            self.history.pop_front();
        }
        // history[len - 1] is now; len - 1 - whole is `whole` samples back.
        let n = self.history.len();
        let a = self.history[n - 1 - whole];
        let b = self.history[n - 2 - whole];
        let delayed = a + frac * (b - a);
        self.filter.step(delayed, self.dt_s, self.filter_s)
    }
}

/// Constants of the two-temperature tread model (rates per second, gains per joule).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ThermalParams {
    /// Surface temperature rise per joule of slip energy, K/J.
    pub surface_gain_k_per_j: f64,
    /// Bulk temperature rise per joule of slip or rolling-loss energy, K/J.
    pub bulk_gain_k_per_j: f64,
    /// Surface-to-bulk exchange rate, 1/s.
    pub surface_to_bulk_per_s: f64,
    /// Bulk-to-surface exchange rate, 1/s (smaller: the bulk is heavier).
    pub bulk_to_surface_per_s: f64,
    /// Surface-to-road cooling rate when rolling at the reference speed, 1/s (scales with
    /// `sqrt(V/V_ref)`, floor `road_cooling_standstill_per_s`).
    pub road_cooling_per_s: f64,
    /// Surface-to-road cooling rate at standstill (only the contact patch), 1/s.
    pub road_cooling_standstill_per_s: f64,
    /// Surface-to-air cooling rate, 1/s.
    pub air_cooling_per_s: f64,
    /// Bulk-to-air cooling rate, 1/s.
    pub bulk_cooling_per_s: f64,
    /// Rolling-loss coefficient: rolling heat = coefficient * Fz * V, W.
    pub rolling_loss: f64,
}

impl Default for ThermalParams {
    fn default() -> Self {
        ThermalParams {
            surface_gain_k_per_j: 1.0e-3,
            bulk_gain_k_per_j: 3.0e-4,
            surface_to_bulk_per_s: 0.5,
            bulk_to_surface_per_s: 0.025,
            road_cooling_per_s: 0.15,
            road_cooling_standstill_per_s: 0.01,
            air_cooling_per_s: 0.01,
            bulk_cooling_per_s: 0.004,
            rolling_loss: 0.015,
        }
    }
}

/// Tread temperatures, degC.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Tread {
    /// Surface temperature (grip, IR sensors), degC.
    pub surface_c: f64,
    /// Bulk tread temperature, degC.
    pub bulk_c: f64,
}

impl Tread {
    /// A tire at rest, in equilibrium with the air.
    pub fn cold(t_c: f64) -> Tread {
        Tread {
            surface_c: t_c,
            bulk_c: t_c,
        }
    }

    /// Advance by `dt_s` (explicit Euler; every rate times `dt_s` is far below 1 at 50 Hz).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        p: &ThermalParams,
        slip_power_w: f64,
        fz_n: f64,
        v_mps: f64,
        v_ref_mps: f64,
        road_c: f64,
        air_c: f64,
        dt_s: f64,
    ) {
        let v = v_mps.abs();
        let road_rate =
            (p.road_cooling_per_s * (v / v_ref_mps).sqrt()).max(p.road_cooling_standstill_per_s);
        let rolling_w = p.rolling_loss * fz_n.max(0.0) * v;
        let ts = self.surface_c;
        let tb = self.bulk_c;
        let d_surface = p.surface_gain_k_per_j * slip_power_w
            - p.surface_to_bulk_per_s * (ts - tb)
            - road_rate * (ts - road_c)
            - p.air_cooling_per_s * (ts - air_c);
        let d_bulk = p.bulk_gain_k_per_j * (slip_power_w + rolling_w)
            + p.bulk_to_surface_per_s * (ts - tb)
            - p.bulk_cooling_per_s * (tb - air_c);
        self.surface_c += d_surface * dt_s;
        self.bulk_c += d_bulk * dt_s;
    }
}

/// Slip power dissipated in the contact patch, W: `|Fx| |kappa| V + |Fy| V |tan(alpha)|`.
pub fn slip_power_w(fx_n: f64, fy_n: f64, kappa: f64, alpha_rad: f64, v_mps: f64) -> f64 {
    let v = v_mps.abs();
    fx_n.abs() * kappa.abs() * v + fy_n.abs() * v * alpha_rad.tan().abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact update reproduces the analytic response to a ramp: after the transient,
    /// `F = F_ss(t - tau)` (the lag is exactly `tau`), whatever the step.
    #[test]
    fn ramp_response_lags_by_exactly_tau() {
        for dt in [0.02, 0.01, 0.001] {
            let tau = 0.035;
            let mut lag = FirstOrderLag::default();
            lag.step(0.0, dt, tau);
            let n = (2.0 / dt) as usize;
            let mut y = 0.0;
            for k in 1..=n {
                y = lag.step(k as f64 * dt, dt, tau);
            }
            let t = n as f64 * dt;
            assert!((y - (t - tau)).abs() < 1e-9, "dt {dt}: {y} vs {}", t - tau);
        }
    }

    /// The chain delays a ramp by exactly `delay + filter` once settled, and passes values
    /// through unchanged when off.
    #[test]
    fn measurement_chain_lags_a_ramp_by_delay_plus_filter() {
        let dt = 0.01;
        for (delay, filter) in [(0.0, 0.0), (0.02, 0.0), (0.025, 0.0), (0.013, 0.017)] {
            let mut chain = MeasurementChain::new(delay, filter, dt);
            let mut y = 0.0;
            let n = 300;
            for k in 0..=n {
                y = chain.step(k as f64 * dt);
            }
            let t = n as f64 * dt;
            assert!(
                (y - (t - delay - filter)).abs() < 1e-9,
                "delay {delay} filter {filter}: {y} vs {}",
                t - delay - filter
            );
        }
    }

    #[test]
    fn tread_heats_with_slip_and_cools_back() {
        let p = ThermalParams::default();
        let mut t = Tread::cold(25.0);
        for _ in 0..1000 {
            t.step(&p, 4000.0, 1100.0, 11.176, 11.176, 25.0, 25.0, 0.01);
        }
        let hot = t;
        assert!(hot.surface_c > hot.bulk_c && hot.bulk_c > 27.0, "{hot:?}");
        for _ in 0..3000 {
            t.step(&p, 0.0, 200.0, 11.176, 11.176, 25.0, 25.0, 0.01);
        }
        assert!(t.surface_c < hot.surface_c - 5.0, "{t:?}");
    }
}
