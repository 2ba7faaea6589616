//! The task side of the configuration: the types tasks' sections are made of ([`Region`],
//! [`Range`]), the options every task reads ([`RewardType`], [`Randomization`],
//! [`TaskThresholds`]) and their checks.
//! The environment's configuration, which holds all of them, is
//! [`EnvConfig`](crate::env::EnvConfig).

use serde::{Deserialize, Serialize};

use crate::config::{invalid, CubeConfig, PlatformConfig};
use crate::error::Result;

/// Which reward the environment returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RewardType {
    /// -1 until the cube is within the success threshold of the goal, then 0.
    #[default]
    Sparse,
    /// Staged shaping: reach, grasp, lift, carry, place (see [`crate::task::reward`]).
    Dense,
}

impl RewardType {
    /// The name used in configs and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            RewardType::Sparse => "sparse",
            RewardType::Dense => "dense",
        }
    }
}

/// An axis-aligned rectangle in the horizontal plane (m, world frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Smallest x and y.
    pub low: [f64; 2],
    /// Largest x and y.
    pub high: [f64; 2],
}

impl Region {
    /// The point at fractions `u` (each in [0, 1]) across the region.
    pub fn lerp(&self, u: [f64; 2]) -> [f64; 2] {
        [
            self.low[0] + (self.high[0] - self.low[0]) * u[0],
            self.low[1] + (self.high[1] - self.low[1]) * u[1],
        ]
    }

    /// Checks that the region is finite and not inverted; errors name `field`.
    pub fn validate(&self, field: &str) -> Result<()> {
        for i in 0..2 {
            if !(self.low[i].is_finite() && self.high[i].is_finite()) {
                return Err(invalid(field, format!("must be finite, got {self:?}")));
            }
            if self.low[i] > self.high[i] {
                return Err(invalid(
                    field,
                    format!("is inverted: low {:?} > high {:?}", self.low, self.high),
                ));
            }
        }
        Ok(())
    }
}

/// A closed interval `[low, high]` for a randomised quantity.
pub type Range = [f64; 2];

/// The default success threshold (m) of a goal position: [`TaskContext`]'s and
/// [`EnvConfig`](crate::env::EnvConfig)'s `success_threshold`.
///
/// [`TaskContext`]: crate::task::context::TaskContext
pub const DEFAULT_SUCCESS_THRESHOLD: f64 = 0.05;

/// Domain randomisation, drawn at every reset. Everything is off by default; the random draws
/// happen either way, so switching one on does not change the other quantities of a seed.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Randomization {
    /// Cube edge length range (m).
    pub cube_size: Option<Range>,
    /// Cube mass range (kg).
    pub cube_mass: Option<Range>,
    /// Cube friction coefficient range.
    pub cube_friction: Option<Range>,
    /// Uniform noise (+- rad) added to each arm joint of the start configuration.
    pub joint_noise: f64,
}

/// Thresholds that decide the task's predicates (`is_grasped`, `is_placed`, ...).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TaskThresholds {
    /// Normal force (N) each finger must press the cube with for it to count as grasped.
    pub grasp_force: f64,
    /// The cube is at rest below this speed (m/s)...
    pub rest_linear_speed: f64,
    /// ...and this angular speed (rad/s).
    pub rest_angular_speed: f64,
    /// A body faster than this (m/s) means the physics blew up: the episode is truncated.
    pub unstable_linear_speed: f64,
    /// A body spinning faster than this (rad/s) means the physics blew up.
    pub unstable_angular_speed: f64,
}

impl Default for TaskThresholds {
    fn default() -> Self {
        Self {
            grasp_force: 1.0,
            rest_linear_speed: 0.02,
            rest_angular_speed: 0.3,
            unstable_linear_speed: 20.0,
            unstable_angular_speed: 200.0,
        }
    }
}

/// Checks that `r` is finite, not inverted and starts at or above `min`; errors name `field`.
pub fn validate_range(field: &str, r: Range, min: f64) -> Result<()> {
    if !(r[0].is_finite() && r[1].is_finite()) {
        return Err(invalid(field, format!("must be finite, got {r:?}")));
    }
    if r[0] > r[1] {
        return Err(invalid(field, format!("is inverted: {r:?}")));
    }
    if r[0] < min {
        return Err(invalid(field, format!("must be >= {min}, got {r:?}")));
    }
    Ok(())
}

/// Checks a task's cube start: `task.cube_region` and `task.cube_yaw_range`.
pub fn validate_cube_start(cube_region: &Region, cube_yaw_range: Range) -> Result<()> {
    cube_region.validate("task.cube_region")?;
    validate_range("task.cube_yaw_range", cube_yaw_range, f64::NEG_INFINITY)
}

/// For the tasks with a platform: cubes drawn in `cube_region` start clear of `platform`
/// (any yaw, the largest size `randomization` draws) and goals in `goal_region` lie on its
/// top. Errors name `task.cube_region` or `task.goal_region`.
pub fn validate_platform_regions(
    randomization: &Randomization,
    platform: &PlatformConfig,
    cube: &CubeConfig,
    cube_region: &Region,
    goal_region: &Region,
) -> Result<()> {
    let (platform_low, platform_high) = platform.top_face();
    let largest_cube = randomization.cube_size.map_or(cube.size, |s| s[1]);
    // Half the diagonal: a yawed cube reaches that far from its centre.
    let reach = largest_cube * std::f64::consts::FRAC_1_SQRT_2;
    let pick = cube_region;
    let overlaps = (0..2)
        .all(|i| pick.low[i] - reach < platform_high[i] && pick.high[i] + reach > platform_low[i]);
    if overlaps {
        return Err(invalid(
            "task.cube_region",
            format!(
                "a cube drawn in {pick:?} could overlap the platform spanning {platform_low:?}..{platform_high:?}"
            ),
        ));
    }
    let goal = goal_region;
    let inside = (0..2).all(|i| goal.low[i] >= platform_low[i] && goal.high[i] <= platform_high[i]);
    if !inside {
        return Err(invalid(
            "task.goal_region",
            format!(
                "must lie on the platform's top {platform_low:?}..{platform_high:?}, got {goal:?}"
            ),
        ));
    }
    Ok(())
}
