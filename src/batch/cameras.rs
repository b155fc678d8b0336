//! The views of a batch job: an orbit around the scene (seeded, reproducible), or a list of
//! cameras given as camera-to-world matrices or as look-at triples.

use glam::{Mat4, Vec3};
use serde::Deserialize;
use serde_json::Value;

use crate::scene::{look_at_camera, Aabb, Camera, Projection};

/// Default vertical field of view of manifest cameras, degrees.
pub const DEFAULT_FOV_Y_DEG: f32 = 40.0;

/// Most views one job may have.
pub const MAX_VIEWS: usize = 10_000;

/// Tolerance of the rigid-transform check of `c2w` matrices (orthonormality of the rotation,
/// determinant +1, last row 0 0 0 1).
pub const RIGID_TOLERANCE: f32 = 1e-3;

/// `{"orbit": {...}}`: `n` views around the scene's bounding-box centre, azimuths evenly
/// spaced from a seeded random start, elevations uniform in `elevation_deg`, at the distance
/// where the bounding sphere fills the vertical field of view.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Orbit {
    /// Number of views.
    pub n: u32,
    /// Elevation range `[lo, hi]` in degrees (above the horizontal plane through the centre).
    #[serde(default = "default_elevation")]
    pub elevation_deg: [f32; 2],
    /// Vertical field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov_y_deg: f32,
    /// Seed of the azimuth offset and the elevations.
    #[serde(default)]
    pub seed: u64,
}

fn default_elevation() -> [f32; 2] {
    [15.0, 15.0]
}

fn default_fov() -> f32 {
    DEFAULT_FOV_Y_DEG
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OrbitLine {
    orbit: Orbit,
}

/// `{"c2w": [[...4], x4], "fov_y_deg": f}`: a row-major camera-to-world matrix (the camera
/// looks down its -Z with +Y up, as in glTF and NeRF's `transform_matrix`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MatrixCamera {
    c2w: [[f32; 4]; 4],
    #[serde(default = "default_fov")]
    fov_y_deg: f32,
}

/// `{"look_from": [x,y,z], "look_at": [x,y,z], "up": [x,y,z], "fov_y_deg": f}`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LookAtCamera {
    look_from: [f32; 3],
    look_at: [f32; 3],
    #[serde(default = "default_up")]
    up: [f32; 3],
    #[serde(default = "default_fov")]
    fov_y_deg: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// The views of a job.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraSpec {
    /// Around the scene (needs its bounds).
    Orbit(Orbit),
    /// Fixed cameras.
    List(Vec<Camera>),
}

/// A camera error: the path below `cameras` (`[2].c2w`, `.orbit.n`) and the message.
pub type CameraError = (String, String);

fn check_fov(fov: f32, at: &str) -> Result<f32, CameraError> {
    if fov.is_finite() && fov > 0.0 && fov < 180.0 {
        Ok(fov.to_radians())
    } else {
        Err((
            format!("{at}.fov_y_deg"),
            format!("{fov} is outside (0, 180) degrees"),
        ))
    }
}

/// Checks that a row-major 4x4 matrix is a rigid transform (rotation + translation) and
/// returns it as a column-major [`Mat4`].
pub fn rigid_from_rows(rows: &[[f32; 4]; 4]) -> Result<Mat4, String> {
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err("has a non-finite entry".into());
    }
    let m = Mat4::from_cols_array_2d(rows).transpose();
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "last row is {:?}, not [0, 0, 0, 1]: not a rigid transform",
            rows[3]
        ));
    }
    let axes = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    for (i, a) in axes.iter().enumerate() {
        if (a.length() - 1.0).abs() > RIGID_TOLERANCE {
            return Err(format!(
                "column {i} of the rotation has length {:.4}: scaled, not a rigid transform",
                a.length()
            ));
        }
        for b in &axes[i + 1..] {
            if a.dot(*b).abs() > RIGID_TOLERANCE {
                return Err(
                    "rotation columns are not orthogonal: sheared, not a rigid transform".into(),
                );
            }
        }
    }
    if axes[0].cross(axes[1]).dot(axes[2]) < 0.0 {
        return Err("rotation has determinant -1: a mirror, not a rigid transform".into());
    }
    Ok(m)
}

