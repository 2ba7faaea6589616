//! Where the picture is taken from: a look-at camera with a vertical field of view.

use nalgebra::Vector3;
use panda_rapier_core::{Error, Result};
use serde::{Deserialize, Serialize};

use crate::mesh::Triangle;
use crate::raster::ScreenVertex;

/// Camera options, as passed from Python (`camera={...}`) or JSON. Either an orbit around
/// `target` (`distance`, `azimuth`, `elevation`, like PyBullet's debug camera) or an explicit
/// `eye`; unset fields take the defaults below.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `target` | `[0.35, 0.05, 0.28]` | the point looked at (m) |
/// | `distance` | `1.4` | eye to target (m), orbit only |
/// | `azimuth` | `40` | degrees about z from +x to the eye, orbit only |
/// | `elevation` | `25` | degrees of the eye above the target's horizontal plane, orbit only |
/// | `eye` | none | the eye position (m); excludes the three orbit fields |
/// | `fov` | `45` | vertical field of view (degrees, 1 to 170) |
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// The point looked at (m).
    pub target: Option<[f64; 3]>,
    /// Eye to target distance for the orbit camera (m).
    pub distance: Option<f64>,
    /// Azimuth of the eye about the world z axis, from +x towards +y (degrees).
    pub azimuth: Option<f64>,
    /// Elevation of the eye above the target (degrees, -90 to 90).
    pub elevation: Option<f64>,
    /// Explicit eye position (m), instead of the orbit.
    pub eye: Option<[f64; 3]>,
    /// Vertical field of view (degrees).
    pub fov: Option<f64>,
}

impl CameraConfig {
    /// The default observation camera, the camera a policy that sees uses (Python's
    /// `panda_rapier.pixels.DEFAULT_CAMERA`, the `rgb` image of `obs_mode="rgb"`, ...): in
    /// front of the robot, looking down at the pick region and the platform, with the gripper
    /// in the picture up to about 0.4 m above the floor.
    pub const OBSERVATION: CameraConfig = CameraConfig {
        target: Some([0.45, 0.05, 0.22]),
        distance: Some(1.35),
        azimuth: Some(25.0),
        elevation: Some(35.0),
        eye: None,
        fov: Some(45.0),
    };
}

fn invalid(field: &str, reason: impl Into<String>) -> Error {
    Error::InvalidConfig {
        field: format!("camera.{field}"),
        reason: reason.into(),
    }
}

fn finite(field: &str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(invalid(field, format!("must be finite, got {v}")))
    }
}

fn finite3(field: &str, v: [f64; 3]) -> Result<Vector3<f64>> {
    for x in v {
        finite(field, x)?;
    }
    Ok(Vector3::from(v))
}

/// A resolved camera: eye, orthonormal view axes and focal length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (m).
    pub eye: Vector3<f64>,
    /// Unit vector from the eye towards the target.
    pub forward: Vector3<f64>,
    /// Unit vector to the right of the picture.
    pub right: Vector3<f64>,
    /// Unit vector to the top of the picture.
    pub up: Vector3<f64>,
    /// Vertical field of view (rad).
    pub fov_y: f64,
}

/// The default camera's target: the middle of the workspace, so the arm in its ready pose,
/// the pick region and the platform are all in the picture.
pub const DEFAULT_TARGET: [f64; 3] = [0.35, 0.05, 0.28];

/// Nothing closer to the eye than this is drawn (m).
pub const NEAR: f64 = 0.01;

