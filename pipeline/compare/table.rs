//! A [`Comparison`] as the `compare` table (`schemas/compare.toml`, expanded per corner load)
//! and as an aligned text table.
//!
//! In: a comparison. Out: a DataFrame conforming to the schema (column order, dtypes,
//! nullability checked), and text with up to 4 significant digits per number. Deliberately not
//! here: computing anything; the CSV writer (`crate::query::write_csv`).

use polars::prelude::*;

use super::{Comparison, objective_column};
use crate::schema::TableName;
use crate::store::StoreError;

/// The comparison as the `compare` table.
pub fn to_frame(c: &Comparison) -> Result<DataFrame, StoreError> {
    let schema = crate::schema::table(TableName::Compare).for_loads(&c.car.loads_whole_n());
    let rows = &c.rows;
    let opt = |v: Option<f64>| v.filter(|x| x.is_finite());
    let f = |g: &dyn Fn(&super::CompareRow) -> f64| -> Vec<f64> { rows.iter().map(g).collect() };
    let o = |g: &dyn Fn(&super::CompareRow) -> Option<f64>| -> Vec<Option<f64>> {
        rows.iter().map(|r| opt(g(r))).collect()
    };
    let mut cols: Vec<Column> = vec![
        Column::new(
            "rank".into(),
            rows.iter()
                .map(|r| r.rank.map(|k| k as i64))
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "tied_with".into(),
            rows.iter()
                .map(|r| {
                    r.tied_with
                        .iter()
                        .map(|&j| rows[j].label(c.cross_round()))
                        .collect::<Vec<_>>()
                        .join("; ")
                })
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "objective".into(),
            vec![objective_column(c.objective); rows.len()],
        ),
        Column::new("objective_error".into(), o(&|r| Some(r.objective_error))),
        Column::new(
            "error_source".into(),
            rows.iter()
                .map(|r| r.error_source.clone())
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "round".into(),
            rows.iter().map(|r| r.round.clone()).collect::<Vec<_>>(),
        ),
        Column::new(
            "tire".into(),
            rows.iter().map(|r| r.tire.clone()).collect::<Vec<_>>(),
        ),
        Column::new(
            "rim_in".into(),
            rows.iter().map(|r| r.rim_in).collect::<Vec<_>>(),
        ),
        Column::new(
            "pressure_kpa".into(),
            rows.iter().map(|r| r.pressure_kpa).collect::<Vec<_>>(),
        ),
        Column::new("pressure_source".into(), vec!["tested"; rows.len()]),
        Column::new(
            "best_pressure".into(),
            rows.iter().map(|r| r.best_pressure).collect::<Vec<_>>(),
        ),
        Column::new(
            "camber_deg".into(),
            f(&|r| r.figures.camber_rad.to_degrees()),
        ),
        Column::new(
            "camber_at_bound".into(),
            rows.iter()
                .map(|r| r.figures.camber_at_bound)
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "camber_gain_pct".into(),
            o(&|r| Some(100.0 * r.figures.camber_gain)),
        ),
        Column::new("lateral_mu".into(), o(&|r| Some(r.figures.lateral_mu))),
        Column::new(
            "longitudinal_mu".into(),
            o(&|r| Some(r.figures.longitudinal_mu)),
        ),
    ];
    for (k, fz) in c.car.loads_whole_n().iter().enumerate() {
        let at = |g: &dyn Fn(&tirebase_core::compare::LoadFigures) -> f64| -> Vec<Option<f64>> {
            rows.iter()
                .map(|r| opt(Some(g(&r.figures.loads[k]))))
                .collect()
        };
        cols.push(Column::new(
            format!("fy_peak_n_fz{fz}").into(),
            at(&|l| l.fy_peak_n),
        ));
        cols.push(Column::new(
            format!("mu_y_peak_fz{fz}").into(),
            at(&|l| l.mu_y_peak),
        ));
        cols.push(Column::new(
            format!("fx_peak_n_fz{fz}").into(),
            at(&|l| l.fx_peak_n),
        ));
        cols.push(Column::new(
            format!("mu_x_peak_fz{fz}").into(),
            at(&|l| l.mu_x_peak),
        ));
        cols.push(Column::new(
            format!("cornering_stiffness_n_per_rad_fz{fz}").into(),
            at(&|l| l.cornering_stiffness_n_per_rad),
        ));
    }
    cols.extend([
        Column::new(
            "mu_y_load_sensitivity_per_kn".into(),
            o(&|r| Some(1000.0 * r.figures.mu_y_load_sensitivity_per_n)),
        ),
        Column::new(
            "mu_x_load_sensitivity_per_kn".into(),
            o(&|r| Some(1000.0 * r.figures.mu_x_load_sensitivity_per_n)),
        ),
        Column::new(
            "cornering_stiffness_n_per_rad".into(),
            o(&|r| Some(r.figures.cornering_stiffness_n_per_rad)),
        ),
        Column::new(
            "longitudinal_stiffness_n".into(),
            o(&|r| Some(r.figures.longitudinal_stiffness_n)),
        ),
        Column::new(
            "envelope_area_kn2".into(),
            o(&|r| r.figures.envelope_area_n2.map(|a| a * 1e-6)),
        ),
        Column::new(
            "relaxation_length_lateral_m".into(),
            o(&|r| r.figures.relaxation_lateral_m),
        ),
        Column::new(
            "relaxation_length_longitudinal_m".into(),
            o(&|r| r.figures.relaxation_longitudinal_m),
        ),
        Column::new(
            "vertical_stiffness_n_per_m".into(),
            o(&|r| r.figures.vertical_stiffness_n_per_m),
        ),
        Column::new("t_opt_c".into(), o(&|r| r.thermal.t_opt_c)),
        Column::new(
            "thermal_gain_pct".into(),
            o(&|r| r.thermal.gain_over_cold.map(|g| 100.0 * g)),
        ),
        Column::new(
            "warmup_rate_c_per_s".into(),
            o(&|r| r.thermal.warmup_rate_c_per_s),
        ),
        Column::new("warmup_time_s".into(), o(&|r| r.thermal.warmup_time_s)),
        Column::new(
            "rounds_tested".into(),
            rows.iter()
                .map(|r| r.rounds_tested as i64)
                .collect::<Vec<_>>(),
        ),
        Column::new("objective_spread".into(), o(&|r| r.objective_spread)),
        Column::new(
            "extrapolated_loads_n".into(),
            rows.iter()
                .map(|r| {
                    r.figures
                        .extrapolated_loads_n
                        .iter()
                        .map(|f| format!("{f:.0}"))
                        .collect::<Vec<_>>()
                        .join(" ")
                })
                .collect::<Vec<_>>(),
        ),
    ]);
    let df = DataFrame::new_infer_height(cols).map_err(|e| StoreError::Schema {
        table: "compare".into(),
        message: e.to_string(),
    })?;
    schema.conform(df)
}

/// Up to 4 significant digits, plain notation for moderate magnitudes.
pub fn format_number(x: f64) -> String {
    if !x.is_finite() {
        return String::new();
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        return format!("{x:.3e}");
    }
    let digits = if a == 0.0 {
        0
    } else {
        (3 - a.log10().floor() as i64).max(0) as usize
    };
    format!("{x:.digits$}")
}

/// The table as aligned text: every column, numbers with up to 4 significant digits.
pub fn format_text(df: &DataFrame) -> String {
    crate::query::aligned_text(df, format_number)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(format_number(2.51234), "2.512");
        assert_eq!(format_number(46213.7), "46214");
        assert_eq!(format_number(0.0012344), "0.001234");
        assert_eq!(format_number(-0.151), "-0.1510");
        assert_eq!(format_number(0.0), "0");
        assert_eq!(format_number(f64::NAN), "");
        assert_eq!(format_number(2.5e-5), "2.500e-5");
    }
}
