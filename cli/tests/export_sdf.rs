//! `atrium export world WORLD --format sdf -o FILE` as a user's script sees it: the file, the
//! exit codes and the messages. What the SDF contains is checked in
//! `worlds/tests/sdf_export.rs`.

mod common;

use common::{atrium, tmpdir};
use std::path::{Path, PathBuf};
use std::process::Output;

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn export(world: &Path, format: &str, out: &Path) -> Output {
    atrium(&[
        "export",
        "world",
        world.to_str().unwrap(),
        "--format",
        format,
        "-o",
        out.to_str().unwrap(),
    ])
}

#[test]
fn writes_the_worlds_sdf_and_nothing_else() {
    let dir = tmpdir("export-sdf");
    let world = repo("worlds/campus.toml");
    let out = dir.join("campus.sdf");
    let o = export(&world, "sdf", &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("wrote"), "{}", stderr(&o));
    let expected = atrium_formats::sdf::to_sdf(&atrium_worlds::World::load(&world).unwrap());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), expected);
    assert!(expected.contains("<sdf version=\"1.9\">"));
    // Written under a temporary name and renamed: only the result is left.
    let files: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(files.len(), 1, "{files:?}");
    // Exporting again replaces the file with the same bytes.
    let o = export(&world, "sdf", &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), expected);
}

#[test]
fn bad_input_exits_2_with_a_message_and_writes_nothing() {
    let dir = tmpdir("export-sdf-bad");
    // -o naming the world itself: refused, the world untouched.
    let world = dir.join("w.toml");
    std::fs::copy(repo("worlds/lab.toml"), &world).unwrap();
    let before = std::fs::read(&world).unwrap();
    let o = export(&world, "sdf", &world);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is the input file"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&world).unwrap(), before);

    // A world with a wall of negative thickness: the message names file and field.
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "name = \"b\"\nceiling_height = 3.0\n[materials.c]\nlaser = \"opaque\"\n\
         [[walls]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nthickness = -0.1\nmaterial = \"c\"\n",
    )
    .unwrap();
    let out = dir.join("bad.sdf");
    let o = export(&bad, "sdf", &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("bad.toml") && e.contains("thickness"), "{e}");
    assert!(!out.exists());

    // A missing world, an unknown format, a missing -o.
    let o = export(&dir.join("none.toml"), "sdf", &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("none.toml"), "{}", stderr(&o));
    let o = export(&world, "urdf", &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("sdf"), "{}", stderr(&o));
    let o = atrium(&[
        "export",
        "world",
        world.to_str().unwrap(),
        "--format",
        "sdf",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.exists());

    // -o naming a folder.
    let o = export(&world, "sdf", &dir);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is a folder"), "{}", stderr(&o));
}
