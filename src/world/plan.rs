//! The plan of a tiled build: what the world is (the scene, its size), how it is cut (the
//! tiles), and how it is made (the global build's size and the levels of detail above it).

use serde::{Deserialize, Serialize};

use super::WorldError;
use crate::scene::Scene;
use crate::wavelet::directional::Region;
use crate::wavelet::synthesis::output_len;

/// The plan file's format version.
pub const VERSION: u32 = 1;

/// The largest global build a plan chooses by itself: 2049^2 (seconds natively, about 1 GiB).
pub const DEFAULT_WORLD_MAX: usize = 2049;

/// The largest global build a plan accepts (the pipeline's own limit).
pub const WORLD_MAX: usize = 8192;

/// The most levels of detail above the global build (each doubles the resolution).
pub const MAX_LEVELS: u32 = crate::wavelet::synthesis::MAX_LEVELS;

/// The largest world: 65536^2 cells.
pub const MAX_SIZE: usize = 65_536;

/// The smallest tile side, and the largest (a tile's task holds a few of them in memory).
pub const TILE_SIDES: std::ops::RangeInclusive<usize> = 64..=8192;

/// A tiled build: the world is the scene built in one piece at `world` cells a side, then
/// `levels` levels of wavelet detail above it (the first `size` cells of each axis of the
/// `(world - 1) 2^levels + 1` grid), cut into tiles of `tile` cells.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    pub version: u32,
    pub scene: Scene,
    /// Cells a side of the world.
    pub size: usize,
    /// Cells a side of a tile (the last row and column of tiles may be smaller).
    pub tile: usize,
    /// Cells a side of the global build.
    pub world: usize,
    /// Levels of detail between the global build and the world.
    pub levels: u32,
    /// Whether the erosion is refined at the world's resolution, tile by tile (stage 1 of
    /// the tasks, [`super::refine`]): only with levels of detail and a scene with erosion.
    /// Absent in a plan file: refined where it can be.
    #[serde(default = "refined")]
    pub refine: bool,
    /// Whether the world's depressions are filled (flat lakes), exactly, by the tiled
    /// Priority-Flood ([`super::flood`]): three more stages after the tiles. Absent in a plan
    /// file: not filled.
    #[serde(default)]
    pub fill: bool,
}

fn refined() -> bool {
    true
}

/// What task `k` of a plan does ([`Plan::task`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Task {
    /// Task 0: the scene in one piece at the plan's `world` size.
    Global,
    /// Stage 1 of a refined build: tile `k`'s window, eroded at the world's resolution.
    Refine(usize),
    /// Tile `k`'s cells, written to its file (the last stage unless the plan fills).
    Tile(usize),
    /// With filling: tile `k` flooded alone, its spill graph written ([`super::flood`]).
    Flood(usize),
    /// With filling: every tile's graph joined and flooded from the world's edge.
    Levels,
    /// With filling, the last stage: tile `k` raised to its watersheds' spill levels.
    Filled(usize),
}

impl Plan {
    /// The plan for `scene` at `size` cells a side in tiles of `tile`; `world` the global
    /// build's size, or the largest up to [`DEFAULT_WORLD_MAX`] that the levels of detail
    /// reach `size` from.
    pub fn new(
        scene: &Scene,
        size: usize,
        tile: usize,
        world: Option<usize>,
    ) -> Result<Self, WorldError> {
        if !(2..=MAX_SIZE).contains(&size) {
            return Err(WorldError::Plan(format!(
                "--size must be 2 to {MAX_SIZE} cells, got {size}"
            )));
        }
        if !TILE_SIDES.contains(&tile) || !tile.is_multiple_of(16) {
            return Err(WorldError::Plan(format!(
                "--tile must be a multiple of 16 from {} to {} cells, got {tile}",
                TILE_SIDES.start(),
                TILE_SIDES.end()
            )));
        }
        let (world, levels) = match world {
            Some(world) => (world, levels_from(world, size)?),
            None => world_for(size)?,
        };
        if !(64..=WORLD_MAX).contains(&world) {
            return Err(WorldError::Plan(format!(
                "--world must be 64 to {WORLD_MAX} cells, got {world}"
            )));
        }
        Ok(Self {
            version: VERSION,
            scene: scene.clone(),
            size,
            tile,
            world,
            levels,
            refine: levels > 0 && scene.erosion.is_some(),
            fill: false,
        })
    }

