//! Typed columns of a table read from the store: the one set of helpers every typed reader of
//! a stored table uses (`store::tables`, `store::results`, the fit stages' sample loader
//! `fit::load`, the report's `report::data`).
//!
//! In: a DataFrame read from a file and a column name. Out: the column's values as
//! `Option<T>` per row (other numeric types cast), `None` for an absent optional column, a
//! [`StoreError::Schema`] naming the file and the column for an absent required one.
//! Deliberately not here: which columns a table has (`schemas/`) and what they mean.

use std::path::Path;

use polars::prelude::*;

use super::{IoOp, StoreError};

/// A polars error while doing `op` at `path` as a store error.
pub fn polars_at(op: IoOp, path: &Path) -> impl Fn(PolarsError) -> StoreError + '_ {
    move |e| StoreError::polars(op, path, e)
}

/// A string column (other types cast); `None` when the column is absent.
pub fn opt_str(
    df: &DataFrame,
    name: &str,
    path: &Path,
) -> Result<Option<Vec<Option<String>>>, StoreError> {
    let Ok(c) = df.column(name) else {
        return Ok(None);
    };
    let c = c
        .cast(&DataType::String)
        .map_err(polars_at(IoOp::Read, path))?;
    Ok(Some(
        c.str()
            .map_err(polars_at(IoOp::Read, path))?
            .iter()
            .map(|v| v.map(str::to_string))
            .collect(),
    ))
}

/// An integer column (other numeric types cast); `None` when the column is absent.
pub fn opt_i64(
    df: &DataFrame,
    name: &str,
    path: &Path,
) -> Result<Option<Vec<Option<i64>>>, StoreError> {
    let Ok(c) = df.column(name) else {
        return Ok(None);
    };
    let c = c
        .cast(&DataType::Int64)
        .map_err(polars_at(IoOp::Read, path))?;
    Ok(Some(
        c.i64()
            .map_err(polars_at(IoOp::Read, path))?
            .iter()
            .collect(),
    ))
}

/// A float column (other numeric types cast); `None` when the column is absent.
pub fn opt_f64(
    df: &DataFrame,
    name: &str,
    path: &Path,
) -> Result<Option<Vec<Option<f64>>>, StoreError> {
    let Ok(c) = df.column(name) else {
        return Ok(None);
    };
    let c = c
        .cast(&DataType::Float64)
        .map_err(polars_at(IoOp::Read, path))?;
    Ok(Some(
        c.f64()
            .map_err(polars_at(IoOp::Read, path))?
            .iter()
            .collect(),
    ))
}

/// A boolean column; `None` when the column is absent.
pub fn opt_bool(
    df: &DataFrame,
    name: &str,
    path: &Path,
) -> Result<Option<Vec<Option<bool>>>, StoreError> {
    let Ok(c) = df.column(name) else {
        return Ok(None);
    };
    Ok(Some(
        c.bool()
            .map_err(polars_at(IoOp::Read, path))?
            .iter()
            .collect(),
    ))
}

/// The error of a required column that is absent.
pub fn missing(path: &Path, name: &str) -> StoreError {
    StoreError::Schema {
        table: path.display().to_string(),
        message: format!("required column {name} is missing"),
    }
}

/// A required string column.
pub fn req_str(df: &DataFrame, name: &str, path: &Path) -> Result<Vec<Option<String>>, StoreError> {
    opt_str(df, name, path)?.ok_or_else(|| missing(path, name))
}

/// A required integer column.
pub fn req_i64(df: &DataFrame, name: &str, path: &Path) -> Result<Vec<Option<i64>>, StoreError> {
    opt_i64(df, name, path)?.ok_or_else(|| missing(path, name))
}

/// A required float column.
pub fn req_f64(df: &DataFrame, name: &str, path: &Path) -> Result<Vec<Option<f64>>, StoreError> {
    opt_f64(df, name, path)?.ok_or_else(|| missing(path, name))
}

/// A required boolean column.
pub fn req_bool(df: &DataFrame, name: &str, path: &Path) -> Result<Vec<Option<bool>>, StoreError> {
    opt_bool(df, name, path)?.ok_or_else(|| missing(path, name))
}
