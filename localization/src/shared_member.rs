//! One filter for every chooser that names the same member, copied when a chooser re-seeds it.
//!
//! A chooser's members are seeded like the stand-alone localizers of the same name, so that
//! its comparison with them is paired ([004] §4; `chooser.rs`): until a chooser re-seeds a
//! member, that member computes exactly what the stand-alone localizer does. Five choosers
//! over laser, depth and WiFi therefore ran each of the three filters six times over. A
//! [`SharedMember`] is a handle on one filter (a node); every holder gives it the same
//! odometry and readings and the node takes each once. Re-seeding through a handle that
//! shares its node copies the node first (its random streams included) and moves that handle
//! to the copy, so the other holders go on undisturbed. Holders that re-seed the same node
//! after the same reading with the same pose and spread share that copy too: the same state
//! re-seeded with the same arguments is the same filter. Every holder thus sees bit for bit
//! what a private instance would have given it, at the cost of the distinct filters alone.

use crate::localizer::{
    observation_fit_of, reset_localizer, Capabilities, Estimate, Localizer, LocalizerError,
    OdometryDelta,
};
use atrium_robots::{Pose2, Reading};
use std::sync::{Arc, Mutex, MutexGuard, Weak};

/// The bits of a re-seeding's pose and spread: copies re-seeded with equal bits are equal.
type ReseedKey = [u64; 6];

fn reseed_key(pose: Pose2, sigma: [f64; 3]) -> ReseedKey {
    [
        pose.x.to_bits(),
        pose.y.to_bits(),
        pose.theta.to_bits(),
        sigma[0].to_bits(),
        sigma[1].to_bits(),
        sigma[2].to_bits(),
    ]
}

/// A re-seeded copy of a node, reusable by holders that re-seed the node the same way.
struct Copy {
    key: ReseedKey,
    node: Weak<Mutex<Node>>,
    /// The copy's `in_place` when it was made: re-seeded in place since, it is another filter.
    in_place: u64,
}

struct Node {
    localizer: Box<dyn Localizer>,
    /// Odometry deltas and readings taken so far.
    taken: u64,
    /// Times its only holder re-seeded it in place.
    in_place: u64,
    /// Re-seeded copies made after the `copied_after`-th delta or reading.
    copied_after: u64,
    copies: Vec<Copy>,
}

fn lock(node: &Mutex<Node>) -> MutexGuard<'_, Node> {
    node.lock().unwrap_or_else(|p| p.into_inner())
}

/// A handle on a member filter shared by several localizers of a run (see the module docs).
/// Every handle on a node must be given the same odometry deltas and readings, in the same
/// order, as the runner gives every localizer; a handle that falls out of step is an error.
pub struct SharedMember {
    node: Arc<Mutex<Node>>,
    /// Odometry deltas and readings given to this handle.
    given: u64,
    name: String,
}

impl SharedMember {
    /// A node holding `localizer`, and the first handle on it.
    pub fn new(localizer: Box<dyn Localizer>) -> SharedMember {
        let name = localizer.name().to_owned();
        SharedMember {
            node: Arc::new(Mutex::new(Node {
                localizer,
                taken: 0,
                in_place: 0,
                copied_after: 0,
                copies: Vec::new(),
            })),
            given: 0,
            name,
        }
    }

    /// Another handle on the same node, in step with this one.
    pub fn share(&self) -> SharedMember {
        SharedMember {
            node: self.node.clone(),
            given: self.given,
            name: self.name.clone(),
        }
    }

    /// Whether the filter can be copied, and so re-seeded through a handle that shares it.
    pub fn can_copy(&self) -> bool {
        let mut node = lock(&self.node);
        node.localizer
            .capabilities()
            .and_then(|c| c.clone_localizer())
            .is_some()
    }

    /// Whether another handle holds this handle's filter.
    pub fn is_shared(&self) -> bool {
        Arc::strong_count(&self.node) > 1
    }

    /// Whether `other` holds the same filter as this handle.
    pub fn same_filter(&self, other: &SharedMember) -> bool {
        Arc::ptr_eq(&self.node, &other.node)
    }

    /// Gives the node the handle's next delta or reading, unless another holder already did.
    fn step(
        &mut self,
        take: impl FnOnce(&mut dyn Localizer) -> Result<(), LocalizerError>,
    ) -> Result<(), LocalizerError> {
        self.given += 1;
        let mut node = lock(&self.node);
        if node.taken + 1 == self.given {
            take(node.localizer.as_mut())?;
            node.taken = self.given;
            Ok(())
        } else if node.taken == self.given {
            Ok(())
        } else {
            Err(LocalizerError::new(format!(
                "{}: a shared member was given its {}th odometry delta or reading while its \
                 filter has taken {}: its holders must be given the same stream",
                self.name, self.given, node.taken
            )))
        }
    }
}

