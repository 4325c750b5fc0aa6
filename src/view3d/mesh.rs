//! The one mesh every chunk is drawn with: a regular grid plus the skirt around it.

use super::lod::CHUNK_QUADS;

/// The shared chunk grid: `n x n` vertices `(i, j, 0)` then the skirt ring `(i, j, 1)`
/// along the four edges; triangles of the grid and of the skirt quads.
pub fn grid_mesh() -> (Vec<[f32; 3]>, Vec<u32>) {
    let n = CHUNK_QUADS as u32 + 1;
    let mut vertices: Vec<[f32; 3]> = (0..n * n)
        .map(|k| [(k % n) as f32, (k / n) as f32, 0.0])
        .collect();
    let mut indices = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            let (b, c, d) = (a + 1, a + n, a + n + 1);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    // Each edge as a list of top vertices in order; its skirt hangs below.
    let edges: [Vec<u32>; 4] = [
        (0..n).collect(),
        (0..n).map(|i| (n - 1) * n + i).collect(),
        (0..n).map(|j| j * n).collect(),
        (0..n).map(|j| j * n + n - 1).collect(),
    ];
    for edge in edges {
        let base = vertices.len() as u32;
        for &top in &edge {
            let [x, y, _] = vertices[top as usize];
            vertices.push([x, y, 1.0]);
        }
        for k in 0..n - 1 {
            let (t0, t1) = (edge[k as usize], edge[k as usize + 1]);
            let (s0, s1) = (base + k, base + k + 1);
            // Both windings: the pipeline does not cull, skirts face either way.
            indices.extend_from_slice(&[t0, s0, t1, t1, s0, s1]);
        }
    }
    (vertices, indices)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view3d::lod;

    #[test]
    fn the_grid_mesh_has_the_skirt_and_valid_indices() {
        let (vertices, indices) = grid_mesh();
        let n = CHUNK_QUADS + 1;
        assert_eq!(vertices.len(), n * n + 4 * n);
        assert_eq!(indices.len() / 3, lod::TRIANGLES_PER_CHUNK);
        assert!(indices.iter().all(|&i| (i as usize) < vertices.len()));
    }
}
