//! Deterministic example run files in each round's exact layout, for tests, benchmarks and fuzz
//! seeds.
//!
//! In: an [`ExampleStyle`] and a row count. Out: `.dat` bytes (via [`render_dat`]) or TTC `.mat`
//! bytes (via [`MatWriter`]) holding smooth made-up signals: sinusoidal slip-angle sweeps at a
//! 250 lb (1112 N) load, SAE axes, each channel in the style's unit. Deliberately not physics:
//! the virtual test machine (synth) makes realistic rounds; these only exercise the formats.
//! Never real TTC data.

use super::dat::{DatColumn, Line1, RoundStyle, push_fixed, render_dat};
use super::mat::{Compression, MatWriter};
use super::{TtcChannel, Unit};

/// The four header-and-unit conventions the examples come in: a round style and a unit system
/// (see `shared/docs/ttc-format.md`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ExampleStyle {
    /// Round 4, US customary: `sec mph ... deg F ... none [SAE]`, `AMBTMP`, 50 Hz.
    R4Uscs,
    /// Round 4, SI, with the ambient temperature in deg F.
    R4Si,
    /// Round 8, US customary: `s mph ... deg f ... SAE`, `AmbTmp`, ISO False, 100 Hz.
    R8Uscs,
    /// Round 9, SI: `s kph ... Nm ... deg c ... SAE`, Tire_Name/Rim_Width, 100 Hz.
    R9Si,
}

impl ExampleStyle {
    pub const ALL: [ExampleStyle; 4] = [
        ExampleStyle::R4Uscs,
        ExampleStyle::R4Si,
        ExampleStyle::R8Uscs,
        ExampleStyle::R9Si,
    ];

    /// The round whose header line and unit spellings this style writes.
    pub fn round(self) -> RoundStyle {
        match self {
            ExampleStyle::R4Uscs | ExampleStyle::R4Si => RoundStyle::R4,
            ExampleStyle::R8Uscs => RoundStyle::R8,
            ExampleStyle::R9Si => RoundStyle::R9,
        }
    }

    /// Sample rate, Hz.
    pub fn sample_rate_hz(self) -> f64 {
        self.round().sample_rate_hz()
    }

    /// The unit string this style writes for `channel`.
    pub fn unit(self, channel: TtcChannel) -> &'static str {
        let uscs = matches!(self, ExampleStyle::R4Uscs | ExampleStyle::R8Uscs);
        let r4 = self.round() == RoundStyle::R4;
        match channel {
            TtcChannel::Et => {
                if r4 {
                    "sec"
                } else {
                    "s"
                }
            }
            TtcChannel::V => {
                if uscs {
                    "mph"
                } else {
                    "kph"
                }
            }
            TtcChannel::N => "rpm",
            TtcChannel::Sa | TtcChannel::Ia => "deg",
            TtcChannel::Rl | TtcChannel::Re => {
                if uscs {
                    "in"
                } else {
                    "cm"
                }
            }
            TtcChannel::P => {
                if uscs {
                    "psi"
                } else {
                    "kPa"
                }
            }
            TtcChannel::Fx | TtcChannel::Fy | TtcChannel::Fz => {
                if uscs {
                    "lb"
                } else {
                    "N"
                }
            }
            TtcChannel::Mx | TtcChannel::Mz => match self {
                ExampleStyle::R9Si => "Nm",
                ExampleStyle::R4Si => "N-m",
                _ => "ft-lb",
            },
            TtcChannel::Nfx | TtcChannel::Nfy => "none",
            TtcChannel::Rst | TtcChannel::Tsti | TtcChannel::Tstc | TtcChannel::Tsto => {
                match self {
                    ExampleStyle::R4Uscs => "deg F",
                    ExampleStyle::R4Si => "deg C",
                    ExampleStyle::R8Uscs => "deg f",
                    ExampleStyle::R9Si => "deg c",
                }
            }
            TtcChannel::Ambtmp => match self {
                ExampleStyle::R4Uscs | ExampleStyle::R4Si => "deg F",
                ExampleStyle::R8Uscs => "deg f",
                ExampleStyle::R9Si => "deg c",
            },
            TtcChannel::Sr => {
                if r4 {
                    "none"
                } else {
                    "SAE"
                }
            }
            TtcChannel::Sl => "SAE",
        }
    }

    /// Line 1 in this round's style.
    pub fn line1(self) -> Line1 {
        let base = |project, run| Line1 {
            project,
            run,
            ..Line1::default()
        };
        match self {
            ExampleStyle::R4Uscs | ExampleStyle::R4Si => base(1320, 125),
            ExampleStyle::R8Uscs => Line1 {
                date: Some("08-01-2018".into()),
                time: Some("19:19".into()),
                iso: Some(false),
                id: Some("3Scoi1N".into()),
                ..base(1965, 51)
            },
            ExampleStyle::R9Si => Line1 {
                date: Some("01-18-2022".into()),
                time: Some("12:51".into()),
                tire_name: Some("Example 16.0X7.5-10, R20, C2000".into()),
                rim_width_in: Some(7.0),
                iso: Some(false),
                id: Some("j8dxoI9".into()),
                ..base(2356, 4)
            },
        }
    }
}

/// Decimals per channel, as TIRF writes them.
fn decimals(channel: TtcChannel) -> u8 {
    match channel {
        TtcChannel::Et | TtcChannel::Sa | TtcChannel::Ia => 3,
        TtcChannel::Nfx | TtcChannel::Nfy | TtcChannel::Sr | TtcChannel::Sl => 4,
        _ => 2,
    }
}

