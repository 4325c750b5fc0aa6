//! Chunked quadtree level of detail (seed paper 003, Sec. 3.3.1-3.3.2; seed paper 004, Sec. 3.3).
//!
//! The heightfield is covered by a quadtree of square chunks. Every chunk is drawn with the
//! same regular grid of `n = CHUNK_QUADS + 1` samples per side; a chunk of level `L` samples
//! the heightfield every `2^L` cells, so level 0 is the field's own resolution and the root
//! covers the whole map with `n^2` samples. Levels below zero (at most
//! [`LodParams::detail_levels`]) are finer than the field: the renderer adds seed 004's
//! multifractal detail there (see `shaders/terrain3d.wgsl`). Every vertex, at every level,
//! lies on one surface, the bicubic B-spline that passes through the samples (seed 004's
//! subdivision limit, [`super::subdivision`]), so a vertex two levels share has one height.
//!
//! Refinement follows seed 004's triangle-density rule, eq. 7: a chunk of size `D`, seen from
//! distance `x` by an eye `h` above it, subtends about `D h / x^2` radians along the view
//! direction and `D / x` across it, so its fineness (triangles per radian) is
//! `f = 2 (n - 1)^2 max(rho_1, rho_2)` with `rho_1 = x^2 / (D h)`, `rho_2 = x / D`; the chunk is
//! split while `f <= tau`. [`tau_for_viewport`] picks `tau` so that a quad spans about a chosen
//! number of pixels. Chunks outside the view frustum are dropped.
//!
//! Neighbouring chunks of different levels do not share all edge vertices; the renderer hides
//! the resulting T-junction cracks with skirts (a ring of vertices hanging below each chunk's
//! edge by the chunk's height range, [`Chunk::skirt`]), which is why every chunk carries the
//! minimum and maximum height it covers.
//!
//! Cost: building the min/max pyramid is O(cells); a selection visits O(chunks drawn x levels)
//! nodes.

use glam::{Mat4, Vec3, Vec4};

use crate::heightfield::Heightfield;

/// Quads per chunk side (`n - 1` of eq. 7).
pub const CHUNK_QUADS: usize = 32;

/// Triangles one chunk draws: its grid plus the skirt around it.
pub const TRIANGLES_PER_CHUNK: usize = 2 * CHUNK_QUADS * CHUNK_QUADS + 2 * 4 * CHUNK_QUADS;

/// One chunk to draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chunk {
    /// Level: samples are `2^level` cells apart (negative: finer than the field).
    pub level: i32,
    /// North-west corner in cells.
    pub origin: [f32; 2],
    /// Heights it covers (metres, before vertical exaggeration).
    pub zmin: f32,
    pub zmax: f32,
}

impl Chunk {
    /// Distance between samples, in cells.
    pub fn stride(&self) -> f32 {
        (self.level as f32).exp2()
    }

    /// Side in cells.
    pub fn side(&self) -> f32 {
        CHUNK_QUADS as f32 * self.stride()
    }

    /// How far the skirt hangs below the edge (metres, before exaggeration): the chunk's
    /// height range bounds the gap to any neighbour over the same ground.
    pub fn skirt(&self) -> f32 {
        (self.zmax - self.zmin).max(0.0)
    }
}

/// Minimum and maximum height of every chunk of every level >= 0.
#[derive(Clone, Debug)]
pub struct ChunkTree {
    width: usize,
    height: usize,
    /// `levels[L]`: the chunks of level `L`.
    levels: Vec<Level>,
}

/// The chunks of one level: `cols x rows` height ranges `(min, max)`, row-major.
#[derive(Clone, Debug)]
struct Level {
    cols: usize,
    rows: usize,
    ranges: Vec<(f32, f32)>,
}

