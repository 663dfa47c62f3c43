//! Maps the localizers of a run derive from its world, built once and shared.
//!
//! MCL's likelihood field is shared within the process (`map_cache`) and across processes
//! on disk (`disk_cache`, kind `likelihood_field`): its distance transform and its table of
//! logarithms are most of an MCL run's startup (~0.25 s and ~0.15 s on the campus at 2 cm).

use crate::disk_cache::{DiskCache, Reader, Writer};
use crate::scenario::Scenario;
use atrium_localization::likelihood_field::{LikelihoodField, LikelihoodFieldParams};
use atrium_localization::mcl::{MclMap, MclParams};
use atrium_localization::LocalizationError;
use atrium_worlds::{Cell, OccupancyGrid};
use std::collections::hash_map::{Entry, HashMap};
use std::sync::Arc;

/// Part of the disk cache's key of likelihood fields: bump when a field is made otherwise
/// from the same grid and parameters (the executable's identity is in the key too).
const FIELD_VERSION: u32 = 1;

/// The disk cache's key of the likelihood field of `grid` with `params`: the whole grid
/// (frame, size and every cell) and every parameter.
fn field_key(grid: &OccupancyGrid, params: &LikelihoodFieldParams) -> Vec<u8> {
    let mut w = Writer::default();
    w.str(&format!("likelihood field {FIELD_VERSION}"));
    w.u64(grid.width as u64);
    w.u64(grid.height as u64);
    let p = params;
    for v in [grid.resolution, grid.origin[0], grid.origin[1]] {
        w.f64(v);
    }
    for v in [p.z_hit, p.z_rand, p.sigma_hit, p.max_dist, p.range_max] {
        w.f64(v);
    }
    let cells: Vec<u8> = grid
        .cells
        .iter()
        .map(|c| match c {
            Cell::Free => 0,
            Cell::Occupied => 1,
            Cell::Unknown => 2,
        })
        .collect();
    w.bytes(&cells);
    w.0
}

/// Payload layouts: every cell's distance and log-likelihood, or a palette of the distinct
/// (distance, log-likelihood) pairs and a 16-bit index per cell.
const RAW: u64 = 0;
const PALETTE: u64 = 1;

/// The disk cache's encoding of a field, bit for bit. Distances are square roots of integers
/// (in cells) up to the cap and the table a function of them, so a field holds a few thousand
/// distinct pairs: the palette stores the campus at 2 cm in 13 MB instead of 80 MB, which is
/// what reading it costs.
fn field_to_bytes(field: &LikelihoodField) -> Vec<u8> {
    let (dist, table) = (field.distances(), field.log_table());
    let mut slots: HashMap<(u64, u32), u16> = HashMap::new();
    let (mut pal_d, mut pal_p) = (Vec::new(), Vec::new());
    let mut index = Vec::with_capacity(2 * dist.len());
    for (d, p) in dist.iter().zip(table) {
        let next = slots.len();
        let slot = match slots.entry((d.to_bits(), p.to_bits())) {
            Entry::Occupied(e) => *e.get(),
            Entry::Vacant(e) => {
                let Ok(slot) = u16::try_from(next) else {
                    return raw_field_bytes(dist, table);
                };
                pal_d.push(*d);
                pal_p.push(*p);
                *e.insert(slot)
            }
        };
        index.extend_from_slice(&slot.to_le_bytes());
    }
    let mut w = Writer::default();
    w.u64(PALETTE);
    w.f64s(&pal_d);
    w.f32s(&pal_p);
    w.bytes(&index);
    w.0
}

fn raw_field_bytes(dist: &[f64], table: &[f32]) -> Vec<u8> {
    let mut w = Writer::default();
    w.u64(RAW);
    w.f64s(dist);
    w.f32s(table);
    w.0
}

