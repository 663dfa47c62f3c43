//! Choosing between sensors ([004] §4): a localizer that runs several
//! member localizers side by side (laser CGR, depth CGR, WiFi, ...), feeds every reading to
//! all of them (each uses its own sensor) and at every sensor update outputs the estimate of
//! the member it chooses:
//!
//! - [`Strategy::Uncertainty`] (§4.1): the member with the smallest computed uncertainty, the
//!   trace of its xy covariance (particle spread for the particle filters);
//! - [`Strategy::Mismatch`] (§4.2): the member whose observations agree best with its belief,
//!   [`Capabilities::observation_fit`] (w_fast / w_slow, made scale-free per sensor: see
//!   `observation_fit.rs`); §4.2 itself warns this is not comparable across sensor types;
//! - [`Strategy::DataDriven`] (§4.3): the member with the lowest mean error in a per-location
//!   error map ([`ErrorMap`], §3 Figure 2), looked up at the current estimate;
//! - [`Strategy::Fused`] (beyond the paper): per region of the world, mixture weights w_k
//!   learnt by maximum likelihood (`mixture.rs`); the output is the mode of
//!   Σ_k w_k N(mean_k, Σ_k), approximated by evaluating the mixture at every member mean.
//!
//! Beyond the paper as well, re-seeding: once a member is chosen, every other member whose
//! estimate is inconsistent with the chosen one is re-seeded around it
//! ([`Capabilities::reset_to`]). Without it a laser filter lost in the atrium's open interior
//! stays lost in the corridors after it, where it would otherwise be the best sensor. The
//! test is on both uncertainties, d > k·√(σ²_member + σ²_chosen) and d > `min_distance_m`:
//! a gate on the member's own uncertainty alone would drag an accurate laser filter (σ of
//! centimetres) to every WiFi estimate a metre off whenever WiFi is chosen.
//!
//! Also beyond the paper, the anchor gate ([`Chooser::set_anchor_gate`]): members re-seeding
//! never moves (WiFi: an absolute sensor whose error is bounded) are anchors, and a member
//! whose estimate fails the same consistency test against an anchor cannot be chosen. It
//! answers §4.1's objection that uncertainties of different algorithms are not comparable: a
//! laser filter converged on the wrong spot reports centimetres, but it cannot report them
//! eight metres from where the WiFi filter, with its metre-wide spread, says the robot is.

use crate::error::LocalizationError;
use crate::error_map::ErrorMap;
use crate::localizer::{
    observation_fit_of, reset_localizer, Capabilities, Estimate, Localizer, LocalizerError,
    OdometryDelta,
};
use crate::mixture::{log_density_xy, RegionMixture};
use atrium_robots::{Pose2, Reading};
use std::sync::Arc;

/// How a [`Chooser`] picks its member.
#[derive(Debug, Clone)]
pub enum Strategy {
    /// Smallest trace of the xy covariance (004 §4.1).
    Uncertainty,
    /// Largest [`Capabilities::observation_fit`] (004 §4.2).
    Mismatch,
    /// Lowest mean error of the member's layer `layers[k]` of `map` near the current estimate
    /// (within `radius_cells`, see [`ErrorMap::mean_near`]) (004 §4.3).
    DataDriven {
        map: Arc<ErrorMap>,
        layers: Vec<usize>,
        radius_cells: usize,
    },
    /// Mode of the mixture of the members' Gaussians of the region at the current estimate,
    /// each covariance floored at the region's floor for that member (see
    /// [`log_density_xy`], [`RegionMixture`]).
    Fused { model: Arc<RegionMixture> },
}

impl Strategy {
    pub fn name(&self) -> &'static str {
        match self {
            Strategy::Uncertainty => "uncertainty",
            Strategy::Mismatch => "mismatch",
            Strategy::DataDriven { .. } => "data_driven",
            Strategy::Fused { .. } => "fused",
        }
    }
}

/// When and how members inconsistent with the chosen estimate are re-seeded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReseedParams {
    /// k of the consistency gate d > k·√(σ²_member + σ²_chosen), σ² the trace of the xy
    /// covariance. Default 3.
    pub gate_sigmas: f64,
    /// Never re-seed a member closer than this to the chosen estimate, m. Default 0.5.
    pub min_distance_m: f64,
    /// Floors of the re-seeded spread (the chosen member's standard deviations below these
    /// would make an overconfident copy of its error), m and rad. Defaults 0.3 and 0.1.
    pub min_sigma_xy: f64,
    pub min_sigma_theta: f64,
}

