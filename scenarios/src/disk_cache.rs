//! On-disk cache of what is expensive to derive from a world and a training run (the WiFi
//! graph learnt from a survey run, a chooser's training runs, MCL's likelihood fields in
//! `maps`, appearance models, omnicam and ceiling-brightness maps), so a later process with
//! the same inputs starts at once. It sits under the in-process memos (`map_cache`, the
//! survey and training memos): those are asked first, this second, the build last.
//!
//! **Key.** The caller gives the full text of every input (the texts of the scenario, world,
//! robot and sensor files, and of every file a localizer names, recursively: see
//! [`scenario_inputs`]; the parsed world, robot and WiFi scanner; the parameters; the seed is
//! in the scenario text). [`FORMAT_VERSION`], the entry's kind with its own version, and the
//! identity of the running executable (size and modification time) are added: a value
//! depends on the simulator and the localizers, code other crates change, so an entry
//! written by another build is never trusted (a rebuilt `atrium` rebuilds its entries once).
//! The file is named by a 128-bit hash of the key without the executable's identity (a new
//! build overwrites its predecessor's entry instead of piling up beside it), and the entry
//! holds the whole key, compared byte for byte on reading: a hash collision is a miss,
//! never a wrong value.
//!
//! **Entry.** `ATRCACH1`, u32 format version, u64 key length, u64 payload length, u64
//! payload checksum, the key, the payload (all little-endian). An entry whose length, key or
//! checksum disagrees, or whose payload does not decode, is rebuilt and overwritten, never
//! trusted.
//!
//! **Concurrency.** An entry is written to a unique temporary file in the same folder
//! (process id, counter, time), flushed to disk (`fsync`) and renamed over the entry: a
//! reader sees a whole entry or none, and processes of a sweep that build the same entry
//! at once each rename an identical file. A cache that cannot be written (read-only folder,
//! full disk) costs a rebuild next time, never a failed run.
//!
//! **Location** ([`default_dir`]): `$ATRIUM_CACHE_DIR`; else `atrium-cache` in the Cargo
//! target folder the running executable was built in (found by its `CACHEDIR.TAG`: entries
//! live beside the build they depend on, `cargo clean` removes both, and a source checkout
//! writes nothing into the home folder); else `$XDG_CACHE_HOME/atrium`, else
//! `~/.cache/atrium` (an installed binary).
//!
//! **Size.** The folder is kept under a cap: `ATRIUM_CACHE_MAX_MB` megabytes (default
//! [`DEFAULT_MAX_MB`]; `none` for no cap). After each write the least recently used entries
//! (by modification time, which a hit refreshes) are deleted until the folder fits, the entry
//! just written always kept; temporary files that killed writers left (older than an hour)
//! go too. A sweep over generated worlds stores a likelihood field of tens of megabytes per
//! world, which without a cap would pile up for good. Deleting is safe under concurrent
//! processes: a reader holding the file keeps reading it, one opening it after sees a miss
//! and rebuilds.
//!
//! **Bypass.** `--no-cache` on the commands that run scenarios ([`set_enabled`]`(false)`) or
//! `ATRIUM_NO_CACHE=1`: nothing is read or written. A hit returns exactly the value a
//! rebuild makes (the values are encoded losslessly), so no result depends on the cache.

use crate::scenario::Scenario;
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};
use std::sync::OnceLock;

/// Bumped when the entry layout or the meaning of a key changes.
pub const FORMAT_VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"ATRCACH1";
const HEADER: usize = 8 + 4 + 8 + 8 + 8;

/// The cap on the cache folder's size when `ATRIUM_CACHE_MAX_MB` is not set, MB.
pub const DEFAULT_MAX_MB: u64 = 2048;

/// The environment variable naming the cap.
pub const MAX_MB_VAR: &str = "ATRIUM_CACHE_MAX_MB";

/// Temporary files older than this are a killed writer's remains.
const STALE_TMP: std::time::Duration = std::time::Duration::from_secs(3600);

/// The cap a value of [`MAX_MB_VAR`] gives, bytes: a whole number of megabytes, or `none`
/// (no cap); unset or empty, [`DEFAULT_MAX_MB`].
pub fn parse_max_mb(value: Option<&str>) -> Result<Option<u64>, String> {
    let v = value.map(str::trim).unwrap_or("");
    match v {
        "" => Ok(Some(DEFAULT_MAX_MB << 20)),
        "none" => Ok(None),
        _ => v
            .parse::<u64>()
            .ok()
            .and_then(|mb| mb.checked_mul(1 << 20))
            .map(Some)
            .ok_or_else(|| {
                format!("{MAX_MB_VAR}: expected a whole number of megabytes or `none`, got {v:?}")
            }),
    }
}

