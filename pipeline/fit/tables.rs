//! The result tables of `tirebase fit`, built from the groups' results and conformed to their
//! schemas (`schemas/<name>.toml`).
//!
//! In: the per-group results (already in group order) and the written models. Out: one
//! DataFrame per table: `coefficients`, `fit_quality`, `lint`, `fit_failures`, `spring_rate`,
//! `thermal`, `thermal_fit`, `relaxation`. Every table starts with `tire, rim_in, pressure_kpa`
//! (nominal); rows follow group order, then each stage's own deterministic order. A NaN in a
//! column the schema declares nullable is written as null (NaN elsewhere stays NaN).
//!
//! Deliberately not here: computing anything, writing files.

use polars::prelude::*;
use tirebase_core::fit::pac2002::Family;
use tirebase_core::fit::segment_data::TireKey;
use tirebase_core::fit::sweep_folds::OutOfSampleQuality;

use super::group::GroupResult;
use super::mf61::Mf61Outcome;
use super::tir::WrittenModel;
use super::{FitError, FitFailure};
use crate::config::FitModel;
use crate::schema::{self, TableName};

/// A column being built.
enum Data {
    Str(Vec<String>),
    OptStr(Vec<Option<String>>),
    F64(Vec<f64>),
    I64(Vec<i64>),
    OptI64(Vec<Option<i64>>),
    Bool(Vec<bool>),
}

/// A table being built row by row: every push adds one value to the named column.
struct Frame {
    name: TableName,
    columns: Vec<(&'static str, Data)>,
}

impl Frame {
    fn new(name: TableName) -> Frame {
        Frame {
            name,
            columns: Vec::new(),
        }
    }

    fn slot(&mut self, col: &'static str, empty: fn() -> Data) -> &mut Data {
        let k = match self.columns.iter().position(|(n, _)| *n == col) {
            Some(k) => k,
            None => {
                self.columns.push((col, empty()));
                self.columns.len() - 1
            }
        };
        &mut self.columns[k].1
    }

    fn s(&mut self, col: &'static str, v: impl Into<String>) -> &mut Self {
        if let Data::Str(x) = self.slot(col, || Data::Str(Vec::new())) {
            x.push(v.into());
        }
        self
    }

    fn o(&mut self, col: &'static str, v: Option<String>) -> &mut Self {
        if let Data::OptStr(x) = self.slot(col, || Data::OptStr(Vec::new())) {
            x.push(v);
        }
        self
    }

    fn f(&mut self, col: &'static str, v: f64) -> &mut Self {
        if let Data::F64(x) = self.slot(col, || Data::F64(Vec::new())) {
            x.push(v);
        }
        self
    }

    fn i(&mut self, col: &'static str, v: i64) -> &mut Self {
        if let Data::I64(x) = self.slot(col, || Data::I64(Vec::new())) {
            x.push(v);
        }
        self
    }

    fn oi(&mut self, col: &'static str, v: Option<i64>) -> &mut Self {
        if let Data::OptI64(x) = self.slot(col, || Data::OptI64(Vec::new())) {
            x.push(v);
        }
        self
    }

    fn b(&mut self, col: &'static str, v: bool) -> &mut Self {
        if let Data::Bool(x) = self.slot(col, || Data::Bool(Vec::new())) {
            x.push(v);
        }
        self
    }

    fn key(&mut self, key: &TireKey) -> &mut Self {
        self.s("tire", key.tire.clone())
            .i("rim_in", key.rim_in)
            .i("pressure_kpa", key.pressure_kpa_nom)
    }

