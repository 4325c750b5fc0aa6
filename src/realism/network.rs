//! The channel network of a DEM, for the network comparison of seed paper 000 (Sec. VII,
//! Fig. 8: the valley lines of a real terrain beside a generated river network).
//!
//! The DEM is filled by Priority-Flood+ε and drained by D8, exactly as for the drainage
//! density ([`super::drainage`]): outlets are the map border and the cells next to no data,
//! no-data cells take no part. Channels are the cells whose upstream area is at least the
//! channel initiation area. Every channel cell becomes a node of a [`RiverNetwork`] whose
//! parent is the cell it drains to, so the channel network is a forest with one tree per
//! outlet, and [`crate::river::stats::analyse`] (the code behind the `rivers.networks`
//! part of the `generate` report) gives its Strahler orders, stream counts, Horton's
//! bifurcation ratio and Tokunaga's T_k: the same numbers for a real and a generated
//! network.

use std::collections::VecDeque;
use std::ops::Range;

use glam::DVec2;
use serde::Serialize;

use super::default_channel_area_m2;
use super::drainage::{d8_receivers, flow_accumulation, priority_flood_epsilon};
use super::grid::Grid;
use crate::river::{NetworkStats, RiverNetwork, stats};

/// The channel cells of a DEM as a forest.
#[derive(Clone, Debug)]
pub struct ChannelNetwork {
    /// One node per channel cell; its parent is the cell it drains to (D8). The roots are
    /// outlet cells. Parents come before their children and every tree is a contiguous run
    /// of nodes. Positions in map units (cell centres, `(column + 0.5) / width`,
    /// `(row + 0.5) / height`), heights the filled heights, `exterior` marks channel heads.
    pub network: RiverNetwork,
    /// The raster cell (`row * width + column`) of every node.
    pub cells: Vec<usize>,
    /// Node ranges of the trees (basins), in the order of their outlet cells.
    pub basins: Vec<Range<usize>>,
    /// The channel initiation area used, m².
    pub channel_area_m2: f64,
}

/// The statistics of a DEM's channel network (`strahler analyze --network`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct ChannelReport {
    /// Channel initiation area, m²: a cell is a channel when its D8 upstream area (its own
    /// included) is at least this.
    pub channel_area_m2: f64,
    /// Cells in the network (an outlet that no channel cell drains to is left out).
    pub channel_cells: usize,
    /// Outlets with at least one channel link: the separate trees of the network.
    pub basins: usize,
    /// All basins pooled (streams of every basin summed, Tokunaga ratios of the sums).
    pub stats: NetworkStats,
    /// The basin with the most channel cells alone: one tree, as one grown network is.
    pub largest_basin: NetworkStats,
}

impl ChannelNetwork {
    /// The basin `range` as a network of its own (its outlet is node 0).
    pub fn basin(&self, range: Range<usize>) -> RiverNetwork {
        let net = &self.network;
        let start = range.start as u32;
        RiverNetwork {
            nodes: net.nodes[range.clone()].to_vec(),
            parent: net.parent[range.clone()]
                .iter()
                .map(|p| p.map(|p| p - start))
                .collect(),
            exterior: net.exterior[range.clone()].to_vec(),
            height: net.height[range].to_vec(),
            link_length: net.link_length,
            trunk: Vec::new(),
            bends: Vec::new(),
        }
    }

    /// The statistics of the whole network and of its largest basin. O(channel cells).
    pub fn report(&self) -> ChannelReport {
        let largest = self
            .basins
            .iter()
            .max_by_key(|r| (r.len(), std::cmp::Reverse(r.start)))
            .cloned();
        ChannelReport {
            channel_area_m2: self.channel_area_m2,
            channel_cells: self.network.nodes.len(),
            basins: self.basins.len(),
            stats: stats::analyse(&self.network),
            largest_basin: largest
                .map(|r| stats::analyse(&self.basin(r)))
                .unwrap_or_default(),
        }
    }
}

