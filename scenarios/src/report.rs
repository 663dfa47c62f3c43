//! What a run reports: a human table and one stable JSON document.

use crate::metrics::ErrorStats;
use crate::runner::RunResult;
use serde_json::{json, Value};
use std::fmt::Write;

fn stats_json(s: &ErrorStats) -> Value {
    json!({
        "samples": s.samples,
        "min": s.min,
        "median": s.median,
        "mean": s.mean,
        "rmse": s.rmse,
        "p95": s.p95,
        "max": s.max,
    })
}

/// The `--json` document. Everything but `timing` is a pure function of scenario and seed.
pub fn to_json(r: &RunResult) -> Value {
    let localizers: Vec<Value> = r
        .localizers
        .iter()
        .map(|l| {
            let m = l.metrics.as_ref();
            json!({
                "name": l.name,
                "kind": l.kind,
                "passed": l.passed,
                "position_error": m.map(|m| stats_json(&m.position_error)),
                "heading_error": m.map(|m| stats_json(&m.heading_error)),
                "final_position_error": m.map(|m| m.final_position_error),
                "per_region": m.map(|m| m.per_region.iter().map(|(k, v)| (k.clone(), stats_json(v))).collect::<serde_json::Map<_, _>>()),
                "per_region_kind": m.map(|m| m.per_region_kind.iter().map(|(k, v)| (k.clone(), stats_json(v))).collect::<serde_json::Map<_, _>>()),
                "converged_after_s": m.and_then(|m| m.converged_after_s),
                "after_convergence": m.and_then(|m| m.after_convergence.as_ref().map(stats_json)),
                "mean_nees_xy": m.and_then(|m| m.mean_nees_xy),
                "chosen": m.and_then(|m| (!m.chosen.is_empty()).then(|| m.chosen.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>())),
                "recoveries": r.events.iter().zip(&l.recoveries).map(|(e, rec)| json!({
                    "kind": e.kind(),
                    "at_s": e.at_s(),
                    "recovered_after_s": rec,
                })).collect::<Vec<_>>(),
                "expectations": l.expectations,
                "slam": l.slam.as_ref().map(crate::slam::to_json),
                "relations": l.relations,
            })
        })
        .collect();
    json!({
        "scenario": r.scenario,
        "description": r.description,
        "seed": r.seed,
        "world": r.world,
        "robot": r.robot,
        "sim_time_s": r.sim_time_s,
        "distance_m": r.distance_m,
        "route_completed": r.route_completed,
        "passed": r.passed(),
        "log": r.log,
        "localizers": localizers,
        "timing": {
            "wall_s": r.timing.wall_s,
            "real_time_factor": r.timing.real_time_factor,
            "physics_steps": r.timing.physics_steps,
            "sim_s": r.timing.sim_s,
            "localizers_s": r.timing.localizers_s.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        },
    })
}

fn opt(v: Option<f64>, unit: &str) -> String {
    match v {
        Some(v) => format!("{v:.3}{unit}"),
        None => "never".into(),
    }
}

