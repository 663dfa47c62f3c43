//! `atrium generate world GENERATOR.toml [--set KEY=VALUE ...] -o WORLD.toml` as a user's
//! script sees it: the file, its round trip through the loader, the exit codes and messages.
//! What the generator makes is checked in `worlds/tests/generate.rs`.

mod common;

use atrium_worlds::{GeneratorFile, GeneratorRegistry, World};
use common::{atrium, tmpdir};
use std::path::{Path, PathBuf};
use std::process::Output;

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn generate(generator: &Path, sets: &[&str], out: &Path) -> Output {
    let mut args = vec!["generate", "world", generator.to_str().unwrap()];
    for s in sets {
        args.extend(["--set", s]);
    }
    args.extend(["-o", out.to_str().unwrap()]);
    atrium(&args)
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn round_trip_writes_the_explicit_world_the_loader_reads_back() {
    let dir = tmpdir("generate-round-trip");
    let gen = repo("worlds/office_atrium_gen.toml");
    let out = dir.join("office.toml");
    let o = generate(
        &gen,
        &["seed=4", "glass_fraction=0.5", "name=office4"],
        &out,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("wrote"), "{}", stderr(&o));
    // Only the output: the temporary name was renamed away.
    assert_eq!(files_in(&dir), vec!["office.toml"]);
    let text = std::fs::read_to_string(&out).unwrap();
    // Exactly what the library makes of the same file and overrides.
    let mut g = GeneratorFile::load(&gen).unwrap();
    for s in ["seed=4", "glass_fraction=0.5", "name=office4"] {
        g.set_arg(s).unwrap();
    }
    let (expected, generated) = g
        .generate_with_text(&GeneratorRegistry::with_builtins())
        .unwrap();
    assert_eq!(text, expected);
    // The written file is an explicit world (no `generator` key) and loads to the same world.
    assert!(!atrium_worlds::generate::is_generator_text(&text));
    let loaded = World::load(&out).unwrap();
    assert_eq!(loaded, generated);
    assert_eq!(loaded.name, "office4");
    // The CLI's own readers take it too.
    let o = atrium(&["inspect", "world", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Same input, same bytes; another seed, another world.
    let again = dir.join("again.toml");
    let o = generate(
        &gen,
        &["seed=4", "glass_fraction=0.5", "name=office4"],
        &again,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read(&again).unwrap(), text.as_bytes());
    let other = dir.join("other.toml");
    let o = generate(
        &gen,
        &["seed=5", "glass_fraction=0.5", "name=office4"],
        &other,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_ne!(std::fs::read(&other).unwrap(), text.as_bytes());
    // Into a folder that does not exist yet.
    let nested = dir.join("a/b/w.toml");
    let o = generate(&gen, &[], &nested);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    World::load(&nested).unwrap();
}

#[test]
fn bad_parameters_exit_2_naming_the_parameter_and_write_nothing() {
    let dir = tmpdir("generate-bad");
    let gen = repo("worlds/office_atrium_gen.toml");
    let out = dir.join("w.toml");
    let cases: &[(&[&str], &str)] = &[
        (
            &["atrium_width=40"],
            "atrium_width: 40 m is wider than the floor (floor_width = 20 m) (from --set)",
        ),
        (
            &["corridor_width=-2"],
            "corridor_width: must be > 0, got -2",
        ),
        (
            &["glass_fraction=1.2"],
            "glass_fraction: must be within [0, 1], got 1.2",
        ),
        (
            &["glass_fraction=nan"],
            "glass_fraction: must be a finite number, got NaN",
        ),
        (
            &["clutter_density=500"],
            "clutter_density: 500 boxes per 100 m²",
        ),
        (
            &["atrium_widht=10"],
            "atrium_widht: unknown parameter of generator \"office_atrium\"",
        ),
        (&["seed=-1"], "seed: "),
        (&["atrium_width"], "--set: expected KEY=VALUE"),
        (
            &["generator=other"],
            "generator: cannot be changed by --set",
        ),
    ];
    for (sets, expected) in cases {
        let o = generate(&gen, sets, &out);
        assert_eq!(o.status.code(), Some(2), "{sets:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(expected), "{sets:?}: {e}");
        assert!(e.contains("office_atrium_gen.toml"), "{sets:?}: {e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    assert!(files_in(&dir).is_empty(), "{:?}", files_in(&dir));

    // A parameter wrong in the file itself is named with its line.
    let bad = dir.join("bad_gen.toml");
    std::fs::write(
        &bad,
        "generator = \"office_atrium\"\nseed = 1\natrium_width = 25.0\n",
    )
    .unwrap();
    let o = generate(&bad, &[], &out);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("bad_gen.toml: atrium_width: 25 m is wider than the floor (floor_width = 20 m) (line 3)"),
        "{}",
        stderr(&o)
    );
    // Not a generator file; an unknown kind; a missing file.
    std::fs::write(&bad, "seed = 1\n").unwrap();
    let o = generate(&bad, &[], &out);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("generator: required"), "{}", stderr(&o));
    std::fs::write(&bad, "generator = \"castle\"\n").unwrap();
    let o = generate(&bad, &[], &out);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown generator \"castle\" (known: office_atrium)"),
        "{}",
        stderr(&o)
    );
    let o = generate(&dir.join("missing.toml"), &[], &out);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("cannot read file"), "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn refuses_to_overwrite_its_input() {
    let dir = tmpdir("generate-overwrite");
    let gen = dir.join("gen.toml");
    std::fs::copy(repo("worlds/office_atrium_gen.toml"), &gen).unwrap();
    let before = std::fs::read(&gen).unwrap();
    let o = generate(&gen, &[], &gen);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("is the input file"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&gen).unwrap(), before);
    // An -o that is a folder is refused before anything is generated.
    let o = generate(&gen, &[], &dir);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("is a folder"), "{}", stderr(&o));
    assert_eq!(files_in(&dir), vec!["gen.toml"]);
}