/// A stored field, if its distances and table fit `grid` and `params`.
fn field_from_bytes(
    bytes: &[u8],
    grid: &OccupancyGrid,
    params: LikelihoodFieldParams,
) -> Option<LikelihoodField> {
    let mut r = Reader::new(bytes);
    let (dist, log_p) = match r.u64()? {
        RAW => (r.f64s()?, r.f32s()?),
        PALETTE => {
            let (pal_d, pal_p) = (r.f64s()?, r.f32s()?);
            let index = r.bytes()?;
            if pal_d.len() != pal_p.len() || index.len() != 2 * grid.cells.len() {
                return None;
            }
            let mut dist = Vec::with_capacity(grid.cells.len());
            let mut log_p = Vec::with_capacity(grid.cells.len());
            for c in index.chunks_exact(2) {
                let slot = usize::from(u16::from_le_bytes([c[0], c[1]]));
                dist.push(*pal_d.get(slot)?);
                log_p.push(*pal_p.get(slot)?);
            }
            (dist, log_p)
        }
        _ => return None,
    };
    if !r.is_empty() {
        return None;
    }
    LikelihoodField::from_tables(grid, dist, log_p, params).ok()
}

/// The likelihood field of `grid` with `params`, from `cache` when it holds it (stored there
/// otherwise); computed when `cache` is `None`. Bit for bit the computed field.
fn cached_field(
    cache: Option<&DiskCache>,
    grid: &OccupancyGrid,
    params: LikelihoodFieldParams,
) -> Result<LikelihoodField, LocalizationError> {
    let build = || LikelihoodField::new(grid, params);
    let Some(cache) = cache else {
        return build();
    };
    cache.get_or_build(
        "likelihood_field",
        &field_key(grid, &params),
        build,
        field_to_bytes,
        |b| field_from_bytes(b, grid, params),
    )
}

/// Maps exported from the world and shared by the localizers that need them: within a run,
/// and through [`crate::map_cache`] with every other run in the process that holds the same
/// map at the time (a sweep's trials). Holding a `SharedMaps` keeps its maps alive.
#[derive(Default)]
pub struct SharedMaps {
    /// The world as JSON: the key part naming the world (computed once).
    world_key: Option<String>,
    grid: Option<Arc<OccupancyGrid>>,
    vector: Option<Arc<atrium_worlds::VectorMap>>,
    /// MCL likelihood fields built so far, by key.
    mcl: Vec<(String, Arc<MclMap>)>,
}

impl SharedMaps {
    fn world_key(&mut self, scenario: &Scenario) -> String {
        self.world_key
            .get_or_insert_with(|| serde_json::to_string(&scenario.world).unwrap_or_default())
            .clone()
    }

    /// The vector map (wall faces and pillars as segments; glass per `[map] include_glass`;
    /// for a ROS map, the faces traced along its occupied cells).
    pub fn vector_map(&mut self, scenario: &Scenario) -> &atrium_worlds::VectorMap {
        let v = match (&self.vector, &scenario.grid_map) {
            (Some(v), _) => v.clone(),
            (None, Some(g)) => g.vector.clone(),
            (None, None) => {
                let glass = scenario.map.include_glass;
                let key = format!("vector_map\n{}\n{glass}", self.world_key(scenario));
                let built = crate::map_cache::shared(key, || {
                    Ok::<_, std::convert::Infallible>(scenario.world.vector_map(glass))
                });
                match built {
                    Ok(v) => v,
                    Err(never) => match never {},
                }
            }
        };
        self.vector.insert(v)
    }

    /// The occupancy grid of the scenario's `[map]` settings.
    pub fn occupancy_grid(&mut self, scenario: &Scenario) -> &OccupancyGrid {
        let g = self.shared_grid(scenario);
        self.grid.insert(g)
    }

