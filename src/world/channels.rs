//! The drawn rivers' channels laid at the world's cells.
//!
//! The global build cuts each river's channel at its own cells: a river cell at the bed and,
//! where the channel is narrower than a cell, the floodplain a bankfull depth above it beside
//! (`erosion::floodplain`). The levels of detail interpolate that, so at the world's
//! resolution a channel narrower than a global cell was a blurred trough one to two global
//! cells wide, where a one-piece build of the world's size has a sharp channel cut into its
//! floor. Each window therefore gets the channels laid again at its own cells, from the
//! rivers' courses, which are vector data (global and small):
//! - **The course**: each link's course as the global build drew it (the same wandering or
//!   meandering curve, `skeleton::meander::course` at the global build's size), in metres.
//! - **The bed**: the global build's lowest height within one global cell of each point of
//!   the course (its river cells lie within a cell of the curve they were drawn from), never
//!   rising downstream: along each link from its source, and from each tributary's mouth
//!   into the river it joins ([`Channels::of`]).
//! - **The channel**: bankfull width `~ A^0.5` and depth `~ A^0.4` from the link's drainage
//!   area (`river::hydraulic::link_areas`, the network's own estimate;
//!   `river::hydraulic::channel_width_m`, `erosion::floodplain::bankfull_depth_m`), at least
//!   one world cell wide. A cell within the half-width of the nearest course is the bed plus
//!   the floor's cross rise (`erosion::floodplain::CROSS_RISE`); beside it the bank rises
//!   over one world cell to the floodplain, a bankfull depth above the bed, and the blurred
//!   trough within half a global cell of the channel is raised to it, fading out over the
//!   next half global cell ([`Nearest::lay`]).
//!
//! **The valley floor.** The levels of detail give every floor the texture of the slopes (the
//! global build's own statistics, one set for the whole map), where the one-piece build's
//! floors are smooth base level. Within [`FLOOR_REACH`] floor half-widths of a course, where
//! the global build is no steeper than the floor's footslope, a cell takes the global
//! build's surface without the detail, fading out onto the walls ([`floor_share`]), and the
//! refinement's change there is faded alike ([`Laid`]).
//!
//! **Which rivers.** Only the drawn rivers (the trunks) whose global build cut a valley floor
//! ([`has_a_floor`]). The trunks are held at their drawn heights in the global build, so
//! their courses are its river cells; a grown branch's heights are set by the erosion, its
//! valley can leave the course it was drawn on, and a channel laid on the course there was
//! a trench across the slope (on a 2 km map, a dark crack across every face).
//!
//! Laid from global data keyed on position in metres, the channels are the same bits in
//! every window and tile that holds them: seamless by construction, whatever the tiling. The
//! refinement holds the channel's cells as base level, as the one-piece build holds its
//! rivers ([`Nearest::laid`]). Departures from the one-piece build (docs/departures.md): the
//! bed is the global build's, sampled, not the design's own heights at the world's cells;
//! the floodplain beyond half a global cell is the global build's floor, interpolated; the
//! branches keep their interpolated valleys.

use glam::DVec2;
use serde::{Deserialize, Serialize};

use crate::erosion::floodplain::{
    CROSS_RISE, FOOTSLOPE, HALF_WIDTH_PER_SQRT_AREA, bankfull_depth_m,
};
use crate::heightfield::Heightfield;
use crate::river::GrownRiver;
use crate::river::hydraulic::{channel_width_m, link_areas};
use crate::skeleton::meander;
use crate::wavelet::directional::Region;

/// One link's channel: its course, downstream end first, with the bed's height at each
/// point, and the link's bankfull half-width and depth.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// The course's points, metres east and south of the map's north-west corner.
    pub points: Vec<[f32; 2]>,
    /// The bed's height at each point, metres, never rising towards the first.
    pub bed: Vec<f32>,
    /// How surely each point lies on the global build's floor, 0 to 1 ([`on_the_floor`]):
    /// the channel is cut that much.
    pub on_floor: Vec<f32>,
    /// Half the bankfull width, metres.
    pub half_width_m: f32,
    /// How far the floodplain stands above the bed, metres.
    pub depth_m: f32,
    /// Half the width of the valley floor the global build cut beside it for the mean rock
    /// (`erosion::floodplain::HALF_WIDTH_PER_SQRT_AREA`), metres.
    pub floor_half_width_m: f32,
}

