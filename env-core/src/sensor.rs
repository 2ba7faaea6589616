//! [`Sensor`]: observation bytes beyond the state vector (camera images), computed from an
//! environment's state by the vector env on each environment's thread.

use crate::env::PandaEnv;

/// Extra observation bytes computed from an environment's state (camera images): one per
/// environment of a [`PandaVecEnv`], see [`PandaVecEnv::set_sensors`].
///
/// [`PandaVecEnv`]: crate::PandaVecEnv
/// [`PandaVecEnv::set_sensors`]: crate::PandaVecEnv::set_sensors
///
/// `observe` must depend on the environment's state only (not on earlier calls), so that an
/// environment's sensor bytes are the same whatever the thread count or batch size.
pub trait Sensor: Send + Sync {
    /// Bytes written per observation.
    fn len(&self) -> usize;
    /// Whether it writes nothing.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Writes the observation of `env`'s current state into `out` (exactly [`Sensor::len`] bytes).
    fn observe(&mut self, env: &PandaEnv, out: &mut [u8]);
}

/// A lane's sensor and its latest outputs.
pub(crate) struct SensorSlot {
    pub(crate) sensor: Box<dyn Sensor>,
    pub(crate) data: Vec<u8>,
    pub(crate) final_data: Vec<u8>,
}

impl std::fmt::Debug for SensorSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SensorSlot")
            .field("len", &self.data.len())
            .finish_non_exhaustive()
    }
}