    /// The conformed frame (an empty table has every schema column and no rows).
    fn finish(self) -> Result<DataFrame, FitError> {
        let table = schema::table(self.name);
        if self.columns.is_empty() {
            return Ok(DataFrame::empty_with_schema(&table.file_schema()));
        }
        let nullable = |name: &str| table.columns.iter().any(|c| c.name == name && c.nullable);
        let mut cols = Vec::with_capacity(self.columns.len());
        for (name, data) in self.columns {
            let col = match data {
                Data::Str(v) => Column::new(name.into(), v),
                Data::OptStr(v) => Column::new(name.into(), v),
                Data::I64(v) => Column::new(name.into(), v),
                Data::OptI64(v) => Column::new(name.into(), v),
                Data::Bool(v) => Column::new(name.into(), v),
                Data::F64(v) if nullable(name) => Column::new(
                    name.into(),
                    v.into_iter()
                        .map(|x| x.is_finite().then_some(x))
                        .collect::<Vec<Option<f64>>>(),
                ),
                Data::F64(v) => Column::new(name.into(), v),
            };
            cols.push(col);
        }
        let df = DataFrame::new_infer_height(cols).map_err(|e| FitError::Table {
            table: self.name,
            message: e.to_string(),
        })?;
        Ok(table.conform(df)?)
    }
}

/// `coefficients` from the written models.
pub fn coefficients(models: &[(TireKey, WrittenModel)]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::Coefficients);
    for (key, m) in models {
        for c in &m.coefficients {
            f.key(key)
                .s("model", m.model.as_str())
                .s("family", c.family.clone())
                .s("name", c.coef.name())
                .f("value", c.value)
                .f("std_error", c.std_error.unwrap_or(f64::NAN))
                .b("at_bound", c.at_bound)
                .s("origin", c.origin.clone())
                .o("note", c.note.clone());
        }
    }
    f.finish()
}

/// `lint` from the written models.
pub fn lint(models: &[(TireKey, WrittenModel)]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::Lint);
    for (key, m) in models {
        for finding in &m.lint.findings {
            f.key(key)
                .s("model", m.model.as_str())
                .s("file", m.file_name.clone())
                .s("severity", finding.severity.to_string())
                .s("code", finding.code)
                .s("message", finding.message.clone());
        }
    }
    f.finish()
}

