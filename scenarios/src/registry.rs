//! The localizer registry: every `kind` a scenario's `[[localizers]]` entry may name, and the
//! factory that builds it. The built-in kinds are registered through the same [`register`]
//! call as a user's (see `builtins`), so a user crate adds its own localizers to scenarios,
//! sweeps and replays without editing Atrium:
//!
//! ```ignore
//! let mut registry = LocalizerRegistry::with_builtins();
//! registry.register("mine", |ctx: &mut BuildContext| {
//!     Ok(Box::new(MyFilter::new(ctx.spec.name.clone(), ctx.scenario.start)) as _)
//! })?;
//! let result = registry.run(&Scenario::load(path)?, RunOptions::default())?;
//! ```
//!
//! [`register`]: LocalizerRegistry::register

use crate::error::ScenarioError;
use crate::maps::SharedMaps;
use crate::runner::{run_localizers, ReadingStream, RunOptions, RunResult, SimStream};
use crate::scenario::{Event, LocalizerSpec, Scenario};
use atrium_localization::{Localizer, SharedMember};
use serde::de::DeserializeOwned;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// What a factory gets to build one localizer of a scenario.
pub struct BuildContext<'a> {
    /// The `[[localizers]]` entry: its `name`, `kind` and every other key in `params`.
    pub spec: &'a LocalizerSpec,
    pub scenario: &'a Scenario,
    /// Maps exported from the world, shared with the other localizers of the run.
    pub maps: &'a mut SharedMaps,
    /// The run's seed; [`BuildContext::seed`] is this localizer's own.
    pub run_seed: u64,
    /// The registry building this localizer (a chooser builds its members through it).
    pub registry: &'a LocalizerRegistry,
    /// The run's shared chooser members, when the whole run is being built.
    members: Option<&'a mut MemberPool>,
}

/// The chooser members of a run being built: one filter per localizer name, shared by the
/// stand-alone localizer of that name and every chooser naming it (see [`SharedMember`]).
#[derive(Default)]
struct MemberPool {
    /// Name, the first handle, and whether the filter can be copied (asked once).
    members: Vec<(String, SharedMember, Option<bool>)>,
}

impl BuildContext<'_> {
    /// This localizer's seed: derived from the run's seed and its name (see
    /// [`localizer_seed`]).
    pub fn seed(&self) -> u64 {
        localizer_seed(self.run_seed, &self.spec.name)
    }

    /// The field path of this localizer in error messages: `localizers[NAME]`.
    pub fn field(&self) -> String {
        format!("localizers[{}]", self.spec.name)
    }

    /// Bad input in this localizer's table: names the scenario file and
    /// `localizers[NAME].key` (or the table itself when `key` is empty).
    pub fn error(&self, key: &str, msg: impl Into<String>) -> ScenarioError {
        let field = if key.is_empty() {
            self.field()
        } else {
            format!("{}.{key}", self.field())
        };
        ScenarioError::field(&self.scenario.file, field, msg)
    }

    /// The entry's parameters (every key but `name` and `kind`) as `T`; unknown keys and
    /// wrong types are errors naming the field when `T` denies unknown fields.
    pub fn params<T: DeserializeOwned>(&self) -> Result<T, ScenarioError> {
        toml::Value::Table(self.spec.params.clone())
            .try_into()
            .map_err(|e: toml::de::Error| self.error("", e.message().to_string()))
    }

    /// A path given in this localizer's table, relative to the scenario file. A registry
    /// made by [`LocalizerRegistry::recording_paths`] remembers it: a sweep hashes the
    /// files its trials read, so that results of changed inputs are never mixed.
    pub fn path(&self, rel: &str) -> std::path::PathBuf {
        let p = self
            .scenario
            .file
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(rel);
        if let Some(log) = &self.registry.paths {
            log.lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(p.clone());
        }
        p
    }

    /// Builds another localizer of the same run (a chooser's member) through the registry.
    pub fn build(&mut self, spec: &LocalizerSpec) -> Result<Box<dyn Localizer>, ScenarioError> {
        self.registry
            .build(spec, self.scenario, self.maps, self.run_seed)
    }

    /// A chooser's member: when the whole run is being built, a handle on the run's one
    /// filter of that name, shared with the stand-alone localizer and the other choosers
    /// (seeded alike, they would compute the same until re-seeded; see [`SharedMember`]).
    /// `reseeded`: the caller may re-seed it, which needs a filter that can be copied; one
    /// that cannot, or a localizer built on its own, gets a private instance as
    /// [`BuildContext::build`] gives.
    pub fn build_member(
        &mut self,
        spec: &LocalizerSpec,
        reseeded: bool,
    ) -> Result<Box<dyn Localizer>, ScenarioError> {
        let Some(pool) = self.members.as_deref_mut() else {
            return self.build(spec);
        };
        let i = match pool.members.iter().position(|(n, _, _)| *n == spec.name) {
            Some(i) => i,
            None => {
                let l = self
                    .registry
                    .build(spec, self.scenario, self.maps, self.run_seed)?;
                pool.members
                    .push((spec.name.clone(), SharedMember::new(l), None));
                pool.members.len() - 1
            }
        };
        let (_, member, copyable) = &mut pool.members[i];
        let copyable = *copyable.get_or_insert_with(|| member.can_copy());
        if reseeded && !copyable {
            return self.build(spec);
        }
        Ok(Box::new(member.share()))
    }
}

