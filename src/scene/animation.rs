//! glTF animations: samplers and channels read and validated at load time, sampled at any
//! time with the spec's LINEAR (slerp for rotations), STEP and CUBICSPLINE interpolation.
//!
//! Every error names the file and the element (`animation 2 sampler 0`, `animation 0
//! channel 3`).

use ::gltf::json as gj;
use gj::validation::Checked;
use glam::{Quat, Vec4};

use super::accessor::{self, Buffers};
use super::error::SceneError;

/// How a sampler interpolates between keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Linear (spherical linear for rotations).
    Linear,
    /// The value of the previous key until the next one.
    Step,
    /// Cubic Hermite spline; every key stores in-tangent, value, out-tangent.
    CubicSpline,
}

/// The node property a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    /// Local translation (3 values).
    Translation,
    /// Local rotation quaternion x, y, z, w (4 values).
    Rotation,
    /// Local scale (3 values).
    Scale,
    /// Morph target weights of the node's mesh (one value per target).
    Weights,
}

/// Keyframes of one sampler.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    /// Key times in seconds, strictly increasing.
    pub input: Vec<f32>,
    /// `width` values per key (`3 * width` for CUBICSPLINE: in-tangent, value, out-tangent).
    pub output: Vec<f32>,
    /// Values per key element: 3, 4 or the morph target count.
    pub width: usize,
    /// Interpolation.
    pub interpolation: Interpolation,
}

/// One animated property of one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channel {
    /// glTF node index.
    pub node: usize,
    /// The property.
    pub property: Property,
    /// Index into [`Animation::samplers`].
    pub sampler: usize,
}

/// One glTF animation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    /// Name (may be empty).
    pub name: String,
    /// Samplers.
    pub samplers: Vec<Sampler>,
    /// Channels.
    pub channels: Vec<Channel>,
}

impl Animation {
    /// Time of the last key over all samplers (0 for an empty animation).
    pub fn duration(&self) -> f32 {
        self.samplers
            .iter()
            .filter_map(|s| s.input.last().copied())
            .fold(0.0, f32::max)
    }
}

/// Which animations play (`--animation N|NAME|all`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AnimationSelection {
    /// The first animation (the default); nothing when the file has none.
    #[default]
    First,
    /// Animation N.
    Index(usize),
    /// The animation with this name.
    Name(String),
    /// Every animation at once.
    All,
    /// None: the rest pose.
    None,
}

impl std::str::FromStr for AnimationSelection {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "" => return Err("empty animation name".into()),
            "all" => Self::All,
            "none" => Self::None,
            _ => match s.parse::<usize>() {
                Ok(i) => Self::Index(i),
                Err(_) => Self::Name(s.to_string()),
            },
        })
    }
}

impl AnimationSelection {
    /// Indices of the selected animations among `animations`, or an error naming the file
    /// when the index or name does not exist.
    pub fn resolve(&self, file: &str, animations: &[Animation]) -> Result<Vec<usize>, SceneError> {
        let all = || (0..animations.len()).collect::<Vec<_>>();
        match self {
            Self::First => Ok(all().into_iter().take(1).collect()),
            Self::All => Ok(all()),
            Self::None => Ok(Vec::new()),
            Self::Index(i) if *i < animations.len() => Ok(vec![*i]),
            Self::Index(i) => Err(SceneError::element(
                file,
                format!("animation {i}"),
                format!("does not exist ({} animations)", animations.len()),
            )),
            Self::Name(name) => animations
                .iter()
                .position(|a| &a.name == name)
                .map(|i| vec![i])
                .ok_or_else(|| {
                    let names: Vec<&str> = animations.iter().map(|a| a.name.as_str()).collect();
                    SceneError::element(
                        file,
                        format!("animation '{name}'"),
                        format!("does not exist (animations: {names:?})"),
                    )
                }),
        }
    }
}

impl Sampler {
    /// Number of keys.
    pub fn keys(&self) -> usize {
        self.input.len()
    }

    /// Element `k` of the value array (CUBICSPLINE: element `3k + 1` is key k's value).
    fn element(&self, k: usize) -> &[f32] {
        &self.output[k * self.width..(k + 1) * self.width]
    }

    /// The value of key `k` (the spline vertex for CUBICSPLINE).
    pub fn key_value(&self, k: usize) -> &[f32] {
        match self.interpolation {
            Interpolation::CubicSpline => self.element(3 * k + 1),
            _ => self.element(k),
        }
    }

