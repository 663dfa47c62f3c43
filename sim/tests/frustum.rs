//! The culled image renderer (`frustum.rs`) against rapier's query pipeline: every pixel's
//! hit (collider, distance, normal) and every depth must be bit-identical, on many poses in
//! the campus world (glass, pillars, furniture), with tilted cameras, cameras touching walls,
//! and with people walking.

use atrium_robots::{DepthCameraSpec, Pose2};
use atrium_sim::frustum::{FrustumCaster, Pinhole};
use atrium_sim::{fixtures, DepthCamera, PeopleParams, Scene, SimConfig, Simulation};
use atrium_worlds::World;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rapier3d::prelude::*;

fn campus() -> World {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/campus.toml");
    World::load(&p).unwrap()
}

fn kinect(decimation: usize) -> DepthCameraSpec {
    let mut s = DepthCameraSpec::kinect("k", "camera");
    s.decimation = decimation;
    s
}

/// Bounds of the world's walls.
fn bounds(world: &World) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for w in &world.walls {
        for p in [w.a, w.b] {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    (lo, hi)
}

fn base_pose(x: f64, y: f64, yaw: f64) -> Pose {
    Pose::from_parts(
        Vector::new(x as f32, y as f32, 0.0),
        Rotation::from_rotation_z(yaw as f32),
    )
}

/// A camera anywhere over `area` at a height in `z`, rolled and pitched by up to `roll` and
/// `pitch` rad, at any heading.
fn random_camera(
    rng: &mut ChaCha8Rng,
    (lo, hi): ([f64; 2], [f64; 2]),
    z: std::ops::Range<f64>,
    roll: f64,
    pitch: f64,
) -> Pose {
    let t = Translation3::new(
        rng.random_range(lo[0]..hi[0]),
        rng.random_range(lo[1]..hi[1]),
        rng.random_range(z),
    );
    let r = UnitQuaternion::from_euler_angles(
        rng.random_range(-roll..roll),
        rng.random_range(-pitch..pitch),
        rng.random_range(-3.2..3.2),
    );
    atrium_sim::scene::iso_to_pose(&Isometry3::from_parts(t, r))
}

/// Renders with both paths and compares every pixel's depth bit for bit; returns the
/// number of valid pixels.
fn compare_depths(scene: &Scene, cam: &mut DepthCamera, base: &Pose, what: &str) -> usize {
    cam.cast_reference(scene, base);
    let want = cam.true_depths().to_vec();
    cam.cast(scene, base);
    let got = cam.true_depths();
    let n = want.len();
    // Ties (coplanar faces of overlapping walls, corners) fall back to the pipeline: a few
    // percent of a frame at most.
    assert!(
        cam.fallback_pixels() * 20 <= n,
        "{what}: {} of {n} pixels fell back",
        cam.fallback_pixels()
    );
    for (i, (a, b)) in want.iter().zip(got).enumerate() {
        assert_eq!(a.to_bits(), b.to_bits(), "{what}: pixel {i}: {a} vs {b}");
    }
    want.iter().filter(|z| **z > 0.0).count()
}

/// Compares the hits themselves (collider, distance, normal) for a camera at `cam`; returns
/// how many pixels fell back to the pipeline (ties).
fn compare_hits(scene: &Scene, cam: &Pose, spec: &DepthCameraSpec, what: &str) -> usize {
    let (fx, fy, cx, cy) = spec.intrinsics();
    let (w, h) = (spec.image_width(), spec.image_height());
    let mut dirs = Vec::new();
    let mut min_axial = 1.0f64;
    for v in 0..h {
        for u in 0..w {
            let d = nalgebra::Vector3::new(1.0, -(u as f64 - cx) / fx, -(v as f64 - cy) / fy);
            let n = d.norm();
            min_axial = min_axial.min(1.0 / n);
            dirs.push(Vector::new(
                (d.x / n) as f32,
                (d.y / n) as f32,
                (d.z / n) as f32,
            ));
        }
    }
    let pin = Pinhole {
        width: w,
        height: h,
        fx,
        fy,
        cx,
        cy,
        min_axial,
    };
    let max_toi = (spec.range_max / min_axial) as f32;
    let filter = QueryFilter::default().groups(Scene::sensor_groups());
    let query = scene.physics.query_pipeline_with_filter(filter);
    // The AVX kernels where the processor has them, and the portable path.
    let mut fallbacks = [0; 2];
    for (f, mut caster) in fallbacks
        .iter_mut()
        .zip([FrustumCaster::new(), FrustumCaster::without_simd()])
    {
        caster.render(&query, cam, &pin, &dirs, max_toi, |i, dir, got| {
            assert_eq!(dir, cam.rotation * dirs[i]);
            let want =
                query.cast_ray_and_get_normal(&Ray::new(cam.translation, dir), max_toi, true);
            match (want, got) {
                (None, None) => {}
                (Some((ha, a)), Some((hb, b))) => {
                    assert_eq!(ha, hb, "{what}: pixel {i}: collider");
                    assert_eq!(
                        a.time_of_impact.to_bits(),
                        b.time_of_impact.to_bits(),
                        "{what}: pixel {i}: {} vs {}",
                        a.time_of_impact,
                        b.time_of_impact
                    );
                    assert_eq!(a.normal, b.normal, "{what}: pixel {i}: normal");
                }
                (a, b) => panic!("{what}: pixel {i}: {a:?} vs {b:?}"),
            }
        });
        *f = caster.fallbacks();
    }
    assert_eq!(fallbacks[0], fallbacks[1], "{what}: fallbacks");
    fallbacks[0]
}

#[test]
fn depth_frames_match_the_query_pipeline_across_the_campus() {
    let world = campus();
    let scene = Scene::new(&world, 200.0).unwrap();
    let (lo, hi) = bounds(&world);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mount = Isometry3::translation(0.1, 0.0, 0.5);
    let mut cam4 = DepthCamera::new(kinect(4), &mount, ChaCha8Rng::seed_from_u64(1), "d").unwrap();
    let mut valid = 0;
    for k in 0..150 {
        let (x, y) = (
            rng.random_range(lo[0]..hi[0]),
            rng.random_range(lo[1]..hi[1]),
        );
        let yaw = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        valid += compare_depths(
            &scene,
            &mut cam4,
            &base_pose(x, y, yaw),
            &format!("pose {k} ({x}, {y}, {yaw})"),
        );
    }
    assert!(valid > 150 * 2000, "{valid} valid pixels");
    // Full resolution at a few poses along the corridors of the bundled scenarios.
    let mut cam1 = DepthCamera::new(kinect(1), &mount, ChaCha8Rng::seed_from_u64(1), "d").unwrap();
    for (x, y, yaw) in [(2.0, 20.0, 0.0), (10.0, 20.0, 1.5), (12.0, 25.0, -2.0)] {
        compare_depths(&scene, &mut cam1, &base_pose(x, y, yaw), "full resolution");
    }
}

#[test]
fn hits_match_with_tilted_cameras_and_cameras_touching_walls() {
    let world = campus();
    let scene = Scene::new(&world, 200.0).unwrap();
    let (lo, hi) = bounds(&world);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let spec = kinect(8);
    let mut fallbacks = 0;
    for k in 0..200 {
        let cam = random_camera(&mut rng, (lo, hi), 0.05..2.9, 0.6, 1.2);
        fallbacks += compare_hits(&scene, &cam, &spec, &format!("camera {k}"));
    }
    // Ties only (cameras inside a wall, where every ray starts at distance 0; corners): a
    // small share of all pixels.
    let pixels = 200 * spec.image_width() * spec.image_height();
    assert!(fallbacks * 20 < pixels, "{fallbacks} of {pixels} fell back");
    // Against walls: 0–2 cm from the south corridor walls' faces, looking along and into them.
    for w in world.walls.iter().take(12) {
        let (dx, dy) = (w.b[0] - w.a[0], w.b[1] - w.a[1]);
        let len = dx.hypot(dy);
        let (nx, ny) = (-dy / len, dx / len);
        for (s, off, yaw) in [(0.3, 0.0, 0.0), (0.5, 0.01, 1.0), (0.7, 0.02, 3.0)] {
            let off = 0.5 * w.thickness + off;
            let (x, y) = (w.a[0] + s * dx + off * nx, w.a[1] + s * dy + off * ny);
            let cam = base_pose(x, y, dy.atan2(dx) + yaw);
            let cam = Pose::from_parts(cam.translation + Vector::new(0.0, 0.0, 0.5), cam.rotation);
            compare_hits(&scene, &cam, &spec, &format!("wall ({x}, {y})"));
        }
    }
}

#[test]
fn depth_frames_match_with_people_walking() {
    let world = campus();
    let config = SimConfig {
        start: Pose2::new(2.0, 20.0, 0.0),
        seed: 3,
        people: PeopleParams {
            density: 8.0,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut sim = Simulation::new(&world, &fixtures::pioneer_3dx_like(), config).unwrap();
    sim.set_route(&[[22.0, 20.0], [10.0, 20.0]]);
    let mount = Isometry3::translation(0.1, 0.0, 0.5);
    let mut cam = DepthCamera::new(kinect(4), &mount, ChaCha8Rng::seed_from_u64(1), "d").unwrap();
    let mut out = Vec::new();
    let mut people_seen = 0;
    for k in 0..40 {
        for _ in 0..50 {
            sim.step(&mut out);
        }
        out.clear();
        let base = sim.robot_bodies().base_pose(&sim.scene().physics);
        compare_depths(sim.scene(), &mut cam, &base, &format!("frame {k}"));
        // Someone within the camera's view now and then (the scene has people in it).
        let g = sim.ground_truth();
        people_seen += sim
            .people()
            .unwrap()
            .positions()
            .iter()
            .filter(|p| (p[0] - g.x).hypot(p[1] - g.y) < 4.0)
            .count();
    }
    assert!(people_seen > 0);
}

/// `cast_cuboid` against parry's cuboid cast, bit for bit, on random boxes and rays: from
/// outside and inside, through edges and corners (slabs entered at the same parameter),
/// along the axes (zero direction components) and beyond `max_toi`.
#[test]
fn cuboid_fast_path_is_parrys_cast_bit_for_bit() {
    use atrium_sim::frustum::cast_cuboid;
    use rapier3d::parry::shape::Cuboid;
    let mut rng = ChaCha8Rng::seed_from_u64(19);
    let (mut fast, mut hits, mut total) = (0, 0, 0);
    for k in 0..200_000 {
        let half = Vector::new(
            rng.random_range(0.01..3.0),
            rng.random_range(0.01..3.0),
            rng.random_range(0.01..3.0),
        );
        let origin = Vector::new(
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
        );
        let target = match k % 4 {
            // A corner or an edge's midpoint: equal slab parameters.
            0 => half * Vector::new(1.0, -1.0, 1.0),
            1 => half * Vector::new(0.0, 1.0, -1.0),
            _ => Vector::new(
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
            ),
        };
        let mut dir = (target - origin).normalize();
        if k % 7 == 0 {
            dir.y = 0.0;
        }
        let ray = Ray::new(origin, dir);
        let max_toi = rng.random_range(0.5..12.0);
        let cuboid = Cuboid::new(half);
        let parry = cuboid.cast_local_ray_and_get_normal(&ray, max_toi, true);
        total += 1;
        if let Some(ours) = cast_cuboid(half, &ray, max_toi) {
            fast += 1;
            let key = |h: Option<RayIntersection>| {
                h.map(|h| {
                    (
                        h.time_of_impact.to_bits(),
                        h.normal.to_array().map(f32::to_bits),
                        h.feature,
                        h.subshape,
                    )
                })
            };
            let ours = ours.map(|h| h.intersection());
            assert_eq!(key(ours), key(parry), "{half:?} {ray:?} {max_toi}");
            hits += ours.is_some() as usize;
        }
    }
    // A quarter of the rays aim at corners and edges and a seventh lie in a plane of the
    // axes: those go to parry; the rest must take the fast path.
    assert!(
        fast > total / 2 && hits > total / 5,
        "{fast} {hits} of {total}"
    );
}

/// Intensity cameras render through the culled caster: every pixel's radiance and depth must
/// be what one pipeline cast per ray gives, bit for bit, in the campus (whose glass cameras
/// see through, by a filter predicate) and in the lab, at random and tilted poses.
#[test]
fn radiance_images_match_the_per_ray_renderer() {
    use atrium_sim::camera::{render_radiance, render_radiance_culled, RayBundle, Shader};
    use atrium_worlds::lighting::LightingCondition;
    let lab =
        World::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml"))
            .unwrap();
    let bundle = RayBundle::pinhole(80, 60, 70.0);
    let n = 80 * 60;
    let mut caster = FrustumCaster::new();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut lit = 0;
    for (world, condition) in [
        (campus(), LightingCondition::Bulb),
        (lab, LightingCondition::Natural),
    ] {
        let scene = Scene::new(&world, 200.0).unwrap();
        let shader = Shader::new(&world, &scene, condition);
        let (lo, hi) = bounds(&world);
        for k in 0..40 {
            let cam = random_camera(&mut rng, (lo, hi), 0.2..2.5, 0.3, 0.8);
            let (mut want, mut want_z) = (vec![0.0f32; n], vec![0.0f32; n]);
            let (mut got, mut got_z) = (vec![1.0f32; n], vec![1.0f32; n]);
            render_radiance(
                &scene,
                &shader,
                &bundle,
                &cam,
                30.0,
                &mut want,
                Some(&mut want_z),
            );
            render_radiance_culled(
                &scene,
                &shader,
                &bundle,
                &mut caster,
                &cam,
                30.0,
                &mut got,
                Some(&mut got_z),
            );
            for i in 0..n {
                assert_eq!(
                    want[i].to_bits(),
                    got[i].to_bits(),
                    "camera {k}: pixel {i} radiance"
                );
                assert_eq!(
                    want_z[i].to_bits(),
                    got_z[i].to_bits(),
                    "camera {k}: pixel {i} depth"
                );
            }
            lit += want.iter().filter(|v| **v > 0.0).count();
        }
    }
    // The images are not blank: most pixels see something lit.
    assert!(lit > 80 * n / 2, "{lit} lit pixels");
}
