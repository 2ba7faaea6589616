//! The observation layout: one flat `f32` vector, and the goal dict as views into it.
//!
//! The flat vector is `[achieved_goal, desired_goal, observation]`, the order in which
//! Gymnasium's `spaces.flatten` lays out the goal dict (keys sorted), so flattening the dict
//! gives exactly the flat layout. For the Panda (9 moving joints: 7 arm joints and 2 fingers)
//! `observation` has 41 entries and the flat vector 47. All positions and velocities are in
//! the world frame (m, m/s, rad, rad/s).
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..3 | `achieved_goal` | `achieved_goal` | 3 | cube centre position |
//! | 3..6 | `desired_goal` | `desired_goal` | 3 | goal position for the cube centre |
//! | 6..15 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 15..24 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 24..27 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 27..30 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 30 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//! | 31..34 | `observation` 25..28 | `cube_position` | 3 | cube centre (same as `achieved_goal`) |
//! | 34..38 | `observation` 28..32 | `cube_orientation` | 4 | unit quaternion x, y, z, w with w >= 0 |
//! | 38..41 | `observation` 32..35 | `cube_linear_velocity` | 3 | cube centre velocity |
//! | 41..44 | `observation` 35..38 | `cube_angular_velocity` | 3 | cube angular velocity |
//! | 44..47 | `observation` 38..41 | `cube_relative_position` | 3 | cube centre minus TCP position |

use std::ops::Range;

/// Size of each goal vector (a position).
pub const GOAL_DIM: usize = 3;

/// One named slot of the flat observation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Slot {
    /// The slot's name, as in the layout table.
    pub name: &'static str,
    /// Indices in the flat vector.
    pub range: Range<usize>,
}

/// Where everything sits in the flat observation of a robot with `num_joints` moving joints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObservationLayout {
    num_joints: usize,
}

/// Sizes of the slots of `observation`, in order; `0` stands for "one per moving joint".
const OBSERVATION_SLOTS: [(&str, usize); 10] = [
    ("joint_positions", 0),
    ("joint_velocities", 0),
    ("tcp_position", 3),
    ("tcp_velocity", 3),
    ("gripper_width", 1),
    ("cube_position", 3),
    ("cube_orientation", 4),
    ("cube_linear_velocity", 3),
    ("cube_angular_velocity", 3),
    ("cube_relative_position", 3),
];

impl ObservationLayout {
    /// The layout for a robot with `num_joints` moving joints (9 for the Panda).
    pub fn new(num_joints: usize) -> Self {
        Self { num_joints }
    }

    /// Number of moving joints reported.
    pub fn num_joints(&self) -> usize {
        self.num_joints
    }

    /// Length of the `observation` entry of the dict.
    pub fn observation_dim(&self) -> usize {
        OBSERVATION_SLOTS
            .iter()
            .map(|&(_, n)| if n == 0 { self.num_joints } else { n })
            .sum()
    }

    /// Length of the flat vector: both goals and the observation.
    pub fn flat_dim(&self) -> usize {
        2 * GOAL_DIM + self.observation_dim()
    }

    /// `achieved_goal` in the flat vector.
    pub fn achieved_goal(&self) -> Range<usize> {
        0..GOAL_DIM
    }

    /// `desired_goal` in the flat vector.
    pub fn desired_goal(&self) -> Range<usize> {
        GOAL_DIM..2 * GOAL_DIM
    }

    /// `observation` in the flat vector.
    pub fn observation(&self) -> Range<usize> {
        2 * GOAL_DIM..self.flat_dim()
    }

    /// Every slot with its range in the flat vector, in order.
    pub fn slots(&self) -> Vec<Slot> {
        let mut slots = vec![
            Slot {
                name: "achieved_goal",
                range: self.achieved_goal(),
            },
            Slot {
                name: "desired_goal",
                range: self.desired_goal(),
            },
        ];
        let mut start = 2 * GOAL_DIM;
        for &(name, n) in &OBSERVATION_SLOTS {
            let n = if n == 0 { self.num_joints } else { n };
            slots.push(Slot {
                name,
                range: start..start + n,
            });
            start += n;
        }
        slots
    }

    /// The range of the slot called `name` in the flat vector.
    pub fn slot(&self, name: &str) -> Option<Range<usize>> {
        self.slots()
            .into_iter()
            .find(|s| s.name == name)
            .map(|s| s.range)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let layout = ObservationLayout::new(9);
        assert_eq!(layout.observation_dim(), 41);
        assert_eq!(layout.flat_dim(), 47);
        let slots = layout.slots();
        let mut next = 0;
        for slot in &slots {
            assert_eq!(slot.range.start, next, "{} is not contiguous", slot.name);
            next = slot.range.end;
        }
        assert_eq!(next, layout.flat_dim());
        // Each slot appears in the module's table with its flat range.
        let source = include_str!("observation.rs");
        for slot in &slots {
            let range = if slot.range.len() == 1 {
                format!("| {} |", slot.range.start)
            } else {
                format!("| {}..{} |", slot.range.start, slot.range.end)
            };
            let row = source
                .lines()
                .find(|l| l.contains(&format!("`{}` | {} |", slot.name, slot.range.len())))
                .unwrap_or_else(|| panic!("no table row for {}", slot.name));
            assert!(
                row.contains(&range),
                "{}: row {row:?} lacks {range}",
                slot.name
            );
        }
    }
}
