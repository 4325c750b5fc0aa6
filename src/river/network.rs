//! Drawing the grown string as a river network (turtle interpretation), keeping every
//! network inside the map and free of crossings, and the heights of Sec. IV-C.

use glam::DVec2;

use super::generator::Sym;
use super::hydraulic::Bends;

/// A river network as a tree rooted at its estuary. Node 0 is the estuary; every other node
/// has a parent one link downstream (towards the estuary).
#[derive(Clone, Debug, Default)]
pub struct RiverNetwork {
    /// Positions in map units ((0, 0) north-west, (1, 1) south-east).
    pub nodes: Vec<DVec2>,
    /// The downstream neighbour; `None` for the estuary.
    pub parent: Vec<Option<u32>>,
    /// Whether the link from the parent is an exterior link (`G`, ending in a source).
    pub exterior: Vec<bool>,
    /// Heights in metres: proportional to the geodesic distance to the estuary (Sec. IV-C).
    pub height: Vec<f32>,
    /// Length of every link in map units.
    pub link_length: f64,
    /// Whether the link from the parent lies on the trunk (the line the user drew, bent by
    /// [`super::course`] where the scene wanders). Filled by [`turtle`] and kept by [`admit`].
    pub trunk: Vec<bool>,
    /// How the channel of the link from the parent meanders ([`super::hydraulic::bends_of`]);
    /// empty or default for straight-bedded links. See [`Self::bends`].
    pub bends: Vec<Bends>,
}

impl RiverNetwork {
    pub fn links(&self) -> usize {
        self.nodes.len().saturating_sub(1)
    }

    /// How the link from `node`'s parent meanders (none where the network has no bends).
    pub fn bends(&self, node: usize) -> Bends {
        self.bends.get(node).copied().unwrap_or_default()
    }

    /// Several networks as one forest (each keeps its own estuary, its nodes after those of
    /// the networks before it), so that [`super::stats::analyse`] pools their statistics.
    pub fn forest(networks: &[RiverNetwork]) -> RiverNetwork {
        let mut out = RiverNetwork {
            link_length: networks.first().map_or(0.0, |n| n.link_length),
            ..Default::default()
        };
        for net in networks {
            let offset = out.nodes.len() as u32;
            out.nodes.extend_from_slice(&net.nodes);
            out.parent
                .extend(net.parent.iter().map(|p| p.map(|p| p + offset)));
            out.exterior.extend_from_slice(&net.exterior);
            out.height.extend_from_slice(&net.height);
        }
        out
    }

    /// `(downstream, upstream)` node pairs of every link.
    pub fn link_pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.parent
            .iter()
            .enumerate()
            .filter_map(|(n, p)| p.map(|p| (p as usize, n)))
    }
}

/// Segments already drawn (by every network of the scene), bucketed on a grid so that a new
/// link is tested against its neighbourhood only: O(1) per link for evenly spread networks.
/// Buckets are singly linked lists in flat arrays (no allocation per bucket).
pub struct SegmentIndex {
    cell: f64,
    side: usize,
    /// First entry of every bucket ([`NONE`] when empty).
    head: Vec<u32>,
    /// `(segment, next entry of the same bucket)`.
    entries: Vec<(u32, u32)>,
    segments: Vec<(DVec2, DVec2)>,
}

/// The end of a bucket's list.
const NONE: u32 = u32::MAX;

impl SegmentIndex {
    /// An index for about `links` links of about `link_length` map units: buckets no smaller
    /// than a link (a link spans at most four) and about one link per bucket, so the grid
    /// stays small (a grid of link-sized buckets held a few percent of links, in megabytes).
    pub fn new(link_length: f64, links: usize) -> Self {
        let finest = (1.0 / link_length.max(1e-4)) as usize;
        let side = finest.min((links as f64).sqrt() as usize).clamp(1, 1024);
        Self {
            cell: 1.0 / side as f64,
            side,
            head: vec![NONE; side * side],
            entries: Vec::new(),
            segments: Vec::new(),
        }
    }

    /// The buckets under the bounding box of `a -> b` (clamped to the map).
    fn cells(&self, a: DVec2, b: DVec2) -> impl Iterator<Item = usize> + use<> {
        let (lo, hi) = (a.min(b), a.max(b));
        let (cell, side) = (self.cell, self.side);
        let clamp = move |v: f64| ((v / cell).floor().max(0.0) as usize).min(side - 1);
        let (x0, x1, y0, y1) = (clamp(lo.x), clamp(hi.x), clamp(lo.y), clamp(hi.y));
        (y0..=y1).flat_map(move |y| (x0..=x1).map(move |x| y * side + x))
    }

