//! Hydraulic geometry of the drawn networks: how wide each link's channel is, and the
//! meanders a scene may ask of its rivers.
//!
//! **Channel width.** Bankfull width grows as discharge^0.5 (Leopold and Maddock 1953,
//! "The hydraulic geometry of stream channels", USGS PP 252) and bankfull discharge about as
//! drainage area, so width ~ A^0.5 ([`channel_width_m`]). The erosion's valley floors use the
//! same law with the area routed over the design ([`crate::erosion::floodplain`]).
//!
//! **A link's area before any terrain exists.** The river stage runs first, so a link's
//! drainage area is estimated from the network itself: the links upstream of it (itself
//! included), each draining a strip one link long and [`STRIP_WIDTH_IN_LINKS`] links wide
//! ([`link_areas`]).
//!
//! **Meanders** ([`Meanders`], [`bends_of`]): a river on its floodplain bends in loops whose
//! wavelength is 10 to 14 channel widths (Leopold and Wolman 1960, "River meanders", GSA
//! Bulletin 71: `lambda = 10.9 w^1.01`), and whose direction follows the sine-generated curve
//! of Langbein and Leopold 1966 ("River meanders: theory of minimum variance", USGS PP 422-H):
//! `theta(s) = omega cos(2 pi s / M)`, `omega` the largest angle to the valley's axis. Each
//! link of a drawn river (the trunk) gets its wavelength from its own width, so loops grow
//! downstream; the skeleton draws them ([`crate::skeleton::meander`]).

use super::RiverNetwork;

/// Bankfull channel width per square root of drainage area, metres per km (2.5 m gives 25 m
/// at 100 km^2 and 80 m at 1000 km^2, within the regional curves of Dunne and Leopold 1978).
pub const CHANNEL_WIDTH_PER_SQRT_KM2: f64 = 2.5;

/// The bankfull width in metres of a channel draining `area_m2`.
pub fn channel_width_m(area_m2: f64) -> f64 {
    CHANNEL_WIDTH_PER_SQRT_KM2 * (area_m2.max(0.0) / 1e6).sqrt()
}

/// Width, in link lengths, of the strip each link drains ([`link_areas`]): 1.4 makes the
/// default scene's estimate at its trunk's mouth (177 links of 570 m: 80 km^2) the area the
/// D8 routing over its terrain gathers there (79 km^2).
pub const STRIP_WIDTH_IN_LINKS: f64 = 1.4;

/// Meander wavelength of a new scene, in channel widths (Leopold and Wolman 1960).
pub const DEFAULT_WAVELENGTH_WIDTHS: f64 = 11.0;

/// The widest meander angle a scene may ask, degrees: sinuosity 2.7, the loops still half a
/// wavelength apart at their necks (beyond it they close into cut-offs).
pub const MAX_ANGLE_DEG: f64 = 100.0;

/// The range of wavelengths a scene may ask, in channel widths (real rivers: 7 to 20).
pub const WAVELENGTH_WIDTHS: std::ops::RangeInclusive<f64> = 6.0..=20.0;

/// The meanders a scene asks of its rivers (the scene's `params.meanders`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Meanders {
    /// `omega`, the largest angle between the channel and its valley's axis, degrees (0: no
    /// meanders; 40 gives sinuosity 1.1, 70 gives 1.5, 90 gives 2.1).
    pub angle_deg: f64,
    /// The wavelength along the valley, in bankfull channel widths.
    pub wavelength_widths: f64,
}

impl Meanders {
    /// Whether these are the defaults (a scene file leaves them out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

impl Default for Meanders {
    /// No meanders (a straight-bedded channel, as the papers draw it).
    fn default() -> Self {
        Self {
            angle_deg: 0.0,
            wavelength_widths: DEFAULT_WAVELENGTH_WIDTHS,
        }
    }
}

/// How one link's channel bends: the sine-generated curve's largest angle and wavelength.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bends {
    /// `omega` in radians; 0 is a link without meanders.
    pub angle: f64,
    /// Wavelength along the valley in map units (map width = 1).
    pub wavelength: f64,
}