/// The seed of the localizer named `name` in a run seeded `run_seed`. A chooser's member gets
/// the seed of the stand-alone localizer of the same name, so the two see the same random
/// draws and a comparison between them is paired (common random numbers).
pub fn localizer_seed(run_seed: u64, name: &str) -> u64 {
    crate::seeds::derive_seed(run_seed, &format!("localizer/{name}"))
}

/// Builds the localizers of one `kind`. Any `Fn(&mut BuildContext) -> Result<Box<dyn
/// Localizer>, ScenarioError>` is one.
pub trait LocalizerFactory: Send + Sync {
    fn build(&self, ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError>;
}

impl<F> LocalizerFactory for F
where
    F: Fn(&mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> + Send + Sync,
{
    fn build(&self, ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
        self(ctx)
    }
}

/// A registration the registry refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    #[error("localizer kind {0:?} is registered already: a registry takes one factory per kind")]
    Duplicate(String),
    #[error(
        "localizer kind {0:?} is not a valid name: use letters, digits, '_' and '-', \
         starting with a letter"
    )]
    BadName(String),
}

/// The localizer kinds a run can build, by name. Cheap to clone (factories are shared).
#[derive(Clone, Default)]
pub struct LocalizerRegistry {
    kinds: BTreeMap<String, Arc<dyn LocalizerFactory>>,
    /// The paths [`BuildContext::path`] resolved, when recording (shared by clones).
    paths: Option<Arc<Mutex<BTreeSet<PathBuf>>>>,
}

impl std::fmt::Debug for LocalizerRegistry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_set().entries(self.kinds.keys()).finish()
    }
}

impl LocalizerRegistry {
    /// A registry with no kinds (see `LocalizerRegistry::with_builtins` for Atrium's own).
    pub fn empty() -> Self {
        Self::default()
    }

    /// Adds `kind`, built by `factory`. A kind registered already is refused, so two crates
    /// cannot silently replace each other's localizer.
    pub fn register(
        &mut self,
        kind: &str,
        factory: impl LocalizerFactory + 'static,
    ) -> Result<&mut Self, RegistryError> {
        let valid = kind.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
            && kind
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !valid {
            return Err(RegistryError::BadName(kind.to_string()));
        }
        if self.kinds.contains_key(kind) {
            return Err(RegistryError::Duplicate(kind.to_string()));
        }
        self.kinds.insert(kind.to_string(), Arc::new(factory));
        Ok(self)
    }

    /// A clone of this registry (the same kinds) that records every path its factories
    /// resolve with [`BuildContext::path`], from now on; [`Self::recorded_paths`] lists them.
    pub fn recording_paths(&self) -> LocalizerRegistry {
        LocalizerRegistry {
            kinds: self.kinds.clone(),
            paths: Some(Arc::default()),
        }
    }

    /// The paths recorded since [`Self::recording_paths`] made this registry (sorted; none
    /// when it does not record).
    pub fn recorded_paths(&self) -> Vec<PathBuf> {
        self.paths.as_ref().map_or_else(Vec::new, |log| {
            log.lock()
                .unwrap_or_else(|e| e.into_inner())
                .iter()
                .cloned()
                .collect()
        })
    }

    /// The registered kinds, sorted.
    pub fn kinds(&self) -> impl Iterator<Item = &str> {
        self.kinds.keys().map(String::as_str)
    }

    pub fn contains(&self, kind: &str) -> bool {
        self.kinds.contains_key(kind)
    }

