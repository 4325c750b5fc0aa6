//! Horton-Strahler and Tokunaga statistics of a river network (seed paper 000, Sec. IV-A:
//! the networks must be self-similar in these measures).

use serde::Serialize;

use super::network::RiverNetwork;

/// The measures the report and the tests use.
#[derive(Clone, Debug, Default, Serialize)]
pub struct NetworkStats {
    pub nodes: usize,
    pub links: usize,
    pub max_order: u32,
    /// `streams_per_order[k - 1]`: number of Strahler streams of order k.
    pub streams_per_order: Vec<usize>,
    /// Horton's bifurcation ratio `R_b`: `N_k ~ R_b^-k`, fitted by least squares in log.
    pub bifurcation_ratio: Option<f64>,
    /// `mean_stream_length[k - 1]`: the mean length of the streams of order k (the links
    /// of order k end to end, over their number), in the nodes' units.
    pub mean_stream_length: Vec<f64>,
    /// Horton's length ratio `R_L` (Horton 1945's law of stream lengths): `L_k ~ R_L^k`,
    /// fitted by least squares in log; real networks 1.5-3.
    pub length_ratio: Option<f64>,
    /// Tokunaga's side-branch counts `T_m` (m = 1, 2, ...): average number of tributaries of
    /// order `k - m` joining a stream of order `k`, averaged over k.
    pub tokunaga: Vec<f64>,
    /// Fit `T_m = a c^(m - 1)`.
    pub tokunaga_a: Option<f64>,
    pub tokunaga_c: Option<f64>,
}

/// Strahler order of every node's downstream link (the estuary gets its subtree's order):
/// sources are 1; where two or more branches of the highest upstream order k meet, k + 1;
/// otherwise that highest order. O(nodes); children always come after their parent.
pub fn strahler_orders(net: &RiverNetwork) -> Vec<u32> {
    let n = net.nodes.len();
    let mut best = vec![0u32; n];
    let mut best_count = vec![0u32; n];
    let mut order = vec![1u32; n];
    for node in (0..n).rev() {
        order[node] = match best[node] {
            0 => 1,
            k if best_count[node] >= 2 => k + 1,
            k => k,
        };
        if let Some(p) = net.parent[node] {
            let p = p as usize;
            if order[node] > best[p] {
                best[p] = order[node];
                best_count[p] = 1;
            } else if order[node] == best[p] {
                best_count[p] += 1;
            }
        }
    }
    order
}

/// Computes [`NetworkStats`]. O(nodes).
///
/// `net` may be a forest: every node without a parent is an estuary (an outlet), and the
/// counts pool all its trees (the channel network of a DEM, with one tree per outlet, or
/// several grown networks merged with [`RiverNetwork::forest`]). On a single tree rooted at
/// node 0 this is the network's own statistics.
pub fn analyse(net: &RiverNetwork) -> NetworkStats {
    let n = net.nodes.len();
    let links = net.parent.iter().filter(|p| p.is_some()).count();
    if links == 0 {
        return NetworkStats {
            nodes: n,
            ..Default::default()
        };
    }
    let order = strahler_orders(net);
    // A link is a node with a parent; an estuary's order is that of its links anyway.
    let has_link = |node: usize| net.parent[node].is_some();
    let max_order = (0..n)
        .filter(|&i| has_link(i))
        .map(|i| order[i])
        .max()
        .unwrap_or(1);
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (p, c) in net.link_pairs() {
        children[p].push(c);
    }
    let k_max = max_order as usize;
    // A link of order k heads a stream when no upstream link continues it at order k.
    let mut streams = vec![0usize; k_max];
    for node in (0..n).filter(|&i| has_link(i)) {
        let k = order[node];
        if !children[node].iter().any(|&c| order[c] == k) {
            streams[k as usize - 1] += 1;
        }
    }
    // Side tributaries: at a node whose stream continues upstream at order k, every other
    // upstream link of order j < k.
    let mut side = vec![vec![0usize; k_max + 1]; k_max + 1];
    for node in 0..n {
        let k = order[node];
        if !children[node].iter().any(|&c| order[c] == k) {
            continue;
        }
        for &c in &children[node] {
            if order[c] < k {
                side[k as usize][order[c] as usize] += 1;
            }
        }
    }
    let mut tokunaga = Vec::new();
    for m in 1..k_max {
        let values: Vec<f64> = ((m + 1)..=k_max)
            .filter(|&k| streams[k - 1] > 0)
            .map(|k| side[k][k - m] as f64 / streams[k - 1] as f64)
            .collect();
        if values.is_empty() {
            break;
        }
        tokunaga.push(values.iter().sum::<f64>() / values.len() as f64);
    }
    let bifurcation_ratio = log_fit(
        &streams
            .iter()
            .enumerate()
            .filter(|(_, s)| **s > 0)
            .map(|(k, &s)| (k as f64, (s as f64).ln()))
            .collect::<Vec<_>>(),
    )
    .map(|(_, slope)| (-slope).exp());
    // Horton's law of stream lengths: every link of order k lies on one stream of order k.
    let mut length_of_order = vec![0.0f64; k_max];
    for node in (0..n).filter(|&i| has_link(i)) {
        if let Some(p) = net.parent[node] {
            length_of_order[order[node] as usize - 1] +=
                net.nodes[node].distance(net.nodes[p as usize]);
        }
    }
    let mean_stream_length: Vec<f64> = length_of_order
        .iter()
        .zip(&streams)
        .map(|(l, &s)| if s > 0 { l / s as f64 } else { 0.0 })
        .collect();
    let length_ratio = log_fit(
        &mean_stream_length
            .iter()
            .enumerate()
            .filter(|(_, l)| **l > 0.0)
            .map(|(k, &l)| (k as f64, l.ln()))
            .collect::<Vec<_>>(),
    )
    .map(|(_, slope)| slope.exp());
    let tok_fit = log_fit(
        &tokunaga
            .iter()
            .enumerate()
            .filter(|(_, t)| **t > 0.0)
            .map(|(m, &t)| (m as f64, t.ln()))
            .collect::<Vec<_>>(),
    );
    NetworkStats {
        nodes: n,
        links,
        max_order,
        streams_per_order: streams,
        bifurcation_ratio,
        mean_stream_length,
        length_ratio,
        tokunaga,
        tokunaga_a: tok_fit.map(|(a, _)| a.exp()),
        tokunaga_c: tok_fit.map(|(_, c)| c.exp()),
    }
}

