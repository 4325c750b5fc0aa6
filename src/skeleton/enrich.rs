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
//! The distance limit L (in cells), by one of two rules ([`DistanceRule`]):
//! - **Points** (the paper as written: "as the distance d between the two points becomes
//!   long, error of the interpolation using these two points becomes large ... When d > L,
//!   we stop the interpolation"): an interpolation is made only from points at most L cells
//!   apart. On this grid's 3 x 3 squares those distances are fixed by the stencil: 2 cells
//!   for an MD edge midpoint (an axis pair), 2 sqrt 2 for an MD square centre (a diagonal
//!   pair), sqrt 2 for an MDI corner from its square's centre. So L >= 3 limits nothing, and
//!   only the number of passes bounds how far the flanks reach.
//! - **Skeleton** (the default, our reading): no point is added farther than L cells (passes)
//!   from the original skeleton, so L bounds the flanks' width whatever the passes.
//!   `docs/departures.md` compares the two.
//!
//! Updates of a pass are computed from the state before it and then applied, so the result
//! does not depend on visiting order. O(passes x skeleton cells).
//!
//! Banks: an added cell beside a channel (river or valley cell, 8-neighbourhood) is never
//! lower than that channel cell. In a dense network a square's mean can mix a tributary with
//! the lower main stream a few cells away, and a flank cell below the tributary would take
//! the tributary's water sideways (drainage by construction: no dam across a river, no
//! descent off it); raising such a cell to its highest channel neighbour is the smallest
//! change that keeps every channel cell's steepest descent on its channel.

use std::ops::Range;

use super::{CellKind, Skeleton};

/// Enrichment settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnrichParams {
    /// MDI + MD passes (0 turns enrichment off).
    pub passes: u32,
    /// Distance limit L in cells.
    pub distance_limit: u32,
    /// What L limits.
    pub rule: DistanceRule,
}

impl Default for EnrichParams {
    fn default() -> Self {
        Self {
            passes: 2,
            distance_limit: 3,
            rule: DistanceRule::Skeleton,
        }
    }
}

/// What the distance limit L limits (see the module's documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DistanceRule {
    /// No point farther than L cells from the original skeleton.
    #[default]
    Skeleton,
    /// The paper as written: no interpolation between points more than L cells apart.
    Points,
}

impl EnrichParams {
    /// Whether a cell `dist` passes from the skeleton may still be added or read as an MDI
    /// square centre (`centre`: the corner it fills is one pass farther).
    fn reaches(&self, dist: u8, centre: bool) -> bool {
        match self.rule {
            DistanceRule::Skeleton if centre => u32::from(dist) < self.distance_limit,
            DistanceRule::Skeleton => u32::from(dist) <= self.distance_limit,
            // MDI interpolates a corner from its square's centre, sqrt 2 cells away.
            DistanceRule::Points => self.distance_limit.pow(2) >= 2,
        }
    }

    /// The weight (0 or 1) of an MD pair of points `diagonal` or not: under
    /// [`DistanceRule::Points`] a pair farther apart than L (2 cells on an axis, 2 sqrt 2 on a
    /// diagonal) is not interpolated from.
    fn md_pair(&self, diagonal: bool) -> u32 {
        match self.rule {
            DistanceRule::Skeleton => 1,
            DistanceRule::Points => {
                let d2 = if diagonal { 8 } else { 4 };
                u32::from(self.distance_limit.pow(2) >= d2)
            }
        }
    }
}

/// Enriches `sk` in place and returns the number of cells added. `alpha` is the flank slope
/// (metres per metre), `cell_m` the cell size in metres.
/// Each half-pass is gathered over the whole grid and then applied ([`HalfPass`] with one
/// band); the pipeline runs the same half-passes in steps of bands (`terrain::enrich`).
pub fn enrich(sk: &mut Skeleton, params: &EnrichParams, alpha: f64, cell_m: f64) -> usize {
    let n = sk.size;
    let mut enrichment = Enrichment::new(sk, params, alpha, cell_m);
    let mut half = HalfPass::new(false, n, n, 1);
    for _ in 0..params.passes {
        for md in [false, true] {
            half.restart(md);
            while half.step(&mut enrichment) {}
        }
    }
    enrichment.added()
}

