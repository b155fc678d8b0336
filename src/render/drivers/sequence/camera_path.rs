//! Camera paths of a sequence: orbit, dolly, and glTF camera animation sampled per frame.

use std::path::Path;
use std::str::FromStr;

use glam::{Mat4, Quat, Vec3};
use serde::Serialize;

use crate::scene::Camera;

/// A camera path as written on the command line (`--camera-path`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CameraPathSpec {
    /// The camera does not move.
    Static,
    /// Rotate about the vertical axis (world +Y) through the pivot, degrees per frame.
    Orbit(f32),
    /// Move along the view direction, scene units per frame.
    Dolly(f32),
    /// The glTF file's animation of the camera node.
    Gltf,
}

impl FromStr for CameraPathSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let number = |v: &str, what: &str| -> Result<f32, String> {
            match v.trim().parse::<f32>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(format!("{what} '{v}' is not a finite number")),
            }
        };
        match s.split_once(':') {
            Some(("orbit", v)) => Ok(Self::Orbit(number(v, "orbit: degrees per frame")?)),
            Some(("dolly", v)) => Ok(Self::Dolly(number(v, "dolly: distance per frame")?)),
            None if s == "gltf" => Ok(Self::Gltf),
            None if s == "static" => Ok(Self::Static),
            _ => Err(format!(
                "unknown camera path '{s}': expected orbit:DEG_PER_FRAME, dolly:DIST_PER_FRAME, gltf or static"
            )),
        }
    }
}

impl std::fmt::Display for CameraPathSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Static => write!(f, "static"),
            Self::Orbit(d) => write!(f, "orbit:{d}"),
            Self::Dolly(d) => write!(f, "dolly:{d}"),
            Self::Gltf => write!(f, "gltf"),
        }
    }
}

/// A camera path resolved against a scene: the camera of every frame number.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPath {
    /// The base camera in every frame.
    Static,
    /// Frame k: the base camera rotated by k × `degrees_per_frame` about the vertical line
    /// through `pivot` (position and orientation turn together).
    Orbit {
        /// Degrees per frame (positive: counter-clockwise seen from above).
        degrees_per_frame: f32,
        /// A point on the rotation axis.
        pivot: Vec3,
    },
    /// Frame k: the base camera moved k × `distance_per_frame` along its view direction.
    Dolly {
        /// Scene units per frame.
        distance_per_frame: f32,
    },
    /// The glTF animation of the camera's node, sampled at `frame / fps` seconds.
    Animation(Box<CameraAnimation>),
}

impl CameraPath {
    /// The camera of frame `frame`; `base` is frame 0's camera of orbit, dolly and static paths.
    pub fn camera(&self, base: &Camera, frame: u32) -> Camera {
        let k = frame as f32;
        match self {
            Self::Static => *base,
            Self::Orbit {
                degrees_per_frame,
                pivot,
            } => {
                let turn = Mat4::from_translation(*pivot)
                    * Mat4::from_rotation_y((degrees_per_frame * k).to_radians())
                    * Mat4::from_translation(-*pivot);
                Camera {
                    camera_to_world: turn * base.camera_to_world,
                    projection: base.projection,
                }
            }
            Self::Dolly { distance_per_frame } => Camera {
                camera_to_world: Mat4::from_translation(base.forward() * distance_per_frame * k)
                    * base.camera_to_world,
                projection: base.projection,
            },
            Self::Animation(a) => a.camera(base, frame),
        }
    }
}

/// Why a glTF camera animation could not be read.
#[derive(Debug, thiserror::Error)]
#[error("camera path gltf: {0}")]
pub struct CameraAnimationError(pub String);

/// Keyframes of one animation property.
#[derive(Clone, Debug, PartialEq)]
enum Track<T> {
    Linear(Vec<f32>, Vec<T>),
    Step(Vec<f32>, Vec<T>),
    /// Per key: in-tangent, value, out-tangent.
    Cubic(Vec<f32>, Vec<[T; 3]>),
}

trait Keyframe: Copy {
    fn lerp(a: Self, b: Self, t: f32) -> Self;
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, dt: f32, t: f32) -> Self;
}

