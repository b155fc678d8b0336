//! The physical sky of `--environment sky[:ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]]`: the
//! Hosek–Wilkie RGB sky model (the `hw-skymodel` crate, a port of the authors' BSD reference
//! code and RGB dataset) baked at load into an equirectangular map that then goes through the
//! same preparation, cache and sampling tables as a map file, plus its sun as a directional
//! light (not baked into the texels, so the Whitted model shadows it and the map stays smooth
//! enough for its sampling tables).
//!
//! Conventions (`docs/techniques/environment.md`):
//! - the sun sits at elevation `e` above the horizon and azimuth `φ` measured as the map's `u`
//!   (`φ = 360° × u`): the direction towards it is `(cos e sin φ, sin e, -cos e cos φ)`, so
//!   azimuth 0 is -Z (in front of the default camera, back-lighting), 90 is +X, 180 is +Z;
//! - radiance is the model's (W m⁻² sr⁻¹, luminous-weighted) times [`SKY_RADIANCE_SCALE`];
//! - below the horizon: a Lambertian ground of albedo [`GROUND_ALBEDO`] lit by this sky and
//!   sun, a uniform radiance.

use std::f32::consts::FRAC_PI_2;

use glam::Vec3;
use hw_skymodel::rgb::{Channel, SkyParams, SkyState};

use super::map::EnvironmentMap;
use super::EnvironmentError;
use crate::scene::{Light, LightKind};

/// Width of the baked map (1024×512: the size the preparation passes are tuned and measured
/// at; the sky has no detail finer than its circumsolar glow, which this resolves).
pub const SKY_MAP_WIDTH: u32 = 1024;

/// Ground albedo: the model's ground-bounce parameter and the reflectance of the ground shown
/// below the horizon (0.3, dry grass or soil).
pub const GROUND_ALBEDO: f32 = 0.3;

/// Angular radius of the sun's disc in degrees (the mean seen from the Earth).
pub const SUN_ANGULAR_RADIUS_DEG: f32 = 0.2665;

/// Multiplies the model's radiance (W m⁻² sr⁻¹ weighted by the luminous efficiency curve:
/// cd/m² / 683) and the sun's, so that at exposure 0 a white Lambertian plane under the
/// default sky reflects a radiance of about 1, as under the default light rig. Sky and sun
/// share it, so their ratio stays physical; `--environment-intensity` scales both.
pub const SKY_RADIANCE_SCALE: f32 = 1.0 / 32.0;

/// Illuminance of the sun above the atmosphere, 128 klx (the solar illuminance constant), in
/// the model's units (lx / 683).
pub const SOLAR_IRRADIANCE_ABOVE_ATMOSPHERE: f32 = 128_000.0 / 683.0;

/// Linear sRGB colour of the sun above the atmosphere (a 5800 K black body; luminance 1).
pub const SOLAR_COLOUR_ABOVE_ATMOSPHERE: [f32; 3] = [1.065, 0.988, 0.921];

/// Wavelengths (µm) at which the sun's transmittance is evaluated for R, G and B.
const RGB_WAVELENGTHS_UM: [f32; 3] = [0.65, 0.57, 0.475];

/// What `sky[:…]` names: the sun's position and the atmosphere's turbidity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkySpec {
    /// Sun elevation above the horizon, degrees (0..=90, the model's range).
    pub elevation_deg: f32,
    /// Sun azimuth, degrees, measured as the map's `u` (0: -Z, 90: +X, 180: +Z).
    pub azimuth_deg: f32,
    /// Atmospheric turbidity (1 = pure air … 10 = hazy; the model's range).
    pub turbidity: f32,
}

impl SkySpec {
    /// `sky` alone: the sun 45° high, at azimuth 150° (from above the default camera's right
    /// shoulder, as the default light rig's sun), a clear atmosphere (turbidity 3).
    pub const DEFAULT: Self = Self {
        elevation_deg: 45.0,
        azimuth_deg: 150.0,
        turbidity: 3.0,
    };