/// The state of an enrichment in progress; [`HalfPass`] gathers and applies its half-passes in
/// steps, so a job can yield between them.
///
/// Which cells a half-pass touches is found 64 cells at a time on bit rows (known cells, MDI
/// square centres), so the work per half-pass is O(cells / 64) for the scan plus O(1) per
/// cell it adds or square centre it reads.
pub struct Enrichment<'a> {
    sk: &'a mut Skeleton,
    params: EnrichParams,
    alpha: f64,
    cell_m: f64,
    /// Distance (passes) from the original skeleton; [`FAR`] on cells not known yet.
    dist: Vec<u8>,
    /// Flank side: +1 river, -1 ridge, 0 unknown cells and flanks between both.
    side: Vec<i8>,
    /// Known cells (not [`CellKind::Free`]).
    known: CellBits,
    /// Cells MDI may use as square centres: known, on a flank (side != 0), nearer than L.
    centres: CellBits,
    /// Channel cells (river, valley): fixed from the skeleton on.
    channels: CellBits,
    /// Cells with a channel cell among their 8 neighbours (see the module's "Banks").
    banks: CellBits,
    added: usize,
}

/// The distance of a cell that is not known yet.
const FAR: u8 = u8::MAX;

impl<'a> Enrichment<'a> {
    pub fn new(sk: &'a mut Skeleton, params: &EnrichParams, alpha: f64, cell_m: f64) -> Self {
        let n = sk.size;
        assert!(n <= 1 << 16, "updates hold 16-bit cell coordinates");
        let mut enrichment = Self {
            sk,
            params: *params,
            alpha,
            cell_m,
            dist: vec![FAR; n * n],
            side: vec![0; n * n],
            known: CellBits::new(n),
            centres: CellBits::new(n),
            channels: CellBits::new(n),
            banks: CellBits::new(n),
            added: 0,
        };
        // The per-cell state from the skeleton, in a band of rows per thread.
        let band = n.div_ceil(crate::parallel::threads()).max(1);
        let bands: Vec<_> = (0..n).step_by(band).map(|y| y..(y + band).min(n)).collect();
        let params = *params;
        crate::parallel::for_each_item(enrichment.rows_mut(&bands), |mut rows| {
            rows.fill(&params);
        });
        enrichment.find_banks();
        enrichment
    }

    /// Marks the cells beside a channel cell. O(cells / 64).
    fn find_banks(&mut self) {
        let (n, words) = (self.sk.size, self.known.words);
        for y in 0..n {
            for w in 0..words {
                let mut near = 0;
                for r in y.saturating_sub(1)..(y + 2).min(n) {
                    let row = self.channels.row(r);
                    near |= west(row, w) | row[w] | east(row, w);
                }
                self.banks.bits[y * words + w] = near;
            }
        }
    }

    /// `u` raised to the highest channel cell beside it, if any (the module's "Banks"). Every
    /// update is at least one cell inside the map, so its 3 x 3 neighbourhood is too.
    #[inline(always)]
    fn above_banks(&self, mut u: Update) -> Update {
        let (x, y) = (usize::from(u.x), usize::from(u.y));
        if bit(self.banks.row(y), x) == 0 {
            return u;
        }
        let n = self.sk.size;
        for r in y - 1..y + 2 {
            let mut near = three_bits(self.channels.row(r), x - 1);
            while near != 0 {
                let c = x - 1 + near.trailing_zeros() as usize;
                near &= near - 1;
                u.height = u.height.max(self.sk.heights[r * n + c]);
            }
        }
        u
    }

    /// Cells added so far.
    pub fn added(&self) -> usize {
        self.added
    }

