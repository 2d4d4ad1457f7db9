//! Table schemas: the `schemas/*.toml` files, embedded at compile time, as typed column lists.
//!
//! In: the TOML schema files (column name, dtype, unit, description). Out: [`TableSchema`], which
//! writers use to order and type their columns and tests use to check written files. Deliberately
//! only the dtypes the tables use (String, Float64, Int64, Boolean).

use polars::prelude::{DataFrame, DataType};
use serde::Deserialize;

/// One column of a table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnSpec {
    /// Column name.
    pub name: String,
    /// `String`, `Float64`, `Int64` or `Boolean`.
    pub dtype: String,
    /// SI unit, or empty.
    pub unit: String,
    /// What the column holds.
    pub description: String,
}

/// A table's columns, in order.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableSchema {
    /// Table name.
    pub table: String,
    /// Columns in file order.
    #[serde(rename = "column")]
    pub columns: Vec<ColumnSpec>,
}

impl TableSchema {
    fn parse(text: &str) -> Self {
        toml::from_str(text).expect("embedded schema files are valid (checked by the schema tests)")
    }

    /// Polars dtype of a column spec.
    pub fn dtype(spec: &ColumnSpec) -> DataType {
        match spec.dtype.as_str() {
            "String" => DataType::String,
            "Float64" => DataType::Float64,
            "Int64" => DataType::Int64,
            "Boolean" => DataType::Boolean,
            other => panic!("schema dtype {other:?} is not supported"),
        }
    }

    /// Checks a frame's column names and dtypes against the schema; the error lists the diff.
    pub fn check(&self, df: &DataFrame) -> Result<(), String> {
        let found: Vec<(String, DataType)> = df
            .columns()
            .iter()
            .map(|c| (c.name().to_string(), c.dtype().clone()))
            .collect();
        let expected: Vec<(String, DataType)> = self
            .columns
            .iter()
            .map(|c| (c.name.clone(), Self::dtype(c)))
            .collect();
        if found == expected {
            Ok(())
        } else {
            Err(format!(
                "table {}: columns {found:?}, schema says {expected:?}",
                self.table
            ))
        }
    }
}

/// Schema of `inertia.parquet` (`schemas/inertia.toml`).
pub fn inertia() -> TableSchema {
    TableSchema::parse(include_str!("../schemas/inertia.toml"))
}

#[cfg(test)]
mod tests {
    #[test]
    fn inertia_schema_parses_and_has_units_column() {
        let s = super::inertia();
        assert_eq!(s.table, "inertia");
        let names: Vec<&str> = s.columns.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "session",
                "run",
                "object",
                "axis",
                "quantity",
                "method",
                "value",
                "uncertainty",
                "units",
                "diagnostics"
            ]
        );
    }
}
