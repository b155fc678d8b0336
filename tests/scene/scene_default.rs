//! The built-in default scene: loads from the embedded GLB and has the content the renderer
//! relies on (glass, mirror, textured floor, two lights, a camera that sees everything).

use glam::Vec3;
use rqr::scene::{self, LightKind, Projection, Scene};

fn default_scene() -> Scene {
    scene::load_default().expect("built-in scene loads")
}

#[test]
fn embedded_glb_is_the_checked_in_asset() {
    let on_disk = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/default_scene.glb"
    ))
    .unwrap();
    assert_eq!(scene::DEFAULT_SCENE_GLB, &on_disk[..]);
    assert!(on_disk.starts_with(b"glTF"));
}

#[test]
fn default_scene_has_the_required_content() {
    let s = default_scene();
    assert_eq!(s.source, "built-in");
    assert!(s.extensions_unsupported.is_empty());

    let glass: Vec<_> = s
        .materials
        .iter()
        .filter(|m| m.transmission == 1.0 && m.ior == 1.5 && m.thickness > 0.0)
        .collect();
    assert_eq!(glass.len(), 2, "glass sphere and glass block");
    assert!(glass
        .iter()
        .all(|m| m.metallic == 0.0 && m.roughness == 0.0));
    assert!(
        s.materials
            .iter()
            .any(|m| m.metallic == 1.0 && m.roughness == 0.0 && m.transmission == 0.0),
        "a mirror"
    );
    assert!(
        s.materials
            .iter()
            .any(|m| m.transmission == 0.0 && m.metallic == 0.0 && m.roughness == 1.0),
        "diffuse surfaces"
    );

    // The floor: the only textured material, sRGB base colour, 256² checker, repeating.
    let floor = s.materials.iter().find(|m| m.name == "floor").unwrap();
    let tex = floor.base_color_texture.expect("floor base colour texture");
    let t = s.textures[tex.texture as usize];
    let img = &s.images[t.image as usize];
    assert!(img.srgb);
    assert_eq!((img.width, img.height), (256, 256));
    assert_ne!(
        img.rgba8[0..4],
        img.rgba8[32 * 4..32 * 4 + 4],
        "checker cells differ"
    );
    let floor_geom = s
        .geometries
        .iter()
        .find(|g| s.materials[g.material as usize].name == "floor")
        .unwrap();
    assert_eq!(floor_geom.uv0.len(), floor_geom.positions.len());

    // Two lights of different kinds, not the default rig, well inside the room.
    assert!(!s.default_lights);
    assert_eq!(s.lights.len(), 2);
    let point = s
        .lights
        .iter()
        .find(|l| l.kind == LightKind::Point)
        .unwrap();
    let spot = s
        .lights
        .iter()
        .find(|l| matches!(l.kind, LightKind::Spot { .. }))
        .unwrap();
    for l in [point, spot] {
        assert!((20.0..=100.0).contains(&l.intensity), "{l:?}");
        assert!(l.position.abs().max_element() < 4.0 && l.position.y > 3.0);
    }
    assert!(
        spot.direction.y < -0.5,
        "the spot shines down into the room"
    );

    // A 4 m room.
    assert_eq!(s.bounds.min, Vec3::new(-2.0, 0.0, -2.0));
    assert_eq!(s.bounds.max, Vec3::new(2.0, 4.0, 2.0));
}

#[test]
fn default_camera_sees_every_object() {
    let s = default_scene();
    assert_eq!(s.cameras.len(), 1);
    let cam = s.camera(None, 1.0).unwrap();
    let Projection::Perspective { yfov, .. } = cam.projection else {
        panic!("perspective camera expected");
    };
    assert!(cam.position().z > 2.0, "in front of the open side");
    for inst in &s.instances {
        let name = &s.materials[s.geometries[inst.geometry as usize].material as usize].name;
        if name.contains("wall") || name == "floor" {
            continue;
        }
        let centre = inst.transform.transform_point3(Vec3::ZERO);
        let angle = cam.forward().angle_between(centre - cam.position());
        assert!(
            angle < yfov * 0.45,
            "{name} at {centre} is {angle} rad off-axis"
        );
    }
}

#[test]
fn default_scene_winding_faces_the_right_way() {
    // Spheres and boxes wind outwards; the room's surfaces face its interior.
    let s = default_scene();
    let room_centre = Vec3::new(0.0, 2.0, 0.0);
    for inst in &s.instances {
        let g = &s.geometries[inst.geometry as usize];
        let name = &s.materials[g.material as usize].name;
        let is_room = name.contains("wall") || name == "floor";
        let centre = inst.transform.transform_point3(Vec3::ZERO);
        for t in g.indices.chunks_exact(3) {
            let p = [t[0], t[1], t[2]]
                .map(|i| inst.transform.transform_point3(g.positions[i as usize]));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let mid = (p[0] + p[1] + p[2]) / 3.0;
            let outward = if is_room {
                room_centre - mid
            } else {
                mid - centre
            };
            assert!(n.dot(outward) > 0.0, "{name}: triangle {p:?} faces inwards");
            // Stored normals agree with the winding.
            let sn = g.normals[t[0] as usize];
            assert!(inst.transform.transform_vector3(sn).dot(n) > 0.0, "{name}");
        }
    }
}