    /// Whether `hit` holds for a stored segment in the buckets of `a -> b`.
    fn any_near(&self, a: DVec2, b: DVec2, hit: impl Fn(DVec2, DVec2) -> bool) -> bool {
        self.cells(a, b).any(|c| {
            let mut e = self.head[c];
            while e != NONE {
                let (s, next) = self.entries[e as usize];
                let (p, q) = self.segments[s as usize];
                if hit(p, q) {
                    return true;
                }
                e = next;
            }
            false
        })
    }

    /// Whether `a -> b` crosses a stored segment, ignoring those that merely touch `a`.
    pub fn crosses(&self, a: DVec2, b: DVec2) -> bool {
        self.any_near(a, b, |p, q| {
            !touches(a, p, q) && segments_intersect(a, b, p, q)
        })
    }

    /// Whether `a -> b` meets a stored segment at all (touching counts).
    pub fn intersects(&self, a: DVec2, b: DVec2) -> bool {
        self.any_near(a, b, |p, q| segments_intersect(a, b, p, q))
    }

    pub fn insert(&mut self, a: DVec2, b: DVec2) {
        let s = self.segments.len() as u32;
        self.segments.push((a, b));
        for c in self.cells(a, b) {
            self.entries.push((s, self.head[c]));
            self.head[c] = (self.entries.len() - 1) as u32;
        }
    }
}

fn touches(a: DVec2, p: DVec2, q: DVec2) -> bool {
    a.distance_squared(p) < 1e-18 || a.distance_squared(q) < 1e-18
}

/// Proper or touching intersection of segments ab and pq.
pub fn segments_intersect(a: DVec2, b: DVec2, p: DVec2, q: DVec2) -> bool {
    let cross = |o: DVec2, u: DVec2, v: DVec2| (u - o).perp_dot(v - o);
    let (d1, d2) = (cross(p, q, a), cross(p, q, b));
    let (d3, d4) = (cross(a, b, p), cross(a, b, q));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |o: DVec2, u: DVec2, v: DVec2, d: f64| {
        d.abs() < 1e-15
            && v.x >= o.x.min(u.x) - 1e-15
            && v.x <= o.x.max(u.x) + 1e-15
            && v.y >= o.y.min(u.y) - 1e-15
            && v.y <= o.y.max(u.y) + 1e-15
    };
    on(p, q, a, d1) || on(p, q, b, d2) || on(a, b, p, d3) || on(a, b, q, d4)
}

