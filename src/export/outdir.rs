//! An output folder as one set of files: one run at a time (an advisory lock), and a run's files
//! appear all together or not at all.
//!
//! A run writes every file under a unique temporary name beside its final name, then writes a
//! journal listing the renames (itself renamed into place, so it is whole or absent), renames
//! every file, and removes the journal. A run killed before the journal leaves only temporaries:
//! the next run removes them and the folder holds the old set. A run killed after it leaves the
//! journal: the next run finishes its renames first, so the folder holds the new set. While a
//! journal is present the folder is mid-commit and only a tipforge run (which recovers it) should
//! read it.

use crate::error::{Error, Result};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The lock file in every output folder (kept: removing a lock file races with its next user).
pub const LOCK_FILE: &str = ".tipforge.lock";
/// The journal of a commit in progress.
pub const JOURNAL_FILE: &str = ".tipforge-journal.json";
/// Every temporary name ends so; a file named so in an output folder is a leftover.
pub const TMP_SUFFIX: &str = ".tmp-tipforge";

/// The output folder, locked against other tipforge runs until dropped.
pub struct OutLock {
    dir: PathBuf,
    _file: File,
}

impl OutLock {
    /// Creates `dir` if needed, waits for any other tipforge run writing to it (saying so on
    /// stderr), then finishes or removes what an interrupted run left.
    pub fn acquire(dir: &Path) -> Result<OutLock> {
        let dir = if dir.as_os_str().is_empty() { PathBuf::from(".") } else { dir.to_path_buf() };
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let path = dir.join(LOCK_FILE);
        let file = std::fs::OpenOptions::new().create(true).truncate(false).write(true).open(&path).map_err(|e| Error::io(&path, e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                eprintln!("waiting for another tipforge run writing to {}", dir.display());
                file.lock().map_err(|e| Error::io(&path, e))?;
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(Error::io(&path, e)),
        }
        recover(&dir)?;
        Ok(OutLock { dir, _file: file })
    }
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

/// The list of what the last whole run into a folder wrote (fit, diagnose): path relative to the
/// folder, bytes and SHA-256 of each file. A reader that trusts only what it lists, with these
/// checksums, reads one run's set; the next run removes the files it lists and does not write.
pub const RUN_MANIFEST: &str = "tipforge-run.json";

#[derive(serde::Serialize, serde::Deserialize)]
struct Journal {
    /// (temporary, final) paths relative to the output folder.
    renames: Vec<(PathBuf, PathBuf)>,
    /// Outputs of the previous run that this one does not write, relative to the folder.
    #[serde(default)]
    removes: Vec<PathBuf>,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct RunManifest {
    schema: String,
    files: Vec<RunFile>,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct RunFile {
    path: PathBuf,
    bytes: usize,
    sha256: String,
}

/// Commits `files` as the whole content of the locked folder: the previous run's outputs that
/// this run does not write are removed in the same commit, and the run manifest is written last.
pub fn commit_run(lock: &OutLock, mut files: Vec<(PathBuf, Vec<u8>)>) -> Result<Vec<PathBuf>> {
    let dir = lock.dir().to_path_buf();
    let rel = |p: &Path| p.strip_prefix(&dir).map(Path::to_path_buf).unwrap_or_else(|_| p.to_path_buf());
    let listed: Vec<RunFile> = files.iter().map(|(p, b)| RunFile { path: rel(p), bytes: b.len(), sha256: super::manifest::sha256_hex(b) }).collect();
    let previous: Vec<PathBuf> = std::fs::read(dir.join(RUN_MANIFEST))
        .ok()
        .and_then(|b| serde_json::from_slice::<RunManifest>(&b).ok())
        .map(|m| m.files.into_iter().map(|f| f.path).collect())
        .unwrap_or_default();
    // only plain relative paths inside the folder are ever removed
    let stale: Vec<PathBuf> =
        previous.into_iter().filter(|p| p.components().all(|c| matches!(c, std::path::Component::Normal(_))) && !listed.iter().any(|f| &f.path == p)).collect();
    let mut text = serde_json::to_string_pretty(&RunManifest { schema: "tipforge.run/1".into(), files: listed }).expect("run manifest json");
    text.push('\n');
    files.push((dir.join(RUN_MANIFEST), text.into_bytes()));
    let mut written = commit(lock, &files, &stale)?;
    written.pop();
    Ok(written)
}

/// Finishes the commit of an interrupted run (its journal), then removes the temporaries left in
/// the folder by runs killed before their journal.
fn recover(dir: &Path) -> Result<()> {
    let jpath = dir.join(JOURNAL_FILE);
    if let Ok(bytes) = std::fs::read(&jpath) {
        if let Ok(j) = serde_json::from_slice::<Journal>(&bytes) {
            for (tmp, fin) in &j.renames {
                let (tmp, fin) = (dir.join(tmp), dir.join(fin));
                if tmp.exists() {
                    std::fs::rename(&tmp, &fin).map_err(|e| Error::io(&fin, e))?;
                }
            }
            for r in &j.removes {
                let _ = std::fs::remove_file(dir.join(r));
            }
        }
        std::fs::remove_file(&jpath).map_err(|e| Error::io(&jpath, e))?;
    }
    remove_leftovers(dir, 1)
}

/// Removes `*.tmp-tipforge` files in `dir` and in its immediate subfolders (a recording's
/// `truth/`), except those that are output folders of their own (they have their own lock).
fn remove_leftovers(dir: &Path, depth: usize) -> Result<()> {
    let Ok(rd) = std::fs::read_dir(dir) else { return Ok(()) };
    for e in rd.flatten() {
        let p = e.path();
        let Ok(ft) = e.file_type() else { continue };
        if ft.is_dir() {
            if depth > 0 && !p.join(LOCK_FILE).exists() {
                remove_leftovers(&p, depth - 1)?;
            }
        } else if e.file_name().to_string_lossy().ends_with(TMP_SUFFIX) {
            std::fs::remove_file(&p).map_err(|err| Error::io(&p, err))?;
        }
    }
    Ok(())
}

/// A temporary name beside `path`, unique to this process and call.
fn tmp_name(path: &Path) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}-{n}{TMP_SUFFIX}", std::process::id()))
}

/// Writes `files` into the locked folder as one set, removing `removes` (relative to the folder)
/// in the same commit (see the module's comment).
pub fn commit(lock: &OutLock, files: &[(PathBuf, Vec<u8>)], removes: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let dir = lock.dir();
    let rel = |p: &Path| -> Result<PathBuf> {
        p.strip_prefix(dir)
            .map(Path::to_path_buf)
            .or_else(|_| if dir == Path::new(".") { Ok(p.to_path_buf()) } else { Err(()) })
            .map_err(|_| Error::io(p, std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("outside the locked output folder {}", dir.display()))))
    };
    let mut renames = Vec::new();
    let mut temps = Vec::new();
    let clean = |temps: &[PathBuf]| {
        for t in temps {
            let _ = std::fs::remove_file(t);
        }
    };
    for (path, bytes) in files {
        let (fin, tmp) = (rel(path)?, tmp_name(path));
        if let Some(parent) = path.parent() {
            if let Err(e) = std::fs::create_dir_all(parent) {
                clean(&temps);
                return Err(Error::io(parent, e));
            }
        }
        if let Err(e) = std::fs::write(&tmp, bytes) {
            let _ = std::fs::remove_file(&tmp);
            clean(&temps);
            return Err(Error::io(&tmp, e));
        }
        renames.push((rel(&tmp)?, fin));
        temps.push(tmp);
    }
    // the journal makes the set whole from here on: a run killed during the renames is finished
    // by the next one
    let jtmp = tmp_name(&dir.join(JOURNAL_FILE));
    let jbytes = serde_json::to_vec(&Journal { renames, removes: removes.to_vec() }).expect("journal json");
    if let Err(e) = std::fs::write(&jtmp, jbytes).and_then(|_| std::fs::rename(&jtmp, dir.join(JOURNAL_FILE))) {
        let _ = std::fs::remove_file(&jtmp);
        clean(&temps);
        return Err(Error::io(&jtmp, e));
    }
    // for scripts/stress-outdir only: a pause before each rename, so a kill lands mid-commit
    let pause = std::env::var("TIPFORGE_TEST_COMMIT_PAUSE_MS").ok().and_then(|v| v.parse::<u64>().ok()).map(std::time::Duration::from_millis);
    let mut done = Vec::new();
    for ((path, _), tmp) in files.iter().zip(&temps) {
        if let Some(p) = pause {
            std::thread::sleep(p);
        }
        std::fs::rename(tmp, path).map_err(|e| Error::io(path, e))?;
        done.push(path.clone());
    }
    for r in removes {
        let _ = std::fs::remove_file(dir.join(r));
    }
    std::fs::remove_file(dir.join(JOURNAL_FILE)).map_err(|e| Error::io(dir.join(JOURNAL_FILE), e))?;
    Ok(done)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("tipforge-outdir-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn an_interrupted_commit_is_finished_by_the_next_run() {
        let d = tmpdir("journal");
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("a.stl"), b"old a").unwrap();
        std::fs::write(d.join("manifest.json"), b"old m").unwrap();
        // killed after the journal and one of two renames
        std::fs::write(d.join(".manifest.json.7-1.tmp-tipforge"), b"new m").unwrap();
        std::fs::write(d.join("a.stl"), b"new a").unwrap();
        let j = Journal { renames: vec![(".a.stl.7-0.tmp-tipforge".into(), "a.stl".into()), (".manifest.json.7-1.tmp-tipforge".into(), "manifest.json".into())], removes: vec![] };
        std::fs::write(d.join(JOURNAL_FILE), serde_json::to_vec(&j).unwrap()).unwrap();
        // and a run killed before its journal
        std::fs::write(d.join(".a.stl.9-0.tmp-tipforge"), b"partial").unwrap();
        let lock = OutLock::acquire(&d).unwrap();
        assert_eq!(std::fs::read(d.join("manifest.json")).unwrap(), b"new m");
        assert_eq!(std::fs::read(d.join("a.stl")).unwrap(), b"new a");
        assert!(!d.join(JOURNAL_FILE).exists());
        assert!(std::fs::read_dir(&d).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().ends_with(TMP_SUFFIX)));
        let w = commit(&lock, &[(d.join("b.stl"), b"b".to_vec()), (d.join("truth").join("b.json"), b"{}".to_vec())], &[]).unwrap();
        assert_eq!(w.len(), 2);
        assert_eq!(std::fs::read(d.join("truth").join("b.json")).unwrap(), b"{}");
        assert!(!d.join(JOURNAL_FILE).exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_whole_run_replaces_the_previous_runs_outputs_and_nothing_else() {
        let d = tmpdir("run");
        let lock = OutLock::acquire(&d).unwrap();
        std::fs::write(d.join("mine.txt"), b"the user's").unwrap();
        commit_run(&lock, vec![(d.join("table-paper.md"), b"p".to_vec()), (d.join("plots").join("a.png"), b"a".to_vec())]).unwrap();
        let w = commit_run(&lock, vec![(d.join("table-lsq.md"), b"l".to_vec()), (d.join("plots").join("b.png"), b"b".to_vec())]).unwrap();
        assert_eq!(w.len(), 2);
        assert!(!d.join("table-paper.md").exists() && !d.join("plots").join("a.png").exists());
        assert!(d.join("table-lsq.md").exists() && d.join("plots").join("b.png").exists());
        assert_eq!(std::fs::read(d.join("mine.txt")).unwrap(), b"the user's");
        let m: RunManifest = serde_json::from_slice(&std::fs::read(d.join(RUN_MANIFEST)).unwrap()).unwrap();
        assert_eq!(m.files.iter().map(|f| f.path.clone()).collect::<Vec<_>>(), vec![PathBuf::from("table-lsq.md"), PathBuf::from("plots/b.png")]);
        assert_eq!(m.files[0].sha256, crate::export::manifest::sha256_hex(b"l"));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn temporary_names_are_unique_within_a_process() {
        let p = Path::new("out/manifest.json");
        assert_ne!(tmp_name(p), tmp_name(p));
        assert!(tmp_name(p).to_string_lossy().ends_with(TMP_SUFFIX));
    }

    #[test]
    fn a_file_outside_the_locked_folder_is_refused_and_nothing_is_written() {
        let d = tmpdir("outside");
        let lock = OutLock::acquire(&d.join("out")).unwrap();
        let e = commit(&lock, &[(d.join("out").join("a"), vec![1]), (d.join("elsewhere"), vec![2])], &[]).unwrap_err();
        assert!(e.to_string().contains("outside the locked output folder"), "{e}");
        assert!(!d.join("out").join("a").exists());
        let _ = std::fs::remove_dir_all(&d);
    }
}
