//! Host-side invariants of the built BVH and agreement of the CPU traversal with brute force.

use std::collections::HashMap;

use glam::{Mat4, Vec2, Vec3};

use super::cpu::{alpha_accepts_untextured, brute_force_closest, HostHit, Ray};
use super::layout::{decode_link, BvhBox, BVH_INSTANCE_ALPHA_TEST};
use super::testing::*;
use super::*;
use crate::scene::Instance;

/// Checks every structural invariant; returns the number of leaves visited.
fn check_invariants(scene: &Scene, data: &BvhData, max_leaf: u32) -> usize {
    // Every usable triangle of every usable instance is reachable exactly once.
    let mut seen: HashMap<(u32, u32), u32> = HashMap::new();
    for key in data.leaf_primitives() {
        *seen.entry(key).or_default() += 1;
    }
    let mut expected = 0;
    for (i, inst) in scene.instances.iter().enumerate() {
        if cpu::world_to_object_rows(&inst.transform).is_none() {
            continue;
        }
        let g = &scene.geometries[inst.geometry as usize];
        for (prim, idx) in g.indices.chunks_exact(3).enumerate() {
            let v = [0, 1, 2].map(|k| g.positions[idx[k] as usize]);
            if v[0] == v[1] || v[1] == v[2] || v[0] == v[2] || !v.iter().all(|p| p.is_finite()) {
                assert!(!seen.contains_key(&(i as u32, prim as u32)));
                continue;
            }
            expected += 1;
            assert_eq!(
                seen.get(&(i as u32, prim as u32)),
                Some(&1),
                "instance {i} triangle {prim}"
            );
        }
    }
    assert_eq!(seen.len(), expected, "unexpected primitives in leaves");

    // Every primitive lies inside every box on its path (what traversal relies on); child boxes
    // nest in their parent's box up to the outward rounding of the child node's quantization;
    // leaves are within the size limit.
    let mut leaves = 0;
    type Entry = (u32, Option<u32>, Vec<BvhBox>);
    let mut stack: Vec<Entry> = vec![(TLAS_ROOT, None, Vec::new())];
    while let Some((node, inst, path)) = stack.pop() {
        let n = &data.nodes[node as usize];
        let children: Vec<_> = n.children().collect();
        if node != TLAS_ROOT || !scene.instances.is_empty() {
            assert!(!children.is_empty() || data.stats.skipped_instances > 0);
        }
        for c in &children {
            if let Some(p) = path.last() {
                for (a, s) in n.scales().iter().enumerate() {
                    assert!(c.bounds.min[a] >= p.min[a] - s, "{c:?} outside {p:?}");
                    assert!(c.bounds.max[a] <= p.max[a] + s, "{c:?} outside {p:?}");
                }
            }
            let mut below = path.clone();
            below.push(c.bounds);
            match (decode_link(c.link), inst) {
                (Ok(next), _) => {
                    assert!((next as usize) < data.nodes.len());
                    assert!(next > node, "pre-order: children after parents");
                    stack.push((next, inst, below));
                }
                (Err((i, count)), None) => {
                    assert_eq!(count, 1, "top-level leaves hold one instance");
                    let bi = &data.instances[i as usize];
                    let inst = &scene.instances[i as usize];
                    assert_eq!(bi.geometry, inst.geometry);
                    let positions = &scene.geometries[inst.geometry as usize].positions;
                    for p in positions.iter().filter(|p| p.is_finite()) {
                        let w = inst.transform.transform_point3(*p).to_array();
                        for b in &below {
                            assert!(b.contains(w), "instance {i}: vertex {w:?} outside {b:?}");
                        }
                    }
                    stack.push((bi.blas_root, Some(i), Vec::new()));
                }
                (Err((first, count)), Some(_)) => {
                    leaves += 1;
                    assert!(count >= 1 && count <= max_leaf, "leaf of {count}");
                    for t in first..first + count {
                        let tri = &data.triangles[t as usize];
                        for v in [tri.v0, tri.v1, tri.v2] {
                            for b in &below {
                                assert!(b.contains(v), "vertex {v:?} outside {b:?}");
                            }
                        }
                    }
                }
            }
        }
    }
    assert_eq!(data.stats.node_count, data.nodes.len());
    assert!(data.stats.max_stack <= layout::BVH_STACK_SIZE);
    assert!(data.stats.max_stack <= 3 * data.stats.max_depth);
    assert!(data.byte_size() <= BvhData::estimate_bytes(scene));
    leaves
}

fn same_hit(a: &Option<HostHit>, b: &Option<HostHit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            (a.t - b.t).abs() <= 1e-5 * a.t.abs().max(1e-6)
                && (a.instance == b.instance && a.primitive == b.primitive || a.t == b.t)
        }
        _ => false,
    }
}

