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
pub mod sky;

use std::path::PathBuf;

use glam::Vec3;

pub use gpu::GpuEnvironment;
pub use map::EnvironmentMap;
pub use sky::{SkyModel, SkySpec};

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
    /// The Hosek–Wilkie physical sky and its sun (`sky[:ELEVATION,AZIMUTH[,TURBIDITY]]`).
    Sky(SkySpec),
    /// `studio`: the photo studio built into rqr (`assets/environments/studio.hdr`, CC0).
    Studio,
}

/// The studio map built into the binary (`assets/environments/studio.hdr`, CC0; 1024×512).
const STUDIO_HDR: &[u8] = include_bytes!("../../assets/environments/studio.hdr");

/// What lights a scene that has no lights and is given no `--environment` (in the CLI, rqr
/// batch and Python; the library's renderer itself adds none).
pub fn default_environment() -> EnvironmentSource {
    EnvironmentSource::Sky(SkySpec::DEFAULT)
}

impl EnvironmentSource {
    /// Parses `none`, `studio`, `sky[:ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]]` or a path (a
    /// file named `studio` or `sky…` is given as `./studio`, `./sky…`).
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
        if s.eq_ignore_ascii_case("studio") {
            return Ok(Self::Studio);
        }
        if let Some(rest) = s
            .get(..3)
            .filter(|head| head.eq_ignore_ascii_case("sky"))
            .map(|_| &s[3..])
        {
            if rest.is_empty() || rest.starts_with(':') {
                return SkySpec::parse(rest, s).map(Self::Sky);
            }
        }
        Ok(Self::File(PathBuf::from(s)))
    }

    /// The sky's model, for [`EnvironmentSource::Sky`].
    pub fn sky(&self) -> Result<Option<SkyModel>, EnvironmentError> {
        match self {
            Self::Sky(spec) => spec.model().map(Some),
            _ => Ok(None),
        }
    }

    /// Lights `scene` for this environment: with one, the default light rig goes (the
    /// file's own lights stay), and the sky adds its sun as a directional light, turned by
    /// `rotation_deg` and scaled by `intensity` as the map is.
    pub fn light_scene(
        &self,
        scene: &mut crate::scene::Scene,
        rotation_deg: f32,
        intensity: f32,
    ) -> Result<(), EnvironmentError> {
        if *self == Self::None {
            return Ok(());
        }
        scene.drop_default_lights();
        if let Some(sky) = self.sky()? {
            scene.lights.push(sky.sun_light(rotation_deg, intensity));
        }
        Ok(())
    }

    /// Loads the map this names (`None` for [`EnvironmentSource::None`]; the sky is baked at
    /// [`sky::SKY_MAP_WIDTH`]), logging one warning when texels had to be clamped.
    pub fn load(&self) -> Result<Option<EnvironmentMap>, EnvironmentError> {
        match self {
            Self::None => Ok(None),
            Self::Studio => map::decode("studio (built in)", STUDIO_HDR).map(Some),
            Self::Sky(spec) => {
                let started = std::time::Instant::now();
                let map = spec.model()?.bake(sky::SKY_MAP_WIDTH);
                log::info!(
                    "sky (sun {}° high at azimuth {}°, turbidity {}) baked to {}x{} in {:.1} ms",
                    spec.elevation_deg,
                    spec.azimuth_deg,
                    spec.turbidity,
                    map.width,
                    map.height,
                    started.elapsed().as_secs_f64() * 1e3
                );
                Ok(Some(map))
            }
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
        assert_eq!(
            EnvironmentSource::parse("sky").unwrap(),
            EnvironmentSource::Sky(SkySpec::DEFAULT)
        );
        assert_eq!(
            EnvironmentSource::parse("sky:10,-20,2.5").unwrap(),
            EnvironmentSource::Sky(SkySpec {
                elevation_deg: 10.0,
                azimuth_deg: -20.0,
                turbidity: 2.5
            })
        );
        assert_eq!(
            EnvironmentSource::parse("sky:10,20").unwrap(),
            EnvironmentSource::Sky(SkySpec {
                elevation_deg: 10.0,
                azimuth_deg: 20.0,
                turbidity: SkySpec::DEFAULT.turbidity
            })
        );
        // A file whose name starts with `sky` is still a file.
        assert!(matches!(
            EnvironmentSource::parse("skyline.hdr").unwrap(),
            EnvironmentSource::File(_)
        ));
        for (bad, says) in [
            ("sky:abc", "elevation \"abc\" is not a number"),
            ("sky:30", "1 value(s)"),
            ("sky:abc,0", "elevation \"abc\" is not a number"),
            ("sky:95,0", "outside 0..90"),
            ("sky:-5,0", "outside 0..90"),
            ("sky:30,0,0.5", "turbidity 0.5 is outside 1..10"),
            ("sky:30,0,11", "outside 1..10"),
            ("sky:30,0,3,9", "4 value(s)"),
            ("sky:30,nan", "azimuth \"nan\" is not a number"),
            ("sky:", "elevation \"\" is not a number"),
        ] {
            let e = EnvironmentSource::parse(bad).unwrap_err().to_string();
            assert!(e.contains(says) && e.contains(bad), "{bad}: {e}");
        }
    }
}
