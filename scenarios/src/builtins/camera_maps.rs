//! The omnicam and ceiling-brightness maps on the disk cache (kinds `omni_map` and
//! `ceiling_map`): the keys (every input a map is trained from) and the payloads (every
//! float bit for bit), refused, so that the map is retrained, unless they decode whole and
//! fit the inputs.

use crate::builtins::appearance::{read_matrix, write_matrix};
use crate::builtins::appearance_filters::{
    train_ceiling_map_from_images, train_omni_map, TrainingGrid,
};
use crate::disk_cache::{DiskCache, Reader, Writer};
use crate::scenario::Scenario;
use atrium_localization::ceiling_mcl::CeilingMap;
use atrium_localization::omni_map::{OmniMap, OmniMapParams};
use atrium_localization::pca::Pca;
use atrium_sim::camera::Shader;
use atrium_sim::camera_stream::{CeilingImager, CeilingSensorSpec, OmniSensorSpec};
use atrium_sim::Scene;
use atrium_worlds::lighting::LightingCondition;
use nalgebra::DVector;

/// Part of the disk cache's key of ceiling-brightness maps: bump when training makes another
/// map from the same inputs (the executable's identity is in the key too).
const CEILING_MAP_VERSION: u32 = 1;

/// Part of the disk cache's key of omnicam maps: bump when training makes another map from
/// the same inputs (the executable's identity is in the key too).
const OMNI_MAP_VERSION: u32 = 1;

/// Everything a ceiling-brightness map is trained from besides the scenario's world.
pub(super) struct CeilingInputs {
    /// The upward camera (its `name` is the sensor's).
    pub(super) camera: CeilingSensorSpec,
    pub(super) grid: TrainingGrid,
    pub(super) lighting: LightingCondition,
    pub(super) seed: u64,
}

impl CeilingInputs {
    /// The in-process key: the parsed world and every training input.
    pub(super) fn memory_key(&self, scenario: &Scenario) -> String {
        format!(
            "ceiling_map\n{}\n{}\n{:?}\n{}\n{:?}\n{}",
            serde_json::to_string(&scenario.world).unwrap_or_default(),
            self.lighting.name(),
            self.grid,
            self.seed,
            self.camera,
            scenario.physics_hz,
        )
    }

    /// The disk cache's key ([`crate::disk_cache::world_derived_key`]).
    fn disk_key(&self, scenario: &Scenario) -> Vec<u8> {
        let label = format!("ceiling map {CEILING_MAP_VERSION}");
        crate::disk_cache::world_derived_key(&label, &self.memory_key(scenario), scenario)
    }

    /// Renders the camera's image at every node of the grid (001, first part).
    fn train(&self, scenario: &Scenario) -> Result<CeilingMap, String> {
        let scene = Scene::new(&scenario.world, scenario.physics_hz).map_err(|e| e.to_string())?;
        let shader = Shader::new(&scenario.world, &scene, self.lighting);
        let imager = CeilingImager::new(
            self.camera.clone(),
            &format!("sensors.{}", self.camera.name),
        )
        .map_err(|e| e.to_string())?;
        train_ceiling_map_from_images(&scene, &shader, &imager, &self.grid, self.seed)
    }
}

/// The ceiling map of `inputs` from `cache` when it holds it (trained and stored otherwise);
/// trained when `cache` is `None`. A stored map is the trained one bit for bit.
pub(super) fn cached_ceiling_map(
    cache: Option<&DiskCache>,
    inputs: &CeilingInputs,
    scenario: &Scenario,
) -> Result<CeilingMap, String> {
    let Some(cache) = cache else {
        return inputs.train(scenario);
    };
    cache.get_or_build(
        "ceiling_map",
        &inputs.disk_key(scenario),
        || inputs.train(scenario),
        ceiling_to_bytes,
        |b| ceiling_from_bytes(b, &inputs.grid),
    )
}

/// The disk cache's encoding of a ceiling map: its grid and every node's brightness, bit for
/// bit (NaN for a node without training data included).
fn ceiling_to_bytes(m: &CeilingMap) -> Vec<u8> {
    let mut w = Writer::default();
    let [x0, y0] = m.origin();
    for v in [x0, y0, m.step()] {
        w.f64(v);
    }
    let (nx, ny) = m.nodes();
    w.u64(nx as u64);
    w.u64(ny as u64);
    w.f64s(m.values());
    w.0
}

