//! From simulated channels to the consortium's file contents: axes, units, decimals, headers.
//!
//! In: [`RunSamples`] (SI, ISO-W) and a [`FileStyle`] (round style 4/8/9, US customary or SI,
//! `.dat` or `.mat`). Out: a [`ChannelTable`] (names, unit spellings, decimals, SAE columns in the
//! file's units) and line 1 of a `.dat` file ([`header_line`]). The ISO-W -> SAE flip happens in
//! `frame::TireChannels::into_sae`, nowhere else. Deliberately not here: the `.dat` and `.mat`
//! encodings (the TTC writers in `crate::ttc`), defects (`defects.rs`).

use crate::frame::{IsoW, TireChannels};
use crate::ttc::dat::{DatColumn, RoundStyle};

use super::machine::RunSamples;
use super::tires::{KPA_PER_PSI, M_PER_IN, N_PER_LBF};

/// N m per ft-lb.
pub const NM_PER_FTLB: f64 = 1.355_817_948_331_400_4;
/// km/h per mph.
pub const KPH_PER_MPH: f64 = 1.609_344;

/// Unit system of a file (the file name's prefix letter).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum FileUnits {
    /// Prefix `A`: mph, in, psi, lb, ft-lb, deg F.
    UsCustomary,
    /// Prefix `B`: km/h, cm, kPa, N, N m, deg C.
    Si,
}

/// Container of a file.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Container {
    Dat,
    Mat,
}

/// Everything that decides a run file's format.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct FileStyle {
    pub round: RoundStyle,
    pub units: FileUnits,
    pub container: Container,
    /// Dwells kept (`raw` in the name) instead of cut (`run`).
    pub raw: bool,
}

impl FileStyle {
    /// Sample rate of the file's round style.
    pub fn rate_hz(&self) -> f64 {
        self.round.sample_rate_hz()
    }

    /// `<prefix><project>run<N>.<ext>` or `...raw<N>...`.
    pub fn file_name(&self, project: u32, run: u32) -> String {
        let prefix = match self.units {
            FileUnits::UsCustomary => 'A',
            FileUnits::Si => 'B',
        };
        let what = if self.raw { "raw" } else { "run" };
        let ext = match self.container {
            Container::Dat => "dat",
            Container::Mat => "mat",
        };
        format!("{prefix}{project}{what}{run}.{ext}")
    }
}

/// The styles a round cycles through, so every reader path is exercised.
pub const STYLE_CYCLE: [FileStyle; 6] = [
    FileStyle {
        round: RoundStyle::R4,
        units: FileUnits::UsCustomary,
        container: Container::Dat,
        raw: false,
    },
    FileStyle {
        round: RoundStyle::R9,
        units: FileUnits::Si,
        container: Container::Dat,
        raw: false,
    },
    FileStyle {
        round: RoundStyle::R8,
        units: FileUnits::Si,
        container: Container::Mat,
        raw: false,
    },
    FileStyle {
        round: RoundStyle::R8,
        units: FileUnits::UsCustomary,
        container: Container::Dat,
        raw: true,
    },
    FileStyle {
        round: RoundStyle::R4,
        units: FileUnits::Si,
        container: Container::Dat,
        raw: false,
    },
    FileStyle {
        round: RoundStyle::R9,
        units: FileUnits::Si,
        container: Container::Mat,
        raw: true,
    },
];

/// A run file's columns in file order, SAE axes, file units.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelTable {
    pub columns: Vec<DatColumn>,
}

impl ChannelTable {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.values.len())
    }

    /// The column called `name` (exact).
    pub fn column_mut(&mut self, name: &str) -> Option<&mut DatColumn> {
        self.columns.iter_mut().find(|c| c.name == name)
    }

    /// The column called `name` (exact).
    pub fn column(&self, name: &str) -> Option<&DatColumn> {
        self.columns.iter().find(|c| c.name == name)
    }
}

fn pick(v: &[f64], keep: &[usize], f: impl Fn(f64) -> f64) -> Vec<f64> {
    keep.iter().map(|&i| f(v[i])).collect()
}

