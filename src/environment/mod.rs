//! Image-based lighting: equirectangular HDR environment maps (`--environment`), loaded and
//! checked on the host ([`map`]), prepared on the GPU at load ([`gpu`]: prefiltered specular
//! levels, irradiance, the split-sum BRDF table) and read by `shaders/common/environment.glsl`
//! in every path and backend.
//!
//! **Convention** (the Khronos glTF Sample Viewer's and Mitsuba 3's): world +Y is up; a world
//! direction `d` maps to `u = atan2(d.x, -d.z) / 2π` (wrapped to [0, 1)) and
//! `v = acos(d.y) / π`, so row 0 is the zenith, a camera looking down -Z faces the map's
//! left/right edge and +Z meets its centre. `--environment-rotation DEG` turns the map
//! counter-clockwise seen from above.

pub mod gpu;
pub mod map;
pub mod sampling;

use std::path::PathBuf;

use glam::Vec3;

pub use gpu::GpuEnvironment;
pub use map::EnvironmentMap;

/// An environment could not be loaded or parsed.
#[derive(Debug, thiserror::Error)]
pub enum EnvironmentError {
    /// The file could not be read.
    #[error("{file}: cannot read")]
    Io {
        /// The file.
        file: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a usable map.
    #[error("{file}: {message}")]
    Format {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The `--environment` argument is malformed.
    #[error("--environment {given:?}: {message}")]
    Argument {
        /// What the user wrote.
        given: String,
        /// What is wrong.
        message: String,
    },
}

impl EnvironmentError {
    /// Builds an [`EnvironmentError::Format`].
    pub fn format(file: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Format {
            file: file.into(),
            message: message.into(),
        }
    }
}

/// What `--environment` names.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    /// No environment: misses show `--background`, surfaces get `--ambient`.
    None,
    /// An equirectangular `.hdr` or `.exr` file.
    File(PathBuf),
}

impl EnvironmentSource {
    /// Parses `none` or a path.
    pub fn parse(s: &str) -> Result<Self, EnvironmentError> {
        let arg = |message: &str| EnvironmentError::Argument {
            given: s.to_string(),
            message: message.to_string(),
        };
        if s.is_empty() {
            return Err(arg("empty; give a .hdr or .exr file, or `none`"));
        }
        if s.eq_ignore_ascii_case("none") {
            return Ok(Self::None);
        }
        Ok(Self::File(PathBuf::from(s)))
    }

    /// Loads the map this names (`None` for [`EnvironmentSource::None`]), logging one
    /// warning when texels had to be clamped.
    pub fn load(&self) -> Result<Option<EnvironmentMap>, EnvironmentError> {
        match self {
            Self::None => Ok(None),
            Self::File(path) => {
                let (map, clamped) = map::load(path)?;
                if clamped > 0 {
                    log::warn!(
                        "{}: {clamped} negative, NaN or infinite channel value(s) clamped to 0",
                        path.display()
                    );
                }
                Ok(Some(map))
            }
        }
    }
}

/// The map coordinates `(u, v)` of world direction `d` (unit length) under the convention
/// above, `shaders/common/env_mapping.glsl`'s `env_uv`.
pub fn direction_to_uv(d: Vec3) -> (f32, f32) {
    let u = d.x.atan2(-d.z) / std::f32::consts::TAU;
    let u = if u < 0.0 { u + 1.0 } else { u };
    (u, d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI)
}

/// The world direction at map coordinates `(u, v)`; inverse of [`direction_to_uv`].
pub fn uv_to_direction(u: f32, v: f32) -> Vec3 {
    let phi = std::f32::consts::TAU * u;
    let theta = std::f32::consts::PI * v;
    Vec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    )
}

/// Where a world direction `d` reads the map turned by `degrees` about +Y (counter-clockwise
/// seen from above), as the shaders' `env_map_direction`.
pub fn rotate_into_map(d: Vec3, degrees: f32) -> Vec3 {
    let (s, c) = degrees.to_radians().sin_cos();
    Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn convention_matches_the_sample_viewer() {
        // -Z (the default camera's view) is the map's left/right edge, +Z its centre, +Y row 0.
        let (u, _) = direction_to_uv(Vec3::NEG_Z);
        assert!(u.abs() < 1e-6 || (u - 1.0).abs() < 1e-6, "{u}");
        let (u, v) = direction_to_uv(Vec3::Z);
        assert!((u - 0.5).abs() < 1e-6 && (v - 0.5).abs() < 1e-6);
        assert!(direction_to_uv(Vec3::Y).1.abs() < 1e-6);
        // +X at u = 1/4.
        assert!((direction_to_uv(Vec3::X).0 - 0.25).abs() < 1e-6);
        for (u, v) in [(0.1, 0.3), (0.7, 0.9), (0.45, 0.02)] {
            let (u2, v2) = direction_to_uv(uv_to_direction(u, v));
            assert!((u - u2).abs() < 1e-5 && (v - v2).abs() < 1e-5);
        }
    }

    #[test]
    fn rotation_is_counter_clockwise_from_above() {
        // Turning the map 90° counter-clockwise (seen from +Y: +X towards -Z) brings what was
        // at +X to -Z: looking towards -Z now reads the map where +X used to be.
        let d = rotate_into_map(Vec3::NEG_Z, 90.0);
        assert!((d - Vec3::X).length() < 1e-5, "{d}");
    }

    #[test]
    fn arguments() {
        assert_eq!(
            EnvironmentSource::parse("none").unwrap(),
            EnvironmentSource::None
        );
        assert!(matches!(
            EnvironmentSource::parse("a.hdr").unwrap(),
            EnvironmentSource::File(_)
        ));
        assert!(EnvironmentSource::parse("").is_err());
    }
}