    /// Samples at `time` into `out` (`width` values). Times before the first key give the
    /// first value and after the last key the last value, as the spec asks. `rotation`:
    /// values are quaternions (LINEAR slerps; results are normalized).
    pub fn sample(&self, time: f32, rotation: bool, out: &mut [f32]) {
        let n = self.keys();
        let next = self.input.partition_point(|&k| k <= time);
        if next == 0 || next >= n || self.interpolation == Interpolation::Step {
            let k = next.saturating_sub(1).min(n - 1);
            out.copy_from_slice(self.key_value(k));
            if rotation {
                normalize_quat(out);
            }
            return;
        }
        let (a, b) = (next - 1, next);
        let dt = self.input[b] - self.input[a];
        let u = (time - self.input[a]) / dt;
        match self.interpolation {
            Interpolation::Step => unreachable!("handled above"),
            Interpolation::Linear if rotation => {
                let qa = Quat::from_slice(self.key_value(a)).normalize();
                let qb = Quat::from_slice(self.key_value(b)).normalize();
                out.copy_from_slice(&qa.slerp(qb, u).to_array());
            }
            Interpolation::Linear => {
                let (va, vb) = (self.key_value(a), self.key_value(b));
                for (o, (x, y)) in out.iter_mut().zip(va.iter().zip(vb)) {
                    *o = x + (y - x) * u;
                }
            }
            Interpolation::CubicSpline => {
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = u3 - 2.0 * u2 + u;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = u3 - u2;
                let v0 = self.element(3 * a + 1);
                let out0 = self.element(3 * a + 2);
                let in1 = self.element(3 * b);
                let v1 = self.element(3 * b + 1);
                for (i, o) in out.iter_mut().enumerate() {
                    *o = h00 * v0[i] + h10 * dt * out0[i] + h01 * v1[i] + h11 * dt * in1[i];
                }
                if rotation {
                    normalize_quat(out);
                }
            }
        }
    }
}

fn normalize_quat(q: &mut [f32]) {
    let v = Vec4::from_slice(q);
    let v = v.try_normalize().unwrap_or(Vec4::W);
    q.copy_from_slice(&v.to_array());
}

/// Morph target count of glTF mesh `mesh` (of its first primitive; the loader checks that
/// every primitive has the same count).
pub(super) fn target_count(root: &gj::Root, mesh: usize) -> usize {
    root.meshes
        .get(mesh)
        .and_then(|m| m.primitives.first())
        .and_then(|p| p.targets.as_ref())
        .map_or(0, Vec::len)
}

/// Reads and validates every animation of the file.
pub(super) fn parse(
    file: &str,
    root: &gj::Root,
    buffers: &Buffers,
) -> Result<Vec<Animation>, SceneError> {
    root.animations
        .iter()
        .enumerate()
        .map(|(a, anim)| parse_one(file, root, buffers, a, anim))
        .collect()
}

