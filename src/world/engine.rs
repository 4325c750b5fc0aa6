//! A built world as an engine's tiles (Unreal World Partition's tiled Landscape import, Unity
//! terrain groups, Godot): tiles of `tile + 1` vertices that share their edge rows and
//! columns (a tile's last column is its east neighbour's first, bit for bit), every tile on
//! the world's one height range (a height is the same 16-bit sample in every tile), named
//! `world_x{column}_y{row}` as Unreal's tiled import expects, with the numbers to type into
//! the engine beside them ([`crate::export::preset::EngineNumbers`]).
//!
//! A tile's cells are read from the build's finished tiles ([`super::task::read_window`]):
//! the shared edge is the same cell of the world read twice, so the same bits. The range is
//! measured over the finished tiles, one at a time.

use super::WorldError;
use super::plan::Plan;
use super::task::{self, BuildDir, write_atomically};
use crate::dem::format::{self, ExportOptions};
use crate::export::preset::{Engine, EngineNumbers};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::wavelet::directional::Region;

/// What [`write`] wrote.
#[derive(Debug)]
pub struct EngineTiles {
    /// Tiles along each axis.
    pub per_side: usize,
    /// Vertices a side of each tile.
    pub side: usize,
    pub numbers: EngineNumbers,
}

/// Whether `engine` can take the world of `plan` in tiles: the world must split into whole
/// tiles that share their edges (`size = k tile + 1`), and the engine must take `tile + 1`
/// vertices a side. Checked before any task runs.
pub fn check(plan: &Plan, engine: Engine) -> Result<(), WorldError> {
    let bad = |m: String| WorldError::Plan(m);
    if plan.size < plan.tile + 1 || !(plan.size - 1).is_multiple_of(plan.tile) {
        let k = ((plan.size - 1) / plan.tile).max(1);
        return Err(bad(format!(
            "engine tiles share their edges, so the world must be a whole number of tiles \
             plus one vertex: --size {} for tiles of {} (or {}), not {}",
            k * plan.tile + 1,
            plan.tile,
            (k + 1) * plan.tile + 1,
            plan.size
        )));
    }
    let side = plan.tile + 1;
    engine.check(side, side, engine.formats()[0]).map_err(|e| {
        bad(format!(
            "--engine {}: a tile of {side} vertices: {e}",
            engine.key()
        ))
    })
}

/// Writes the world of `plan` in `dir` as `engine`'s tiles into `dir/engine/` (every build
/// tile must be done; [`check`] first).
pub async fn write(
    dir: &BuildDir,
    plan: &Plan,
    engine: Engine,
    ctx: &JobCtx,
) -> Result<EngineTiles, WorldError> {
    check(plan, engine)?;
    let side = plan.tile + 1;
    let format = engine.formats()[0];
    let range = world_range(dir, plan)?;
    let per_side = (plan.size - 1) / plan.tile;
    let cell_m = plan.cell_m();
    let options = ExportOptions {
        size: None,
        flip_y: engine.flip_y(),
        z_scale: 1.0,
        cell_size: cell_m,
        z_range: Some(range),
    };
    let centre = plan.scene.location.map(|l| [l.lon, l.lat]);
    let width_m = plan.size as f64 * cell_m;
    for row in 0..per_side {
        for col in 0..per_side {
            let (x0, y0) = (col * plan.tile, row * plan.tile);
            let window = Region {
                x0,
                y0,
                width: side,
                height: side,
            };
            let cells = task::read_window(dir, plan, window)?;
            let field = Heightfield::from_vec(side, side, cells)
                .map_err(|e| WorldError::Io(e.to_string()))?;
            let georef = crate::export::map_georef(
                centre,
                width_m,
                cell_m,
                x0 as f64 * cell_m,
                y0 as f64 * cell_m,
            );
            let written = format::write_in(format, &field, &georef, &options, ctx)
                .await
                .map_err(|e| WorldError::Io(format!("tile ({col}, {row}): {e}")))?;
            let stem = format!("world_x{col}_y{row}");
            let path = dir.engine().join(format!("{stem}.{}", format.extension()));
            write_atomically(&path, &written.bytes)?;
            if let Some(sidecar) = written.sidecar {
                write_atomically(
                    &dir.engine().join(format!("{stem}.json")),
                    sidecar.as_bytes(),
                )?;
            }
        }
    }
    let extent = (plan.size - 1) as f64 * cell_m;
    let numbers = EngineNumbers::new(
        engine,
        format,
        plan.size,
        extent,
        (f64::from(range.0), f64::from(range.1)),
    );
    write_atomically(&dir.engine().join("world.txt"), numbers.text().as_bytes())?;
    Ok(EngineTiles {
        per_side,
        side,
        numbers,
    })
}

/// The world's finite height range, over its finished tiles.
fn world_range(dir: &BuildDir, plan: &Plan) -> Result<(f32, f32), WorldError> {
    let mut range = (f32::INFINITY, f32::NEG_INFINITY);
    for k in 0..plan.tile_count() {
        for v in task::read_tile(dir, plan, k)? {
            if v.is_finite() {
                range = (range.0.min(v), range.1.max(v));
            }
        }
    }
    if range.0 > range.1 {
        return Err(WorldError::Io("the world has no finite height".into()));
    }
    Ok(range)
}