/// A DEM's channel network beside generated river networks, row by row: a label and the
/// values for the DEM's whole network, its largest basin and the generated networks
/// (`networks` of them, pooled in `generated`). The table of `strahler analyze --network`
/// and of the app's DEM panel.
pub fn comparison_rows(
    dem: &ChannelReport,
    generated: &NetworkStats,
    networks: usize,
) -> Vec<(String, [String; 3])> {
    let columns = [&dem.stats, &dem.largest_basin, generated];
    let mut rows = Vec::new();
    let mut row = |label: &str, cells: [String; 3]| rows.push((label.to_owned(), cells));
    let each = |cell: &dyn Fn(&NetworkStats) -> String| columns.map(cell);
    let opt = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.2}"));
    row(
        "basins / networks",
        [
            dem.basins.to_string(),
            dem.basins.min(1).to_string(),
            networks.to_string(),
        ],
    );
    row("nodes (channel cells)", each(&|s| s.nodes.to_string()));
    row("Strahler order", each(&|s| s.max_order.to_string()));
    let orders = columns.iter().map(|s| s.max_order).max().unwrap_or(0) as usize;
    for k in 1..=orders {
        row(
            &format!("streams of order {k}"),
            each(&|s| {
                s.streams_per_order
                    .get(k - 1)
                    .map_or("-".into(), |n| n.to_string())
            }),
        );
    }
    row("bifurcation ratio R_b", each(&|s| opt(s.bifurcation_ratio)));
    row("length ratio R_L", each(&|s| opt(s.length_ratio)));
    let tk = columns.iter().map(|s| s.tokunaga.len()).max().unwrap_or(0);
    for m in 1..=tk {
        row(
            &format!("Tokunaga T_{m}"),
            each(&|s| opt(s.tokunaga.get(m - 1).copied())),
        );
    }
    row("Tokunaga fit a", each(&|s| opt(s.tokunaga_a)));
    row("Tokunaga fit c", each(&|s| opt(s.tokunaga_c)));
    rows
}

/// Extracts the channel network of a `width x height` row-major heightmap (cells `cell_x_m`
/// along a row by `cell_y_m` along a column; non-finite heights are no data).
/// `channel_area_m2` of `None` (or not positive / not finite) uses
/// [`default_channel_area_m2`], as the realism report's drainage density does. `None` when
/// the shape does not match `heights` or a cell size is zero or not finite.
/// O(cells log cells) for the fill, O(cells) for the rest.
pub fn extract_channels(
    heights: &[f32],
    width: usize,
    height: usize,
    cell_x_m: f64,
    cell_y_m: f64,
    channel_area_m2: Option<f64>,
) -> Option<ChannelNetwork> {
    let threshold = channel_area_m2
        .filter(|a| a.is_finite() && *a > 0.0)
        .unwrap_or_else(|| default_channel_area_m2(cell_x_m, cell_y_m));
    let g = Grid::new(heights, width, height, cell_x_m, cell_y_m)?;
    let (z, outlet) = priority_flood_epsilon(&g);
    let rcv = d8_receivers(&g, &z, &outlet);
    let area = flow_accumulation(&g, &rcv);
    // A channel cell drains to a cell of at least its area, so the channel cells are closed
    // downstream and every one of them reaches an outlet that is a channel cell too.
    let channel: Vec<bool> = area
        .iter()
        .zip(&g.z)
        .map(|(&a, v)| v.is_finite() && a >= threshold)
        .collect();
    // Channel donors of every cell, in compressed rows.
    let n = g.z.len();
    let mut first = vec![0u32; n + 1];
    for (i, r) in rcv.iter().enumerate() {
        if let Some((j, _)) = r
            && channel[i]
        {
            first[j + 1] += 1;
        }
    }
    for i in 0..n {
        first[i + 1] += first[i];
    }
    let mut fill = first.clone();
    let mut donors = vec![0u32; first[n] as usize];
    for (i, r) in rcv.iter().enumerate() {
        if let Some((j, _)) = r
            && channel[i]
        {
            donors[fill[j] as usize] = i as u32;
            fill[j] += 1;
        }
    }
    let donors_of = |j: usize| &donors[first[j] as usize..first[j + 1] as usize];

    let mut net = RiverNetwork {
        link_length: 1.0 / width.max(height) as f64,
        ..Default::default()
    };
    let mut cells = Vec::new();
    let mut basins = Vec::new();
    let mut queue = VecDeque::new();
    for (root, &is_channel) in channel.iter().enumerate() {
        if !is_channel || rcv.get(root).is_some() || donors_of(root).is_empty() {
            continue;
        }
        let start = cells.len();
        queue.push_back((root, None));
        while let Some((cell, parent)) = queue.pop_front() {
            let node = cells.len() as u32;
            let (r, c) = (cell / width, cell % width);
            net.nodes.push(DVec2::new(
                (c as f64 + 0.5) / width as f64,
                (r as f64 + 0.5) / height as f64,
            ));
            net.parent.push(parent);
            net.exterior.push(donors_of(cell).is_empty());
            net.height.push(z[cell] as f32);
            cells.push(cell);
            for &d in donors_of(cell) {
                queue.push_back((d as usize, Some(node)));
            }
        }
        basins.push(start..cells.len());
    }
    Some(ChannelNetwork {
        network: net,
        cells,
        basins,
        channel_area_m2: threshold,
    })
}

