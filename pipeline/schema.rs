//! Table schemas, read from the TOML definitions in `schemas/` (embedded at build time): the one
//! place a table's columns, types and units are defined.
//!
//! In: `schemas/<table>.toml`. Out: [`TableSchema`] lookups, the polars schema of a table and
//! [`TableSchema::conform`], which every writer calls so a table on disk always matches its
//! definition (column order, dtypes, nullability). Deliberately not here: where tables live
//! (store/layout.rs) or how they are computed.

use std::sync::OnceLock;

use polars::prelude::*;
use serde::Deserialize;

use crate::store::StoreError;

/// The tables tirebase defines, one per `schemas/<name>.toml`: a table is named by a variant,
/// so a misspelt table is a compile error.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum TableName {
    /// `schemas/runs.toml`.
    Runs,
    /// `schemas/segments.toml`.
    Segments,
    /// `schemas/samples.toml`.
    Samples,
    /// `schemas/inertia.toml`.
    Inertia,
    /// `schemas/spring_rate.toml`.
    SpringRate,
    /// `schemas/thermal.toml`.
    Thermal,
    /// `schemas/thermal_fit.toml`.
    ThermalFit,
    /// `schemas/relaxation.toml`.
    Relaxation,
    /// `schemas/coefficients.toml`.
    Coefficients,
    /// `schemas/fit_quality.toml`.
    FitQuality,
    /// `schemas/lint.toml`.
    Lint,
    /// `schemas/fit_failures.toml`.
    FitFailures,
    /// `schemas/compare.toml`.
    Compare,
}

impl TableName {
    /// Every table, in the order of [`all`].
    pub const ALL: [TableName; 13] = [
        TableName::Runs,
        TableName::Segments,
        TableName::Samples,
        TableName::Inertia,
        TableName::SpringRate,
        TableName::Thermal,
        TableName::ThermalFit,
        TableName::Relaxation,
        TableName::Coefficients,
        TableName::FitQuality,
        TableName::Lint,
        TableName::FitFailures,
        TableName::Compare,
    ];

    /// The table's name: its schema file's stem, its `<name>.parquet` and its SQL name.
    pub const fn as_str(self) -> &'static str {
        match self {
            TableName::Runs => "runs",
            TableName::Segments => "segments",
            TableName::Samples => "samples",
            TableName::Inertia => "inertia",
            TableName::SpringRate => "spring_rate",
            TableName::Thermal => "thermal",
            TableName::ThermalFit => "thermal_fit",
            TableName::Relaxation => "relaxation",
            TableName::Coefficients => "coefficients",
            TableName::FitQuality => "fit_quality",
            TableName::Lint => "lint",
            TableName::FitFailures => "fit_failures",
            TableName::Compare => "compare",
        }
    }

    /// The table named `name`, if tirebase defines one.
    pub fn parse(name: &str) -> Option<TableName> {
        TableName::ALL.into_iter().find(|t| t.as_str() == name)
    }

    /// The embedded schema definition (TOML).
    const fn source(self) -> &'static str {
        match self {
            TableName::Runs => include_str!("../schemas/runs.toml"),
            TableName::Segments => include_str!("../schemas/segments.toml"),
            TableName::Samples => include_str!("../schemas/samples.toml"),
            TableName::Inertia => include_str!("../schemas/inertia.toml"),
            TableName::SpringRate => include_str!("../schemas/spring_rate.toml"),
            TableName::Thermal => include_str!("../schemas/thermal.toml"),
            TableName::ThermalFit => include_str!("../schemas/thermal_fit.toml"),
            TableName::Relaxation => include_str!("../schemas/relaxation.toml"),
            TableName::Coefficients => include_str!("../schemas/coefficients.toml"),
            TableName::FitQuality => include_str!("../schemas/fit_quality.toml"),
            TableName::Lint => include_str!("../schemas/lint.toml"),
            TableName::FitFailures => include_str!("../schemas/fit_failures.toml"),
            TableName::Compare => include_str!("../schemas/compare.toml"),
        }
    }
}

impl std::fmt::Display for TableName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl AsRef<str> for TableName {
    fn as_ref(&self) -> &str {
        self.as_str()
    }
}

/// Column data types used by tirebase tables.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dtype {
    /// UTF-8 string.
    Str,
    /// 64-bit float.
    F64,
    /// 64-bit signed integer.
    I64,
    /// Boolean.
    Bool,
}

impl Dtype {
    /// The polars data type.
    pub fn polars(self) -> DataType {
        match self {
            Dtype::Str => DataType::String,
            Dtype::F64 => DataType::Float64,
            Dtype::I64 => DataType::Int64,
            Dtype::Bool => DataType::Boolean,
        }
    }
}

