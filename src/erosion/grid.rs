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

    /// Index offsets of the D8 neighbours (valid for cells not on the map edge).
    pub(super) fn offsets(self) -> [isize; 8] {
        D8.map(|(dx, dy)| dy * self.width as isize + dx)
    }

    /// Whether `(x, y)` is off the map edge, so that all eight neighbours exist.
    #[inline]
    pub(super) fn interior(self, x: usize, y: usize) -> bool {
        x > 0 && y > 0 && x + 1 < self.width && y + 1 < self.height
    }
}
