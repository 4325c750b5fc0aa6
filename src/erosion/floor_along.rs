//! What a valley floor's cells take from their channel, spread along the valley: the height
//! the floor rises from, the drainage area that sizes its channel and bank, how far it reaches
//! and how far the cell lies from the channel.
//!
//! Each floor cell takes these from its nearest channel cell
//! ([`super::floodplain::nearest_within`]). Nearest-cell regions are strips across the floor,
//! one a channel cell, so each value steps from strip to strip along the valley: the height by
//! the channel's fall, the area and the reach where the taper's origin moves on
//! ([`super::floodplain::taper_along`]), and the distance to a raster channel in a sawtooth
//! along every slanting reach (the nearest cell of a staircase jumps ahead at each of its
//! steps), which the footslope and the bank turn into kinks of 5-10 cm. On a floor that rises
//! 0.4% across, such steps and kinks show in a hillshade: stripes across every floor and a
//! dashed line along each bank at 2048^2-4096^2. So each value is smoothed over the floor
//! ([`spread`]).
//!
//! The smoothing is the first sweeps of a harmonic interpolation from the channel cells over
//! their floor, each cell taking the mean of its pairs of opposite neighbours on the floor or
//! its channel. Pairs keep linear values as they are (a channel falling evenly keeps its floor
//! falling evenly up to the floor's edges and ends), so only steps are spread. Jacobi sweeps of
//! neighbours one cell apart spread a step over about `sqrt(sweeps)` cells, while the strips
//! grow with the channel in cells: at 2.4 m cells (a 10 km map at 4096^2) eight such sweeps
//! left a stripe across the floor every few strips. So the sweeps run at several scales, the
//! opposite neighbours `2^k` cells apart, from the widest within [`SPREAD_M`] down to one cell
//! (the "à trous" form of a smoothing pyramid; Holschneider et al. 1989, "A real-time
//! algorithm for signal analysis with the help of the wavelet transform"), which spreads a step
//! over about [`SPREAD_M`] at every cell size, two sweeps a scale. On cells of half
//! [`SPREAD_M`] or more the one-cell sweeps run alone.

/// How far along a valley a step in its floor is spread, metres at least: about a floor's
/// half-width where floors begin (the least floor is a cell or two either side of its channel).
pub const SPREAD_M: f64 = 20.0;

/// Jacobi sweeps of pairs one cell apart (chosen by eye in hillshades of the default scene at
/// 2048^2, 4.9 m cells: 2 sweeps still showed the stripes, 8 none).
const NEAR_SWEEPS: usize = 8;

/// Jacobi sweeps at each wider scale, pairs `2^k` cells apart.
const WIDE_SWEEPS: usize = 2;

/// The floors of an `n` x `n` grid: each cell's nearest channel cell with a floor and its
/// distance in cells (`None` off the floors), the channel cells, and which of them have a
/// floor (the sources).
pub(super) struct Floors<'a> {
    /// Each cell's nearest source and its distance, cells ([`super::floodplain::nearest_within`]).
    pub nearest: &'a [Option<(u32, f32)>],
    /// The channel cells, which keep their heights.
    pub channel: &'a [bool],
    /// The channel cells with a floor.
    pub sources: &'a [bool],
    /// Cells a side.
    pub n: usize,
}

impl Floors<'_> {
    /// The floor cells: near a source, not a channel.
    fn cells(&self) -> Vec<usize> {
        (0..self.nearest.len())
            .filter(|&i| self.nearest[i].is_some() && !self.channel[i])
            .collect()
    }

    /// Whether cell `j` carries a height to spread: a floor or channel cell.
    fn with_height(&self, j: usize) -> bool {
        self.channel[j] || self.nearest[j].is_some()
    }

    /// Whether cell `j` carries a floor's size to spread: a floor cell or a source.
    fn with_size(&self, j: usize) -> bool {
        self.sources[j] || (self.nearest[j].is_some() && !self.channel[j])
    }
}

/// The floor's inputs at every cell, spread along the valleys; values off the floors and their
/// channels are unspecified.
pub(super) struct FloorInputs {
    /// The height the floor rises from: its channel's, spread.
    pub base: Vec<f32>,
    /// The drainage area sizing the channel and its bank, m^2.
    pub area: Vec<f32>,
    /// How far the floor reaches from its channel, metres.
    pub reach: Vec<f32>,
    /// How far the cell lies from its channel, cells.
    pub across: Vec<f32>,
}