/// One column of a table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Column {
    /// Column name (units in the name).
    pub name: String,
    /// Data type.
    pub dtype: Dtype,
    /// Unit, human readable ("" for none).
    pub unit: String,
    /// May hold nulls.
    #[serde(default)]
    pub nullable: bool,
    /// Hive partition key (lives in directory names, not inside the files).
    #[serde(default)]
    pub partition: bool,
    /// One column per load of a load list: the name holds `{fz}`, replaced by each load in whole
    /// newtons ([`TableSchema::for_loads`]).
    #[serde(default)]
    pub per_load: bool,
    /// What the column means.
    pub description: String,
}

/// A table definition.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableSchema {
    /// Table name.
    pub name: String,
    /// What a row is and where the table lives.
    pub description: String,
    /// Columns in canonical order.
    pub columns: Vec<Column>,
}

/// Every table schema, parsed once, in the order of [`TableName::ALL`].
pub fn all() -> &'static [TableSchema] {
    static ALL: OnceLock<Vec<TableSchema>> = OnceLock::new();
    ALL.get_or_init(|| {
        TableName::ALL
            .iter()
            .map(|t| {
                let schema: TableSchema = toml::from_str(t.source())
                    .unwrap_or_else(|e| panic!("schemas/{t}.toml is invalid: {e}"));
                assert_eq!(
                    schema.name,
                    t.as_str(),
                    "schemas/{t}.toml names another table"
                );
                schema
            })
            .collect()
    })
}

/// The schema of table `name`.
pub fn table(name: TableName) -> &'static TableSchema {
    &all()[name as usize]
}

/// The schema of the table called `name` (a name read at run time), if tirebase defines it.
pub fn table_named(name: &str) -> Option<&'static TableSchema> {
    TableName::parse(name).map(table)
}

impl TableSchema {
    /// Columns stored inside the files (partition keys excluded).
    pub fn file_columns(&self) -> impl Iterator<Item = &Column> {
        self.columns.iter().filter(|c| !c.partition)
    }

    /// The Arrow schema of the columns stored inside the files (what polars writes for
    /// [`TableSchema::file_schema`]; every field nullable, as polars marks them).
    pub fn arrow_file_schema(&self) -> ArrowSchema {
        self.file_columns()
            .map(|c| {
                let dtype = c.dtype.polars().to_arrow(CompatLevel::newest());
                let name: PlSmallStr = c.name.as_str().into();
                (name.clone(), ArrowField::new(name, dtype, true))
            })
            .collect()
    }

    /// Order `arrays` (by name) as the file columns, checking names and types: the
    /// [`TableSchema::conform`] of a writer that builds Arrow arrays itself.
    pub fn conform_arrays(
        &self,
        mut arrays: Vec<(&str, ArrayRef)>,
    ) -> Result<(ArrowSchema, Vec<ArrayRef>), StoreError> {
        let err = |message: String| StoreError::Schema {
            table: self.name.clone(),
            message,
        };
        let schema = self.arrow_file_schema();
        if let Some((name, _)) = arrays.iter().find(|(n, _)| schema.get(n).is_none()) {
            return Err(err(format!(
                "column {name} is not in schemas/{}.toml",
                self.name
            )));
        }
        let mut ordered = Vec::with_capacity(schema.len());
        for (name, field) in schema.iter() {
            let i = arrays
                .iter()
                .position(|(n, _)| *n == name.as_str())
                .ok_or_else(|| err(format!("missing column {name}")))?;
            let (_, array) = arrays.swap_remove(i);
            if array.dtype() != &field.dtype {
                return Err(err(format!(
                    "column {name}: {:?}, schema says {:?}",
                    array.dtype(),
                    field.dtype
                )));
            }
            let column = self.columns.iter().find(|c| c.name == name.as_str());
            if column.is_some_and(|c| !c.nullable) && array.null_count() > 0 {
                return Err(err(format!(
                    "column {name} has {} nulls but is not nullable",
                    array.null_count()
                )));
            }
            ordered.push(array);
        }
        Ok((schema, ordered))
    }

    /// The schema with every per-load column repeated once per load of `loads_n` (whole
    /// newtons), `{fz}` in its name replaced by the load, in load order.
    ///
    /// ```
    /// let t = tirebase::schema::table(tirebase::schema::TableName::Compare).for_loads(&[350, 700]);
    /// let names: Vec<&str> = t.columns.iter().map(|c| c.name.as_str()).collect();
    /// assert!(names.contains(&"mu_y_peak_fz350") && names.contains(&"mu_y_peak_fz700"));
    /// assert!(t.columns.iter().all(|c| !c.per_load));
    /// ```
    pub fn for_loads(&self, loads_n: &[i64]) -> TableSchema {
        let mut columns = Vec::with_capacity(self.columns.len());
        for c in &self.columns {
            if !c.per_load {
                columns.push(c.clone());
                continue;
            }
            for fz in loads_n {
                columns.push(Column {
                    name: c.name.replace("{fz}", &fz.to_string()),
                    per_load: false,
                    description: format!("{} (at Fz = {fz} N)", c.description),
                    ..c.clone()
                });
            }
        }
        TableSchema {
            name: self.name.clone(),
            description: self.description.clone(),
            columns,
        }
    }

