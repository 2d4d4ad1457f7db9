//! The store lock: one writer at a time.
//!
//! `store.lock` is locked with an OS advisory lock (`File::try_lock`), released automatically
//! when the process exits, even on SIGKILL, so a crashed run never leaves a stale lock. The file
//! holds the holder's pid and command for the "waiting for ..." message.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;

use super::layout::LOCK_FILE;
use super::{IoOp, StoreError, files::ensure_dir};

/// What to do when another process holds the lock.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum LockWait {
    /// Block until the other writer finishes.
    Wait,
    /// Fail at once with [`StoreError::Locked`].
    Refuse,
}

/// An exclusive lock on a store, held until dropped.
#[derive(Debug)]
pub struct StoreLock {
    file: File,
}

impl StoreLock {
    /// Lock the store at `root` (creating the root if needed). `on_wait` is called once, with
    /// the holder's description, if the lock is busy and `wait` is [`LockWait::Wait`].
    pub fn acquire(
        root: &Path,
        what: &str,
        wait: LockWait,
        on_wait: impl FnOnce(&str),
    ) -> Result<StoreLock, StoreError> {
        ensure_dir(root)?;
        let path = root.join(LOCK_FILE);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| StoreError::io(IoOp::Lock, &path, e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = holder.trim().to_string();
                match wait {
                    LockWait::Refuse => {
                        return Err(StoreError::Locked {
                            root: root.to_path_buf(),
                            holder,
                        });
                    }
                    LockWait::Wait => {
                        on_wait(&holder);
                        file.lock()
                            .map_err(|e| StoreError::io(IoOp::Lock, &path, e))?;
                    }
                }
            }
            Err(TryLockError::Error(e)) => return Err(StoreError::io(IoOp::Lock, &path, e)),
        }
        let note = format!("pid {} ({what})\n", std::process::id());
        let _ = file.set_len(0);
        let _ = file.seek(SeekFrom::Start(0));
        let _ = file.write_all(note.as_bytes());
        let _ = file.sync_all();
        Ok(StoreLock { file })
    }
}

impl Drop for StoreLock {
    fn drop(&mut self) {
        let _ = self.file.set_len(0);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn second_locker_is_refused_then_succeeds_after_release() {
        let dir = tempfile::tempdir().unwrap();
        let first = StoreLock::acquire(dir.path(), "test one", LockWait::Refuse, |_| {}).unwrap();
        let err = StoreLock::acquire(dir.path(), "test two", LockWait::Refuse, |_| {}).unwrap_err();
        assert!(err.to_string().contains("test one"), "{err}");
        drop(first);
        StoreLock::acquire(dir.path(), "test two", LockWait::Refuse, |_| {}).unwrap();
    }
}