    /// MDI: an unknown cell is a corner of the 3 x 3 squares centred on its known diagonal
    /// neighbours; it takes the mean of those squares' interpolations. Writes the updates of
    /// the rows `rows` into `updates` (cleared first, so a caller can reuse the buffer),
    /// computed from the state before the half-pass: nothing changes until
    /// [`Self::apply_bands`], so the result does not depend on visiting order.
    ///
    /// Each square centre's interpolation (the mean of its known cells plus the flank
    /// displacement) is computed once and shared by the up to four corners that read it:
    /// rows of centres are kept in a ring of three, since the corners of row `y` read the
    /// centres of rows `y - 1` and `y + 1`.
    pub fn mdi_updates_into(&self, rows: Range<usize>, updates: &mut Vec<Update>) {
        let n = self.sk.size;
        updates.clear();
        if n < 5 {
            return;
        }
        let (inside, centre_inside) = (interior_mask(n, 2), interior_mask(n, 1));
        let mut ring: [CentreRow; 3] = std::array::from_fn(|_| CentreRow::new(n));
        for y in rows.start.max(2)..rows.end.min(n - 2) {
            for r in [y - 1, y + 1] {
                if ring[r % 3].row != r {
                    self.centre_row(r, &centre_inside, &mut ring[r % 3]);
                }
            }
            let (above, below) = (&ring[(y - 1) % 3], &ring[(y + 1) % 3]);
            let known = self.known.row(y);
            for w in 0..known.len() {
                let reached = west(&above.bits, w)
                    | east(&above.bits, w)
                    | west(&below.bits, w)
                    | east(&below.bits, w);
                let mut corners = reached & !known[w] & inside[w];
                while corners != 0 {
                    let x = w * 64 + corners.trailing_zeros() as usize;
                    corners &= corners - 1;
                    // Branch-free (which diagonals are centres is unpredictable): entries of
                    // cells that are not centres are finite and weighted by 0.
                    let (mut total, mut count, mut sides, mut d) = (0.0f64, 0u32, 0i32, FAR);
                    for (row, cx) in [
                        (above, x - 1),
                        (above, x + 1),
                        (below, x - 1),
                        (below, x + 1),
                    ] {
                        let centre = bit(&row.bits, cx);
                        total += f64::from(centre) * row.value[cx];
                        count += centre;
                        sides += centre as i32 * i32::from(row.side[cx]);
                        d = d.min(if centre == 1 { row.dist[cx] } else { FAR });
                    }
                    updates.push(self.above_banks(Update::mean(x, y, total, count, sides, d)));
                }
            }
        }
    }

    /// The square centres of row `r` that MDI reads (those with an unknown diagonal
    /// neighbour). Their value is the mean of the known cells of their 3 x 3 square plus
    /// `side * alpha * d`, `d` the diagonal in metres (Fig. 5b).
    fn centre_row(&self, r: usize, inside: &[u64], out: &mut CentreRow) {
        let (sk, n) = (&*self.sk, self.sk.size);
        let diagonal_m = std::f64::consts::SQRT_2 * self.cell_m;
        let (up, down, centres) = (
            self.known.row(r - 1),
            self.known.row(r + 1),
            self.centres.row(r),
        );
        out.row = r;
        // A square's sum column by column, (col[x - 1] + col[x]) + col[x + 1]; unknown cells
        // hold 0 m (`Enrichment::new`), so only the count skips them.
        let rows = |dy: usize| (r + dy - 1) * n..(r + dy) * n;
        let (h0, h1, h2) = (
            &sk.heights[rows(0)],
            &sk.heights[rows(1)],
            &sk.heights[rows(2)],
        );
        let (k0, k1, k2) = (&sk.kinds[rows(0)], &sk.kinds[rows(1)], &sk.kinds[rows(2)]);
        let column = |x: usize| (f64::from(h0[x]) + f64::from(h1[x])) + f64::from(h2[x]);
        let known = |x: usize| {
            u32::from(k0[x] != CellKind::Free)
                + u32::from(k1[x] != CellKind::Free)
                + u32::from(k2[x] != CellKind::Free)
        };
        for w in 0..centres.len() {
            let free_diagonal = !(west(up, w) & east(up, w) & west(down, w) & east(down, w));
            out.bits[w] = centres[w] & free_diagonal & inside[w];
            let mut bits = out.bits[w];
            while bits != 0 {
                let x = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let c = r * n + x;
                let total = (column(x - 1) + column(x)) + column(x + 1);
                let count = known(x - 1) + known(x) + known(x + 1);
                let s = self.side[c];
                out.value[x] = total / f64::from(count) + f64::from(s) * self.alpha * diagonal_m;
                out.side[x] = s;
                out.dist[x] = self.dist[c] + 1;
            }
        }
    }

