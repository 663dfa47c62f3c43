//! One way to write an output file: under a temporary name in the same folder, then renamed,
//! so an interrupted run never leaves a half-written file under the final name. Every writer
//! (run folders, figures, HTML reports, sweeps) goes through [`write_atomic`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

/// Files being written under a temporary name right now. The CLI's interrupt handler removes
/// them ([`remove_unfinished`]), so Ctrl-C or a `kill` never leaves a half-written file behind.
/// Each with whether it is a folder (removed with everything in it).
fn unfinished() -> &'static Mutex<Vec<(PathBuf, bool)>> {
    static FILES: OnceLock<Mutex<Vec<(PathBuf, bool)>>> = OnceLock::new();
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
        Self::push(path, false)
    }

    /// A temporary folder (a recording's `<dir>.partial/`, a process localizer's map folder):
    /// removed on interrupt with everything in it. Register only folders Atrium made itself.
    pub fn register_dir(path: &Path) -> Unfinished {
        Self::push(path, true)
    }

    fn push(path: &Path, dir: bool) -> Unfinished {
        let path = path.to_path_buf();
        lock(unfinished()).push((path.clone(), dir));
        Unfinished { path }
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        let mut files = lock(unfinished());
        if let Some(i) = files.iter().position(|(p, _)| *p == self.path) {
            files.swap_remove(i);
        }
    }
}

/// Process groups of children Atrium started (process localizers, each the leader of its own
/// group), ended on interrupt ([`end_child_groups`]) since a signal's exit runs no destructor.
fn child_groups() -> &'static Mutex<Vec<u32>> {
    static GROUPS: OnceLock<Mutex<Vec<u32>>> = OnceLock::new();
    GROUPS.get_or_init(|| Mutex::new(Vec::new()))
}

/// A child's process group, killed (SIGKILL to the whole group, so the children it forked go
/// too) by [`ChildGroup::end`], when dropped, or by [`end_child_groups`] on interrupt.
#[derive(Debug)]
pub struct ChildGroup {
    pgid: Option<u32>,
}

impl ChildGroup {
    /// `pgid`: the id of a group made for a child (`Command::process_group(0)`: its pid).
    pub fn register(pgid: u32) -> ChildGroup {
        lock(child_groups()).push(pgid);
        ChildGroup { pgid: Some(pgid) }
    }

    /// Kills every process left in the group and forgets it.
    pub fn end(&mut self) {
        if let Some(g) = self.pgid.take() {
            kill_group(g);
            let mut groups = lock(child_groups());
            if let Some(i) = groups.iter().position(|p| *p == g) {
                groups.swap_remove(i);
            }
        }
    }
}

impl Drop for ChildGroup {
    fn drop(&mut self) {
        self.end();
    }
}

fn kill_group(pgid: u32) {
    #[cfg(unix)]
    if let Ok(g) = i32::try_from(pgid) {
        // Never 0 or 1 (our own group, or every process): only a child's own group.
        if g > 1 {
            // SAFETY: kill(2) with a negative pid signals that process group; no memory is
            // involved.
            unsafe {
                libc::kill(-g, libc::SIGKILL);
            }
        }
    }
    #[cfg(not(unix))]
    let _ = pgid;
}

/// Kills the process groups of every child still running (the interrupt handler calls it
/// before [`remove_unfinished`], so no child writes into a folder being removed).
pub fn end_child_groups() {
    for g in std::mem::take(&mut *lock(child_groups())) {
        kill_group(g);
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
        .filter(|(p, dir)| {
            if *dir {
                std::fs::remove_dir_all(p).is_ok()
            } else {
                std::fs::remove_file(p).is_ok()
            }
        })
        .map(|(p, _)| p)
        .collect()
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so the
/// final name never holds a partial file. The temporary name is unique per process and call
/// (threads of a sweep write at once).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let file_name = path
        .file_name()
        .ok_or_else(|| std::io::Error::other(format!("{}: not a file path", path.display())))?;
    atrium_formats::output_path::check_replaceable(path)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fifo_is_not_replaced_by_a_written_file() {
        let dir = std::env::temp_dir().join(format!("atrium-atomic-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("out.html");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return; // no mkfifo on this system
        }
        let e = write_atomic(&fifo, b"report").unwrap_err().to_string();
        assert!(e.contains("FIFO"), "{e}");
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        // Nothing left behind under a temporary name either.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        write_atomic(&dir.join("plain.html"), b"report").unwrap();
        assert_eq!(std::fs::read(dir.join("plain.html")).unwrap(), b"report");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
