//! Immutable published versions: `STORE/versions/v000001/`, `v000002/`, ...
//!
//! A version is built in a hidden sibling directory (`.v000002.building-<pid>`) and becomes
//! visible by ONE atomic directory rename, so a reader (or a crash) never sees a partial version.
//! Version numbers are assigned under the store lock (the caller holds it). Leftovers of a
//! crashed build are removed by [`remove_incomplete`] at the start of the next publish.
//! Deliberately not here: what goes into a version (publish.rs decides).

use std::fs;
use std::path::{Path, PathBuf};

use super::files::{ensure_dir, sync_dir};
use super::layout::{VERSIONS_DIR, parse_version_dir, version_dir};
use super::{IoOp, StoreError};

/// Published versions under `root`, ascending: (number, absolute directory).
pub fn list(root: &Path) -> Result<Vec<(u32, PathBuf)>, StoreError> {
    let dir = root.join(VERSIONS_DIR);
    let mut out = Vec::new();
    let entries = match fs::read_dir(&dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(out),
        Err(e) => return Err(StoreError::io(IoOp::List, &dir, e)),
    };
    for entry in entries {
        let entry = entry.map_err(|e| StoreError::io(IoOp::List, &dir, e))?;
        let name = entry.file_name();
        if let Some(n) = name.to_str().and_then(parse_version_dir)
            && entry.path().is_dir()
        {
            out.push((n, entry.path()));
        }
    }
    out.sort();
    Ok(out)
}

/// The newest published version, if any.
pub fn latest(root: &Path) -> Result<Option<(u32, PathBuf)>, StoreError> {
    Ok(list(root)?.pop())
}

/// Remove half-built versions left by a crashed publish. Call with the store lock held.
pub fn remove_incomplete(root: &Path) -> Result<usize, StoreError> {
    let dir = root.join(VERSIONS_DIR);
    let Ok(entries) = fs::read_dir(&dir) else {
        return Ok(0);
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        if name
            .to_str()
            .is_some_and(|n| n.starts_with('.') && n.contains(".building"))
        {
            fs::remove_dir_all(entry.path())
                .map_err(|e| StoreError::io(IoOp::Remove, &entry.path(), e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// A version being built. Dropping it without [`VersionBuilder::commit`] removes the partial
/// directory.
#[derive(Debug)]
pub struct VersionBuilder {
    number: u32,
    staging: PathBuf,
    target: PathBuf,
    committed: bool,
}

impl VersionBuilder {
    /// Start building the next version (number = newest + 1). Call with the store lock held.
    pub fn begin(root: &Path) -> Result<VersionBuilder, StoreError> {
        let number = latest(root)?.map_or(1, |(n, _)| n + 1);
        let target = root.join(version_dir(number));
        let staging = root
            .join(VERSIONS_DIR)
            .join(format!(".v{number:06}.building-{}", std::process::id()));
        if staging.exists() {
            fs::remove_dir_all(&staging).map_err(|e| StoreError::io(IoOp::Remove, &staging, e))?;
        }
        ensure_dir(&staging)?;
        Ok(VersionBuilder {
            number,
            staging,
            target,
            committed: false,
        })
    }

    /// The version number this build will get.
    pub fn number(&self) -> u32 {
        self.number
    }

    /// Directory to write the version's files into.
    pub fn dir(&self) -> &Path {
        &self.staging
    }

    /// Make the version visible (one rename) and return its final directory.
    pub fn commit(mut self) -> Result<PathBuf, StoreError> {
        sync_tree(&self.staging);
        fs::rename(&self.staging, &self.target)
            .map_err(|e| StoreError::io(IoOp::Rename, &self.target, e))?;
        if let Some(parent) = self.target.parent() {
            sync_dir(parent);
        }
        self.committed = true;
        Ok(self.target.clone())
    }
}

impl Drop for VersionBuilder {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.staging);
        }
    }
}

/// fsync every file and directory below `dir` so the rename publishes durable content.
fn sync_tree(dir: &Path) {
    if let Ok(entries) = fs::read_dir(dir) {
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                sync_tree(&path);
            } else if let Ok(f) = fs::File::open(&path) {
                let _ = f.sync_all();
            }
        }
    }
    sync_dir(dir);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_appear_only_on_commit_and_number_upwards() {
        let root = tempfile::tempdir().unwrap();
        let b = VersionBuilder::begin(root.path()).unwrap();
        fs::write(b.dir().join("a.txt"), "x").unwrap();
        assert!(list(root.path()).unwrap().is_empty());
        let v1 = b.commit().unwrap();
        assert!(v1.ends_with("versions/v000001"));
        assert_eq!(fs::read_to_string(v1.join("a.txt")).unwrap(), "x");

        let b = VersionBuilder::begin(root.path()).unwrap();
        assert_eq!(b.number(), 2);
        drop(b);
        assert_eq!(list(root.path()).unwrap().len(), 1);
        let staging_left = fs::read_dir(root.path().join(VERSIONS_DIR))
            .unwrap()
            .count();
        assert_eq!(
            staging_left, 1,
            "an abandoned build must not leave its directory"
        );
    }

    #[test]
    fn crashed_builds_are_cleaned() {
        let root = tempfile::tempdir().unwrap();
        let crashed = root.path().join(VERSIONS_DIR).join(".v000001.building-999");
        fs::create_dir_all(&crashed).unwrap();
        assert_eq!(remove_incomplete(root.path()).unwrap(), 1);
        assert!(!crashed.exists());
    }
}