/// The cap the environment sets (see [`parse_max_mb`]); the error names the variable. The
/// CLI checks it before running anything; a cache asked to store with a bad value keeps the
/// default.
pub fn max_bytes_from_env() -> Result<Option<u64>, String> {
    let v = std::env::var_os(MAX_MB_VAR);
    match v.as_ref().map(|v| v.to_str()) {
        None => parse_max_mb(None),
        Some(Some(v)) => parse_max_mb(Some(v)),
        Some(None) => Err(format!("{MAX_MB_VAR}: not valid UTF-8")),
    }
}

/// 0: not set (the environment decides), 1: on, 2: off.
static ENABLED: AtomicU8 = AtomicU8::new(0);

/// Turns the disk cache on or off for this process (the CLI's `--no-cache`); overrides
/// `ATRIUM_NO_CACHE`.
pub fn set_enabled(on: bool) {
    ENABLED.store(if on { 1 } else { 2 }, Ordering::SeqCst);
}

/// Whether runs read and write the disk cache: [`set_enabled`] if called, else unless
/// `ATRIUM_NO_CACHE` is set to anything but empty, `0` or `false`.
pub fn enabled() -> bool {
    match ENABLED.load(Ordering::SeqCst) {
        1 => true,
        2 => false,
        _ => {
            !std::env::var("ATRIUM_NO_CACHE").is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"))
        }
    }
}

/// The cache folder (see the module docs), or `None` when no folder can be named.
pub fn default_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("ATRIUM_CACHE_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    if let Ok(exe) = std::env::current_exe() {
        // target/<profile>/atrium, target/<profile>/deps/<test>, target/<triple>/<profile>/..
        for dir in exe.ancestors().skip(1).take(4) {
            if dir.join("CACHEDIR.TAG").is_file() {
                return Some(dir.join("atrium-cache"));
            }
        }
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d).join("atrium"));
    }
    std::env::var_os("HOME")
        .filter(|d| !d.is_empty())
        .map(|h| PathBuf::from(h).join(".cache").join("atrium"))
}

/// The running executable's identity: its size and modification time (a rebuild changes
/// them). Part of every key.
fn exe_identity() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        let meta = std::env::current_exe().and_then(std::fs::metadata);
        match meta {
            Ok(m) => {
                let mtime = m
                    .modified()
                    .ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_nanos());
                format!("exe {} bytes, modified {mtime} ns", m.len())
            }
            // Unknown executable: a key no other process shares.
            Err(_) => format!("exe unknown, process {}", std::process::id()),
        }
    })
}

/// A 64-bit hash of `bytes` (word at a time; not cryptographic): the payload checksum and,
/// with two seeds, the entry's file name.
pub fn hash64(seed: u64, bytes: &[u8]) -> u64 {
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut h = seed ^ (bytes.len() as u64).wrapping_mul(K);
    let mut chunks = bytes.chunks_exact(8);
    for c in &mut chunks {
        let w = u64::from_le_bytes(c.try_into().unwrap_or([0; 8]));
        h = (h ^ w).wrapping_mul(K);
        h ^= h >> 29;
    }
    let mut tail = [0u8; 8];
    tail[..chunks.remainder().len()].copy_from_slice(chunks.remainder());
    h = (h ^ u64::from_le_bytes(tail)).wrapping_mul(K);
    h ^= h >> 32;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^ (h >> 33)
}

/// A cache folder. [`DiskCache::global`] is the one runs use; tests make their own.
#[derive(Debug, Clone)]
pub struct DiskCache {
    dir: PathBuf,
    /// The folder's cap, bytes (`None`: no cap).
    max_bytes: Option<u64>,
}

impl DiskCache {
    /// The cache in `dir`, capped as the environment says (see [`max_bytes_from_env`]).
    pub fn at(dir: impl Into<PathBuf>) -> DiskCache {
        let max_bytes = max_bytes_from_env().unwrap_or(Some(DEFAULT_MAX_MB << 20));
        DiskCache::with_cap(dir, max_bytes)
    }

