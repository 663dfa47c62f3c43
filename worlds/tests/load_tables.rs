//! Loading worlds: furniture (`[[boxes]]`) and WiFi (`[[access_points]]`, `[wifi]`) tables,
//! read from TOML text and from the bundled campus, with errors that name the entry.

use atrium_worlds::{RegionKind, World};

/// The bundled campus's furniture stands inside rooms (none in a corridor or the
/// atrium); in rooms SW, SE and NW it is clear of every wall and pillar.
#[test]
fn campus_furniture_stands_clear_inside_the_allowed_rooms() {
    let w = World::campus().unwrap();
    assert!(w.boxes.len() >= 15, "{} boxes", w.boxes.len());
    let mut walls_only = w.clone();
    walls_only.boxes.clear();
    for (i, b) in w.boxes.iter().enumerate() {
        for p in b.corners().into_iter().chain([b.center]) {
            let r = w
                .region_at(p)
                .unwrap_or_else(|| panic!("boxes[{i}] outside"));
            assert_eq!(r.kind, RegionKind::Room, "boxes[{i}] in {}", r.name);
            // Rooms SW, SE and NW are furnished here (issue 3); others furnish the rest.
            let ours = ["room_sw", "room_se", "room_nw"]
                .iter()
                .any(|prefix| r.name.starts_with(prefix));
            if ours {
                assert!(walls_only.clearance(p) > 0.02, "boxes[{i}] touches a wall");
            }
        }
        assert!(w.furniture_at(b.center) == Some(i));
    }
    // Furniture is not in the maps.
    let (m1, m2) = (w.vector_map(true), walls_only.vector_map(true));
    assert_eq!(m1, m2);
}

#[test]
fn bad_boxes_are_named_with_their_line() {
    let base = "name = \"t\"\nceiling_height = 3.0\n[materials.wood]\nlaser = \"opaque\"\n\
                [[walls]]\npoints = [[0.0, 0.0], [5.0, 0.0]]\nthickness = 0.1\nmaterial = \"wood\"\n\
                [[boxes]]\ncenter = [1.0, 1.0]\n";
    let load =
        |rest: &str| World::from_toml_str(&format!("{base}{rest}"), std::path::Path::new("w.toml"));
    let ok = load("size = [1.0, 1.0, 1.0]\nmaterial = \"wood\"\n").unwrap();
    assert_eq!(ok.boxes[0].yaw, 0.0);
    let e = load("size = [1.0, 0.0, 1.0]\nmaterial = \"wood\"\n")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "w.toml: boxes[0].size: size[1] must be finite and > 0, got 0 (entry at line 9)"
    );
    let e = load("size = [1.0, 1.0, 1.0]\nmaterial = \"oak\"\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("boxes[0].material") && e.contains("oak"), "{e}");
    let e = load("size = [1.0, 1.0, 1.0]\nmaterial = \"wood\"\ncolour = 1\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("boxes[0]") && e.contains("colour"), "{e}");
}

const WORLD: &str = r#"name = "w"
ceiling_height = 3.0
[materials.concrete]
laser = "opaque"
wifi_attenuation_db = 12.0
[materials.glass]
laser = "glass"
reflect_within_deg = 5.0
[[walls]]
points = [[0.0, 0.0], [10.0, 0.0]]
thickness = 0.2
material = "concrete"
[wifi]
shadowing_sigma_db = 4.0
[[access_points]]
name = "a1"
position = [1.0, 2.0, 2.8]
tx_power_dbm = -40.0
path_loss_exponent = 2.5
channel = 6
"#;

#[test]
fn loader_reads_access_points_attenuation_and_environment() {
    let path = std::path::Path::new("w.toml");
    let w = World::from_toml_str(WORLD, path).unwrap();
    assert_eq!(w.access_points.len(), 1);
    assert_eq!(w.access_points[0].channel, 6);
    assert_eq!(w.material("concrete").unwrap().wifi_attenuation_db, 12.0);
    assert_eq!(
        w.material("glass").unwrap().wifi_attenuation_db,
        0.0,
        "serde default"
    );
    assert_eq!(w.wifi.shadowing_sigma_db, 4.0);
    assert_eq!(w.wifi.shadowing_decorrelation_m, 3.0, "default");
    w.validate(path).unwrap();
    let bad = WORLD.replace("position = [1.0, 2.0, 2.8]", "position = [1.0, 2.0, 3.5]");
    let e = World::from_toml_str(&bad, path).unwrap_err().to_string();
    assert!(
        e.starts_with("w.toml: access_points[0].position: height z"),
        "{e}"
    );
    let bad = WORLD.replace("wifi_attenuation_db = 12.0", "wifi_attenuation_db = -3.0");
    let e = World::from_toml_str(&bad, path).unwrap_err().to_string();
    assert!(
        e.starts_with("w.toml: materials.concrete.wifi_attenuation_db: must be"),
        "{e}"
    );
    let bad = format!("{WORLD}[[access_points]]\nname = \"a1\"\nposition = [0.0, 0.0, 1.0]\ntx_power_dbm = -40.0\npath_loss_exponent = 2.0\nchannel = 1\n");
    let e = World::from_toml_str(&bad, path).unwrap_err().to_string();
    assert!(
        e.contains("access_points[1].name: duplicate access point name"),
        "{e}"
    );
    let bad = WORLD.replace("shadowing_sigma_db = 4.0", "shadowing_sigm = 4.0");
    let e = World::from_toml_str(&bad, path).unwrap_err().to_string();
    assert!(e.contains("wifi: unknown field `shadowing_sigm`"), "{e}");
    let campus = World::campus().unwrap();
    assert_eq!(campus.access_points.len(), 15);
    // None inside the atrium (x 30–60, y 2.85–40): its interior stays open.
    assert!(campus.access_points.iter().all(|a| {
        let [x, y, _] = a.position;
        !(x > 30.0 && x < 60.0 && y > 2.85 && y < 40.0)
    }));
}