    /// The plan with the world's depressions filled ([`super::flood`]).
    pub fn with_fill(mut self) -> Self {
        self.fill = true;
        self
    }

    /// The plan with no refinement: the tiles are the global build and its levels of
    /// detail alone (every cell exact, [`super::window`]).
    pub fn without_refinement(mut self) -> Self {
        self.refine = false;
        self
    }

    /// Tiles along each axis.
    pub fn tiles_per_side(&self) -> usize {
        self.size.div_ceil(self.tile)
    }

    /// Tiles of the world.
    pub fn tile_count(&self) -> usize {
        self.tiles_per_side() * self.tiles_per_side()
    }

    /// Tasks of the build: the global build (task 0), then with refinement one per tile's
    /// window (stage 1), then one per tile; with filling, one more per tile, one for the
    /// whole world's graph, and one per tile again.
    pub fn tasks(&self) -> usize {
        let tiles = self.tile_count();
        1 + tiles * (1 + usize::from(self.refine)) + usize::from(self.fill) * (2 * tiles + 1)
    }

    /// What task `k` does; `None` past the last.
    pub fn task(&self, k: usize) -> Option<Task> {
        let tiles = self.tile_count();
        if k == 0 {
            return Some(Task::Global);
        }
        if k >= self.tasks() {
            return None;
        }
        let mut j = k - 1;
        if self.refine {
            if j < tiles {
                return Some(Task::Refine(j));
            }
            j -= tiles;
        }
        Some(match j {
            _ if j < tiles => Task::Tile(j),
            _ if j < 2 * tiles => Task::Flood(j - tiles),
            _ if j == 2 * tiles => Task::Levels,
            _ => Task::Filled(j - 2 * tiles - 1),
        })
    }

    /// The task that writes tile `k`'s final heights: the tile's own, or with filling the
    /// filled tile's.
    pub fn final_task(&self, k: usize) -> usize {
        if self.fill {
            self.levels_task() + 1 + k
        } else {
            self.tile_task(k)
        }
    }

    /// With filling, the task of the whole world's spill graph.
    pub fn levels_task(&self) -> usize {
        self.tile_task(0) + 2 * self.tile_count()
    }

    /// Tile `k` and the tiles around it (whose refined windows reach into each other), in
    /// tile order.
    pub fn neighbours(&self, k: usize) -> impl Iterator<Item = usize> + use<> {
        let per = self.tiles_per_side();
        let (row, col) = (k / per, k % per);
        (row.saturating_sub(1)..=(row + 1).min(per - 1)).flat_map(move |r| {
            (col.saturating_sub(1)..=(col + 1).min(per - 1)).map(move |c| r * per + c)
        })
    }

    /// The task that writes tile `k`.
    pub fn tile_task(&self, k: usize) -> usize {
        1 + k + usize::from(self.refine) * self.tile_count()
    }

    /// The stages of the tasks, in the order they must run (each may run its tasks in any
    /// order, on any number of workers): the task numbers and what they do.
    pub fn stages(&self) -> Vec<(std::ops::RangeInclusive<usize>, String)> {
        let tiles = self.tile_count();
        let mut stages = vec![(0..=0, format!("the global build at {}^2", self.world))];
        if self.refine {
            stages.push((
                1..=tiles,
                format!(
                    "each tile's erosion refined on the tile and {} cells around it",
                    self.halo()
                ),
            ));
        }
        let first = self.tile_task(0);
        stages.push((first..=first + tiles - 1, "the tiles".into()));
        if self.fill {
            let levels = self.levels_task();
            stages.push((
                first + tiles..=levels - 1,
                "each tile's depressions flooded alone, its spill graph".into(),
            ));
            stages.push((levels..=levels, "the whole world's spill graph".into()));
            stages.push((
                levels + 1..=levels + tiles,
                "each tile filled to its spill levels".into(),
            ));
        }
        stages
    }