#[cfg(test)]
mod tests {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;

    use super::*;

    /// A `size x size` DEM (1 m cells) of V-shaped valleys along the straight channels
    /// `(x0, y0, x1, y1)` (cells, flowing from the first end to the second): every cell's
    /// height is its cost to the outlet `(outlet_x, size - 1)` on the 8-neighbour graph,
    /// 0.01 per metre along a channel and 1 per metre elsewhere (Dijkstra), so the valley
    /// floors descend gently and the hillslopes fall steeply and straight onto them.
    fn valleys(
        size: usize,
        channels: &[(usize, usize, usize, usize)],
        outlet_x: usize,
    ) -> Vec<f32> {
        let mut on_channel = vec![false; size * size];
        for &(x0, y0, x1, y1) in channels {
            let steps = x0.abs_diff(x1).max(y0.abs_diff(y1));
            for s in 0..=steps {
                let t = |a: usize, b: usize| {
                    (a as f64 + (b as f64 - a as f64) * s as f64 / steps as f64).round() as usize
                };
                on_channel[t(y0, y1) * size + t(x0, x1)] = true;
            }
        }
        let mut cost = vec![f64::INFINITY; size * size];
        let mut heap = BinaryHeap::new();
        let start = (size - 1) * size + outlet_x;
        cost[start] = 0.0;
        heap.push(Reverse(((0.0f64).to_bits(), start)));
        while let Some(Reverse((bits, i))) = heap.pop() {
            let ci = f64::from_bits(bits);
            if ci > cost[i] {
                continue;
            }
            let (r, c) = ((i / size) as isize, (i % size) as isize);
            for dr in -1..=1isize {
                for dc in -1..=1isize {
                    let (nr, nc) = (r + dr, c + dc);
                    if (dr, dc) == (0, 0) || nr < 0 || nc < 0 {
                        continue;
                    }
                    let (nr, nc) = (nr as usize, nc as usize);
                    if nr >= size || nc >= size {
                        continue;
                    }
                    let j = nr * size + nc;
                    let len = ((dr * dr + dc * dc) as f64).sqrt();
                    let rate = if on_channel[i] && on_channel[j] {
                        0.01
                    } else {
                        1.0
                    };
                    let cj = ci + len * rate;
                    if cj < cost[j] {
                        cost[j] = cj;
                        heap.push(Reverse((cj.to_bits(), j)));
                    }
                }
            }
        }
        cost.iter().map(|&c| (100.0 + c) as f32).collect()
    }

    /// The valley system of the test: two order-2 streams, each from two order-1 streams
    /// (heads on the map border), meet in an order-3 trunk that leaves the map through the
    /// south border; two order-1 side streams join the trunk. Every channel is straight and
    /// every junction a T, so no hillslope hollow gathers enough area for a channel.
    const TREE: [(usize, usize, usize, usize); 9] = [
        (40, 0, 40, 60),     // order 1, from the north border
        (0, 60, 40, 60),     // order 1, from the west border
        (120, 0, 120, 60),   // order 1, from the north border
        (160, 60, 120, 60),  // order 1, from the east border
        (40, 60, 80, 60),    // order 2
        (120, 60, 80, 60),   // order 2
        (80, 60, 80, 160),   // order 3, to the outlet on the south border
        (0, 110, 80, 110),   // order 1 side stream from the west
        (160, 135, 80, 135), // order 1 side stream from the east
    ];