impl ChunkTree {
    /// Builds the min/max pyramid of `field` (non-finite cells are ignored), each chunk's
    /// range taken over its cells and the ring of cells around them: with `field` the
    /// B-spline control points, the surface over the chunk lies within it (the basis is
    /// non-negative and sums to one; the border's ghosts keep that, see
    /// `super::subdivision`). O(cells).
    pub fn new(field: &Heightfield) -> Self {
        let (w, h) = (field.width(), field.height());
        let chunks = |cells: usize, side: usize| (cells.saturating_sub(1)).div_ceil(side).max(1);
        let (cols, rows) = (chunks(w, CHUNK_QUADS), chunks(h, CHUNK_QUADS));
        let data = field.data();
        let mut ranges = vec![(f32::INFINITY, f32::NEG_INFINITY); cols * rows];
        for (cy, row) in ranges.chunks_mut(cols).enumerate() {
            // One cell of margin: the B-spline over a chunk reaches one control point past
            // its edge (see `super::subdivision`).
            let y0 = (cy * CHUNK_QUADS).saturating_sub(1);
            let y1 = (cy * CHUNK_QUADS + CHUNK_QUADS + 1).min(h.saturating_sub(1));
            for y in y0..=y1 {
                let line = &data[y * w..(y + 1) * w];
                for (cx, range) in row.iter_mut().enumerate() {
                    let x0 = (cx * CHUNK_QUADS).saturating_sub(1);
                    let x1 = (cx * CHUNK_QUADS + CHUNK_QUADS + 1).min(w - 1);
                    for &z in &line[x0..=x1] {
                        if z.is_finite() {
                            range.0 = range.0.min(z);
                            range.1 = range.1.max(z);
                        }
                    }
                }
            }
        }
        let mut levels = vec![Level { cols, rows, ranges }];
        loop {
            let below = levels.last().expect("level 0 exists");
            let (c, r) = (below.cols, below.rows);
            if c == 1 && r == 1 {
                break;
            }
            let (pc, pr) = (c.div_ceil(2), r.div_ceil(2));
            let mut up = vec![(f32::INFINITY, f32::NEG_INFINITY); pc * pr];
            for y in 0..r {
                for x in 0..c {
                    let (lo, hi) = below.ranges[y * c + x];
                    let p = &mut up[(y / 2) * pc + x / 2];
                    *p = (p.0.min(lo), p.1.max(hi));
                }
            }
            levels.push(Level {
                cols: pc,
                rows: pr,
                ranges: up,
            });
        }
        Self {
            width: w,
            height: h,
            levels,
        }
    }

    /// The root's level.
    pub fn top_level(&self) -> i32 {
        self.levels.len() as i32 - 1
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// The chunk of `level` >= 0 at chunk column `cx`, row `cy`, if it covers any cell.
    fn chunk(&self, level: i32, cx: usize, cy: usize) -> Option<Chunk> {
        let l = self.levels.get(usize::try_from(level).ok()?)?;
        if cx >= l.cols || cy >= l.rows {
            return None;
        }
        let (zmin, zmax) = l.ranges[cy * l.cols + cx];
        let side = (CHUNK_QUADS << level) as f32;
        Some(Chunk {
            level,
            origin: [cx as f32 * side, cy as f32 * side],
            zmin: if zmin.is_finite() { zmin } else { 0.0 },
            zmax: if zmax.is_finite() { zmax } else { 0.0 },
        })
    }

    /// The four children of `chunk` that cover cells of the map.
    fn children(&self, chunk: &Chunk, detail_amplitude: f32) -> Vec<Chunk> {
        let level = chunk.level - 1;
        let half = chunk.side() / 2.0;
        let mut out = Vec::with_capacity(4);
        for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let origin = [
                chunk.origin[0] + dx as f32 * half,
                chunk.origin[1] + dy as f32 * half,
            ];
            if origin[0] >= (self.width - 1) as f32 || origin[1] >= (self.height - 1) as f32 {
                continue;
            }
            if level >= 0 {
                let step = (CHUNK_QUADS << level) as f32;
                let (cx, cy) = ((origin[0] / step) as usize, (origin[1] / step) as usize);
                out.extend(self.chunk(level, cx, cy));
            } else {
                // Finer than the field: the parent's range widened by the synthetic detail.
                let pad = if chunk.level >= 0 {
                    detail_amplitude
                } else {
                    0.0
                };
                out.push(Chunk {
                    level,
                    origin,
                    zmin: chunk.zmin - pad,
                    zmax: chunk.zmax + pad,
                });
            }
        }
        out
    }
}