/// Every link's channel (empty: a scene without rivers, or a build from before channels).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Channels {
    pub links: Vec<Channel>,
}

impl Channels {
    /// The channels of the drawn rivers (the trunks) of `rivers` on the global build `field`
    /// (square, vertex-registered over a map `map_width_m` wide) that run in a valley floor
    /// there ([`has_a_floor`]).
    /// O(points of the courses).
    pub fn of(rivers: &[GrownRiver], field: &Heightfield, map_width_m: f64) -> Self {
        let mut links = Vec::new();
        for river in rivers {
            links.extend(network_channels(&river.network, field, map_width_m));
        }
        Self { links }
    }
}

/// Whether the global build (cells `global_cell_m` wide) cut a valley floor beside a river
/// draining `area_m2`: the floor's half-width for the mean rock
/// (`erosion::floodplain::HALF_WIDTH_PER_SQRT_AREA`) a cell or more. Smaller rivers keep the
/// V of their valleys there (`erosion::floodplain`), interpolated smoothly at the world's
/// cells, and their course need not lie at the valley's lowest cells: a channel laid along
/// one on a steep side (a global cell falls 11 m on a 30 degree slope of 19.5 m cells) cut
/// a trench into the slope.
fn has_a_floor(area_m2: f64, global_cell_m: f64) -> bool {
    HALF_WIDTH_PER_SQRT_AREA * area_m2.max(0.0).sqrt() >= global_cell_m
}

/// The channels of one network, each link's bed never rising downstream and never below the
/// bed of the river it flows into at their confluence. Parents come before their children in
/// a network (`river::hydraulic::link_areas` walks them the same way).
fn network_channels(
    net: &crate::river::network::RiverNetwork,
    field: &Heightfield,
    map_width_m: f64,
) -> Vec<Channel> {
    let n = field.width();
    let last = (n.max(2) - 1) as f64;
    let global_cell_m = map_width_m / last;
    let surface = Surface {
        field,
        cell_m: global_cell_m as f32,
    };
    let areas = link_areas(net, map_width_m);
    let mut inflow = vec![f32::INFINITY; net.nodes.len()];
    let mut by_child: Vec<Option<Channel>> = vec![None; net.nodes.len()];
    for c in (0..net.nodes.len()).rev() {
        let Some(p) = net.parent[c] else { continue };
        let p = p as usize;
        let drawn = net.trunk.get(c).copied().unwrap_or(false);
        if !drawn || !has_a_floor(areas[c], global_cell_m) {
            continue;
        }
        let course = meander::course(net.nodes[p], net.nodes[c], n, net.bends(c));
        let mut bed: Vec<f32> = course.iter().map(|q| lowest_near(field, *q)).collect();
        // From the source end (the last point) down: never rising, and no higher than the
        // tributaries that join at the upstream node.
        let mut low = inflow[c];
        for b in bed.iter_mut().rev() {
            low = low.min(*b);
            *b = low;
        }
        inflow[p] = inflow[p].min(bed[0]);
        let width = channel_width_m(areas[c]);
        let depth = bankfull_depth_m(areas[c]);
        let on_floor = course
            .iter()
            .zip(&bed)
            .map(|(q, b)| on_the_floor(surface.at(q.x * last, q.y * last).0 - b, depth))
            .collect();
        by_child[c] = Some(Channel {
            points: course
                .iter()
                .map(|q| [(q.x * map_width_m) as f32, (q.y * map_width_m) as f32])
                .collect(),
            bed,
            on_floor,
            half_width_m: (0.5 * width) as f32,
            depth_m: depth as f32,
            floor_half_width_m: (HALF_WIDTH_PER_SQRT_AREA * areas[c].max(0.0).sqrt()) as f32,
        });
    }
    by_child.into_iter().flatten().collect()
}

