//! Property-based fuzzing of recordings (issue 15): a small real recording (one second of a
//! laser, WiFi and odometry run, recorded once per test process) damaged by bit flips,
//! truncations and overwritten byte ranges must open and replay to `Ok` or to a clean error
//! that names the file: never a panic, never an absurd allocation (the allocator of this test
//! binary refuses any single allocation above [`ALLOCATION_CAP`], which aborts the process
//! with the size it asked for).
//!
//! Two files are damaged: the recording as `record` writes it (zstd chunks, every CRC set),
//! where whatever opens must hold exactly the original messages (no silent garbage), and the
//! same messages rewritten uncompressed without any CRC, where damage reaches the message
//! decoders, the metadata and the localizers. Inputs that once failed are kept below as
//! explicit regression tests.

#[allow(dead_code)] // this test uses only `tmpdir`
mod common;

use atrium_formats::mcap::container::Messages;
use atrium_recordings::{self as dataset, replay::Recording, ReplayOptions};
use atrium_scenarios::{LocalizerRegistry, RunOptions, Scenario};
use proptest::prelude::*;
use proptest::sample::select;
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::OnceLock;

/// The largest single allocation allowed in this test binary. The recordings are about
/// 50 KB and 90 KB, and the largest allocation a clean replay of them makes is about 340 KB;
/// 64 MiB is far above anything legitimate and far below what a damaged length field
/// claims (gigabytes to exabytes).
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

/// One second on the campus: laser MCL and dead reckoning, with the Pioneer's laser, WiFi
/// and odometry. Few particles and a coarse map keep a replay to a few milliseconds.
const SCENARIO: &str = r#"
name = "fuzz"
world = "../worlds/campus.toml"
robot = "../robots/urdf/pioneer3dx.urdf"
seed = 5
duration_s = 1.0
[start]
pose = [2.0, 20.0, 0.0]
[route]
waypoints = [[8.0, 20.0]]
[map]
resolution = 0.25
[initial_belief]
mode = "tracking"
sigma = [0.1, 0.1, 0.05]
[[localizers]]
name = "mcl"
kind = "mcl"
min_particles = 50
max_particles = 100
grid_resolution = 0.25
[[localizers]]
name = "odometry"
kind = "dead_reckoning"
"#;

const NAME: &str = "fuzz.mcap";

/// The recording as written, and the same rewritten without compression and CRCs.
fn recordings() -> &'static (Vec<u8>, Vec<u8>) {
    static FILES: OnceLock<(Vec<u8>, Vec<u8>)> = OnceLock::new();
    FILES.get_or_init(|| {
        // Beside the bundled scenarios, so the recorded scenario's relative paths resolve.
        let file = atrium_scenarios::bundled_scenarios_dir().join("fuzz.toml");
        let scenario = Scenario::from_toml_str(SCENARIO, &file).unwrap();
        let dir = common::tmpdir("fuzz_mcap");
        let out = dir.join(NAME);
        dataset::record(
            &LocalizerRegistry::with_builtins(),
            &scenario,
            &out,
            RunOptions::default(),
        )
        .unwrap();
        let recorded = std::fs::read(&out).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let plain = without_crcs(&recorded);
        (recorded, plain)
    })
}

/// `bytes` rewritten with uncompressed chunks and no CRCs at all, so that damage is not
/// caught by the container and reaches everything behind it.
fn without_crcs(bytes: &[u8]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .calculate_chunk_crcs(false)
        .calculate_data_section_crc(false)
        .calculate_summary_section_crc(false)
        .chunk_size(Some(4096))
        .create(&mut out)
        .unwrap();
    for r in mcap::read::LinearReader::new(bytes).unwrap() {
        if let mcap::records::Record::Metadata(m) = r.unwrap() {
            w.write_metadata(&m).unwrap();
        }
    }
    for m in mcap::MessageStream::new(bytes).unwrap() {
        w.write(&m.unwrap()).unwrap();
    }
    w.finish().unwrap();
    drop(w);
    out.into_inner()
}

/// The messages of a file that opened: (topic, log time, sequence, bytes).
fn messages(bytes: &[u8]) -> Vec<(String, u64, u32, Vec<u8>)> {
    mcap::MessageStream::new(bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (
                m.channel.topic.clone(),
                m.log_time,
                m.sequence,
                m.data.to_vec(),
            )
        })
        .collect()
}

/// A change to a file; positions are taken modulo the file's length at the time.
#[derive(Debug, Clone)]
enum Mutation {
    Flip(usize, u8),
    Truncate(usize),
    Overwrite(usize, Vec<u8>),
    Fill(usize, usize, u8),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, b)),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        2 => (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, v)| Mutation::Overwrite(i, v)),
        2 => (any::<usize>(), 1usize..64, select(vec![0u8, 0xff, 0x7f, 0x80]))
            .prop_map(|(i, n, v)| Mutation::Fill(i, n, v)),
    ]
}