/// The human-readable report.
pub fn to_text(r: &RunResult) -> String {
    let mut s = String::new();
    match &r.log {
        Some(log) => {
            let _ = writeln!(
                s,
                "scenario {} (seed {}): real log {} ({} scans on {}, odometry {}), {:.1} s, \
                 {:.1} m along the reference",
                r.scenario,
                r.seed,
                log.path,
                log.scans,
                log.scan_topic,
                log.odom_topic,
                r.sim_time_s,
                r.distance_m,
            );
            let _ = writeln!(
                s,
                "scored against {} at {} instants; {} scans not covered by it are not scored",
                log.reference, log.scored_instants, log.unscored_scans
            );
            if let Some(a) = &log.reference_accuracy {
                let _ = writeln!(
                    s,
                    "reference accuracy {:.3} m ({}): smaller errors are shown as <{:.3}",
                    a.position_m, a.source, a.position_m
                );
            }
        }
        None => {
            let _ = writeln!(
                s,
                "scenario {} (seed {}): {} in {}, {:.1} s simulated, {:.1} m driven{}",
                r.scenario,
                r.seed,
                r.robot,
                r.world,
                r.sim_time_s,
                r.distance_m,
                if r.route_completed {
                    ""
                } else {
                    " (route NOT completed)"
                }
            );
        }
    }
    if !r.description.is_empty() {
        let _ = writeln!(s, "{}", r.description);
    }
    // On a real log, no figure claims more precision than the reference has.
    let floor = r
        .log
        .as_ref()
        .and_then(|l| l.reference_accuracy.as_ref())
        .map(|a| a.position_m);
    let m3 = |v: f64| match floor {
        Some(f) if v < f => format!("<{f:.3}"),
        _ => format!("{v:.3}"),
    };
    let _ = writeln!(s, "\nposition error (m)");
    let _ = writeln!(
        s,
        "{:<18} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>10}",
        "localizer", "min", "median", "rmse", "p95", "max", "final", "converged"
    );
    for l in &r.localizers {
        if let Some(m) = &l.metrics {
            let p = &m.position_error;
            let _ = writeln!(
                s,
                "{:<18} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>10}",
                l.name,
                m3(p.min),
                m3(p.median),
                m3(p.rmse),
                m3(p.p95),
                m3(p.max),
                m3(m.final_position_error),
                opt(m.converged_after_s, " s")
            );
        }
    }
    if r.localizers.iter().any(|l| l.relations.is_some()) {
        let _ = writeln!(
            s,
            "\nrelations error [Kümmerle 2009] (mean ± std)\n{:<18} {:>20} {:>20} {:>9}",
            "localizer", "translation (m)", "rotation (deg)", "relations"
        );
        for l in &r.localizers {
            if let Some(x) = &l.relations {
                let _ = writeln!(
                    s,
                    "{:<18} {:>20} {:>20} {:>9}",
                    l.name,
                    format!("{:.3} ± {:.3}", x.trans_mean_m, x.trans_std_m),
                    format!("{:.2} ± {:.2}", x.rot_mean_deg, x.rot_std_deg),
                    x.count
                );
            }
        }
    }
    let mut regions: Vec<&String> = r
        .localizers
        .iter()
        .filter_map(|l| l.metrics.as_ref())
        .flat_map(|m| m.per_region.keys())
        .collect();
    regions.sort();
    regions.dedup();
    if !regions.is_empty() {
        let _ = writeln!(s, "\nmedian / max position error per region (m)");
        let _ = write!(s, "{:<22}", "region");
        for l in &r.localizers {
            let _ = write!(s, " {:>20}", l.name);
        }
        let _ = writeln!(s);
        for region in regions {
            let _ = write!(s, "{region:<22}");
            for l in &r.localizers {
                let cell = l
                    .metrics
                    .as_ref()
                    .and_then(|m| m.per_region.get(region))
                    .map(|e| format!("{:.3} / {:.3}", e.median, e.max))
                    .unwrap_or_else(|| "-".into());
                let _ = write!(s, " {cell:>20}");
            }
            let _ = writeln!(s);
        }
    }
    let choosers: Vec<_> = r
        .localizers
        .iter()
        .filter_map(|l| l.metrics.as_ref().map(|m| (l, &m.chosen)))
        .filter(|(_, c)| !c.is_empty())
        .collect();
    if !choosers.is_empty() {
        let _ = writeln!(s, "\nshare of time each member was chosen");
        for (l, chosen) in choosers {
            let shares: Vec<String> = chosen
                .iter()
                .map(|(m, v)| format!("{m} {:.0} %", 100.0 * v))
                .collect();
            let _ = writeln!(s, "{:<22} {}", l.name, shares.join(", "));
        }
    }
    for (l, ev) in r
        .localizers
        .iter()
        .flat_map(|l| l.recoveries.iter().zip(&r.events).map(move |x| (l, x)))
    {
        let _ = writeln!(
            s,
            "{}: {} at {:.1} s, recovered after {}",
            l.name,
            ev.1.kind(),
            ev.1.at_s(),
            opt(*ev.0, " s")
        );
    }
    for l in &r.localizers {
        if let Some(slam) = &l.slam {
            s.push_str(&crate::slam::to_text(&l.name, slam));
        }
    }
    let any = r.localizers.iter().any(|l| !l.expectations.is_empty());
    if any {
        let _ = writeln!(s, "\nexpectations");
        for l in &r.localizers {
            for e in &l.expectations {
                let op = match e.bound {
                    crate::expect::Bound::Max => "<=",
                    crate::expect::Bound::Min => ">=",
                };
                let _ = writeln!(
                    s,
                    "  [{}] {}: {} = {} {} {}",
                    if e.passed { "pass" } else { "FAIL" },
                    l.name,
                    e.metric,
                    e.value
                        .map(|v| format!("{v:.4}"))
                        .unwrap_or_else(|| "none".into()),
                    op,
                    e.limit
                );
            }
        }
        let _ = writeln!(
            s,
            "{}",
            if r.passed() {
                "all expectations met"
            } else {
                "EXPECTATIONS NOT MET"
            }
        );
    }
    let _ = writeln!(
        s,
        "\ntiming: {:.2} s wall, {:.1}x real time ({} physics steps)",
        r.timing.wall_s, r.timing.real_time_factor, r.timing.physics_steps
    );
    s
}
