//! Grid geometry: row-major indexing and the D8 neighbourhood.

/// D8 neighbour offsets `(dx, dy)` in row-major scan order.
/// Indices 0, 2, 5 and 7 are the diagonals.
pub(super) const D8: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Distance to each D8 neighbour in cell units (1 or sqrt 2).
pub(super) const D8_DIST: [f64; 8] = [
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
];

/// The 4-neighbourhood (used by the diffusion stencil).
pub(super) const D4: [(isize, isize); 4] = [(0, -1), (-1, 0), (1, 0), (0, 1)];

/// A `width` x `height` row-major grid with square cells of `cell` metres.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) cell: f64,
}

impl Grid {
    pub(super) fn len(self) -> usize {
        self.width * self.height
    }

    pub(super) fn xy(self, i: usize) -> (usize, usize) {
        (i % self.width, i / self.width)
    }

    /// Index of the cell at `(x + dx, y + dy)`, or `None` outside the grid.
    #[inline]
    pub(super) fn offset(self, x: usize, y: usize, (dx, dy): (isize, isize)) -> Option<usize> {
        let nx = x.wrapping_add_signed(dx);
        let ny = y.wrapping_add_signed(dy);
        if nx < self.width && ny < self.height {
            Some(ny * self.width + nx)
        } else {
            None
        }
    }

    /// Index of D8 neighbour `d` of `(x, y)`, or `None` outside the grid.
    #[inline]
    pub(super) fn neighbour(self, x: usize, y: usize, d: usize) -> Option<usize> {
        self.offset(x, y, D8[d])
    }

    /// D8 direction index of the step from cell `from` to its neighbour `to`.
    pub(super) fn direction(self, from: usize, to: usize) -> usize {
        let (fx, fy) = self.xy(from);
        let (tx, ty) = self.xy(to);
        let dx = tx as isize - fx as isize;
        let dy = ty as isize - fy as isize;
        let k = ((dy + 1) * 3 + (dx + 1)) as usize;
        // Row-major 3x3 index without the centre (4).
        if k < 4 { k } else { k - 1 }
    }

    /// Distance in metres between cell `i` and its D8 neighbour `j`.
    pub(super) fn distance(self, i: usize, j: usize) -> f64 {
        let diagonal = i % self.width != j % self.width && i / self.width != j / self.width;
        if diagonal {
            self.cell * std::f64::consts::SQRT_2
        } else {
            self.cell
        }
    }
}
