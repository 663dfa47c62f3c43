//! Pedestrians in recordings (issue 17): a run with `[people]` recorded in the Foxglove
//! profile has a `/people` topic of `foxglove.SceneUpdate`s at 10 Hz, one cylinder entity per
//! person, at the simulator's people positions; a run without people has no such topic.

#[allow(dead_code)] // this test uses only `tmpdir`
mod common;

use atrium_recordings as dataset;
use atrium_scenarios::{RunOptions, Scenario};
use common::tmpdir;
use foxglove::messages as fg;
use foxglove::Decode;

fn short(people: Option<f64>) -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join("people_corridor.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(3.0));
    match people {
        Some(d) => {
            let t = table["people"].as_table_mut().unwrap();
            t.insert("density".into(), toml::Value::Float(d));
        }
        None => {
            table.remove("people");
        }
    }
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).unwrap()
}

fn people_messages(scenario: &Scenario, tag: &str) -> Vec<(u64, fg::SceneUpdate, String)> {
    let out = tmpdir(tag).join("run.mcap");
    dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        scenario,
        &out,
        RunOptions::default(),
    )
    .unwrap();
    let bytes = std::fs::read(&out).unwrap();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .filter(|m| m.channel.topic == "/people")
        .map(|m| {
            let schema = m.channel.schema.as_ref().unwrap().name.clone();
            (
                m.log_time,
                fg::SceneUpdate::decode(&m.data[..]).unwrap(),
                schema,
            )
        })
        .collect()
}

#[test]
fn people_are_recorded_as_scene_entities() {
    let scenario = short(Some(5.0));
    let msgs = people_messages(&scenario, "people_mcap");
    // 3 s at 10 Hz.
    assert!((29..=31).contains(&msgs.len()), "{} updates", msgs.len());
    assert!(msgs.windows(2).all(|w| w[1].0 - w[0].0 == 100_000_000));
    let (_, first, schema) = &msgs[0];
    assert_eq!(schema, "foxglove.SceneUpdate");
    assert!(first.entities.len() > 3, "{} people", first.entities.len());
    for (i, e) in first.entities.iter().enumerate() {
        assert_eq!(e.id, format!("person/{i}"));
        assert_eq!(e.frame_id, "map");
        let c = &e.cylinders[0];
        let size = c.size.as_ref().unwrap();
        assert_eq!((size.x, size.z), (0.5, 1.7));
    }
    // The entities are where the simulator has its people (the runner's sim seed).
    let mut sim = atrium_sim::Simulation::new(
        &scenario.world,
        &scenario.robot,
        scenario.sim_config(atrium_scenarios::seeds::derive_seed(scenario.seed, "sim")),
    )
    .unwrap();
    let mut out = Vec::new();
    sim.step(&mut out);
    let (last_ns, last, _) = msgs.last().unwrap();
    // 200 Hz physics: 5 ms per step.
    let steps = (*last_ns as f64 / 5e6).round() as u64;
    while sim.steps() < steps {
        sim.step(&mut out);
        out.clear();
    }
    for (e, p) in last.entities.iter().zip(sim.people().unwrap().positions()) {
        let at = e.cylinders[0]
            .pose
            .as_ref()
            .unwrap()
            .position
            .as_ref()
            .unwrap();
        assert!(
            (at.x - p[0]).abs() < 1e-9 && (at.y - p[1]).abs() < 1e-9,
            "{at:?} vs {p:?}"
        );
    }
    // The robot moved while the people walked: a different update than the first.
    assert_ne!(first.entities, last.entities);

    assert!(people_messages(&short(None), "no_people_mcap").is_empty());
}