/// The example signal of `channel` at sample `i`, canonical units (s, km/h, rpm, rad, m, kPa,
/// N, N m, degC, 1), SAE axes.
pub fn example_value(channel: TtcChannel, i: usize, rate_hz: f64) -> f64 {
    let t = i as f64 / rate_hz;
    let sa_deg = 12.0 * (t * 0.5).sin();
    let fz = -1112.06 + 30.0 * (t * 3.0).sin();
    let fy = -2.4 * fz * (sa_deg.to_radians() * 8.0).atan().sin();
    let fx = 40.0 * (t * 0.7).cos();
    match channel {
        TtcChannel::Et => 26.84 + t,
        TtcChannel::V => 40.2336 + 0.2 * (t * 2.0).sin(),
        // Consistent with V and RE (= 0.21 m): N = V / RE * 60 / (2 pi).
        TtcChannel::N => {
            (40.2336 + 0.2 * (t * 2.0).sin()) / 3.6 / 0.21 * 60.0 / std::f64::consts::TAU
        }
        TtcChannel::Sa => sa_deg.to_radians(),
        TtcChannel::Ia => (f64::from((i / 500 % 5) as u32)).to_radians(),
        TtcChannel::Rl => 0.2 + 0.001 * (t * 3.0).sin(),
        TtcChannel::Re => 0.21,
        TtcChannel::P => 82.7 + 0.3 * (t * 0.1).sin(),
        TtcChannel::Fx => fx,
        TtcChannel::Fy => fy,
        TtcChannel::Fz => fz,
        TtcChannel::Mx => -0.02 * fy,
        TtcChannel::Mz => -0.015 * fy * (1.0 - (sa_deg / 12.0).abs()),
        TtcChannel::Nfx => fx / fz,
        TtcChannel::Nfy => fy / fz,
        TtcChannel::Rst => 30.0,
        TtcChannel::Tsti => 55.0 + 10.0 * (t * 0.05).sin(),
        TtcChannel::Tstc => 50.0 + 10.0 * (t * 0.05).sin(),
        TtcChannel::Tsto => 45.0 + 10.0 * (t * 0.05).sin(),
        TtcChannel::Ambtmp => 24.0,
        TtcChannel::Sr => 0.02 * (t * 0.3).sin() + 0.003,
        TtcChannel::Sl => 0.02 * (t * 0.3).sin(),
    }
}

/// The columns of an example run: the 21 standard channels (22 with `with_sl`), in file units.
pub fn example_columns(style: ExampleStyle, rows: usize, with_sl: bool) -> Vec<DatColumn> {
    let rate = style.sample_rate_hz();
    TtcChannel::ALL
        .into_iter()
        .filter(|c| with_sl || *c != TtcChannel::Sl)
        .map(|channel| {
            let unit_text = style.unit(channel);
            let unit = Unit::parse(unit_text).expect("style units are known spellings");
            let name = match (channel, style) {
                (TtcChannel::Ambtmp, ExampleStyle::R8Uscs | ExampleStyle::R9Si) => "AmbTmp",
                _ => channel.name(),
            };
            DatColumn {
                name: name.to_string(),
                unit: unit_text.to_string(),
                decimals: decimals(channel),
                values: (0..rows)
                    .map(|i| unit.from_canonical(example_value(channel, i, rate)))
                    .collect(),
            }
        })
        .collect()
}

/// An example `.dat` file.
pub fn example_dat(style: ExampleStyle, rows: usize, with_sl: bool) -> Vec<u8> {
    render_dat(&style.line1(), &example_columns(style, rows, with_sl))
}

/// An example TTC `.mat` file (SI, the real variable set: 22 channels with SL, `RUN` as uint8,
/// the `channel` struct, `source`, `testid`, `tireid`), values rounded like the `.dat`.
pub fn example_mat(rows: usize, compression: Compression) -> Vec<u8> {
    let style = ExampleStyle::R4Si;
    let columns = example_columns(style, rows, true);
    let mut writer = MatWriter::new("MATLAB 5.0 MAT-file, Platform: PCWIN64, Created on: example");
    for column in &columns {
        let rounded: Vec<f64> = column
            .values
            .iter()
            .map(|v| {
                let mut text = Vec::new();
                push_fixed(&mut text, *v, column.decimals);
                String::from_utf8(text)
                    .expect("ASCII digits")
                    .parse()
                    .expect("number")
            })
            .collect();
        let name = if column.name == "AmbTmp" {
            "AMBTMP"
        } else {
            &column.name
        };
        writer
            .push_column(name, &rounded, compression)
            .expect("valid column");
    }
    let run: Vec<u8> = vec![7; rows];
    writer
        .push_uint8_column("RUN", &run, compression)
        .expect("valid RUN");
    let names: Vec<&str> = columns
        .iter()
        .map(|c| {
            if c.name == "AmbTmp" {
                "AMBTMP"
            } else {
                c.name.as_str()
            }
        })
        .collect();
    let units: Vec<&str> = columns.iter().map(|c| c.unit.as_str()).collect();
    writer
        .push_struct_of_text_cells(
            "channel",
            &[("name", &names), ("units", &units)],
            compression,
        )
        .expect("valid channel struct");
    writer
        .push_text("source", "example", compression)
        .expect("valid text");
    writer
        .push_text("testid", "Cornering", compression)
        .expect("valid text");
    writer
        .push_text("tireid", "Example 18.0x6.0-10 R20, 7 inch rim", compression)
        .expect("valid text");
    writer.finish()
}
