//! When each sensor's readings fall due, on the simulation's step counter. Its own module so
//! that the simulation and the camera streams it owns both use it without importing each
//! other.

use crate::error::SimError;

/// A sensor schedule on the step counter: reading k (k = 1, 2, …) is due at step
/// round(k · physics_hz / rate), so sensor times never drift with float accumulation.
#[derive(Debug, Clone)]
pub(crate) struct Schedule {
    steps_per_reading: f64,
    count: u64,
    next_step: u64,
}

impl Schedule {
    pub(crate) fn new(physics_hz: f64, rate_hz: f64, field: &str) -> Result<Self, SimError> {
        crate::error::positive(field, rate_hz)?;
        if rate_hz > physics_hz {
            return Err(SimError::config(
                field,
                format!("{rate_hz} Hz exceeds physics_hz ({physics_hz} Hz): at most one reading per step"),
            ));
        }
        let steps_per_reading = physics_hz / rate_hz;
        Ok(Self {
            steps_per_reading,
            count: 1,
            next_step: steps_per_reading.round() as u64,
        })
    }

    /// Whether a reading is due at `step`, without taking it.
    pub(crate) fn due_at(&self, step: u64) -> bool {
        step >= self.next_step
    }

    pub(crate) fn due(&mut self, step: u64) -> bool {
        if !self.due_at(step) {
            return false;
        }
        self.count += 1;
        self.next_step = (self.count as f64 * self.steps_per_reading).round() as u64;
        true
    }
}