/// CPU traversal of the flattened BVH against brute force (closest and any).
fn check_against_brute_force(scene: &Scene, data: &BvhData, rays: &[Ray]) -> usize {
    let accepts = |i, p, b| alpha_accepts_untextured(scene, i, p, b);
    let mut hits = 0;
    for (k, ray) in rays.iter().enumerate() {
        let want = brute_force_closest(scene, ray, accepts);
        let got = data.trace_closest(ray, accepts);
        assert!(
            same_hit(&want, &got),
            "ray {k} {ray:?}: bvh {got:?} vs brute {want:?}"
        );
        assert_eq!(data.trace_any(ray, accepts), want.is_some(), "any, ray {k}");
        hits += usize::from(want.is_some());
    }
    hits
}

#[test]
fn random_triangles_every_leaf_size() {
    let mut rng = Rng::new(1);
    let scene = scene_of(vec![random_triangles(&mut rng, 3000, 10.0, 1.0)], vec![]);
    let rays = random_rays(&mut rng, &scene, 2000);
    for max_leaf in [1, 2, 4, 8, 16] {
        let opts = BvhBuildOptions {
            max_leaf_size: max_leaf,
            collapse_traversal_cost: 3.0,
            ..Default::default()
        };
        let data = BvhData::build(&scene, &opts).unwrap();
        let leaves = check_invariants(&scene, &data, max_leaf);
        assert!(leaves >= 3000usize.div_ceil(max_leaf as usize));
        if max_leaf == 1 {
            assert_eq!(leaves, 3000);
            // 4-wide nodes: about a third of the binary tree's 2999 inner nodes.
            assert!(data.nodes.len() < 1500, "{} nodes", data.nodes.len());
        }
        let hits = check_against_brute_force(&scene, &data, &rays);
        assert!(
            hits > 400,
            "only {hits} of 2000 rays hit: generator broken?"
        );
    }
}

#[test]
fn instancing_stores_each_geometry_once() {
    let mut rng = Rng::new(2);
    let scene = instanced_grid(&mut rng, 4, 5);
    let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
    assert_eq!(data.triangles.len(), scene.unique_triangle_count());
    assert_eq!(data.stats.blas_count, 3);
    assert_eq!(data.instances.len(), 20);
    assert!(
        data.stats.tlas_depth >= 3,
        "20 instances need >= 3 levels of 4-wide nodes"
    );
    check_invariants(&scene, &data, 4);
    let mirrored = scene.instances.iter().filter(|i| i.flips_winding()).count();
    assert!(mirrored >= 5);
    let rays = random_rays(&mut rng, &scene, 3000);
    let hits = check_against_brute_force(&scene, &data, &rays);
    assert!(hits > 600, "{hits}");
}

#[test]
fn closed_meshes_never_leak_at_edges_or_vertices() {
    // Rays from inside towards every vertex and edge midpoint of closed meshes.
    for (name, geom) in [
        ("cube", grid_cube(4)),
        ("sphere", scaled_sphere(13, 9, 1.5)),
    ] {
        let scene = scene_of(vec![geom.clone()], vec![]);
        let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
        let mut targets: Vec<Vec3> = geom.positions.clone();
        for t in geom.indices.chunks_exact(3) {
            for k in 0..3 {
                let (a, b) = (
                    geom.positions[t[k] as usize],
                    geom.positions[t[(k + 1) % 3] as usize],
                );
                targets.push((a + b) * 0.5);
            }
        }
        let origins = [
            Vec3::ZERO,
            Vec3::new(0.25, -0.125, 0.5),
            Vec3::new(-0.3, 0.2, 0.1),
        ];
        for o in origins {
            for (k, t) in targets.iter().enumerate() {
                let ray = Ray {
                    origin: o,
                    dir: *t - o,
                    tmin: 0.0,
                    tmax: f32::INFINITY,
                };
                let hit = data.trace_closest(&ray, |_, _, _| true);
                let h = hit.unwrap_or_else(|| panic!("{name}: ray {k} from {o} to {t} leaked"));
                assert!(
                    (h.t - 1.0).abs() < 1e-5,
                    "{name}: t = {} for target {t}",
                    h.t
                );
            }
        }
    }
}

#[test]
fn alpha_mask_skips_transparent_hits() {
    let scene = alpha_quads();
    let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
    assert_eq!(
        data.instances[0].flags & BVH_INSTANCE_ALPHA_TEST,
        BVH_INSTANCE_ALPHA_TEST
    );
    assert_eq!(data.instances[2].flags & BVH_INSTANCE_ALPHA_TEST, 0);
    let accepts = |i, p, b| alpha_accepts_untextured(&scene, i, p, b);
    let ray = |x: f32| Ray {
        origin: Vec3::new(x, 0.1, 3.0),
        dir: Vec3::new(0.0, 0.0, -1.0),
        tmin: 0.0,
        tmax: 100.0,
    };
    // x > 0: the vertex-alpha quad at z = 0 blocks; x < 0: only the opaque one at z = -1.
    let right = data.trace_closest(&ray(0.5), accepts).unwrap();
    assert_eq!((right.instance, right.t), (1, 3.0));
    let left = data.trace_closest(&ray(-0.5), accepts).unwrap();
    assert_eq!((left.instance, left.t), (2, 4.0));
    // Without alpha, the first quad would win.
    assert_eq!(
        data.trace_closest(&ray(-0.5), |_, _, _| true)
            .unwrap()
            .instance,
        0
    );
    let shadow = |x: f32, tmax: f32| Ray { tmax, ..ray(x) };
    assert!(!data.trace_any(&shadow(-0.5, 3.5), accepts));
    assert!(data.trace_any(&shadow(0.5, 3.5), accepts));
    let mut rng = Rng::new(3);
    check_against_brute_force(&scene, &data, &random_rays(&mut rng, &scene, 2000));
}