/// A map stored by [`ceiling_to_bytes`], if it is a valid map on the nodes of `grid`; `None`
/// for anything else.
fn ceiling_from_bytes(bytes: &[u8], grid: &TrainingGrid) -> Option<CeilingMap> {
    let mut r = Reader::new(bytes);
    let origin = [r.f64()?, r.f64()?];
    let step = r.f64()?;
    let nx = usize::try_from(r.u64()?).ok()?;
    let ny = usize::try_from(r.u64()?).ok()?;
    let values = r.f64s()?;
    if !r.is_empty() || !on_grid(origin, step, (nx, ny), grid) {
        return None;
    }
    CeilingMap::new(origin, step, nx, ny, values).ok()
}

/// Whether a stored map's node grid is the one `grid` trains on (bit for bit).
fn on_grid(origin: [f64; 2], step: f64, nodes: (usize, usize), grid: &TrainingGrid) -> bool {
    origin[0].to_bits() == grid.area[0].to_bits()
        && origin[1].to_bits() == grid.area[1].to_bits()
        && step.to_bits() == grid.step.to_bits()
        && nodes == grid.nodes()
}

/// Everything an omnicam map is trained from besides the scenario's world.
pub(super) struct OmniInputs {
    /// The panoramic camera (its `name` is the sensor's).
    pub(super) camera: OmniSensorSpec,
    pub(super) grid: TrainingGrid,
    pub(super) lighting: LightingCondition,
    /// Rotations, d, PCA locations and the training seed.
    pub(super) params: OmniMapParams,
}

impl OmniInputs {
    /// The in-process key: the parsed world and every training input.
    pub(super) fn memory_key(&self, scenario: &Scenario) -> String {
        format!(
            "omni_map\n{}\n{}\n{:?}\n{:?}\n{:?}\n{}",
            serde_json::to_string(&scenario.world).unwrap_or_default(),
            self.lighting.name(),
            self.grid,
            self.params,
            self.camera,
            scenario.physics_hz,
        )
    }

    /// The disk cache's key ([`crate::disk_cache::world_derived_key`]).
    fn disk_key(&self, scenario: &Scenario) -> Vec<u8> {
        let label = format!("omni map {OMNI_MAP_VERSION}");
        crate::disk_cache::world_derived_key(&label, &self.memory_key(scenario), scenario)
    }

    /// Renders a panorama at every node of the grid and builds the eigenimage map (001,
    /// second part).
    fn train(&self, scenario: &Scenario) -> Result<OmniMap, String> {
        let scene = Scene::new(&scenario.world, scenario.physics_hz).map_err(|e| e.to_string())?;
        let shader = Shader::new(&scenario.world, &scene, self.lighting);
        let cam = self
            .camera
            .camera(&format!("sensors.{}", self.camera.name))
            .map_err(|e| e.to_string())?;
        train_omni_map(&scene, &shader, &cam, &self.grid, self.params)
    }
}

/// The omnicam map of `inputs` from `cache` when it holds it (trained and stored otherwise);
/// trained when `cache` is `None`. A stored map is the trained one bit for bit.
pub(super) fn cached_omni_map(
    cache: Option<&DiskCache>,
    inputs: &OmniInputs,
    scenario: &Scenario,
) -> Result<OmniMap, String> {
    let Some(cache) = cache else {
        return inputs.train(scenario);
    };
    cache.get_or_build(
        "omni_map",
        &inputs.disk_key(scenario),
        || inputs.train(scenario),
        omni_to_bytes,
        |b| omni_from_bytes(b, inputs),
    )
}

/// The disk cache's encoding of an omnicam map: grid, panorama size, rotations, the
/// eigenimages (mean, components, eigenvalues) and every feature, each f64 bit for bit.
fn omni_to_bytes(m: &OmniMap) -> Vec<u8> {
    let mut w = Writer::default();
    let [x0, y0] = m.origin();
    for v in [x0, y0, m.step()] {
        w.f64(v);
    }
    let (nx, ny) = m.nodes();
    for n in [nx, ny, m.width, m.height, m.rotations()] {
        w.u64(n as u64);
    }
    let pca = m.pca();
    w.f64s(pca.mean.as_slice());
    write_matrix(&mut w, &pca.components);
    w.f64s(pca.eigenvalues.as_slice());
    w.f64s(m.features());
    w.0
}