/// Metres the global build may stand above a channel's floodplain at a point of its course
/// that lies on the floor ([`on_the_floor`]).
const FLOOR_TOLERANCE_M: f64 = 1.0;

/// How surely a point of a course lies on the global build's valley floor, from how far the
/// build stands above the bed there (`above`, metres; the build's surface interpolated at the
/// point) and the channel's bankfull `depth`: 1 up to the floodplain's height and a
/// [`FLOOR_TOLERANCE_M`], falling to 0 at twice that. A branch's course can run across a
/// valley's side where the build's channel took another line, and a channel cut there was a
/// trench in the slope; it fades out instead.
fn on_the_floor(above: f32, depth: f64) -> f32 {
    let floor = (depth + FLOOR_TOLERANCE_M) as f32;
    (2.0 - above / floor).clamp(0.0, 1.0)
}

/// The lowest height of `field` (`n` x `n`, vertex-registered) within one cell of the map
/// point `q` (map units): the 3 x 3 cells around the nearest.
fn lowest_near(field: &Heightfield, q: DVec2) -> f32 {
    let n = field.width();
    let last = (n - 1) as i64;
    let x = (q.x * last as f64).round() as i64;
    let y = (q.y * last as f64).round() as i64;
    let mut low = f32::INFINITY;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let (cx, cy) = ((x + dx).clamp(0, last), (y + dy).clamp(0, last));
            low = low.min(field.data()[cy as usize * n + cx as usize]);
        }
    }
    low
}

/// The nearest channel of each cell of a window within reach: what [`Nearest::lay`] cuts.
pub struct Nearest {
    window: Region,
    cell_m: f32,
    global_cell_m: f32,
    cells: Vec<Reach>,
}

/// What the refinement keeps of a window's channels and valley floors (row-major, the
/// window's cells).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Laid {
    /// The cells inside a channel cut there in full: held as base level through the step
    /// and kept at their heights, as the one-piece build holds its rivers.
    pub held: Vec<bool>,
    /// The share of the step's change each cell forgoes for lying on a valley floor (the
    /// one-piece build's floors are base level and take no rills). Not held: a gentle patch
    /// of a valley's side that passed for floor was then an outlet, and the step sank a
    /// hole into it.
    pub still: Vec<f32>,
}

/// A cell's nearest channel.
#[derive(Clone, Copy)]
struct Reach {
    /// Metres beyond the channel's half-width (infinite: out of reach).
    beyond: f32,
    /// Metres to the course.
    across: f32,
    /// The bed at the nearest point of the course, metres.
    bed: f32,
    /// The channel's bankfull depth, metres.
    depth: f32,
    /// How much of the cut the cell takes (the course's [`Channel::on_floor`] there).
    laid: f32,
    /// Half the width of the channel's valley floor, metres.
    floor: f32,
    /// The global build's surface at the cell, without the levels' detail (bilinear).
    smooth: f32,
    /// How much of the detail the cell loses for lying on the valley floor, 0 to 1
    /// ([`floor_share`]).
    on_floor: f32,
}

const OUT_OF_REACH: Reach = Reach {
    beyond: f32::INFINITY,
    across: 0.0,
    bed: 0.0,
    depth: 0.0,
    laid: 0.0,
    floor: 0.0,
    smooth: 0.0,
    on_floor: 0.0,
};

/// How far from its course, in floor half-widths, a valley floor may reach: the widest rock
/// (the rock field's contrast of 10 gives floors up to 1.8 times the mean width) and the
/// meander belt's slack widen it; the global build's slope says where it ends.
const FLOOR_REACH: f32 = 2.0;