    /// The cache in `dir`, kept under `max_bytes` (`None`: no cap).
    pub fn with_cap(dir: impl Into<PathBuf>, max_bytes: Option<u64>) -> DiskCache {
        DiskCache {
            dir: dir.into(),
            max_bytes,
        }
    }

    /// The process's cache: `None` when disabled or no folder can be named.
    pub fn global() -> Option<DiskCache> {
        if !enabled() {
            return None;
        }
        default_dir().map(DiskCache::at)
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The entry file for `kind` and `key` (without the executable's identity).
    pub fn entry_path(&self, kind: &str, key: &[u8]) -> PathBuf {
        let a = hash64(0x6174_7269_756d_0001, key);
        let b = hash64(0x6174_7269_756d_0002, key);
        self.dir.join(format!("{kind}-{a:016x}{b:016x}.bin"))
    }

    fn full_key(kind: &str, key: &[u8]) -> Vec<u8> {
        let mut k = format!(
            "atrium disk cache {FORMAT_VERSION}\n{kind}\n{}\n",
            exe_identity()
        )
        .into_bytes();
        k.extend_from_slice(key);
        k
    }

    /// The payload stored under `kind` and `key`, if a whole, matching entry is there.
    pub fn get(&self, kind: &str, key: &[u8]) -> Option<Vec<u8>> {
        self.decode_stored(kind, key, |p| Some(p.to_vec()))
    }

    /// `decode` of the payload stored under `kind` and `key`, read in place (a likelihood
    /// field's entry is tens of megabytes: no copy of it is made).
    fn decode_stored<T>(
        &self,
        kind: &str,
        key: &[u8],
        decode: impl FnOnce(&[u8]) -> Option<T>,
    ) -> Option<T> {
        let path = self.entry_path(kind, key);
        // Only a regular file is an entry: reading a FIFO (or a device) put there would
        // block the run for good. Anything else is a miss, and `put` renames over it.
        if !std::fs::metadata(&path).is_ok_and(|m| m.is_file()) {
            return None;
        }
        let bytes = std::fs::read(&path).ok()?;
        let value = decode(decode_entry(&bytes, &Self::full_key(kind, key))?)?;
        // Recently used: the last entries the cap evicts. Best effort (a read-only cache).
        if let Ok(f) = std::fs::File::options().write(true).open(&path) {
            let _ = f.set_modified(std::time::SystemTime::now());
        }
        Some(value)
    }

    /// Stores `payload` under `kind` and `key` (temporary file, fsync, rename).
    pub fn put(&self, kind: &str, key: &[u8], payload: &[u8]) -> std::io::Result<()> {
        let result = self.put_entry(kind, key, payload);
        if let Err(e) = &result {
            // Said once per process: a cache that cannot be written (a read-only folder
            // beside an installed binary, a cluster node's) silently costs every run a rebuild.
            static WARNED: std::sync::atomic::AtomicBool =
                std::sync::atomic::AtomicBool::new(false);
            if !WARNED.swap(true, Ordering::Relaxed) {
                eprintln!(
                    "warning: cannot write the cache in {} ({e}): what runs learn from a world is \
                     rebuilt every time; set ATRIUM_CACHE_DIR to a writable folder (or pass \
                     --no-cache)",
                    self.dir.display()
                );
            }
        }
        result
    }

    fn put_entry(&self, kind: &str, key: &[u8], payload: &[u8]) -> std::io::Result<()> {
        std::fs::create_dir_all(&self.dir)?;
        let path = self.entry_path(kind, key);
        let full = Self::full_key(kind, key);
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("entry");
        let tmp = self.dir.join(format!(
            ".{name}.{}-{}-{nanos}.tmp",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let result = (|| {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&tmp)?;
            f.write_all(&encode_entry(&full, payload))?;
            f.sync_all()?;
            drop(f);
            std::fs::rename(&tmp, &path)?;
            // Best effort: the rename itself durable.
            if let Ok(d) = std::fs::File::open(&self.dir) {
                let _ = d.sync_all();
            }
            Ok(())
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        if result.is_ok() {
            if let Some(cap) = self.max_bytes {
                self.evict(cap, &path);
            }
        }
        result
    }

    /// Deletes the least recently used entries until the folder's entries fit in `cap`
    /// bytes, never `keep` (the entry just written), and temporary files older than
    /// [`STALE_TMP`]. Returns the entries deleted. Files another process deleted first are
    /// skipped; nothing but entries and temporary files of this cache is touched.
    pub fn evict(&self, cap: u64, keep: &Path) -> Vec<PathBuf> {
        let Ok(dir) = std::fs::read_dir(&self.dir) else {
            return Vec::new();
        };
        let now = std::time::SystemTime::now();
        let mut entries = Vec::new();
        let mut total = 0u64;
        for e in dir.flatten() {
            let (path, Ok(meta)) = (e.path(), e.metadata()) else {
                continue;
            };
            let name = e.file_name();
            let name = name.to_string_lossy();
            let modified = meta.modified().unwrap_or(std::time::UNIX_EPOCH);
            if name.starts_with('.') && name.ends_with(".tmp") {
                if now
                    .duration_since(modified)
                    .is_ok_and(|age| age > STALE_TMP)
                {
                    let _ = std::fs::remove_file(&path);
                }
                continue;
            }
            if !meta.is_file() || !name.ends_with(".bin") {
                continue;
            }
            total = total.saturating_add(meta.len());
            if path != keep {
                entries.push((modified, path, meta.len()));
            }
        }
        entries.sort();
        let mut deleted = Vec::new();
        for (_, path, len) in entries {
            if total <= cap {
                break;
            }
            match std::fs::remove_file(&path) {
                Ok(()) => deleted.push(path),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(_) => continue,
            }
            total -= len;
        }
        deleted
    }

    /// The cached value of `kind` under `key`, or `build()`'s, stored for later processes.
    /// An entry that does not decode is rebuilt and overwritten.
    pub fn get_or_build<T, E>(
        &self,
        kind: &str,
        key: &[u8],
        build: impl FnOnce() -> Result<T, E>,
        encode: impl FnOnce(&T) -> Vec<u8>,
        decode: impl FnOnce(&[u8]) -> Option<T>,
    ) -> Result<T, E> {
        if let Some(v) = self.decode_stored(kind, key, decode) {
            return Ok(v);
        }
        let v = build()?;
        // A cache that cannot be written costs a rebuild next time, not the run.
        let _ = self.put(kind, key, &encode(&v));
        Ok(v)
    }
}

/// [`DiskCache::get_or_build`] on the process's cache, or `build()` when it is off.
pub fn cached<T, E>(
    kind: &str,
    key: &[u8],
    build: impl FnOnce() -> Result<T, E>,
    encode: impl FnOnce(&T) -> Vec<u8>,
    decode: impl FnOnce(&[u8]) -> Option<T>,
) -> Result<T, E> {
    match DiskCache::global() {
        Some(c) => c.get_or_build(kind, key, build, encode, decode),
        None => build(),
    }
}

fn encode_entry(key: &[u8], payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + key.len() + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(key.len() as u64).to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&hash64(0, payload).to_le_bytes());
    out.extend_from_slice(key);
    out.extend_from_slice(payload);
    out
}

/// The payload of a whole entry written under `key`; `None` for anything else.
fn decode_entry<'a>(bytes: &'a [u8], key: &[u8]) -> Option<&'a [u8]> {
    let mut r = Reader::new(bytes);
    if r.take(8)? != MAGIC || r.u32()? != FORMAT_VERSION {
        return None;
    }
    let key_len = usize::try_from(r.u64()?).ok()?;
    let payload_len = usize::try_from(r.u64()?).ok()?;
    let checksum = r.u64()?;
    if r.remaining() != key_len.checked_add(payload_len)? || r.take(key_len)? != key {
        return None;
    }
    let payload = r.take(payload_len)?;
    (hash64(0, payload) == checksum).then_some(payload)
}

/// Little-endian writer for payloads.
#[derive(Default)]
pub struct Writer(pub Vec<u8>);

impl Writer {
    pub fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_bits().to_le_bytes());
    }
    pub fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for x in v {
            self.f64(*x);
        }
    }
    pub fn f32s(&mut self, v: &[f32]) {
        self.u64(v.len() as u64);
        for x in v {
            self.0.extend_from_slice(&x.to_bits().to_le_bytes());
        }
    }
    pub fn str(&mut self, s: &str) {
        self.bytes(s.as_bytes());
    }
    pub fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }
}

