//! Process-wide sharing of the maps localizers derive from a world (occupancy grid, vector map,
//! MCL likelihood field). Each is a pure function of the world and a few parameters and costs
//! more than a short trial (the campus likelihood field: ~0.3 s of distance transform and
//! table), so runs that want the same one share a single copy.
//!
//! The registry holds only weak references, keyed by the full text of what the value depends
//! on (never a hash, so a key cannot collide): a value lives as long as some
//! `SharedMaps` (the `maps` module) holds it. A sweep keeps the maps of every cell it has
//! trials left for alive, so its trials build nothing; a lone run builds and frees its own.
//! A hit returns exactly what a rebuild would, so no result depends on the cache.

use std::any::Any;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock, Weak};

type Registry = Mutex<HashMap<String, Weak<dyn Any + Send + Sync>>>;

fn registry() -> &'static Registry {
    static REG: OnceLock<Registry> = OnceLock::new();
    REG.get_or_init(|| Mutex::new(HashMap::new()))
}

fn lookup<T: Any + Send + Sync>(
    reg: &HashMap<String, Weak<dyn Any + Send + Sync>>,
    key: &str,
) -> Option<Arc<T>> {
    reg.get(key)?.upgrade()?.downcast::<T>().ok()
}

/// The live value under `key`, or `build()`'s, registered for later callers. Two threads
/// asking at once may both build (the values are equal); one copy is kept.
pub fn shared<T: Any + Send + Sync, E>(
    key: String,
    build: impl FnOnce() -> Result<T, E>,
) -> Result<Arc<T>, E> {
    {
        let reg = registry().lock().unwrap_or_else(|p| p.into_inner());
        if let Some(hit) = lookup::<T>(&reg, &key) {
            return Ok(hit);
        }
    }
    // Built outside the lock: other keys proceed meanwhile.
    let built = Arc::new(build()?);
    let mut reg = registry().lock().unwrap_or_else(|p| p.into_inner());
    if let Some(hit) = lookup::<T>(&reg, &key) {
        return Ok(hit);
    }
    reg.retain(|_, w| w.strong_count() > 0);
    let any: Arc<dyn Any + Send + Sync> = built.clone();
    reg.insert(key, Arc::downgrade(&any));
    Ok(built)
}

/// Number of live entries (for tests and the benchmark's report).
pub fn live_entries() -> usize {
    let reg = registry().lock().unwrap_or_else(|p| p.into_inner());
    reg.values().filter(|w| w.strong_count() > 0).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn built_once_while_held_and_freed_after() {
        static BUILDS: AtomicUsize = AtomicUsize::new(0);
        let build = || {
            BUILDS.fetch_add(1, Ordering::SeqCst);
            Ok::<_, ()>(vec![1u8, 2, 3])
        };
        let key = "map_cache test: built_once".to_string();
        let a = shared(key.clone(), build).unwrap();
        let b = shared(key.clone(), build).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(BUILDS.load(Ordering::SeqCst), 1);
        drop((a, b));
        let c = shared(key.clone(), build).unwrap();
        assert_eq!(*c, vec![1, 2, 3]);
        assert_eq!(BUILDS.load(Ordering::SeqCst), 2, "nothing held it: rebuilt");
        // Another type under the same key is a miss, not a wrong downcast.
        let d = shared(key, || Ok::<_, ()>(7u32)).unwrap();
        assert_eq!(*d, 7);
        let e: Result<Arc<u32>, &str> = shared("map_cache test: error".into(), || Err("bad"));
        assert_eq!(e.unwrap_err(), "bad");
    }
}