impl Camera {
    /// Resolves and validates `config`; bad values are [`Error::InvalidConfig`] naming the field.
    pub fn new(config: &CameraConfig) -> Result<Self> {
        let target = finite3("target", config.target.unwrap_or(DEFAULT_TARGET))?;
        let fov = finite("fov", config.fov.unwrap_or(45.0))?;
        if !(1.0..=170.0).contains(&fov) {
            return Err(invalid(
                "fov",
                format!("must be in [1, 170] degrees, got {fov}"),
            ));
        }
        let eye = match config.eye {
            Some(eye) => {
                for (name, set) in [
                    ("distance", config.distance.is_some()),
                    ("azimuth", config.azimuth.is_some()),
                    ("elevation", config.elevation.is_some()),
                ] {
                    if set {
                        return Err(invalid(name, "cannot be combined with camera.eye"));
                    }
                }
                finite3("eye", eye)?
            }
            None => {
                let distance = finite("distance", config.distance.unwrap_or(1.4))?;
                if !(NEAR * 2.0..=1e4).contains(&distance) {
                    return Err(invalid(
                        "distance",
                        format!("must be in [{}, 1e4] m, got {distance}", NEAR * 2.0),
                    ));
                }
                let azimuth = finite("azimuth", config.azimuth.unwrap_or(40.0))?.to_radians();
                let elevation = finite("elevation", config.elevation.unwrap_or(25.0))?;
                if !(-90.0..=90.0).contains(&elevation) {
                    return Err(invalid(
                        "elevation",
                        format!("must be in [-90, 90] degrees, got {elevation}"),
                    ));
                }
                let elevation = elevation.to_radians();
                target
                    + distance
                        * Vector3::new(
                            elevation.cos() * azimuth.cos(),
                            elevation.cos() * azimuth.sin(),
                            elevation.sin(),
                        )
            }
        };
        Self::look_at(eye, target, fov.to_radians())
    }

    /// A camera at `eye` looking at `target`, z up (or y up when looking straight up or
    /// down, so no direction is degenerate).
    pub fn look_at(eye: Vector3<f64>, target: Vector3<f64>, fov_y: f64) -> Result<Self> {
        let offset = target - eye;
        let distance = offset.norm();
        // NaN fails `contains` too.
        if !(NEAR * 2.0..=f64::MAX).contains(&distance) {
            return Err(invalid(
                "eye",
                format!(
                    "must be at least {} m from the target, got {distance}",
                    NEAR * 2.0
                ),
            ));
        }
        if !(fov_y > 0.0 && fov_y < std::f64::consts::PI) {
            return Err(invalid(
                "fov",
                format!("must be in (0, pi) rad, got {fov_y}"),
            ));
        }
        let forward = offset / distance;
        let mut right = forward.cross(&Vector3::z());
        if right.norm() < 1e-6 {
            right = forward.cross(&Vector3::y());
        }
        let right = right.normalize();
        let up = right.cross(&forward);
        Ok(Self {
            eye,
            forward,
            right,
            up,
            fov_y,
        })
    }

    /// `p` in view coordinates: right, up, and depth along the viewing direction.
    pub fn to_view(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let d = p - self.eye;
        Vector3::new(d.dot(&self.right), d.dot(&self.up), d.dot(&self.forward))
    }

    /// Focal length in pixels for a picture `height` pixels high.
    pub fn focal_px(&self, height: u32) -> f64 {
        f64::from(height) / 2.0 / (self.fov_y / 2.0).tan()
    }

    /// Pixel coordinates (x right, y down, pixel centres at +0.5) of a point in front of the
    /// eye, for a `width` x `height` picture; `None` behind the near plane.
    pub fn project(&self, p: &Vector3<f64>, width: u32, height: u32) -> Option<[f64; 2]> {
        let v = self.to_view(p);
        if v.z < NEAR {
            return None;
        }
        let f = self.focal_px(height);
        Some([
            f64::from(width) / 2.0 + f * v.x / v.z,
            f64::from(height) / 2.0 - f * v.y / v.z,
        ])
    }
}

/// From the camera's view space to pixels: the focal length and the picture's centre.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Projection {
    pub(crate) focal_px: f64,
    pub(crate) cx: f64,
    pub(crate) cy: f64,
}

impl Projection {
    pub(crate) fn screen(&self, v: &Vector3<f64>) -> ScreenVertex {
        // One division: the f64 results move by an ulp at most, which their f32 roundings
        // below almost never see.
        let inv = 1.0 / v.z;
        let f = self.focal_px * inv;
        ScreenVertex {
            x: (self.cx + f * v.x) as f32,
            y: (self.cy - f * v.y) as f32,
            inv_depth: inv as f32,
        }
    }
}

/// A view-space triangle on the screen: `screen` (its corners projected) where it lies
/// wholly beyond the near plane, else the projections of its clipped parts.
pub(crate) fn on_screen(
    projection: &Projection,
    view: &Triangle,
    screen: &[ScreenVertex; 3],
) -> [Option<[ScreenVertex; 3]>; 2] {
    if view.iter().all(|v| v.z >= NEAR) {
        return [Some(*screen), None];
    }
    clip_near(view).map(|t| t.map(|t| t.map(|v| projection.screen(&v))))
}