/// Little-endian reader for payloads: every read checks the length (`None` past the end).
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Reader<'a> {
        Reader { bytes, at: 0 }
    }
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }
    pub fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.bytes.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    pub fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    pub fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    /// A count of items of at least `item_bytes` each, refused if the rest cannot hold them.
    pub fn len(&mut self, item_bytes: usize) -> Option<usize> {
        let n = usize::try_from(self.u64()?).ok()?;
        (n.checked_mul(item_bytes.max(1))? <= self.remaining()).then_some(n)
    }
    pub fn f64(&mut self) -> Option<f64> {
        Some(f64::from_bits(self.u64()?))
    }
    pub fn f64s(&mut self) -> Option<Vec<f64>> {
        let n = self.len(8)?;
        // Whole words from one slice: no length check per value (fields run to millions).
        let words = self.take(n.checked_mul(8)?)?.chunks_exact(8);
        Some(
            words
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                .collect(),
        )
    }
    pub fn f32s(&mut self) -> Option<Vec<f32>> {
        let n = self.len(4)?;
        let words = self.take(n.checked_mul(4)?)?.chunks_exact(4);
        Some(
            words
                .map(|c| f32::from_le_bytes(c.try_into().unwrap_or([0; 4])))
                .collect(),
        )
    }
    pub fn bytes(&mut self) -> Option<&'a [u8]> {
        let n = self.len(1)?;
        self.take(n)
    }
    pub fn str(&mut self) -> Option<String> {
        String::from_utf8(self.bytes()?.to_vec()).ok()
    }
    pub fn is_empty(&self) -> bool {
        self.remaining() == 0
    }
}

