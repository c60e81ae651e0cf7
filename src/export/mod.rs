//! Writers for STL, 3MF and the manifest. Every writer produces bytes in memory; [`Staged`]
//! puts them into the locked output folder as one set ([`outdir`]), so a failed or killed run
//! leaves it as it was.

pub mod manifest;
pub mod outdir;
pub mod stl;
pub mod threemf;

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Files to write: every one is staged under a temporary name first, then all are renamed.
#[derive(Default)]
pub struct Staged {
    files: Vec<(PathBuf, Vec<u8>)>,
    /// The folder holds one run's outputs: the previous run's files that this run does not write
    /// are removed, and `tipforge-run.json` lists what this run wrote (fit, diagnose).
    whole_run: bool,
}

impl Staged {
    /// Files that make up the whole content of their output folder (see [`outdir::RUN_MANIFEST`]).
    pub fn whole_run() -> Staged {
        Staged { files: Vec::new(), whole_run: true }
    }
    pub fn add(&mut self, path: PathBuf, bytes: Vec<u8>) {
        self.files.push((path, bytes));
    }
    /// Writes every file into the locked output folder as one set: all of them or, if the run
    /// fails or is killed, none (see [`outdir`]).
    pub fn commit(self, lock: &outdir::OutLock) -> Result<Vec<PathBuf>> {
        // two files staged for one path would leave the first renamed and the second failing
        for (i, (path, _)) in self.files.iter().enumerate() {
            if self.files[..i].iter().any(|(p, _)| p == path) {
                return Err(Error::io(path, std::io::Error::new(std::io::ErrorKind::AlreadyExists, "two outputs of this run have this name; nothing was written")));
            }
        }
        if self.whole_run {
            outdir::commit_run(lock, self.files)
        } else {
            outdir::commit(lock, &self.files, &[])
        }
    }
}

/// The output folder given with `option` must be a folder or not exist yet (it is created): a
/// file there, or a file where one of its parents should be, is the user's input problem, found
/// before any work is done.
pub fn check_out_dir(dir: &Path, option: &str, fix: &str) -> Result<()> {
    let mut at = Some(dir);
    while let Some(p) = at {
        if p.as_os_str().is_empty() {
            break;
        }
        if let Ok(meta) = std::fs::metadata(p) {
            if meta.is_dir() {
                return Ok(());
            }
            let what = if p == dir { "is a file, not a folder".to_string() } else { format!("cannot be created: {} is a file", p.display()) };
            return Err(Error::input(dir.display().to_string(), option, dir.display(), format!("{what}; {fix}")));
        }
        at = p.parent();
    }
    Ok(())
}
