//! The `.tir` file of one group: the fitted PAC2002 model with the spring-rate and relaxation
//! results written in, its identity in the header, and its lint findings.
//!
//! In: a [`GroupResult`] with a PAC2002 fit. Out: a [`WrittenModel`]: file name
//! (`tirebase_core::naming::tir_file_name`), text (Adams PAC2002 layout, SI, ISO-W), the
//! coefficient rows of the `coefficients` table (every value as written, with its origin) and
//! the lint report of the rendered text read back.
//!
//! What goes where: `[DIMENSION] UNLOADED_RADIUS` and `[VERTICAL] VERTICAL_STIFFNESS` from the
//! spring-rate stage (dynamic, at test speed; the PAC2002 stage already used them),
//! `BREFF/DREFF/FREFF` from its effective-radius law, `RIM_WIDTH` from the rim, `WIDTH`,
//! `ASPECT_RATIO` and `RIM_RADIUS` from the size in the tire's name (`16x7.5-10`, `205/55R16`;
//! left out of the file when the name has none, never written as 0), `PTY1/PTY2` and
//! `PTX1..3` from the relaxation stage; `USE_MODE` = the families fitted (1 Fx, 2 Fy+Mz, 3 both
//! pure, 4 combined) + 10 when both relaxation laws were fitted; `[TYRE_CONDITIONS] IP` = median
//! measured pressure of the fitted sweeps, `IP_NOM` = the nominal pressure; `[MDI_HEADER]`
//! comment lines name tire, rim and pressure.
//!
//! Deliberately not here: any fitting, writing files.

use tirebase_core::fit::pac2002::{CoefficientOrigin, Pac2002Fit};
use tirebase_core::fit::spring_rate::EffectiveRadiusLaw;
use tirebase_core::naming::tir_file_name;
use tirebase_core::tire_model::Coef;
use tirebase_core::tire_model::tir::lint::{self, LintReport};
use tirebase_core::tire_model::tir::{TirFile, TirReadError, TirWriteError, TyrePressure};

use super::group::GroupResult;
use crate::config::FitModel;

/// Why a fit's `.tir` was not written (a one-line reason in `fit_failures`).
#[derive(Debug, thiserror::Error)]
pub enum TirBuildError {
    /// The group has no PAC2002 model.
    #[error("no PAC2002 model")]
    NoModel,
    /// The PAC2002 fit fitted no pure family.
    #[error("neither pure Fy nor pure Fx could be fitted (USE_MODE 0)")]
    UseModeZero,
    /// The writer refused the model.
    #[error("cannot render the {}.tir: {source}", model_label(*model))]
    Render {
        /// The model being written.
        model: FitModel,
        /// The writer's reason.
        source: TirWriteError,
    },
    /// The rendered text does not parse.
    #[error("the rendered {}.tir does not read back: {source}", model_label(*model))]
    ReadBack {
        /// The model being written.
        model: FitModel,
        /// The reader's reason.
        source: TirReadError,
    },
}

/// How a reason names a model's file: the PAC2002 one is "the .tir", the MF 6.1 one "the MF 6.1
/// .tir".
fn model_label(model: FitModel) -> &'static str {
    match model {
        FitModel::Pac2002 => "",
        FitModel::Mf61 => "MF 6.1 ",
    }
}

/// One coefficient of a written model: its row of the `coefficients` table (without the group
/// columns), as the table is built (read back, it is `store::results::CoefficientRecord`).
#[derive(Clone, Debug, PartialEq)]
pub struct WrittenCoefficient {
    /// The coefficient.
    pub coef: Coef,
    /// Family name (`Fy0` .. `My`, `relaxation`, `vertical`, `scalar`).
    pub family: String,
    /// Value as written, SI.
    pub value: f64,
    /// Standard error (fitted, off bounds).
    pub std_error: Option<f64>,
    /// On a bound.
    pub at_bound: bool,
    /// Where it comes from.
    pub origin: String,
    /// Why it is held or on a bound (see `FittedCoefficient::note`).
    pub note: Option<String>,
}

/// A model ready to write.
#[derive(Clone, Debug)]
pub struct WrittenModel {
    /// Which model it is (the tables' `model` column).
    pub model: FitModel,
    /// The file as read back from `text`.
    pub file: TirFile,
    /// File name under `OUT/tir/`.
    pub file_name: String,
    /// File text.
    pub text: String,
    /// Coefficient rows in canonical file order.
    pub coefficients: Vec<WrittenCoefficient>,
    /// Lint of the written text.
    pub lint: LintReport,
}

