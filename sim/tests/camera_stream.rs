//! Camera streams in a running simulation: intensity, stereo, ceiling and omni cameras render
//! at their own rates under the chosen light, and bad rates are named.

use atrium_robots::{IntensityImage, Reading};
use atrium_robots::{Pose2, RobotModel};
use atrium_sim::camera::{CameraSpec, Shader};
use atrium_sim::camera_stream::*;
use atrium_sim::stereo::StereoSpec;
use atrium_sim::Scene;
use atrium_sim::{SimConfig, Simulation};
use atrium_worlds::lighting::LightingCondition;
use atrium_worlds::World;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The random stream `id` under `seed`, as the camera stream draws it.
fn stream(seed: u64, id: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id);
    rng
}

fn lab() -> World {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml");
    World::load(&path).unwrap()
}

fn small(name: &str) -> CameraSpec {
    let mut c = CameraSpec::paper(name);
    c.width = 40;
    c.height = 30;
    c
}

fn config(cameras: CameraSensors) -> SimConfig {
    SimConfig {
        start: Pose2::new(5.5, 3.5, 0.0),
        cameras,
        seed: 3,
        ..Default::default()
    }
}

#[test]
fn cameras_render_at_their_rates_under_the_chosen_light() {
    let world = lab();
    let robot = RobotModel::from_urdf(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../robots/urdf/pioneer3dx.urdf"
    )))
    .unwrap();
    let mut stereo = StereoSpec::paper("stereo");
    stereo.camera = small("stereo");
    stereo.max_disparity = 10;
    stereo.window_radius = 2;
    let sensors = |lighting| CameraSensors {
        lighting,
        cameras: vec![CameraSensorSpec {
            camera: small("front"),
            rate_hz: 4.0,
        }],
        stereo: vec![StereoSensorSpec {
            stereo: stereo.clone(),
            rate_hz: 2.0,
        }],
        ..Default::default()
    };
    let run = |lighting| {
        let mut sim = Simulation::new(&world, &robot, config(sensors(lighting))).unwrap();
        let mut out = Vec::new();
        for _ in 0..200 {
            sim.step(&mut out);
        }
        out
    };
    let tube = run(LightingCondition::Tube);
    let images: Vec<&IntensityImage> = tube
        .iter()
        .filter_map(|r| match r {
            Reading::Intensity(i) => Some(i),
            _ => None,
        })
        .collect();
    let front: Vec<_> = images.iter().filter(|i| i.sensor == "front").collect();
    let left: Vec<_> = images.iter().filter(|i| i.sensor == "stereo").collect();
    // One simulated second: 4 frames at 4 Hz, 2 stereo pairs at 2 Hz.
    assert_eq!(front.len(), 4);
    assert_eq!(left.len(), 2);
    let disparities: Vec<_> = tube
        .iter()
        .filter_map(|r| match r {
            Reading::Disparity(d) => Some(d),
            _ => None,
        })
        .collect();
    assert_eq!(disparities.len(), 2);
    assert_eq!(disparities[0].disparity.len(), 40 * 30);
    assert!((disparities[0].stamp - 0.5).abs() < 1e-9);
    assert!(front[0].pixels.len() == 40 * 30);
    // The same run under another light sees the same scene differently.
    let bulb = run(LightingCondition::Bulb);
    let first = |v: &[Reading]| {
        v.iter()
            .find_map(|r| match r {
                Reading::Intensity(i) if i.sensor == "front" => Some(i.pixels.clone()),
                _ => None,
            })
            .unwrap()
    };
    let mean = |p: &[f32]| p.iter().sum::<f32>() / p.len() as f32;
    assert!((mean(&first(&tube)) - mean(&first(&bulb))).abs() > 0.01);
    // Deterministic per seed.
    assert_eq!(first(&tube), first(&run(LightingCondition::Tube)));
}

