//! The coverage-guided fuzz targets' entry points (`fuzz-targets/`, docs/fuzzing.md), run
//! deterministically in CI: every seed and every input the fuzzer once broke
//! (`fuzz-targets/regressions/TARGET/`) through the same reader calls, then a few hundred
//! byte-level mutations of the seeds (bit flips, overwritten bytes, truncations). Each must
//! give `Ok` or an error naming the file, and no allocation may exceed [`ALLOCATION_CAP`];
//! the ten-minute fuzzing itself is not run here.

use atrium_formats::robot_log::RobotLog;
use atrium_formats::ros_map;
use atrium_formats::ros_msgs::MessageKind;
use proptest::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The largest single allocation allowed in this test binary (one failing aborts it, naming
/// the size): the seeds are a few kilobytes and read in well under a megabyte, while damage
/// that makes a reader trust a length field asks for hundreds of megabytes or more.
const ALLOCATION_CAP: usize = 64 << 20;

struct Capped;

// SAFETY: forwards to the system allocator; refusing (null) is allowed by `GlobalAlloc`.
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOCATION_CAP {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOCATION_CAP {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > ALLOCATION_CAP {
            return std::ptr::null_mut();
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Capped = Capped;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz-targets")
}

/// The files of `seeds/TARGET` and `regressions/TARGET`, sorted.
fn inputs(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    for dir in ["seeds", "regressions"] {
        let Ok(entries) = std::fs::read_dir(root().join(dir).join(target)) else {
            continue;
        };
        for e in entries {
            let p = e.unwrap().path();
            out.push((p.clone(), std::fs::read(&p).unwrap()));
        }
    }
    out.sort();
    out
}

fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("atrium-fuzz-corpus-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    })
}

/// A folder of its own for one input (the tests of this file run in parallel).
fn case_dir(name: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = scratch().join(format!("{name}-{}", N.fetch_add(1, Ordering::Relaxed)));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn names(err: &dyn std::fmt::Display, path: &Path) -> Result<(), String> {
    let text = err.to_string();
    let name = path.file_name().unwrap().to_string_lossy();
    if text.contains(name.as_ref()) {
        Ok(())
    } else {
        Err(format!("the error does not name {name}: {text}"))
    }
}

/// `fuzz_targets/common.rs` `split`.
fn split(data: &[u8]) -> Option<(&[u8], &[u8])> {
    let n = u16::from_le_bytes(data.get(..2)?.try_into().ok()?) as usize;
    let rest = &data[2..];
    (n <= rest.len()).then(|| rest.split_at(n))
}

/// `fuzz_targets/common.rs` `walk_log`.
fn walk_log(path: &Path) -> Result<(), String> {
    let log = match RobotLog::open(path) {
        Ok(l) => l,
        Err(e) => return names(&e, path),
    };
    for t in log.topics().to_vec() {
        let r = match t.kind() {
            Some(MessageKind::LaserScan) => log.scans(&t.name).map(drop),
            Some(MessageKind::Odometry) => log.odometry(&t.name).map(drop),
            Some(MessageKind::PoseStamped | MessageKind::PoseWithCovarianceStamped) => {
                log.poses(&t.name).map(drop)
            }
            Some(MessageKind::TfMessage) => log.transforms(&t.name).map(drop),
            None => Ok(()),
        };
        if let Err(e) = r {
            names(&e, path)?;
        }
    }
    if let Err(e) = log.static_transforms() {
        names(&e, path)?;
    }
    Ok(())
}

fn carmen(data: &[u8]) -> Result<(), String> {
    if data.starts_with(b"#ROSBAG") || data.starts_with(b"\x89MCAP") {
        return Ok(());
    }
    let p = case_dir("carmen").join("log.clf");
    std::fs::write(&p, data).unwrap();
    walk_log(&p)
}

fn ros1(data: &[u8]) -> Result<(), String> {
    const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(data.strip_prefix(MAGIC).unwrap_or(data));
    let p = case_dir("ros1").join("log.bag");
    std::fs::write(&p, bytes).unwrap();
    walk_log(&p)
}

fn rosbag2(data: &[u8]) -> Result<(), String> {
    let Some((meta, storage)) = split(data) else {
        return Ok(());
    };
    let dir = case_dir("rosbag2").join("bag");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("metadata.yaml"), meta).unwrap();
    std::fs::write(dir.join("bag.db3"), storage).unwrap();
    std::fs::write(dir.join("bag.mcap"), storage).unwrap();
    walk_log(&dir)
}

fn ros_map(data: &[u8]) -> Result<(), String> {
    let Some((yaml, image)) = split(data) else {
        return Ok(());
    };
    let dir = case_dir("ros_map");
    let yaml_path = dir.join("map.yaml");
    std::fs::write(&yaml_path, yaml).unwrap();
    std::fs::write(dir.join("map.pgm"), image).unwrap();
    std::fs::write(dir.join("map.png"), image).unwrap();
    match ros_map::read_map(&yaml_path) {
        Ok(g) if !(g.resolution.is_finite() && g.resolution > 0.0) => {
            Err(format!("resolution {}", g.resolution))
        }
        Ok(g) if g.cells.len() != g.width * g.height => Err("cells do not fill the grid".into()),
        Ok(_) => Ok(()),
        Err(e) if e.to_string().contains("map.") => Ok(()),
        Err(e) => Err(format!("the error names no file: {e}")),
    }
}

fn run_all(target: &str, f: fn(&[u8]) -> Result<(), String>) {
    let all = inputs(target);
    assert!(!all.is_empty(), "no seeds for {target}");
    for (p, data) in all {
        if let Err(e) = f(&data) {
            panic!("{}: {e}", p.display());
        }
    }
}

#[test]
fn seeds_and_regressions_carmen() {
    run_all("carmen", carmen);
}

#[test]
fn seeds_and_regressions_ros1() {
    run_all("ros1", ros1);
}

#[test]
fn seeds_and_regressions_rosbag2() {
    run_all("rosbag2", rosbag2);
}

#[test]
fn seeds_and_regressions_ros_map() {
    run_all("ros_map", ros_map);
}

/// The seeds the mutations start from are read whole, every topic of every log.
#[test]
fn the_seeds_are_read_whole() {
    let read_all = |path: &Path| {
        let log = RobotLog::open(path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!log.topics().is_empty());
        for t in log.topics().to_vec() {
            match t.kind() {
                Some(MessageKind::LaserScan) => assert!(!log.scans(&t.name).unwrap().is_empty()),
                Some(MessageKind::Odometry) => assert!(!log.odometry(&t.name).unwrap().is_empty()),
                Some(MessageKind::TfMessage) => drop(log.transforms(&t.name).unwrap()),
                _ => {}
            }
        }
    };
    for data in seeds("carmen") {
        let file = case_dir("whole").join("log.clf");
        std::fs::write(&file, &data).unwrap();
        read_all(&file);
    }
    for data in seeds("ros1") {
        let file = case_dir("whole").join("log.bag");
        std::fs::write(&file, &data).unwrap();
        read_all(&file);
    }
    for data in seeds("rosbag2") {
        let (meta, storage) = split(&data).unwrap();
        let dir = case_dir("whole");
        std::fs::write(dir.join("metadata.yaml"), meta).unwrap();
        std::fs::write(dir.join("bag.db3"), storage).unwrap();
        std::fs::write(dir.join("bag.mcap"), storage).unwrap();
        read_all(&dir);
    }
    for data in seeds("ros_map") {
        let (yaml, image) = split(&data).unwrap();
        let dir = case_dir("whole");
        std::fs::write(dir.join("map.yaml"), yaml).unwrap();
        std::fs::write(dir.join("map.pgm"), image).unwrap();
        std::fs::write(dir.join("map.png"), image).unwrap();
        let g = ros_map::read_map(&dir.join("map.yaml")).unwrap();
        assert_eq!((g.width, g.height), (24, 16));
    }
}

#[derive(Debug, Clone)]
enum Damage {
    Flip(prop::sample::Index, u8),
    Set(prop::sample::Index, u8),
    Truncate(prop::sample::Index),
    Cut(prop::sample::Index, usize),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (any::<prop::sample::Index>(), 0u8..8).prop_map(|(i, b)| Damage::Flip(i, b)),
        (
            any::<prop::sample::Index>(),
            prop::sample::select(vec![0u8, 0xff, 0x7f, 0x80, b'\n', b' '])
        )
            .prop_map(|(i, v)| Damage::Set(i, v)),
        any::<prop::sample::Index>().prop_map(Damage::Truncate),
        (any::<prop::sample::Index>(), 1usize..64).prop_map(|(i, n)| Damage::Cut(i, n)),
    ]
}

fn apply(mut b: Vec<u8>, damage: &[Damage]) -> Vec<u8> {
    for d in damage {
        if b.is_empty() {
            break;
        }
        match d {
            Damage::Flip(i, bit) => {
                let at = i.index(b.len());
                b[at] ^= 1 << bit;
            }
            Damage::Set(i, v) => {
                let at = i.index(b.len());
                b[at] = *v;
            }
            Damage::Truncate(i) => b.truncate(i.index(b.len())),
            Damage::Cut(i, n) => {
                let at = i.index(b.len());
                let end = (at + n).min(b.len());
                b.drain(at..end);
            }
        }
    }
    b
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("FUZZ_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(96),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn seeds(target: &str) -> Vec<Vec<u8>> {
    inputs(target)
        .into_iter()
        .filter(|(p, _)| p.to_string_lossy().contains("/seeds/"))
        .map(|(_, d)| d)
        .collect()
}

fn mutated(target: &'static str) -> impl Strategy<Value = Vec<u8>> {
    let all = seeds(target);
    (
        prop::sample::select(all),
        prop::collection::vec(damage(), 1..5),
    )
        .prop_map(|(seed, d)| apply(seed, &d))
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn damaged_carmen(data in mutated("carmen")) {
        prop_assert!(carmen(&data).is_ok(), "{:?}", carmen(&data));
    }

    #[test]
    fn damaged_ros1(data in mutated("ros1")) {
        let r = ros1(&data);
        prop_assert!(r.is_ok(), "{:?}", r);
    }

    #[test]
    fn damaged_rosbag2(data in mutated("rosbag2")) {
        let r = rosbag2(&data);
        prop_assert!(r.is_ok(), "{:?}", r);
    }

    #[test]
    fn damaged_ros_map(data in mutated("ros_map")) {
        let r = ros_map(&data);
        prop_assert!(r.is_ok(), "{:?}", r);
    }
}
