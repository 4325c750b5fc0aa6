//! River networks (seed paper 000, Sec. IV): a Tokunaga self-similar network grown by an
//! L-system from each stroke the user draws (estuary first, then the flow direction and
//! extent), with heights that grow with the geodesic distance to the estuary.
//!
//! - [`generator`]: generators, `P` and `R` (eq. 1), link lengths (eq. 2), rule set Omega.
//! - [`lsystem`]: rewriting with a seeded generator choice and a link budget.
//! - [`course`]: the stroke bent into a wandering course, the network with it.
//! - [`hydraulic`]: channel widths from drainage area, and the meanders they set.
//! - [`network`]: turtle interpretation, clipping to the map, no crossings, heights.
//! - [`keepout`]: the sketch's peaks and ridges, which grown tributaries keep clear of.
//! - [`stats`]: Strahler orders, Horton bifurcation ratio, Tokunaga side-branch counts.

pub mod course;
pub mod generator;
pub mod hydraulic;
pub mod keepout;
pub mod lsystem;
pub mod network;
pub mod stats;

use glam::DVec2;
use rand::SeedableRng;
use rand::rngs::ChaCha12Rng;
use serde::Serialize;

pub use keepout::Keepout;
pub use network::RiverNetwork;
pub use stats::NetworkStats;

/// One river as the user drew it, in map units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stroke {
    /// The estuary (the network's lowest point).
    pub estuary: DVec2,
    /// The point giving the flow direction (upstream) and the trunk's extent.
    pub toward: DVec2,
    /// Generator index phi (1 to 6).
    pub phi: u32,
    /// Maximum iteration depth (MaxDepth of eq. 3).
    pub max_depth: u32,
}

/// Global river parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RiverParams {
    /// Branching angle theta in degrees (exterior links turn theta or 2 theta).
    pub theta_deg: f64,
    /// River slope: metres of height per metre of channel.
    pub slope: f64,
    /// Width of the map in metres (converts map units to metres for heights).
    pub map_width_m: f64,
    /// Most links a single network may have; growth stops before exceeding it.
    pub link_budget: usize,
    /// How far each trunk wanders from the straight stroke: the standard deviation of its
    /// sideways offset in stroke lengths (0: the paper's straight trunk; see [`course`]).
    pub wander: f64,
    /// The meanders of every link's channel ([`hydraulic::bends_of`]; none by default).
    pub meanders: hydraulic::Meanders,
}

/// The wander of a new scene's rivers ([`RiverParams::wander`]): bends of a few hundred
/// metres on a trunk of 6 km.
pub const DEFAULT_WANDER: f64 = 0.08;

impl Default for RiverParams {
    fn default() -> Self {
        Self {
            theta_deg: 30.0,
            slope: 0.01,
            map_width_m: 10_000.0,
            link_budget: 60_000,
            wander: DEFAULT_WANDER,
            meanders: hydraulic::Meanders::default(),
        }
    }
}

/// One grown network with what the report needs.
#[derive(Clone, Debug)]
pub struct GrownRiver {
    pub network: RiverNetwork,
    pub stats: NetworkStats,
    /// Iteration depth from eq. 3 and the depth actually grown.
    pub depth_asked: u32,
    pub depth: u32,
    /// Interior generator choices (index = generator) and their mean, which estimates R.
    pub interior_choices: Vec<u64>,
    pub interior_mean: Option<f64>,
    /// Why this network is smaller than asked, in words.
    pub trimmed: Option<String>,
}

/// Summary of a river set for reports (`strahler generate --report`).
#[derive(Clone, Debug, Serialize)]
pub struct RiverReport {
    pub nodes: usize,
    pub links: usize,
    pub max_order: u32,
    pub networks: Vec<NetworkStats>,
    pub interior_generator_means: Vec<Option<f64>>,
    pub trimmed: Vec<String>,
}