    #[test]
    fn a_known_valley_tree_gives_its_orders_and_stream_counts() {
        let size = 161;
        let z = valleys(size, &TREE, 80);
        // Hillslopes gather at most about 80 m² (a row of the widest slope); the channels
        // gather that much per metre.
        let net = extract_channels(&z, size, size, 1.0, 1.0, Some(300.0)).unwrap();
        let report = net.report();
        assert_eq!(report.basins, 1, "{report:?}");
        let s = &report.stats;
        assert_eq!(s.max_order, 3, "{s:?}");
        assert_eq!(s.streams_per_order, vec![6, 2, 1], "{s:?}");
        // No order-1 stream joins an order-2 one, none of order 2 joins the trunk from the
        // side, two of order 1 do: T_1 = 0, T_2 = 2.
        assert_eq!(s.tokunaga, vec![0.0, 2.0], "{s:?}");
        // ln N_k = ln 6, ln 2, 0 fitted by a line: R_b = sqrt(6).
        assert!(
            (s.bifurcation_ratio.unwrap() - 6f64.sqrt()).abs() < 1e-9,
            "{s:?}"
        );
        // The outlet is the trunk's cell on the south border, every node drains to it.
        assert_eq!(net.cells[0], (size - 1) * size + 80);
        assert_eq!(report.largest_basin.streams_per_order, s.streams_per_order);
        // The channel cells are the drawn ones (heads start a few cells below the border).
        let (w, h) = (size as f64, size as f64);
        for p in &net.network.nodes {
            let (c, r) = ((p.x * w - 0.5).round(), (p.y * h - 0.5).round());
            let near = TREE.iter().any(|&(x0, y0, x1, y1)| {
                let (lo_x, hi_x) = (x0.min(x1) as f64, x0.max(x1) as f64);
                let (lo_y, hi_y) = (y0.min(y1) as f64, y0.max(y1) as f64);
                let dx = (lo_x - c).max(c - hi_x).max(0.0);
                let dy = (lo_y - r).max(r - hi_y).max(0.0);
                dx.max(dy) <= 1.0
            });
            assert!(near, "channel cell ({c}, {r}) off the drawn valleys");
        }
    }

    #[test]
    fn no_data_cells_are_skipped_and_their_neighbours_are_outlets() {
        let size = 161;
        let mut z = valleys(size, &TREE, 80);
        // The north of the map (rows 0..70) has no data: the order-1 and order-2 valleys
        // are gone, the trunk rises at the edge of the data and the side streams join it.
        for v in &mut z[..70 * size] {
            *v = f32::NAN;
        }
        let net = extract_channels(&z, size, size, 1.0, 1.0, Some(300.0)).unwrap();
        assert!(net.cells.iter().all(|&c| c >= 70 * size));
        let report = net.report();
        assert_eq!(report.basins, 1, "{report:?}");
        assert_eq!(report.stats.max_order, 2, "{report:?}");
        assert_eq!(report.stats.streams_per_order, vec![3, 1], "{report:?}");
        // A shape that does not match, or a zero cell size, gives nothing.
        assert!(extract_channels(&z, size, size - 1, 1.0, 1.0, None).is_none());
        assert!(extract_channels(&z, size, size, 0.0, 1.0, None).is_none());
    }
}

/// The real DEM of the repository (SRTM, 384 x 384 cells of about 66 x 93 m).
#[cfg(test)]
mod real {
    use super::*;

    #[test]
    fn a_real_dem_has_a_network_of_order_4_or_more_with_a_horton_ratio_of_3_to_5() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/srtm_n44e005_384.tif"
        );
        let bytes = std::fs::read(path).unwrap();
        let dem = crate::dem::geotiff::read(&bytes, crate::dem::ReadLimits::default()).unwrap();
        let f = &dem.field;
        let (cx, cy) = dem.georef.cell_size_m(f.height()).unwrap();
        assert!(
            (60.0..70.0).contains(&cx) && (85.0..100.0).contains(&cy),
            "{cx} {cy}"
        );
        let net = extract_channels(f.data(), f.width(), f.height(), cx, cy, None).unwrap();
        let report = net.report();
        let s = &report.stats;
        assert!(s.max_order >= 4, "{report:?}");
        let rb = s.bifurcation_ratio.unwrap();
        assert!((3.0..=5.0).contains(&rb), "R_b {rb}: {report:?}");
        // Horton's law: fewer streams at every higher order.
        assert!(
            s.streams_per_order.windows(2).all(|p| p[0] > p[1]),
            "{report:?}"
        );
        assert!(report.largest_basin.max_order >= 4, "{report:?}");
        // Every node but the outlets drains to a node one cell away.
        for (node, p) in net.network.parent.iter().enumerate() {
            if let Some(p) = p {
                let (a, b) = (net.cells[node], net.cells[*p as usize]);
                let (w, _) = (f.width(), f.height());
                assert!((a / w).abs_diff(b / w) <= 1 && (a % w).abs_diff(b % w) <= 1);
            }
        }
    }
}
