//! The threshold-slope limit of the eroded surface: no free cell stands higher above any
//! cell within two cells than the talus slope allows, `h_i <= h_j + tan(talus) * |x_i - x_j|`.
//!
//! Hillslopes of rapidly uplifting ranges stand at a threshold angle, steeper ground failing
//! by landslides whose debris the rivers carry away (Burbank et al. 1996, "Bedrock incision,
//! rock uplift and threshold hillslopes in the northwestern Himalayas", Nature 379;
//! Montgomery and Brandon 2002, "Topographic controls on erosion rates in tectonically active
//! mountain ranges", EPSL 201). The thermal relaxation of each step (`thermal.rs`) moves
//! material downhill but, at two passes a step, cannot hold the angle where uplift outpaces it
//! (slopes of 50-75 degrees on 2-10 km maps); this limit lowers what stands above it, leaving
//! the largest surface below the eroded one whose slopes all stay within the angle, and the
//! step's hillslope diffusion then rounds the crests it leaves.
//!
//! The largest such surface is the min-plus convolution `h'_i = min_j (h_j + c_ij)` with the
//! slope cone `c_ij = tan(talus) * d_ij`, computed as a chamfer distance transform: raster
//! scans forward and backward, each cell taking the minimum over the half of a 5 x 5 mask
//! already scanned (the 8 neighbours and the 8 knight's moves, exact distances 1, sqrt 2 and
//! sqrt 5; Borgefors 1986, "Distance transformations in digital images", CVGIP 34). The 5 x
//! 5 mask's cones are 16-sided (within 2.7% of round) where the 8 neighbours alone give
//! octagons, whose facets would face the grid's 8 directions. Base-level cells (the rivers
//! and their banks) keep their heights and act only as sources. The solver runs one scan
//! pair a time step, after the incision ([`super::Eroder::with_slope_limit`]): exact where
//! no base-level cell bends the paths, and the next step's pair goes on from there.
//!
//! Pits are rare: a lowered cell ends at `h_j + c_ij` above some cell `j` within two cells,
//! which is lower, and a cell not lowered keeps its lower neighbour, which only went down;
//! only where `j` is a knight's move away behind two higher base-level cells can a lowered
//! cell be left without a lower neighbour, and the next routing fills it.

use std::ops::Range;

/// The mask's offsets `(dx, dy)` in the forward scan's half (rows above, and the cells left
/// of the current one); the backward half is their negation.
const FORWARD: [(isize, isize); 8] = [
    (-1, -2),
    (1, -2),
    (-2, -1),
    (-1, -1),
    (0, -1),
    (1, -1),
    (2, -1),
    (-1, 0),
];

/// The 5 x 5 mask on a `width` x `height` grid: offsets and the rise allowed over each.
pub(super) struct Mask {
    width: usize,
    height: usize,
    steps: [(isize, isize, f32); 8],
}

impl Mask {
    /// The mask of slopes up to `talus_deg` on a `width` x `height` grid of `cell_m` cells.
    pub(super) fn new(width: usize, height: usize, cell_m: f64, talus_deg: f64) -> Self {
        let rise = (talus_deg.to_radians().tan() * cell_m) as f32;
        Self {
            width,
            height,
            steps: FORWARD.map(|(dx, dy)| {
                let d = ((dx * dx + dy * dy) as f32).sqrt();
                (dx, dy, rise * d)
            }),
        }
    }