/// Every node's drainage area estimate in m^2, for the link from its parent (the estuary's
/// is the whole network's): the links upstream of it, itself included, times the strip each
/// drains. Parents come before their children in a network ([`super::network::admit`]).
/// O(nodes).
pub fn link_areas(net: &RiverNetwork, map_width_m: f64) -> Vec<f64> {
    let mut upstream = vec![1.0f64; net.nodes.len()];
    for c in (1..net.nodes.len()).rev() {
        if let Some(p) = net.parent[c] {
            upstream[p as usize] += upstream[c];
        }
    }
    let link_m = net.link_length * map_width_m;
    let strip = link_m * link_m * STRIP_WIDTH_IN_LINKS;
    upstream.iter().map(|u| u * strip).collect()
}

/// Every node's [`Bends`] for the link from its parent: on the trunk (the river the user
/// drew), the scene's angle and a wavelength of `wavelength_widths` times the link's channel
/// width ([`channel_width_m`] of [`link_areas`]); the grown branches stay as they wander.
/// All default (straight) when `meanders.angle_deg` is 0. O(nodes).
///
/// Only the trunks: rivers meander on floodplains, and the drawn rivers are the ones the
/// erosion gives a floor wide enough for their loops; a grown branch's loops, a dozen cells
/// long where the grid first resolves them, were carved into the slopes as saw-tooth gullies.
pub fn bends_of(net: &RiverNetwork, meanders: &Meanders, map_width_m: f64) -> Vec<Bends> {
    if meanders.angle_deg <= 0.0 || map_width_m <= 0.0 {
        return vec![Bends::default(); net.nodes.len()];
    }
    let angle = meanders.angle_deg.min(MAX_ANGLE_DEG).to_radians();
    link_areas(net, map_width_m)
        .into_iter()
        .enumerate()
        .map(|(node, area)| match net.trunk.get(node) {
            Some(true) => Bends {
                angle,
                wavelength: meanders.wavelength_widths * channel_width_m(area) / map_width_m,
            },
            _ => Bends::default(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    /// A trunk of three links with one tributary at its middle node.
    fn small_network() -> RiverNetwork {
        RiverNetwork {
            nodes: vec![
                DVec2::new(0.5, 1.0),
                DVec2::new(0.5, 0.9),
                DVec2::new(0.5, 0.8),
                DVec2::new(0.6, 0.75),
                DVec2::new(0.5, 0.7),
            ],
            parent: vec![None, Some(0), Some(1), Some(2), Some(2)],
            exterior: vec![false, false, false, true, true],
            height: vec![0.0; 5],
            link_length: 0.1,
            trunk: vec![false, true, true, false, true],
            bends: Vec::new(),
        }
    }

    /// Areas gather downstream: each link drains its own strip and every link above it.
    #[test]
    fn areas_gather_downstream_link_by_link() {
        let areas = link_areas(&small_network(), 10_000.0);
        let strip = 1000.0 * 1000.0 * STRIP_WIDTH_IN_LINKS;
        let links: Vec<f64> = areas.iter().map(|a| a / strip).collect();
        assert_eq!(links, vec![5.0, 4.0, 3.0, 1.0, 1.0]);
    }

    /// Widths follow hydraulic geometry (four times the area, twice the width), so meander
    /// wavelengths grow downstream along the trunk, in the asked number of channel widths.
    #[test]
    fn meander_wavelengths_grow_downstream_as_channel_widths() {
        assert!((channel_width_m(400e6) / channel_width_m(100e6) - 2.0).abs() < 1e-12);
        assert!((channel_width_m(100e6) - 25.0).abs() < 1e-12);
        let net = small_network();
        let meanders = Meanders {
            angle_deg: 60.0,
            wavelength_widths: 11.0,
        };
        let bends = bends_of(&net, &meanders, 10_000.0);
        let areas = link_areas(&net, 10_000.0);
        for node in [1, 2, 4] {
            let (b, a) = (bends[node], areas[node]);
            assert!((b.angle - 60f64.to_radians()).abs() < 1e-12);
            let widths = b.wavelength * 10_000.0 / channel_width_m(a);
            assert!((widths - 11.0).abs() < 1e-9, "{widths}");
        }
        assert!(bends[1].wavelength > bends[2].wavelength);
        assert!(bends[2].wavelength > bends[4].wavelength);
        assert_eq!(
            bends[3],
            Bends::default(),
            "a grown branch stays as it wanders"
        );
        let none = bends_of(&net, &Meanders::default(), 10_000.0);
        assert!(none.iter().all(|b| *b == Bends::default()));
    }
}
