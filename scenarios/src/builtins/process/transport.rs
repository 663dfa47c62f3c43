//! The child process behind a process localizer: its stdin fed by a writer thread, its stdout
//! read line by line by a reader thread, its stderr kept by a third, so that waiting for an
//! answer never blocks longer than the timeout, whatever the process does (crash, hang, stop
//! reading its input, flood its stderr).

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// How much of the process's stderr is kept: the last 64 KiB.
pub const LOG_KEEP: usize = 64 * 1024;
/// The longest answer line accepted, bytes.
pub const MAX_LINE: usize = 16 * 1024 * 1024;
/// How long a process that closed its stdout gets to exit before its status is read.
const EXIT_GRACE: Duration = Duration::from_secs(2);
/// How long the stderr thread gets to drain what a dead process wrote.
const STDERR_DRAIN: Duration = Duration::from_secs(1);

/// The last [`LOG_KEEP`] bytes a process wrote to its stderr.
#[derive(Default)]
pub struct StderrLog {
    state: Mutex<StderrState>,
    closed: Condvar,
}

#[derive(Default)]
struct StderrState {
    bytes: VecDeque<u8>,
    dropped: u64,
    closed: bool,
}

impl StderrLog {
    fn push(&self, data: &[u8]) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.bytes.extend(data);
        let excess = s.bytes.len().saturating_sub(LOG_KEEP);
        if excess > 0 {
            s.bytes.drain(..excess);
            s.dropped += excess as u64;
        }
    }

    fn close(&self) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.closed = true;
        self.closed.notify_all();
    }

    /// Waits up to `timeout` for the process's stderr to reach its end.
    fn wait_closed(&self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        while !s.closed {
            let now = Instant::now();
            if now >= deadline {
                return;
            }
            s = match self.closed.wait_timeout(s, deadline - now) {
                Ok((s, _)) => s,
                Err(e) => e.into_inner().0,
            };
        }
    }

    /// Everything kept, with a first line saying how much was dropped before it.
    pub fn text(&self) -> String {
        let s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let (a, b) = s.bytes.as_slices();
        let mut bytes = a.to_vec();
        bytes.extend_from_slice(b);
        let body = String::from_utf8_lossy(&bytes).into_owned();
        if s.dropped > 0 {
            format!(
                "[... {} earlier bytes of stderr dropped]\n{body}",
                s.dropped
            )
        } else {
            body
        }
    }

    /// The last `lines` lines (at most `max_bytes`), for error messages.
    pub fn tail(&self, lines: usize, max_bytes: usize) -> String {
        let text = self.text();
        let trimmed = text.trim_end();
        let mut start = trimmed.len();
        for _ in 0..lines {
            match trimmed[..start].rfind('\n') {
                Some(i) => start = i,
                None => {
                    start = 0;
                    break;
                }
            }
        }
        let mut tail = trimmed[start..].trim_start_matches('\n');
        if tail.len() > max_bytes {
            let mut cut = tail.len() - max_bytes;
            while !tail.is_char_boundary(cut) {
                cut += 1;
            }
            tail = &tail[cut..];
        }
        tail.to_string()
    }
}

/// What the reader and writer threads report.
enum Event {
    Line(Vec<u8>),
    /// A line longer than [`MAX_LINE`] (the reader stops there).
    TooLong,
    /// The process closed its stdout (usually: it exited).
    Closed,
    ReadFailed(String),
    WriteFailed(String),
}

/// Why no answer came.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// The process is gone (or closed its stdout): what happened to it, e.g. "exited with
    /// status 3" or "was killed by signal 9 (SIGKILL)".
    Gone(String),
    /// No answer within the timeout; the process has been killed.
    Timeout(Duration),
    /// Its stdout could not be read, or a line exceeded [`MAX_LINE`].
    Unreadable(String),
}

/// A running localizer process.
pub struct Child {
    child: std::process::Child,
    writer: Option<Sender<Vec<u8>>>,
    events: Receiver<Event>,
    /// An event taken off `events` by [`Child::unasked_line`] and not yet handled.
    held: Option<Event>,
    stderr: Arc<StderrLog>,
    /// Set once the process has exited (or been killed and reaped).
    status: Option<ExitStatus>,
    /// Its process group (it leads one of its own): whatever it forked ends with it.
    group: crate::atomic::ChildGroup,
}