/// The share of the levels' detail a cell `across` metres from a course loses for lying on
/// the valley floor of half-width `floor` metres, where the global build slopes `slope`
/// (m/m): all of it on the floor and its footslope (no steeper than
/// `erosion::floodplain::FOOTSLOPE`), none on the walls (twice as steep) or beyond
/// [`FLOOR_REACH`] half-widths, smoothly between.
fn floor_share(across: f32, floor: f32, slope: f32) -> f32 {
    let foot = FOOTSLOPE as f32;
    let gentle = (2.0 - slope / foot).clamp(0.0, 1.0);
    let near = (FLOOR_REACH - across / floor.max(1e-6)) / (FLOOR_REACH - 1.5);
    let t = gentle * near.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Nearest {
    /// The nearest channel of `channels` to each cell of `window`, world cells `cell_m`
    /// wide, over the global build `global` `levels` levels of detail below: the channel
    /// whose edge is nearest, within its half-width and a global cell or its valley floor's
    /// reach. O(segments x the cells each reaches).
    pub fn find(
        channels: &Channels,
        global: &Heightfield,
        levels: u32,
        window: Region,
        cell_m: f64,
    ) -> Self {
        let scale = f64::from(1u32 << levels);
        let (cell, global_cell) = (cell_m as f32, (cell_m * scale) as f32);
        let mut cells = vec![OUT_OF_REACH; window.width * window.height];
        for link in &channels.links {
            let half = link.half_width_m.max(0.5 * cell);
            let reach = (half + global_cell).max(FLOOR_REACH * link.floor_half_width_m);
            for (k, pair) in link.points.windows(2).enumerate() {
                let laid = [link.on_floor[k], link.on_floor[k + 1]];
                if laid == [0.0, 0.0] {
                    continue;
                }
                let piece = Piece {
                    a: pair[0],
                    b: pair[1],
                    bed: [link.bed[k], link.bed[k + 1]],
                    laid,
                };
                piece.visit(window, cell, reach, |i, across, [bed, laid]| {
                    let beyond = across - half;
                    if beyond < cells[i].beyond {
                        cells[i] = Reach {
                            beyond,
                            across,
                            bed,
                            depth: link.depth_m,
                            laid,
                            floor: link.floor_half_width_m,
                            ..OUT_OF_REACH
                        };
                    }
                });
            }
        }
        let surface = Surface {
            field: global,
            cell_m: global_cell,
        };
        for (i, r) in cells.iter_mut().enumerate() {
            if r.beyond.is_finite() {
                let x = (window.x0 + i % window.width) as f64 / scale;
                let y = (window.y0 + i / window.width) as f64 / scale;
                let (smooth, slope) = surface.at(x, y);
                r.smooth = smooth;
                r.on_floor = r.laid * floor_share(r.across, r.floor, slope);
            }
        }
        Self {
            window,
            cell_m: cell,
            global_cell_m: global_cell,
            cells,
        }
    }

    /// What the refinement keeps of the channels and their floors ([`Laid`]).
    pub fn laid(&self) -> Laid {
        Laid {
            held: self
                .cells
                .iter()
                .map(|r| r.beyond <= 0.0 && r.laid >= 1.0)
                .collect(),
            still: self.cells.iter().map(|r| r.on_floor).collect(),
        }
    }

    /// Cuts the channels into `heights` (the window's cells, row-major): the valley floor
    /// without the levels' detail (the global build's surface, [`floor_share`]); inside the
    /// channel, the bed plus the cross rise; the bank rising over one world cell across the
    /// channel's edge to the floodplain, a bankfull depth above the bed; lower land within
    /// half a global cell raised to it, the raise fading out over the next half global cell.
    /// Each cell takes the cut in the share its course lies on the global build's floor.
    /// O(cells).
    pub fn lay(&self, heights: &mut [f32]) {
        let rise = CROSS_RISE as f32;
        for (z, r) in heights.iter_mut().zip(&self.cells) {
            if !r.beyond.is_finite() {
                continue;
            }
            *z += r.on_floor * (r.smooth - *z);
            // The bank: from the bed at the channel's edge (at least half a cell from the
            // course, so the cells nearest the course make an unbroken line at the bed,
            // falling downstream) to the floodplain a cell beyond it.
            let bank = (r.beyond / self.cell_m).clamp(0.0, 1.0);
            let profile = r.bed + rise * r.across + r.depth * bank;
            if bank < 1.0 {
                *z += r.laid * (profile - *z);
            } else {
                let fade = (2.0 - 2.0 * r.beyond / self.global_cell_m).clamp(0.0, 1.0);
                let t = r.laid * fade * fade * (3.0 - 2.0 * fade);
                *z += t * (z.max(profile) - *z);
            }
        }
        debug_assert_eq!(heights.len(), self.window.width * self.window.height);
    }
}

/// The global build's surface between its cells: bilinear heights, and slopes from its
/// central differences, bilinear too (continuous across the cells, so a share of detail
/// taken from them shows no cell edges).
struct Surface<'a> {
    field: &'a Heightfield,
    /// The global build's cell, metres.
    cell_m: f32,
}