fn perspective(camera_to_world: Mat4, yfov: f32) -> Camera {
    Camera {
        camera_to_world,
        projection: Projection::Perspective {
            yfov,
            aspect: None,
            znear: crate::scene::camera::LOOK_AT_ZNEAR,
            zfar: None,
        },
    }
}

impl CameraSpec {
    /// Parses the `cameras` value of a manifest line.
    pub fn from_json(value: &Value) -> Result<Self, CameraError> {
        let serde_err = |at: String, e: serde_json::Error| (at, e.to_string());
        match value {
            Value::Object(o) if o.contains_key("orbit") => {
                let orbit = OrbitLine::deserialize(value)
                    .map_err(|e| serde_err(".orbit".into(), e))?
                    .orbit;
                if orbit.n == 0 || orbit.n as usize > MAX_VIEWS {
                    return Err((
                        ".orbit.n".into(),
                        format!("{} is outside 1..={MAX_VIEWS}", orbit.n),
                    ));
                }
                let [lo, hi] = orbit.elevation_deg;
                if !(lo.is_finite() && hi.is_finite() && lo <= hi && lo > -90.0 && hi < 90.0) {
                    return Err((
                        ".orbit.elevation_deg".into(),
                        format!("[{lo}, {hi}] must be an increasing range inside (-90, 90)"),
                    ));
                }
                check_fov(orbit.fov_y_deg, ".orbit")?;
                Ok(Self::Orbit(orbit))
            }
            Value::Array(list) => {
                if list.is_empty() || list.len() > MAX_VIEWS {
                    return Err((
                        String::new(),
                        format!("needs 1..={MAX_VIEWS} cameras, got {}", list.len()),
                    ));
                }
                let mut cameras = Vec::with_capacity(list.len());
                for (k, entry) in list.iter().enumerate() {
                    let at = format!("[{k}]");
                    let has = |key| entry.as_object().is_some_and(|o| o.contains_key(key));
                    let camera = if has("c2w") {
                        let c = MatrixCamera::deserialize(entry)
                            .map_err(|e| serde_err(at.clone(), e))?;
                        let m = rigid_from_rows(&c.c2w).map_err(|m| (format!("{at}.c2w"), m))?;
                        perspective(m, check_fov(c.fov_y_deg, &at)?)
                    } else if has("look_from") {
                        let c = LookAtCamera::deserialize(entry)
                            .map_err(|e| serde_err(at.clone(), e))?;
                        let (from, to, up) = (
                            Vec3::from(c.look_from),
                            Vec3::from(c.look_at),
                            Vec3::from(c.up),
                        );
                        if !(from.is_finite() && to.is_finite() && up.is_finite()) {
                            return Err((at, "non-finite coordinates".into()));
                        }
                        if (to - from).length() < 1e-6 {
                            return Err((
                                format!("{at}.look_at"),
                                "is the same point as look_from".into(),
                            ));
                        }
                        if up.length() < 1e-6 {
                            return Err((format!("{at}.up"), "is the zero vector".into()));
                        }
                        look_at_camera(from, to, up, check_fov(c.fov_y_deg, &at)?)
                    } else {
                        return Err((at, "a camera needs `c2w` or `look_from` + `look_at`".into()));
                    };
                    cameras.push(camera);
                }
                Ok(Self::List(cameras))
            }
            other => Err((
                String::new(),
                format!("expected {{\"orbit\": {{...}}}} or a list of cameras, got {other}"),
            )),
        }
    }

    /// Number of views.
    pub fn len(&self) -> usize {
        match self {
            Self::Orbit(o) => o.n as usize,
            Self::List(l) => l.len(),
        }
    }

    /// Whether there are no views (never true of a parsed spec).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cameras, framing `bounds` for an orbit.
    pub fn cameras(&self, bounds: &Aabb, aspect: f32) -> Vec<Camera> {
        match self {
            Self::List(l) => l.clone(),
            Self::Orbit(o) => orbit_cameras(o, bounds, aspect),
        }
    }
}

/// SplitMix64: a tiny, well-mixed, reproducible generator (the orbit's views must be the same
/// on every machine and every rerun).
fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1).
fn unit(state: &mut u64) -> f32 {
    (splitmix64(state) >> 40) as f32 / (1u64 << 24) as f32
}

