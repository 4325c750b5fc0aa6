//! Enriching the skeleton with Midpoint Displacement and its inverse (seed paper 000,
//! Sec. V-B, Fig. 5), so valleys and ridges get flanks instead of being single-cell lines.
//!
//! Each pass runs MDI then MD, as the paper alternates them:
//! - **MDI** (Fig. 5b): every known cell is the centre of a 3 x 3 square; the square's unknown
//!   corners are interpolated from the known points inside it (their mean) and displaced
//!   along the flank: `+ alpha * d` beside rivers (valley walls rise) and `- alpha * d` beside
//!   ridges (shoulders fall), `d` the corner's distance from the centre in metres and alpha
//!   the ridge slope of eq. 4. This extends the skeleton by one cell per pass.
//! - **MD** (Fig. 5a): unknown cells between known ones (an edge midpoint between two known
//!   neighbours, or a square centre between four known corners) take their mean, filling the
//!   holes MDI leaves.
//!
//! The distance limit L (in cells): no point is added farther than L cells from the original
//! skeleton, since interpolating from far points adds errors (the paper stops when d > L).
//! Updates of a pass are computed from the state before it and then applied, so the result
//! does not depend on visiting order. O(passes x skeleton cells).

use std::ops::Range;

use super::{CellKind, Skeleton};

/// Enrichment settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnrichParams {
    /// MDI + MD passes (0 turns enrichment off).
    pub passes: u32,
    /// Distance limit L in cells.
    pub distance_limit: u32,
}

impl Default for EnrichParams {
    fn default() -> Self {
        Self {
            passes: 2,
            distance_limit: 3,
        }
    }
}

/// Enriches `sk` in place and returns the number of cells added. `alpha` is the flank slope
/// (metres per metre), `cell_m` the cell size in metres.
pub fn enrich(sk: &mut Skeleton, params: &EnrichParams, alpha: f64, cell_m: f64) -> usize {
    let mut enrichment = Enrichment::new(sk, params, alpha, cell_m);
    for _ in 0..params.passes {
        enrichment.mdi();
        enrichment.md();
    }
    enrichment.added()
}

/// [`enrich`] one half-pass at a time, so a job can yield between them (each is one O(cells)
/// scan of the grid).
pub struct Enrichment<'a> {
    sk: &'a mut Skeleton,
    params: EnrichParams,
    alpha: f64,
    cell_m: f64,
    /// Distance (passes) from the original skeleton.
    dist: Vec<u32>,
    /// Flank side: +1 river, -1 ridge.
    side: Vec<i8>,
    added: usize,
}

impl<'a> Enrichment<'a> {
    pub fn new(sk: &'a mut Skeleton, params: &EnrichParams, alpha: f64, cell_m: f64) -> Self {
        let dist = sk
            .kinds
            .iter()
            .map(|k| if *k == CellKind::Free { u32::MAX } else { 0 })
            .collect();
        let side = sk
            .kinds
            .iter()
            .map(|k| match k {
                CellKind::River | CellKind::Valley => 1,
                CellKind::Ridge => -1,
                _ => 0,
            })
            .collect();
        Self {
            sk,
            params: *params,
            alpha,
            cell_m,
            dist,
            side,
            added: 0,
        }
    }

    /// Cells added so far.
    pub fn added(&self) -> usize {
        self.added
    }

    /// MDI: an unknown cell is a corner of the 3 x 3 squares centred on its known diagonal
    /// neighbours; it takes the mean of those squares' interpolations (gathered, so the
    /// result does not depend on visiting order).
    pub fn mdi(&mut self) {
        let updates = self.mdi_updates(0..self.sk.size);
        self.apply(&updates);
    }

    /// The MDI updates of the rows `rows` (computed from the state before the half-pass;
    /// nothing changes until [`Self::apply`]).
    pub fn mdi_updates(&self, rows: Range<usize>) -> Vec<Update> {
        let (sk, params, dist, side) = (&*self.sk, &self.params, &self.dist, &self.side);
        let n = sk.size;
        let known = |i: usize| sk.kinds[i] != CellKind::Free;
        let diagonal_m = std::f64::consts::SQRT_2 * self.cell_m;
        let mut updates: Vec<Update> = Vec::new();
        let square_mean = |c: usize| {
            let (mut total, mut count) = (0.0f64, 0u32);
            for j in [
                c - n - 1,
                c - n,
                c - n + 1,
                c - 1,
                c,
                c + 1,
                c + n - 1,
                c + n,
                c + n + 1,
            ] {
                if known(j) {
                    total += f64::from(sk.heights[j]);
                    count += 1;
                }
            }
            total / f64::from(count.max(1))
        };
        for y in rows.start.max(2)..rows.end.min(n.saturating_sub(2)) {
            for x in 2..n.saturating_sub(2) {
                let k = y * n + x;
                if known(k) {
                    continue;
                }
                let (mut total, mut count, mut sides, mut d) = (0.0f64, 0u32, 0i32, u32::MAX);
                for c in [k - n - 1, k - n + 1, k + n - 1, k + n + 1] {
                    if known(c) && side[c] != 0 && dist[c] < params.distance_limit {
                        total += square_mean(c) + f64::from(side[c]) * self.alpha * diagonal_m;
                        count += 1;
                        sides += i32::from(side[c]);
                        d = d.min(dist[c] + 1);
                    }
                }
                if count > 0 {
                    updates.push((k, total / f64::from(count), sides.signum() as i8, d));
                }
            }
        }
        updates
    }