    fn shared_grid(&mut self, scenario: &Scenario) -> Arc<OccupancyGrid> {
        if let Some(g) = &self.grid {
            return g.clone();
        }
        // A ROS map is the grid, as it is.
        if let Some(g) = &scenario.grid_map {
            return g.grid.clone();
        }
        let (res, glass) = (scenario.map.resolution, scenario.map.include_glass);
        let key = format!(
            "occupancy_grid\n{}\n{res}\n{glass}",
            self.world_key(scenario)
        );
        let built = crate::map_cache::shared(key, || {
            Ok::<_, std::convert::Infallible>(scenario.world.occupancy_grid(res, glass))
        });
        match built {
            Ok(g) => g,
            Err(never) => match never {},
        }
    }

    /// The likelihood field and free cells an MCL filter with `params` needs, built for the
    /// range of the scenario's first laser (so the filter need not rebuild its table).
    pub fn mcl_map(
        &mut self,
        scenario: &Scenario,
        params: &MclParams,
    ) -> Result<Arc<MclMap>, atrium_localization::LocalizationError> {
        let range_max = scenario.lasers.first().map_or(8.0, |l| l.range_max);
        let grid = self.shared_grid(scenario);
        self.grid = Some(grid.clone());
        let key = format!(
            "mcl_map\n{}\n{}\n{}\n{:?}\n{range_max}",
            self.world_key(scenario),
            scenario.map.resolution,
            scenario.map.include_glass,
            [
                params.z_hit,
                params.z_rand,
                params.sigma_hit,
                params.max_dist,
                params.grid_resolution
            ]
        );
        if let Some((_, m)) = self.mcl.iter().find(|(k, _)| *k == key) {
            return Ok(m.clone());
        }
        let map = crate::map_cache::shared(key.clone(), || {
            MclMap::with_field(&grid, params, range_max, |g, p| {
                cached_field(DiskCache::global().as_ref(), g, p)
            })
        })?;
        self.mcl.push((key, map.clone()));
        Ok(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn temp_cache(tag: &str) -> (PathBuf, DiskCache) {
        let dir = std::env::temp_dir().join(format!(
            "atrium-maps-{tag}-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos())
        ));
        (dir.clone(), DiskCache::at(dir))
    }

    fn lab_grid(resolution: f64) -> OccupancyGrid {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml");
        atrium_worlds::World::load(&path)
            .unwrap()
            .occupancy_grid(resolution, false)
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn field_params() -> LikelihoodFieldParams {
        let p = MclParams::default();
        LikelihoodFieldParams {
            z_hit: p.z_hit,
            z_rand: p.z_rand,
            sigma_hit: p.sigma_hit,
            max_dist: p.max_dist,
            range_max: 8.0,
        }
    }

    /// Bit patterns of a field's distances and table.
    fn field_bits(f: &LikelihoodField) -> (Vec<u64>, Vec<u32>) {
        let table = f.log_table().iter().map(|x| x.to_bits()).collect();
        (bits(f.distances()), table)
    }

    #[test]
    fn mcl_fields_from_the_disk_cache_are_the_computed_ones() {
        let params = MclParams::default();
        let grid = lab_grid(params.grid_resolution);
        let (dir, cache) = temp_cache("mcl");
        let from_cache = |g: &OccupancyGrid| {
            MclMap::with_field(g, &params, 8.0, |g, p| cached_field(Some(&cache), g, p)).unwrap()
        };
        let built = MclMap::new(&grid, &params, 8.0).unwrap();
        let want = field_bits(built.field());
        let first = from_cache(&grid);
        let key = field_key(&grid, &field_params());
        let entry = cache.entry_path("likelihood_field", &key);
        assert!(entry.is_file(), "the first build stores its field");
        let second = from_cache(&grid);
        assert!(field_bits(first.field()) == want);
        assert!(field_bits(second.field()) == want);
        let at = |m: &MclMap| {
            m.field()
                .log_likelihood(grid.origin[0] + 1.03, grid.origin[1] + 2.1)
        };
        assert_eq!(at(&second).to_bits(), at(&built).to_bits());
        assert_eq!(second.field().log_floor(), built.field().log_floor());

        // Both layouts hold the field bit for bit.
        let (good_d, good_t) = (built.field().distances(), built.field().log_table());
        let stored = field_to_bytes(built.field());
        assert_eq!(Reader::new(&stored).u64(), Some(PALETTE));
        for bytes in [stored, raw_field_bytes(good_d, good_t)] {
            let back = field_from_bytes(&bytes, &grid, field_params()).unwrap();
            assert!(field_bits(&back) == want);
        }

        // The second build reads the entry: another (valid) field stored under the key comes
        // back.
        let n = grid.cells.len();
        let zeros = LikelihoodField::from_tables(&grid, vec![0.0; n], vec![0.0; n], field_params())
            .unwrap();
        cache
            .put("likelihood_field", &key, &field_to_bytes(&zeros))
            .unwrap();
        let read = cached_field(Some(&cache), &grid, field_params()).unwrap();
        assert!(read.distances().iter().all(|d| *d == 0.0));

        // Distances or a table of the wrong count or range, a truncated, flipped or empty
        // entry: rebuilt.
        let payload = raw_field_bytes;
        let bad_payloads = [
            payload(&good_d[1..], good_t),
            payload(good_d, &good_t[1..]),
            payload(&vec![params.max_dist * 2.0; n], good_t),
            payload(&vec![f64::NAN; n], good_t),
            payload(good_d, &vec![f32::NAN; n]),
        ];
        let mut bad_palette = Writer::default();
        bad_palette.u64(PALETTE);
        bad_palette.f64s(&[0.0]);
        bad_palette.f32s(&[0.0]);
        bad_palette.bytes(&vec![1; 2 * n]);
        let mut unknown = raw_field_bytes(good_d, good_t);
        unknown[0] = 7;
        let bad_payloads = bad_payloads.into_iter().chain([bad_palette.0, unknown]);
        for bad in bad_payloads {
            cache.put("likelihood_field", &key, &bad).unwrap();
            assert!(
                field_bits(&cached_field(Some(&cache), &grid, field_params()).unwrap()) == want
            );
        }
        let whole = std::fs::read(&entry).unwrap();
        let mut flipped = whole.clone();
        flipped[whole.len() / 2] ^= 0x10;
        for bad in [whole[..whole.len() / 3].to_vec(), flipped, Vec::new()] {
            std::fs::write(&entry, &bad).unwrap();
            assert!(field_bits(from_cache(&grid).field()) == want);
            assert_eq!(std::fs::read(&entry).unwrap(), whole, "rewritten whole");
        }

        // One cell, a parameter or the frame changed: another key, another entry.
        let mut one_cell = grid.clone();
        let k = one_cell
            .cells
            .iter()
            .position(|c| *c == Cell::Free)
            .unwrap();
        one_cell.cells[k] = Cell::Occupied;
        let mut moved = grid.clone();
        moved.origin[0] += 0.5;
        let p = field_params();
        let others = [
            field_key(&one_cell, &p),
            field_key(&moved, &p),
            field_key(
                &grid,
                &LikelihoodFieldParams {
                    max_dist: p.max_dist * 0.5,
                    ..p
                },
            ),
            field_key(
                &grid,
                &LikelihoodFieldParams {
                    sigma_hit: p.sigma_hit * 2.0,
                    ..p
                },
            ),
            field_key(
                &grid,
                &LikelihoodFieldParams {
                    z_hit: p.z_hit * 0.5,
                    ..p
                },
            ),
            field_key(
                &grid,
                &LikelihoodFieldParams {
                    z_rand: p.z_rand * 0.5,
                    ..p
                },
            ),
            field_key(
                &grid,
                &LikelihoodFieldParams {
                    range_max: 30.0,
                    ..p
                },
            ),
        ];
        for other in &others {
            assert_ne!(cache.entry_path("likelihood_field", other), entry);
        }
        let changed = from_cache(&one_cell);
        let fresh = LikelihoodField::new(&one_cell, p).unwrap();
        assert!(field_bits(changed.field()) == field_bits(&fresh));
        assert!(field_bits(&fresh) != want);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
