//! Cameras: the automatic framing camera, look-at cameras, the pixel/ray convention, and
//! the default light rig for scenes without lights.

use glam::{Mat4, Vec3};

use super::types::{Aabb, Camera, Light, LightKind, Projection};

/// Vertical field of view of [`auto_camera`]: 45°.
pub const AUTO_CAMERA_YFOV: f32 = std::f32::consts::FRAC_PI_4;

/// Elevation of [`auto_camera`] above the scene centre: 15°.
pub const AUTO_CAMERA_ELEVATION: f32 = 15.0 * std::f32::consts::PI / 180.0;

/// Near plane of [`look_at_camera`] (ray tracing ignores it; raster uses it).
pub const LOOK_AT_ZNEAR: f32 = 1e-3;

/// Orthonormalises a node's world matrix into a camera pose: translation kept, scale and
/// shear removed, always a proper rotation (a mirroring node does not mirror the image).
pub fn camera_pose(world: Mat4) -> Mat4 {
    let pos = world.w_axis.truncate();
    let back = world.z_axis.truncate().normalize_or(Vec3::Z);
    let up = world.y_axis.truncate();
    let right = up.cross(back).normalize_or_zero();
    let right = if right == Vec3::ZERO {
        back.any_orthonormal_vector()
    } else {
        right
    };
    let up = back.cross(right);
    Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        back.extend(0.0),
        pos.extend(1.0),
    )
}

/// A perspective camera at `from` looking at `at`, with `up` as the approximate up direction
/// (any other when parallel to the view direction) and vertical field of view `yfov` in
/// radians. Near plane [`LOOK_AT_ZNEAR`], no far plane.
pub fn look_at_camera(from: Vec3, at: Vec3, up: Vec3, yfov: f32) -> Camera {
    let back = (from - at).normalize_or(Vec3::Z);
    let right = up.cross(back).normalize_or_zero();
    let right = if right == Vec3::ZERO {
        back.any_orthonormal_vector()
    } else {
        right
    };
    let true_up = back.cross(right);
    Camera {
        camera_to_world: Mat4::from_cols(
            right.extend(0.0),
            true_up.extend(0.0),
            back.extend(0.0),
            from.extend(1.0),
        ),
        projection: Projection::Perspective {
            yfov,
            aspect: None,
            znear: LOOK_AT_ZNEAR,
            zfar: None,
        },
    }
}

/// A camera that frames `bounds` for an image of the given `aspect` (width / height):
/// it looks at the box centre along -Z from the +Z side, raised by
/// [`AUTO_CAMERA_ELEVATION`] (15°), with a 45° vertical field of view, at the distance where
/// the bounding sphere just fits both the vertical and the horizontal field of view.
/// Near plane at 1/1000 of that distance, no far plane. An empty box frames the unit cube.
pub fn auto_camera(bounds: &Aabb, aspect: f32) -> Camera {
    let (center, radius) = if bounds.is_empty() || !bounds.diagonal().is_finite() {
        (Vec3::ZERO, 3f32.sqrt() * 0.5)
    } else {
        (bounds.center(), (bounds.diagonal() * 0.5).max(1e-4))
    };
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect
    } else {
        1.0
    };
    let half_v = AUTO_CAMERA_YFOV * 0.5;
    let half_h = (half_v.tan() * aspect).atan();
    let distance = radius / half_v.min(half_h).sin();
    let dir = Vec3::new(
        0.0,
        AUTO_CAMERA_ELEVATION.sin(),
        AUTO_CAMERA_ELEVATION.cos(),
    );
    let mut cam = look_at_camera(center + dir * distance, center, Vec3::Y, AUTO_CAMERA_YFOV);
    cam.projection = Projection::Perspective {
        yfov: AUTO_CAMERA_YFOV,
        aspect: None,
        znear: distance * 1e-3,
        zfar: None,
    };
    cam
}

impl Camera {
    /// Camera position in world space.
    pub fn position(&self) -> Vec3 {
        self.camera_to_world.w_axis.truncate()
    }

    /// Unit view direction in world space (the camera's -Z).
    pub fn forward(&self) -> Vec3 {
        -self.camera_to_world.z_axis.truncate()
    }

