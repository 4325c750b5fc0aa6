//! The river network and the ridges as GeoJSON (RFC 7946 geometry; coordinates in map
//! metres, the exported GeoTIFF's local grid: x east from the west edge, y north from the
//! south edge, a cell's centre at `(column + 0.5, rows - row - 0.5)` cells).
//!
//! Each river link is one `LineString` along its drawn, wandering course
//! (`crate::skeleton::meander::course`, the same points the skeleton rasterises, so every
//! vertex lies on a river cell), with its Strahler order, its width in metres (hydraulic
//! geometry by order, `crate::view3d::maps::river_width_m`), and the drainage area at each
//! vertex. Each ridge segment (the Voronoi ridges of the design) is one `LineString` with its
//! heights. RFC 7946 asks for WGS84 longitudes and latitudes: a scene placed on Earth (its
//! `location`) gets them, through its UTM zone ([`crate::dem::utm`]); a scene with no place
//! names its local metric CRS in a `crs` member instead, as older GeoJSON did.

use glam::DVec2;
use serde_json::{Value, json};

use crate::ridge::RidgeSegment;
use crate::river::RiverNetwork;

/// Where the map lies: map units `[0, 1]` to metres.
#[derive(Clone, Copy, Debug)]
pub struct MapFrame {
    /// Vertices a side of the exported raster.
    pub cells: usize,
    /// Metres between them.
    pub cell_m: f64,
    /// Where the map lies on Earth, if it does: coordinates are then longitude and latitude.
    pub placed: Option<super::Placed>,
}

impl MapFrame {
    /// `p` (map units) as the file's coordinates: `[lon, lat]` in degrees when the map is
    /// placed on Earth (its UTM zone's inverse), else [`Self::metres`].
    pub fn coordinates(&self, p: DVec2) -> [f64; 2] {
        let [x, y] = self.metres(p);
        match self.placed {
            Some(placed) => {
                let half = self.cells as f64 * self.cell_m / 2.0;
                let [e, n] = placed.centre;
                let (lon, lat) = placed.utm.inverse(e - half + x, n - half + y);
                [lon, lat]
            }
            None => [x, y],
        }
    }

    /// `p` (map units, y south) in metres (y north).
    pub fn metres(&self, p: DVec2) -> [f64; 2] {
        let s = (self.cells.max(2) - 1) as f64;
        [
            (p.x * s + 0.5) * self.cell_m,
            (self.cells as f64 - (p.y * s + 0.5)) * self.cell_m,
        ]
    }
}

/// A drainage-area raster (m^2) of `size` x `size` cells over the map.
pub struct AreaRaster<'a> {
    pub area_m2: &'a [f32],
    pub size: usize,
}

impl AreaRaster<'_> {
    /// The area at `p`: the largest in its cell's 3 x 3 neighbourhood, since D8 routing on
    /// the raster may carry a drawn river one cell beside its course (at confluences,
    /// mostly).
    fn at(&self, p: DVec2) -> f64 {
        let n = self.size;
        let s = (n.max(2) - 1) as f64;
        let x = (p.x * s).round().clamp(0.0, s) as usize;
        let y = (p.y * s).round().clamp(0.0, s) as usize;
        let mut best = 0.0f32;
        for yy in y.saturating_sub(1)..=(y + 1).min(n - 1) {
            for xx in x.saturating_sub(1)..=(x + 1).min(n - 1) {
                best = best.max(self.area_m2[yy * n + xx]);
            }
        }
        f64::from(best)
    }
}

/// The rivers of `networks` (their skeleton drawn on `skeleton_cells` a side) and `ridges` as
/// one GeoJSON FeatureCollection.
pub fn geojson(
    networks: &[RiverNetwork],
    ridges: &[RidgeSegment],
    skeleton_cells: usize,
    frame: MapFrame,
    area: &AreaRaster,
) -> Value {
    let mut features = Vec::new();
    for (index, net) in networks.iter().enumerate() {
        let orders = crate::river::stats::strahler_orders(net);
        for (down, up) in net.link_pairs() {
            // Drawn from upstream to downstream, as water flows.
            let course = crate::skeleton::meander::course(
                net.nodes[down],
                net.nodes[up],
                skeleton_cells,
                net.bends(up),
            );
            let points: Vec<DVec2> = course.into_iter().rev().collect();
            let order = orders[up].min(255) as u8;
            features.push(json!({
                "type": "Feature",
                "geometry": {
                    "type": "LineString",
                    "coordinates": points.iter().map(|p| frame.coordinates(*p)).collect::<Vec<_>>(),
                },
                "properties": {
                    "kind": "river",
                    "network": index,
                    "strahler_order": order,
                    "width_m": crate::view3d::maps::river_width_m(order),
                    "drainage_area_m2": points.iter().map(|p| area.at(*p)).collect::<Vec<_>>(),
                    "height_m": [net.height[up], net.height[down]],
                },
            }));
        }
    }
    for ridge in ridges {
        features.push(json!({
            "type": "Feature",
            "geometry": {
                "type": "LineString",
                "coordinates": [frame.coordinates(DVec2::from(ridge.a)), frame.coordinates(DVec2::from(ridge.b))],
            },
            "properties": {
                "kind": "ridge",
                "height_m": [ridge.height_a, ridge.height_b],
            },
        }));
    }
    if frame.placed.is_some() {
        // RFC 7946's own coordinates: WGS84 longitude and latitude, no `crs` member.
        return json!({ "type": "FeatureCollection", "features": features });
    }
    json!({
        "type": "FeatureCollection",
        "crs": {
            "type": "name",
            "properties": { "name": "local metric grid (metres), south-west corner at (0, 0)" },
        },
        "features": features,
    })
}
