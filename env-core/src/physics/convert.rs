//! The one place where rapier's f32 glam types meet the f64 nalgebra types of the public API.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

use rapier3d::math::{Pose, Rotation, Vector};

pub(crate) fn vec_to_na(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x as f64, v.y as f64, v.z as f64)
}

pub(crate) fn vec_from_na(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x as f32, v.y as f32, v.z as f32)
}

pub(crate) fn vec_from_array(v: [f64; 3]) -> Vector {
    Vector::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

pub(crate) fn rot_to_na(r: Rotation) -> UnitQuaternion<f64> {
    UnitQuaternion::new_normalize(Quaternion::new(
        r.w as f64, r.x as f64, r.y as f64, r.z as f64,
    ))
}

pub(crate) fn rot_from_na(r: &UnitQuaternion<f64>) -> Rotation {
    let q = r.quaternion();
    Rotation::from_xyzw(q.i as f32, q.j as f32, q.k as f32, q.w as f32).normalize()
}

pub(crate) fn pose_to_na(p: &Pose) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(vec_to_na(p.translation)),
        rot_to_na(p.rotation),
    )
}

pub(crate) fn pose_from_na(p: &Isometry3<f64>) -> Pose {
    Pose::from_parts(vec_from_na(&p.translation.vector), rot_from_na(&p.rotation))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_f32_precision() {
        let p = Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(0.3, -1.2, 2.0),
        );
        let back = pose_to_na(&pose_from_na(&p));
        assert!((back.translation.vector - p.translation.vector).norm() < 1e-7);
        assert!(back.rotation.angle_to(&p.rotation) < 1e-6);
    }
}