/// Build the file's columns from the samples at indices `keep` (in order). `with_sl` adds the
/// `SL` column (drive/brake `.dat`, every `.mat`).
pub fn channel_table(
    s: &RunSamples,
    keep: &[usize],
    style: &FileStyle,
    with_sl: bool,
) -> ChannelTable {
    let sel = |v: &Vec<f64>| pick(v, keep, |x| x);
    let sae = TireChannels::<IsoW>::new(
        sel(&s.fx_n),
        sel(&s.fy_n),
        sel(&s.fz_n),
        sel(&s.mx_nm),
        Vec::new(),
        sel(&s.mz_nm),
        sel(&s.alpha_rad),
        sel(&s.gamma_rad),
        sel(&s.sl),
    )
    .into_sae();
    let us = style.units == FileUnits::UsCustomary;
    let mat = style.container == Container::Mat;
    let r4 = style.round == RoundStyle::R4 || mat;
    let (force, moment, length, speed, pressure) = if us {
        ("lb", "ft-lb", "in", "mph", "psi")
    } else if r4 {
        ("N", "N-m", "cm", "kph", "kPa")
    } else {
        ("N", "Nm", "cm", "kph", "kPa")
    };
    let temp = match (us, r4) {
        (true, true) => "deg F",
        (true, false) => "deg f",
        (false, true) => "deg C",
        (false, false) => "deg c",
    };
    // Round 4 SI .dat files label (and hold) the ambient temperature in deg F.
    let amb_f = us || (style.round == RoundStyle::R4 && !mat);
    let amb_unit = if amb_f && !us { "deg F" } else { temp };
    let time = if r4 { "sec" } else { "s" };
    let ratio = if r4 { "none" } else { "SAE" };
    let f = |x: f64| if us { x / N_PER_LBF } else { x };
    let m = |x: f64| if us { x / NM_PER_FTLB } else { x };
    let l = |x: f64| if us { x / M_PER_IN } else { x * 100.0 };
    let t = |x: f64| if us { x * 1.8 + 32.0 } else { x };
    let deg = |v: &[f64]| v.iter().map(|x| x.to_degrees()).collect::<Vec<_>>();
    let fx: Vec<f64> = sae.fx_n.iter().map(|&x| f(x)).collect();
    let fy: Vec<f64> = sae.fy_n.iter().map(|&x| f(x)).collect();
    let fz: Vec<f64> = sae.fz_n.iter().map(|&x| f(x)).collect();
    let nfx = sae
        .fx_n
        .iter()
        .zip(&sae.fz_n)
        .map(|(a, b)| if b.abs() > 1.0 { a / b } else { 0.0 })
        .collect();
    let nfy = sae
        .fy_n
        .iter()
        .zip(&sae.fz_n)
        .map(|(a, b)| if b.abs() > 1.0 { a / b } else { 0.0 })
        .collect();
    let col = |name: &str, unit: &str, decimals, values| DatColumn {
        name: name.to_string(),
        unit: unit.to_string(),
        decimals,
        values,
    };
    let mut columns = vec![
        col("ET", time, 3, sel(&s.et_s)),
        col(
            "V",
            speed,
            2,
            pick(&s.v_mps, keep, |x| {
                if us { x * 3.6 / KPH_PER_MPH } else { x * 3.6 }
            }),
        ),
        col("N", "rpm", 2, sel(&s.n_rpm)),
        col("SA", "deg", 3, deg(&sae.alpha_rad)),
        col("IA", "deg", 3, deg(&sae.gamma_rad)),
        col("RL", length, 3, pick(&s.rl_m, keep, l)),
        col("RE", length, 3, pick(&s.re_m, keep, l)),
        col(
            "P",
            pressure,
            2,
            pick(&s.p_kpa, keep, |x| if us { x / KPA_PER_PSI } else { x }),
        ),
        col("FX", force, 2, fx),
        col("FY", force, 2, fy),
        col("FZ", force, 2, fz),
        col("MX", moment, 2, sae.mx_nm.iter().map(|&x| m(x)).collect()),
        col("MZ", moment, 2, sae.mz_nm.iter().map(|&x| m(x)).collect()),
        col("NFX", "none", 4, nfx),
        col("NFY", "none", 4, nfy),
        col("RST", temp, 2, pick(&s.road_c, keep, t)),
        col("TSTI", temp, 2, pick(&s.tread_inner_c, keep, t)),
        col("TSTC", temp, 2, pick(&s.tread_centre_c, keep, t)),
        col("TSTO", temp, 2, pick(&s.tread_outer_c, keep, t)),
        col(
            if r4 { "AMBTMP" } else { "AmbTmp" },
            amb_unit,
            2,
            pick(
                &s.ambient_c,
                keep,
                |x| if amb_f { x * 1.8 + 32.0 } else { x },
            ),
        ),
        col("SR", ratio, 4, sel(&s.sr)),
    ];
    if with_sl {
        columns.push(col("SL", "SAE", 4, sae.kappa.clone()));
    }
    ChannelTable { columns }
}

/// What line 1 of a `.dat` file may say about the run.
#[derive(Clone, Debug, PartialEq)]
pub struct HeaderFields<'a> {
    pub project: u32,
    pub run: u32,
    /// `MM-DD-YYYY`.
    pub date: &'a str,
    /// `HH:MM`.
    pub time: &'a str,
    pub tire_name: &'a str,
    pub rim_in: f64,
    /// 7-character run ID.
    pub id: &'a str,
}

/// Line 1 of a `.dat` file in the style of the round.
pub fn header_line(style: &FileStyle, h: &HeaderFields) -> String {
    let HeaderFields {
        project,
        run,
        date,
        time,
        tire_name,
        rim_in,
        id,
    } = h;
    match style.round {
        RoundStyle::R4 => format!("TIRF Data File: Project {project}; Run {run}"),
        RoundStyle::R8 => format!(
            "TIRF Data File: Project {project}; Run {run:03}; Date {date}; Time {time}; ISO False; ID {id}"
        ),
        RoundStyle::R9 => format!(
            "TIRF Data File: Project {project}; Run {run:03}; Date {date}; Time {time}; Tire_Name={tire_name}; Rim_Width={rim_in:.1}; ISO False; ID {id}"
        ),
    }
}