/// The cameras of an orbit around `bounds`.
pub fn orbit_cameras(o: &Orbit, bounds: &Aabb, aspect: f32) -> Vec<Camera> {
    let (center, radius) = if bounds.is_empty() || !bounds.diagonal().is_finite() {
        (Vec3::ZERO, 3f32.sqrt() * 0.5)
    } else {
        (bounds.center(), (bounds.diagonal() * 0.5).max(1e-4))
    };
    let yfov = o.fov_y_deg.to_radians();
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect
    } else {
        1.0
    };
    let half_v = yfov * 0.5;
    let half_h = (half_v.tan() * aspect).atan();
    let distance = radius / half_v.min(half_h).sin();
    let mut state = o.seed;
    let offset = unit(&mut state);
    let [lo, hi] = o.elevation_deg;
    (0..o.n)
        .map(|i| {
            let azimuth = std::f32::consts::TAU * (i as f32 + offset) / o.n as f32;
            let elevation = (lo + (hi - lo) * unit(&mut state)).to_radians();
            let dir = Vec3::new(
                elevation.cos() * azimuth.sin(),
                elevation.sin(),
                elevation.cos() * azimuth.cos(),
            );
            let mut cam = look_at_camera(center + dir * distance, center, Vec3::Y, yfov);
            cam.projection = Projection::Perspective {
                yfov,
                aspect: None,
                znear: distance * 1e-3,
                zfar: None,
            };
            cam
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn rigid_check_refuses_scale_shear_mirror_and_projection() {
        let id = [
            [1.0, 0.0, 0.0, 2.0],
            [0.0, 1.0, 0.0, 3.0],
            [0.0, 0.0, 1.0, 4.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        let m = rigid_from_rows(&id).unwrap();
        assert_eq!(m.w_axis.truncate(), Vec3::new(2.0, 3.0, 4.0));
        let mut scaled = id;
        scaled[0][0] = 2.0;
        assert!(rigid_from_rows(&scaled).unwrap_err().contains("scaled"));
        let mut sheared = id;
        sheared[0][1] = 0.5;
        assert!(rigid_from_rows(&sheared).is_err());
        let mut mirror = id;
        mirror[2][2] = -1.0;
        assert!(rigid_from_rows(&mirror).unwrap_err().contains("mirror"));
        let mut proj = id;
        proj[3][2] = 1.0;
        assert!(rigid_from_rows(&proj).unwrap_err().contains("last row"));
    }

    #[test]
    fn camera_errors_name_the_camera() {
        let bad = json!([{"look_from": [0, 0, 1], "look_at": [0, 0, 0]}, {"c2w": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]);
        let (at, msg) = CameraSpec::from_json(&bad).unwrap_err();
        assert_eq!(at, "[1].c2w");
        assert!(msg.contains("not a rigid transform"), "{msg}");
        let (at, msg) = CameraSpec::from_json(
            &json!([{"look_from": [0, 0, 1], "look_at": [0, 0, 0], "zoom": 2}]),
        )
        .unwrap_err();
        assert_eq!(at, "[0]");
        assert!(msg.contains("unknown field `zoom`"), "{msg}");
        let (at, _) = CameraSpec::from_json(&json!({"orbit": {"n": 0}})).unwrap_err();
        assert_eq!(at, ".orbit.n");
        let (at, _) = CameraSpec::from_json(&json!({"orbit": {"n": 3, "elevation_deg": [40, 10]}}))
            .unwrap_err();
        assert_eq!(at, ".orbit.elevation_deg");
    }

    #[test]
    fn orbits_are_reproducible_and_look_at_the_centre() {
        let o = Orbit {
            n: 5,
            elevation_deg: [-10.0, 40.0],
            fov_y_deg: 40.0,
            seed: 7,
        };
        let bounds = Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::new(1.0, 3.0, 1.0),
        };
        let a = orbit_cameras(&o, &bounds, 1.0);
        assert_eq!(a, orbit_cameras(&o, &bounds, 1.0));
        let other = orbit_cameras(
            &Orbit {
                seed: 8,
                ..o.clone()
            },
            &bounds,
            1.0,
        );
        assert_ne!(a, other);
        for c in &a {
            let to_centre = (bounds.center() - c.position()).normalize();
            assert!(c.forward().dot(to_centre) > 0.999);
            let elevation = to_centre.y.asin().to_degrees();
            assert!((-40.01..=10.01).contains(&elevation), "{elevation}");
        }
    }
}