fn apply(bytes: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for m in mutations {
        if b.is_empty() {
            break;
        }
        match m {
            Mutation::Flip(i, bit) => {
                let at = i % b.len();
                b[at] ^= 1 << bit;
            }
            Mutation::Truncate(i) => b.truncate(i % b.len()),
            Mutation::Overwrite(i, v) => {
                let at = i % b.len();
                let n = v.len().min(b.len() - at);
                b[at..at + n].copy_from_slice(&v[..n]);
            }
            Mutation::Fill(i, n, v) => {
                let at = i % b.len();
                let end = (at + n).min(b.len());
                b[at..end].fill(*v);
            }
        }
    }
    b
}

/// Opens and, if that works, replays `bytes`; a panic fails the property (proptest catches
/// it), an error must name the file. Returns whether the file opened.
fn open_and_replay(bytes: Vec<u8>) -> bool {
    let path = Path::new(NAME);
    let named = |e: &dyn std::fmt::Display| {
        let e = e.to_string();
        assert!(e.contains(NAME) || e.contains("localizer"), "{e}");
    };
    // The message reader for foreign files goes through the same checks.
    for m in Messages::new(&bytes, path).into_iter().flatten() {
        if let Err(e) = m {
            named(&e);
        }
    }
    let rec = match Recording::from_bytes(bytes, path) {
        Ok(r) => r,
        Err(e) => {
            named(&e);
            return false;
        }
    };
    if let Err(e) = dataset::replay::replay_recording(&rec, ReplayOptions::default()) {
        // Damaged metadata may name a scenario or world that does not load: those errors
        // name the recording or the file that failed to load.
        let e = e.to_string();
        assert!(!e.is_empty());
    }
    true
}

fn config() -> ProptestConfig {
    ProptestConfig {
        // About 1 ms per case for the recording with CRCs (almost every case is refused
        // while opening) and 3 ms for the one without (most replay): about 1 s in all.
        cases: 256,
        // Failures are kept as explicit tests below, not in a regressions file.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn a_damaged_recording_is_refused_or_holds_exactly_its_messages(
        mutations in prop::collection::vec(mutation(), 1..4)
    ) {
        let (recorded, _) = recordings();
        let damaged = apply(recorded, &mutations);
        let opened = Recording::from_bytes(damaged.clone(), Path::new(NAME));
        match opened {
            Err(e) => prop_assert!(e.to_string().starts_with(NAME), "{}", e),
            // Only a change no CRC covers can open: an overwrite with the same bytes, or a
            // CRC cleared to 0 ("not computed"). The messages are then the original ones.
            Ok(_) => prop_assert!(messages(&damaged) == messages(recorded)),
        }
    }

    #[test]
    fn a_damaged_recording_without_crcs_replays_or_fails_cleanly(
        mutations in prop::collection::vec(mutation(), 1..4)
    ) {
        let (_, plain) = recordings();
        open_and_replay(apply(plain, &mutations));
    }
}

#[test]
fn both_recordings_replay_as_recorded() {
    let (recorded, plain) = recordings();
    assert!(recorded.len() < 64 << 10, "{} bytes", recorded.len());
    assert_eq!(messages(recorded), messages(plain));
    for bytes in [recorded, plain] {
        let rec = Recording::from_bytes(bytes.clone(), Path::new(NAME)).unwrap();
        let r = dataset::replay::replay_recording(&rec, ReplayOptions::default()).unwrap();
        assert_eq!(r.run.localizers.len(), 2);
        assert_eq!(r.run.ground_truth.len(), 10);
    }
}

/// Offset of the first chunk record of `bytes`.
fn first_chunk(bytes: &[u8]) -> usize {
    let mut at = mcap::MAGIC.len();
    while bytes[at] != 0x06 {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
        at += 9 + len as usize;
    }
    at
}

/// Inputs the fuzzing above found (or that were found by hand while writing it), with the
/// error each must give.
#[test]
fn regressions() {
    let (recorded, plain) = recordings();
    let half = recorded.len() / 2;
    // The chunk's compression string: opcode and length (9), times (16), uncompressed size
    // (8) and CRC (4) come before its length prefix.
    let compression = |b: &[u8]| first_chunk(b) + 9 + 16 + 8 + 4;
    let cases: Vec<(&Vec<u8>, Vec<Mutation>, &str)> = vec![
        (
            recorded,
            vec![Mutation::Truncate(half)],
            "truncated MCAP file",
        ),
        (plain, vec![Mutation::Truncate(half)], "truncated MCAP file"),
        // Found by the fuzzing: a string length of 0x7f7f7f7f made the `mcap` crate's parser
        // reserve 2 GB before reading the string (an abort).
        (
            plain,
            vec![Mutation::Fill(compression(plain), 4, 0x7f)],
            "its compression of 2139062143 bytes at byte 28 runs past the record's end",
        ),
        (
            recorded,
            vec![Mutation::Fill(compression(recorded), 4, 0x7f)],
            "its compression of 2139062143 bytes at byte 28 runs past the record's end",
        ),
    ];
    for (bytes, mutations, expect) in cases {
        let damaged = apply(bytes, &mutations);
        let e = Recording::from_bytes(damaged.clone(), Path::new(NAME))
            .err()
            .unwrap_or_else(|| panic!("{mutations:?} opened"));
        assert!(e.to_string().contains(expect), "{mutations:?}: {e}");
        open_and_replay(damaged);
    }
}