/// Keeps the links of several turtle drawings ([`turtle`]) that fit together.
///
/// Links are admitted from the estuaries upstream, the trunks (the strokes themselves) first,
/// then higher Strahler orders first across all networks: one that would leave the map or cross a link already admitted is dropped with
/// everything upstream of it, so main streams win over tributaries and networks never cross.
/// A grown link (not a stroke's trunk) that `keepout` blocks is dropped the same way.
/// Heights: `slope * geodesic distance`, in metres for a map `map_width_m` wide (Sec. IV-C;
/// each estuary is at 0 m). O(L log L) for L links in all.
pub fn admit(
    drawings: &[RiverNetwork],
    slope: f64,
    map_width_m: f64,
    keepout: &super::Keepout,
) -> Vec<RiverNetwork> {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;

    let finest = drawings
        .iter()
        .map(|d| d.link_length)
        .fold(1.0f64, f64::min);
    let drawn = drawings.iter().map(RiverNetwork::links).sum();
    let mut index = SegmentIndex::new(finest, drawn);
    let orders: Vec<Vec<u32>> = drawings.iter().map(super::stats::strahler_orders).collect();
    let children: Vec<Vec<Vec<usize>>> = drawings
        .iter()
        .map(|d| {
            let mut c = vec![Vec::new(); d.nodes.len()];
            for (p, n) in d.link_pairs() {
                c[p].push(n);
            }
            c
        })
        .collect();
    let mut nets: Vec<RiverNetwork> = drawings
        .iter()
        .map(|d| RiverNetwork {
            nodes: vec![d.nodes[0]],
            parent: vec![None],
            exterior: vec![false],
            trunk: vec![false],
            height: vec![0.0],
            link_length: d.link_length,
            bends: Vec::new(),
        })
        .collect();
    let mut new_id: Vec<Vec<u32>> = drawings
        .iter()
        .map(|d| vec![u32::MAX; d.nodes.len()])
        .collect();
    let mut distance: Vec<Vec<f64>> = drawings.iter().map(|d| vec![0.0; d.nodes.len()]).collect();
    // Trunks first (what the user drew is kept), then by Strahler order, then closeness to
    // the estuary: (rank, closeness, network, node), best first.
    let rank = |k: usize, c: usize| {
        let trunk = drawings[k].trunk.get(c).copied().unwrap_or(false);
        orders[k][c] + if trunk { 1 << 20 } else { 0 }
    };
    let mut frontier = BinaryHeap::new();
    for (k, d) in drawings.iter().enumerate() {
        new_id[k][0] = 0;
        for &c in &children[k][0] {
            frontier.push((rank(k, c), Reverse((d.link_length * 1e9) as u64), k, c));
        }
    }
    while let Some((_, _, k, node)) = frontier.pop() {
        let d = &drawings[k];
        let parent = d.parent[node].map_or(0, |p| p as usize);
        let (from, to) = (d.nodes[parent], d.nodes[node]);
        let inside = (0.0..=1.0).contains(&to.x) && (0.0..=1.0).contains(&to.y);
        let trunk = d.trunk.get(node).copied().unwrap_or(false);
        if !inside || index.crosses(from, to) || (!trunk && keepout.blocks(from, to)) {
            continue; // dropped, and with it everything upstream
        }
        index.insert(from, to);
        let dist = distance[k][parent] + d.link_length;
        distance[k][node] = dist;
        let net = &mut nets[k];
        new_id[k][node] = net.nodes.len() as u32;
        net.nodes.push(to);
        net.parent.push(Some(new_id[k][parent]));
        net.exterior.push(d.exterior[node]);
        net.trunk.push(trunk);
        net.height.push((slope * dist * map_width_m) as f32);
        for &c in &children[k][node] {
            let closeness = Reverse(((dist + d.link_length) * 1e9) as u64);
            frontier.push((rank(k, c), closeness, k, c));
        }
    }
    nets
}

/// The turtle drawing of `symbols` from `estuary` towards `toward`, nothing dropped yet
/// (parents always before children). All links have the same length (eq. 2: links of one
/// iteration step are equal), chosen so that the trunk (the links outside any bracket,
/// always straight) ends at `toward`. O(symbols).
pub fn turtle(symbols: &[Sym], estuary: DVec2, toward: DVec2, theta: f64) -> RiverNetwork {
    let trunk_links = trunk_links(symbols).max(1);
    let link_length = estuary.distance(toward) / trunk_links as f64;
    let mut net = RiverNetwork {
        nodes: vec![estuary],
        parent: vec![None],
        exterior: vec![false],
        trunk: vec![false],
        height: vec![0.0],
        link_length,
        bends: Vec::new(),
    };
    // `libm` rather than the platform's trigonometry: the same bits natively and in wasm, so
    // the same scene grows the same network everywhere.
    let d = toward - estuary;
    let (mut node, mut heading) = (0u32, libm::atan2(d.y, d.x));
    let mut stack = Vec::new();
    for s in symbols {
        match s {
            Sym::Push => stack.push((node, heading)),
            Sym::Pop => (node, heading) = stack.pop().unwrap_or((node, heading)),

            Sym::Plus => heading += theta,
            Sym::Minus => heading -= theta,
            Sym::F | Sym::G => {
                let dir = DVec2::new(libm::cos(heading), libm::sin(heading));
                let to = net.nodes[node as usize] + dir * link_length;
                net.nodes.push(to);
                net.parent.push(Some(node));
                net.exterior.push(*s == Sym::G);
                net.trunk.push(stack.is_empty());
                net.height.push(0.0);
                node = (net.nodes.len() - 1) as u32;
            }
        }
    }
    net
}

/// Links drawn outside any bracket: the straight trunk from the estuary.
fn trunk_links(symbols: &[Sym]) -> usize {
    let mut depth = 0usize;
    let mut n = 0;
    for s in symbols {
        match s {
            Sym::Push => depth += 1,
            Sym::Pop => depth = depth.saturating_sub(1),
            Sym::F | Sym::G if depth == 0 => n += 1,
            _ => {}
        }
    }
    n
}
