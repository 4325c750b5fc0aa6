//! Wavefront OBJ meshes of a height field, for Blender and other 3D tools: one vertex per
//! cell (`v x y z` with Y up, x east, z south, in metres), texture coordinates (`vt`), and
//! two triangles per grid square (counter-clockwise seen from above). Squares touching a
//! no-data cell are left out. O(cells) in time and output (~40 bytes per vertex), so the
//! size is capped at [`MAX_VERTICES`]; larger maps export at a smaller size preset.

use std::fmt::Write as _;

use super::DemError;
use crate::heightfield::Heightfield;

/// 2049^2: a ~200 MB text file.
pub const MAX_VERTICES: u64 = 2049 * 2049;

/// Writes the mesh; `cell_size` is the horizontal spacing in metres.
pub fn write(field: &Heightfield, cell_size: f64) -> Result<Vec<u8>, DemError> {
    crate::jobs::run_inline(|ctx| async move { write_in(field, cell_size, &ctx).await })
}

/// [`write`] in a job: a tick after each row of vertices, of texture coordinates and of
/// faces.
pub async fn write_in(
    field: &Heightfield,
    cell_size: f64,
    ctx: &crate::jobs::JobCtx,
) -> Result<Vec<u8>, DemError> {
    let (w, h) = (field.width(), field.height());
    if (w as u64) * (h as u64) > MAX_VERTICES {
        return Err(DemError::Write(format!(
            "an OBJ mesh of {w} x {h} vertices is too large; export at 2049 x 2049 or smaller"
        )));
    }
    if !(cell_size.is_finite() && cell_size > 0.0) {
        return Err(DemError::Write(format!(
            "an OBJ mesh needs a positive, finite cell size, got {cell_size}"
        )));
    }
    if w < 2 || h < 2 {
        return Err(DemError::Write(
            "an OBJ mesh needs at least 2 x 2 cells".into(),
        ));
    }
    let mut out = String::with_capacity(w * h * 60);
    let _ = writeln!(
        out,
        "# Strahler heightmap, {w} x {h} vertices, {cell_size} m apart"
    );
    let _ = writeln!(out, "o terrain");
    let tick = |row: usize| async move {
        ctx.tick_of(row, 3 * h, "writing the OBJ mesh")
            .await
            .map_err(|_| DemError::Cancelled)
    };
    for (i, &z) in field.data().iter().enumerate() {
        let (x, y) = (i % w, i / w);
        if x == 0 {
            tick(y).await?;
        }
        let z = if z.is_finite() { z } else { 0.0 };
        let _ = writeln!(
            out,
            "v {} {} {}",
            x as f64 * cell_size,
            z,
            y as f64 * cell_size
        );
    }
    for i in 0..w * h {
        let (x, y) = (i % w, i / w);
        if x == 0 {
            tick(h + y).await?;
        }
        let _ = writeln!(
            out,
            "vt {} {}",
            x as f64 / (w - 1) as f64,
            1.0 - y as f64 / (h - 1) as f64
        );
    }
    let ok = |i: usize| field.data()[i].is_finite();
    for y in 0..h - 1 {
        tick(2 * h + y).await?;
        for x in 0..w - 1 {
            let a = y * w + x;
            let (b, c, d) = (a + 1, a + w, a + w + 1);
            if !(ok(a) && ok(b) && ok(c) && ok(d)) {
                continue;
            }
            // OBJ indices are 1-based; seen from +Y (above) with z pointing south these
            // triangles wind counter-clockwise, so their normals point up.
            let (a, b, c, d) = (a + 1, b + 1, c + 1, d + 1);
            let _ = writeln!(out, "f {a}/{a} {c}/{c} {b}/{b}");
            let _ = writeln!(out, "f {b}/{b} {c}/{c} {d}/{d}");
        }
    }
    Ok(out.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertices_carry_the_heights_and_faces_point_up() {
        let field = Heightfield::from_vec(3, 2, vec![1.0, 2.5, 3.0, 4.0, f32::NAN, 6.0]).unwrap();
        let text = String::from_utf8(write(&field, 10.0).unwrap()).unwrap();
        let verts: Vec<[f64; 3]> = text
            .lines()
            .filter(|l| l.starts_with("v "))
            .map(|l| {
                let v: Vec<f64> = l[2..].split(' ').map(|t| t.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        assert_eq!(verts.len(), 6);
        assert_eq!(verts[1], [10.0, 2.5, 0.0]);
        // Both squares touch the NaN cell: no faces.
        assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 0);
        let flat = Heightfield::filled(2, 2, 0.0).unwrap();
        let text = String::from_utf8(write(&flat, 1.0).unwrap()).unwrap();
        let face: Vec<usize> = text
            .lines()
            .find(|l| l.starts_with("f "))
            .unwrap()
            .split(' ')
            .skip(1)
            .map(|t| t.split('/').next().unwrap().parse().unwrap())
            .collect();
        // (a, c, b): normal (c - a) x (b - a) = (0,0,1) x (1,0,0) = +Y, so it faces up.
        assert_eq!(face, vec![1, 3, 2]);
    }
}