impl Child {
    /// Starts `program` with `args` in `cwd`, with `env` added to Atrium's environment.
    pub fn spawn(
        program: &Path,
        args: &[String],
        env: &[(String, String)],
        cwd: &Path,
    ) -> std::io::Result<Child> {
        let mut cmd = Command::new(program);
        cmd.args(args)
            .current_dir(cwd)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        for (k, v) in env {
            cmd.env(k, v);
        }
        // Its own process group, so that killing the group ends the children it forks, and a
        // Ctrl-C in the terminal reaches Atrium alone (whose handler ends the group).
        #[cfg(unix)]
        {
            use std::os::unix::process::CommandExt;
            cmd.process_group(0);
        }
        let mut child = cmd.spawn()?;
        let group = crate::atomic::ChildGroup::register(child.id());
        let (stdin, stdout, stderr) =
            match (child.stdin.take(), child.stdout.take(), child.stderr.take()) {
                (Some(a), Some(b), Some(c)) => (a, b, c),
                _ => {
                    drop(group);
                    let _ = child.wait();
                    return Err(std::io::Error::other("the process's pipes are missing"));
                }
            };
        let (event_tx, events) = mpsc::channel();
        let log = Arc::new(StderrLog::default());

        let tx = event_tx.clone();
        spawn_thread("atrium-process-stdout", move || read_lines(stdout, tx))?;
        let (writer, lines) = mpsc::channel::<Vec<u8>>();
        spawn_thread("atrium-process-stdin", move || {
            write_lines(stdin, lines, event_tx)
        })?;
        let keep = log.clone();
        spawn_thread("atrium-process-stderr", move || read_stderr(stderr, &keep))?;

        Ok(Child {
            child,
            writer: Some(writer),
            events,
            held: None,
            stderr: log,
            status: None,
            group,
        })
    }

    pub fn id(&self) -> u32 {
        self.child.id()
    }

    pub fn stderr(&self) -> &StderrLog {
        &self.stderr
    }

    /// Queues one line for the process's stdin (`line` must not hold a newline; one is
    /// added).
    pub fn send(&mut self, mut line: Vec<u8>) {
        line.push(b'\n');
        if let Some(w) = &self.writer {
            // A closed channel means the writer stopped on an error it reported already.
            let _ = w.send(line);
        }
    }

    /// A non-blank line the process wrote that no message asked for, if one is waiting now
    /// (a process that answers twice would make every later estimate one message stale).
    /// Other events stay queued for [`Child::request`].
    pub fn unasked_line(&mut self) -> Option<Vec<u8>> {
        loop {
            if self.held.is_some() {
                return None;
            }
            match self.events.try_recv() {
                Ok(Event::Line(l)) if l.iter().all(u8::is_ascii_whitespace) => continue,
                Ok(Event::Line(l)) => return Some(l),
                Ok(other) => {
                    self.held = Some(other);
                    return None;
                }
                Err(_) => return None,
            }
        }
    }

    /// After the process ended (or closed its stdout): the non-blank lines it wrote that no
    /// message asked for, waiting up to `timeout` for its stdout to reach its end.
    pub fn unasked_lines_at_end(&mut self, timeout: Duration) -> usize {
        let deadline = Instant::now() + timeout;
        let mut extra = 0;
        if let Some(e) = self.held.take() {
            match e {
                Event::Line(l) if !l.iter().all(u8::is_ascii_whitespace) => extra += 1,
                Event::Line(_) => {}
                _ => return extra,
            }
        }
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(Event::Line(l)) if l.iter().all(u8::is_ascii_whitespace) => {}
                Ok(Event::Line(_)) => extra += 1,
                // Closed, unreadable, or the stdin writer's report: nothing more to count.
                Ok(Event::WriteFailed(_)) => {}
                Ok(_) | Err(_) => return extra,
            }
        }
    }

    /// Sends `line` and waits up to `timeout` for the next non-blank line of the process's
    /// stdout. On a failure the process is dead or killed.
    pub fn request(&mut self, line: Vec<u8>, timeout: Duration) -> Result<Vec<u8>, Failure> {
        self.send(line);
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let event = match self.held.take() {
                Some(e) => Ok(e),
                None => self.events.recv_timeout(left),
            };
            match event {
                Ok(Event::Line(l)) if l.iter().all(u8::is_ascii_whitespace) => continue,
                Ok(Event::Line(l)) => return Ok(l),
                Ok(Event::TooLong) => {
                    self.kill();
                    return Err(Failure::Unreadable(format!(
                        "an answer line longer than {} MiB",
                        MAX_LINE >> 20
                    )));
                }
                Ok(Event::ReadFailed(e)) => {
                    self.kill();
                    return Err(Failure::Unreadable(format!("cannot read its stdout: {e}")));
                }
                Ok(Event::Closed) => {
                    return Err(Failure::Gone(self.gone("closed its stdout")));
                }
                Ok(Event::WriteFailed(e)) => {
                    let alive = format!("stopped reading its stdin ({e})");
                    return Err(Failure::Gone(self.gone(&alive)));
                }
                Err(RecvTimeoutError::Timeout) => {
                    // It may have died just now: say so rather than "timed out".
                    if let Ok(Some(status)) = self.child.try_wait() {
                        self.status = Some(status);
                        self.group.end();
                        self.stderr.wait_closed(STDERR_DRAIN);
                        return Err(Failure::Gone(describe(status)));
                    }
                    self.kill();
                    return Err(Failure::Timeout(timeout));
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(Failure::Gone(self.gone("closed its stdout")));
                }
            }
        }
    }

    /// The process stopped talking: waits briefly for its exit status and describes it
    /// (killing it if it is still running, having closed its stdout).
    fn gone(&mut self, alive: &str) -> String {
        let deadline = Instant::now() + EXIT_GRACE;
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(s)) => break Some(s),
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(5))
                }
                _ => break None,
            }
        };
        let what = match status {
            Some(s) => {
                self.status = Some(s);
                self.group.end();
                describe(s)
            }
            None => {
                self.kill();
                alive.to_string()
            }
        };
        self.stderr.wait_closed(STDERR_DRAIN);
        what
    }

    /// Closes its stdin (after whatever is queued) and waits up to `grace` for it to exit,
    /// then kills it. Returns its exit status when it exited by itself.
    pub fn finish(&mut self, grace: Duration) -> Option<ExitStatus> {
        self.writer = None;
        if self.status.is_some() {
            return self.status;
        }
        let deadline = Instant::now() + grace;
        loop {
            match self.child.try_wait() {
                Ok(Some(s)) => {
                    self.status = Some(s);
                    // Children it left running (holding its stderr open) end with it.
                    self.group.end();
                    self.stderr.wait_closed(STDERR_DRAIN);
                    return Some(s);
                }
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(5))
                }
                _ => {
                    self.kill();
                    return None;
                }
            }
        }
    }

    /// Kills the process (if still running) and every process of its group, and reaps it.
    pub fn kill(&mut self) {
        if self.status.is_none() {
            // The group before the reap: while the leader is unreaped its pid (the group's id)
            // cannot name another process.
            self.group.end();
            let _ = self.child.kill();
            self.writer = None;
            if let Ok(s) = self.child.wait() {
                self.status = Some(s);
            }
            self.stderr.wait_closed(STDERR_DRAIN);
        }
        self.group.end();
        self.writer = None;
    }
}