impl Surface<'_> {
    /// The height's change per cell along x and along y at cell `(x, y)`: central
    /// differences, one-sided on the border.
    fn gradient(&self, x: usize, y: usize) -> [f32; 2] {
        let n = self.field.width();
        let z = self.field.data();
        let (l, r) = (x.saturating_sub(1), (x + 1).min(n - 1));
        let (u, d) = (y.saturating_sub(1), (y + 1).min(n - 1));
        [
            (z[y * n + r] - z[y * n + l]) / (r - l).max(1) as f32,
            (z[d * n + x] - z[u * n + x]) / (d - u).max(1) as f32,
        ]
    }

    /// The height (m) and the slope (m/m) at global cell coordinates `(x, y)`.
    fn at(&self, x: f64, y: f64) -> (f32, f32) {
        let n = self.field.width();
        let last = (n - 1) as f64;
        let (fx, fy) = (x.clamp(0.0, last), y.clamp(0.0, last));
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(n - 1), (y0 + 1).min(n - 1));
        let (tx, ty) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let mix = |c: [[f32; 2]; 2]| {
            let top = c[0][0] + (c[0][1] - c[0][0]) * tx;
            let bottom = c[1][0] + (c[1][1] - c[1][0]) * tx;
            top + (bottom - top) * ty
        };
        let z = |x: usize, y: usize| self.field.data()[y * n + x];
        let height = mix([[z(x0, y0), z(x1, y0)], [z(x0, y1), z(x1, y1)]]);
        let g = [
            [self.gradient(x0, y0), self.gradient(x1, y0)],
            [self.gradient(x0, y1), self.gradient(x1, y1)],
        ];
        let gx = mix(g.map(|row| row.map(|v| v[0])));
        let gy = mix(g.map(|row| row.map(|v| v[1])));
        (height, gx.hypot(gy) / self.cell_m)
    }
}

/// A straight piece of a course (metres) with the bed and the share of the cut at its ends.
struct Piece {
    a: [f32; 2],
    b: [f32; 2],
    bed: [f32; 2],
    laid: [f32; 2],
}