    /// MD: midpoints between two known neighbours and centres between four known corners.
    pub fn md(&mut self) {
        let updates = self.md_updates(0..self.sk.size);
        self.apply(&updates);
    }

    /// The MD updates of the rows `rows` (see [`Self::mdi_updates`]).
    pub fn md_updates(&self, rows: Range<usize>) -> Vec<Update> {
        let (sk, params, dist, side) = (&*self.sk, &self.params, &self.dist, &self.side);
        let n = sk.size;
        let known = |i: usize| sk.kinds[i] != CellKind::Free;
        let mut updates: Vec<Update> = Vec::new();
        for y in rows.start.max(1)..rows.end.min(n.saturating_sub(1)) {
            for x in 1..n.saturating_sub(1) {
                let f = y * n + x;
                if known(f) {
                    continue;
                }
                let pairs = [
                    (f - 1, f + 1),
                    (f - n, f + n),
                    (f - n - 1, f + n + 1),
                    (f - n + 1, f + n - 1),
                ];
                let (mut total, mut count, mut sides, mut d) = (0.0f64, 0u32, 0i32, u32::MAX);
                for (a, b) in pairs {
                    if known(a) && known(b) {
                        total += f64::from(sk.heights[a]) + f64::from(sk.heights[b]);
                        count += 2;
                        sides += i32::from(side[a]) + i32::from(side[b]);
                        d = d.min(dist[a].max(dist[b]));
                    }
                }
                if count > 0 && d <= params.distance_limit {
                    updates.push((f, total / f64::from(count), sides.signum() as i8, d));
                }
            }
        }
        updates
    }

    /// Applies a half-pass's updates (all of its rows' at once).
    pub fn apply(&mut self, updates: &[Update]) {
        for &(i, value, s, d) in updates {
            self.sk.heights[i] = value as f32;
            self.sk.kinds[i] = CellKind::Enriched;
            self.side[i] = s;
            self.dist[i] = d;
        }
        self.added += updates.len();
    }
}

/// One added cell: index, height, flank side, distance (passes) from the skeleton.
pub type Update = (usize, f64, i8, u32);

#[cfg(test)]
mod tests {
    use super::*;

    fn line_skeleton(kind: CellKind, height: f32) -> Skeleton {
        let n = 21;
        let mut sk = Skeleton {
            size: n,
            heights: vec![0.0; n * n],
            kinds: vec![CellKind::Free; n * n],
            river_order: vec![0; n * n],
        };
        for x in 0..n {
            sk.kinds[10 * n + x] = kind;
            sk.heights[10 * n + x] = height;
        }
        sk
    }

    #[test]
    fn rivers_get_rising_walls_and_ridges_falling_shoulders_within_l() {
        let mut river = line_skeleton(CellKind::River, 10.0);
        let added = enrich(
            &mut river,
            &EnrichParams {
                passes: 2,
                distance_limit: 3,
            },
            0.1,
            10.0,
        );
        assert!(added > 0);
        let n = river.size;
        let wall = river.heights[9 * n + 10];
        assert_eq!(river.kinds[9 * n + 10], CellKind::Enriched);
        assert!(wall > 10.0, "valley wall {wall} rises above the river");
        // Nothing farther than L = 3 cells from the line.
        for y in 0..n {
            if (y as i64 - 10).abs() > 3 {
                assert!(
                    (0..n).all(|x| river.kinds[y * n + x] == CellKind::Free),
                    "row {y}"
                );
            }
        }
        let mut ridge = line_skeleton(CellKind::Ridge, 100.0);
        enrich(&mut ridge, &EnrichParams::default(), 0.1, 10.0);
        assert!(ridge.heights[11 * n + 10] < 100.0, "ridge shoulder falls");
    }

    #[test]
    fn zero_passes_change_nothing() {
        let mut sk = line_skeleton(CellKind::River, 1.0);
        let before = sk.heights.clone();
        assert_eq!(
            enrich(
                &mut sk,
                &EnrichParams {
                    passes: 0,
                    distance_limit: 3
                },
                0.1,
                1.0
            ),
            0
        );
        assert_eq!(sk.heights, before);
    }
}