impl Keyframe for Vec3 {
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        a.lerp(b, t)
    }
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, dt: f32, t: f32) -> Self {
        let (t2, t3) = (t * t, t * t * t);
        v0 * (2.0 * t3 - 3.0 * t2 + 1.0)
            + out0 * dt * (t3 - 2.0 * t2 + t)
            + v1 * (-2.0 * t3 + 3.0 * t2)
            + in1 * dt * (t3 - t2)
    }
}

impl Keyframe for Quat {
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        a.slerp(b, t)
    }
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, dt: f32, t: f32) -> Self {
        let (t2, t3) = (t * t, t * t * t);
        let v = glam::Vec4::from(v0) * (2.0 * t3 - 3.0 * t2 + 1.0)
            + glam::Vec4::from(out0) * dt * (t3 - 2.0 * t2 + t)
            + glam::Vec4::from(v1) * (-2.0 * t3 + 3.0 * t2)
            + glam::Vec4::from(in1) * dt * (t3 - t2);
        Quat::from_vec4(v).normalize()
    }
}

impl<T: Keyframe> Track<T> {
    /// glTF sampling: clamped to the first and last key.
    fn sample(&self, time: f32) -> Option<T> {
        let times = match self {
            Self::Linear(t, _) | Self::Step(t, _) | Self::Cubic(t, _) => t,
        };
        let last = times.len().checked_sub(1)?;
        let i = times.partition_point(|&k| k <= time);
        let (a, b, u) = if i == 0 {
            (0, 0, 0.0)
        } else if i > last {
            (last, last, 0.0)
        } else {
            let dt = times[i] - times[i - 1];
            (
                i - 1,
                i,
                if dt > 0.0 {
                    (time - times[i - 1]) / dt
                } else {
                    0.0
                },
            )
        };
        Some(match self {
            Self::Linear(_, v) => T::lerp(*v.get(a)?, *v.get(b)?, u),
            Self::Step(_, v) => *v.get(a)?,
            Self::Cubic(t, v) => {
                let (ka, kb) = (v.get(a)?, v.get(b)?);
                if a == b {
                    ka[1]
                } else {
                    T::hermite(ka[1], ka[2], kb[1], kb[0], t[b] - t[a], u)
                }
            }
        })
    }
}

/// The translation/rotation animation of a glTF camera node (channels on the node itself;
/// its parents are taken as static, at their rest pose).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraAnimation {
    parent_world: Mat4,
    rest: (Vec3, Quat, Vec3),
    translation: Option<Track<Vec3>>,
    rotation: Option<Track<Quat>>,
    /// Frames per second: frame k samples the animation at k / fps seconds.
    pub fps: f32,
}