/// The inputs of the cells of `floors`, on cells `cell_m` wide: each floor cell takes its
/// nearest source's height of `z`, `area` and `reach` (functions of the source's index), and
/// these are spread over the floor ([`spread`]), the channel cells held at their own.
/// O(floor cells x (sweeps + the widest offset)).
pub(super) fn floor_inputs(
    z: &[f32],
    floors: &Floors,
    cell_m: f64,
    area: impl Fn(usize) -> f32,
    reach: impl Fn(usize) -> f32,
) -> FloorInputs {
    let cells = floors.cells();
    let sources: Vec<usize> = (0..z.len()).filter(|&i| floors.sources[i]).collect();
    let of_source = |value: &dyn Fn(usize) -> f32| -> Vec<f32> {
        let mut field = vec![0.0f32; z.len()];
        for &s in &sources {
            field[s] = value(s);
        }
        for &i in &cells {
            if let Some((source, _)) = floors.nearest[i] {
                field[i] = value(source as usize);
            }
        }
        field
    };
    let mut base = z.to_vec();
    for &i in &cells {
        if let Some((source, _)) = floors.nearest[i] {
            base[i] = z[source as usize];
        }
    }
    let mut area = of_source(&area);
    let mut reach = of_source(&reach);
    let mut across = vec![0.0f32; z.len()];
    for &i in &cells {
        if let Some((_, distance)) = floors.nearest[i] {
            across[i] = distance;
        }
    }
    let scales = scales(cell_m);
    spread(&mut [&mut base[..]], &cells, floors.n, &scales, |j| {
        floors.with_height(j)
    });
    spread(
        &mut [&mut area[..], &mut reach[..]],
        &cells,
        floors.n,
        &scales,
        |j| floors.with_size(j),
    );
    // The floor's cells alone: a pair across the channel would average the two sides'
    // distances, which fall to the channel and rise again.
    spread(&mut [&mut across[..]], &cells, floors.n, &scales, |j| {
        floors.nearest[j].is_some() && !floors.channel[j]
    });
    FloorInputs {
        base,
        area,
        reach,
        across,
    }
}

/// Smooths `heights` over `cells` (an `n`-wide grid) by [`NEAR_SWEEPS`] Jacobi sweeps of
/// pairs one cell apart that are both `on` (the cells between the same), the other cells held:
/// the land within a floor's reach that the floor does not lower. There the floor keeps the
/// design, which near a grown branch is a raster staircase (the branch a cell lower than the
/// land beside it, each step's corner a cell higher): a base-level cell the solver never
/// reshapes, it showed as a string of beads across the floor's margin at 2048^2-4096^2.
/// The sweeps round the steps at the cell scale and keep slopes as they are.
pub(super) fn smooth_cells(
    heights: &mut [f32],
    cells: &[usize],
    n: usize,
    on: impl Fn(usize) -> bool,
) {
    spread(&mut [heights], cells, n, &[1; NEAR_SWEEPS], on);
}

/// The offsets, in cells, of the sweeps on `cell_m` cells, widest first: each power of two up
/// to [`SPREAD_M`] ([`WIDE_SWEEPS`] sweeps each), then one cell ([`NEAR_SWEEPS`] sweeps).
fn scales(cell_m: f64) -> Vec<usize> {
    let widest = (SPREAD_M / cell_m.max(1e-9)).floor().max(1.0);
    let mut wide = Vec::new();
    let mut offset = 2usize;
    while offset as f64 <= widest {
        wide.push(offset);
        offset *= 2;
    }
    let wide = wide.into_iter().rev().flat_map(|s| [s; WIDE_SWEEPS]);
    wide.chain([1; NEAR_SWEEPS]).collect()
}

/// Jacobi sweeps of each of `fields` over `cells` of an `n`-wide grid, one a scale of `scales`
/// (the offset of its pairs, in cells): each cell takes the mean of its pairs of opposite
/// neighbours at that offset, the others held; a pair counts where it and every cell between
/// them are `on`, so a sweep never reaches across a ridge into another valley's floor; a cell
/// without such a pair keeps its value.
fn spread(
    fields: &mut [&mut [f32]],
    cells: &[usize],
    n: usize,
    scales: &[usize],
    on: impl Fn(usize) -> bool,
) {
    // The sweep's new values, by position in `cells`.
    let mut next = vec![0.0f32; cells.len()];
    let mut pairs: Vec<[Option<(usize, usize)>; 2]> = Vec::new();
    let mut last = 0;
    for &s in scales {
        if s != last {
            pairs = cells.iter().map(|&i| pairs_at(i, n, s, &on)).collect();
            last = s;
        }
        for field in fields.iter_mut() {
            for ((&i, cell_pairs), new) in cells.iter().zip(&pairs).zip(next.iter_mut()) {
                let (mut sum, mut count) = (0.0f32, 0u32);
                for (a, b) in cell_pairs.iter().flatten() {
                    sum += field[*a] + field[*b];
                    count += 2;
                }
                *new = if count > 0 {
                    sum / count as f32
                } else {
                    field[i]
                };
            }
            for (&i, new) in cells.iter().zip(&next) {
                field[i] = *new;
            }
        }
    }
}