    /// Parses what follows `sky` in an `--environment` argument: nothing, or
    /// `:ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]`. `given` is the whole argument, for errors.
    pub fn parse(rest: &str, given: &str) -> Result<Self, EnvironmentError> {
        let err = |message: String| EnvironmentError::Argument {
            given: given.to_string(),
            message,
        };
        if rest.is_empty() {
            return Ok(Self::DEFAULT);
        }
        let Some(list) = rest.strip_prefix(':') else {
            return Err(err(
                "write `sky` or `sky:ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]`".into(),
            ));
        };
        let parts: Vec<&str> = list.split(',').map(str::trim).collect();
        let names = ["elevation", "azimuth", "turbidity"];
        let mut values = [0.0f32; 3];
        for (i, p) in parts.iter().take(3).enumerate() {
            values[i] = p
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err(format!("{} {p:?} is not a number", names[i])))?;
        }
        if !(2..=3).contains(&parts.len()) {
            return Err(err(format!(
                "{} value(s) after `sky:`; give ELEVATION_DEG,AZIMUTH_DEG[,TURBIDITY]",
                parts.len()
            )));
        }
        let spec = Self {
            elevation_deg: values[0],
            azimuth_deg: values[1],
            turbidity: if parts.len() == 3 {
                values[2]
            } else {
                Self::DEFAULT.turbidity
            },
        };
        spec.check().map_err(err)?;
        Ok(spec)
    }

    /// Checks the ranges of the model.
    pub fn check(&self) -> Result<(), String> {
        if !(0.0..=90.0).contains(&self.elevation_deg) {
            return Err(format!(
                "sun elevation {}° is outside 0..90 (the Hosek-Wilkie model covers suns from the horizon to the zenith)",
                self.elevation_deg
            ));
        }
        if !self.azimuth_deg.is_finite() {
            return Err(format!("sun azimuth {} is not finite", self.azimuth_deg));
        }
        if !(1.0..=10.0).contains(&self.turbidity) {
            return Err(format!(
                "turbidity {} is outside 1..10, the range of the Hosek-Wilkie model",
                self.turbidity
            ));
        }
        Ok(())
    }

    /// Unit direction towards the sun in map space (environment rotation 0).
    pub fn sun_direction(&self) -> Vec3 {
        let (se, ce) = self.elevation_deg.to_radians().sin_cos();
        let (sa, ca) = self.azimuth_deg.to_radians().sin_cos();
        Vec3::new(ce * sa, se, -ce * ca)
    }

    /// The model for this sky.
    pub fn model(&self) -> Result<SkyModel, EnvironmentError> {
        SkyModel::new(*self)
    }
}

/// The Hosek–Wilkie model set up for one [`SkySpec`].
#[derive(Clone, Debug)]
pub struct SkyModel {
    /// What it was made from.
    pub spec: SkySpec,
    state: SkyState,
    sun: Vec3,
}

impl SkyModel {
    /// Sets the model up (checks the ranges first).
    pub fn new(spec: SkySpec) -> Result<Self, EnvironmentError> {
        let given = || {
            format!(
                "sky:{},{},{}",
                spec.elevation_deg, spec.azimuth_deg, spec.turbidity
            )
        };
        spec.check().map_err(|message| EnvironmentError::Argument {
            given: given(),
            message,
        })?;
        let state = SkyState::new(&SkyParams {
            elevation: spec.elevation_deg.to_radians().clamp(0.0, FRAC_PI_2),
            turbidity: spec.turbidity,
            albedo: [GROUND_ALBEDO; 3],
        })
        .map_err(|e| EnvironmentError::Argument {
            given: given(),
            message: e.to_string(),
        })?;
        Ok(Self {
            spec,
            state,
            sun: spec.sun_direction(),
        })
    }

    /// The model's own radiance (unscaled) at zenith angle `theta` and angle `gamma` from the
    /// sun, both radians: the crate's `SkyState::radiance` per channel.
    pub fn model_radiance(&self, theta: f32, gamma: f32) -> [f32; 3] {
        [Channel::R, Channel::G, Channel::B].map(|c| self.state.radiance(theta, gamma, c))
    }

    /// Sky radiance (scaled by [`SKY_RADIANCE_SCALE`]) towards map-space direction `d` (unit),
    /// for `d.y >= 0`; below the horizon it is one ground colour (`SkyModel::ground_radiance`).
    pub fn sky_radiance(&self, d: Vec3) -> [f32; 3] {
        let theta = d.y.clamp(0.0, 1.0).acos();
        let gamma = d.dot(self.sun).clamp(-1.0, 1.0).acos();
        self.model_radiance(theta, gamma)
            .map(|v| (v * SKY_RADIANCE_SCALE).max(0.0))
    }

    /// Solid angle of the sun's disc, steradians.
    pub fn sun_solid_angle() -> f32 {
        let r = f64::from(SUN_ANGULAR_RADIUS_DEG).to_radians();
        (2.0 * std::f64::consts::PI * (1.0 - r.cos())) as f32
    }