impl Piece {
    /// Calls `visit(i, across, [bed, laid])` for each cell `i` of `window` (world cells
    /// `cell` metres wide) within `reach` metres of the piece: its distance to the piece, and
    /// the bed and the share of the cut at the nearest point.
    fn visit(
        &self,
        window: Region,
        cell: f32,
        reach: f32,
        mut visit: impl FnMut(usize, f32, [f32; 2]),
    ) {
        let (a, b) = (
            DVec2::from(self.a.map(f64::from)),
            DVec2::from(self.b.map(f64::from)),
        );
        let (cell, reach) = (f64::from(cell), f64::from(reach));
        let lo = (a.min(b) - reach) / cell;
        let hi = (a.max(b) + reach) / cell;
        let span = |lo: f64, hi: f64, start: usize, len: usize| {
            let first = (lo.ceil().max(start as f64)) as usize;
            let end = ((hi.floor() + 1.0).min((start + len) as f64)).max(first as f64) as usize;
            first..end
        };
        let along = b - a;
        let length2 = along.length_squared();
        for y in span(lo.y, hi.y, window.y0, window.height) {
            for x in span(lo.x, hi.x, window.x0, window.width) {
                let p = DVec2::new(x as f64, y as f64) * cell;
                let t = if length2 > 0.0 {
                    ((p - a).dot(along) / length2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let across = (p - (a + along * t)).length();
                if across <= reach {
                    let along = |v: [f32; 2]| (f64::from(v[0]) + t * f64::from(v[1] - v[0])) as f32;
                    let i = (y - window.y0) * window.width + x - window.x0;
                    visit(i, across as f32, [along(self.bed), along(self.laid)]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::task;

    /// On a real world (the default design's 129^2 global build on a 10 km map, two levels
    /// of detail: global cells of 78 m, world cells of 19.5 m), the trunk's channel runs
    /// at its own width and depth: its beds never rise downstream; in the refined window
    /// over the trunk, the channel's cells hold the laid bed, each drains to a neighbour at
    /// or below it, and the land just beyond the bank stands the bankfull depth above the
    /// bed (where the levels of detail left a trough one global cell wide); and its valley
    /// floor is smooth, without the levels' detail.
    #[test]
    fn a_worlds_channels_are_cut_at_their_width_and_drain() {
        let plan = crate::world::refine::tests::real_world_plan();
        let ctx = crate::jobs::JobCtx::detached();
        let build = pollster::block_on(task::build_global(&plan, &ctx)).unwrap();
        let global = build.global(&plan);
        assert!(!global.channels.links.is_empty(), "the trunk has a floor");
        for link in &global.channels.links {
            assert!(
                link.bed.windows(2).all(|w| w[0] <= w[1]),
                "a bed rises downstream"
            );
        }
        let window = plan.refine_window(12);
        let (w, h) = (window.width, window.height);
        let nearest = task::channels_in(&global, &plan, window);
        let laid = nearest.laid();
        let inside = &laid.held;
        let cells = task::cells(&global, &plan, window);
        let refined = crate::world::refine::refine(&plan, window, cells.clone(), &laid).unwrap();
        let z = &refined.heights;
        let rise = CROSS_RISE as f32;
        let (mut channel, mut pits) = (0, 0);
        let (mut above, mut beside, mut trough) = (0.0f64, 0usize, 0.0f64);
        let mut bed_trough = 0.0f64;
        let bare = task::Global {
            channels: Channels::default(),
            ..build.global(&plan)
        };
        let interpolated = task::cells(&bare, &plan, window);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let (i, r) = (y * w + x, nearest.cells[y * w + x]);
                if inside[i] {
                    channel += 1;
                    bed_trough += f64::from((interpolated[i] - r.bed - rise * r.across) / r.depth);
                    assert_eq!(z[i], cells[i], "a channel cell moved");
                    assert_eq!(z[i], r.bed + rise * r.across, "a channel cell off its bed");
                    let lowest = [
                        i - 1,
                        i + 1,
                        i - w,
                        i + w,
                        i - w - 1,
                        i - w + 1,
                        i + w - 1,
                        i + w + 1,
                    ]
                    .iter()
                    .map(|&j| z[j])
                    .fold(f32::INFINITY, f32::min);
                    pits += usize::from(lowest > z[i]);
                } else if r.laid >= 1.0
                    && (nearest.cell_m..2.0 * nearest.cell_m).contains(&r.beyond)
                {
                    above += f64::from((z[i] - r.bed - rise * r.across) / r.depth);
                    trough += f64::from((interpolated[i] - r.bed - rise * r.across) / r.depth);
                    beside += 1;
                }
            }
        }
        let (above, trough) = (above / beside as f64, trough / beside as f64);
        let bed_trough = bed_trough / channel as f64;
        println!(
            "{channel} channel cells, {pits} pits; beside the bank {above:.2} bankfull \
             depths above the bed ({trough:.2} interpolated, whose channel cells stand \
             {bed_trough:.2} above it)"
        );
        assert!(
            channel > 100 && pits == 0,
            "{channel} channel cells, {pits} pits"
        );
        // The bank's step: a bankfull depth or more (the interpolation's, from its channel
        // cells to the same cells beside, half a depth).
        assert!(above >= 1.0, "the floodplain {above} depths above the bed");
        assert!(trough - bed_trough < 1.0, "{trough} - {bed_trough}");
        // The valley floor beyond the banks loses the levels' detail: its cells' mean
        // |Laplacian| after the step, against the interpolation's with its detail.
        let laplacian = |v: &[f32], i: usize| {
            f64::from((v[i - 1] + v[i + 1] + v[i - w] + v[i + w] - 4.0 * v[i]).abs())
        };
        let (mut floor, mut rough, mut count) = (0.0f64, 0.0f64, 0usize);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let (i, r) = (y * w + x, nearest.cells[y * w + x]);
                if r.on_floor >= 1.0 && r.beyond > 2.0 * nearest.cell_m {
                    floor += laplacian(z, i);
                    rough += laplacian(&interpolated, i);
                    count += 1;
                }
            }
        }
        let (floor, rough) = (floor / count as f64, rough / count as f64);
        println!(
            "{count} floor cells: mean |Laplacian| {floor:.3} m ({rough:.3} m with the detail)"
        );
        assert!(
            count > 100 && floor < 0.5 * rough,
            "{count} cells: {floor} against {rough}"
        );
    }

    /// A straight channel across a sloping window: the bed cells at the course, the bank up
    /// to the floodplain a bankfull depth above, the land far away untouched, and the cells
    /// inside marked.
    #[test]
    fn a_channel_is_cut_to_its_bed_with_banks_to_the_floodplain() {
        let channels = Channels {
            links: vec![Channel {
                points: vec![[0.0, 50.0], [200.0, 50.0]],
                bed: vec![10.0, 12.0],
                on_floor: vec![1.0, 1.0],
                half_width_m: 4.0,
                depth_m: 1.5,
                floor_half_width_m: 0.0,
            }],
        };
        let window = Region {
            x0: 0,
            y0: 0,
            width: 201,
            height: 101,
        };
        // 1 m world cells, 8 m global cells (three levels); the land a V rising 0.2 m/m
        // from 10.5 m; no valley floor.
        let v = |y: f32| 10.5 + 0.2 * (y - 50.0).abs();
        let global = (0..26 * 26).map(|i| v((i / 26 * 8) as f32)).collect();
        let global = Heightfield::from_vec(26, 26, global).unwrap();
        let nearest = Nearest::find(&channels, &global, 3, window, 1.0);
        let mut z: Vec<f32> = (0..201 * 101).map(|i| v((i / 201) as f32)).collect();
        nearest.lay(&mut z);
        let at = |x: usize, y: usize| z[y * 201 + x];
        // The bed at the course, rising upstream (towards x = 200).
        assert!((at(0, 50) - 10.0).abs() < 1e-4 && (at(200, 50) - 12.0).abs() < 1e-4);
        assert!((at(100, 52) - (11.0 + 0.008)).abs() < 1e-4);
        // The floodplain beside it: a bankfull depth above the bed (raised from the V).
        assert!(
            (at(100, 56) - (11.0 + 1.5 + 0.024)).abs() < 1e-3,
            "{}",
            at(100, 56)
        );
        // Far away the land is what it was.
        assert_eq!(at(100, 80), 10.5 + 0.2 * 30.0);
        let inside = nearest.laid().held;
        assert!(inside[50 * 201 + 100] && inside[54 * 201 + 100] && !inside[55 * 201 + 100]);
    }
}