impl WrittenModel {
    /// `file` rendered, read back from its text (what a user's tool will read) and linted.
    pub(super) fn checked(
        model: FitModel,
        file: &TirFile,
        file_name: String,
        coefficients: Vec<WrittenCoefficient>,
    ) -> Result<WrittenModel, TirBuildError> {
        let text = file
            .render()
            .map_err(|source| TirBuildError::Render { model, source })?;
        let (read_back, _) =
            TirFile::parse(&text).map_err(|source| TirBuildError::ReadBack { model, source })?;
        Ok(WrittenModel {
            model,
            file_name,
            lint: lint::lint(&read_back),
            file: read_back,
            text,
            coefficients,
        })
    }
}

fn rows_of(fit: &Pac2002Fit) -> Vec<WrittenCoefficient> {
    fit.coefficients
        .iter()
        .map(|c| WrittenCoefficient {
            coef: c.coef,
            family: c
                .family
                .map_or_else(|| "scalar".to_string(), |f| f.as_str().to_string()),
            value: c.value,
            std_error: c.std_error,
            at_bound: c.at_bound,
            origin: c.origin.as_str().to_string(),
            note: c.note.clone(),
        })
        .collect()
}

/// Put `value` into both the coefficients and the rows.
pub(super) fn set(
    file: &mut TirFile,
    rows: &mut Vec<WrittenCoefficient>,
    coef: Coef,
    value: f64,
    family: &str,
    origin: &str,
) {
    file.coefs[coef] = value;
    let row = WrittenCoefficient {
        coef,
        family: family.to_string(),
        value,
        std_error: None,
        at_bound: false,
        origin: origin.to_string(),
        note: None,
    };
    match rows.iter_mut().find(|r| r.coef == coef) {
        Some(r) => *r = row,
        None => rows.push(row),
    }
}

/// `BREFF`, `DREFF`, `FREFF` from the spring-rate stage's effective-radius law; a `BREFF` on
/// an end of its search interval is marked so, with the reason, like a fitted coefficient on a
/// bound.
pub(super) fn set_effective_radius(
    file: &mut TirFile,
    rows: &mut Vec<WrittenCoefficient>,
    law: &EffectiveRadiusLaw,
) {
    for (coef, value) in [
        (Coef::BREFF, law.breff),
        (Coef::DREFF, law.dreff),
        (Coef::FREFF, law.freff),
    ] {
        set(file, rows, coef, value, "vertical", "spring_rate");
    }
    if law.at_bound
        && let Some(r) = rows.iter_mut().find(|r| r.coef == Coef::BREFF)
    {
        r.at_bound = true;
        r.note = Some(
            "on an end of its search interval ([spring_rate] breff_range): the measured \
             effective radius does not determine the curvature of RE over load, so DREFF and \
             FREFF may offset each other; RE over the tested loads is what the law reproduces"
                .to_string(),
        );
    }
}

/// The geometry coefficients the fits do not use: `WIDTH`, `ASPECT_RATIO`, `RIM_RADIUS`,
/// `RIM_WIDTH`.
pub(super) const GEOMETRY: [Coef; 4] = [
    Coef::WIDTH,
    Coef::ASPECT_RATIO,
    Coef::RIM_RADIUS,
    Coef::RIM_WIDTH,
];

/// Write the [`GEOMETRY`] from the catalog: `RIM_WIDTH` from the rim (inches; none when 0),
/// the others from the tire size in its name; a coefficient with no source is left out of the
/// file, never written as 0.
pub(super) fn set_geometry(
    file: &mut TirFile,
    rows: &mut Vec<WrittenCoefficient>,
    tire: &str,
    rim_in: i64,
) {
    for coef in GEOMETRY {
        file.present[coef] = false;
    }
    if rim_in > 0 {
        set(
            file,
            rows,
            Coef::RIM_WIDTH,
            rim_in as f64 * 0.0254,
            "scalar",
            "data",
        );
        file.present[Coef::RIM_WIDTH] = true;
    }
    if let Some(size) = TireSize::from_name(tire) {
        for (coef, value) in [
            (Coef::WIDTH, size.width_m),
            (Coef::ASPECT_RATIO, size.aspect_ratio),
            (Coef::RIM_RADIUS, size.rim_radius_m),
        ] {
            set(file, rows, coef, value, "scalar", "catalog");
            file.present[coef] = true;
        }
    }
}

