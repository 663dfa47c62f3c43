//! The on-disk cache (`atrium_scenarios::disk_cache`) end to end: a run that builds the WiFi
//! graph (an MCL likelihood field, an appearance model, an omnicam or ceiling map) and stores
//! it, a run that reads it back, and a run with `--no-cache` give the same results; a corrupt
//! entry is rebuilt. Each test uses its own cache folder (`ATRIUM_CACHE_DIR` set on the child
//! process only), so no test depends on the cache's state.

#[allow(dead_code)]
mod common;

use common::tmpdir;
use std::path::Path;
use std::process::Command;

/// A short survey (40 s on the campus corridors) and a 20 s scenario learning from it.
fn write_scenarios(dir: &Path) -> std::path::PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let world = root.join("worlds/campus.toml");
    let robot = root.join("robots/urdf/pioneer3dx.urdf");
    let head = format!(
        "world = {:?}\nrobot = {:?}\n",
        world.display().to_string(),
        robot.display().to_string()
    );
    std::fs::write(
        dir.join("survey.toml"),
        format!(
            "name = \"survey\"\n{head}seed = 5\nduration_s = 40.0\n\
             [start]\npose = [2.0, 20.0, 0.0]\n\
             [route]\nwaypoints = [[10.0, 20.0], [10.0, 1.5], [29.0, 1.5]]\n\
             [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n"
        ),
    )
    .unwrap();
    let run = dir.join("run.toml");
    std::fs::write(
        &run,
        format!(
            "name = \"cached_wifi\"\n{head}seed = 7\nduration_s = 20.0\n\
             [start]\npose = [2.0, 20.0, 0.0]\n\
             [route]\nwaypoints = [[10.0, 20.0], [10.0, 5.0]]\n\
             [[localizers]]\nname = \"wifi\"\nkind = \"wifi\"\ntraining = \"survey.toml\"\n\
             particles = 200\n"
        ),
    )
    .unwrap();
    run
}

/// `atrium run SCENARIO --json` with the cache in `cache`, on, with the default cap.
fn run_command(scenario: &Path, cache: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_atrium"));
    c.arg("run")
        .arg(scenario)
        .arg("--json")
        .env("ATRIUM_CACHE_DIR", cache)
        .env_remove("ATRIUM_NO_CACHE")
        .env_remove("ATRIUM_CACHE_MAX_MB");
    c
}

