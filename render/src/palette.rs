//! The palette and lighting of a picture: colours of the sky, floor, platform, objects, goal
//! and robot, and the light's direction and strengths. The renderer ([`crate::scene`]) draws
//! with them and the visual randomisation ([`crate::look`]) perturbs them; this module names
//! neither.

/// Direction towards the light (normalised in use): high, from the front left.
pub(crate) const LIGHT: [f64; 3] = [0.4, 0.3, 1.0];
/// Share of each colour lit by the ambient light.
pub(crate) const AMBIENT: f64 = 0.42;
/// Share of each colour lit by the directional light, at its strongest.
pub(crate) const DIFFUSE: f64 = 0.5;
/// Light from the eye, so faces turned away from the sun keep their shape.
pub(crate) const HEADLIGHT: f64 = 0.12;
/// Colour left in shadow, out of 256.
pub(crate) const SHADOW: u16 = 165;

/// The sky's colour at the top of the picture...
pub(crate) const SKY_TOP: [f64; 3] = [150.0, 180.0, 215.0];
/// ...and at the horizon.
pub(crate) const SKY_HORIZON: [f64; 3] = [222.0, 230.0, 238.0];
/// The floor's two checkerboard colours.
pub(crate) const FLOOR: [[u8; 3]; 2] = [[196, 196, 190], [172, 174, 170]];
/// The platform's colour.
pub(crate) const PLATFORM: [u8; 3] = [176, 132, 86];
/// Object colours, by the object's index in the task's scene (a second cube is blue).
pub(crate) const OBJECTS: [[u8; 3]; 3] = [[214, 52, 40], [40, 92, 214], [226, 178, 32]];
/// The goal marker's colour.
pub(crate) const GOAL: [u8; 3] = [40, 190, 80];
/// An articulated object's root link (a cabinet's carcass).
pub(crate) const CARCASS: [u8; 3] = [150, 104, 62];
/// An articulated object's other links (a cabinet's drawer).
pub(crate) const DRAWER: [u8; 3] = [206, 178, 128];
/// The robot's links.
pub(crate) const LINK: [u8; 3] = [236, 236, 236];
/// The robot's hand and fingers.
pub(crate) const HAND: [u8; 3] = [70, 70, 76];