    /// The polars schema of the columns stored inside the files.
    pub fn file_schema(&self) -> Schema {
        self.file_columns()
            .map(|c| Field::new(c.name.as_str().into(), c.dtype.polars()))
            .collect()
    }

    /// Bring `df` to this schema's file layout: every file column present, in canonical order,
    /// cast to its dtype, no nulls in non-nullable columns. Extra columns are an error (a
    /// column nobody defined is a column nobody documents).
    pub fn conform(&self, df: DataFrame) -> Result<DataFrame, StoreError> {
        let err = |message: String| StoreError::Schema {
            table: self.name.clone(),
            message,
        };
        for name in df.get_column_names() {
            if !self.file_columns().any(|c| c.name == name.as_str()) {
                return Err(err(format!(
                    "column {name} is not in schemas/{}.toml",
                    self.name
                )));
            }
        }
        let mut columns = Vec::with_capacity(self.columns.len());
        for c in self.file_columns() {
            let series = df
                .column(&c.name)
                .map_err(|_| err(format!("missing column {}", c.name)))?;
            let dtype = c.dtype.polars();
            let cast = if series.dtype() == &dtype {
                series.clone()
            } else {
                series
                    .cast(&dtype)
                    .map_err(|e| err(format!("column {}: {e}", c.name)))?
            };
            if !c.nullable && cast.null_count() > 0 {
                return Err(err(format!(
                    "column {} has {} nulls but is not nullable",
                    c.name,
                    cast.null_count()
                )));
            }
            columns.push(cast);
        }
        DataFrame::new_infer_height(columns).map_err(|e| err(e.to_string()))
    }
}

/// Text rendering of every schema (the snapshot).
pub fn render_snapshot() -> String {
    let mut out = String::new();
    for t in all() {
        out.push_str(&format!("[{}]\n", t.name));
        for c in &t.columns {
            let mut flags = Vec::new();
            if c.nullable {
                flags.push("nullable");
            }
            if c.partition {
                flags.push("partition");
            }
            if c.per_load {
                flags.push("per_load");
            }
            let line = format!(
                "{:<24} {:<5} {:<6} {}",
                c.name,
                format!("{:?}", c.dtype).to_lowercase(),
                c.unit,
                flags.join(",")
            );
            out.push_str(line.trim_end());
            out.push('\n');
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The snapshot test: any change to a table definition must be accepted deliberately
    /// (`UPDATE_SNAPSHOTS=1 cargo test schema_snapshot`).
    #[test]
    fn schema_snapshot() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/schemas/snapshot.txt");
        let rendered = render_snapshot();
        if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
            std::fs::write(path, &rendered).unwrap();
        }
        let stored = std::fs::read_to_string(path).unwrap_or_default();
        assert_eq!(
            stored, rendered,
            "schemas changed; review and run with UPDATE_SNAPSHOTS=1 to accept"
        );
    }

    #[test]
    fn every_schema_has_unique_columns_and_units_in_names() {
        for t in all() {
            let mut names: Vec<_> = t.columns.iter().map(|c| c.name.as_str()).collect();
            names.sort();
            names.dedup();
            assert_eq!(
                names.len(),
                t.columns.len(),
                "duplicate column in {}",
                t.name
            );
        }
    }

    #[test]
    fn per_load_columns_and_only_they_name_the_load() {
        for t in all() {
            for c in &t.columns {
                assert_eq!(
                    c.per_load,
                    c.name.contains("{fz}"),
                    "{}.{}: per_load and {{fz}} go together",
                    t.name,
                    c.name
                );
            }
        }
        let t = table(TableName::Compare).for_loads(&[350, 700, 1050]);
        let per_load = table(TableName::Compare)
            .columns
            .iter()
            .filter(|c| c.per_load)
            .count();
        assert_eq!(
            t.columns.len(),
            table(TableName::Compare).columns.len() + 2 * per_load
        );
        let mut names: Vec<_> = t.columns.iter().map(|c| c.name.clone()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), t.columns.len());
    }

    #[test]
    fn conform_orders_casts_and_rejects_unknown_columns() {
        let runs = table(TableName::Runs);
        let df = df!("rows" => [3i32], "source_file" => ["a.dat"]).unwrap();
        let err = runs.conform(df).unwrap_err().to_string();
        assert!(err.contains("missing column"), "{err}");
        let df = df!("bogus" => [1]).unwrap();
        assert!(runs.conform(df).unwrap_err().to_string().contains("bogus"));
    }
}