    /// One band of a scan: rows `rows` of the forward scan (top down, left to right), or of
    /// the backward scan (row `height - 1 - y` for `y` in `rows`, right to left). Returns
    /// whether a cell was lowered. O(cells of the rows).
    pub(super) fn scan(
        &self,
        h: &mut [f32],
        base: &[bool],
        rows: Range<usize>,
        forward: bool,
    ) -> bool {
        let (w, rows_total) = (self.width as isize, self.height as isize);
        let sign = if forward { 1 } else { -1 };
        let mut changed = false;
        for yy in rows {
            let y = if forward { yy } else { self.height - 1 - yy } as isize;
            for xx in 0..w {
                let x = if forward { xx } else { w - 1 - xx };
                let i = (y * w + x) as usize;
                if base[i] {
                    continue;
                }
                let mut cap = h[i];
                for &(dx, dy, rise) in &self.steps {
                    let (nx, ny) = (x + sign * dx, y + sign * dy);
                    if nx >= 0 && ny >= 0 && nx < w && ny < rows_total {
                        cap = cap.min(h[(ny * w + nx) as usize] + rise);
                    }
                }
                if cap < h[i] {
                    h[i] = cap;
                    changed = true;
                }
            }
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scans on 10 m cells until nothing changes; returns how many cells were lowered.
    fn limited(h: &mut [f32], n: usize, base: &[bool], talus: f64) -> usize {
        let before = h.to_vec();
        let mask = Mask::new(n, n, 10.0, talus);
        for _ in 0..8 {
            let forward = mask.scan(h, base, 0..n, true);
            let backward = mask.scan(h, base, 0..n, false);
            if !(forward || backward) {
                break;
            }
        }
        h.iter().zip(&before).filter(|(a, b)| a != b).count()
    }

    /// A spike on a plain becomes a 16-sided cone of the talus slope: every cell at most
    /// `tan(talus) * distance` above the plain, lowered only, the plain and the base kept,
    /// no pit; a second run changes nothing.
    #[test]
    fn a_spike_becomes_a_round_cone_of_the_talus_slope() {
        let n = 41;
        let mut h = vec![0.0f32; n * n];
        let base: Vec<bool> = (0..n * n).map(|i| i % n == 0).collect();
        let c = 20 * n + 20;
        h[c] = 1000.0;
        h[20 * n + 30] = 3.0;
        let before = h.clone();
        let count = limited(&mut h, n, &base, 30.0);
        assert_eq!(count, 1, "only the spike stands above the limit");
        let tan = 30f64.to_radians().tan() * 10.0;
        // The spike is one cell: its neighbours at 0 hold it to tan * 10 m.
        assert!((f64::from(h[c]) - tan).abs() < 1e-3, "{}", h[c]);
        assert!(h.iter().zip(&before).all(|(a, b)| a <= b));
        // A raised table: the limit cuts its edges into a cone about the plain.
        let mut table = vec![500.0f32; n * n];
        for (i, b) in base.iter().enumerate() {
            if *b {
                table[i] = 0.0;
            }
        }
        limited(&mut table, n, &base, 30.0);
        for y in 0..n {
            for x in 1..n {
                let limit = tan * x as f64; // the nearest base cell is (0, y)
                let got = f64::from(table[y * n + x]);
                assert!(got <= limit * 1.001 + 1e-3, "({x}, {y}): {got} > {limit}");
                assert!(got >= limit * 0.97 - 1e-3, "({x}, {y}): {got} < {limit}");
            }
        }
        let again = table.clone();
        assert_eq!(limited(&mut table, n, &base, 30.0), 0);
        assert_eq!(table, again);
    }

    /// Around a single low cell the cone is round: the height at every distance varies with
    /// the direction by under 3% (an octagon of the 8 neighbours alone: 8%).
    #[test]
    fn cones_are_nearly_round() {
        let n = 81;
        let mut h = vec![1.0e4f32; n * n];
        let mut base = vec![false; n * n];
        let c = 40 * n + 40;
        h[c] = 0.0;
        base[c] = true;
        limited(&mut h, n, &base, 45.0);
        for y in 0..n {
            for x in 0..n {
                let r = ((x as f64 - 40.0).hypot(y as f64 - 40.0)) * 10.0;
                if (100.0..=390.0).contains(&r) {
                    let ratio = f64::from(h[y * n + x]) / r;
                    assert!((1.0 - 1e-3..1.03).contains(&ratio), "({x}, {y}): {ratio}");
                }
            }
        }
    }
}