/// Cell `i`'s pairs of opposite neighbours `s` cells away along the rows and the columns (of an
/// `n`-wide grid), where they and the cells between are all `on`.
fn pairs_at(
    i: usize,
    n: usize,
    s: usize,
    on: impl Fn(usize) -> bool,
) -> [Option<(usize, usize)>; 2] {
    let (x, y) = (i % n, i / n);
    let along = |step: usize| (1..=s).all(|k| on(i - k * step) && on(i + k * step));
    [
        (x >= s && x + s < n && along(1)).then(|| (i - s, i + s)),
        (y >= s && y + s < n && along(n)).then(|| (i - s * n, i + s * n)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One cell's sweeps alone on cells of half [`SPREAD_M`] or more (the maps of before);
    /// finer cells add two sweeps a power of two up to it, widest first.
    #[test]
    fn the_scales_reach_the_spread_at_every_cell_size() {
        assert_eq!(scales(20.0), vec![1; NEAR_SWEEPS]);
        assert_eq!(scales(10.0), [vec![2, 2], vec![1; NEAR_SWEEPS]].concat());
        assert_eq!(
            scales(2.4),
            [vec![8, 8, 4, 4, 2, 2], vec![1; NEAR_SWEEPS]].concat()
        );
    }

    /// Values that change linearly along and across a strip are kept as they are by the
    /// sweeps at every scale (a channel falling evenly keeps its floor so); a step in them is
    /// spread over the strip's length at fine cells, where one-cell sweeps leave most of it.
    #[test]
    fn the_sweeps_keep_slopes_and_spread_steps() {
        let n = 64;
        let cells: Vec<usize> = (20 * n..44 * n).collect();
        let on = |j: usize| (20 * n..44 * n).contains(&j);
        let mut linear: Vec<f32> = (0..n * n)
            .map(|i| (i % n) as f32 * 0.5 + (i / n) as f32)
            .collect();
        let before = linear.clone();
        spread(&mut [&mut linear[..]], &cells, n, &scales(2.4), on);
        for &i in &cells {
            assert!((linear[i] - before[i]).abs() < 1e-3, "cell {i}");
        }
        let step = |scales: &[usize]| {
            let mut v: Vec<f32> = (0..n * n)
                .map(|i| if i % n < 32 { 1.0 } else { 0.0 })
                .collect();
            spread(&mut [&mut v[..]], &cells, n, scales, on);
            let row = 32 * n;
            (1..n)
                .map(|x| (v[row + x] - v[row + x - 1]).abs())
                .fold(0.0f32, f32::max)
        };
        let (near, all) = (step(&scales(20.0)), step(&scales(2.4)));
        assert!(all < 0.12, "largest jump {all}");
        assert!(near > 2.0 * all, "one-cell sweeps {near}, all scales {all}");
    }

    /// The distance to a channel that slants one cell in four, a raster staircase: down a
    /// column the channel comes nearer, and each cell's distance to its nearest channel cell
    /// falls in a sawtooth (a kink at each of the staircase's steps); spread, it falls evenly,
    /// its second differences a fifth of the raw ones or less, within the raw range.
    #[test]
    fn the_distance_to_a_staircase_channel_is_smooth_along_it() {
        let n = 96;
        let mut channel = vec![false; n * n];
        for y in 0..n {
            channel[y * n + 20 + y / 4] = true;
        }
        let sources = channel.clone();
        let reach = vec![12.0f32; n * n];
        let nearest = crate::erosion::floodplain::nearest_within(
            n,
            (0..n * n).filter(|&i| channel[i]),
            &reach,
        );
        let floors = Floors {
            nearest: &nearest,
            channel: &channel,
            sources: &sources,
            n,
        };
        let z = vec![0.0f32; n * n];
        let inputs = floor_inputs(&z, &floors, 2.4, |_| 1.0e8, |_| 30.0);
        let raw: Vec<f32> = (0..n * n)
            .map(|i| nearest[i].map_or(0.0, |(_, d)| d))
            .collect();
        // One column, the channel coming nearer from 10 cells west to 2 as it slants east.
        let line = |field: &[f32]| -> Vec<f32> { (56..88).map(|y| field[y * n + 44]).collect() };
        let kink = |v: &[f32]| {
            v.windows(3)
                .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
                .fold(0.0f32, f32::max)
        };
        let (raw_line, spread_line) = (line(&raw), line(&inputs.across));
        assert!(kink(&raw_line) > 0.2, "raw kinks {}", kink(&raw_line));
        assert!(
            kink(&spread_line) < kink(&raw_line) / 5.0,
            "kinks {} against {}",
            kink(&spread_line),
            kink(&raw_line)
        );
        let (lo, hi) = raw_line
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
        assert!(
            spread_line
                .iter()
                .all(|v| (lo - 1e-3..=hi + 1e-3).contains(v))
        );
    }

    /// A branch a cell wide on a 4-connected staircase climbing a cell in three, held, in land
    /// that rises half a metre a 4-connected step from it (the raster V a design leaves, beads
    /// at each step's corner): smoothed, the land 1.5-2.5 cells from the branch's line strays
    /// from a straight rise with the distance 0.7 times as much or less, the branch keeps its
    /// heights, and no cell leaves the range it had.
    #[test]
    fn a_floors_margin_loses_its_raster_steps() {
        let n = 60;
        let mut branch = vec![false; n * n];
        for x in 0..n {
            branch[(x / 3) * n + x] = true;
            if x % 3 == 0 && x > 0 {
                branch[(x / 3 - 1) * n + x] = true;
            }
        }
        // 4-connected steps from the branch, breadth first.
        let mut steps = vec![usize::MAX; n * n];
        let mut queue: std::collections::VecDeque<usize> =
            (0..n * n).filter(|&i| branch[i]).collect();
        for &i in &queue {
            steps[i] = 0;
        }
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i % n, i / n);
            let next = [
                (x > 0).then(|| i - 1),
                (x + 1 < n).then(|| i + 1),
                (y > 0).then(|| i - n),
                (y + 1 < n).then(|| i + n),
            ];
            for j in next.into_iter().flatten() {
                if steps[j] == usize::MAX {
                    steps[j] = steps[i] + 1;
                    queue.push_back(j);
                }
            }
        }
        let mut heights: Vec<f32> = steps.iter().map(|d| 0.5 * *d as f32).collect();
        let before = heights.clone();
        let cells: Vec<usize> = (0..n * n).filter(|&i| !branch[i]).collect();
        smooth_cells(&mut heights, &cells, n, |_| true);
        // The distance to the branch's line y = x / 3 - 1/3, and how far the land strays
        // from the best straight rise with it, 1.5 to 2.5 cells out, away from the ends.
        let stray = |field: &[f32]| {
            let band: Vec<(f32, f32)> = (0..n * n)
                .filter(|&i| (10..n - 10).contains(&(i % n)) && (5..n - 5).contains(&(i / n)))
                .map(|i| {
                    let (x, y) = ((i % n) as f32, (i / n) as f32);
                    ((3.0 * y - x + 1.0).abs() / 10f32.sqrt(), field[i])
                })
                .filter(|(d, _)| (1.5..2.5).contains(d))
                .collect();
            let count = band.len() as f32;
            let (md, mh) = band
                .iter()
                .fold((0.0, 0.0), |(a, b), (d, h)| (a + d / count, b + h / count));
            let slope = band.iter().map(|(d, h)| (d - md) * (h - mh)).sum::<f32>()
                / band.iter().map(|(d, _)| (d - md) * (d - md)).sum::<f32>();
            let var = band
                .iter()
                .map(|(d, h)| (h - mh - slope * (d - md)).powi(2))
                .sum::<f32>()
                / count;
            var.sqrt()
        };
        let (raw, smooth) = (stray(&before), stray(&heights));
        assert!(raw > 0.1, "raw {raw}");
        // Measured: 0.15 m raw, 0.09 m smoothed.
        assert!(smooth <= 0.7 * raw, "strays {smooth} against {raw}");
        assert!((0..n * n).filter(|&i| branch[i]).all(|i| heights[i] == 0.0));
        let top = before.iter().cloned().fold(0.0f32, f32::max);
        assert!(heights.iter().all(|h| (0.0..=top).contains(h)));
    }

    /// Two floors side by side, a ridge of three cells between them: no sweep averages one
    /// floor's values with the other's.
    #[test]
    fn the_sweeps_do_not_cross_into_another_floor() {
        let n = 48;
        let floor = |j: usize| {
            let y = j / n;
            (10..20).contains(&y) || (23..33).contains(&y)
        };
        let cells: Vec<usize> = (0..n * n).filter(|&j| floor(j)).collect();
        let mut v: Vec<f32> = (0..n * n)
            .map(|j| if j / n < 21 { 0.0 } else { 100.0 })
            .collect();
        spread(&mut [&mut v[..]], &cells, n, &scales(1.0), floor);
        assert!(
            cells
                .iter()
                .all(|&j| v[j] == if j / n < 21 { 0.0 } else { 100.0 })
        );
    }
}