    /// Every `[[localizers]]` kind of `scenario` is registered and every `[expect]` key is
    /// known (checked before a run or a sweep starts, so a typo costs no simulation).
    pub fn check(&self, scenario: &Scenario) -> Result<(), ScenarioError> {
        for spec in &scenario.localizers {
            self.factory(spec, scenario)?;
        }
        crate::expect::parse_expectations(scenario)?;
        Ok(())
    }

    fn factory(
        &self,
        spec: &LocalizerSpec,
        scenario: &Scenario,
    ) -> Result<&Arc<dyn LocalizerFactory>, ScenarioError> {
        self.kinds.get(&spec.kind).ok_or_else(|| {
            let known: Vec<&str> = self.kinds().collect();
            ScenarioError::field(
                &scenario.file,
                format!("localizers[{}].kind", spec.name),
                format!(
                    "unknown localizer kind {:?} (registered: {})",
                    spec.kind,
                    known.join(", ")
                ),
            )
        })
    }

    /// Builds the localizer `spec` names, seeded from `run_seed` (see [`localizer_seed`]).
    /// A chooser built alone has members of its own (see [`BuildContext::build_member`]).
    pub fn build(
        &self,
        spec: &LocalizerSpec,
        scenario: &Scenario,
        maps: &mut SharedMaps,
        run_seed: u64,
    ) -> Result<Box<dyn Localizer>, ScenarioError> {
        self.build_in_run(spec, scenario, maps, run_seed, None)
    }

    fn build_in_run(
        &self,
        spec: &LocalizerSpec,
        scenario: &Scenario,
        maps: &mut SharedMaps,
        run_seed: u64,
        members: Option<&mut MemberPool>,
    ) -> Result<Box<dyn Localizer>, ScenarioError> {
        let factory = self.factory(spec, scenario)?.clone();
        let mut ctx = BuildContext {
            spec,
            scenario,
            maps,
            run_seed,
            registry: self,
            members,
        };
        factory.build(&mut ctx)
    }

    /// Builds every localizer of `scenario`, in scenario order. Choosers share their members'
    /// filters with each other and with the stand-alone localizers of the same names (see
    /// [`BuildContext::build_member`]): a stand-alone localizer some chooser names is a handle
    /// on that filter.
    pub fn build_all(
        &self,
        scenario: &Scenario,
        run_seed: u64,
    ) -> Result<Vec<Box<dyn Localizer>>, ScenarioError> {
        self.check(scenario)?;
        let mut maps = SharedMaps::default();
        let mut pool = MemberPool::default();
        let mut built = scenario
            .localizers
            .iter()
            .map(|spec| self.build_in_run(spec, scenario, &mut maps, run_seed, Some(&mut pool)))
            .collect::<Result<Vec<_>, _>>()?;
        for (name, member, _) in pool.members {
            // Built from the same entry with the same seed, the pooled filter is what the
            // stand-alone instance would compute; holding it, the run keeps one of them.
            if let Some(i) = scenario.localizers.iter().position(|s| s.name == name) {
                built[i] = Box::new(member);
            }
        }
        Ok(built)
    }

    /// Runs `scenario` live with its localizers built from this registry, scores them and
    /// checks its expectations.
    pub fn run(
        &self,
        scenario: &Scenario,
        options: RunOptions,
    ) -> Result<RunResult, ScenarioError> {
        let seed = options.seed.unwrap_or(scenario.seed);
        if let Some(log) = scenario.log.as_deref() {
            let mut stream = crate::log_stream::LogStream::new(log);
            let localizers = self.build_all(scenario, seed)?;
            return run_localizers(scenario, seed, &mut stream, &[], localizers, options);
        }
        // The simulation first: a start inside a wall is reported before any training run.
        let mut stream = SimStream::new(scenario, seed)?;
        let localizers = self.build_all(scenario, seed)?;
        run_localizers(
            scenario,
            seed,
            &mut stream,
            &scenario.events,
            localizers,
            options,
        )
    }

    /// Feeds `stream` (a live run or a recording whose run went through `events`) to the
    /// localizers of `scenario` built from this registry.
    pub fn run_stream(
        &self,
        scenario: &Scenario,
        seed: u64,
        stream: &mut dyn ReadingStream,
        events: &[Event],
        options: RunOptions,
    ) -> Result<RunResult, ScenarioError> {
        let localizers = self.build_all(scenario, seed)?;
        run_localizers(scenario, seed, stream, events, localizers, options)
    }
}