/// `atrium run --json` with the cache in `cache`; the JSON without its timing.
fn run(scenario: &Path, cache: &Path, extra: &[&str]) -> serde_json::Value {
    let out = run_command(scenario, cache)
        .args(extra)
        .output()
        .expect("run atrium");
    assert!(
        out.status.success() || out.status.code() == Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    v.as_object_mut().unwrap().remove("timing");
    v
}

fn entries(cache: &Path) -> Vec<std::path::PathBuf> {
    match std::fs::read_dir(cache) {
        Ok(d) => d.filter_map(|e| e.ok().map(|e| e.path())).collect(),
        Err(_) => Vec::new(),
    }
}

/// A hit does not rewrite `entry` (a write renames a new file over it: another inode), but
/// marks it recently used (its modification time), for the size cap.
fn assert_read_not_rewritten(entry: &Path, before: &std::fs::Metadata) {
    use std::os::unix::fs::MetadataExt;
    let after = std::fs::metadata(entry).unwrap();
    assert_eq!(
        after.ino(),
        before.ino(),
        "a hit does not rewrite the entry"
    );
    assert!(after.modified().unwrap() >= before.modified().unwrap());
}

#[test]
fn a_cache_hit_gives_the_results_of_a_rebuild() {
    let dir = tmpdir("disk-cache");
    let scenario = write_scenarios(&dir);
    let cache = dir.join("cache");

    let uncached = run(&scenario, &cache, &["--no-cache"]);
    assert!(entries(&cache).is_empty(), "--no-cache writes nothing");

    let first = run(&scenario, &cache, &[]);
    let stored = entries(&cache);
    assert_eq!(stored.len(), 1, "one WiFi graph stored: {stored:?}");
    assert!(stored[0]
        .file_name()
        .unwrap()
        .to_string_lossy()
        .starts_with("wifi_graph-"));
    let written = std::fs::metadata(&stored[0]).unwrap();

    let second = run(&scenario, &cache, &[]);
    assert_read_not_rewritten(&stored[0], &written);
    assert_eq!(first, uncached);
    assert_eq!(second, uncached);

    // A truncated entry is detected, rebuilt and rewritten whole.
    let whole = std::fs::read(&stored[0]).unwrap();
    std::fs::write(&stored[0], &whole[..whole.len() / 2]).unwrap();
    let third = run(&scenario, &cache, &[]);
    assert_eq!(third, uncached);
    assert_eq!(std::fs::read(&stored[0]).unwrap(), whole);

    // An edited survey is another key: a second entry, not a stale hit.
    let survey = dir.join("survey.toml");
    let text = std::fs::read_to_string(&survey).unwrap();
    std::fs::write(&survey, text.replace("seed = 5", "seed = 6")).unwrap();
    let edited = run(&scenario, &cache, &[]);
    assert_eq!(entries(&cache).len(), 2);
    assert_ne!(edited, uncached, "another survey, another graph");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_size_cap_keeps_the_newest_entry_and_a_bad_cap_is_refused() {
    let dir = tmpdir("disk-cache-cap");
    let scenario = write_scenarios(&dir);
    let cache = dir.join("cache");
    let uncached = run(&scenario, &cache, &["--no-cache"]);
    let atrium = |cap: &str| {
        run_command(&scenario, &cache)
            .env("ATRIUM_CACHE_MAX_MB", cap)
            .output()
            .expect("run atrium")
    };
    // Two surveys' graphs under a cap of 0 MB: only the one just written stays.
    let out = atrium("0");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let first = entries(&cache);
    assert_eq!(first.len(), 1, "{first:?}");
    let survey = dir.join("survey.toml");
    let text = std::fs::read_to_string(&survey).unwrap();
    std::fs::write(&survey, text.replace("seed = 5", "seed = 6")).unwrap();
    assert!(atrium("0").status.success());
    let second = entries(&cache);
    assert_eq!(second.len(), 1, "{second:?}");
    assert_ne!(first, second, "the older survey's graph was evicted");
    // Evicted or not, a run's results are the build's.
    std::fs::write(&survey, text).unwrap();
    assert_eq!(run(&scenario, &cache, &[]), uncached);
    // A cap that is not a number of megabytes is bad input, refused before anything runs.
    for bad in ["lots", "-5", "1.5"] {
        let out = atrium(bad);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("ATRIUM_CACHE_MAX_MB") && err.contains(bad),
            "{err}"
        );
        assert!(out.stdout.is_empty());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run without the cache, one that stores `kind`'s single entry, one that reads it, and one
/// after the entry was truncated: the same results.
fn same_results_through_the_cache(scenario: &Path, cache: &Path, kind: &str) {
    let uncached = run(scenario, cache, &["--no-cache"]);
    assert!(entries(cache).is_empty(), "--no-cache writes nothing");
    let first = run(scenario, cache, &[]);
    let stored = entries(cache);
    assert_eq!(stored.len(), 1, "one {kind} stored: {stored:?}");
    let name = stored[0].file_name().unwrap().to_string_lossy().to_string();
    assert!(name.starts_with(&format!("{kind}-")), "{name}");
    let written = std::fs::metadata(&stored[0]).unwrap();
    let second = run(scenario, cache, &[]);
    assert_read_not_rewritten(&stored[0], &written);
    assert_eq!(first, uncached);
    assert_eq!(second, uncached);
    let whole = std::fs::read(&stored[0]).unwrap();
    std::fs::write(&stored[0], &whole[..whole.len() / 2]).unwrap();
    assert_eq!(run(scenario, cache, &[]), uncached);
    assert_eq!(
        std::fs::read(&stored[0]).unwrap(),
        whole,
        "rebuilt and rewritten"
    );
}

fn head(world: &str) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    format!(
        "world = {:?}\nrobot = {:?}\n",
        root.join(world).display().to_string(),
        root.join("robots/urdf/pioneer3dx.urdf")
            .display()
            .to_string()
    )
}

#[test]
fn an_mcl_run_reads_its_likelihood_field_from_the_cache() {
    let dir = tmpdir("disk-cache-mcl");
    let scenario = dir.join("mcl.toml");
    std::fs::write(
        &scenario,
        format!(
            "name = \"cached_mcl\"\n{}seed = 3\nduration_s = 8.0\n\
             [start]\npose = [2.0, 20.0, 0.0]\n\
             [route]\nwaypoints = [[10.0, 20.0]]\n\
             [initial_belief]\nmode = \"tracking\"\nsigma = [0.1, 0.1, 0.05]\n\
             [[localizers]]\nname = \"mcl\"\nkind = \"mcl\"\n\
             min_particles = 200\nmax_particles = 500\n",
            head("worlds/campus.toml")
        ),
    )
    .unwrap();
    same_results_through_the_cache(&scenario, &dir.join("cache"), "likelihood_field");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_appearance_run_reads_its_model_from_the_cache() {
    let dir = tmpdir("disk-cache-apf");
    let scenario = dir.join("apf.toml");
    std::fs::write(
        &scenario,
        format!(
            "name = \"cached_apf\"\n{}seed = 3\nduration_s = 6.0\n\
             [start]\npose = [2.6, 2.2, 0.0]\n\
             [route]\nwaypoints = [[4.0, 2.4]]\n\
             [sensors.stereo]\nkind = \"stereo\"\nwidth = 48\nheight = 36\n\
             max_disparity = 10\nwindow_radius = 2\nrate_hz = 2.0\n\
             [[localizers]]\nname = \"apf\"\nkind = \"appearance\"\n\
             training = {{ area = [2.5, 2.0, 4.5, 3.0], step = 0.5, rotation_step_deg = 45.0 }}\n\
             d = 10\npca_samples = 40\nparticles = 300\n",
            head("worlds/lab.toml")
        ),
    )
    .unwrap();
    same_results_through_the_cache(&scenario, &dir.join("cache"), "appearance_model");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The bundled scenario `name` (each of these runs in under a second in release).
fn bundled(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenarios")
        .join(format!("{name}.toml"))
}

#[test]
fn an_omni_run_reads_its_map_from_the_cache() {
    let dir = tmpdir("disk-cache-omni");
    same_results_through_the_cache(&bundled("omni_lab"), &dir.join("cache"), "omni_map");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_ceiling_run_reads_its_map_from_the_cache() {
    let dir = tmpdir("disk-cache-ceiling");
    same_results_through_the_cache(&bundled("ceiling_mcl"), &dir.join("cache"), "ceiling_map");
    std::fs::remove_dir_all(&dir).unwrap();
}