/// Build the file of a group; `Err` (a one-line reason) when there is no model to write.
pub fn build(result: &GroupResult, notes: &[String]) -> Result<WrittenModel, TirBuildError> {
    let fit = result.pac2002.as_ref().ok_or(TirBuildError::NoModel)?;
    if fit.use_mode == 0 {
        return Err(TirBuildError::UseModeZero);
    }
    let key = &result.key;
    let mut file = TirFile::from_coefs(fit.model.coefs.clone());
    let mut rows = rows_of(fit);
    // Cz and R0 entered the fit through its context; record their origin as the stage.
    for r in rows.iter_mut() {
        if matches!(r.coef, Coef::VERTICAL_STIFFNESS | Coef::UNLOADED_RADIUS)
            && r.origin == CoefficientOrigin::Context.as_str()
        {
            r.family = "vertical".to_string();
            r.origin = "spring_rate".to_string();
        }
    }
    set_geometry(&mut file, &mut rows, &key.tire, key.rim_in);
    let fnomin = file.coefs[Coef::FNOMIN];
    if let Some(v) = result.spring_rate.as_ref().and_then(|s| s.vertical.first())
        && let Some(law) = &v.effective_radius
        && (law.fnomin_n - fnomin).abs() <= 1e-6 * fnomin.abs().max(1.0)
    {
        set_effective_radius(&mut file, &mut rows, law);
    }
    let mut relaxation_laws = 0;
    if let Some(law) = result.relaxation.as_ref().and_then(|r| r.laws.first()) {
        if let Some((pty1, pty2, ..)) = law.lateral {
            set(
                &mut file,
                &mut rows,
                Coef::PTY1,
                pty1,
                "relaxation",
                "relaxation",
            );
            set(
                &mut file,
                &mut rows,
                Coef::PTY2,
                pty2,
                "relaxation",
                "relaxation",
            );
            relaxation_laws += 1;
        }
        if let Some((ptx1, ptx2, ptx3, ..)) = law.longitudinal {
            set(
                &mut file,
                &mut rows,
                Coef::PTX1,
                ptx1,
                "relaxation",
                "relaxation",
            );
            set(
                &mut file,
                &mut rows,
                Coef::PTX2,
                ptx2,
                "relaxation",
                "relaxation",
            );
            set(
                &mut file,
                &mut rows,
                Coef::PTX3,
                ptx3,
                "relaxation",
                "relaxation",
            );
            relaxation_laws += 1;
        }
    }
    rows.sort_by_key(|r| r.coef);
    file.use_mode = Some(i64::from(fit.use_mode) + if relaxation_laws == 2 { 10 } else { 0 });
    let nominal_pa = key.pressure_kpa_nom as f64 * 1e3;
    file.pressure = TyrePressure {
        inflation_pa: Some(if result.pressure_kpa_mean.is_finite() {
            result.pressure_kpa_mean * 1e3
        } else {
            nominal_pa
        }),
        nominal_pa: Some(nominal_pa),
    };
    file.header_comments = header_comments(result, fit, notes);
    WrittenModel::checked(
        FitModel::Pac2002,
        &file,
        tir_file_name(&key.tire, key.rim_in as f64, key.pressure_kpa_nom as f64),
        rows,
    )
}

/// Tire size from a name: `16x7.5-10` (overall diameter x section width - rim diameter, in;
/// also `16x7.5R10`), `7.0/20.0-13` (width / overall diameter - rim diameter, in) or
/// `205/55R16` (width mm / aspect ratio % R rim diameter in).
#[derive(Copy, Clone, Debug, PartialEq)]
pub(super) struct TireSize {
    pub(super) width_m: f64,
    pub(super) aspect_ratio: f64,
    pub(super) rim_radius_m: f64,
}

impl TireSize {
    pub(super) fn from_name(name: &str) -> Option<TireSize> {
        const IN: f64 = 0.0254;
        name.split_whitespace().find_map(|token| {
            let t = token.to_ascii_lowercase();
            let num = |s: &str| s.parse::<f64>().ok().filter(|v| *v > 0.0);
            if let Some((a, rest)) = t.split_once('x') {
                let (b, rim) = rest.split_once('-').or_else(|| rest.split_once('r'))?;
                let (a, b, rim) = (num(a)?, num(b)?, num(rim)?);
                let (diameter, width) = (a.max(b), a.min(b));
                let side = 0.5 * (diameter - rim);
                (side > 0.0).then(|| TireSize {
                    width_m: width * IN,
                    aspect_ratio: side / width,
                    rim_radius_m: 0.5 * rim * IN,
                })
            } else {
                let (w, rest) = t.split_once('/')?;
                if let Some((ar, rim)) = rest.split_once('r') {
                    let (w, ar, rim) = (num(w)?, num(ar)?, num(rim.trim_start_matches('-'))?);
                    return Some(TireSize {
                        width_m: w * 1e-3,
                        aspect_ratio: ar / 100.0,
                        rim_radius_m: 0.5 * rim * IN,
                    });
                }
                // Width / overall diameter - rim diameter, in.
                let (diameter, rim) = rest.split_once('-')?;
                let (w, diameter, rim) = (num(w)?, num(diameter)?, num(rim)?);
                let side = 0.5 * (diameter - rim);
                (side > 0.0 && w < diameter).then(|| TireSize {
                    width_m: w * IN,
                    aspect_ratio: side / w,
                    rim_radius_m: 0.5 * rim * IN,
                })
            }
        })
    }
}