/// `fit_quality`: one row per fitted family of every written PAC2002 model (`pac2002`: the
/// PAC2002 models are written), then per tested pressure and family of every MF 6.1 model; rows
/// sorted by group, PAC2002 before MF 6.1 within a group. `oos_ratio_limit` decides `oos_flag`
/// ([`tirebase_core::fit::pac2002::FitConfig::oos_ratio_limit`]).
pub fn fit_quality(
    results: &[GroupResult],
    pac2002: bool,
    mf61: &[Mf61Outcome],
    oos_ratio_limit: f64,
) -> Result<DataFrame, FitError> {
    let mut rows: Vec<(TireKey, u8, Frame)> = Vec::new();
    for r in results.iter().filter(|_| pac2002) {
        let Some(fit) = &r.pac2002 else { continue };
        let mut f = Frame::new(TableName::FitQuality);
        for fam in &fit.families {
            let Some(q) = &fam.quality else { continue };
            let t_ref = r.grip.as_ref().and_then(|g| match fam.family {
                Family::Fx0 | Family::Fx => g.longitudinal_t_ref_c,
                Family::My => None,
                _ => g.lateral_t_ref_c,
            });
            let oos = q.out_of_sample.as_ref();
            let trend = q.trend.as_ref();
            let id = &q.identifiability;
            f.key(&r.key)
                .s("model", FitModel::Pac2002.as_str())
                .s("channel", fam.family.as_str())
                .f("oos_rmse", oos.map_or(f64::NAN, |o| o.rmse))
                .f("rmse", q.rmse)
                .f("oos_ratio", q.oos_ratio())
                .b("oos_flag", q.oos_flagged(oos_ratio_limit))
                .f("grip_t_ref_c", t_ref.unwrap_or(f64::NAN))
                .f("trend_dev_max", trend.map_or(f64::NAN, |t| t.max))
                .f(
                    "trend_dev_pct_of_peak",
                    trend.map_or(f64::NAN, |t| 100.0 * t.max / q.peak()),
                )
                .o("trend_dev_sweep", trend.map(|t| t.sweep.clone()))
                .f("trend_dev_slip", trend.map_or(f64::NAN, |t| t.slip))
                .i("oos_folds", oos.map_or(0, |o| o.folds as i64))
                .i("oos_n", oos.map_or(0, |o| o.n as i64))
                .i(
                    "oos_deficient_folds",
                    oos.map_or(0, |o| o.deficient_folds as i64),
                )
                .f("lopo_rmse", f64::NAN)
                .f("lopo_ratio", f64::NAN)
                .oi("n_free", Some(id.n_free as i64))
                .oi("jacobian_rank", Some(id.rank as i64))
                .f("condition_number", id.condition)
                .i("n", q.n as i64)
                .f("rmse_pct_of_peak", q.rmse_pct_of_peak)
                .f("r2", q.r2)
                .oi("n_samples", Some(q.n_samples as i64))
                .f("sample_rmse", q.sample_rmse)
                .f("initial_rmse", q.initial_rmse)
                .i("iterations", q.iterations as i64)
                .s("termination", q.termination.as_str())
                .i("evaluations", q.evaluations as i64)
                .f("seconds", q.seconds);
        }
        rows.push((r.key.clone(), 0, f));
    }
    for o in mf61 {
        let Some(fit) = &o.fit else { continue };
        let mut by_pressure: std::collections::BTreeMap<i64, Frame> = Default::default();
        for q in &fit.family_quality {
            let key = TireKey {
                pressure_kpa_nom: q.pressure_kpa_nom,
                ..o.key.clone()
            };
            let family = fit.families.iter().find(|x| x.family == q.family);
            let id = family.map(|x| &x.identifiability);
            by_pressure
                .entry(q.pressure_kpa_nom)
                .or_insert_with(|| Frame::new(TableName::FitQuality))
                .key(&key)
                .s("model", FitModel::Mf61.as_str())
                .s("channel", q.family.as_str())
                .f("oos_rmse", q.oos_rmse.unwrap_or(f64::NAN))
                .f("rmse", q.rmse)
                .f("oos_ratio", q.oos_ratio())
                .b("oos_flag", q.oos_flagged(oos_ratio_limit))
                .f("grip_t_ref_c", f64::NAN)
                .f("trend_dev_max", f64::NAN)
                .f("trend_dev_pct_of_peak", f64::NAN)
                .o("trend_dev_sweep", None)
                .f("trend_dev_slip", f64::NAN)
                .i("oos_folds", q.oos_folds as i64)
                .i("oos_n", q.oos_n as i64)
                .i("oos_deficient_folds", q.oos_deficient_folds as i64)
                .f("lopo_rmse", q.lopo_rmse.unwrap_or(f64::NAN))
                .f("lopo_ratio", q.lopo_ratio())
                .oi("n_free", id.map(|i| i.n_free as i64))
                .oi("jacobian_rank", id.map(|i| i.rank as i64))
                .f("condition_number", id.map_or(f64::NAN, |i| i.condition))
                .i("n", q.n as i64)
                .f("rmse_pct_of_peak", q.rmse_pct_of_peak)
                .f("r2", q.r2)
                .oi("n_samples", None)
                .f("sample_rmse", f64::NAN)
                .f("initial_rmse", f64::NAN)
                .i("iterations", family.map_or(0, |x| x.iterations as i64))
                .s(
                    "termination",
                    family.map_or("not_refined", |x| x.termination.as_str()),
                )
                .i("evaluations", family.map_or(0, |x| x.evaluations as i64))
                .f("seconds", family.map_or(0.0, |x| x.seconds));
        }
        for (p, f) in by_pressure {
            let key = TireKey {
                pressure_kpa_nom: p,
                ..o.key.clone()
            };
            rows.push((key, 1, f));
        }
    }
    rows.sort_by(|a, b| (&a.0, a.1).cmp(&(&b.0, b.1)));
    let mut out: Option<DataFrame> = None;
    for (_, _, f) in rows {
        let df = f.finish()?;
        out = Some(match out {
            None => df,
            Some(acc) => acc.vstack(&df).map_err(|e| FitError::Table {
                table: TableName::FitQuality,
                message: e.to_string(),
            })?,
        });
    }
    match out {
        Some(df) => Ok(df),
        None => Frame::new(TableName::FitQuality).finish(),
    }
}

