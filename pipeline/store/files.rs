//! Crash-safe file primitives: content hashing, atomic writes (temp file, fsync, rename,
//! fsync of the directory) and Parquet read/write of whole tables through polars.
//!
//! A reader never sees a half-written file: every write goes to a `*.tmp` sibling that no
//! `*.parquet` glob matches and becomes visible by one `rename`. Deliberately not here: what the
//! files mean (layout.rs) and multi-file commits (the runs table and version directories build on
//! these primitives).

use std::fs::{self, File};
use std::io::{self, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use polars::prelude::*;
use polars_arrow::record_batch::RecordBatchT;
use sha2::{Digest, Sha256};

use super::layout::temp_path;
use super::{IoOp, StoreError};

/// Hex SHA-256 of a file's content, streamed (1 MiB buffer).
pub fn sha256_file(path: &Path) -> Result<String, StoreError> {
    let mut file = File::open(path).map_err(|e| StoreError::io(IoOp::Read, path, e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file
            .read(&mut buf)
            .map_err(|e| StoreError::io(IoOp::Read, path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hex(&hasher.finalize()))
}

/// Hex SHA-256 of bytes in memory.
pub fn sha256_bytes(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A name unique within this process and distinct across processes (pid + counter).
fn unique_suffix() -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    format!(
        "{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    )
}

/// Create `dir` and its parents.
pub fn ensure_dir(dir: &Path) -> Result<(), StoreError> {
    fs::create_dir_all(dir).map_err(|e| StoreError::io(IoOp::CreateDir, dir, e))
}

/// fsync a directory so a rename inside it survives a crash (no-op where unsupported).
pub fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Write a file atomically: `fill` writes the content into a temporary sibling, which is
/// flushed, fsynced and renamed over `path`.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<(), StoreError>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<(), StoreError>,
{
    write_atomic_with(path, Durability::Now, fill)
}

/// When a written file reaches the disk.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Durability {
    /// fsync the file and its directory before returning.
    Now,
    /// Rename without fsync; the caller makes it durable with [`sync_filesystem`] before it
    /// commits anything that refers to the file. A crash before that commit leaves a file
    /// nothing refers to (garbage). Ingest writes ~35 partition files per run: one fsync pair
    /// each cost more wall time than parsing and encoding together.
    Deferred,
}

/// Flush every pending write of the filesystem holding `path` (Linux `syncfs`): the one
/// durability point for [`Durability::Deferred`] writes.
pub fn sync_filesystem(path: &Path) -> Result<(), StoreError> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        let dir = File::open(path).map_err(|e| StoreError::io(IoOp::Sync, path, e))?;
        // SAFETY: `dir` is an open file descriptor for the duration of the call.
        if unsafe { libc::syncfs(dir.as_raw_fd()) } != 0 {
            return Err(StoreError::io(IoOp::Sync, path, io::Error::last_os_error()));
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = path;
    Ok(())
}

/// [`write_atomic`] with a choice of [`Durability`] (`Deferred` is `Now` where
/// [`sync_filesystem`] is not available).
pub fn write_atomic_with<F>(path: &Path, durability: Durability, fill: F) -> Result<(), StoreError>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<(), StoreError>,
{
    let sync_now = durability == Durability::Now || !cfg!(target_os = "linux");
    let parent = path.parent().unwrap_or(Path::new("."));
    ensure_dir(parent)?;
    let tmp = temp_path(path, &unique_suffix());
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| StoreError::io(IoOp::Write, &tmp, e))?;
        let mut writer = BufWriter::new(file);
        fill(&mut writer)?;
        writer
            .flush()
            .map_err(|e| StoreError::io(IoOp::Write, &tmp, e))?;
        let file = writer
            .into_inner()
            .map_err(|e| StoreError::io(IoOp::Write, &tmp, e.into_error()))?;
        if sync_now {
            file.sync_all()
                .map_err(|e| StoreError::io(IoOp::Write, &tmp, e))?;
        }
        fs::rename(&tmp, path).map_err(|e| StoreError::io(IoOp::Rename, path, e))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    } else if sync_now {
        sync_dir(parent);
    }
    result
}

/// Write bytes atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
    write_atomic(path, |w| {
        w.write_all(bytes)
            .map_err(|e| StoreError::io(IoOp::Write, path, e))
    })
}

/// Write a DataFrame as one Parquet file, atomically (see [`write_parquet`] for the encoding).
pub fn write_parquet_atomic(path: &Path, df: &mut DataFrame) -> Result<(), StoreError> {
    write_parquet_atomic_with(path, Durability::Now, df)
}

/// [`write_parquet_atomic`] with a choice of [`Durability`].
pub fn write_parquet_atomic_with(
    path: &Path,
    durability: Durability,
    df: &mut DataFrame,
) -> Result<(), StoreError> {
    write_atomic_with(path, durability, |w| {
        write_parquet(w, df).map_err(|e| StoreError::polars(IoOp::Write, path, e))
    })
}

/// Write a DataFrame as one Parquet file (one row group per chunk) to `w`.
///
/// The store's files are many and small (a run's samples split into one file per load, camber
/// and pressure partition: a few hundred to a few thousand rows each), so the fixed cost per
/// column decides ingest speed. polars' own `ParquetWriter` asks every float and string column
/// whether a dictionary would pay, by a HyperLogLog count of its distinct values whose cost
/// does not shrink with the column; measured, that was the largest single cost of ingest, for
/// an answer that is always no for a measured channel. So floats are written `PLAIN`; so are
/// strings, except a column made of a few long runs (a partition's file name, hash and segment
/// ids), found by comparing neighbours and written as a dictionary
/// (`dictionary_encode_string_runs`); integers keep polars' choice (a dictionary when their
/// range is small, decided from min and max, no counting). Compression is Snappy, the Parquet
/// default every reader has: on a 470-row, 27-column partition (release build) writing took
/// 0.66 ms with Snappy, 0.86 ms with LZ4 (whose C encoder clears a 16 KiB table for every page)
/// and 1.6 ms with zstd level 1, for files about a third larger than zstd's. Readers see the
/// schema of the DataFrame (the Arrow schema travels in the file's metadata).
pub fn write_parquet<W: Write>(w: W, df: &mut DataFrame) -> PolarsResult<()> {
    df.rechunk_mut();
    let schema = df.schema().to_arrow(CompatLevel::newest());
    let batches: Vec<_> = df.iter_chunks(CompatLevel::newest(), false).collect();
    write_arrow_parquet(w, schema, batches)
}

/// [`write_parquet`] for Arrow arrays built by the caller (one row group per batch): the
/// ingest path, which skips polars' DataFrame (its crates are unoptimised in release builds;
/// see README "Build profiles").
pub fn write_arrow_parquet<W: Write>(
    w: W,
    schema: ArrowSchema,
    batches: Vec<RecordBatchT<ArrayRef>>,
) -> PolarsResult<()> {
    use polars_parquet::write::{
        CompressionOptions, Encoding, FileWriter, RowGroupIterator, Version, WriteOptions,
        get_dtype_encoding,
    };
    let integer = |dtype: &ArrowDataType| {
        use ArrowDataType as A;
        matches!(
            dtype,
            A::Int8 | A::Int16 | A::Int32 | A::Int64 | A::UInt8 | A::UInt16 | A::UInt32 | A::UInt64
        )
    };
    // The readers' schema (in the file's metadata) stays the caller's; only the pages of
    // run-constant string columns are dictionary-encoded.
    let metadata = arrow_schema_metadata(&schema);
    let (schema, batches) = dictionary_encode_string_runs(schema, batches)?;
    let encodings = schema
        .iter_values()
        .map(|field| {
            let mut enc = get_dtype_encoding(&field.dtype);
            if matches!(field.dtype, ArrowDataType::Dictionary(..)) {
                enc.iter_mut().for_each(|e| *e = Encoding::RleDictionary);
            } else if !integer(&field.dtype) {
                enc.iter_mut().for_each(|e| *e = Encoding::Plain);
            }
            enc
        })
        .collect();
    let options = WriteOptions {
        statistics: StatisticsOptions::default(),
        compression: CompressionOptions::Snappy,
        version: Version::V1,
        data_page_size: None,
    };
    let lengths: Vec<u64> = batches.iter().map(|b| b.len() as u64).collect();
    let row_groups =
        RowGroupIterator::try_new(batches.into_iter().map(Ok), &schema, options, encodings)?;
    let mut writer = FileWriter::try_new(w, schema, options)?;
    for (group, rows) in row_groups.zip(lengths) {
        writer.write(rows, group?)?;
    }
    writer.end(Some(vec![metadata]))?;
    Ok(())
}

/// The file metadata entry holding the Arrow schema (an IPC message, base64): serialised once
/// per thread and schema, not once per file (a run's ~30 partitions share one schema; it was
/// ~3 % of ingest).
fn arrow_schema_metadata(schema: &ArrowSchema) -> polars_parquet::write::KeyValue {
    use std::cell::RefCell;
    thread_local! {
        static LAST: RefCell<Option<(ArrowSchema, polars_parquet::write::KeyValue)>> =
            const { RefCell::new(None) };
    }
    LAST.with_borrow_mut(|last| match last {
        Some((cached, key)) if cached == schema => key.clone(),
        _ => {
            let key = polars_parquet::write::schema_to_metadata_key(schema);
            *last = Some((schema.clone(), key.clone()));
            key
        }
    })
}

/// A string column of one batch made of at most one run per this many rows is written as a
/// Parquet dictionary (values once, then run-length encoded indices).
const ROWS_PER_STRING_RUN: usize = 16;

/// Replace every string column that is a few long runs (a sample partition's file name, hash
/// and segment id) by an Arrow dictionary of its runs, in the write schema and the one batch
/// (several batches are left as they are). Plain-encoded, such a column was most of what the
/// compressor had to chew through (a 64-character hash on every row); as a dictionary it is a
/// handful of bytes. The file's Arrow metadata keeps the caller's string type, so readers see
/// the same schema either way: dictionary pages are ordinary Parquet string encoding.
fn dictionary_encode_string_runs(
    schema: ArrowSchema,
    batches: Vec<RecordBatchT<ArrayRef>>,
) -> PolarsResult<(ArrowSchema, Vec<RecordBatchT<ArrayRef>>)> {
    use polars_arrow::array::{
        Array, DictionaryArray, MutableBinaryViewArray, PrimitiveArray, Utf8ViewArray,
    };
    use polars_arrow::datatypes::IntegerType;
    let [batch] = batches.as_slice() else {
        return Ok((schema, batches));
    };
    let runs = |a: &Utf8ViewArray| -> Option<(Vec<u32>, Utf8ViewArray)> {
        if a.null_count() > 0 || a.len() < ROWS_PER_STRING_RUN {
            return None;
        }
        let limit = a.len() / ROWS_PER_STRING_RUN;
        let mut keys = Vec::with_capacity(a.len());
        let mut values = MutableBinaryViewArray::<str>::new();
        let mut last: Option<&str> = None;
        for v in a.values_iter() {
            if last != Some(v) {
                if values.len() == limit {
                    return None;
                }
                values.push_value(v);
                last = Some(v);
            }
            keys.push(values.len() as u32 - 1);
        }
        Some((keys, values.into()))
    };
    let mut fields = Vec::with_capacity(schema.len());
    let mut arrays = Vec::with_capacity(schema.len());
    let mut changed = false;
    for (field, array) in schema.iter_values().zip(batch.columns()) {
        let encoded = (field.dtype == ArrowDataType::Utf8View)
            .then(|| array.as_any().downcast_ref::<Utf8ViewArray>())
            .flatten()
            .and_then(runs);
        match encoded {
            Some((keys, values)) => {
                let dtype = ArrowDataType::Dictionary(
                    IntegerType::UInt32,
                    Box::new(ArrowDataType::Utf8View),
                    false,
                );
                let dict = DictionaryArray::try_new(
                    dtype.clone(),
                    PrimitiveArray::from_vec(keys),
                    values.boxed(),
                )?;
                fields.push(ArrowField::new(
                    field.name.clone(),
                    dtype,
                    field.is_nullable,
                ));
                arrays.push(dict.boxed());
                changed = true;
            }
            None => {
                fields.push(field.clone());
                arrays.push(array.clone());
            }
        }
    }
    if !changed {
        return Ok((schema, batches));
    }
    let schema = ArrowSchema::from_iter(fields);
    let batch = RecordBatchT::try_new(batch.len(), Arc::new(schema.clone()), arrays)?;
    Ok((schema, vec![batch]))
}

/// [`write_arrow_parquet`] of one batch, atomically, with a choice of [`Durability`].
pub fn write_arrow_parquet_atomic_with(
    path: &Path,
    durability: Durability,
    schema: ArrowSchema,
    batch: RecordBatchT<ArrayRef>,
) -> Result<(), StoreError> {
    write_atomic_with(path, durability, |w| {
        write_arrow_parquet(w, schema, vec![batch])
            .map_err(|e| StoreError::polars(IoOp::Write, path, e))
    })
}

/// Read one Parquet file into memory.
pub fn read_parquet(path: &Path) -> Result<DataFrame, StoreError> {
    let file = File::open(path).map_err(|e| StoreError::io(IoOp::Read, path, e))?;
    ParquetReader::new(file)
        .finish()
        .map_err(|e| StoreError::polars(IoOp::Read, path, e))
}

/// Every regular file directly in `dir` (sorted; empty if `dir` does not exist).
pub fn files_in(dir: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let mut out = Vec::new();
    let entries = match fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(out),
        Err(e) => return Err(StoreError::io(IoOp::List, dir, e)),
    };
    for entry in entries {
        let path = entry
            .map_err(|e| StoreError::io(IoOp::List, dir, e))?
            .path();
        if path.is_file() {
            out.push(path);
        }
    }
    out.sort();
    Ok(out)
}