/// The `RIM_WIDTH_IN` header line, none when the rim is unknown (stored as 0): a `.tir` never
/// states a 0 in rim.
pub(super) fn rim_width_line(rim_in: i64) -> Option<String> {
    (rim_in > 0).then(|| format!("! : RIM_WIDTH_IN :  {rim_in}"))
}

/// The rim in a header comment: `a 7 in rim`, or `an unknown rim (not catalogued)` for 0.
pub(super) fn rim_phrase(rim_in: i64) -> String {
    if rim_in > 0 {
        format!("a {rim_in} in rim")
    } else {
        "an unknown rim (not catalogued)".to_string()
    }
}

fn header_comments(result: &GroupResult, fit: &Pac2002Fit, notes: &[String]) -> Vec<String> {
    let key = &result.key;
    let comment = |text: &str| format!("! : COMMENT :       {text}");
    let families: Vec<String> = fit
        .families
        .iter()
        .map(|f| format!("{} {}", f.family.as_str(), f.status.as_str()))
        .collect();
    let mut out = vec![format!("! : TIRE :          {}", key.tire)];
    out.extend(rim_width_line(key.rim_in));
    out.extend([
        format!("! : PRESSURE_KPA :  {}", key.pressure_kpa_nom),
        comment(&format!(
            "{} on {} at {} kPa nominal, fitted by tirebase fit {} from {} sweeps",
            key.tire,
            rim_phrase(key.rim_in),
            key.pressure_kpa_nom,
            env!("CARGO_PKG_VERSION"),
            result.n_pac2002_segments
        )),
        comment(&format!("families: {}", families.join(", "))),
    ]);
    out.extend(notes.iter().map(|n| comment(&n.replace('\n', " "))));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tire_sizes_from_names() {
        let s = TireSize::from_name("Hoosier 43075 16x7.5-10 LCO").unwrap();
        assert!((s.width_m - 7.5 * 0.0254).abs() < 1e-12);
        assert!((s.rim_radius_m - 5.0 * 0.0254).abs() < 1e-12);
        assert!((s.aspect_ratio - 3.0 / 7.5).abs() < 1e-12);
        let s = TireSize::from_name("Hoosier 20.5x7.0-13 R25B").unwrap();
        assert!((s.rim_radius_m - 6.5 * 0.0254).abs() < 1e-12);
        let s = TireSize::from_name("Some 205/55R16 91V").unwrap();
        assert!((s.width_m - 0.205).abs() < 1e-12 && (s.aspect_ratio - 0.55).abs() < 1e-12);
        let s = TireSize::from_name("Avon 7.0/20.0-13 A45").unwrap();
        assert!((s.width_m - 7.0 * 0.0254).abs() < 1e-12);
        assert!((s.rim_radius_m - 6.5 * 0.0254).abs() < 1e-12);
        assert_eq!(TireSize::from_name("projectunknown-rununknown"), None);
        assert_eq!(TireSize::from_name("Tire A"), None);
    }

    #[test]
    fn an_effective_radius_law_on_its_breff_bound_says_so() {
        let law = |at_bound| EffectiveRadiusLaw {
            breff: 0.05,
            dreff: -125.8,
            freff: 6.58,
            fnomin_n: 1646.0,
            rmse_m: 1e-4,
            n: 500,
            at_bound,
        };
        let mut file = TirFile::from_coefs(tirebase_core::tire_model::Coefs::defaults());
        let mut rows = Vec::new();
        set_effective_radius(&mut file, &mut rows, &law(true));
        let breff = rows.iter().find(|r| r.coef == Coef::BREFF).unwrap();
        assert!(breff.at_bound, "{rows:?}");
        assert!(breff.note.as_deref().unwrap().contains("breff_range"));
        assert_eq!(file.coefs[Coef::DREFF], -125.8);
        assert!(rows.iter().filter(|r| r.at_bound).count() == 1);
        set_effective_radius(&mut file, &mut rows, &law(false));
        assert!(
            rows.iter().all(|r| !r.at_bound && r.note.is_none()),
            "{rows:?}"
        );
        assert_eq!(rows.len(), 3);
    }
}