/// Longest string parameter taken for a file name.
const MAX_NAME: usize = 4096;

/// Key text of everything a run of `scenario` reads: the texts of its files (scenario,
/// world, robot, sensor file), the parsed world (a generated world's parameters included),
/// robot and WiFi scanner, and every file a localizer's string parameter names beside the
/// scenario (a survey, a training scenario, a saved graph or error map), a scenario among
/// them with its own inputs, recursively. Paths are left out: a moved checkout still hits.
pub fn scenario_inputs(scenario: &Scenario) -> Vec<u8> {
    let mut out = Vec::new();
    let mut seen = BTreeSet::new();
    add_scenario(scenario, &mut out, &mut seen);
    out
}

/// The key of an entry learnt from a scenario's world: `label` (the kind and its version),
/// the caller's in-process key, and [`world_inputs`]; not the scenario's own text, so a run
/// with another route, seed or filter parameter reuses the entry.
pub fn world_derived_key(label: &str, memory_key: &str, scenario: &Scenario) -> Vec<u8> {
    let mut key = format!("{label}\n{memory_key}\n").into_bytes();
    key.extend(world_inputs(scenario));
    key
}

/// Key text of the world a scenario runs in and what it carries: the texts of its files but
/// the scenario file (world, robot, sensor file) and the parsed world (a generated world's
/// parameters included), robot and WiFi scanner. Maps trained by rendering the world key on
/// this and their own parameters, so editing another part of the scenario still hits.
pub fn world_inputs(scenario: &Scenario) -> Vec<u8> {
    let mut out = Vec::new();
    for f in scenario.input_files.iter().filter(|f| **f != scenario.file) {
        add_file(f, &mut out);
    }
    let mut w = Writer(out);
    w.str(&serde_json::to_string(&scenario.world).unwrap_or_default());
    w.str(&format!("{:?}", scenario.robot));
    w.str(&format!("{:?}", scenario.wifi));
    w.str(&format!("{:?}", scenario.world_params));
    w.0
}

fn add_file(path: &Path, out: &mut Vec<u8>) {
    let mut w = Writer(std::mem::take(out));
    match std::fs::read(path) {
        Ok(b) => {
            w.str("file");
            w.bytes(&b);
        }
        Err(_) => w.str("unreadable file"),
    }
    *out = w.0;
}

fn add_scenario(scenario: &Scenario, out: &mut Vec<u8>, seen: &mut BTreeSet<PathBuf>) {
    for f in &scenario.input_files {
        add_file(f, out);
    }
    let mut w = Writer(std::mem::take(out));
    w.str(&serde_json::to_string(&scenario.world).unwrap_or_default());
    w.str(&format!("{:?}", scenario.robot));
    w.str(&format!("{:?}", scenario.wifi));
    w.str(&format!("{:?}", scenario.world_params));
    *out = w.0;
    let dir = scenario.file.parent().unwrap_or(Path::new("."));
    for spec in &scenario.localizers {
        for s in strings(&toml::Value::Table(spec.params.clone())) {
            if s.is_empty() || s.len() > MAX_NAME || s.contains('\0') {
                continue;
            }
            let p = dir.join(s);
            if !p.is_file() {
                continue;
            }
            add_file(&p, out);
            let canon = p.canonicalize().unwrap_or(p.clone());
            if p.extension().is_some_and(|e| e == "toml") && seen.insert(canon) {
                if let Ok(sub) = Scenario::load(&p) {
                    add_scenario(&sub, out, seen);
                }
            }
        }
    }
}