/// Clips a view-space triangle to the part in front of the near plane: none, one or two
/// triangles.
pub(crate) fn clip_near(t: &Triangle) -> [Option<Triangle>; 2] {
    let inside = t.map(|v| v.z >= NEAR);
    match inside.iter().filter(|&&i| i).count() {
        3 => [Some(*t), None],
        0 => [None, None],
        _ => {
            let mut poly: Vec<Vector3<f64>> = Vec::with_capacity(4);
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                if inside[i] {
                    poly.push(a);
                }
                if inside[i] != inside[(i + 1) % 3] {
                    let s = (NEAR - a.z) / (b.z - a.z);
                    let mut p = a + (b - a) * s;
                    p.z = NEAR;
                    poly.push(p);
                }
            }
            match poly.len() {
                3 => [Some([poly[0], poly[1], poly[2]]), None],
                4 => [
                    Some([poly[0], poly[1], poly[2]]),
                    Some([poly[0], poly[2], poly[3]]),
                ],
                _ => [None, None],
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_clipping_keeps_the_front_part() {
        let t = [
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(1.0, 0.0, 1.0),
            Vector3::new(-1.0, 0.0, 1.0),
        ];
        let [a, b] = clip_near(&t);
        let (a, b) = (a.unwrap(), b.unwrap());
        for v in a.iter().chain(&b) {
            assert!(v.z >= NEAR - 1e-12);
        }
        let behind = t.map(|v| Vector3::new(v.x, v.y, -2.0));
        assert_eq!(clip_near(&behind), [None, None]);
    }

    #[test]
    fn target_projects_to_the_centre_and_up_is_up() {
        let cam = Camera::new(&CameraConfig::default()).unwrap();
        let target = Vector3::from(DEFAULT_TARGET);
        let [x, y] = cam.project(&target, 720, 480).unwrap();
        assert!((x - 360.0).abs() < 1e-9 && (y - 240.0).abs() < 1e-9);
        let [_, y_above] = cam
            .project(&(target + Vector3::z() * 0.1), 720, 480)
            .unwrap();
        assert!(
            y_above < y,
            "a point above the target is higher in the picture"
        );
        assert!(cam.project(&(cam.eye - cam.forward), 720, 480).is_none());
    }

    #[test]
    fn field_of_view_sets_the_scale() {
        // At 90 degrees, a point at depth d and height d sits on the top edge.
        let cam = Camera::look_at(Vector3::zeros(), Vector3::x(), 90f64.to_radians()).unwrap();
        let [x, y] = cam.project(&Vector3::new(2.0, 0.0, 2.0), 100, 100).unwrap();
        assert!((x - 50.0).abs() < 1e-9 && y.abs() < 1e-9, "{x} {y}");
    }

    #[test]
    fn degenerate_cameras_are_errors_or_well_defined() {
        let straight_down = CameraConfig {
            elevation: Some(90.0),
            ..Default::default()
        };
        let cam = Camera::new(&straight_down).unwrap();
        for v in [cam.forward, cam.right, cam.up] {
            assert!(v.iter().all(|x| x.is_finite()));
            assert!((v.norm() - 1.0).abs() < 1e-9);
        }
        let bad = [
            CameraConfig {
                eye: Some(DEFAULT_TARGET),
                ..Default::default()
            },
            CameraConfig {
                distance: Some(0.0),
                ..Default::default()
            },
            CameraConfig {
                fov: Some(f64::NAN),
                ..Default::default()
            },
            CameraConfig {
                fov: Some(180.0),
                ..Default::default()
            },
            CameraConfig {
                elevation: Some(91.0),
                ..Default::default()
            },
            CameraConfig {
                target: Some([0.0, f64::INFINITY, 0.0]),
                ..Default::default()
            },
            CameraConfig {
                eye: Some([1.0, 1.0, 1.0]),
                distance: Some(2.0),
                ..Default::default()
            },
        ];
        for config in bad {
            let err = Camera::new(&config).unwrap_err();
            assert!(
                matches!(err, Error::InvalidConfig { ref field, .. } if field.starts_with("camera.")),
                "{err}"
            );
        }
    }
}
