//! Tiles of one heightmap for engines that stream a world in pieces (Unreal World
//! Partition's tiled Landscape import, Unity terrain groups): `columns x rows` tiles of
//! `side` vertices that share their edge rows and columns, so a tile's last column is,
//! bit for bit, its east neighbour's first, and a map of `columns * (side - 1) + 1`
//! vertices a side is split exactly. Named `_x{column}_y{row}` as Unreal's tiled import
//! expects ("World Partition - Importing Landscapes": "filename_x0_y0.png").

use crate::heightfield::Heightfield;

/// How a map is cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileGrid {
    pub columns: usize,
    pub rows: usize,
    /// Vertices a side of every tile.
    pub side_x: usize,
    pub side_y: usize,
}

impl TileGrid {
    /// The grid of `columns x rows` tiles over a `width x height` map, when the map's quads
    /// divide evenly (each tile at least 2 vertices a side).
    pub fn plan(width: usize, height: usize, columns: usize, rows: usize) -> Result<Self, String> {
        if columns == 0 || rows == 0 || columns > 64 || rows > 64 {
            return Err(format!(
                "{columns} x {rows} tiles: give 1 to 64 tiles each way"
            ));
        }
        let divides = |n: usize, k: usize| n > 1 && (n - 1).is_multiple_of(k) && (n - 1) / k >= 1;
        if !divides(width, columns) || !divides(height, rows) {
            let fits = |n: usize| -> String {
                (1..=16)
                    .filter(|&k| divides(n, k))
                    .map(|k| k.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(format!(
                "a {width} x {height} map does not split into {columns} x {rows} tiles that \
                 share their edges ({} quads must divide evenly); tiles across that fit: {}",
                width.saturating_sub(1),
                fits(width)
            ));
        }
        Ok(TileGrid {
            columns,
            rows,
            side_x: (width - 1) / columns + 1,
            side_y: (height - 1) / rows + 1,
        })
    }

    /// The tile at `(column, row)`: its first vertex in the map.
    pub fn origin(&self, column: usize, row: usize) -> (usize, usize) {
        (column * (self.side_x - 1), row * (self.side_y - 1))
    }

    /// The name suffix of a tile.
    pub fn suffix(column: usize, row: usize) -> String {
        format!("_x{column}_y{row}")
    }

    /// Every tile of `field` with its column and row, row by row.
    pub fn split(&self, field: &Heightfield) -> Vec<(usize, usize, Heightfield)> {
        let w = field.width();
        let mut tiles = Vec::with_capacity(self.columns * self.rows);
        for row in 0..self.rows {
            for column in 0..self.columns {
                let (x0, y0) = self.origin(column, row);
                let data: Vec<f32> = (y0..y0 + self.side_y)
                    .flat_map(|y| field.data()[y * w + x0..y * w + x0 + self.side_x].iter())
                    .copied()
                    .collect();
                let tile = Heightfield::from_vec(self.side_x, self.side_y, data)
                    .expect("a tile has cells");
                tiles.push((column, row, tile));
            }
        }
        tiles
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_share_edges_and_reassemble_the_map() {
        let (w, h) = (13, 9);
        let data: Vec<f32> = (0..w * h).map(|i| (i as f32 * 0.77).sin()).collect();
        let field = Heightfield::from_vec(w, h, data).unwrap();
        let grid = TileGrid::plan(w, h, 3, 2).unwrap();
        assert_eq!((grid.side_x, grid.side_y), (5, 5));
        let tiles = grid.split(&field);
        let mut back = vec![f32::NAN; w * h];
        for (c, r, tile) in &tiles {
            let (x0, y0) = grid.origin(*c, *r);
            for y in 0..tile.height() {
                for x in 0..tile.width() {
                    let i = (y0 + y) * w + x0 + x;
                    let v = tile.get(x, y).unwrap();
                    // Where tiles overlap they hold the same bits.
                    assert!(back[i].is_nan() || back[i].to_bits() == v.to_bits());
                    back[i] = v;
                }
            }
        }
        assert_eq!(back, field.data());
        let err = TileGrid::plan(1024, 1024, 2, 2).unwrap_err();
        assert!(err.contains("1023 quads"), "{err}");
        assert!(TileGrid::plan(4033, 4033, 4, 4).is_ok());
        assert_eq!(TileGrid::suffix(2, 0), "_x2_y0");
    }
}
