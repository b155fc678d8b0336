//! Reflection, refraction and Fresnel: the host mirror of `shaders/common/brdf.glsl`
//! (unit-tested here, and checked against the shader by `tests/gpu/shader_math.rs`).

use glam::Vec3;

/// Mirror direction of incident `i` about unit normal `n`: `r = i - 2 (n·i) n`.
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - 2.0 * n.dot(i) * n
}

/// Snell refraction of unit incident `i` through unit normal `n` (facing against `i`) with
/// `eta = n1 / n2`; `None` on total internal reflection (negative square-root argument).
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -n.dot(i);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    (k >= 0.0).then(|| eta * i + (eta * cos_i - k.sqrt()) * n)
}

/// Schlick's Fresnel approximation for reflectance `f0` at normal incidence.
pub fn fresnel_schlick(f0: f32, cos_theta: f32) -> f32 {
    f0 + (1.0 - f0) * (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5)
}

/// Normal-incidence reflectance of a dielectric of index `ior` in air.
pub fn dielectric_f0(ior: f32) -> f32 {
    ((ior - 1.0) / (ior + 1.0)).powi(2)
}

/// Critical angle (radians) for light going from index `n1` into `n2 < n1`.
pub fn critical_angle(n1: f32, n2: f32) -> Option<f32> {
    (n2 < n1).then(|| (n2 / n1).asin())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn incident(angle: f32) -> Vec3 {
        // Travelling down onto the plane y = 0 (normal +Y) at `angle` from the normal.
        Vec3::new(angle.sin(), -angle.cos(), 0.0)
    }

    #[test]
    fn reflect_mirrors_about_the_normal() {
        let r = reflect(incident(0.3), Vec3::Y);
        assert!((r - Vec3::new(0.3f32.sin(), 0.3f32.cos(), 0.0)).length() < 1e-6);
        assert!((reflect(-Vec3::Y, Vec3::Y) - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn refract_obeys_snell() {
        let eta = 1.0 / 1.5;
        let t = refract(incident(0.5), Vec3::Y, eta).unwrap();
        assert!((t.length() - 1.0).abs() < 1e-5);
        let sin_t = t.x; // angle from -normal
        assert!((sin_t - eta * 0.5f32.sin()).abs() < 1e-6);
        // Normal incidence passes straight through.
        assert!((refract(-Vec3::Y, Vec3::Y, eta).unwrap() + Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn total_internal_reflection_at_and_beyond_the_critical_angle() {
        // Inside glass (1.5) towards air: eta = 1.5, critical angle asin(1/1.5) ≈ 41.81°.
        let crit = critical_angle(1.5, 1.0).unwrap();
        assert!((crit.to_degrees() - 41.8103).abs() < 1e-3);
        // Just below: refracts, grazing.
        let t = refract(incident(crit - 1e-3), Vec3::Y, 1.5).unwrap();
        assert!(t.y.abs() < 0.1, "near-grazing exit expected, got {t}");
        // Exactly at the critical angle the root is ~0: grazing or TIR within float noise.
        if let Some(t) = refract(incident(crit), Vec3::Y, 1.5) {
            assert!(t.y.abs() < 2e-3);
        }
        // Beyond: total internal reflection.
        assert!(refract(incident(crit + 1e-3), Vec3::Y, 1.5).is_none());
        assert!(refract(incident(1.2), Vec3::Y, 1.5).is_none());
        // From air into glass (eta = 1/1.5) there is never TIR, even at grazing angles.
        assert!(critical_angle(1.0, 1.5).is_none());
        assert!(refract(
            incident(std::f32::consts::FRAC_PI_2 - 1e-3),
            Vec3::Y,
            1.0 / 1.5
        )
        .is_some());
    }

    #[test]
    fn fresnel_limits() {
        let f0 = dielectric_f0(1.5);
        assert!((f0 - 0.04).abs() < 1e-6);
        assert!((fresnel_schlick(f0, 1.0) - f0).abs() < 1e-7, "0°: F = F0");
        assert!((fresnel_schlick(f0, 0.0) - 1.0).abs() < 1e-7, "90°: F = 1");
        assert!(fresnel_schlick(f0, 0.5) > f0 && fresnel_schlick(f0, 0.5) < 1.0);
        assert_eq!(fresnel_schlick(1.0, 0.3), 1.0);
    }
}