impl Drop for Child {
    fn drop(&mut self) {
        self.kill();
    }
}

fn spawn_thread(name: &str, f: impl FnOnce() + Send + 'static) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name(name.into())
        .spawn(f)
        .map(|_| ())
}

fn read_lines(stdout: impl Read, tx: Sender<Event>) {
    let mut reader = BufReader::new(stdout);
    let mut buf = Vec::new();
    loop {
        buf.clear();
        match (&mut reader)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
        {
            Ok(0) => {
                let _ = tx.send(Event::Closed);
                return;
            }
            Ok(_) if buf.last() == Some(&b'\n') => {
                buf.pop();
                if buf.last() == Some(&b'\r') {
                    buf.pop();
                }
                if tx.send(Event::Line(std::mem::take(&mut buf))).is_err() {
                    return;
                }
            }
            Ok(_) if buf.len() > MAX_LINE => {
                let _ = tx.send(Event::TooLong);
                return;
            }
            // The last line, without a newline: then the end.
            Ok(_) => {
                let _ = tx.send(Event::Line(std::mem::take(&mut buf)));
                let _ = tx.send(Event::Closed);
                return;
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => {
                let _ = tx.send(Event::ReadFailed(e.to_string()));
                return;
            }
        }
    }
}

fn write_lines(mut stdin: impl Write, lines: Receiver<Vec<u8>>, tx: Sender<Event>) {
    for line in lines {
        if let Err(e) = stdin.write_all(&line).and_then(|_| stdin.flush()) {
            let _ = tx.send(Event::WriteFailed(e.to_string()));
            return;
        }
    }
    // The channel closed: dropping stdin tells the process there is no more input.
}

fn read_stderr(mut stderr: impl Read, log: &StderrLog) {
    let mut buf = [0u8; 8192];
    loop {
        match stderr.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => log.push(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    log.close();
}

/// "exited with status 3", "was killed by signal 9 (SIGKILL)".
pub fn describe(status: ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = status.signal() {
            let name = match sig {
                1 => " (SIGHUP)",
                2 => " (SIGINT)",
                6 => " (SIGABRT)",
                9 => " (SIGKILL)",
                11 => " (SIGSEGV)",
                13 => " (SIGPIPE)",
                15 => " (SIGTERM)",
                _ => "",
            };
            return format!("was killed by signal {sig}{name}");
        }
    }
    match status.code() {
        Some(c) => format!("exited with status {c}"),
        None => format!("ended ({status})"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stderr_log_keeps_the_last_bytes_and_tails_lines() {
        let log = StderrLog::default();
        for i in 0..10_000 {
            log.push(format!("line {i}\n").as_bytes());
        }
        let text = log.text();
        assert!(text.starts_with("[... "), "{}", &text[..40]);
        assert!(text.len() <= LOG_KEEP + 64);
        assert!(text.ends_with("line 9999\n"));
        assert_eq!(log.tail(2, 1000), "line 9998\nline 9999");
        assert_eq!(log.tail(2, 4), "9999");
        let short = StderrLog::default();
        short.push(b"only\n");
        assert_eq!(short.tail(5, 100), "only");
    }
}