/// Every string in `v` (tables and arrays searched).
fn strings(v: &toml::Value) -> Vec<&str> {
    match v {
        toml::Value::String(s) => vec![s.as_str()],
        toml::Value::Array(a) => a.iter().flat_map(strings).collect(),
        toml::Value::Table(t) => t.values().flat_map(strings).collect(),
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!(
            "atrium-disk-cache-{tag}-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos())
        ));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn round_trip_and_key_mismatch_is_a_miss() {
        let dir = temp_dir("round");
        let c = DiskCache::at(&dir);
        assert_eq!(c.get("t", b"key"), None);
        c.put("t", b"key", b"payload bytes").unwrap();
        assert_eq!(c.get("t", b"key").unwrap(), b"payload bytes");
        assert_eq!(c.get("t", b"other key"), None);
        assert_eq!(c.get("u", b"key"), None);
        // No temporary file is left behind.
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(names.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Issue 45: a FIFO where an entry belongs hung the run (reading it blocks for a writer
    /// that never comes). It is a miss, and the entry written over it reads back. (On the old
    /// code this test does not fail; it hangs.)
    #[cfg(unix)]
    #[test]
    fn a_fifo_in_place_of_an_entry_is_a_miss_and_is_replaced() {
        let dir = temp_dir("fifo");
        let c = DiskCache::at(&dir);
        let path = c.entry_path("t", b"k");
        let made = std::process::Command::new("mkfifo")
            .arg(&path)
            .status()
            .unwrap();
        assert!(made.success());
        assert_eq!(c.get("t", b"k"), None);
        c.put("t", b"k", b"payload").unwrap();
        assert!(std::fs::metadata(&path).unwrap().is_file());
        assert_eq!(c.get("t", b"k").unwrap(), b"payload");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn corrupt_or_truncated_entries_are_rebuilt() {
        let dir = temp_dir("corrupt");
        let c = DiskCache::at(&dir);
        let payload: Vec<u8> = (0..1000u32).flat_map(|i| i.to_le_bytes()).collect();
        c.put("t", b"k", &payload).unwrap();
        let path = c.entry_path("t", b"k");
        let good = std::fs::read(&path).unwrap();
        // A flipped payload bit, a truncation, an appended byte, an empty file.
        let mut flipped = good.clone();
        *flipped.last_mut().unwrap() ^= 1;
        let mut longer = good.clone();
        longer.push(0);
        for bad in [flipped, good[..good.len() - 3].to_vec(), longer, Vec::new()] {
            std::fs::write(&path, &bad).unwrap();
            assert_eq!(c.get("t", b"k"), None);
            let mut built = 0;
            let v: Result<Vec<u8>, ()> = c.get_or_build(
                "t",
                b"k",
                || {
                    built += 1;
                    Ok(payload.clone())
                },
                |v| v.clone(),
                |b| Some(b.to_vec()),
            );
            assert_eq!(v.unwrap(), payload);
            assert_eq!(built, 1);
            assert_eq!(std::fs::read(&path).unwrap(), good, "rewritten whole");
        }
        // A payload that does not decode is rebuilt too.
        let mut built = 0;
        let v: Result<u8, ()> = c.get_or_build(
            "t",
            b"k",
            || {
                built += 1;
                Ok(7)
            },
            |v| vec![*v],
            |b| (b.len() == 1).then(|| b[0]),
        );
        assert_eq!((v.unwrap(), built), (7, 1));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_cap_evicts_least_recently_used_entries_and_keeps_the_newest() {
        let dir = temp_dir("evict");
        let uncapped = DiskCache::with_cap(&dir, None);
        let kb = vec![7u8; 1000];
        let t0 = std::time::SystemTime::now() - std::time::Duration::from_secs(7200);
        // Five entries of about 1.1 kB, written in order a..e, each a second after the last.
        for (i, k) in ["a", "b", "c", "d", "e"].iter().enumerate() {
            uncapped.put("t", k.as_bytes(), &kb).unwrap();
            let f = std::fs::File::options()
                .write(true)
                .open(uncapped.entry_path("t", k.as_bytes()))
                .unwrap();
            f.set_modified(t0 + std::time::Duration::from_secs(i as u64))
                .unwrap();
        }
        let size = std::fs::metadata(uncapped.entry_path("t", b"a"))
            .unwrap()
            .len();
        // A hit makes `a` the most recently used.
        assert!(uncapped.get("t", b"a").is_some());
        // A stale temporary file and an unrelated file.
        let tmp = dir.join(".t-x.bin.1-2-3.tmp");
        std::fs::write(&tmp, b"torn").unwrap();
        std::fs::File::options()
            .write(true)
            .open(&tmp)
            .unwrap()
            .set_modified(t0)
            .unwrap();
        std::fs::write(dir.join("notes.txt"), vec![0u8; 100_000]).unwrap();
        // Room for three entries: writing `f` evicts b, c and d (the least recently used).
        let capped = DiskCache::with_cap(&dir, Some(3 * size + size / 2));
        capped.put("t", b"f", &kb).unwrap();
        let present = |k: &str| capped.entry_path("t", k.as_bytes()).exists();
        assert_eq!(
            ["a", "b", "c", "d", "e", "f"].map(present),
            [true, false, false, false, true, true]
        );
        assert!(!tmp.exists(), "a stale temporary file is removed");
        assert!(
            dir.join("notes.txt").exists(),
            "only the cache's files are touched"
        );
        // An entry larger than the cap is still kept: it is the one just written.
        let tiny = DiskCache::with_cap(&dir, Some(1));
        tiny.put("t", b"g", &kb).unwrap();
        assert!(tiny.get("t", b"g").is_some());
        assert!(!present("a") && !present("e") && !present("f"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_cap_is_megabytes_or_none() {
        assert_eq!(parse_max_mb(None), Ok(Some(DEFAULT_MAX_MB << 20)));
        assert_eq!(parse_max_mb(Some(" ")), Ok(Some(DEFAULT_MAX_MB << 20)));
        assert_eq!(parse_max_mb(Some("64")), Ok(Some(64 << 20)));
        assert_eq!(parse_max_mb(Some("0")), Ok(Some(0)));
        assert_eq!(parse_max_mb(Some("none")), Ok(None));
        for bad in ["-1", "1.5", "lots", "99999999999999999999"] {
            let e = parse_max_mb(Some(bad)).unwrap_err();
            assert!(e.contains(MAX_MB_VAR) && e.contains(bad), "{e}");
        }
    }

    #[test]
    fn concurrent_writers_leave_one_whole_entry() {
        let dir = temp_dir("concurrent");
        let payload: Vec<u8> = (0..200_000u32).map(|i| (i % 251) as u8).collect();
        std::thread::scope(|s| {
            for _ in 0..8 {
                s.spawn(|| {
                    let c = DiskCache::at(&dir);
                    for _ in 0..5 {
                        c.put("t", b"shared", &payload).unwrap();
                        // Whatever a reader sees is whole.
                        if let Some(p) = c.get("t", b"shared") {
                            assert_eq!(p, payload);
                        }
                    }
                });
            }
        });
        assert_eq!(DiskCache::at(&dir).get("t", b"shared").unwrap(), payload);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reader_refuses_lengths_past_the_end() {
        let mut w = Writer::default();
        w.u64(u64::MAX);
        assert_eq!(Reader::new(&w.0).f64s(), None);
        let mut w = Writer::default();
        w.f64s(&[1.0, -0.0, f64::NAN]);
        let back = Reader::new(&w.0).f64s().unwrap();
        assert_eq!(back[0], 1.0);
        assert!(back[1].is_sign_negative() && back[2].is_nan());
    }

    #[test]
    fn inputs_include_named_files_recursively() {
        let path = crate::bundled_scenarios_dir().join("tour.toml");
        let s = Scenario::load(&path).unwrap();
        let inputs = scenario_inputs(&s);
        let survey =
            std::fs::read(crate::bundled_scenarios_dir().join("wifi_survey.toml")).unwrap();
        let has = |needle: &[u8]| inputs.windows(needle.len()).any(|w| w == needle);
        assert!(has(&survey), "the survey the wifi localizer names");
        assert!(has(s.text.as_bytes()));
    }
}
