//! Memory order of built bottom levels: how far apart a node and its children, and
//! consecutive leaves' triangles, lie in the arrays. Two trees of equal SAH cost can trace at
//! different speeds once they outgrow the caches; these numbers compare the host and GPU
//! builders' layouts (`rqr bench` reports them) and [`check_depth_first`] states the order
//! both builders produce.

use super::layout::{decode_link, BvhNode};
use super::BvhData;

/// Memory-order statistics over the inner-node links and leaves of bottom levels.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Locality {
    /// Parent → inner-child links counted.
    pub links: u64,
    /// Mean `|child - parent|` in nodes (64 bytes each).
    pub mean_child_distance: f64,
    /// Share of nodes with an inner child whose first inner child is the next node.
    pub first_child_adjacent: f64,
    /// Share of parent → child links within 64 nodes (4 KiB, one page).
    pub child_within_page: f64,
    /// Share of nodes whose subtree's triangles fill one contiguous range of the triangle
    /// array (1: a subtree's leaves share cache lines and pages).
    pub contiguous_subtrees: f64,
    /// Whether every bottom level is stored in depth-first pre-order ([`check_depth_first`]).
    pub depth_first: bool,
}

/// Statistics over every distinct bottom level an instance enters.
pub fn measure(data: &BvhData) -> Locality {
    let mut sum_distance = 0.0;
    let mut links = 0u64;
    let mut within_page = 0u64;
    let mut parents = 0u64;
    let mut adjacent = 0u64;
    let mut nodes = 0u64;
    let mut contiguous = 0u64;
    let mut depth_first = true;
    for root in blas_roots(data) {
        depth_first &= check_depth_first(&data.nodes, root).is_ok();
        let mut stack = vec![root];
        while let Some(index) = stack.pop() {
            let Some(node) = data.nodes.get(index as usize) else {
                continue;
            };
            let inner: Vec<u32> = node
                .children()
                .filter_map(|c| decode_link(c.link).ok())
                .collect();
            if let Some(&first) = inner.first() {
                parents += 1;
                adjacent += u64::from(first == index + 1);
            }
            for &c in &inner {
                let d = c.abs_diff(index);
                sum_distance += f64::from(d);
                within_page += u64::from(d < 64);
                links += 1;
            }
            stack.extend(inner.iter().rev());
        }
        for (lo, hi, count) in triangle_ranges(&data.nodes, root) {
            nodes += 1;
            contiguous += u64::from(count == 0 || hi - lo == count);
        }
    }
    let ratio = |a: f64, b: u64| if b == 0 { 0.0 } else { a / b as f64 };
    Locality {
        links,
        mean_child_distance: ratio(sum_distance, links),
        first_child_adjacent: ratio(adjacent as f64, parents),
        child_within_page: ratio(within_page as f64, links),
        contiguous_subtrees: ratio(contiguous as f64, nodes),
        depth_first,
    }
}

/// Per node of the tree at `root` (in post-order): the lowest and one past the highest
/// triangle index under it, and how many triangles it holds.
fn triangle_ranges(nodes: &[BvhNode], root: u32) -> Vec<(u32, u32, u32)> {
    let mut out = Vec::new();
    // (node, children done): a node is summarised after all its inner children.
    let mut stack = vec![(root, false)];
    let mut done: Vec<(u32, u32, u32)> = Vec::new();
    while let Some((index, expanded)) = stack.pop() {
        let Some(node) = nodes.get(index as usize) else {
            continue;
        };
        let inner = node.children().filter(|c| decode_link(c.link).is_ok());
        if !expanded {
            stack.push((index, true));
            stack.extend(inner.filter_map(|c| decode_link(c.link).ok().map(|c| (c, false))));
            continue;
        }
        let mut range = (u32::MAX, 0u32, 0u32);
        let mut merge = |lo: u32, hi: u32, count: u32| {
            range = (range.0.min(lo), range.1.max(hi), range.2 + count);
        };
        for _ in inner {
            // Inner children's ranges were pushed last (their order does not matter here).
            if let Some((lo, hi, count)) = done.pop() {
                merge(lo, hi, count);
            }
        }
        for c in node.children() {
            if let Err((first, count)) = decode_link(c.link) {
                merge(first, first + count, count);
            }
        }
        out.push(range);
        done.push(range);
    }
    out
}

/// Roots of the distinct bottom levels that instances enter.
fn blas_roots(data: &BvhData) -> Vec<u32> {
    let mut roots: Vec<u32> = data
        .instances
        .iter()
        .map(|i| i.blas_root)
        .filter(|&r| r as usize >= data.stats.tlas_nodes && (r as usize) < data.nodes.len())
        .collect();
    roots.sort_unstable();
    roots.dedup();
    roots
}

/// Checks that the tree at `root` is stored in depth-first pre-order: visiting inner children
/// in link order, the k-th node visited is node `root + k`. So every node's first inner child
/// is the next node, and every subtree occupies one contiguous range of nodes that starts at
/// its root and precedes its next sibling's. Returns the number of nodes, or which node breaks
/// the order.
pub fn check_depth_first(nodes: &[BvhNode], root: u32) -> Result<u32, String> {
    let mut expected = root;
    let mut stack = vec![root];
    while let Some(index) = stack.pop() {
        if index != expected {
            return Err(format!(
                "node {index} is the {}-th visited in pre-order, expected at {expected}",
                expected - root
            ));
        }
        let node = nodes
            .get(index as usize)
            .ok_or_else(|| format!("link to node {index} beyond {} nodes", nodes.len()))?;
        expected += 1;
        let start = stack.len();
        stack.extend(node.children().filter_map(|c| decode_link(c.link).ok()));
        stack[start..].reverse();
    }
    Ok(expected - root)
}