#[test]
fn barycentrics_weight_vertices_one_and_two_in_index_order() {
    let g = geometry(
        vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ],
        vec![0, 1, 2],
        0,
    );
    let scene = scene_of(vec![g], vec![]);
    let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
    for dz in [-1.0f32, 1.0] {
        let ray = Ray {
            origin: Vec3::new(0.25, 0.5, -dz),
            dir: Vec3::new(0.0, 0.0, dz * 0.5),
            tmin: 0.0,
            tmax: 10.0,
        };
        let h = data.trace_closest(&ray, |_, _, _| true).unwrap();
        assert_eq!(h.t, 2.0, "t is in units of the unnormalised dir");
        assert!(
            (h.barycentrics - Vec2::new(0.25, 0.5)).length() < 1e-6,
            "{h:?}"
        );
    }
}

#[test]
fn degenerate_inputs_do_not_panic() {
    // Empty scene: one root with two empty children, every ray misses.
    let empty = Scene::default();
    let data = BvhData::build(&empty, &BvhBuildOptions::default()).unwrap();
    assert_eq!(data.nodes.len(), 1);
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::X,
        tmin: 0.0,
        tmax: f32::INFINITY,
    };
    assert!(data.trace_closest(&ray, |_, _, _| true).is_none());

    // One triangle: the root wraps the single leaf; a singular instance is skipped; a zero
    // direction never hits; triangles with repeated or NaN vertices are dropped.
    let mut g = geometry(
        vec![
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ],
        vec![0, 1, 2, 0, 0, 1],
        0,
    );
    g.positions.push(Vec3::NAN);
    g.indices.extend([0, 1, 3]);
    let mut scene = scene_of(vec![g], vec![]);
    scene.instances.push(Instance {
        geometry: 0,
        transform: Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        node: 1,
    });
    let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
    assert_eq!(data.stats.skipped_instances, 1);
    assert_eq!(data.stats.skipped_triangles, 2);
    assert_eq!(data.triangles.len(), 1);
    check_invariants(&scene, &data, 4);
    let hit = data
        .trace_closest(
            &Ray {
                dir: Vec3::Z,
                ..ray
            },
            |_, _, _| true,
        )
        .unwrap();
    assert_eq!((hit.instance, hit.primitive, hit.t), (0, 0, 1.0));
    assert!(data
        .trace_closest(
            &Ray {
                dir: Vec3::ZERO,
                ..ray
            },
            |_, _, _| true
        )
        .is_none());

    // Out-of-range references are errors, not panics.
    let mut bad = scene.clone();
    bad.geometries[0].indices.extend([0, 1, 99]);
    assert!(matches!(
        BvhData::build(&bad, &Default::default()),
        Err(BvhError::InvalidScene(_))
    ));
    let mut bad = scene.clone();
    bad.instances[0].geometry = 7;
    assert!(matches!(
        BvhData::build(&bad, &Default::default()),
        Err(BvhError::InvalidScene(_))
    ));
    let mut bad = scene;
    bad.geometries[0].material = 5;
    assert!(matches!(
        BvhData::build(&bad, &Default::default()),
        Err(BvhError::InvalidScene(_))
    ));
}

#[test]
fn size_checks_use_the_largest_device_local_heap() {
    use crate::vk::MemoryHeapInfo;
    let heaps = [
        MemoryHeapInfo {
            size_bytes: 1 << 30,
            device_local: true,
        },
        MemoryHeapInfo {
            size_bytes: 1 << 34,
            device_local: false,
        },
    ];
    assert!(check_fits(&heaps, 1 << 29, "exact").is_ok());
    let err = check_fits(&heaps, (1 << 30) + 1, "estimate").unwrap_err();
    assert!(matches!(err, BvhError::TooLarge { heap, .. } if heap == 1 << 30));
    assert!(err.to_string().contains("1073741825 bytes"), "{err}");
    assert!(check_fits(&[], 1, "exact").is_err());
    // The estimate bounds the exact size.
    let mut rng = Rng::new(9);
    let scene = instanced_grid(&mut rng, 3, 3);
    let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
    assert!(data.byte_size() <= BvhData::estimate_bytes(&scene));
    assert!(data.byte_size() * 3 >= BvhData::estimate_bytes(&scene));
}