    /// MD: midpoints between two known neighbours and centres between four known corners.
    /// Writes the updates of the rows `rows` into `updates` as
    /// [`Self::mdi_updates_into`] does.
    pub fn md_updates_into(&self, rows: Range<usize>, updates: &mut Vec<Update>) {
        let (sk, n) = (&*self.sk, self.sk.size);
        let params = &self.params;
        let (axis, diagonal) = (params.md_pair(false), params.md_pair(true));
        updates.clear();
        if n < 3 {
            return;
        }
        let inside = interior_mask(n, 1);
        let known = |i: usize| sk.kinds[i] != CellKind::Free;
        for y in rows.start.max(1)..rows.end.min(n - 1) {
            let (up, mid, down) = (
                self.known.row(y - 1),
                self.known.row(y),
                self.known.row(y + 1),
            );
            for w in 0..mid.len() {
                let between = (west(mid, w) & east(mid, w))
                    | (up[w] & down[w])
                    | (west(up, w) & east(down, w))
                    | (east(up, w) & west(down, w));
                let mut midpoints = between & !mid[w] & inside[w];
                while midpoints != 0 {
                    let x = w * 64 + midpoints.trailing_zeros() as usize;
                    midpoints &= midpoints - 1;
                    let f = y * n + x;
                    let pairs = [
                        (f - 1, f + 1, axis),
                        (f - n, f + n, axis),
                        (f - n - 1, f + n + 1, diagonal),
                        (f - n + 1, f + n - 1, diagonal),
                    ];
                    let (mut total, mut count, mut sides, mut d) = (0.0f64, 0u32, 0i32, FAR);
                    // Branch-free: a pair with an unknown end (or farther apart than the
                    // rule allows) is weighted by 0.
                    for (a, b, allowed) in pairs {
                        let both = u32::from(known(a) & known(b)) & allowed;
                        total +=
                            f64::from(both) * (f64::from(sk.heights[a]) + f64::from(sk.heights[b]));
                        count += 2 * both;
                        sides += both as i32 * (i32::from(self.side[a]) + i32::from(self.side[b]));
                        let far = self.dist[a].max(self.dist[b]);
                        d = d.min(if both == 1 { far } else { FAR });
                    }
                    if count > 0 && params.reaches(d, false) {
                        updates.push(self.above_banks(Update::mean(x, y, total, count, sides, d)));
                    }
                }
            }
        }
    }

    /// Applies the updates `parts[k]` of the rows `bands[k]` (ascending, disjoint), on all
    /// threads natively.
    pub fn apply_bands(&mut self, bands: &[Range<usize>], parts: &[Vec<Update>]) {
        let params = self.params;
        let items: Vec<_> = self.rows_mut(bands).into_iter().zip(parts).collect();
        crate::parallel::for_each_item(items, |(mut rows, updates)| {
            rows.apply(updates, &params);
        });
        self.added += parts.iter().map(Vec::len).sum::<usize>();
    }

    /// The state of the rows of each of `bands` (ascending, disjoint), to write in parallel.
    fn rows_mut(&mut self, bands: &[Range<usize>]) -> Vec<Rows<'_>> {
        let (n, words) = (self.sk.size, self.known.words);
        let Skeleton { heights, kinds, .. } = &mut *self.sk;
        let mut heights = split_rows(heights, n, bands).into_iter();
        let mut kinds = split_rows(kinds, n, bands).into_iter();
        let mut side = split_rows(&mut self.side, n, bands).into_iter();
        let mut dist = split_rows(&mut self.dist, n, bands).into_iter();
        let mut known = split_rows(&mut self.known.bits, words, bands).into_iter();
        let mut centres = split_rows(&mut self.centres.bits, words, bands).into_iter();
        let mut channels = split_rows(&mut self.channels.bits, words, bands).into_iter();
        bands
            .iter()
            .filter_map(|band| {
                Some(Rows {
                    n,
                    words,
                    first_row: band.start,
                    heights: heights.next()?,
                    kinds: kinds.next()?,
                    side: side.next()?,
                    dist: dist.next()?,
                    known: known.next()?,
                    centres: centres.next()?,
                    channels: channels.next()?,
                })
            })
            .collect()
    }
}

/// The per-cell state of a band of rows ([`Enrichment::rows_mut`]).
struct Rows<'s> {
    n: usize,
    words: usize,
    first_row: usize,
    heights: &'s mut [f32],
    kinds: &'s mut [CellKind],
    side: &'s mut [i8],
    dist: &'s mut [u8],
    known: &'s mut [u64],
    centres: &'s mut [u64],
    channels: &'s mut [u64],
}