/// Iteration depth of eq. 3: `depth = length_ab / width_T * MaxDepth` (map width = 1 map
/// unit), rounded, at least 1.
pub fn depth_for(stroke: &Stroke) -> u32 {
    let length = stroke.estuary.distance(stroke.toward);
    ((length * f64::from(stroke.max_depth)).round() as u32).max(1)
}

/// The courses of a scene's strokes ([`course::courses`]) as [`grow_all`] bends them with the
/// same `seed`.
pub fn courses_of(strokes: &[Stroke], wander: f64, seed: u64) -> Vec<course::Course> {
    course::courses(strokes, wander, |index| {
        crate::noise::splitmix64(seed ^ (index as u64).wrapping_mul(0xa076_1d64_78bd_642f))
    })
}

/// Grows one network per stroke, in order; later networks never cross earlier ones, and
/// none leaves the map, and grown tributaries keep off `keepout`. Deterministic in `seed`
/// (each stroke gets its own stream).
pub fn grow_all(
    strokes: &[Stroke],
    params: &RiverParams,
    keepout: &Keepout,
    seed: u64,
) -> Vec<GrownRiver> {
    let grown: Vec<(u32, lsystem::Grown)> = strokes
        .iter()
        .enumerate()
        .map(|(i, stroke)| {
            let stream = 0x9e37_79b9_7f4a_7c15u64.wrapping_mul(i as u64 + 1);
            let mut rng = ChaCha12Rng::seed_from_u64(seed ^ stream);
            let depth_asked = depth_for(stroke);
            (
                depth_asked,
                lsystem::grow(stroke.phi, depth_asked, params.link_budget, &mut rng),
            )
        })
        .collect();
    let courses = courses_of(strokes, params.wander, seed);
    let drawings: Vec<RiverNetwork> = strokes
        .iter()
        .zip(&grown)
        .zip(&courses)
        .map(|((s, (_, g)), course)| {
            let mut drawing = network::turtle(
                &g.symbols,
                s.estuary,
                s.toward,
                params.theta_deg.to_radians(),
            );
            course.bend_network(&mut drawing);
            drawing
        })
        .collect();
    let mut networks = network::admit(&drawings, params.slope, params.map_width_m, keepout);
    for net in &mut networks {
        net.bends = hydraulic::bends_of(net, &params.meanders, params.map_width_m);
    }
    networks
        .into_iter()
        .zip(grown)
        .map(|(network, (depth_asked, grown))| {
            let n: u64 = grown.interior_choices.iter().sum();
            let interior_mean = (n > 0).then(|| {
                grown
                    .interior_choices
                    .iter()
                    .enumerate()
                    .map(|(k, c)| k as f64 * *c as f64)
                    .sum::<f64>()
                    / n as f64
            });
            GrownRiver {
                stats: stats::analyse(&network),
                network,
                depth_asked,
                depth: grown.depth,
                interior_choices: grown.interior_choices,
                interior_mean,
                trimmed: grown.trimmed,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use network::segments_intersect;

    fn stroke(a: (f64, f64), b: (f64, f64), phi: u32, max_depth: u32) -> Stroke {
        Stroke {
            estuary: DVec2::new(a.0, a.1),
            toward: DVec2::new(b.0, b.1),
            phi,
            max_depth,
        }
    }

    fn all_links(rivers: &[GrownRiver]) -> Vec<(DVec2, DVec2)> {
        rivers
            .iter()
            .flat_map(|r| {
                r.network
                    .link_pairs()
                    .map(|(p, c)| (r.network.nodes[p], r.network.nodes[c]))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    #[test]
    fn networks_branch_to_order_three_and_more_stay_inside_and_never_cross() {
        let strokes = [
            stroke((0.5, 1.0), (0.5, 0.35), 2, 9),
            stroke((0.0, 0.3), (0.45, 0.2), 3, 8),
            stroke((1.0, 0.6), (0.65, 0.4), 4, 7),
        ];
        let rivers = grow_all(&strokes, &RiverParams::default(), &Keepout::default(), 11);
        for (r, s) in rivers.iter().zip(&strokes) {
            assert!(
                r.stats.max_order >= 3,
                "phi {}: order {}",
                s.phi,
                r.stats.max_order
            );
            assert!(
                r.network
                    .nodes
                    .iter()
                    .all(|p| (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y))
            );
            let rb = r.stats.bifurcation_ratio.unwrap();
            assert!((2.0..8.0).contains(&rb), "bifurcation ratio {rb}");
        }
        // No two links anywhere cross (links sharing a node may touch there).
        let links = all_links(&rivers);
        for (i, &(a, b)) in links.iter().enumerate() {
            for &(p, q) in &links[i + 1..] {
                let shared = [a, b]
                    .iter()
                    .any(|u| u.distance(p) < 1e-12 || u.distance(q) < 1e-12);
                assert!(
                    shared || !segments_intersect(a, b, p, q),
                    "{a} {b} x {p} {q}"
                );
            }
        }
    }

    /// With wander the trunk bends away from the drawn segment (by more than a few cells of a
    /// 512 map) yet starts at the estuary and ends at the stroke's end; without, it is the
    /// paper's straight trunk.
    #[test]
    fn a_wandering_trunk_keeps_the_strokes_ends() {
        let s = stroke((0.5, 1.0), (0.5, 0.35), 3, 6);
        let trunk_of = |wander: f64| {
            let params = RiverParams {
                wander,
                ..RiverParams::default()
            };
            let net = grow_all(&[s], &params, &Keepout::default(), 9)
                .remove(0)
                .network;
            (1..net.nodes.len())
                .filter(|&i| net.trunk[i])
                .map(|i| net.nodes[i])
                .collect::<Vec<_>>()
        };
        let straight = trunk_of(0.0);
        assert!(straight.iter().all(|p| (p.x - 0.5).abs() < 1e-9));
        let bent = trunk_of(0.1);
        let last = bent.last().copied().unwrap();
        assert!(last.distance(s.toward) < 1e-9, "ends at {last}");
        let widest = bent.iter().map(|p| (p.x - 0.5).abs()).fold(0.0, f64::max);
        assert!(widest > 0.02, "the trunk strays at most {widest}");
        // Along the stroke the nodes keep their order: the shear moves them only sideways.
        assert!(bent.windows(2).all(|w| w[1].y < w[0].y));
    }

    #[test]
    fn heights_rise_from_the_estuary_along_every_link() {
        let rivers = grow_all(
            &[stroke((0.5, 1.0), (0.5, 0.4), 3, 8)],
            &RiverParams::default(),
            &Keepout::default(),
            5,
        );
        let net = &rivers[0].network;
        assert_eq!(net.height[0], 0.0);
        for (p, c) in net.link_pairs() {
            assert!(net.height[c] > net.height[p]);
        }
        // Trunk end: slope x distance (0.6 map units of 10 km at 1%) = 60 m.
        let top = net.height.iter().copied().fold(0.0f32, f32::max);
        assert!(top >= 59.0, "{top}");
    }

    #[test]
    fn same_seed_same_network() {
        let s = [stroke((0.2, 1.0), (0.3, 0.3), 3, 8)];
        let a = grow_all(&s, &RiverParams::default(), &Keepout::default(), 9);
        let b = grow_all(&s, &RiverParams::default(), &Keepout::default(), 9);
        assert_eq!(a[0].network.nodes, b[0].network.nodes);
        let c = grow_all(&s, &RiverParams::default(), &Keepout::default(), 10);
        assert_ne!(a[0].network.nodes, c[0].network.nodes);
    }

    #[test]
    fn absurd_phi_and_depth_are_trimmed_and_explained() {
        let rivers = grow_all(
            &[stroke((0.5, 1.0), (0.5, 0.0), 6, 12)],
            &RiverParams::default(),
            &Keepout::default(),
            1,
        );
        assert!(rivers[0].network.links() <= RiverParams::default().link_budget);
        assert!(
            rivers[0]
                .trimmed
                .as_deref()
                .is_some_and(|t| t.contains("budget"))
        );
    }
}
