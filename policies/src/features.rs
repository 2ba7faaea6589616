//! [`InputFeatures`]: what a policy network computes from a flat observation before its
//! standardisation, in the same fixed-order `f64` arithmetic as the layers
//! ([`crate::network`]).
//!
//! [`InputFeatures::CubeOrientation`] is for tasks whose goals are the cube's orientation
//! (`flip`): `achieved_goal` and `desired_goal` are unit quaternions `x, y, z, w` with
//! `w >= 0`, which jump from `w = 0` to the other sign as a turn passes half a turn, so two
//! orientations a degree apart can lie far apart in the input. The two quaternions (the first
//! 8 entries of the flat observation, whose keys are sorted) become 24 numbers that are
//! continuous in the orientations and the same for every labelling of the cube's faces:
//!
//! - the 9 entries (row-major) of `D = R(g) R(a)^T`, the rotation in the world frame that
//!   turns the cube onto its goal (`R(q)` the rotation matrix of `q`);
//! - the 15 distinct entries `T[j][k][l][m]`, `j <= k <= l <= m` in lexicographic order, of
//!   the fourth-order tensor `T = sum_i c_i (x) c_i (x) c_i (x) c_i`, `c_i` the columns of
//!   `R(a)` (the cube's axes in the world): it tells the cube's pose up to its 24 symmetries,
//!   which are all an expert pushing a uniform cube can see.
//!
//! Replacing `a` and `g` by `a S` and `g S` for any symmetry `S` of the cube leaves both
//! unchanged. The rest of the flat observation follows unchanged.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion};

/// Entries of the flat observation the cube-orientation features replace: the two goal
/// quaternions.
const GOALS: usize = 8;
/// Entries they become: `D` (9) and the distinct entries of `T` (15).
const CUBE_FEATURES: usize = 24;

/// A policy network's input features (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InputFeatures {
    /// The flat observation as it is.
    #[default]
    Flat,
    /// The goal quaternions as the rotation to the goal and the cube's pose up to its symmetry
    /// (module docs): 16 entries longer than the flat observation.
    CubeOrientation,
}

impl InputFeatures {
    /// Every kind, in the order their names are listed.
    pub const ALL: [Self; 2] = [Self::Flat, Self::CubeOrientation];

    /// The name Python and saved models use: `"flat"` or `"cube_orientation"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Flat => "flat",
            Self::CubeOrientation => "cube_orientation",
        }
    }

    /// Parses a [`Self::name`].
    pub fn parse(name: &str) -> panda_rapier_core::Result<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| panda_rapier_core::Error::InvalidConfig {
                field: "features".into(),
                reason: format!("must be \"flat\" or \"cube_orientation\", got {name:?}"),
            })
    }

    /// How many entries the features have beyond the flat observation's.
    pub fn extra_entries(self) -> usize {
        match self {
            Self::Flat => 0,
            Self::CubeOrientation => CUBE_FEATURES - GOALS,
        }
    }

    /// The fewest flat entries these features need (the cube's: the two goals and more).
    pub fn min_observation_dim(self) -> usize {
        match self {
            Self::Flat => 1,
            Self::CubeOrientation => GOALS + 1,
        }
    }

    /// Length of the features of a flat observation of `observation_dim` entries.
    pub fn dim(self, observation_dim: usize) -> usize {
        observation_dim + self.extra_entries()
    }

    /// Writes the features of the flat observation `row` into `out` (`self.dim(row.len())`
    /// entries), in `f64`: `f32` observations convert exactly, so rows of either type give the
    /// same bits.
    pub fn write<T: Copy + Into<f64>>(self, row: &[T], out: &mut [f64]) {
        let widen = |out: &mut [f64], values: &[T]| {
            for (o, &v) in out.iter_mut().zip(values) {
                *o = v.into();
            }
        };
        match self {
            Self::Flat => widen(out, row),
            Self::CubeOrientation => {
                let a = rotation(&row[0..4]);
                let g = rotation(&row[4..8]);
                let d = g * a.transpose();
                for j in 0..3 {
                    for k in 0..3 {
                        out[3 * j + k] = d[(j, k)];
                    }
                }
                let mut n = 9;
                for j in 0..3 {
                    for k in j..3 {
                        for l in k..3 {
                            for m in l..3 {
                                let mut t = 0.0;
                                for i in 0..3 {
                                    t += a[(j, i)] * a[(k, i)] * a[(l, i)] * a[(m, i)];
                                }
                                out[n] = t;
                                n += 1;
                            }
                        }
                    }
                }
                widen(&mut out[CUBE_FEATURES..], &row[GOALS..]);
            }
        }
    }
}