/// `fit_failures`.
pub fn fit_failures(failures: &[FitFailure]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::FitFailures);
    for x in failures {
        f.s("tire", x.tire.clone())
            .i("rim_in", x.rim_in)
            .i("pressure_kpa", x.pressure_kpa)
            .s("stage", x.stage.clone())
            .s("scope", x.scope.clone())
            .b("fatal", x.fatal)
            .s("reason", x.reason.clone());
    }
    f.finish()
}

/// `spring_rate`.
pub fn spring_rate(results: &[GroupResult]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::SpringRate);
    for r in results.iter().filter_map(|r| r.spring_rate.as_ref()) {
        for row in &r.rows {
            f.key(&row.key)
                .oi("ia_cdeg_nom", row.ia_cdeg_nom)
                .s("condition", row.condition.as_str())
                .f("stiffness_n_per_m", row.stiffness_n_per_m)
                .f("stiffness_std_n_per_m", row.stiffness_std_n_per_m)
                .f("unloaded_radius_m", row.unloaded_radius_m)
                .f("unloaded_radius_std_m", row.unloaded_radius_std_m)
                .i("n", row.n as i64)
                .i("n_segments", row.n_segments as i64)
                .f("r2", row.r2)
                .f("residual_rms_m", row.residual_rms_m)
                .f("speed_kph", row.speed_kph)
                .f("pressure_kpa_mean", row.pressure_kpa_mean)
                .f("fz_n_min", row.fz_n_min)
                .f("fz_n_max", row.fz_n_max);
        }
    }
    f.finish()
}

/// `thermal` (per-sweep quadrant rows).
pub fn thermal(results: &[GroupResult]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::Thermal);
    for t in results.iter().filter_map(|r| r.thermal.as_ref()) {
        for row in &t.rows {
            f.key(&row.key)
                .s("segment_id", row.segment_id.clone())
                .s("source_file", row.source_file.clone())
                .s("quadrant", row.quadrant.as_str())
                .f("et_peak_s", row.et_peak_s)
                .f("alpha_peak_rad", row.alpha_peak_rad)
                .f("fz_n", row.fz_n)
                .f("mu_peak", row.mu_peak)
                .b("peak_interior", row.peak_interior)
                .f("t_centre_peak_c", row.t_centre_peak_c)
                .f("t_inner_peak_c", row.t_inner_peak_c)
                .f("t_outer_peak_c", row.t_outer_peak_c)
                .f("ir_delay_s", row.ir_delay_s)
                .f("force_lag_s", row.force_lag_s)
                .f("dtdt_peak_c_per_s", row.dtdt_peak_c_per_s)
                .f("mu_time_curvature_per_s2", row.mu_time_curvature_per_s2)
                .f("alpha_rate_rad_per_s", row.alpha_rate_rad_per_s)
                .f(
                    "cornering_stiffness_n_per_rad",
                    row.cornering_stiffness_n_per_rad,
                )
                .f("alpha_delineation_rad", row.alpha_delineation_rad)
                .f("fy_delineation_n", row.fy_delineation_n)
                .f("dtdt_mean_c_per_s", row.dtdt_mean_c_per_s)
                .f("dtdt_slope_c_per_s", row.dtdt_slope_c_per_s)
                .f("mu_break_even", row.mu_break_even);
        }
    }
    f.finish()
}

/// `thermal_fit` (one mu(T) curve per group).
pub fn thermal_fit(results: &[GroupResult]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::ThermalFit);
    for t in results.iter().filter_map(|r| r.thermal.as_ref()) {
        for row in &t.fits {
            f.key(&row.key)
                .f("t_peak_c", row.t_peak_c)
                .f("gain_peak_over_cold", row.gain_peak_over_cold)
                .f("t_cold_c", row.t_cold_c)
                .s("t_cold_source", row.t_cold_source)
                .f("k_cold_per_c2", row.k_cold_per_c2)
                .f("hot_falloff", row.hot_falloff)
                .b("hot_side_observed", row.hot_side_observed)
                .f("mu_peak_mean", row.mu_peak_mean)
                .i("n", row.n as i64)
                .f("rmse", row.rmse)
                .b("converged", row.converged);
        }
    }
    f.finish()
}