impl Rows<'_> {
    /// The state of a fresh skeleton: unknown cells hold 0 m (so a square's sum may add all
    /// nine cells, `centre_row`), skeleton cells are at distance 0 on their flank.
    fn fill(&mut self, params: &EnrichParams) {
        for (h, k) in self.heights.iter_mut().zip(self.kinds.iter()) {
            *h = if *k == CellKind::Free { 0.0 } else { *h };
        }
        for ((k, d), s) in self
            .kinds
            .iter()
            .zip(self.dist.iter_mut())
            .zip(self.side.iter_mut())
        {
            *d = if *k == CellKind::Free { FAR } else { 0 };
            *s = match k {
                CellKind::River | CellKind::Valley => 1,
                CellKind::Ridge => -1,
                _ => 0,
            };
        }
        let (n, words) = (self.n, self.words);
        for (y, (kinds, sides)) in self.kinds.chunks(n).zip(self.side.chunks(n)).enumerate() {
            let row = y * words..(y + 1) * words;
            fill_bits(&mut self.known[row.clone()], kinds, |k| {
                *k != CellKind::Free
            });
            fill_bits(&mut self.channels[row.clone()], kinds, |k| {
                matches!(k, CellKind::River | CellKind::Valley)
            });
            fill_bits(&mut self.centres[row], sides, |s| {
                *s != 0 && params.reaches(0, true)
            });
        }
    }

    /// Writes `updates` (all in these rows).
    fn apply(&mut self, updates: &[Update], params: &EnrichParams) {
        for u in updates {
            let (x, y) = (usize::from(u.x), usize::from(u.y) - self.first_row);
            let i = y * self.n + x;
            self.heights[i] = u.height;
            self.kinds[i] = CellKind::Enriched;
            self.side[i] = u.side;
            self.dist[i] = u.dist;
            let (w, b) = (y * self.words + x / 64, x % 64);
            self.known[w] |= 1 << b;
            if u.side != 0 && params.reaches(u.dist, true) {
                self.centres[w] |= 1 << b;
            }
        }
    }
}

/// The slices of `data` (rows of `width` items) holding the rows of each of `bands`
/// (ascending, disjoint).
fn split_rows<'d, T>(data: &'d mut [T], width: usize, bands: &[Range<usize>]) -> Vec<&'d mut [T]> {
    let (mut rest, mut row) = (data, 0);
    let mut slices = Vec::with_capacity(bands.len());
    for band in bands {
        let (_, tail) = std::mem::take(&mut rest).split_at_mut((band.start - row) * width);
        let (slice, tail) = tail.split_at_mut(band.len() * width);
        slices.push(slice);
        (rest, row) = (tail, band.end);
    }
    slices
}

/// Sets the bits of `words` where `is_set` holds for the cells (64 per word).
fn fill_bits<T>(words: &mut [u64], cells: &[T], is_set: impl Fn(&T) -> bool) {
    for (word, chunk) in words.iter_mut().zip(cells.chunks(64)) {
        *word = chunk
            .iter()
            .enumerate()
            .fold(0, |bits, (b, c)| bits | u64::from(is_set(c)) << b);
    }
}

/// One bit per cell of an `n` x `n` grid, each row padded to whole 64-bit words.
struct CellBits {
    words: usize,
    bits: Vec<u64>,
}

impl CellBits {
    fn new(n: usize) -> Self {
        let words = n.div_ceil(64);
        Self {
            words,
            bits: vec![0; words * n],
        }
    }

    fn row(&self, y: usize) -> &[u64] {
        &self.bits[y * self.words..(y + 1) * self.words]
    }
}

/// Word `w` of `row` moved one cell east: bit x holds the cell at x - 1 (its west neighbour).
fn west(row: &[u64], w: usize) -> u64 {
    (row[w] << 1) | if w > 0 { row[w - 1] >> 63 } else { 0 }
}

/// Word `w` of `row` moved one cell west: bit x holds the cell at x + 1 (its east neighbour).
fn east(row: &[u64], w: usize) -> u64 {
    (row[w] >> 1) | row.get(w + 1).map_or(0, |next| next << 63)
}

/// The bits of columns `margin..n - margin` of a row.
fn interior_mask(n: usize, margin: usize) -> Vec<u64> {
    let mut mask = vec![0u64; n.div_ceil(64)];
    for x in margin..n.saturating_sub(margin) {
        mask[x / 64] |= 1 << (x % 64);
    }
    mask
}

/// One row of MDI square centres ([`Enrichment::centre_row`]): which cells are centres
/// (`bits`), their interpolated value, side and the distance a corner they fill gets (theirs
/// + 1); only the entries of centres are meaningful.
struct CentreRow {
    row: usize,
    bits: Vec<u64>,
    value: Vec<f64>,
    side: Vec<i8>,
    dist: Vec<u8>,
}

impl CentreRow {
    fn new(n: usize) -> Self {
        Self {
            row: usize::MAX,
            bits: vec![0; n.div_ceil(64)],
            value: vec![0.0; n],
            side: vec![0; n],
            dist: vec![FAR; n],
        }
    }
}