/// The rotation matrix of the quaternion `x, y, z, w` (normalised; the identity for zero).
fn rotation<T: Copy + Into<f64>>(q: &[T]) -> Matrix3<f64> {
    let q = Quaternion::new(q[3].into(), q[0].into(), q[1].into(), q[2].into());
    if q.norm() == 0.0 {
        return Matrix3::identity();
    }
    UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn xyzw(q: &UnitQuaternion<f64>) -> [f64; 4] {
        [q.i, q.j, q.k, q.w]
    }

    fn features(a: &UnitQuaternion<f64>, g: &UnitQuaternion<f64>) -> Vec<f64> {
        let mut row = Vec::from(xyzw(a));
        row.extend(xyzw(g));
        row.extend([0.5, -0.25]);
        let mut out = vec![0.0; InputFeatures::CubeOrientation.dim(row.len())];
        InputFeatures::CubeOrientation.write(&row, &mut out);
        out
    }

    /// The 24 rotations that map a cube onto itself.
    fn cube_symmetries() -> Vec<UnitQuaternion<f64>> {
        let mut found: Vec<UnitQuaternion<f64>> = vec![UnitQuaternion::identity()];
        let generators = [
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
        ];
        let mut i = 0;
        while i < found.len() {
            for g in &generators {
                let next = found[i] * g;
                if found.iter().all(|f| f.angle_to(&next) > 1e-6) {
                    found.push(next);
                }
            }
            i += 1;
        }
        found
    }

    #[test]
    fn the_cube_features_are_the_same_for_every_labelling_of_the_faces() {
        let a = UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        let g = UnitQuaternion::from_euler_angles(-2.2, 0.4, 0.9);
        let reference = features(&a, &g);
        let symmetries = cube_symmetries();
        assert_eq!(symmetries.len(), 24);
        for s in &symmetries {
            let turned = features(&(a * s), &(g * s));
            for (x, y) in reference.iter().zip(&turned) {
                assert!((x - y).abs() < 1e-12, "{x} {y}");
            }
        }
        // The rest of the row follows the features, unchanged.
        assert_eq!(&reference[24..], &[0.5, -0.25]);
        // Another orientation of the cube gives other features.
        let other = features(&(a * UnitQuaternion::from_euler_angles(0.0, 0.0, 0.4)), &g);
        assert!(reference
            .iter()
            .zip(&other)
            .any(|(x, y)| (x - y).abs() > 0.01));
    }

    #[test]
    fn the_cube_features_do_not_jump_where_the_quaternion_changes_sign() {
        // Turns of just under and just over half a turn about z: w changes sign, and the
        // observation's quaternion (w >= 0) jumps to the other side.
        let g = UnitQuaternion::from_euler_angles(0.7, 0.0, 0.0);
        let near = |angle: f64| {
            let a = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle);
            let mut q = xyzw(&a);
            if q[3] < 0.0 {
                q = q.map(|v| -v);
            }
            let mut row = Vec::from(q);
            row.extend(xyzw(&g));
            let mut out = vec![0.0; 24];
            InputFeatures::CubeOrientation.write(&row, &mut out);
            (q, out)
        };
        let (q1, f1) = near(std::f64::consts::PI - 1e-3);
        let (q2, f2) = near(std::f64::consts::PI + 1e-3);
        assert!(
            q1.iter()
                .zip(&q2)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
                > 1.9
        );
        assert!(
            f1.iter()
                .zip(&f2)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
                < 1e-2
        );
    }

    #[test]
    fn the_rotation_to_the_goal_turns_the_cube_onto_it() {
        let a = UnitQuaternion::from_euler_angles(1.0, 0.2, -0.5);
        let g = UnitQuaternion::from_euler_angles(0.1, -0.9, 2.5);
        let f = features(&a, &g);
        let d = Matrix3::from_row_slice(&f[..9]);
        let expected = g.to_rotation_matrix().into_inner();
        assert!(
            (d * a.to_rotation_matrix().into_inner() - expected)
                .abs()
                .max()
                < 1e-12
        );
        assert!(InputFeatures::parse("quaternion").is_err());
        assert_eq!(InputFeatures::parse("flat").unwrap(), InputFeatures::Flat);
    }
}
