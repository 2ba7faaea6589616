//! The scripted policy's distances and speeds.

/// Distances and speeds of the sequence. The defaults were tuned on seeded episodes (see the
/// crate's tests); every length is in metres, every speed a fraction of a full action.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScriptedParams {
    /// Height of the hand above the cube's centre while it moves in from afar.
    pub hover_height: f64,
    /// Horizontal hand-to-cube distance below which the open hand goes straight down.
    pub align_tolerance: f64,
    /// The hand counts as around the cube within this horizontal distance from its centre...
    pub in_hand_tolerance: f64,
    /// ...and this vertical one (the finger pads are taller than they are wide).
    pub in_hand_height: f64,
    /// Fraction of the remaining distance covered per step on the final approach to the cube
    /// and to the goal.
    pub arrival_gain: f64,
    /// The hand closes only once it moves slower than this (m/s).
    pub settle_speed: f64,
    /// Fraction of the hand's velocity times the control period added to its position before
    /// steering: the arm lags its targets, and this lead keeps it from overshooting.
    pub velocity_lead: f64,
    /// Height the held cube's bottom keeps above any surface it is carried over.
    pub carry_clearance: f64,
    /// Horizontal cube-to-goal distance below which the cube is lowered.
    pub place_tolerance: f64,
    /// Horizontal cube-to-goal distance below which the carry turns into a careful descent.
    pub arrival_distance: f64,
    /// The cube is released once its centre is this close above the goal.
    pub release_height: f64,
    /// The hand rises this far above the goal after releasing.
    pub retreat_height: f64,
    /// `stack`: the hover height used on the way from the stack to the second cube, higher
    /// than `hover_height` because that way starts low and the arm lags downwards.
    pub stack_hover_height: f64,
    /// `stack`: horizontal distance from the top cube to the bottom one below which the top
    /// cube is lowered onto it (tighter than `place_tolerance`: an overhanging cube slides off).
    pub stack_place_tolerance: f64,
    /// `stack`: within this horizontal distance of the bottom cube, the hand rises above it
    /// before heading for the other cube.
    pub stack_clear_distance: f64,
    /// `stack`: within this horizontal distance of the second cube the approach slows...
    pub stack_slow_distance: f64,
    /// `stack`: ...to this speed (a fraction of a full action).
    pub stack_approach_speed: f64,
    /// `stack`: a cube held tilted more than this (rad) right after the grasp...
    pub stack_max_tilt: f64,
    /// `stack`: ...with its centre less than this above its resting height is let go and
    /// grasped again.
    pub stack_regrasp_height: f64,
    /// `stack`: the fingers first close to this far (m) beyond the cube's width across them...
    pub stack_close_gap: f64,
    /// `stack`: ...and squeeze once they are within this of it...
    pub stack_squeeze_from: f64,
    /// `stack`: ...and the cube counts as held once they are within this of it.
    pub stack_touch_margin: f64,
    /// `stack`: a squeezed cube whose centre is this far above its resting height on the
    /// surface under it counts as held whatever the fingers' speed.
    pub stack_aloft_height: f64,
    /// `push`: height of the fingertips' path over the cube's top when passing over it.
    pub push_clearance: f64,
    /// `push`: height of the TCP above the cube's centre while pushing. The fingertip pads
    /// reach 8 mm below the TCP, and the fingers' upper parts (from 19 mm above the TCP) stick
    /// out 12 mm beyond the pads along the fingers' axis: pushed lower, the cube's top edge
    /// meets those and the cube tips over (200 episodes, `ee` control, dynamic arm, before the
    /// `push_upright` recovery and the sag correction: 67 % success at 0 mm, 97-99 % at
    /// 12-14 mm). Higher, the pads push the cube's upper half and it tips forwards.
    pub push_height: f64,
    /// `push`: with the dynamic arm, the final descent behind the cube, from this height above
    /// the passing height down, goes at...
    pub push_descent_height: f64,
    /// `push`: ...this speed (a fraction of a full action).
    pub push_descent_speed: f64,
    /// `push`: how much of the TCP's shortfall below the pushing height is added to its target.
    pub push_sag_gain: f64,
    /// `push`: the largest shortfall (m) corrected.
    pub push_sag_limit: f64,
    /// `push`: the hand lets go of a cube tilted more than this (rad)...
    pub push_upright: f64,
    /// `push`: ...or pressed this far (m) into the floor.
    pub push_sink: f64,
    /// `push`: the hand pushes only once the TCP is within this height above the pushing
    /// height.
    pub push_height_tolerance: f64,
    /// `push`: half the width of the closed fingers, seen from the cube.
    pub pusher_half_width: f64,
    /// `push`: gap between the fingers and the cube's back face when lining up.
    pub push_gap: f64,
    /// `push`: largest sideways distance from the line through the cube to the goal at which
    /// the hand keeps pushing; farther, it backs off and lines up again.
    pub push_line_tolerance: f64,
    /// `push`: pushing speed, a fraction of a full action.
    pub push_speed: f64,
    /// `push`: the cube counts as delivered this close to the goal.
    pub push_done: f64,
    /// `push`: the fingers count as closed below this opening (m).
    pub push_closed_width: f64,
}

impl Default for ScriptedParams {
    fn default() -> Self {
        Self {
            hover_height: 0.06,
            align_tolerance: 0.01,
            in_hand_tolerance: 0.025,
            in_hand_height: 0.025,
            velocity_lead: 0.0,
            settle_speed: 0.1,
            arrival_gain: 0.5,
            carry_clearance: 0.015,
            place_tolerance: 0.015,
            release_height: 0.004,
            arrival_distance: 0.05,
            retreat_height: 0.1,
            stack_hover_height: 0.18,
            stack_place_tolerance: 0.003,
            stack_clear_distance: 0.1,
            stack_slow_distance: 0.15,
            stack_approach_speed: 0.5,
            stack_max_tilt: 0.15,
            stack_regrasp_height: 0.02,
            stack_close_gap: 0.003,
            stack_squeeze_from: 0.005,
            stack_touch_margin: 0.002,
            stack_aloft_height: 0.01,
            push_clearance: 0.03,
            push_height: 0.008,
            push_descent_height: 0.03,
            push_descent_speed: 0.35,
            push_sag_gain: 1.0,
            push_sag_limit: 0.01,
            push_upright: 0.25,
            push_sink: 0.005,
            push_height_tolerance: 0.008,
            pusher_half_width: 0.012,
            push_gap: 0.015,
            push_line_tolerance: 0.012,
            push_speed: 0.4,
            push_done: 0.015,
            push_closed_width: 0.01,
        }
    }
}