/// How much detail to draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodParams {
    /// Eq. 7's threshold `tau` (triangles per radian): chunks with `f <= tau` are split.
    pub tau: f32,
    /// Levels finer than the field allowed near the eye (0 = none).
    pub detail_levels: u32,
    /// Largest height the synthetic detail adds (metres), for culling and skirts.
    pub detail_amplitude: f32,
    /// At most this many chunks are drawn (refinement stops there).
    pub max_chunks: usize,
}

/// `tau` for a viewport `height_px` pixels tall with vertical field of view `fov_y`
/// radians, such that a quad edge spans about `pixels_per_quad` pixels: a chunk of
/// `n - 1` quads subtending `a` radians shows `(n - 1) / a` quads per radian against
/// `height_px / fov_y` pixels per radian, and eq. 7's `f = 2 (n - 1)^2 / a`.
pub fn tau_for_viewport(height_px: f32, fov_y: f32, pixels_per_quad: f32) -> f32 {
    2.0 * CHUNK_QUADS as f32 * height_px / (fov_y * pixels_per_quad.max(0.25))
}

/// Where the view is.
#[derive(Clone, Copy, Debug)]
pub struct ViewPoint {
    /// Eye in world metres.
    pub eye: Vec3,
    /// View-projection matrix for frustum culling (`None`: keep every chunk).
    pub view_proj: Option<Mat4>,
    /// Metres per cell.
    pub cell: f32,
    /// Vertical exaggeration (world z = height x exaggeration).
    pub exaggeration: f32,
}

/// The chunks to draw for one frame.
#[derive(Clone, Debug, Default)]
pub struct Selection {
    pub chunks: Vec<Chunk>,
}

impl Selection {
    pub fn triangles(&self) -> usize {
        self.chunks.len() * TRIANGLES_PER_CHUNK
    }

    /// Finest level drawn.
    pub fn finest_level(&self) -> Option<i32> {
        self.chunks.iter().map(|c| c.level).min()
    }
}

/// World-space box of a chunk.
fn bounds(chunk: &Chunk, view: &ViewPoint, tree: &ChunkTree) -> (Vec3, Vec3) {
    let side = chunk.side();
    let x1 = (chunk.origin[0] + side).min((tree.width - 1) as f32);
    let y1 = (chunk.origin[1] + side).min((tree.height - 1) as f32);
    let lo = Vec3::new(
        chunk.origin[0] * view.cell,
        chunk.origin[1] * view.cell,
        chunk.zmin * view.exaggeration,
    );
    let hi = Vec3::new(
        x1 * view.cell,
        y1 * view.cell,
        chunk.zmax * view.exaggeration,
    );
    (lo, hi)
}

/// Eq. 7: triangles per radian of `chunk` seen from `view`.
pub fn fineness(chunk: &Chunk, view: &ViewPoint, tree: &ChunkTree) -> f32 {
    let (lo, hi) = bounds(chunk, view, tree);
    fineness_in(chunk, view, lo, hi)
}

/// [`fineness`] of a chunk whose world box is `lo..hi`.
fn fineness_in(chunk: &Chunk, view: &ViewPoint, lo: Vec3, hi: Vec3) -> f32 {
    let nearest = view.eye.clamp(lo, hi);
    let x = view.eye.distance(nearest).max(1e-3);
    let d = (chunk.side() * view.cell).max(1e-3);
    // Height of the eye above the chunk; a rough chunk is never seen flatter than its relief.
    let above = (view.eye.z - nearest.z).abs();
    let h = above.max(hi.z - lo.z).max(view.cell);
    let rho_1 = x * x / (d * h);
    let rho_2 = x / d;
    let n1 = CHUNK_QUADS as f32;
    2.0 * n1 * n1 * rho_1.max(rho_2)
}