fn parse_one(
    file: &str,
    root: &gj::Root,
    buffers: &Buffers,
    a: usize,
    anim: &gj::animation::Animation,
) -> Result<Animation, SceneError> {
    let err = |element: String, message: String| SceneError::element(file, element, message);
    // Each sampler's width comes from the channels that use it.
    let mut channels = Vec::with_capacity(anim.channels.len());
    let mut widths: Vec<Option<(usize, usize)>> = vec![None; anim.samplers.len()];
    for (c, ch) in anim.channels.iter().enumerate() {
        let el = format!("animation {a} channel {c}");
        let node = ch.target.node.value();
        let Some(gltf_node) = root.nodes.get(node) else {
            return Err(err(
                el,
                format!(
                    "targets node {node}, which does not exist ({} nodes)",
                    root.nodes.len()
                ),
            ));
        };
        let property = match &ch.target.path {
            Checked::Valid(gj::animation::Property::Translation) => Property::Translation,
            Checked::Valid(gj::animation::Property::Rotation) => Property::Rotation,
            Checked::Valid(gj::animation::Property::Scale) => Property::Scale,
            Checked::Valid(gj::animation::Property::MorphTargetWeights) => Property::Weights,
            Checked::Invalid => return Err(err(el, "invalid target path".into())),
        };
        let width = match property {
            Property::Translation | Property::Scale => 3,
            Property::Rotation => 4,
            Property::Weights => {
                let targets = gltf_node.mesh.map_or(0, |m| target_count(root, m.value()));
                if targets == 0 {
                    return Err(err(
                        el,
                        format!(
                            "animates the weights of node {node}, whose mesh has no morph targets"
                        ),
                    ));
                }
                targets
            }
        };
        let sampler = ch.sampler.value();
        let Some(slot) = widths.get_mut(sampler) else {
            return Err(err(
                el,
                format!(
                    "sampler {sampler} does not exist ({} samplers)",
                    anim.samplers.len()
                ),
            ));
        };
        match slot {
            Some((w, first)) if *w != width => {
                return Err(err(
                    el,
                    format!("uses sampler {sampler} with {width} values per key, but channel {first} uses it with {w}"),
                ))
            }
            _ => *slot = Some((width, c)),
        }
        channels.push(Channel {
            node,
            property,
            sampler,
        });
    }
    let mut samplers = Vec::with_capacity(anim.samplers.len());
    for (s, js) in anim.samplers.iter().enumerate() {
        let el = format!("animation {a} sampler {s}");
        let interpolation = match &js.interpolation {
            Checked::Valid(gj::animation::Interpolation::Linear) => Interpolation::Linear,
            Checked::Valid(gj::animation::Interpolation::Step) => Interpolation::Step,
            Checked::Valid(gj::animation::Interpolation::CubicSpline) => Interpolation::CubicSpline,
            Checked::Invalid => return Err(err(el, "invalid interpolation".into())),
        };
        let input_index = js.input.value();
        let input = accessor::read_f32(root, buffers, input_index)
            .map_err(|m| err(el.clone(), format!("input accessor {input_index}: {m}")))?;
        if input.comps != 1 {
            return Err(err(
                el,
                format!(
                    "input accessor {input_index} has {} components, expected SCALAR times",
                    input.comps
                ),
            ));
        }
        let input = input.values;
        if input.is_empty() {
            return Err(err(el, format!("input accessor {input_index} has no keys")));
        }
        if let Some(k) = input.iter().position(|t| !t.is_finite()) {
            return Err(err(
                el,
                format!("input accessor {input_index}: key {k} time is not finite"),
            ));
        }
        if let Some(k) = input.windows(2).position(|w| w[1] <= w[0]) {
            return Err(err(
                el,
                format!(
                    "input times are not strictly increasing: key {} is {} after key {k} at {}",
                    k + 1,
                    input[k + 1],
                    input[k]
                ),
            ));
        }
        let output_index = js.output.value();
        let output = accessor::read_f32(root, buffers, output_index)
            .map_err(|m| err(el.clone(), format!("output accessor {output_index}: {m}")))?;
        let Some((width, _)) = widths[s] else {
            // A sampler no channel uses: kept so indices stay valid, never sampled.
            samplers.push(Sampler {
                input,
                output: Vec::new(),
                width: 0,
                interpolation,
            });
            continue;
        };
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        // Vectors are read as such; weights are SCALAR with `width` elements per key.
        let values = output.values.len();
        let want = input.len() * per_key * width;
        if values != want {
            let what = if interpolation == Interpolation::CubicSpline {
                format!(
                    "CUBICSPLINE needs 3 elements (in-tangent, value, out-tangent) of {width} values per key: {} keys need {want} values",
                    input.len()
                )
            } else {
                format!("{} keys of {width} values need {want} values", input.len())
            };
            return Err(err(
                el,
                format!("output accessor {output_index} has {values} values; {what}"),
            ));
        }
        if let Some(k) = output.values.iter().position(|v| !v.is_finite()) {
            return Err(err(
                el,
                format!("output accessor {output_index}: value {k} is not finite"),
            ));
        }
        samplers.push(Sampler {
            input,
            output: output.values,
            width,
            interpolation,
        });
    }
    Ok(Animation {
        name: anim.name.clone().unwrap_or_default(),
        samplers,
        channels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(
        interpolation: Interpolation,
        input: &[f32],
        output: &[f32],
        width: usize,
    ) -> Sampler {
        Sampler {
            input: input.to_vec(),
            output: output.to_vec(),
            width,
            interpolation,
        }
    }

    #[test]
    fn linear_step_and_clamping() {
        let s = sampler(Interpolation::Linear, &[1.0, 3.0], &[0.0, 10.0], 1);
        let mut v = [0.0];
        for (t, want) in [
            (0.0, 0.0),
            (1.0, 0.0),
            (2.0, 5.0),
            (2.5, 7.5),
            (3.0, 10.0),
            (9.0, 10.0),
        ] {
            s.sample(t, false, &mut v);
            assert_eq!(v[0], want, "linear at {t}");
        }
        let s = Sampler {
            interpolation: Interpolation::Step,
            ..s
        };
        for (t, want) in [(0.0, 0.0), (2.9, 0.0), (3.0, 10.0)] {
            s.sample(t, false, &mut v);
            assert_eq!(v[0], want, "step at {t}");
        }
    }

    #[test]
    fn cubic_spline_matches_hermite_by_hand() {
        // Keys at 0 and 2 with values 0 and 1, out-tangent 1 at key 0, in-tangent -1 at key 1.
        let s = sampler(
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &[9.0, 0.0, 1.0, -1.0, 1.0, 9.0],
            1,
        );
        let mut v = [0.0];
        s.sample(1.0, false, &mut v);
        // u = 0.5: h00 = 0.5, h10 = 0.125, h01 = 0.5, h11 = -0.125; dt = 2.
        let (v0, out0, v1, in1, dt) = (0.0, 1.0, 1.0, -1.0, 2.0);
        let want = 0.5 * v0 + 0.125 * dt * out0 + 0.5 * v1 - 0.125 * dt * in1;
        assert!((v[0] - want).abs() < 1e-6, "{} vs {want}", v[0]);
    }

    #[test]
    fn rotation_slerps_the_short_way() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let mut out = [0.0; 4];
        let s = sampler(
            Interpolation::Linear,
            &[0.0, 1.0],
            &[a.to_array(), b.to_array()].concat(),
            4,
        );
        s.sample(0.5, true, &mut out);
        let want = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(Quat::from_slice(&out).abs_diff_eq(want, 1e-6));
    }

    #[test]
    fn selection_parses() {
        assert_eq!("all".parse(), Ok(AnimationSelection::All));
        assert_eq!("2".parse(), Ok(AnimationSelection::Index(2)));
        assert_eq!("Walk".parse(), Ok(AnimationSelection::Name("Walk".into())));
    }
}