impl CameraAnimation {
    /// Reads the animation of camera `camera` (the scene's camera index, as in
    /// [`Scene::cameras`](crate::scene::Scene::cameras)) in scene `scene` (default: the file's default scene, else 0) of a
    /// `.gltf`/`.glb` file.
    pub fn load(
        path: &Path,
        scene: Option<usize>,
        camera: usize,
        fps: f32,
    ) -> Result<Self, CameraAnimationError> {
        let err = |m: String| CameraAnimationError(format!("{}: {m}", path.display()));
        if !(fps.is_finite() && fps > 0.0) {
            return Err(CameraAnimationError(format!(
                "--fps {fps} must be a positive number"
            )));
        }
        let gltf = gltf::Gltf::open(path).map_err(|e| err(e.to_string()))?;
        let doc = &gltf.document;
        let chosen = match scene {
            Some(i) => doc.scenes().nth(i),
            None => doc.default_scene().or_else(|| doc.scenes().next()),
        }
        .ok_or_else(|| err("the file has no such scene".into()))?;
        // The loader's camera order: camera nodes reached from the scene, by node index.
        let mut cameras: Vec<(usize, Mat4)> = Vec::new();
        let mut stack: Vec<(gltf::Node, Mat4)> =
            chosen.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
        let mut visits = 0usize;
        while let Some((node, parent)) = stack.pop() {
            visits += 1;
            if visits > crate::scene::MAX_INSTANCES {
                return Err(err("the node hierarchy is too large".into()));
            }
            if node.camera().is_some() {
                cameras.push((node.index(), parent));
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            stack.extend(node.children().map(|c| (c, world)));
        }
        cameras.sort_by_key(|c| c.0);
        let &(node_index, parent_world) = cameras.get(camera).ok_or_else(|| {
            err(format!(
                "camera {camera} does not exist ({} cameras)",
                cameras.len()
            ))
        })?;
        let node = doc
            .nodes()
            .nth(node_index)
            .ok_or_else(|| err("camera node missing".into()))?;
        let (t, r, s) = node.transform().decomposed();
        let buffers = gltf::import_buffers(doc, path.parent(), gltf.blob.clone())
            .map_err(|e| err(e.to_string()))?;
        let mut translation = None;
        let mut rotation = None;
        for animation in doc.animations() {
            for channel in animation.channels() {
                if channel.target().node().index() != node_index {
                    continue;
                }
                let reader = channel.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let times: Vec<f32> = reader
                    .read_inputs()
                    .ok_or_else(|| err("animation sampler without input times".into()))?
                    .collect();
                let interpolation = channel.sampler().interpolation();
                let outputs = reader
                    .read_outputs()
                    .ok_or_else(|| err("animation sampler without outputs".into()))?;
                use gltf::animation::util::ReadOutputs;
                match outputs {
                    ReadOutputs::Translations(v) if translation.is_none() => {
                        let v: Vec<Vec3> = v.map(Vec3::from).collect();
                        translation = Some(track(interpolation, times, v).map_err(err)?);
                    }
                    ReadOutputs::Rotations(v) if rotation.is_none() => {
                        let v: Vec<Quat> = v.into_f32().map(Quat::from_array).collect();
                        rotation = Some(track(interpolation, times, v).map_err(err)?);
                    }
                    _ => {}
                }
            }
        }
        if translation.is_none() && rotation.is_none() {
            return Err(err(format!(
                "scene has no camera animation (no translation or rotation channel targets camera {camera}'s node {node_index})"
            )));
        }
        Ok(Self {
            parent_world,
            rest: (Vec3::from(t), Quat::from_array(r), Vec3::from(s)),
            translation,
            rotation,
            fps,
        })
    }

    /// The camera of frame `frame` (projection from `base`).
    pub fn camera(&self, base: &Camera, frame: u32) -> Camera {
        let time = frame as f32 / self.fps;
        let (t, r, s) = self.rest;
        let t = self
            .translation
            .as_ref()
            .and_then(|k| k.sample(time))
            .unwrap_or(t);
        let r = self
            .rotation
            .as_ref()
            .and_then(|k| k.sample(time))
            .unwrap_or(r);
        let mut world =
            self.parent_world * Mat4::from_scale_rotation_translation(s, r.normalize(), t);
        if !world.is_finite() {
            // Degenerate keys (a zero quaternion): keep the node's rest pose.
            let (t, r, s) = self.rest;
            world = self.parent_world * Mat4::from_scale_rotation_translation(s, r.normalize(), t);
        }
        Camera {
            camera_to_world: crate::scene::camera::camera_pose(world),
            projection: base.projection,
        }
    }
}

fn track<T: Copy>(
    interpolation: gltf::animation::Interpolation,
    times: Vec<f32>,
    values: Vec<T>,
) -> Result<Track<T>, String> {
    use gltf::animation::Interpolation;
    let bad = || {
        format!(
            "animation has {} keys and {} values",
            times.len(),
            values.len()
        )
    };
    if times.is_empty() || times.iter().any(|t| !t.is_finite()) {
        return Err("animation input times are empty or not finite".into());
    }
    Ok(match interpolation {
        Interpolation::Linear if values.len() == times.len() => Track::Linear(times, values),
        Interpolation::Step if values.len() == times.len() => Track::Step(times, values),
        Interpolation::CubicSpline if values.len() == 3 * times.len() => Track::Cubic(
            times,
            values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        ),
        _ => return Err(bad()),
    })
}
