//! [`Sensor`]: observation bytes beyond the state vector (camera images, touch), computed from
//! an environment's state by the vector env on each environment's thread; [`TouchSensor`]
//! writes the hand's touch reading, [`SensorChain`] puts several sensors' bytes one after the
//! other.

use crate::env::PandaEnv;
use crate::physics::TouchReading;

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

/// The `touch` observation entry: [`TouchReading::observation`] of the environment's hand, as
/// [`TouchReading::LEN`] little-endian float32 values ([`TouchReading::LAYOUT`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct TouchSensor;

impl TouchSensor {
    /// The observation key of the entry.
    pub const KEY: &'static str = "touch";
}

impl Sensor for TouchSensor {
    fn len(&self) -> usize {
        4 * TouchReading::LEN
    }

    fn observe(&mut self, env: &PandaEnv, out: &mut [u8]) {
        for (chunk, value) in out.chunks_exact_mut(4).zip(env.touch().observation()) {
            chunk.copy_from_slice(&value.to_le_bytes());
        }
    }
}

/// Several sensors as one: their bytes one after the other, in order.
pub struct SensorChain(pub Vec<Box<dyn Sensor>>);

impl std::fmt::Debug for SensorChain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SensorChain")
            .field("len", &self.len())
            .finish_non_exhaustive()
    }
}

impl Sensor for SensorChain {
    fn len(&self) -> usize {
        self.0.iter().map(|s| s.len()).sum()
    }

    fn observe(&mut self, env: &PandaEnv, out: &mut [u8]) {
        let mut start = 0;
        for sensor in &mut self.0 {
            let end = start + sensor.len();
            sensor.observe(env, &mut out[start..end]);
            start = end;
        }
    }
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
