//! The node graph: cycle check, local transforms, EXT_mesh_gpu_instancing, the animation rig,
//! cameras and lights.

use super::*;

impl Loader<'_> {
    /// Checks child indices and rejects cycles (iterative DFS, so deep trees cannot
    /// overflow the stack).
    pub(super) fn check_node_graph(&self) -> Result<(), SceneError> {
        let nodes = &self.root.nodes;
        for (n, node) in nodes.iter().enumerate() {
            for c in node.children.iter().flatten() {
                if c.value() >= nodes.len() {
                    return Err(self.err(
                        format!("node {n}"),
                        format!("child {} does not exist ({} nodes)", c.value(), nodes.len()),
                    ));
                }
            }
        }
        #[derive(Clone, Copy, PartialEq)]
        enum State {
            New,
            OnPath,
            Done,
        }
        let mut state = vec![State::New; nodes.len()];
        let children = |n: usize| nodes[n].children.as_deref().unwrap_or(&[]);
        for start in 0..nodes.len() {
            if state[start] != State::New {
                continue;
            }
            // (node, next child position)
            let mut path: Vec<(usize, usize)> = vec![(start, 0)];
            state[start] = State::OnPath;
            while let Some(top) = path.last_mut() {
                let n = top.0;
                if let Some(c) = children(n).get(top.1) {
                    top.1 += 1;
                    let c = c.value();
                    match state[c] {
                        State::New => {
                            state[c] = State::OnPath;
                            path.push((c, 0));
                        }
                        State::OnPath => {
                            let from = path.iter().position(|&(p, _)| p == c).unwrap_or(0);
                            let cycle: Vec<String> = path[from..]
                                .iter()
                                .map(|&(p, _)| format!("node {p}"))
                                .chain(std::iter::once(format!("node {c}")))
                                .collect();
                            return Err(self.err(
                                format!("node {c}"),
                                format!("node hierarchy has a cycle: {}", cycle.join(" -> ")),
                            ));
                        }
                        State::Done => {}
                    }
                } else {
                    state[n] = State::Done;
                    path.pop();
                }
            }
        }
        Ok(())
    }

    /// Skins, animations and the rest node hierarchy (parents are filled by
    /// [`Loader::load_scene`]).
    pub(super) fn load_rig(&mut self) -> Result<(), SceneError> {
        let (file, root, buffers) = (&self.file, &self.root, &self.buffers);
        morph::check_morph_counts(file, root)?;
        self.scene.rig = Rig {
            nodes: pose::rest_nodes(root),
            skins: skin::parse_skins(file, root, buffers)?,
            animations: animation::parse(file, root, buffers)?,
            ..Default::default()
        };
        Ok(())
    }

    pub(super) fn node_local(&self, n: usize) -> Result<Mat4, SceneError> {
        let node = &self.root.nodes[n];
        let m = if let Some(m) = node.matrix {
            Mat4::from_cols_array(&m)
        } else {
            let t = Vec3::from(node.translation.unwrap_or([0.0; 3]));
            let r = node
                .rotation
                .map_or(Quat::IDENTITY, |q| Quat::from_array(q.0));
            let s = Vec3::from(node.scale.unwrap_or([1.0; 3]));
            if r.length_squared() == 0.0 {
                return Err(self.err(format!("node {n}"), "rotation is a zero quaternion"));
            }
            Mat4::from_scale_rotation_translation(s, r.normalize(), t)
        };
        if !m.is_finite() {
            return Err(self.err(format!("node {n}"), "transform is not finite"));
        }
        Ok(m)
    }

    /// Instance transforms of a node's mesh: EXT_mesh_gpu_instancing's TRS per instance, or
    /// the identity.
    pub(super) fn gpu_instances(&self, n: usize) -> Result<Vec<Mat4>, SceneError> {
        let Some(ext) = self.root.nodes[n]
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("EXT_mesh_gpu_instancing"))
        else {
            return Ok(vec![Mat4::IDENTITY]);
        };
        let element = format!("node {n} EXT_mesh_gpu_instancing");
        let attrs = ext
            .get("attributes")
            .and_then(|a| a.as_object())
            .ok_or_else(|| self.err(&element, "missing 'attributes'"))?;
        let read = |name: &str, comps: usize| -> Result<Option<Vec<f32>>, SceneError> {
            let Some(v) = attrs.get(name) else {
                return Ok(None);
            };
            let index = v
                .as_u64()
                .ok_or_else(|| self.err(&element, format!("{name} is not an accessor index")))?;
            let e = accessor::read_f32(&self.root, &self.buffers, index as usize)
                .map_err(|m| self.err(&element, format!("{name} accessor {index}: {m}")))?;
            if e.comps != comps {
                return Err(self.err(
                    &element,
                    format!(
                        "{name} accessor {index} has {} components, expected {comps}",
                        e.comps
                    ),
                ));
            }
            Ok(Some(e.values))
        };
        let t = read("TRANSLATION", 3)?;
        let r = read("ROTATION", 4)?;
        let s = read("SCALE", 3)?;
        let counts: Vec<usize> = [(&t, 3), (&r, 4), (&s, 3)]
            .iter()
            .filter_map(|(v, c)| v.as_ref().map(|v| v.len() / c))
            .collect();
        let Some(&count) = counts.first() else {
            return Ok(vec![Mat4::IDENTITY]);
        };
        if counts.iter().any(|&c| c != count) {
            return Err(self.err(&element, format!("attribute counts differ: {counts:?}")));
        }
        if count > MAX_INSTANCES {
            return Err(self.err(
                &element,
                format!("{count} instances exceed rqr's limit of {MAX_INSTANCES}"),
            ));
        }
        let mut out = Vec::with_capacity(count);
        for i in 0..count {
            let tr = t
                .as_ref()
                .map_or(Vec3::ZERO, |v| Vec3::from_slice(&v[i * 3..]));
            let ro = r
                .as_ref()
                .map_or(Quat::IDENTITY, |v| Quat::from_slice(&v[i * 4..]));
            let sc = s
                .as_ref()
                .map_or(Vec3::ONE, |v| Vec3::from_slice(&v[i * 3..]));
            if ro.length_squared() == 0.0 {
                return Err(self.err(&element, format!("instance {i}: zero rotation quaternion")));
            }
            let m = Mat4::from_scale_rotation_translation(sc, ro.normalize(), tr);
            if !m.is_finite() {
                return Err(self.err(&element, format!("instance {i}: transform is not finite")));
            }
            out.push(m);
        }
        Ok(out)
    }

    pub(super) fn camera(&self, n: usize, c: usize, world: Mat4) -> Result<Camera, SceneError> {
        let el = format!("camera {c} (node {n})");
        let j = self.root.cameras.get(c).ok_or_else(|| {
            self.err(
                &el,
                format!("does not exist ({} cameras)", self.root.cameras.len()),
            )
        })?;
        let projection = match (checked(&j.type_), &j.perspective, &j.orthographic) {
            (Some(gj::camera::Type::Perspective), Some(p), _) => {
                if !(p.yfov > 0.0 && p.yfov < std::f32::consts::PI) {
                    return Err(self.err(&el, format!("yfov {} is outside (0, π)", p.yfov)));
                }
                if p.znear <= 0.0 || p.zfar.is_some_and(|f| f <= p.znear) {
                    return Err(self.err(
                        &el,
                        format!("invalid clip planes znear {} zfar {:?}", p.znear, p.zfar),
                    ));
                }
                if p.aspect_ratio.is_some_and(|a| a <= 0.0) {
                    return Err(self.err(&el, "aspectRatio must be positive"));
                }
                Projection::Perspective {
                    yfov: p.yfov,
                    aspect: p.aspect_ratio,
                    znear: p.znear,
                    zfar: p.zfar,
                }
            }
            (Some(gj::camera::Type::Orthographic), _, Some(o)) => {
                if o.xmag == 0.0 || o.ymag == 0.0 || o.znear < 0.0 || o.zfar <= o.znear {
                    return Err(self.err(
                        &el,
                        format!(
                            "invalid orthographic camera (xmag {}, ymag {}, znear {}, zfar {})",
                            o.xmag, o.ymag, o.znear, o.zfar
                        ),
                    ));
                }
                Projection::Orthographic {
                    xmag: o.xmag.abs(),
                    ymag: o.ymag.abs(),
                    znear: o.znear,
                    zfar: o.zfar,
                }
            }
            (Some(t), _, _) => {
                return Err(self.err(&el, format!("{t:?} camera without its {t:?} properties")))
            }
            (None, _, _) => return Err(self.err(&el, "invalid type")),
        };
        Ok(Camera {
            camera_to_world: camera_pose(world),
            projection,
        })
    }

    pub(super) fn light(&self, n: usize, l: usize, world: Mat4) -> Result<Light, SceneError> {
        use gj::extensions::scene::khr_lights_punctual::Type;
        let el = format!("light {l} (node {n})");
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map_or(&[][..], |k| &k.lights[..]);
        let j = lights
            .get(l)
            .ok_or_else(|| self.err(&el, format!("does not exist ({} lights)", lights.len())))?;
        let kind = match checked(&j.type_) {
            Some(Type::Directional) => LightKind::Directional,
            Some(Type::Point) => LightKind::Point,
            Some(Type::Spot) => {
                let spot = j.spot.clone().unwrap_or_default();
                let (inner, outer) = (spot.inner_cone_angle, spot.outer_cone_angle);
                if !(0.0 <= inner && inner < outer && outer <= std::f32::consts::FRAC_PI_2 + 1e-6) {
                    return Err(self.err(
                        &el,
                        format!("spot cone angles inner {inner} / outer {outer} must satisfy 0 <= inner < outer <= π/2"),
                    ));
                }
                LightKind::Spot {
                    inner_cone: inner,
                    outer_cone: outer,
                }
            }
            None => return Err(self.err(&el, "invalid type")),
        };
        if j.intensity < 0.0 {
            return Err(self.err(&el, format!("intensity {} is negative", j.intensity)));
        }
        if j.range.is_some_and(|r| r <= 0.0) {
            return Err(self.err(&el, "range must be positive"));
        }
        let size = light_size_extra(&el, &kind, j.extras.as_deref().map(|r| r.get()));
        Ok(Light {
            kind,
            color: Vec3::from(j.color),
            intensity: j.intensity,
            range: j.range.unwrap_or(f32::INFINITY),
            position: world.transform_point3(Vec3::ZERO),
            direction: world
                .transform_vector3(Vec3::NEG_Z)
                .normalize_or(Vec3::NEG_Z),
            size,
        })
    }
}