/// Ceiling and omni cameras render at their rates, their images are the ones the map
/// trainers render at the same floor pose (`CeilingCamera` / `OmniCamera`), and the
/// panorama carries the cylinder's intrinsics.
#[test]
fn ceiling_and_omni_cameras_render_in_the_stream() {
    let world = lab();
    let robot = RobotModel::from_urdf(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../robots/urdf/pioneer3dx.urdf"
    )))
    .unwrap();
    let mut ceiling = CeilingSensorSpec::new("ceiling");
    ceiling.noise_sigma = 0.0;
    ceiling.rate_hz = 5.0;
    let mut omni = OmniSensorSpec::new("omni");
    omni.noise_sigma = 0.0;
    omni.rate_hz = 2.0;
    let sensors = CameraSensors {
        lighting: LightingCondition::Bulb,
        ceiling: vec![ceiling.clone()],
        omni: vec![omni.clone()],
        ..Default::default()
    };
    let mut sim = Simulation::new(&world, &robot, config(sensors)).unwrap();
    let mut out = Vec::new();
    let mut truths = Vec::new();
    for _ in 0..200 {
        let n = out.len();
        let truth = sim.step(&mut out);
        truths.extend(std::iter::repeat_n(truth, out.len() - n));
    }
    let pick = |name: &str| -> Vec<(IntensityImage, Pose2)> {
        out.iter()
            .zip(&truths)
            .filter_map(|(r, t)| match r {
                Reading::Intensity(i) if i.sensor == name => Some((i.clone(), *t)),
                _ => None,
            })
            .collect()
    };
    let up = pick("ceiling");
    let pano = pick("omni");
    assert_eq!((up.len(), pano.len()), (5, 2));
    let (img, at) = &up[0];
    assert_eq!((img.width, img.height, img.pixels.len()), (9, 9, 81));
    assert_eq!(img.mount.xyz, [0.0, 0.0, 0.5]);
    // The mean of the image is the brightness the old single-number camera reports
    // (noise-free; up to 8-bit quantisation).
    let scene = Scene::new(&world, 200.0).unwrap();
    let shader = Shader::new(&world, &scene, LightingCondition::Bulb);
    let mut rng = stream(0, 0);
    let b = atrium_sim::camera::CeilingCamera::new(0.5, 0.0)
        .unwrap()
        .brightness(&scene, &shader, at.x, at.y, &mut rng);
    let mean = img.pixels.iter().map(|p| *p as f64).sum::<f64>() / 81.0;
    assert!(b > 0.05 && (mean - b).abs() < 0.003, "{mean} vs {b}");
    // The panorama is `OmniCamera`'s at the robot's floor pose.
    let (img, at) = &pano[0];
    assert_eq!((img.width, img.height), (64, 16));
    let cam = atrium_sim::camera::OmniCamera::new(64, 16, 1.0).unwrap();
    let mut expect = vec![0.0; 64 * 16];
    cam.render(&scene, &shader, at, &mut rng, &mut expect);
    let diff = img
        .pixels
        .iter()
        .zip(&expect)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(diff <= 1.5 / 255.0, "{diff}");
    assert!((img.fx - 64.0 / std::f64::consts::TAU).abs() < 1e-12);
    assert_eq!((img.cx, img.cy), (0.0, 7.5));
    assert!((img.fy * 2.0 * OMNI_ELEVATION - 15.0).abs() < 1e-9);
    // Bad specs name the field.
    let mut bad = OmniSensorSpec::new("o");
    bad.width = 1;
    let e = bad.validate("omni[0]").unwrap_err().to_string();
    assert!(e.contains("omni[0].width"), "{e}");
    let mut bad = CeilingSensorSpec::new("c");
    bad.z = -1.0;
    let e = bad.validate("ceiling[0]").unwrap_err().to_string();
    assert!(e.contains("ceiling[0].z"), "{e}");
}

#[test]
fn bad_camera_rates_are_named() {
    let world = lab();
    let robot = RobotModel::from_urdf(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../robots/urdf/pioneer3dx.urdf"
    )))
    .unwrap();
    let sensors = CameraSensors {
        cameras: vec![CameraSensorSpec {
            camera: small("front"),
            rate_hz: 0.0,
        }],
        ..Default::default()
    };
    let err = Simulation::new(&world, &robot, config(sensors))
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("cameras[0].rate_hz"), "{err}");
}