/// Every `*.parquet` file directly in `dir` (sorted; empty if `dir` does not exist).
pub fn parquet_files_in(dir: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let mut files = files_in(dir)?;
    files.retain(|p| p.extension().is_some_and(|x| x == "parquet"));
    Ok(files)
}

/// Every `*.parquet` file anywhere below `dir` (sorted; empty if `dir` does not exist).
pub fn parquet_files_below(dir: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let entries = match fs::read_dir(&d) {
            Ok(e) => e,
            Err(e) if e.kind() == io::ErrorKind::NotFound => continue,
            Err(e) => return Err(StoreError::io(IoOp::List, &d, e)),
        };
        for entry in entries {
            let path = entry.map_err(|e| StoreError::io(IoOp::List, &d, e))?.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "parquet") {
                out.push(path);
            }
        }
    }
    out.sort();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a/b.txt");
        write_bytes_atomic(&path, b"one").unwrap();
        write_bytes_atomic(&path, b"two").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two");
        let names: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn io_errors_say_what_was_being_done_and_on_which_path_issue_18() {
        let dir = tempfile::tempdir().unwrap();
        let says = |err: StoreError, op: IoOp, path: &Path| {
            let text = err.to_string();
            assert!(
                matches!(&err, StoreError::Io { op: o, path: p, .. } if *o == op && p == path),
                "{err:?}"
            );
            assert!(
                text.starts_with(&format!("{op} {}: ", path.display())),
                "{text}"
            );
        };
        let missing = dir.path().join("missing.parquet");
        says(read_parquet(&missing).unwrap_err(), IoOp::Read, &missing);
        says(sha256_file(&missing).unwrap_err(), IoOp::Read, &missing);
        let file = dir.path().join("file");
        fs::write(&file, b"x").unwrap();
        says(files_in(&file).unwrap_err(), IoOp::List, &file);
        says(
            write_bytes_atomic(&file.join("sub/t.bin"), b"y").unwrap_err(),
            IoOp::CreateDir,
            &file.join("sub"),
        );
        let occupied = dir.path().join("occupied");
        fs::create_dir_all(occupied.join("inside")).unwrap();
        says(
            write_bytes_atomic(&occupied, b"y").unwrap_err(),
            IoOp::Rename,
            &occupied,
        );
    }

    #[test]
    fn table_errors_say_what_was_being_done_and_on_which_path() {
        let dir = tempfile::tempdir().unwrap();
        let corrupt = dir.path().join("runs.parquet");
        fs::write(&corrupt, b"not a parquet file").unwrap();
        let err = read_parquet(&corrupt).unwrap_err();
        assert!(
            matches!(&err, StoreError::Polars { op: IoOp::Read, path, .. } if *path == corrupt),
            "{err:?}"
        );
        let text = err.to_string();
        assert!(
            text.starts_with(&format!("reading {}: ", corrupt.display())),
            "{text}"
        );
    }

    #[test]
    fn failed_fill_leaves_previous_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.parquet");
        write_bytes_atomic(&path, b"old").unwrap();
        let err = write_atomic(&path, |_| {
            Err(StoreError::io(
                IoOp::Write,
                &path,
                io::Error::other("simulated"),
            ))
        });
        assert!(err.is_err());
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn parquet_round_trip_and_hash() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        let mut df = df!("fz_n" => [1.0, 2.0], "name" => ["a", "b"]).unwrap();
        write_parquet_atomic(&path, &mut df).unwrap();
        assert_eq!(read_parquet(&path).unwrap(), df);
        assert_eq!(
            sha256_file(&path).unwrap(),
            sha256_bytes(&fs::read(&path).unwrap())
        );
        assert_eq!(parquet_files_below(dir.path()).unwrap(), vec![path]);
    }

    #[test]
    fn string_runs_are_written_as_dictionaries_and_read_back_as_strings() {
        let dir = tempfile::tempdir().unwrap();
        let n = 400;
        let hash = "e7760966aef4c276db1c7aef983ce67a5d2bed78433f1ab5da8d5d401de3c403";
        let segment: Vec<String> = (0..n).map(|i| format!("run6-{:03}", i / 100)).collect();
        let varied: Vec<String> = (0..n).map(|i| format!("v{i}")).collect();
        let mut df = df!(
            "sha" => vec![hash; n],
            "segment_id" => segment,
            "varied" => varied,
            "x" => (0..n).map(|i| i as f64).collect::<Vec<_>>()
        )
        .unwrap();
        let path = dir.path().join("runs.parquet");
        write_parquet_atomic(&path, &mut df).unwrap();
        let back = read_parquet(&path).unwrap();
        assert_eq!(back, df);
        assert_eq!(back.column("sha").unwrap().dtype(), &DataType::String);
        // The two run columns carry a dictionary page; the varied one and the floats do not.
        let meta = polars_parquet::read::read_metadata(&mut File::open(&path).unwrap()).unwrap();
        let dictionary: Vec<bool> = meta.row_groups[0]
            .parquet_columns()
            .iter()
            .map(|c| c.dictionary_page_offset().is_some())
            .collect();
        assert_eq!(dictionary, [true, true, false, false]);
    }
}