/// Whether the box is entirely outside one plane of the frustum of `view_proj` (wgpu clip
/// space: -w <= x, y <= w, 0 <= z <= w).
fn outside_frustum(view_proj: &Mat4, lo: Vec3, hi: Vec3) -> bool {
    let (r0, r1, r2, r3) = (
        view_proj.row(0),
        view_proj.row(1),
        view_proj.row(2),
        view_proj.row(3),
    );
    let planes: [Vec4; 5] = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2];
    planes.iter().any(|p| {
        // The box corner furthest along the plane normal.
        let c = Vec3::new(
            if p.x >= 0.0 { hi.x } else { lo.x },
            if p.y >= 0.0 { hi.y } else { lo.y },
            if p.z >= 0.0 { hi.z } else { lo.z },
        );
        p.truncate().dot(c) + p.w < 0.0
    })
}

/// Chooses the chunks to draw: breadth-first from the root, splitting every visible chunk
/// whose eq. 7 fineness is at most `tau`, until nothing needs splitting, the finest allowed
/// level is reached or the chunk budget is spent. The chunks returned tile the visible part
/// of the map without overlapping.
pub fn select(tree: &ChunkTree, view: &ViewPoint, params: &LodParams) -> Selection {
    let finest = -(params.detail_levels.min(4) as i32);
    let mut out = Vec::new();
    let mut current: Vec<Chunk> = tree.chunk(tree.top_level(), 0, 0).into_iter().collect();
    let budget = params.max_chunks.max(1);
    while !current.is_empty() {
        let mut next = Vec::new();
        let pending = current.len();
        for (i, chunk) in current.into_iter().enumerate() {
            let (lo, hi) = bounds(&chunk, view, tree);
            if view
                .view_proj
                .is_some_and(|vp| outside_frustum(&vp, lo, hi))
            {
                continue;
            }
            let left = pending - i - 1;
            let refine = chunk.level > finest
                && fineness_in(&chunk, view, lo, hi) <= params.tau
                && out.len() + next.len() + left + 4 <= budget;
            if refine {
                next.extend(tree.children(&chunk, params.detail_amplitude));
            } else {
                out.push(chunk);
            }
        }
        current = next;
    }
    Selection { chunks: out }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view3d::camera::{Camera, FOV_Y};

    fn hills(n: usize) -> Heightfield {
        let data = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 / n as f32, (i / n) as f32 / n as f32);
                400.0 * (6.0 * x).sin() * (5.0 * y).cos() + 500.0
            })
            .collect();
        Heightfield::from_vec(n, n, data).unwrap()
    }

    fn params() -> LodParams {
        LodParams {
            tau: tau_for_viewport(600.0, FOV_Y, 6.0),
            detail_levels: 0,
            detail_amplitude: 0.0,
            max_chunks: 4096,
        }
    }

    fn view(camera: &Camera, cell: f32) -> ViewPoint {
        ViewPoint {
            eye: camera.eye(),
            view_proj: Some(camera.view_proj(1.5, 1.0, 1e6)),
            cell,
            exaggeration: 1.0,
        }
    }

    #[test]
    fn the_pyramid_holds_every_chunks_height_range() {
        let field = hills(257);
        let tree = ChunkTree::new(&field);
        assert_eq!(tree.top_level(), 3);
        let root = tree.chunk(3, 0, 0).unwrap();
        let (lo, hi) = field.finite_range().unwrap();
        assert_eq!((root.zmin, root.zmax), (lo, hi));
        // A level-0 chunk's range is exactly that of its 33 x 33 cells and the ring around
        // them (the control points its B-spline surface reaches).
        let c = tree.chunk(0, 2, 5).unwrap();
        let cells = (159..=193).flat_map(|y| (63..=97).map(move |x| (x, y)));
        let zs: Vec<f32> = cells.map(|(x, y)| field.get(x, y).unwrap()).collect();
        let min = zs.iter().copied().fold(f32::INFINITY, f32::min);
        let max = zs.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        assert_eq!((c.zmin, c.zmax), (min, max));
    }

    #[test]
    fn chunks_tile_the_map_without_overlap() {
        let field = hills(513);
        let tree = ChunkTree::new(&field);
        let cell = 10.0;
        let mut camera = Camera::overview(5120.0, 5120.0, 500.0);
        camera.distance = 800.0;
        let mut v = view(&camera, cell);
        v.view_proj = None;
        let sel = select(&tree, &v, &params());
        assert!(sel.chunks.len() > 4);
        // Each cell of the map is covered exactly once.
        let mut covered = vec![0u8; 512 * 512];
        for c in &sel.chunks {
            let side = c.side() as usize;
            let (x0, y0) = (c.origin[0] as usize, c.origin[1] as usize);
            for y in y0..(y0 + side).min(512) {
                for x in x0..(x0 + side).min(512) {
                    covered[y * 512 + x] += 1;
                }
            }
        }
        assert!(covered.iter().all(|&k| k == 1));
    }

    #[test]
    fn closer_views_draw_more_triangles() {
        let field = hills(1025);
        let tree = ChunkTree::new(&field);
        let cell = 10.0;
        let mut camera = Camera::overview(10240.0, 10240.0, 500.0);
        camera.pitch = 0.5;
        let at = |d: f32| {
            let mut c = camera;
            c.distance = d * 10240.0;
            select(&tree, &view(&c, cell), &params())
        };
        let (near, mid, far) = (at(0.1), at(0.6), at(3.0));
        let (tn, tm, tf) = (near.triangles(), mid.triangles(), far.triangles());
        assert!(tn >= tm && tm > tf, "{tn} {tm} {tf}");
        assert!(tn >= 2 * tf, "{tn} {tf}");
        // Near the ground the finest chunks are the field's own cells; far away, coarse ones.
        assert_eq!(near.finest_level(), Some(0));
        assert!(mid.finest_level() > near.finest_level());
        assert!(far.finest_level() > mid.finest_level());
    }

    #[test]
    fn detail_levels_refine_beyond_the_field_only_near_the_eye() {
        let field = hills(257);
        let tree = ChunkTree::new(&field);
        let mut camera = Camera::overview(2560.0, 2560.0, 500.0);
        camera.pitch = 0.3;
        camera.distance = 150.0;
        let mut p = params();
        assert_eq!(
            select(&tree, &view(&camera, 10.0), &p).finest_level(),
            Some(0)
        );
        p.detail_levels = 2;
        p.detail_amplitude = 5.0;
        let sel = select(&tree, &view(&camera, 10.0), &p);
        assert_eq!(sel.finest_level(), Some(-2));
        assert!(sel.chunks.iter().any(|c| c.level >= 1));
    }

    #[test]
    fn the_budget_caps_the_chunk_count() {
        let field = hills(1025);
        let tree = ChunkTree::new(&field);
        let mut camera = Camera::overview(10240.0, 10240.0, 500.0);
        camera.distance = 100.0;
        let mut p = params();
        p.max_chunks = 20;
        p.detail_levels = 2;
        let sel = select(&tree, &view(&camera, 10.0), &p);
        assert!(!sel.chunks.is_empty() && sel.chunks.len() <= 20);
    }

    #[test]
    fn chunks_behind_the_camera_are_culled() {
        let field = hills(1025);
        let tree = ChunkTree::new(&field);
        let mut camera = Camera::overview(10240.0, 10240.0, 500.0);
        camera.distance = 300.0;
        camera.pitch = 0.2;
        let culled = select(&tree, &view(&camera, 10.0), &params());
        let mut all = view(&camera, 10.0);
        all.view_proj = None;
        let kept = select(&tree, &all, &params());
        assert!(culled.chunks.len() < kept.chunks.len());
    }
}