/// The light's size from its glTF `extras` (the distributed model's soft shadows):
/// `{"radius": R}` for point and spot lights (scene units), `{"angularRadius": θ}` for
/// directional ones (radians). A missing key is 0 (punctual); a value of the wrong type, a
/// negative or non-finite one, or the other light kind's key is a warning naming the light,
/// and 0 is used.
pub(crate) fn light_size_extra(light: &str, kind: &LightKind, extras: Option<&str>) -> f32 {
    let Some(text) = extras else {
        return 0.0;
    };
    let Ok(serde_json::Value::Object(map)) = serde_json::from_str::<serde_json::Value>(text) else {
        return 0.0;
    };
    let (key, other) = match kind {
        LightKind::Directional => ("angularRadius", "radius"),
        _ => ("radius", "angularRadius"),
    };
    if map.contains_key(other) {
        log::warn!("{light}: extras.{other} does not apply to this kind of light (it takes extras.{key}); ignored");
    }
    let Some(value) = map.get(key) else {
        return 0.0;
    };
    match value.as_f64() {
        Some(v)
            if v.is_finite()
                && v >= 0.0
                && (key == "radius" || v < std::f64::consts::FRAC_PI_2) =>
        {
            v as f32
        }
        _ => {
            let what = if key == "radius" {
                "a non-negative number (scene units)"
            } else {
                "an angle in radians in [0, π/2)"
            };
            log::warn!(
                "{light}: extras.{key} must be {what}, not {value}; using 0 (a punctual light)"
            );
            0.0
        }
    }
}

#[cfg(test)]
mod light_size_tests {
    use super::*;

    #[test]
    fn light_sizes_come_from_extras_of_their_kind() {
        let point = LightKind::Point;
        let sun = LightKind::Directional;
        assert_eq!(light_size_extra("l", &point, None), 0.0);
        assert_eq!(
            light_size_extra("l", &point, Some(r#"{"radius": 0.3}"#)),
            0.3
        );
        assert_eq!(
            light_size_extra("l", &sun, Some(r#"{"angularRadius": 0.01}"#)),
            0.01
        );
        // The other kind's key, a wrong type, a negative value, too wide a cone: punctual.
        assert_eq!(light_size_extra("l", &sun, Some(r#"{"radius": 0.3}"#)), 0.0);
        assert_eq!(
            light_size_extra("l", &point, Some(r#"{"radius": "1"}"#)),
            0.0
        );
        assert_eq!(
            light_size_extra("l", &point, Some(r#"{"radius": -1}"#)),
            0.0
        );
        assert_eq!(
            light_size_extra("l", &sun, Some(r#"{"angularRadius": 1.6}"#)),
            0.0
        );
        assert_eq!(light_size_extra("l", &point, Some("[1, 2]")), 0.0);
    }
}
