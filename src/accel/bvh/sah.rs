//! Surface-area-heuristic cost of built 4-wide BVHs, the quality measure that compares the host
//! and GPU builders (and a BVH before and after a refit) on the same layout.
//!
//! The cost of one bottom level is the expected work of a ray that hits its root box:
//! `sum over nodes A(node) / A(root) * C_node + sum over leaves A(leaf) / A(root) * count * C_tri`
//! with `C_node = C_tri = 1` (one node visit slab-tests four boxes in about the time of one
//! triangle test), areas taken from the dequantized child boxes that traversal actually tests.

use super::layout::{decode_link, BvhBox, BvhNode};
use super::BvhData;

/// Cost of visiting one 4-wide node, relative to one triangle test.
pub const NODE_COST: f64 = 1.0;
/// Cost of one triangle test.
pub const TRIANGLE_COST: f64 = 1.0;

fn half_area(b: &BvhBox) -> f64 {
    let d: Vec<f64> = (0..3)
        .map(|a| (f64::from(b.max[a]) - f64::from(b.min[a])).max(0.0))
        .collect();
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

fn union_area(node: &BvhNode) -> f64 {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for c in node.children() {
        for a in 0..3 {
            lo[a] = lo[a].min(c.bounds.min[a]);
            hi[a] = hi[a].max(c.bounds.max[a]);
        }
    }
    half_area(&BvhBox { min: lo, max: hi })
}

/// SAH cost of the bottom level rooted at node `root`.
pub fn subtree_cost(nodes: &[BvhNode], root: u32) -> f64 {
    let Some(root_node) = nodes.get(root as usize) else {
        return 0.0;
    };
    let root_area = union_area(root_node);
    if root_area <= 0.0 {
        return NODE_COST;
    }
    let mut cost = 0.0;
    let mut stack = vec![(root, root_area)];
    while let Some((index, area)) = stack.pop() {
        cost += NODE_COST * area / root_area;
        let Some(node) = nodes.get(index as usize) else {
            continue;
        };
        for child in node.children() {
            let child_area = half_area(&child.bounds);
            match decode_link(child.link) {
                Ok(inner) => stack.push((inner, child_area)),
                Err((_, count)) => {
                    cost += TRIANGLE_COST * f64::from(count) * child_area / root_area;
                }
            }
        }
    }
    cost
}

/// SAH cost of every distinct bottom level that an instance enters, summed (one number per
/// scene; for a single mesh it is that mesh's cost).
pub fn blas_cost(data: &BvhData) -> f64 {
    let mut roots: Vec<u32> = data
        .instances
        .iter()
        .map(|i| i.blas_root)
        .filter(|&r| r as usize >= data.stats.tlas_nodes && (r as usize) < data.nodes.len())
        .collect();
    roots.sort_unstable();
    roots.dedup();
    roots.iter().map(|&r| subtree_cost(&data.nodes, r)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::testing::{geometry, random_triangles, scene_of, Rng};
    use crate::accel::bvh::BvhBuildOptions;
    use glam::Vec3;

    #[test]
    fn one_leaf_costs_one_node_plus_its_triangles() {
        let scene = scene_of(
            vec![geometry(
                vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1.0)],
                vec![0, 1, 2],
                0,
            )],
            vec![],
        );
        let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
        // Root node (area ratio 1) plus one triangle in a leaf whose box is the root's.
        assert!(
            (blas_cost(&data) - 2.0).abs() < 1e-9,
            "{}",
            blas_cost(&data)
        );
    }

    #[test]
    fn a_tree_costs_less_than_testing_every_triangle() {
        let mut rng = Rng::new(7);
        let scene = scene_of(vec![random_triangles(&mut rng, 2000, 10.0, 0.3)], vec![]);
        let data = BvhData::build(&scene, &BvhBuildOptions::default()).unwrap();
        let cost = blas_cost(&data);
        assert!(cost > 1.0 && cost < 200.0, "{cost}");
    }
}