    /// Cells a refined window reaches past its tile on each side ([`super::refine`]): an
    /// eighth of the tile, and at least eight global cells (the step's creep reaches one
    /// global cell from the held edge, and the windows' blend starts half a halo in), at
    /// most the tile (the windows over a tile are its own and its neighbours').
    pub fn halo(&self) -> usize {
        (self.tile / 8).max(8 << self.levels).min(self.tile)
    }

    /// Tile `k`'s window of the refinement: the tile and [`Plan::halo`] cells around it,
    /// within the world.
    pub fn refine_window(&self, k: usize) -> Region {
        let (_, _, tile) = self.tile(k);
        let halo = self.halo();
        let (x0, y0) = (tile.x0.saturating_sub(halo), tile.y0.saturating_sub(halo));
        Region {
            x0,
            y0,
            width: (tile.x0 + tile.width + halo).min(self.size) - x0,
            height: (tile.y0 + tile.height + halo).min(self.size) - y0,
        }
    }

    /// Metres between the global build's cells.
    pub fn global_cell_m(&self) -> f64 {
        self.cell_m() * f64::from(1u32 << self.levels)
    }

    /// Tile `k` (0-based, row by row): its row, column and cells.
    pub fn tile(&self, k: usize) -> (usize, usize, Region) {
        let per = self.tiles_per_side();
        let (row, col) = (k / per, k % per);
        let (x0, y0) = (col * self.tile, row * self.tile);
        let window = Region {
            x0,
            y0,
            width: self.tile.min(self.size - x0),
            height: self.tile.min(self.size - y0),
        };
        (row, col, window)
    }

    /// Metres between the world's cells: the scene's map width over the detail's grid.
    pub fn cell_m(&self) -> f64 {
        let map_width = self.scene.cell_size * self.scene.size as f64;
        map_width / ((self.world - 1) << self.levels) as f64
    }

    /// The plan as the file holds it.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// A plan file's plan, checked.
    pub fn from_json(text: &str) -> Result<Self, WorldError> {
        let plan: Self = serde_json::from_str(text)
            .map_err(|e| WorldError::Plan(format!("the plan file: {e}")))?;
        if plan.version != VERSION {
            return Err(WorldError::Plan(format!(
                "the plan file is version {}, this build reads {VERSION}",
                plan.version
            )));
        }
        let mut plan = plan;
        let again = Self::new(&plan.scene, plan.size, plan.tile, Some(plan.world))?;
        // Refined only where it can be (a plan file may ask for it without erosion).
        plan.refine &= again.refine;
        if again.levels != plan.levels {
            return Err(WorldError::Plan(format!(
                "the plan file's levels ({}) do not take a {} world to {} cells",
                plan.levels, plan.world, plan.size
            )));
        }
        plan.scene
            .validate()
            .map_err(|e| WorldError::Plan(format!("the plan file's scene: {e}")))?;
        Ok(plan)
    }
}

/// The fewest levels that take a `world` build to at least `size` cells.
fn levels_from(world: usize, size: usize) -> Result<u32, WorldError> {
    (0..=MAX_LEVELS)
        .find(|&k| world >= 2 && output_len(world, k) >= size)
        .ok_or_else(|| {
            WorldError::Plan(format!(
                "a {world} world reaches {} cells with {MAX_LEVELS} levels of detail, not \
                 {size}: ask for a larger --world",
                output_len(world.max(2), MAX_LEVELS)
            ))
        })
}