impl Default for ReseedParams {
    fn default() -> Self {
        Self {
            gate_sigmas: 3.0,
            min_distance_m: 0.5,
            min_sigma_xy: 0.3,
            min_sigma_theta: 0.1,
        }
    }
}

impl ReseedParams {
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("reseed_gate_sigmas", self.gate_sigmas),
            ("reseed_min_distance_m", self.min_distance_m),
            ("reseed_min_sigma_xy", self.min_sigma_xy),
            ("reseed_min_sigma_theta", self.min_sigma_theta),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} must be finite and >= 0, got {v}"));
            }
        }
        Ok(())
    }
}

/// Trace of the xy block of a covariance (NaN stays NaN).
fn xy_variance(e: &Estimate) -> f64 {
    e.covariance[(0, 0)] + e.covariance[(1, 1)]
}

/// A localizer that chooses, at every sensor update, one of its members' estimates.
pub struct Chooser {
    name: String,
    members: Vec<Box<dyn Localizer>>,
    strategy: Strategy,
    reseed: Option<ReseedParams>,
    /// Per member: whether re-seeding may move it (all by default).
    reseedable: Vec<bool>,
    chosen: usize,
    /// Per member: sensor updates at which it was chosen, and times it was re-seeded.
    choices: Vec<u64>,
    reseeds: Vec<u64>,
    /// Only members consistent with every anchor (a member not re-seedable) may be chosen.
    anchor_gate: bool,
    /// Scratch for the members' estimates (no allocation per update).
    estimates: Vec<Estimate>,
    /// The members' observation fits, refreshed with the estimates.
    fits: Vec<Option<f64>>,
}

/// The consistency test of re-seeding and of the anchor gate: `a` and `b` agree when they are
/// within `min_distance_m`, or within `gate_sigmas` of their combined xy spread. A NaN
/// distance (a broken member) disagrees.
fn consistent(a: &Estimate, b: &Estimate, r: &ReseedParams) -> bool {
    let d = a.pose.distance(&b.pose);
    let var = xy_variance(a).max(0.0) + xy_variance(b).max(0.0);
    d <= r.min_distance_m || d <= r.gate_sigmas * var.sqrt()
}

impl Chooser {
    /// `members` must be non-empty; a data-driven strategy needs one layer per member and a
    /// fused one a weight per member in every region.
    pub fn new(
        name: &str,
        members: Vec<Box<dyn Localizer>>,
        strategy: Strategy,
        reseed: Option<ReseedParams>,
    ) -> Result<Chooser, LocalizationError> {
        let k = members.len();
        if k == 0 {
            return Err(LocalizationError::InvalidParameter(
                "members must name at least one localizer".into(),
            ));
        }
        match &strategy {
            Strategy::DataDriven { map, layers, .. } => {
                if layers.len() != k || layers.iter().any(|l| *l >= map.localizers.len()) {
                    return Err(LocalizationError::InvalidParameter(format!(
                        "data_driven needs one error-map layer per member: {k} members, layers {layers:?} of {}",
                        map.localizers.len()
                    )));
                }
            }
            Strategy::Fused { model } => {
                if !model.is_consistent(k) {
                    return Err(LocalizationError::InvalidParameter(format!(
                        "fused needs one mixture weight and one positive floor per member ({k}) \
                         in every region"
                    )));
                }
            }
            Strategy::Uncertainty | Strategy::Mismatch => {}
        }
        if let Some(r) = &reseed {
            r.validate().map_err(LocalizationError::InvalidParameter)?;
        }
        let estimates = members.iter().map(|m| m.estimate()).collect();
        let fits = vec![None; members.len()];
        Ok(Chooser {
            name: name.to_owned(),
            members,
            strategy,
            reseed,
            reseedable: vec![true; k],
            chosen: 0,
            choices: vec![0; k],
            reseeds: vec![0; k],
            anchor_gate: false,
            estimates,
            fits,
        })
    }

