//! Test-only synthetic runs: piecewise-linear set-point schedules of P, IA, FZ, V, SA, SL with a
//! toy tire (forces, loaded radius, tread temperature), seeded noise, and dwells either kept
//! ("raw" files) or cut (ET jumps, "run" files). Every scheduled segment is recorded as truth.
//!
//! In: a seed and builder calls. Out: owned columns convertible to [`RunSignals`] and the truth
//! list. Deliberately not here: realism beyond what segmentation needs (the virtual test machine
//! of issue 3 is the real generator; these builders stand in until it lands).

use std::ops::Range;

use super::output::{NominalLevels, SegmentKind, ia_cdeg_label};
use super::signals::{RunSignals, TreadTemps};

/// One scheduled segment.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Truth {
    pub kind: SegmentKind,
    pub samples: Range<usize>,
    pub nominal: NominalLevels,
}

/// Set-point targets; `None` keeps the current value.
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct To {
    pub p: Option<f64>,
    pub ia: Option<f64>,
    pub fz: Option<f64>,
    pub v: Option<f64>,
    pub sa: Option<f64>,
    pub sl: Option<f64>,
}

#[derive(Copy, Clone, Debug, Default)]
struct State {
    p: f64,
    ia: f64,
    fz: f64,
    v: f64,
    sa: f64,
    sl: f64,
}

/// Owned columns of a synthetic run.
#[derive(Clone, Debug, Default)]
pub(crate) struct Columns {
    pub et_s: Vec<f64>,
    pub speed_kph: Vec<f64>,
    pub pressure_kpa: Vec<f64>,
    pub fz_n: Vec<f64>,
    pub alpha_rad: Vec<f64>,
    pub gamma_rad: Vec<f64>,
    pub kappa: Vec<f64>,
    pub fy_n: Vec<f64>,
    pub fx_n: Vec<f64>,
    pub loaded_radius_m: Vec<f64>,
    pub t_inner_c: Vec<f64>,
    pub t_centre_c: Vec<f64>,
    pub t_outer_c: Vec<f64>,
    pub mz_nm: Vec<f64>,
}

impl Columns {
    pub fn signals(&self, has_kappa: bool) -> RunSignals<'_> {
        RunSignals {
            et_s: &self.et_s,
            speed_kph: &self.speed_kph,
            pressure_kpa: &self.pressure_kpa,
            fz_n: &self.fz_n,
            alpha_rad: &self.alpha_rad,
            gamma_rad: &self.gamma_rad,
            kappa: &self.kappa,
            has_kappa,
            fy_n: &self.fy_n,
            fx_n: &self.fx_n,
            loaded_radius_m: &self.loaded_radius_m,
            tread_temps: Some(TreadTemps {
                inner_c: &self.t_inner_c,
                centre_c: &self.t_centre_c,
                outer_c: &self.t_outer_c,
            }),
            extra: vec![("mz_nm", &self.mz_nm)],
        }
    }
}

/// The synthetic rig.
pub(crate) struct Rig {
    hz: f64,
    keep_dwells: bool,
    rng: u64,
    state: State,
    t: f64,
    temp_c: f64,
    pub cols: Columns,
    pub truth: Vec<Truth>,
}