/// The global build and levels for `size`: no detail up to [`DEFAULT_WORLD_MAX`], else the
/// fewest levels whose world fits it, or the world [`MAX_LEVELS`] levels need.
fn world_for(size: usize) -> Result<(usize, u32), WorldError> {
    for levels in 0..=MAX_LEVELS {
        let world = (size - 1).div_ceil(1 << levels) + 1;
        if world <= DEFAULT_WORLD_MAX {
            return Ok((world.max(64), levels));
        }
    }
    let world = (size - 1).div_ceil(1 << MAX_LEVELS) + 1;
    Ok((world, MAX_LEVELS))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plans_cut_the_world_into_tiles_and_reach_its_size() {
        let scene = Scene::default();
        let plan = Plan::new(&scene, 32_768, 2048, None).unwrap();
        assert_eq!((plan.world, plan.levels), (4097, 3));
        assert!(output_len(plan.world, plan.levels) >= 32_768);
        assert_eq!(
            plan.tasks(),
            1 + 2 * 256,
            "refined: two stages of tile tasks"
        );
        assert_eq!(plan.task(1), Some(Task::Refine(0)));
        assert_eq!(plan.task(257), Some(Task::Tile(0)));
        assert_eq!(plan.task(512), Some(Task::Tile(255)));
        assert_eq!(plan.task(513), None);
        assert_eq!(plan.tile_task(255), 512);
        let plain = plan.clone().without_refinement();
        assert_eq!(plain.tasks(), 1 + 256);
        assert_eq!(plain.task(1), Some(Task::Tile(0)));
        assert_eq!(plain.stages().len(), 2);
        assert_eq!(plan.stages()[2].0, 257..=512);
        // Filled: a flood per tile, the world's graph, a fill per tile, each stage in turn.
        let filled = plan.clone().with_fill();
        assert_eq!(filled.tasks(), 1 + 2 * 256 + 2 * 256 + 1);
        assert_eq!(filled.task(513), Some(Task::Flood(0)));
        assert_eq!(filled.task(768), Some(Task::Flood(255)));
        assert_eq!(filled.task(769), Some(Task::Levels));
        assert_eq!(filled.task(770), Some(Task::Filled(0)));
        assert_eq!(filled.task(1025), Some(Task::Filled(255)));
        assert_eq!(filled.task(1026), None);
        assert_eq!((filled.levels_task(), filled.final_task(255)), (769, 1025));
        let ranges: Vec<_> = filled.stages().into_iter().map(|(r, _)| r).collect();
        assert_eq!(ranges[3..], [513..=768, 769..=769, 770..=1025]);
        assert_eq!(plain.clone().with_fill().task(257), Some(Task::Flood(0)));
        assert_eq!(Plan::from_json(&filled.to_json()).unwrap(), filled);
        // A window holds its tile and a halo, within the world.
        let w = plan.refine_window(17);
        let (_, _, t) = plan.tile(17);
        assert_eq!((t.x0 - w.x0, w.width), (256, 2048 + 512));
        assert_eq!(plan.refine_window(0).x0, 0);
        let plan = Plan::new(&scene, 1000, 256, None).unwrap();
        assert_eq!((plan.world, plan.levels), (1000, 0));
        assert!(!plan.refine, "no levels of detail: nothing finer to refine");
        assert_eq!(plan.tiles_per_side(), 4);
        let (row, col, last) = plan.tile(15);
        assert_eq!((row, col), (3, 3));
        assert_eq!((last.x0, last.width, last.height), (768, 232, 232));
        let plan = Plan::new(&scene, 513, 128, Some(129)).unwrap();
        assert_eq!(plan.levels, 2);
        assert_eq!(Plan::from_json(&plan.to_json()).unwrap(), plan);
        for (size, tile, world, words) in [
            (1, 256, None, "--size"),
            (4096, 8, None, "--tile"),
            (4096, 100, None, "multiple of 16"),
            (4096, 256, Some(100), "with 3 levels"),
            (4096, 256, Some(9000), "--world"),
        ] {
            let err = Plan::new(&scene, size, tile, world)
                .unwrap_err()
                .to_string();
            assert!(err.contains(words), "{err}");
        }
    }
}