    /// The primary ray through image point (`x`, `y`) in pixels of a `width` x `height`
    /// image: row 0 is the top, the centre of pixel (i, j) is (i + 0.5, j + 0.5). The image's
    /// aspect ratio always wins over one stored in the file; orthographic cameras keep
    /// `ymag` and derive the horizontal half-extent from the aspect. Returns (origin,
    /// unit direction) in world space.
    pub fn primary_ray(&self, x: f32, y: f32, width: u32, height: u32) -> (Vec3, Vec3) {
        let aspect = width.max(1) as f32 / height.max(1) as f32;
        let ndc_x = 2.0 * x / width.max(1) as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * y / height.max(1) as f32;
        let (origin, dir) = match self.projection {
            Projection::Perspective { yfov, .. } => {
                let t = (yfov * 0.5).tan();
                (
                    Vec3::ZERO,
                    Vec3::new(ndc_x * t * aspect, ndc_y * t, -1.0).normalize(),
                )
            }
            Projection::Orthographic { ymag, .. } => (
                Vec3::new(ndc_x * ymag * aspect, ndc_y * ymag, 0.0),
                Vec3::NEG_Z,
            ),
        };
        (
            self.camera_to_world.transform_point3(origin),
            self.camera_to_world
                .transform_vector3(dir)
                .normalize_or(Vec3::NEG_Z),
        )
    }
}

/// Intensity of the default sun in lux: a white diffuse surface facing it reflects a
/// radiance of about 1 (3 / π), i.e. it is well exposed at exposure 1.
pub const DEFAULT_SUN_LUX: f32 = 3.0;

/// The light rig used when a scene has no lights ([`super::Scene::default_lights`] = true):
/// one white directional "sun" of [`DEFAULT_SUN_LUX`] shining from above, in front (+Z, the
/// auto camera's side) and a little to the right, towards `(-0.3, -1, -0.5)`. Renderers add
/// a little ambient light on top.
pub fn default_lights() -> Vec<Light> {
    vec![Light {
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: DEFAULT_SUN_LUX,
        range: f32::INFINITY,
        position: Vec3::ZERO,
        direction: Vec3::new(-0.3, -1.0, -0.5).normalize(),
        size: 0.0,
    }]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;

    #[test]
    fn look_at_points_at_target() {
        let cam = look_at_camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 1.0);
        assert!(cam.forward().abs_diff_eq(Vec3::NEG_Z, 1e-6));
        let (o, d) = cam.primary_ray(50.0, 50.0, 100, 100);
        assert!(o.abs_diff_eq(Vec3::new(0.0, 0.0, 5.0), 1e-6));
        assert!(d.abs_diff_eq(Vec3::NEG_Z, 1e-6));
        // Row 0 is the top: a ray through the first row goes up.
        let (_, top) = cam.primary_ray(50.0, 0.5, 100, 100);
        assert!(top.y > 0.0);
        let (_, left) = cam.primary_ray(0.5, 50.0, 100, 100);
        assert!(left.x < 0.0);
        // Looking straight down still yields a valid basis.
        let down = look_at_camera(Vec3::Y, Vec3::ZERO, Vec3::Y, 1.0);
        assert!((down.camera_to_world.determinant() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn auto_camera_fits_sphere() {
        let b = Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::splat(1.0),
        };
        for aspect in [0.5, 1.0, 2.0] {
            let cam = auto_camera(&b, aspect);
            let r = 3f32.sqrt();
            let d = cam.position().length();
            let half_v = AUTO_CAMERA_YFOV * 0.5;
            let half = half_v.min((half_v.tan() * aspect).atan());
            assert!((r / d - half.sin()).abs() < 1e-5);
            assert!(cam.position().y > 0.0 && cam.position().z > 0.0);
            assert!(cam.forward().dot(-cam.position().normalize()) > 0.9999);
        }
        let empty = auto_camera(&Aabb::EMPTY, 1.0);
        assert!(empty.position().is_finite());
    }

    #[test]
    fn pose_removes_scale() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 3.0, 4.0),
            glam::Quat::from_rotation_y(0.5),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let p = camera_pose(m);
        assert!((p.determinant() - 1.0).abs() < 1e-5);
        assert!(p.w_axis.abs_diff_eq(Vec4::new(1.0, 2.0, 3.0, 1.0), 1e-6));
        let r = Mat4::from_rotation_y(0.5);
        assert!(p.x_axis.abs_diff_eq(r.x_axis, 1e-5));
    }
}