/// A map stored by [`omni_to_bytes`], if its parts fit together and fit `inputs` (grid,
/// panorama size, rotations); `None` for anything else.
fn omni_from_bytes(bytes: &[u8], inputs: &OmniInputs) -> Option<OmniMap> {
    let mut r = Reader::new(bytes);
    let size = |r: &mut Reader| usize::try_from(r.u64()?).ok();
    let origin = [r.f64()?, r.f64()?];
    let step = r.f64()?;
    let (nx, ny) = (size(&mut r)?, size(&mut r)?);
    let (width, height, rotations) = (size(&mut r)?, size(&mut r)?, size(&mut r)?);
    let mean = DVector::from_vec(r.f64s()?);
    let components = read_matrix(&mut r)?;
    let eigenvalues = DVector::from_vec(r.f64s()?);
    let features = r.f64s()?;
    let c = &inputs.camera;
    if !r.is_empty()
        || !on_grid(origin, step, (nx, ny), &inputs.grid)
        || (width, height, rotations) != (c.width, c.height, inputs.params.rotations)
    {
        return None;
    }
    let pca = Pca::from_parts(mean, components, eigenvalues).ok()?;
    OmniMap::from_parts(
        origin, step, nx, ny, width, height, rotations, pca, features,
    )
    .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    const CEILING: &str = "[sensors.ceiling]\nkind = \"ceiling\"";

    /// The lab with a small panoramic camera and the upward camera.
    fn lab_with_cameras() -> Scenario {
        let text = format!(
            "name = \"t\"\nworld = \"../worlds/lab.toml\"\n\
             robot = \"../robots/urdf/pioneer3dx.urdf\"\nduration_s = 5.0\n\
             [start]\npose = [2.6, 2.2, 0.0]\n[route]\nwaypoints = [[3.0, 2.2]]\n\
             [sensors.omni]\nkind = \"omni\"\nwidth = 32\nheight = 4\n{CEILING}\n\
             [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n"
        );
        let file = crate::bundled_scenarios_dir().join("t.toml");
        Scenario::from_toml_str(&text, &file).unwrap()
    }

    /// A fresh cache folder under the system's temporary folder.
    fn temp_cache(tag: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!(
            "atrium-{tag}-cache-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos())
        ))
    }

    /// 4 × 3 nodes, 8 rotations, eigenimages from 4 locations.
    fn omni_inputs(s: &Scenario) -> OmniInputs {
        OmniInputs {
            camera: s.cameras.omni[0].clone(),
            grid: TrainingGrid {
                area: [2.0, 2.0, 3.5, 3.0],
                step: 0.5,
                rotation_step_deg: 360.0,
            },
            lighting: LightingCondition::Tube,
            params: OmniMapParams {
                rotations: 8,
                d: 5,
                pca_locations: 4,
                seed: 1,
            },
        }
    }

    /// Every float of an omnicam map (grid, eigenimages, eigenvalues, mean, features) by bits.
    fn omni_bits(m: &OmniMap) -> Vec<u64> {
        let p = m.pca();
        [m.origin().as_slice(), &[m.step()]]
            .into_iter()
            .chain([
                p.mean.as_slice(),
                p.components.as_slice(),
                p.eigenvalues.as_slice(),
                m.features(),
            ])
            .flatten()
            .map(|v| v.to_bits())
            .collect()
    }

    /// `bytes` with the u64 at byte `at` replaced by `v`.
    fn patched(bytes: &[u8], at: usize, v: u64) -> Vec<u8> {
        let mut b = bytes.to_vec();
        b[at..at + 8].copy_from_slice(&v.to_le_bytes());
        b
    }

    #[test]
    fn omni_maps_from_the_disk_cache_are_the_trained_ones() {
        let s = lab_with_cameras();
        let inputs = omni_inputs(&s);
        let dir = temp_cache("omni");
        let cache = DiskCache::at(&dir);
        let trained = inputs.train(&s).unwrap();
        let bytes = omni_to_bytes(&trained);
        let first = cached_omni_map(Some(&cache), &inputs, &s).unwrap();
        let key = inputs.disk_key(&s);
        let entry = cache.entry_path("omni_map", &key);
        assert!(entry.is_file(), "the first build stores its map");
        let second = cached_omni_map(Some(&cache), &inputs, &s).unwrap();
        // Bit for bit: every eigenimage, eigenvalue, mean entry and feature.
        assert_eq!(omni_bits(&first), omni_bits(&trained));
        assert_eq!(omni_bits(&second), omni_bits(&trained));
        assert_eq!(omni_to_bytes(&second), bytes);
        assert_eq!(second, trained);
        assert_eq!(
            second.step_energy().to_bits(),
            trained.step_energy().to_bits()
        );

        // The second build reads the entry: another map stored under the key comes back.
        let (nx, ny) = trained.nodes();
        let other = OmniMap::from_parts(
            trained.origin(),
            trained.step(),
            nx,
            ny,
            trained.width,
            trained.height,
            trained.rotations(),
            trained.pca().clone(),
            trained.features().iter().map(|v| 2.0 * v).collect(),
        )
        .unwrap();
        cache.put("omni_map", &key, &omni_to_bytes(&other)).unwrap();
        let read = cached_omni_map(Some(&cache), &inputs, &s).unwrap();
        assert_eq!(read, other);

        // A truncated, lengthened or empty payload, parts that do not fit together (a wider
        // panorama than the eigenimages, a node count past the features), or a whole map of
        // another grid or camera: retrained.
        let mut longer = bytes.clone();
        longer.push(0);
        let shifted = OmniMap::from_parts(
            [2.5, 2.0],
            trained.step(),
            nx,
            ny,
            trained.width,
            trained.height,
            trained.rotations(),
            trained.pca().clone(),
            trained.features().to_vec(),
        )
        .unwrap();
        for bad in [
            bytes[..bytes.len() - 8].to_vec(),
            longer,
            Vec::new(),
            patched(&bytes, 40, 64),
            patched(&bytes, 24, u64::MAX),
            patched(&bytes, 56, 16),
            omni_to_bytes(&shifted),
        ] {
            cache.put("omni_map", &key, &bad).unwrap();
            let m = cached_omni_map(Some(&cache), &inputs, &s).unwrap();
            assert_eq!(omni_to_bytes(&m), bytes);
        }
        // A damaged entry file: retrained and rewritten whole.
        let whole = std::fs::read(&entry).unwrap();
        let mut flipped = whole.clone();
        flipped[whole.len() - 100] ^= 0x04;
        for bad in [whole[..whole.len() / 2].to_vec(), flipped] {
            std::fs::write(&entry, &bad).unwrap();
            let m = cached_omni_map(Some(&cache), &inputs, &s).unwrap();
            assert_eq!(omni_to_bytes(&m), bytes);
            assert_eq!(std::fs::read(&entry).unwrap(), whole, "rewritten whole");
        }

        // Any other training input is another key.
        let variants: [fn(&mut OmniInputs); 12] = [
            |i| i.params.seed = 2,
            |i| i.params.d = 6,
            |i| i.params.rotations = 16,
            |i| i.params.pca_locations = 5,
            |i| i.grid.step = 0.25,
            |i| i.grid.area[2] = 4.0,
            |i| i.lighting = LightingCondition::Bulb,
            |i| i.camera.width = 64,
            |i| i.camera.height = 8,
            |i| i.camera.z = 1.2,
            |i| i.camera.gain = 1.5,
            |i| i.camera.noise_sigma = 0.02,
        ];
        for change in variants {
            let mut changed = omni_inputs(&s);
            change(&mut changed);
            let path = cache.entry_path("omni_map", &changed.disk_key(&s));
            assert_ne!(path, entry);
        }
        // So is another world (a moved lamp) or physics rate; another seed or route of the
        // run is not.
        let mut lamp = s.clone();
        lamp.world.lighting.lights[0].from[0] += 0.1;
        let mut rate = s.clone();
        rate.physics_hz = 100.0;
        for other in [lamp, rate] {
            assert_ne!(
                cache.entry_path("omni_map", &inputs.disk_key(&other)),
                entry
            );
        }
        let mut run = s.clone();
        run.seed = 9;
        run.waypoints = vec![[4.0, 2.2]];
        assert_eq!(cache.entry_path("omni_map", &inputs.disk_key(&run)), entry);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// 5 × 3 nodes under the lab's bulbs.
    fn ceiling_inputs(s: &Scenario) -> CeilingInputs {
        CeilingInputs {
            camera: s.cameras.ceiling[0].clone(),
            grid: TrainingGrid {
                area: [2.0, 2.0, 4.0, 3.0],
                step: 0.5,
                rotation_step_deg: 360.0,
            },
            lighting: LightingCondition::Bulb,
            seed: 1,
        }
    }

    fn ceiling_bits(m: &CeilingMap) -> Vec<u64> {
        [m.origin().as_slice(), &[m.step()], m.values()]
            .into_iter()
            .flatten()
            .map(|v| v.to_bits())
            .collect()
    }

    #[test]
    fn ceiling_maps_from_the_disk_cache_are_the_trained_ones() {
        let s = lab_with_cameras();
        let inputs = ceiling_inputs(&s);
        let dir = temp_cache("ceiling");
        let cache = DiskCache::at(&dir);
        let trained = inputs.train(&s).unwrap();
        let (lo, hi) = trained.range();
        assert!(hi > lo, "the bulbs make the ceiling vary: {lo} {hi}");
        let bytes = ceiling_to_bytes(&trained);
        let first = cached_ceiling_map(Some(&cache), &inputs, &s).unwrap();
        let key = inputs.disk_key(&s);
        let entry = cache.entry_path("ceiling_map", &key);
        assert!(entry.is_file(), "the first build stores its map");
        let second = cached_ceiling_map(Some(&cache), &inputs, &s).unwrap();
        assert_eq!(ceiling_bits(&first), ceiling_bits(&trained));
        assert_eq!(ceiling_bits(&second), ceiling_bits(&trained));
        assert_eq!(second, trained);

        // The second build reads the entry: another map stored under the key comes back,
        // a node without data (NaN) included.
        let (nx, ny) = trained.nodes();
        let mut values = trained.values().to_vec();
        values[3] = f64::NAN;
        let other = CeilingMap::new(trained.origin(), trained.step(), nx, ny, values).unwrap();
        cache
            .put("ceiling_map", &key, &ceiling_to_bytes(&other))
            .unwrap();
        let read = cached_ceiling_map(Some(&cache), &inputs, &s).unwrap();
        assert_eq!(ceiling_bits(&read), ceiling_bits(&other));

        // Truncated, lengthened, empty, values that do not fill the grid, an infinite
        // brightness, a map of another grid: retrained.
        let mut longer = bytes.clone();
        longer.push(0);
        let mut inf = trained.values().to_vec();
        inf[0] = f64::INFINITY;
        let mut w = Writer::default();
        for v in [2.0, 2.0, 0.5] {
            w.f64(v);
        }
        w.u64(nx as u64);
        w.u64(ny as u64);
        w.f64s(&inf);
        let shifted = CeilingMap::new(
            [2.5, 2.0],
            trained.step(),
            nx,
            ny,
            trained.values().to_vec(),
        )
        .unwrap();
        for bad in [
            bytes[..bytes.len() - 8].to_vec(),
            longer,
            Vec::new(),
            patched(&bytes, 24, nx as u64 + 1),
            patched(&bytes, 24, u64::MAX / 2 + 1),
            w.0,
            ceiling_to_bytes(&shifted),
        ] {
            cache.put("ceiling_map", &key, &bad).unwrap();
            let m = cached_ceiling_map(Some(&cache), &inputs, &s).unwrap();
            assert_eq!(ceiling_to_bytes(&m), bytes);
        }
        let whole = std::fs::read(&entry).unwrap();
        let mut flipped = whole.clone();
        flipped[whole.len() - 20] ^= 0x04;
        for bad in [whole[..whole.len() / 2].to_vec(), flipped] {
            std::fs::write(&entry, &bad).unwrap();
            let m = cached_ceiling_map(Some(&cache), &inputs, &s).unwrap();
            assert_eq!(ceiling_to_bytes(&m), bytes);
            assert_eq!(std::fs::read(&entry).unwrap(), whole, "rewritten whole");
        }

        // Any other training input, world or physics rate is another key.
        let variants: [fn(&mut CeilingInputs); 9] = [
            |i| i.seed = 2,
            |i| i.grid.step = 0.25,
            |i| i.grid.area[0] = 1.5,
            |i| i.lighting = LightingCondition::Tube,
            |i| i.camera.size = 7,
            |i| i.camera.fov = 0.5,
            |i| i.camera.z = 0.6,
            |i| i.camera.gain = 1.5,
            |i| i.camera.noise_sigma = 0.02,
        ];
        for change in variants {
            let mut changed = ceiling_inputs(&s);
            change(&mut changed);
            let path = cache.entry_path("ceiling_map", &changed.disk_key(&s));
            assert_ne!(path, entry);
        }
        let mut lamp = s.clone();
        lamp.world.lighting.lights[0].from[1] += 0.1;
        let mut rate = s.clone();
        rate.physics_hz = 100.0;
        for other in [lamp, rate] {
            assert_ne!(
                cache.entry_path("ceiling_map", &inputs.disk_key(&other)),
                entry
            );
        }
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