    /// Transmittance of the atmosphere along the sun's path for R, G, B: Rayleigh scattering
    /// and Ångström aerosol extinction from the turbidity, over Kasten's relative air mass (the
    /// formulas of Preetham, Shirley and Smits 1999, appendix; ozone, water vapour and mixed
    /// gases are left out, each under 5 % in the visible at the zenith).
    pub fn sun_transmittance(&self) -> [f32; 3] {
        let zenith_deg = 90.0 - self.spec.elevation_deg;
        let air_mass =
            1.0 / (zenith_deg.to_radians().cos() + 0.15 * (93.885 - zenith_deg).powf(-1.253));
        let beta = 0.04608 * self.spec.turbidity - 0.04586;
        RGB_WAVELENGTHS_UM.map(|l| {
            let rayleigh = (-0.008735 * l.powf(-4.08) * air_mass).exp();
            let aerosol = (-beta * l.powf(-1.3) * air_mass).exp();
            rayleigh * aerosol
        })
    }

    /// Irradiance of the sun on a plane facing it (scaled as the sky): the light's colour ×
    /// intensity. It equals the disc's radiance ([`SkyModel::sun_radiance`]) × its solid angle.
    pub fn sun_irradiance(&self) -> Vec3 {
        let t = self.sun_transmittance();
        Vec3::from_array(std::array::from_fn(|c| {
            SOLAR_IRRADIANCE_ABOVE_ATMOSPHERE
                * SOLAR_COLOUR_ABOVE_ATMOSPHERE[c]
                * t[c]
                * SKY_RADIANCE_SCALE
        }))
    }

    /// Mean radiance of the sun's disc (scaled as the sky).
    pub fn sun_radiance(&self) -> Vec3 {
        self.sun_irradiance() / Self::sun_solid_angle()
    }

    /// Uniform radiance of the ground below the horizon: a Lambertian ground of albedo
    /// [`GROUND_ALBEDO`] lit by the sky (irradiance on a horizontal plane, from `sky_map`'s
    /// upper rows) and the sun.
    fn ground_radiance(&self, sky_map: &EnvironmentMap) -> [f32; 3] {
        let (w, h) = (sky_map.width as usize, sky_map.height as usize);
        let mut e = [0.0f64; 3];
        let texel_angle =
            (2.0 * std::f64::consts::PI / w as f64) * (std::f64::consts::PI / h as f64);
        for y in 0..h / 2 {
            let theta = std::f64::consts::PI * (y as f64 + 0.5) / h as f64;
            let weight = theta.cos() * theta.sin() * texel_angle;
            for t in &sky_map.texels[y * w..(y + 1) * w] {
                for c in 0..3 {
                    e[c] += f64::from(t[c]) * weight;
                }
            }
        }
        let sun = self.sun_irradiance() * self.sun.y.max(0.0);
        std::array::from_fn(|c| {
            ((e[c] + f64::from(sun[c])) * f64::from(GROUND_ALBEDO) / std::f64::consts::PI) as f32
        })
    }

    /// Bakes the sky into a `width`×`width/2` map (row 0 at the zenith; the sun's disc is not
    /// in it: [`SkyModel::sun_light`] carries the sun).
    pub fn bake(&self, width: u32) -> EnvironmentMap {
        let mut map = EnvironmentMap::from_fn(width, |d| {
            if d.y >= 0.0 {
                self.sky_radiance(d)
            } else {
                [0.0; 3]
            }
        });
        let ground = self.ground_radiance(&map);
        let (w, h) = (map.width as usize, map.height as usize);
        for t in &mut map.texels[w * h.div_ceil(2)..] {
            *t = ground;
        }
        map
    }

    /// The sun as a directional light in world space, with the environment turned by
    /// `rotation_deg` and its radiance scaled by `intensity` (as the map).
    pub fn sun_light(&self, rotation_deg: f32, intensity: f32) -> Light {
        let to_sun = super::rotate_into_map(self.sun, -rotation_deg).normalize();
        let e = self.sun_irradiance() * intensity;
        let peak = e.max_element();
        Light {
            kind: LightKind::Directional,
            color: if peak > 0.0 { e / peak } else { Vec3::ZERO },
            intensity: peak,
            range: f32::INFINITY,
            position: Vec3::ZERO,
            direction: -to_sun,
            size: SUN_ANGULAR_RADIUS_DEG.to_radians(),
        }
    }
}