/// `relaxation`.
pub fn relaxation(results: &[GroupResult]) -> Result<DataFrame, FitError> {
    let mut f = Frame::new(TableName::Relaxation);
    for x in results.iter().filter_map(|r| r.relaxation.as_ref()) {
        for row in &x.rows {
            f.key(&row.key)
                .oi("fz_n_nom", row.fz_n_nom)
                .f("fz_n_mean", row.fz_n_mean)
                .oi("ia_cdeg_nom", row.ia_cdeg_nom)
                .s("direction", row.direction.as_str())
                .s("method", row.method.as_str())
                .f("slip_rate", row.slip_rate)
                .f("speed_kph", row.speed_kph)
                .f("sigma_m", row.sigma_m)
                .f("sigma_row_m", row.sigma_row_m)
                .f("sigma_spread_m", row.sigma_spread_m)
                .f("sigma_se_m", row.sigma_se_m)
                .f("sigma_prior_m", row.sigma_prior_m)
                .f("pool_weight", row.pool_weight)
                .f("sigma_law_m", row.sigma_law_m)
                .f("deflection_m", row.deflection_m)
                .f("contact_half_length_m", row.contact_half_length_m)
                .f("slip_stiffness", row.slip_stiffness)
                .f("carcass_stiffness_n_per_m", row.carcass_stiffness_n_per_m)
                .f("residual_rms_n", row.residual_rms_n)
                .i("n", row.n as i64)
                .i("n_segments", row.n_segments as i64)
                .f("model_scale", row.model_scale)
                .f("model_offset_n", row.model_offset_n)
                .b("converged", row.converged)
                .b("at_bound", row.at_bound)
                .f("measurement_lag_s", row.measurement_lag_s)
                .b("lag_separated", row.lag_separated)
                .s("lag_note", row.lag_note.clone())
                .f("apparent_lag_s", row.apparent_lag_s)
                .b("scale_drift", row.scale_drift);
        }
    }
    f.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_is_null_only_where_the_schema_allows_it() {
        let key = TireKey {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa_nom: 83,
        };
        let failures = vec![FitFailure::new(
            &key,
            "pac2002",
            "pac2002",
            true,
            "no\nsweeps".into(),
        )];
        let df = fit_failures(&failures).unwrap();
        assert_eq!(df.height(), 1);
        assert_eq!(
            df.get_column_names()
                .iter()
                .map(|c| c.as_str())
                .collect::<Vec<_>>(),
            [
                "tire",
                "rim_in",
                "pressure_kpa",
                "stage",
                "scope",
                "fatal",
                "reason"
            ]
        );
        let reason = df.column("reason").unwrap().str().unwrap().get(0).unwrap();
        assert_eq!(reason, "no sweeps", "one-line reasons");

        let mut f = Frame::new(TableName::Coefficients);
        f.key(&key)
            .s("model", "pac2002")
            .s("family", "Fy0")
            .s("name", "PDY1")
            .f("value", -2.5)
            .f("std_error", f64::NAN)
            .b("at_bound", false)
            .s("origin", "fitted")
            .o("note", None);
        let df = f.finish().unwrap();
        assert_eq!(df.column("std_error").unwrap().null_count(), 1);
        assert_eq!(df.column("note").unwrap().null_count(), 1);
        assert_eq!(df.column("value").unwrap().null_count(), 0);
    }

    #[test]
    fn empty_tables_have_every_column() {
        let df = relaxation(&[]).unwrap();
        assert_eq!(df.height(), 0);
        assert_eq!(
            df.width(),
            schema::table(schema::TableName::Relaxation)
                .file_columns()
                .count()
        );
    }
}
