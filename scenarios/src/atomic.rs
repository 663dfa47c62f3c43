//! One way to write an output file: under a temporary name in the same folder, then renamed,
//! so an interrupted run never leaves a half-written file under the final name. Every writer
//! (run folders, figures, HTML reports, sweeps) goes through [`write_atomic`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

/// Files being written under a temporary name right now. The CLI's interrupt handler removes
/// them ([`remove_unfinished`]), so Ctrl-C or a `kill` never leaves a half-written file behind.
fn unfinished() -> &'static Mutex<Vec<PathBuf>> {
    static FILES: OnceLock<Mutex<Vec<PathBuf>>> = OnceLock::new();
    FILES.get_or_init(|| Mutex::new(Vec::new()))
}

/// Registers a temporary file for removal on interrupt for as long as the guard lives; drop it
/// once the file is renamed to its final name or removed.
#[derive(Debug)]
pub struct Unfinished {
    path: PathBuf,
}

impl Unfinished {
    pub fn register(path: &Path) -> Unfinished {
        let path = path.to_path_buf();
        lock(unfinished()).push(path.clone());
        Unfinished { path }
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        let mut files = lock(unfinished());
        if let Some(i) = files.iter().position(|p| *p == self.path) {
            files.swap_remove(i);
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Removes every registered temporary file and returns those that existed. Called when the
/// process is interrupted; writers may still hold them open (on Unix the data goes to an
/// unlinked file), and a rename racing with this finds the name gone or the final file whole.
pub fn remove_unfinished() -> Vec<PathBuf> {
    let files = std::mem::take(&mut *lock(unfinished()));
    files
        .into_iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .collect()
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so the
/// final name never holds a partial file. The temporary name is unique per process and call
/// (threads of a sweep write at once).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let file_name = path
        .file_name()
        .ok_or_else(|| std::io::Error::other(format!("{}: not a file path", path.display())))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(file_name);
    static CALLS: AtomicU64 = AtomicU64::new(0);
    let call = CALLS.fetch_add(1, Ordering::Relaxed);
    tmp_name.push(format!(".{}-{call}.tmp", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    let _unfinished = Unfinished::register(&tmp);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