    /// Which members re-seeding may move (one flag per member). A member with an absolute
    /// sensor (WiFi) is never lost for good, and re-seeding it could only import the chosen
    /// member's error: excluding it keeps it as an anchor the others are re-seeded against.
    pub fn set_reseedable(&mut self, mask: Vec<bool>) -> Result<(), LocalizationError> {
        if mask.len() != self.members.len() {
            return Err(LocalizationError::InvalidParameter(format!(
                "reseed_members: {} flags for {} members",
                mask.len(),
                self.members.len()
            )));
        }
        self.reseedable = mask;
        Ok(())
    }

    /// Whether only members consistent with every anchor (see [`Chooser::set_reseedable`])
    /// may be chosen; the test is re-seeding's (defaults when re-seeding is off).
    pub fn set_anchor_gate(&mut self, on: bool) {
        self.anchor_gate = on;
    }

    /// Whether member `k` may be chosen: always, unless the anchor gate is on and `k`
    /// disagrees with an anchor.
    fn eligible(&self, k: usize) -> bool {
        if !self.anchor_gate || !self.reseedable[k] {
            return true;
        }
        let r = self.reseed.unwrap_or_default();
        (0..self.members.len())
            .filter(|&a| !self.reseedable[a])
            .all(|a| consistent(&self.estimates[k], &self.estimates[a], &r))
    }

    /// Index of the member whose estimate is the output now.
    pub fn chosen(&self) -> usize {
        self.chosen
    }

    pub fn members(&self) -> &[Box<dyn Localizer>] {
        &self.members
    }

    pub fn strategy(&self) -> &Strategy {
        &self.strategy
    }

    /// Per member: the number of sensor updates at which it was chosen.
    pub fn choice_counts(&self) -> &[u64] {
        &self.choices
    }

    /// Per member: the number of times it was re-seeded.
    pub fn reseed_counts(&self) -> &[u64] {
        &self.reseeds
    }

    /// The member to output given the members' current estimates (in `self.estimates`);
    /// `None` keeps the current choice (no member has a usable score).
    fn choose(&self) -> Option<usize> {
        // (index, score): lower is better for every strategy (fit and density are negated).
        let score = |k: usize| -> Option<f64> {
            let e = &self.estimates[k];
            match &self.strategy {
                Strategy::Uncertainty => Some(xy_variance(e)),
                Strategy::Mismatch => self.fits[k].map(|f| -f),
                Strategy::DataDriven {
                    map,
                    layers,
                    radius_cells,
                } => {
                    let at = self.estimates[self.chosen].pose;
                    map.mean_near(layers[k], [at.x, at.y], *radius_cells)
                }
                Strategy::Fused { model } => {
                    let p = [e.pose.x, e.pose.y];
                    // One mixture for every candidate: the region's at the current estimate,
                    // as the data-driven chooser looks its map up. Looking it up at each
                    // candidate's own estimate compared densities of different mixtures: a
                    // lost laser filter whose estimate lay in a corridor was scored with the
                    // corridor's weights and centimetre floors, and won in the atrium.
                    let at = self.estimates[self.chosen].pose;
                    let g = model.group_at([at.x, at.y]);
                    let w = &g.weights;
                    // log Σ_j w_j N(p; mean_j, Σ_j) by log-sum-exp, in two passes (the terms
                    // are recomputed rather than stored: no allocation per update).
                    let term = |j: usize| -> f64 {
                        let other = &self.estimates[j];
                        if w[j] <= 0.0 {
                            return f64::NEG_INFINITY;
                        }
                        w[j].ln()
                            + log_density_xy(
                                [other.pose.x, other.pose.y],
                                &other.covariance,
                                g.floors_m[j],
                                p,
                            )
                    };
                    let n = self.estimates.len();
                    let max = (0..n).map(term).fold(f64::NEG_INFINITY, f64::max);
                    if !max.is_finite() {
                        return None;
                    }
                    let sum: f64 = (0..n).map(|j| (term(j) - max).exp()).sum();
                    Some(-(max + sum.ln()))
                }
            }
        };
        let mut best: Option<(usize, f64)> = None;
        for k in (0..self.members.len()).filter(|&k| self.eligible(k)) {
            if let Some(s) = score(k).filter(|s| !s.is_nan()) {
                if best.is_none_or(|(_, b)| s < b) {
                    best = Some((k, s));
                }
            }
        }
        // Data-driven with no map data near the current estimate: the estimate has left the
        // area the map was learnt on, which the drive never does — it is wrong. Keeping the
        // choice would lock onto the member that took it there (re-seeding drags the others
        // along), so fall back to an anchor, which re-seeding never moves.
        if best.is_none() && matches!(self.strategy, Strategy::DataDriven { .. }) {
            return self.reseedable.iter().position(|r| !r);
        }
        best.map(|(k, _)| k)
    }