impl Rig {
    pub fn new(hz: f64, keep_dwells: bool, seed: u64, p_kpa: f64) -> Self {
        Rig {
            hz,
            keep_dwells,
            rng: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            state: State {
                p: p_kpa,
                ..State::default()
            },
            t: 0.0,
            temp_c: 25.0,
            cols: Columns::default(),
            truth: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.cols.et_s.len()
    }

    /// Roughly N(0, 1) from a seeded xorshift (sum of 4 uniforms, rescaled).
    fn noise(&mut self) -> f64 {
        let mut s = 0.0;
        for _ in 0..4 {
            self.rng ^= self.rng << 13;
            self.rng ^= self.rng >> 7;
            self.rng ^= self.rng << 17;
            s += (self.rng >> 11) as f64 / (1u64 << 53) as f64;
        }
        (s - 2.0) * 3.0_f64.sqrt()
    }

    fn round(x: f64, decimals: i32) -> f64 {
        let f = 10f64.powi(decimals);
        (x * f).round() / f
    }

    /// Record one sample of the current state and advance time.
    fn sample(&mut self) {
        let s = self.state;
        let dt = 1.0 / self.hz;
        let rolling = s.v > 1.0;
        let grip = 2.4 * (1.0 + 0.25 * ((self.temp_c - 25.0) / 40.0).min(1.0));
        let a = s.sa.to_radians();
        let fy = if rolling {
            grip * s.fz * (1.4 * (9.0 * a).atan()).sin() * (1.0 - 2.0 * s.sl.abs())
        } else {
            0.0
        };
        let fx = if rolling {
            grip * s.fz * (1.6 * (12.0 * s.sl).atan()).sin()
        } else {
            0.0
        };
        let power = if rolling {
            (fy * a).abs() + (fx * s.sl).abs() * 10.0
        } else {
            0.0
        };
        self.temp_c += dt * (power * 0.004 - 0.05 * (self.temp_c - 30.0));
        let n = [(); 9].map(|_| self.noise());
        let c = &mut self.cols;
        c.et_s.push(Self::round(self.t, 3));
        c.speed_kph.push(Self::round(
            (s.v + 0.05 * n[0]).max(0.0) * f64::from(u8::from(s.v > 0.0)),
            2,
        ));
        c.pressure_kpa.push(Self::round(s.p + 0.3 * n[1], 2));
        c.fz_n.push(Self::round(s.fz + 6.0 * n[2] + 0.02 * fy, 2));
        c.alpha_rad
            .push(Self::round(s.sa + 0.01 * n[3], 3).to_radians());
        c.gamma_rad
            .push(Self::round(s.ia + 0.01 * n[4], 3).to_radians());
        c.kappa.push(Self::round(s.sl + 0.0005 * n[5], 4));
        c.fy_n.push(Self::round(fy + 10.0 * n[6], 2));
        c.fx_n.push(Self::round(fx - 0.015 * s.fz + 8.0 * n[7], 2));
        c.loaded_radius_m
            .push(Self::round(26.0 - s.fz / 1500.0 + 0.01 * n[8], 2) / 100.0);
        c.t_inner_c.push(Self::round(self.temp_c + 2.0 * s.ia, 1));
        c.t_centre_c.push(Self::round(self.temp_c, 1));
        c.t_outer_c.push(Self::round(self.temp_c - 2.0 * s.ia, 1));
        c.mz_nm.push(Self::round(-fy * 0.01 + 0.3 * n[6], 2));
        self.t += dt;
    }

    /// Hold the current state for `secs`.
    pub fn hold(&mut self, secs: f64) -> &mut Self {
        let n = (secs * self.hz).round() as usize;
        for _ in 0..n {
            self.sample();
        }
        self
    }

    /// Move every given set-point linearly to its target over `secs`.
    pub fn go(&mut self, to: To, secs: f64) -> &mut Self {
        let from = self.state;
        let n = ((secs * self.hz).round() as usize).max(1);
        let lerp = |a: f64, b: Option<f64>, f: f64| b.map_or(a, |b| a + (b - a) * f);
        for k in 1..=n {
            let f = k as f64 / n as f64;
            self.state = State {
                p: lerp(from.p, to.p, f),
                ia: lerp(from.ia, to.ia, f),
                fz: lerp(from.fz, to.fz, f),
                v: lerp(from.v, to.v, f),
                sa: lerp(from.sa, to.sa, f),
                sl: lerp(from.sl, to.sl, f),
            };
            self.sample();
        }
        self
    }

    /// Slip angle through `points` (deg, ISO-W) at `rate` deg/s.
    pub fn sa_path(&mut self, points: &[f64], rate: f64) -> &mut Self {
        for &p in points {
            let secs = (p - self.state.sa).abs() / rate;
            self.go(
                To {
                    sa: Some(p),
                    ..To::default()
                },
                secs,
            );
        }
        self
    }

    /// Longitudinal slip through `points` at `rate` 1/s.
    pub fn sl_path(&mut self, points: &[f64], rate: f64) -> &mut Self {
        for &p in points {
            let secs = (p - self.state.sl).abs() / rate;
            self.go(
                To {
                    sl: Some(p),
                    ..To::default()
                },
                secs,
            );
        }
        self
    }

    /// A dwell of `secs`: kept (SA, SL to 0, load to `rest_fz`, held, cooling) or cut (ET jumps;
    /// the set-points jump to `then` with no samples in between).
    pub fn dwell(&mut self, secs: f64, rest_fz: f64, then: To) -> &mut Self {
        if self.keep_dwells {
            self.go(
                To {
                    sa: Some(0.0),
                    sl: Some(0.0),
                    fz: Some(rest_fz),
                    ..To::default()
                },
                1.0,
            );
            self.hold(secs);
            self.go(then, 1.5);
        } else {
            self.t += secs;
            self.temp_c = 30.0 + (self.temp_c - 30.0) * 0.7;
            let s = &mut self.state;
            (s.sa, s.sl) = (0.0, 0.0);
            s.p = then.p.unwrap_or(s.p);
            s.ia = then.ia.unwrap_or(s.ia);
            s.fz = then.fz.unwrap_or(s.fz);
            s.v = then.v.unwrap_or(s.v);
        }
        self
    }

    /// Record what `f` schedules as a truth segment of `kind`.
    pub fn mark(
        &mut self,
        kind: SegmentKind,
        nominal: NominalLevels,
        f: impl FnOnce(&mut Self),
    ) -> &mut Self {
        let start = self.len();
        f(self);
        self.truth.push(Truth {
            kind,
            samples: start..self.len(),
            nominal,
        });
        self
    }

    /// Current set-points rounded to nominal integers (pressure, IA, load, speed).
    pub fn nominal(&self, alpha: Option<i64>) -> NominalLevels {
        let s = self.state;
        NominalLevels {
            pressure_kpa: Some(s.p.round() as i64),
            ia_cdeg: Some(ia_cdeg_label(s.ia)),
            fz_n: Some(s.fz.round() as i64),
            alpha_deg: alpha,
            speed_kph: Some(s.v.round() as i64),
        }
    }
}

/// Nominal loads, N.
pub(crate) const LB50: f64 = 222.0;
pub(crate) const LB100: f64 = 445.0;
pub(crate) const LB150: f64 = 667.0;
pub(crate) const LB200: f64 = 890.0;
pub(crate) const LB250: f64 = 1112.0;
pub(crate) const LB350: f64 = 1557.0;

/// A spring-rate staircase at the current speed for each IA.
pub(crate) fn spring_rates(rig: &mut Rig, ias: &[f64], loads: &[f64]) {
    for &ia in ias {
        rig.go(
            To {
                ia: Some(ia),
                fz: Some(100.0),
                ..To::default()
            },
            1.0,
        );
        rig.hold(0.5);
        let kind = if rig.state.v > 0.0 {
            SegmentKind::SpringRateDynamic
        } else {
            SegmentKind::SpringRateStatic
        };
        let mut nominal = rig.nominal(Some(0));
        nominal.fz_n = None;
        rig.mark(kind, nominal, |r| {
            for &fz in loads {
                r.go(
                    To {
                        fz: Some(fz),
                        ..To::default()
                    },
                    0.2,
                );
                r.hold(0.8);
            }
        });
        rig.go(
            To {
                fz: Some(100.0),
                ..To::default()
            },
            0.5,
        );
        rig.hold(1.0);
    }
}

/// One block of `n` back-to-back cycles 0 -> +a -> -a -> 0 at `rate`, marked as one `kind`.
pub(crate) fn sweep_cycles(rig: &mut Rig, kind: SegmentKind, n: usize, amp: f64, rate: f64) {
    let nominal = rig.nominal(None);
    rig.mark(kind, nominal, |r| {
        for _ in 0..n {
            r.sa_path(&[amp, -amp, 0.0], rate);
        }
    });
}

/// One block of a continuous triangle: 0 -> +a, then `n` times (-a, +a), then 0 (the virtual
/// machine's cold-to-warm shape), marked as one `kind`.
pub(crate) fn sweep_triangle(rig: &mut Rig, kind: SegmentKind, n: usize, amp: f64, rate: f64) {
    let nominal = rig.nominal(None);
    rig.mark(kind, nominal, |r| {
        r.sa_path(&[amp], rate);
        for _ in 0..n {
            r.sa_path(&[-amp, amp], rate);
        }
        r.sa_path(&[0.0], rate);
    });
}

impl Rig {
    /// Inclination to `deg` over `secs`.
    pub fn ia_to(&mut self, deg: f64, secs: f64) -> &mut Self {
        self.go(
            To {
                ia: Some(deg),
                ..To::default()
            },
            secs,
        )
    }
}

/// Round-4 cornering run at `p_kpa`: spring rates static and dynamic, optional cold-to-warm
/// (8 cycles +-12 deg at 8 deg/s, 250 lb), conditioning (3 cycles +-6 deg at 6 deg/s, 250 lb),
/// the 25-sweep matrix (SAE SA -4 -> +12 -> -12 -> +3 at 4 deg/s, ISO-W alpha +4 -> -12 -> +12
/// -> -3; IA 0,2,4,1,3 x loads
/// 350,150,50,250,100 lb), spring rates again. 50 Hz, dwells cut unless `keep_dwells`.
pub(crate) fn round4_cornering(p_kpa: f64, cold: bool, keep_dwells: bool, seed: u64) -> Rig {
    let mut rig = Rig::new(50.0, keep_dwells, seed, p_kpa);
    let loads = [LB50, LB100, LB150, LB200, LB250, LB350];
    rig.hold(2.0);
    if cold {
        spring_rates(&mut rig, &[0.0, 2.0, 4.0], &loads);
    }
    rig.go(
        To {
            v: Some(40.0),
            ia: Some(0.0),
            fz: Some(LB50),
            ..To::default()
        },
        8.0,
    );
    rig.hold(2.0);
    if cold {
        spring_rates(&mut rig, &[0.0, 2.0, 4.0], &loads);
        rig.go(
            To {
                ia: Some(0.0),
                fz: Some(LB250),
                ..To::default()
            },
            2.0,
        );
        rig.hold(1.0);
        sweep_cycles(&mut rig, SegmentKind::ColdToWarm, 8, 12.0, 8.0);
        rig.hold(2.0);
        spring_rates(&mut rig, &[0.0, 2.0, 4.0], &loads);
    }
    rig.go(
        To {
            ia: Some(0.0),
            fz: Some(LB250),
            ..To::default()
        },
        2.0,
    );
    rig.hold(1.0);
    sweep_cycles(&mut rig, SegmentKind::Conditioning, 3, 6.0, 6.0);
    for ia in [0.0, 2.0, 4.0, 1.0, 3.0] {
        for fz in [LB350, LB150, LB50, LB250, LB100] {
            rig.dwell(
                12.0,
                LB50,
                To {
                    ia: Some(ia),
                    ..To::default()
                },
            );
            rig.go(
                To {
                    fz: Some(fz),
                    ..To::default()
                },
                1.0,
            );
            let nominal = rig.nominal(None);
            rig.mark(SegmentKind::Cornering, nominal, |r| {
                r.sa_path(&[4.0, -12.0, 12.0, -3.0], 4.0);
            });
            rig.sa_path(&[0.0], 4.0);
        }
    }
    rig.dwell(
        5.0,
        LB50,
        To {
            ia: Some(0.0),
            fz: Some(100.0),
            ..To::default()
        },
    );
    rig.hold(1.0);
    spring_rates(&mut rig, &[0.0], &loads);
    rig.hold(2.0);
    rig
}

/// Round-4 drive/brake run: conditioning (2 SL cycles at 250 lb), then SL sweeps
/// 0 -> +0.2 -> -0.2 -> +0.2 -> 0 at 0.1/s for IA 0,2,4 x loads 350,150,250,50 lb x SA 0,3,6 deg
/// (ISO-W; stored as 0,-3,-6 in SAE). 50 Hz.
pub(crate) fn round4_drive_brake(p_kpa: f64, keep_dwells: bool, seed: u64) -> Rig {
    let mut rig = Rig::new(50.0, keep_dwells, seed, p_kpa);
    rig.hold(2.0);
    rig.go(
        To {
            v: Some(40.0),
            fz: Some(LB250),
            ..To::default()
        },
        8.0,
    );
    rig.hold(1.0);
    for _ in 0..2 {
        let nominal = rig.nominal(Some(0));
        rig.mark(SegmentKind::Conditioning, nominal, |r| {
            r.sl_path(&[0.2, -0.2, 0.2, 0.0], 0.2);
        });
    }
    for ia in [0.0, 2.0, 4.0] {
        for fz in [LB350, LB150, LB250, LB50] {
            for sa in [0.0, 3.0, 6.0] {
                rig.dwell(
                    10.0,
                    LB50,
                    To {
                        ia: Some(ia),
                        ..To::default()
                    },
                );
                rig.go(
                    To {
                        fz: Some(fz),
                        sa: Some(sa),
                        ..To::default()
                    },
                    1.5,
                );
                rig.hold(0.5);
                let kind = if sa == 0.0 {
                    SegmentKind::DriveBrake
                } else {
                    SegmentKind::Combined
                };
                let nominal = rig.nominal(Some(sa as i64));
                rig.mark(kind, nominal, |r| {
                    r.sl_path(&[0.2, -0.2, 0.2, 0.0], 0.1);
                });
                rig.go(
                    To {
                        sa: Some(0.0),
                        ..To::default()
                    },
                    1.0,
                );
            }
        }
    }
    rig.hold(2.0);
    rig
}

/// Round-8 style cornering raw file (100 Hz, dwells kept): spring rates, a cold-to-warm block
/// (continuous +-12 deg triangle of 12 cycles at 8 deg/s), +-12 deg matrix sweeps at 4 deg/s for loads 200,50,150,250 lb (10 inch
/// tire: 200 lb replaces 350) x IA 0,2,4 at two pressures, IA sweeps -4 -> +4, and speed sweeps
/// at 15 and 45 mph. IA sweeps go 0 -> -4 -> +4 -> 0 at 1 deg/s.
pub(crate) fn round8_cornering_raw(seed: u64) -> Rig {
    let mut rig = Rig::new(100.0, true, seed, 83.0);
    let loads = [LB50, LB100, LB150, LB200, LB250];
    rig.hold(2.0);
    spring_rates(&mut rig, &[0.0, 2.0, 4.0], &loads);
    rig.go(
        To {
            v: Some(40.0),
            fz: Some(LB150),
            ..To::default()
        },
        8.0,
    );
    rig.hold(2.0);
    rig.ia_to(0.0, 1.0);
    sweep_triangle(&mut rig, SegmentKind::ColdToWarm, 12, 12.0, 8.0);
    for p in [83.0, 97.0] {
        rig.dwell(
            8.0,
            LB50,
            To {
                p: Some(p),
                ..To::default()
            },
        );
        for ia in [0.0, 2.0, 4.0] {
            for fz in [LB200, LB50, LB150, LB250] {
                rig.dwell(
                    6.0,
                    LB50,
                    To {
                        ia: Some(ia),
                        fz: Some(fz),
                        ..To::default()
                    },
                );
                rig.hold(1.0);
                let nominal = rig.nominal(None);
                rig.mark(SegmentKind::Cornering, nominal, |r| {
                    r.sa_path(&[12.0, -12.0, 0.0], 4.0);
                });
            }
        }
    }
    for fz in [LB150, LB250] {
        rig.dwell(
            6.0,
            LB50,
            To {
                ia: Some(0.0),
                fz: Some(fz),
                ..To::default()
            },
        );
        rig.hold(2.0);
        let mut nominal = rig.nominal(Some(0));
        nominal.ia_cdeg = None;
        rig.mark(SegmentKind::IaSweep, nominal, |r| {
            r.ia_to(-4.0, 4.0).ia_to(4.0, 8.0).ia_to(0.0, 4.0);
        });
        rig.hold(2.0);
    }
    for v in [24.0, 72.0] {
        for fz in [LB150, LB250] {
            rig.dwell(
                6.0,
                LB50,
                To {
                    ia: Some(0.0),
                    fz: Some(fz),
                    v: Some(v),
                    ..To::default()
                },
            );
            rig.hold(1.0);
            let nominal = rig.nominal(None);
            rig.mark(SegmentKind::SpeedSweep, nominal, |r| {
                r.sa_path(&[12.0, -12.0, 0.0], 4.0);
            });
        }
    }
    rig.dwell(
        4.0,
        LB50,
        To {
            v: Some(40.0),
            ..To::default()
        },
    );
    rig
}

/// Round-8 transient run (100 Hz, dwells kept): spring rates, then at each load step steers to
/// SAE -1, +1, +6 deg (ISO-W +1, -1, -6) at 60 deg/s, each held 2 s and returned to 0 (0.5 s at
/// zero before and after belong to the step, as in the virtual machine's plan).
pub(crate) fn round8_transient(seed: u64) -> Rig {
    let mut rig = Rig::new(100.0, true, seed, 83.0);
    rig.hold(2.0);
    spring_rates(&mut rig, &[0.0], &[LB50, LB100, LB150, LB200, LB250]);
    rig.go(
        To {
            v: Some(40.0),
            fz: Some(LB150),
            ..To::default()
        },
        8.0,
    );
    for fz in [LB50, LB150, LB250] {
        rig.dwell(
            5.0,
            LB50,
            To {
                fz: Some(fz),
                ..To::default()
            },
        );
        rig.hold(2.0);
        for sa in [1.0, -1.0, -6.0] {
            let nominal = rig.nominal(Some(sa as i64));
            rig.mark(SegmentKind::StepSteer, nominal, |r| {
                r.hold(0.5);
                r.sa_path(&[sa], 60.0).hold(2.0);
                r.sa_path(&[0.0], 60.0).hold(0.5);
            });
            rig.hold(3.0);
        }
    }
    rig.hold(2.0);
    rig
}

/// Round-9 style drive/brake raw file (100 Hz, dwells kept): SL sweeps 0 -> +0.15 -> -0.15 -> 0
/// at 0.05/s for SA 0,3,6 x loads 350,150 lb x IA 0,2, then two sweeps at 15 and 45 mph.
pub(crate) fn round9_drive_brake_raw(seed: u64) -> Rig {
    let mut rig = Rig::new(100.0, true, seed, 69.0);
    rig.hold(2.0);
    rig.go(
        To {
            v: Some(40.0),
            fz: Some(LB150),
            ..To::default()
        },
        8.0,
    );
    for ia in [0.0, 2.0] {
        for fz in [LB350, LB150] {
            for sa in [0.0, 3.0, 6.0] {
                rig.dwell(
                    6.0,
                    LB50,
                    To {
                        ia: Some(ia),
                        fz: Some(fz),
                        sa: Some(sa),
                        ..To::default()
                    },
                );
                rig.hold(0.5);
                let kind = if sa == 0.0 {
                    SegmentKind::DriveBrake
                } else {
                    SegmentKind::Combined
                };
                let nominal = rig.nominal(Some(sa as i64));
                rig.mark(kind, nominal, |r| {
                    r.sl_path(&[0.15, -0.15, 0.0], 0.05);
                });
            }
        }
    }
    for v in [24.0, 72.0] {
        rig.dwell(
            6.0,
            LB50,
            To {
                ia: Some(0.0),
                fz: Some(LB150),
                v: Some(v),
                ..To::default()
            },
        );
        rig.hold(0.5);
        let nominal = rig.nominal(Some(0));
        rig.mark(SegmentKind::SpeedSweep, nominal, |r| {
            r.sl_path(&[0.15, -0.15, 0.0], 0.05);
        });
    }
    rig.dwell(
        3.0,
        LB50,
        To {
            v: Some(40.0),
            ..To::default()
        },
    );
    rig
}