/// Runs `scenario` with Atrium's built-in localizer kinds (see
/// [`LocalizerRegistry::with_builtins`]; a user's kinds: [`LocalizerRegistry::run`]).
pub fn run_scenario(scenario: &Scenario, options: RunOptions) -> Result<RunResult, ScenarioError> {
    LocalizerRegistry::with_builtins().run(scenario, options)
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_localization::dead_reckoning::DeadReckoning;

    fn dead_reckoning(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
        Ok(Box::new(DeadReckoning::new(
            &ctx.spec.name,
            ctx.scenario.start,
        )))
    }

    fn corridor() -> Scenario {
        Scenario::load(&crate::bundled_scenarios_dir().join("corridor_tracking.toml")).unwrap()
    }

    #[test]
    fn a_kind_registered_twice_is_refused() {
        let mut r = LocalizerRegistry::empty();
        r.register("mine", dead_reckoning).unwrap();
        assert_eq!(
            r.register("mine", dead_reckoning).err(),
            Some(RegistryError::Duplicate("mine".into()))
        );
        let mut b = LocalizerRegistry::with_builtins();
        let e = b.register("mcl", dead_reckoning).unwrap_err();
        assert!(
            e.to_string().contains("\"mcl\" is registered already"),
            "{e}"
        );
    }

    #[test]
    fn kind_names_are_identifiers() {
        let mut r = LocalizerRegistry::empty();
        for bad in ["", "1x", "a b", "a/b", "ä"] {
            assert_eq!(
                r.register(bad, dead_reckoning).err(),
                Some(RegistryError::BadName(bad.into())),
                "{bad:?}"
            );
        }
        r.register("my-filter_2", dead_reckoning).unwrap();
    }

    #[test]
    fn an_unknown_kind_names_the_registered_ones_before_the_run() {
        let mut s = corridor();
        s.add_localizer("x", "mine", toml::Table::new(), toml::Table::new())
            .unwrap();
        let builtins = LocalizerRegistry::with_builtins();
        let e = builtins.check(&s).unwrap_err().to_string();
        assert!(e.contains("localizers[x].kind"), "{e}");
        assert!(e.contains("unknown localizer kind \"mine\""), "{e}");
        // The list is the registry's own, built-ins included.
        for k in builtins.kinds() {
            assert!(e.contains(k), "{k} missing from: {e}");
        }
        let mut mine = builtins.clone();
        mine.register("mine", dead_reckoning).unwrap();
        mine.check(&s).unwrap();
        assert!(
            !builtins.contains("mine"),
            "a clone is a registry of its own"
        );
    }

    #[test]
    fn a_users_kind_runs_and_is_judged_by_its_expect_table() {
        let mut s = corridor();
        s.duration_s = 20.0;
        s.localizers.retain(|l| l.kind == "dead_reckoning");
        s.expect = toml::Table::new();
        let expect: toml::Table = toml::from_str("median_max = 1e-6").unwrap();
        s.add_localizer("mine", "mine", toml::Table::new(), expect)
            .unwrap();
        let mut r = LocalizerRegistry::empty();
        r.register("mine", dead_reckoning)
            .unwrap()
            .register("dead_reckoning", dead_reckoning)
            .unwrap();
        let result = r.run(&s, RunOptions::default()).unwrap();
        let mine = result.localizers.iter().find(|l| l.name == "mine").unwrap();
        assert_eq!(mine.kind, "mine");
        // Dead reckoning drifts by far more than a micrometre in 20 s: the bound fails, so
        // the expectation was really evaluated against this localizer's run.
        assert_eq!(mine.expectations.len(), 1);
        assert!(!mine.passed);
        assert!(!result.passed());
    }

    #[test]
    fn a_recording_registry_lists_the_paths_its_factories_resolved() {
        fn reads_a_file(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
            let _ = ctx.path("weights.bin");
            dead_reckoning(ctx)
        }
        let mut r = LocalizerRegistry::empty();
        r.register("mine", reads_a_file).unwrap();
        let mut s = corridor();
        s.localizers.clear();
        s.expect = toml::Table::new();
        s.add_localizer("m", "mine", toml::Table::new(), toml::Table::new())
            .unwrap();
        r.build_all(&s, 1).unwrap();
        assert!(
            r.recorded_paths().is_empty(),
            "only a recording clone records"
        );
        let rec = r.recording_paths();
        rec.build_all(&s, 1).unwrap();
        let dir = s.file.parent().unwrap();
        assert_eq!(rec.recorded_paths(), [dir.join("weights.bin")]);
        assert!(r.recorded_paths().is_empty());
    }
}