    /// Re-seeds members inconsistent with the chosen estimate (see the module docs).
    fn reseed_members(&mut self, r: ReseedParams) {
        let c = self.chosen;
        let ec = self.estimates[c];
        let sigma = [
            ec.covariance[(0, 0)].max(0.0).sqrt().max(r.min_sigma_xy),
            ec.covariance[(1, 1)].max(0.0).sqrt().max(r.min_sigma_xy),
            ec.covariance[(2, 2)].max(0.0).sqrt().max(r.min_sigma_theta),
        ];
        for j in 0..self.members.len() {
            if j == c || !self.reseedable[j] {
                continue;
            }
            if !consistent(&self.estimates[j], &ec, &r)
                && reset_localizer(self.members[j].as_mut(), ec.pose, sigma)
            {
                self.reseeds[j] += 1;
                self.estimates[j] = self.members[j].estimate();
            }
        }
    }

    fn refresh_estimates(&mut self) {
        for ((e, f), m) in self
            .estimates
            .iter_mut()
            .zip(&mut self.fits)
            .zip(&mut self.members)
        {
            *e = m.estimate();
            *f = observation_fit_of(m.as_mut());
        }
    }
}

impl Localizer for Chooser {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        for m in &mut self.members {
            m.predict(delta)?;
        }
        Ok(())
    }

    /// Every member sees the reading; then the choice is made again, and inconsistent members
    /// are re-seeded.
    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        for m in &mut self.members {
            m.update(reading)?;
        }
        self.refresh_estimates();
        if let Some(k) = self.choose() {
            self.chosen = k;
        }
        self.choices[self.chosen] += 1;
        if let Some(r) = self.reseed {
            self.reseed_members(r);
        }
        Ok(())
    }

    fn estimate(&self) -> Estimate {
        self.members[self.chosen].estimate()
    }

    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl Capabilities for Chooser {
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn observation_fit(&self) -> Option<f64> {
        self.fits[self.chosen]
    }

    fn chosen_member(&self) -> Option<&str> {
        Some(self.members[self.chosen].name())
    }

    /// Re-seeds every member; true if any could be.
    fn reset_to(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        let mut any = false;
        for m in &mut self.members {
            any |= reset_localizer(m.as_mut(), pose, sigma);
        }
        any
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// A member with a fixed estimate, covariance and fit, that records re-seeding.
    struct Fake {
        name: String,
        pose: Pose2,
        var: f64,
        fit: Option<f64>,
        resets: usize,
    }

    fn fake(name: &str, x: f64, var: f64, fit: Option<f64>) -> Box<dyn Localizer> {
        Box::new(Fake {
            name: name.into(),
            pose: Pose2::new(x, 0.0, 0.0),
            var,
            fit,
            resets: 0,
        })
    }

    impl Localizer for Fake {
        fn name(&self) -> &str {
            &self.name
        }
        fn predict(&mut self, _delta: &OdometryDelta) -> Result<(), LocalizerError> {
            Ok(())
        }
        fn update(&mut self, _reading: &Reading) -> Result<(), LocalizerError> {
            Ok(())
        }
        fn estimate(&self) -> Estimate {
            Estimate {
                stamp: 0.0,
                pose: self.pose,
                covariance: Matrix3::from_diagonal(&nalgebra::Vector3::new(
                    self.var, self.var, 0.01,
                )),
            }
        }

        fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
            Some(self)
        }
    }

    impl Capabilities for Fake {
        fn as_any(&self) -> Option<&dyn std::any::Any> {
            Some(self)
        }

        fn observation_fit(&self) -> Option<f64> {
            self.fit
        }

        fn reset_to(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
            self.pose = pose;
            self.var = sigma[0] * sigma[0];
            self.resets += 1;
            true
        }
    }

    /// Weights with a 0.1 m floor for every component.
    fn group(w: &[f64]) -> crate::mixture::MixtureGroup {
        crate::mixture::MixtureGroup {
            weights: w.to_vec(),
            floors_m: vec![0.1; w.len()],
        }
    }

    fn scan() -> Reading {
        Reading::Laser(atrium_robots::LaserScan {
            stamp: 0.1,
            sensor: "laser".into(),
            mount: Pose2::default(),
            angle_min: 0.0,
            angle_increment: 0.01,
            range_min: 0.1,
            range_max: 8.0,
            ranges: vec![],
        })
    }

    /// Laser (x = 0, tight, poor fit), depth (x = 0.2, medium, best fit), WiFi (x = 5, wide).
    fn members() -> Vec<Box<dyn Localizer>> {
        vec![
            fake("laser", 0.0, 1e-4, Some(0.2)),
            fake("depth", 0.2, 1e-2, Some(1.1)),
            fake("wifi", 5.0, 1.0, None),
        ]
    }

    fn chosen_after_update(strategy: Strategy) -> usize {
        let mut c = Chooser::new("c", members(), strategy, None).unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.choice_counts()[c.chosen()], 1);
        assert_eq!(
            Capabilities::chosen_member(&c),
            Some(c.members()[c.chosen()].name())
        );
        c.chosen()
    }

    #[test]
    fn uncertainty_picks_the_smallest_covariance() {
        assert_eq!(chosen_after_update(Strategy::Uncertainty), 0);
    }

    #[test]
    fn mismatch_picks_the_best_fit_and_skips_members_without_one() {
        assert_eq!(chosen_after_update(Strategy::Mismatch), 1);
    }

    #[test]
    fn data_driven_picks_the_lowest_mapped_error_at_the_estimate() {
        let names = vec!["wifi".to_string(), "laser".into(), "depth".into()];
        let mut map = ErrorMap::new([-10.0, -10.0], [10.0, 10.0], 1.0, names).unwrap();
        // Near the estimate (0, 0): WiFi 0.8 m, laser 2 m, depth 0.5 m; far away the laser is
        // best, which must not matter.
        map.add(0, [0.5, 0.5], 0.8);
        map.add(1, [0.5, 0.5], 2.0);
        map.add(2, [0.5, 0.5], 0.5);
        map.add(1, [8.5, 8.5], 0.01);
        let strategy = Strategy::DataDriven {
            map: Arc::new(map),
            // Member order laser, depth, wifi -> layers 1, 2, 0.
            layers: vec![1, 2, 0],
            radius_cells: 1,
        };
        assert_eq!(chosen_after_update(strategy), 1);
    }

    /// Where the map has nothing near the current estimate (it has left the mapped area),
    /// the data-driven chooser falls back to the anchor instead of keeping its choice.
    #[test]
    fn data_driven_falls_back_to_the_anchor_off_the_map() {
        let names = vec!["wifi".to_string(), "laser".into(), "depth".into()];
        let mut map = ErrorMap::new([-10.0, -10.0], [10.0, 10.0], 1.0, names).unwrap();
        map.add(1, [8.5, 8.5], 0.01);
        let strategy = Strategy::DataDriven {
            map: Arc::new(map),
            layers: vec![1, 2, 0],
            radius_cells: 1,
        };
        let mut c = Chooser::new("c", members(), strategy, None).unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.chosen(), 0, "without an anchor the choice is kept");
        c.set_reseedable(vec![true, true, false]).unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.chosen(), 2);
    }

    #[test]
    fn fused_picks_the_mode_of_the_weighted_mixture() {
        // Laser and depth agree near x = 0; WiFi is at 5. With weight on WiFi alone the mode is
        // WiFi's mean; with the weight spread over all, the two agreeing members win.
        let only_wifi = RegionMixture {
            regions: vec![],
            default: group(&[0.0, 0.0, 1.0]),
        };
        let strategy = |m: RegionMixture| Strategy::Fused { model: Arc::new(m) };
        assert_eq!(chosen_after_update(strategy(only_wifi)), 2);
        // Region weights apply where the member's mean lies: inside the square around the
        // origin WiFi has no weight.
        let by_region = RegionMixture {
            regions: vec![(
                vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]],
                group(&[0.5, 0.5, 0.0]),
            )],
            default: group(&[0.0, 0.0, 1.0]),
        };
        // Laser's mean (0, 0): 0.5·N(0; 0, 0.01) + 0.5·N(0; 0.2, 0.01) — far above WiFi's
        // density at its own mean, 1·N(5; 5, 1).
        assert_eq!(chosen_after_update(strategy(by_region)), 0);
    }

    /// WiFi (x = 5, σ = 1 m) is the anchor: the laser and depth (x ≈ 0) are 5 m from it,
    /// beyond 3 σ, so the anchor gate leaves only WiFi; once the laser agrees with it, the
    /// laser's smaller spread wins again.
    #[test]
    fn anchor_gate_refuses_members_that_disagree_with_the_anchor() {
        let mut c = Chooser::new("c", members(), Strategy::Uncertainty, None).unwrap();
        c.set_reseedable(vec![true, true, false]).unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.chosen(), 0, "without the gate the tightest member wins");
        c.set_anchor_gate(true);
        c.update(&scan()).unwrap();
        assert_eq!(c.chosen(), 2);
        let near = vec![
            fake("laser", 3.5, 1e-4, None),
            fake("depth", 0.2, 1e-2, None),
            fake("wifi", 5.0, 1.0, None),
        ];
        let mut c = Chooser::new("c", near, Strategy::Uncertainty, None).unwrap();
        c.set_reseedable(vec![true, true, false]).unwrap();
        c.set_anchor_gate(true);
        c.update(&scan()).unwrap();
        assert_eq!(c.chosen(), 0);
    }

    #[test]
    fn reseeding_moves_a_lost_member_and_leaves_consistent_ones() {
        // The WiFi member is chosen (only it has weight); the laser and depth members, 5 m away
        // with small covariances, are inconsistent with it and are moved there.
        let strategy = Strategy::Fused {
            model: Arc::new(RegionMixture {
                regions: vec![],
                default: group(&[0.0, 0.0, 1.0]),
            }),
        };
        let mut c = Chooser::new("c", members(), strategy, Some(ReseedParams::default())).unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.chosen(), 2);
        assert_eq!(c.reseed_counts(), &[1, 1, 0]);
        for m in &c.members()[..2] {
            let e = m.estimate();
            assert!((e.pose.x - 5.0).abs() < 1e-12);
            // Spread: WiFi's σ = 1 m (above the 0.3 m floor).
            assert!((e.covariance[(0, 0)] - 1.0).abs() < 1e-12);
        }
        // Now all agree: a second update re-seeds nothing.
        c.update(&scan()).unwrap();
        assert_eq!(c.reseed_counts(), &[1, 1, 0]);

        // The laser chosen (uncertainty): WiFi 5 m off with σ = 1 m is beyond 3·√(1 + 1e-4)
        // and is re-seeded; depth 0.2 m off is within min_distance_m and is left alone.
        let mut c = Chooser::new(
            "c",
            members(),
            Strategy::Uncertainty,
            Some(ReseedParams::default()),
        )
        .unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.reseed_counts(), &[0, 0, 1]);
        let wifi = c.members()[2].estimate();
        assert!(wifi.pose.x.abs() < 1e-12);
        // ... with the floored spread, not the laser's centimetres.
        assert!((wifi.covariance[(0, 0)] - 0.09).abs() < 1e-12);

        // Without re-seeding nothing moves.
        let mut c = Chooser::new("c", members(), Strategy::Uncertainty, None).unwrap();
        c.update(&scan()).unwrap();
        assert_eq!(c.reseed_counts(), &[0, 0, 0]);
        assert_eq!(c.estimate().pose.x, 0.0);
    }

    #[test]
    fn bad_construction_is_an_error() {
        assert!(Chooser::new("c", vec![], Strategy::Uncertainty, None).is_err());
        let map = ErrorMap::new([0.0, 0.0], [1.0, 1.0], 1.0, vec!["a".into()]).unwrap();
        let dd = Strategy::DataDriven {
            map: Arc::new(map),
            layers: vec![0, 1, 0],
            radius_cells: 0,
        };
        let e = Chooser::new("c", members(), dd, None).err().unwrap();
        assert!(e.to_string().contains("layer"), "{e}");
        let fused = Strategy::Fused {
            model: Arc::new(RegionMixture {
                regions: vec![],
                default: group(&[1.0]),
            }),
        };
        assert!(Chooser::new("c", members(), fused, None).is_err());
        let bad = ReseedParams {
            gate_sigmas: -1.0,
            ..Default::default()
        };
        let e = Chooser::new("c", members(), Strategy::Mismatch, Some(bad))
            .err()
            .unwrap();
        assert!(e.to_string().contains("reseed_gate_sigmas"), "{e}");
    }
}
