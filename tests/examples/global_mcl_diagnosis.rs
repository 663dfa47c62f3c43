//! Diagnosis of a globally localizing MCL (issue 16, finding 7): where the particle weight
//! sits against ground truth over a run. Run with `DIAG_SCENARIO=<scenario> DIAG_SEEDS=1,2
//! DIAG_EVERY=2.0 cargo run --release -p atrium-tests --example global_mcl_diagnosis`.
//! Prints, every `DIAG_EVERY` seconds of laser updates: the particle count, the weight within
//! 1 m and 20° of the true pose ("near"), the number of particles there, the effective sample
//! size and the estimate's error. It asserts nothing.

#[path = "diag/mod.rs"]
mod diag;

use atrium_localization::{Mcl, ParticleFilter};
use atrium_robots::{normalize_angle, Pose2, Reading};
use atrium_scenarios::runner::SimStream;
use atrium_scenarios::{
    run_localizers, Capabilities, Estimate, Localizer, LocalizerError, LocalizerRegistry,
    OdometryDelta, RunOptions, Scenario,
};
use std::sync::{Arc, Mutex};

struct Spy {
    inner: Box<dyn Localizer>,
    truth: Arc<Mutex<Pose2>>,
    every: f64,
    next_print: f64,
}

impl Localizer for Spy {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn predict(&mut self, d: &OdometryDelta) -> Result<(), LocalizerError> {
        self.inner.predict(d)
    }
    fn update(&mut self, r: &Reading) -> Result<(), LocalizerError> {
        self.inner.update(r)?;
        let Reading::Laser(l) = r else { return Ok(()) };
        if l.stamp < self.next_print {
            return Ok(());
        }
        self.next_print = l.stamp + self.every;
        let tr = *self.truth.lock().unwrap();
        let est = self.inner.estimate().pose;
        let Some(mcl) = self
            .inner
            .capabilities()
            .and_then(|c| c.as_any())
            .and_then(|a| a.downcast_ref::<Mcl>())
        else {
            return Ok(());
        };
        // The model's log-likelihood of this scan at the true pose, at the best particle and
        // at the best particle near the truth.
        let poses: Vec<Pose2> = mcl.particles().map(|(p, _)| p).collect();
        let ll = mcl.scan_log_likelihoods(l, &poses);
        let at_truth = mcl.scan_log_likelihoods(l, &[tr])[0];
        let near =
            |p: &Pose2| p.distance(&tr) < 1.0 && normalize_angle(p.theta - tr.theta).abs() < 0.35;
        let best = ll.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let best_near = poses
            .iter()
            .zip(&ll)
            .filter(|(p, _)| near(p))
            .map(|(_, l)| *l)
            .fold(f64::NEG_INFINITY, f64::max);
        let (mut near_w, mut near_n, mut total, mut sq, mut n) = (0.0, 0, 0.0, 0.0, 0);
        for (p, w) in mcl.particles() {
            total += w;
            sq += w * w;
            n += 1;
            if near(&p) {
                near_w += w;
                near_n += 1;
            }
        }
        // Where the scan prefers another pose than the truth by more than DIAG_BEAMS nats:
        // each beam's log-likelihood at the truth and at the best particle.
        if let Ok(gap) = std::env::var("DIAG_BEAMS") {
            let gap: f64 = gap.parse().expect("DIAG_BEAMS: nats");
            if best - at_truth > gap {
                let best_pose =
                    poses[ll
                        .iter()
                        .enumerate()
                        .fold(0, |b, (i, v)| if *v > ll[b] { i } else { b })];
                for i in 0..l.ranges.len() {
                    let mut one = l.clone();
                    for (k, r) in one.ranges.iter_mut().enumerate() {
                        if k != i {
                            *r = f64::NAN;
                        }
                    }
                    let v = mcl.scan_log_likelihoods(&one, &[tr, best_pose]);
                    if (v[0] - v[1]).abs() > 0.5 {
                        println!(
                            "    beam {i:3} angle {:6.1} range {:.3}: truth {:.2} best {:.2}",
                            l.beam_angle(i).to_degrees(),
                            l.ranges[i],
                            v[0],
                            v[1]
                        );
                    }
                }
            }
        }
        println!(
            "t {:6.1} n {:6} near {:.3} ({:5} particles) ess {:7.0} err {:6.2} m truth ({:5.1},{:5.1},{:4.0}) est ({:5.1},{:5.1},{:4.0}) inj {:.3} ll truth {:.1} best {:.1} best near {:.1}",
            l.stamp,
            n,
            near_w / total,
            near_n,
            total * total / sq,
            est.distance(&tr),
            tr.x,
            tr.y,
            tr.theta.to_degrees(),
            est.x,
            est.y,
            est.theta.to_degrees(),
            mcl.injection_probability(),
            at_truth,
            best,
            best_near,
        );
        Ok(())
    }
    fn estimate(&self) -> Estimate {
        self.inner.estimate()
    }
    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        self.inner.capabilities()
    }
}

fn main() {
    let path = diag::scenario_path("global_localization.toml");
    let seeds = diag::seeds();
    let every: f64 = std::env::var("DIAG_EVERY")
        .map(|s| s.parse().expect("DIAG_EVERY: seconds"))
        .unwrap_or(2.0);
    let scenario = Scenario::load(std::path::Path::new(&path)).expect("the scenario loads");
    let registry = LocalizerRegistry::with_builtins();
    for seed in seeds {
        println!("seed {seed}");
        let mut one = scenario.clone();
        one.expect.clear();
        let truth = Arc::new(Mutex::new(one.start));
        let mut built = registry
            .build_all(&one, seed)
            .expect("the localizers build");
        let inner = built.remove(0);
        let spy = Spy {
            inner,
            truth: truth.clone(),
            every,
            next_print: 0.0,
        };
        let mut stream = SimStream::new(&one, seed).expect("the simulation starts");
        let mut obs = diag::LatestTruth(truth);
        run_localizers(
            &one,
            seed,
            &mut stream,
            &[],
            std::iter::once(Box::new(spy) as Box<dyn Localizer>)
                .chain(built)
                .collect(),
            RunOptions {
                seed: Some(seed),
                observer: Some(&mut obs),
                ..Default::default()
            },
        )
        .expect("the run completes");
    }
}
