//! Writers for STL, 3MF and the manifest. Every writer produces bytes in memory; `atomic`
//! puts them into `out/` (temporary name, then rename) so a failed build leaves `out/` as it was.

pub mod manifest;
pub mod stl;
pub mod threemf;

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Files to write: every one is staged under a temporary name first, then all are renamed.
#[derive(Default)]
pub struct Staged {
    files: Vec<(PathBuf, Vec<u8>)>,
}

impl Staged {
    pub fn add(&mut self, path: PathBuf, bytes: Vec<u8>) {
        self.files.push((path, bytes));
    }
    /// Writes every file to `<name>.tmp-tipforge`, then renames them all into place. On any error
    /// the temporaries are removed and nothing in place has changed.
    pub fn commit(self) -> Result<Vec<PathBuf>> {
        // two files staged for one path would leave the first renamed and the second failing
        for (i, (path, _)) in self.files.iter().enumerate() {
            if self.files[..i].iter().any(|(p, _)| p == path) {
                return Err(Error::io(path, std::io::Error::new(std::io::ErrorKind::AlreadyExists, "two outputs of this run have this name; nothing was written")));
            }
        }
        let mut temps = Vec::new();
        for (path, bytes) in &self.files {
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
            }
            let tmp = tmp_name(path);
            if let Err(e) = std::fs::write(&tmp, bytes) {
                let _ = std::fs::remove_file(&tmp);
                for t in &temps {
                    let _ = std::fs::remove_file(t);
                }
                return Err(Error::io(&tmp, e));
            }
            temps.push(tmp);
        }
        let mut done = Vec::new();
        for ((path, _), tmp) in self.files.iter().zip(&temps) {
            std::fs::rename(tmp, path).map_err(|e| Error::io(path, e))?;
            done.push(path.clone());
        }
        Ok(done)
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

fn tmp_name(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp-tipforge");
    PathBuf::from(s)
}