/// Least-squares line `y = a + b x`; `None` with fewer than two points.
fn log_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(sx, sy), (x, y)| (sx + x, sy + y));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(sxy, sxx), (x, y)| {
        (sxy + (x - mx) * (y - my), sxx + (x - mx) * (x - mx))
    });
    (sxx > 0.0).then(|| {
        let b = sxy / sxx;
        (my - b * mx, b)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    /// A perfect binary tree of depth 2 below the estuary link: orders 3 / 2 / 1.
    #[test]
    fn strahler_orders_of_a_binary_tree() {
        let mut net = RiverNetwork::default();
        let parents = [
            None,
            Some(0),
            Some(1),
            Some(1),
            Some(2),
            Some(2),
            Some(3),
            Some(3),
        ];
        // Links of order 1 one unit long, of order 2 two, the order-3 link four.
        let at = [
            (0.0, 0.0),
            (0.0, 4.0),
            (-2.0, 4.0),
            (2.0, 4.0),
            (-3.0, 4.0),
            (-2.0, 5.0),
            (3.0, 4.0),
            (2.0, 5.0),
        ];
        for (p, (x, y)) in parents.into_iter().zip(at) {
            net.nodes.push(DVec2::new(x, y));
            net.parent.push(p);
            net.exterior.push(false);
            net.height.push(0.0);
        }
        let order = strahler_orders(&net);
        assert_eq!(order, vec![3, 3, 2, 2, 1, 1, 1, 1]);
        let stats = analyse(&net);
        assert_eq!(stats.max_order, 3);
        assert_eq!(stats.streams_per_order, vec![4, 2, 1]);
        assert!((stats.bifurcation_ratio.unwrap() - 2.0).abs() < 1e-9);
        // Streams twice as long at each order: R_L = 2.
        assert_eq!(stats.mean_stream_length, vec![1.0, 2.0, 4.0]);
        assert!((stats.length_ratio.unwrap() - 2.0).abs() < 1e-9);
        // No side tributaries in a perfect binary tree.
        assert!(stats.tokunaga.iter().all(|&t| t == 0.0));

        // Two such trees and a lone order-1 link as one forest: the counts pool, no link
        // joins the estuaries.
        let mut lone = RiverNetwork::default();
        for p in [None, Some(0)] {
            lone.nodes.push(DVec2::ZERO);
            lone.parent.push(p);
            lone.exterior.push(true);
            lone.height.push(0.0);
        }
        let forest = RiverNetwork::forest(&[net.clone(), lone, net]);
        let stats = analyse(&forest);
        assert_eq!((stats.nodes, stats.links, stats.max_order), (18, 15, 3));
        assert_eq!(stats.streams_per_order, vec![9, 4, 2]);
    }
}