/// Bits `x .. x + 3` of a bit row (those past its end as 0), as the low bits of a word.
#[inline]
fn three_bits(row: &[u64], x: usize) -> u64 {
    let (w, b) = (x / 64, x % 64);
    let mut bits = row[w] >> b;
    if b > 61
        && let Some(next) = row.get(w + 1)
    {
        bits |= next << (64 - b);
    }
    bits & 0b111
}

/// Bit `x` of a bit row, as 0 or 1.
fn bit(row: &[u64], x: usize) -> u32 {
    (row[x / 64] >> (x % 64) & 1) as u32
}

/// One half-pass (MDI or MD) in steps, so a job can yield between them and only a few bands'
/// updates are held at a time.
///
/// Each step gathers the next `per_step` bands of rows (on all threads natively, one band per
/// thread) and then applies the updates of the step before. That is the same as applying the
/// whole half-pass at once: a band's gather reads at most two rows beyond its own (MDI:
/// corner, square centre, square), and bands are at least three rows high, so the rows a step
/// applies are never read by a later step's gather.
pub struct HalfPass {
    md: bool,
    bands: Vec<Range<usize>>,
    per_step: usize,
    next: usize,
    /// Buffers of the step being gathered and of the step waiting to be applied (its first
    /// `waiting_len` buffers).
    gathered: Vec<Vec<Update>>,
    waiting: Vec<Vec<Update>>,
    waiting_len: usize,
}

impl HalfPass {
    /// An MDI (`md` false) or MD half-pass over `rows` rows in bands of `band_rows` (at least
    /// three), `per_step` bands per step.
    pub fn new(md: bool, rows: usize, band_rows: usize, per_step: usize) -> Self {
        let band_rows = band_rows.max(3);
        let per_step = per_step.max(1);
        Self {
            md,
            bands: (0..rows)
                .step_by(band_rows)
                .map(|start| start..(start + band_rows).min(rows))
                .collect(),
            per_step,
            next: 0,
            gathered: vec![Vec::new(); per_step],
            waiting: vec![Vec::new(); per_step],
            waiting_len: 0,
        }
    }

    /// Starts over as an MDI (`md` false) or MD half-pass, keeping the buffers.
    pub fn restart(&mut self, md: bool) {
        self.md = md;
        self.next = 0;
        self.waiting_len = 0;
    }

    /// Gathers the next bands and applies the step before's. Returns false once the whole
    /// half-pass is applied.
    pub fn step(&mut self, enrichment: &mut Enrichment<'_>) -> bool {
        let start = self.next.min(self.bands.len());
        let group = &self.bands[start..(start + self.per_step).min(self.bands.len())];
        if !group.is_empty() {
            let items: Vec<_> = group
                .iter()
                .cloned()
                .zip(self.gathered.iter_mut())
                .collect();
            let gather = &*enrichment;
            let md = self.md;
            crate::parallel::for_each_item(items, |(rows, out)| {
                if md {
                    gather.md_updates_into(rows, out);
                } else {
                    gather.mdi_updates_into(rows, out);
                }
            });
        }
        let previous = start.saturating_sub(self.waiting_len)..start;
        enrichment.apply_bands(&self.bands[previous], &self.waiting[..self.waiting_len]);
        std::mem::swap(&mut self.gathered, &mut self.waiting);
        self.waiting_len = group.len();
        self.next += group.len();
        self.waiting_len > 0
    }
}

/// One added cell: its column and row (grids are at most 8192 cells wide), height, flank
/// side, distance (passes) from the skeleton.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Update {
    pub x: u16,
    pub y: u16,
    pub height: f32,
    pub side: i8,
    pub dist: u8,
}