impl Localizer for SharedMember {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        self.step(|l| l.predict(delta))
    }

    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        self.step(|l| l.update(reading))
    }

    fn estimate(&self) -> Estimate {
        lock(&self.node).localizer.estimate()
    }

    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl Capabilities for SharedMember {
    /// The handle itself (the filter behind it is locked away).
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn take_node_verification(&mut self) -> Option<usize> {
        let mut node = lock(&self.node);
        node.localizer
            .capabilities()
            .and_then(|c| c.take_node_verification())
    }

    fn observation_fit(&self) -> Option<f64> {
        observation_fit_of(lock(&self.node).localizer.as_mut())
    }

    /// Re-seeds this holder's filter: in place when no other handle holds it, else a copy
    /// (shared with holders that re-seed it the same way after the same reading). False,
    /// changing nothing, when the filter cannot be re-seeded, or is shared and cannot be
    /// copied.
    fn reset_to(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        if !self.is_shared() {
            let mut node = lock(&self.node);
            let done = reset_localizer(node.localizer.as_mut(), pose, sigma);
            if done {
                // Copies made from the state before are not copies of this one.
                node.in_place += 1;
                node.copies.clear();
            }
            return done;
        }
        let key = reseed_key(pose, sigma);
        let mut node = lock(&self.node);
        if node.copied_after != self.given {
            node.copies.clear();
            node.copied_after = self.given;
        }
        let made = node.copies.iter().find_map(|c| {
            let copy = c.node.upgrade().filter(|_| c.key == key)?;
            let unchanged = lock(&copy).in_place == c.in_place;
            unchanged.then_some(copy)
        });
        if let Some(copy) = made {
            drop(node);
            self.node = copy;
            return true;
        }
        let Some(mut copy) = node
            .localizer
            .capabilities()
            .and_then(|c| c.clone_localizer())
        else {
            return false;
        };
        if !reset_localizer(copy.as_mut(), pose, sigma) {
            return false;
        }
        let copy = Arc::new(Mutex::new(Node {
            localizer: copy,
            taken: node.taken,
            in_place: 0,
            copied_after: 0,
            copies: Vec::new(),
        }));
        node.copies.push(Copy {
            key,
            node: Arc::downgrade(&copy),
            in_place: 0,
        });
        drop(node);
        self.node = copy;
        true
    }

    fn log(&mut self) -> Option<String> {
        let mut node = lock(&self.node);
        node.localizer.capabilities().and_then(|c| c.log())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// A filter whose pose is its odometry count plus ten times its reading count, with a
    /// random-stream stand-in (`draws`) that every re-seed advances, so that the order and
    /// number of calls is visible in its estimate.
    #[derive(Clone)]
    struct Counter {
        x: f64,
        draws: u64,
        clonable: bool,
    }

    impl Localizer for Counter {
        fn name(&self) -> &str {
            "counter"
        }
        fn predict(&mut self, _delta: &OdometryDelta) -> Result<(), LocalizerError> {
            self.x += 1.0;
            Ok(())
        }
        fn update(&mut self, _reading: &Reading) -> Result<(), LocalizerError> {
            self.x += 10.0;
            Ok(())
        }
        fn estimate(&self) -> Estimate {
            Estimate {
                stamp: self.draws as f64,
                pose: Pose2::new(self.x, 0.0, 0.0),
                covariance: Matrix3::identity(),
            }
        }
        fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
            Some(self)
        }
    }

    impl Capabilities for Counter {
        fn reset_to(&mut self, pose: Pose2, _sigma: [f64; 3]) -> bool {
            self.draws += 1;
            self.x = pose.x + self.draws as f64 * 1e-3;
            true
        }
        fn clone_localizer(&self) -> Option<Box<dyn Localizer>> {
            self.clonable
                .then(|| Box::new(self.clone()) as Box<dyn Localizer>)
        }
    }

    fn counter(clonable: bool) -> SharedMember {
        SharedMember::new(Box::new(Counter {
            x: 0.0,
            draws: 0,
            clonable,
        }))
    }

    fn delta() -> OdometryDelta {
        OdometryDelta {
            stamp: 0.0,
            from: Pose2::default(),
            to: Pose2::default(),
        }
    }

    fn reading() -> Reading {
        Reading::Wifi(atrium_robots::WifiScan {
            stamp: 0.0,
            sensor: "wifi".into(),
            readings: vec![],
        })
    }

    fn x(m: &SharedMember) -> f64 {
        m.estimate().pose.x
    }

    const SIGMA: [f64; 3] = [0.3, 0.3, 0.1];

    #[test]
    fn holders_of_one_filter_apply_each_delta_and_reading_once() {
        let mut a = counter(true);
        let mut b = a.share();
        for m in [&mut a, &mut b] {
            m.predict(&delta()).unwrap();
        }
        for m in [&mut a, &mut b] {
            m.update(&reading()).unwrap();
        }
        assert_eq!((x(&a), x(&b)), (11.0, 11.0));
        assert!(a.same_filter(&b));
        // A holder given a reading the other was not is out of step: an error, not a silent
        // skip.
        a.update(&reading()).unwrap();
        a.update(&reading()).unwrap();
        let e = b.update(&reading()).unwrap_err();
        assert!(e.0.contains("must be given the same stream"), "{e}");
    }

    /// Re-seeding a shared filter copies it for that holder alone; the other keeps the filter
    /// as it was, and both go on as private instances would.
    #[test]
    fn reseeding_a_shared_filter_copies_it() {
        let mut a = counter(true);
        let mut b = a.share();
        let private = || Counter {
            x: 0.0,
            draws: 0,
            clonable: true,
        };
        let (mut private_a, mut private_b) = (private(), private());
        a.update(&reading()).unwrap();
        b.update(&reading()).unwrap();
        private_a.update(&reading()).unwrap();
        private_b.update(&reading()).unwrap();
        let to = Pose2::new(5.0, 0.0, 0.0);
        assert!(a.reset_to(to, SIGMA));
        assert!(private_a.reset_to(to, SIGMA));
        assert!(!a.same_filter(&b));
        for _ in 0..2 {
            a.predict(&delta()).unwrap();
            b.predict(&delta()).unwrap();
            private_a.predict(&delta()).unwrap();
            private_b.predict(&delta()).unwrap();
        }
        assert_eq!(x(&a), private_a.estimate().pose.x);
        assert_eq!(x(&b), private_b.estimate().pose.x);
        assert_eq!(x(&b), 12.0);
        // Now each holds its filter alone: re-seeding is in place.
        assert!(!a.is_shared() && !b.is_shared());
        assert!(b.reset_to(Pose2::new(1.0, 0.0, 0.0), SIGMA));
        assert_eq!(x(&b), 1.001);
    }

    /// Holders re-seeding the same filter after the same reading around the same pose share
    /// the copy; another pose or another reading makes another copy.
    #[test]
    fn the_same_reseed_shares_the_copy() {
        let root = counter(true);
        let mut hs: Vec<SharedMember> = (0..4).map(|_| root.share()).collect();
        for h in &mut hs {
            h.update(&reading()).unwrap();
        }
        let to = Pose2::new(5.0, 0.0, 0.0);
        assert!(hs[0].reset_to(to, SIGMA));
        assert!(hs[1].reset_to(to, SIGMA));
        assert!(hs[2].reset_to(Pose2::new(6.0, 0.0, 0.0), SIGMA));
        assert!(hs[0].same_filter(&hs[1]));
        assert!(!hs[0].same_filter(&hs[2]));
        assert!(hs[3].same_filter(&root));
        // One draw each: the shared copy was re-seeded once, not twice.
        assert_eq!(hs[1].estimate().stamp, 1.0);
        assert_eq!(x(&hs[1]), 5.001);
        assert_eq!(x(&root), 10.0);
        for h in &mut hs {
            h.update(&reading()).unwrap();
        }
        // After another reading the old copy is not reused for the same arguments.
        assert!(hs[3].reset_to(to, SIGMA));
        assert!(!hs[3].same_filter(&hs[0]));
    }

    /// A copy re-seeded in place by its only holder since it was made is another filter: a
    /// later holder re-seeding the original the same way gets a fresh copy.
    #[test]
    fn a_copy_reseeded_again_is_not_reused() {
        let root = counter(true);
        let (mut a, mut b, mut c) = (root.share(), root.share(), root.share());
        for h in [&mut a, &mut b, &mut c] {
            h.update(&reading()).unwrap();
        }
        let to = Pose2::new(5.0, 0.0, 0.0);
        assert!(a.reset_to(to, SIGMA));
        assert!(a.reset_to(Pose2::new(7.0, 0.0, 0.0), SIGMA));
        assert!(b.reset_to(to, SIGMA));
        assert!(!a.same_filter(&b));
        assert_eq!(x(&b), 5.001);
        assert_eq!(x(&a), 7.002);
        assert!(c.same_filter(&root));
    }

    #[test]
    fn a_shared_filter_that_cannot_be_copied_is_not_reseeded() {
        let mut a = counter(false);
        assert!(!a.can_copy());
        let b = a.share();
        assert!(!a.reset_to(Pose2::new(5.0, 0.0, 0.0), SIGMA));
        assert!(a.same_filter(&b));
        assert_eq!(x(&b), 0.0);
        drop(b);
        // Held alone, it is re-seeded in place.
        assert!(a.reset_to(Pose2::new(5.0, 0.0, 0.0), SIGMA));
        assert_eq!(x(&a), 5.001);
    }
}