impl Update {
    /// Cell `(x, y)` at the mean `total / count` of what it is interpolated from, on the side
    /// the summed flank sides lean to, at distance `dist`.
    fn mean(x: usize, y: usize, total: f64, count: u32, sides: i32, dist: u8) -> Self {
        Self {
            x: x as u16,
            y: y as u16,
            height: (total / f64::from(count)) as f32,
            side: sides.signum() as i8,
            dist,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_skeleton(kind: CellKind, height: f32) -> Skeleton {
        let n = 21;
        let mut sk = Skeleton::empty(n);
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
                ..EnrichParams::default()
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

    /// A tributary two cells from a main stream 30 m lower: the squares between them mix both,
    /// but no added cell may sit below a river cell beside it, or the tributary would drain
    /// sideways into its flank.
    #[test]
    fn flanks_never_sink_below_the_river_beside_them() {
        let n = 21;
        let mut sk = Skeleton::empty(n);
        for x in 0..n {
            for (y, base) in [(8, 40.0), (11, 10.0)] {
                sk.kinds[y * n + x] = CellKind::River;
                sk.heights[y * n + x] = base + 0.1 * x as f32;
            }
        }
        let rivers = sk.clone();
        let added = enrich(&mut sk, &EnrichParams::default(), 0.1, 10.0);
        assert!(added > 0);
        let mut beside_tributary = 0;
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let i = y * n + x;
                if sk.kinds[i] != CellKind::Enriched {
                    continue;
                }
                for j in [
                    i - n - 1,
                    i - n,
                    i - n + 1,
                    i - 1,
                    i + 1,
                    i + n - 1,
                    i + n,
                    i + n + 1,
                ] {
                    if rivers.kinds[j] == CellKind::River {
                        assert!(
                            sk.heights[i] >= rivers.heights[j],
                            "cell ({x}, {y}) at {} below the river beside it at {}",
                            sk.heights[i],
                            rivers.heights[j]
                        );
                        beside_tributary += usize::from(j / n == 8 && y > 8);
                    }
                }
            }
        }
        // The cells between the rivers were enriched (the case the rule is for).
        assert!(beside_tributary > 20, "{beside_tributary}");
    }

    /// The half-passes as the paper states them, one cell at a time, with each square's mean
    /// computed for every corner that reads it (the reference for the row-wise version).
    fn reference(sk: &mut Skeleton, params: &EnrichParams, alpha: f64, cell_m: f64) {
        let n = sk.size;
        let mut dist: Vec<u32> = sk
            .kinds
            .iter()
            .map(|k| if *k == CellKind::Free { u32::MAX } else { 0 })
            .collect();
        let mut side: Vec<i8> = sk
            .kinds
            .iter()
            .map(|k| match k {
                CellKind::River | CellKind::Valley => 1,
                CellKind::Ridge => -1,
                _ => 0,
            })
            .collect();
        let diagonal_m = std::f64::consts::SQRT_2 * cell_m;
        for _ in 0..params.passes {
            for md in [false, true] {
                let known = |i: usize| sk.kinds[i] != CellKind::Free;
                // Summed column by column, as the row-wise code does, so that the two agree
                // bit for bit.
                let square_mean = |c: usize| {
                    let (mut columns, mut count) = ([0.0f64; 3], 0u32);
                    for (column, j) in columns.iter_mut().zip(c - 1..c + 2) {
                        for i in [j - n, j, j + n] {
                            if known(i) {
                                *column += f64::from(sk.heights[i]);
                                count += 1;
                            }
                        }
                    }
                    ((columns[0] + columns[1]) + columns[2]) / f64::from(count)
                };
                let mut updates = Vec::new();
                // MDI corners keep two cells from the border (their squares inside), MD
                // midpoints one.
                let (lo, hi) = if md { (1, n - 1) } else { (2, n - 2) };
                for y in lo..hi {
                    for x in lo..hi {
                        let k = y * n + x;
                        if known(k) {
                            continue;
                        }
                        let (mut total, mut count, mut sides, mut d) = (0.0, 0u32, 0i32, u32::MAX);
                        if md {
                            // Squared lengths of the pairs, in cells.
                            for (a, b, len2) in [
                                (k - 1, k + 1, 4),
                                (k - n, k + n, 4),
                                (k - n - 1, k + n + 1, 8),
                                (k - n + 1, k + n - 1, 8),
                            ] {
                                let near = params.rule == DistanceRule::Skeleton
                                    || params.distance_limit.pow(2) >= len2;
                                if known(a) && known(b) && near {
                                    total += f64::from(sk.heights[a]) + f64::from(sk.heights[b]);
                                    count += 2;
                                    sides += i32::from(side[a]) + i32::from(side[b]);
                                    d = d.min(dist[a].max(dist[b]));
                                }
                            }
                            if count == 0
                                || (params.rule == DistanceRule::Skeleton
                                    && d > params.distance_limit)
                            {
                                continue;
                            }
                        } else {
                            for c in [k - n - 1, k - n + 1, k + n - 1, k + n + 1] {
                                let near = match params.rule {
                                    DistanceRule::Skeleton => dist[c] < params.distance_limit,
                                    // The corner is sqrt 2 cells from the centre.
                                    DistanceRule::Points => params.distance_limit.pow(2) >= 2,
                                };
                                if known(c) && side[c] != 0 && near {
                                    total +=
                                        square_mean(c) + f64::from(side[c]) * alpha * diagonal_m;
                                    count += 1;
                                    sides += i32::from(side[c]);
                                    d = d.min(dist[c] + 1);
                                }
                            }
                        }
                        if count > 0 {
                            // Banks: not below a channel cell beside it.
                            let mut h = (total / f64::from(count)) as f32;
                            for j in [
                                k - n - 1,
                                k - n,
                                k - n + 1,
                                k - 1,
                                k + 1,
                                k + n - 1,
                                k + n,
                                k + n + 1,
                            ] {
                                if matches!(sk.kinds[j], CellKind::River | CellKind::Valley) {
                                    h = h.max(sk.heights[j]);
                                }
                            }
                            updates.push((k, h, sides.signum(), d));
                        }
                    }
                }
                for (k, h, s, d) in updates {
                    sk.heights[k] = h;
                    sk.kinds[k] = CellKind::Enriched;
                    side[k] = s as i8;
                    dist[k] = d;
                }
            }
        }
    }

    #[test]
    fn row_wise_half_passes_equal_the_cell_by_cell_reference_bit_for_bit() {
        // Crossing rivers and ridges at every angle, with varied heights, on a grid small
        // enough for the reference.
        let n = 67;
        let mut sk = Skeleton::empty(n);
        let mut state = 7u64;
        let mut next = |m: i64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) % m as u64) as i64
        };
        for line in 0..24 {
            let kind = if line % 3 == 0 {
                CellKind::River
            } else {
                CellKind::Ridge
            };
            let (a, b) = ((next(67), next(67)), (next(67), next(67)));
            let base = next(500) as f32;
            crate::skeleton::bresenham(a, b, |x, y| {
                let i = y as usize * n + x as usize;
                sk.kinds[i] = kind;
                sk.heights[i] = base + (x * 3 + y) as f32 * 0.37;
            });
        }
        let (skeleton, points) = (DistanceRule::Skeleton, DistanceRule::Points);
        for (passes, distance_limit, rule) in [
            (1, 3, skeleton),
            (2, 3, skeleton),
            (3, 2, skeleton),
            (4, 6, skeleton),
            (3, 2, points),
            (4, 3, points),
        ] {
            let params = EnrichParams {
                passes,
                distance_limit,
                rule,
            };
            let mut expected = sk.clone();
            reference(&mut expected, &params, 0.13, 7.5);
            let mut got = sk.clone();
            let mut enrichment = Enrichment::new(&mut got, &params, 0.13, 7.5);
            for _ in 0..passes {
                // In steps of two bands of three rows (the smallest), as the pipeline runs
                // them.
                for md in [false, true] {
                    let mut half = HalfPass::new(md, n, 3, 2);
                    while half.step(&mut enrichment) {}
                }
            }
            assert!(enrichment.added() > 500, "{}", enrichment.added());
            assert_eq!(
                got.kinds, expected.kinds,
                "passes {passes} L {distance_limit} {rule:?}"
            );
            let bits = |s: &Skeleton| s.heights.iter().map(|h| h.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&got),
                bits(&expected),
                "passes {passes} L {distance_limit} {rule:?}"
            );
        }
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
                    ..EnrichParams::default()
                },
                0.1,
                1.0
            ),
            0
        );
        assert_eq!(sk.heights, before);
    }

    /// The two readings of L on a straight river: the skeleton rule stops the flanks L cells
    /// from the line whatever the passes; the paper's rule (points at most L apart) limits
    /// nothing on 3 x 3 squares once L >= 3, so the passes alone set the reach; with L = 1
    /// no stencil's points are that close and nothing is added.
    #[test]
    fn the_distance_limit_bounds_the_flanks_by_the_chosen_rule() {
        let reach = |passes: u32, distance_limit: u32, rule: DistanceRule| {
            let mut sk = line_skeleton(CellKind::River, 10.0);
            let params = EnrichParams {
                passes,
                distance_limit,
                rule,
            };
            enrich(&mut sk, &params, 0.1, 10.0);
            let n = sk.size;
            (0..n * n)
                .filter(|&i| sk.kinds[i] == CellKind::Enriched)
                .map(|i| (i / n).abs_diff(10))
                .max()
                .unwrap_or(0)
        };
        assert_eq!(reach(6, 3, DistanceRule::Skeleton), 3);
        assert_eq!(reach(2, 3, DistanceRule::Skeleton), 2);
        assert_eq!(reach(6, 3, DistanceRule::Points), 6);
        assert_eq!(reach(6, 1, DistanceRule::Points), 0);
    }
}
