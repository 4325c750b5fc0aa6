//! The tasks of a tiled build, each a stateless, idempotent step that reads the plan and the
//! files its inputs left, and writes its own file atomically (a temporary name, then a
//! rename): a killed task leaves no half-written output, and running a task again is
//! harmless (a finished one is skipped).
//!
//! - Task 0, the global build: the scene through the whole pipeline at the plan's `world`
//!   size (`world.f32`, RAW R32: little-endian `f32`, row-major; `preview.tif`, the same as a
//!   GeoTIFF: the whole world at low resolution before any tile), and the standard
//!   deviations of its levels of detail from its wavelet statistics and the rivers'
//!   channels ([`super::channels`]) (`world.json`).
//! - With refinement ([`super::refine`]), tasks 1 to T: tile `k`'s window (the tile and a
//!   halo), its cells of the world eroded once more at the world's resolution
//!   (`refined/rRRR-cCCC.f32`: its heights, then the drainage area the step routed, RAW R32
//!   of twice the window's rows).
//! - The last T tasks, tile `k`: its cells of the world (`tiles/rRRR-cCCC.f32`), the global
//!   build with the levels of detail [`super::window::synthesize`] adds, or with refinement
//!   the refined windows over it blended.
//! - With filling ([`super::flood`]), after the tiles: each tile's spill graph
//!   (`flood/rRRR-cCCC.json`), then one task joining them (`flood/levels.json`), then each
//!   tile filled (`filled/rRRR-cCCC.f32`, what the world is assembled from).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::WorldError;
use super::channels::{Channels, Laid, Nearest};
use super::plan::{Plan, Task};
use super::refine::Refined;
use super::window::synthesize;
use crate::compute::Backend;
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::pipeline::{Pipeline, RunOptions};
use crate::wavelet::directional::Region;
use crate::wavelet::synthesis::SigmaTables;
use crate::wavelet::{AnalysisParams, directional, rng};

/// What task 0 found: the global build's size and checksum, and the detail's standard
/// deviations (as `f32` bits, `levels x 3`, band order H, V, D).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorldInfo {
    pub size: usize,
    pub checksum: String,
    pub sigma_bits: Vec<u32>,
    pub min: f32,
    pub max: f32,
    /// The drawn rivers' channels, laid again at the world's cells ([`super::channels`]);
    /// empty without levels of detail.
    #[serde(default)]
    pub channels: Channels,
}

/// Where a build's files are.
#[derive(Clone, Debug)]
pub struct BuildDir {
    root: PathBuf,
}

impl BuildDir {
    pub fn new(root: &Path) -> Self {
        Self {
            root: root.to_path_buf(),
        }
    }

    pub fn plan(&self) -> PathBuf {
        self.root.join("plan.json")
    }

    pub fn world(&self) -> PathBuf {
        self.root.join("world.f32")
    }

    pub fn world_info(&self) -> PathBuf {
        self.root.join("world.json")
    }

    /// The assembled world.
    pub fn world_tif(&self) -> PathBuf {
        self.root.join("world.tif")
    }

    /// Where the engine's tiles go ([`super::engine`]).
    pub fn engine(&self) -> PathBuf {
        self.root.join("engine")
    }

    /// The global build as a GeoTIFF: the whole world at low resolution, first.
    pub fn preview(&self) -> PathBuf {
        self.root.join("preview.tif")
    }

    /// Tile (`row`, `col`)'s file.
    pub fn tile(&self, row: usize, col: usize) -> PathBuf {
        self.root
            .join("tiles")
            .join(format!("r{row:03}-c{col:03}.f32"))
    }

    /// Tile (`row`, `col`)'s refined window ([`super::refine`]).
    pub fn refined(&self, row: usize, col: usize) -> PathBuf {
        self.root
            .join("refined")
            .join(format!("r{row:03}-c{col:03}.f32"))
    }

    /// Tile (`row`, `col`)'s spill graph, flooded alone ([`super::flood`]).
    pub fn flood_graph(&self, row: usize, col: usize) -> PathBuf {
        self.root
            .join("flood")
            .join(format!("r{row:03}-c{col:03}.json"))
    }

    /// Every tile's spill levels, from the whole world's graph.
    pub fn flood_levels(&self) -> PathBuf {
        self.root.join("flood").join("levels.json")
    }

    /// Tile (`row`, `col`) with its depressions filled.
    pub fn filled(&self, row: usize, col: usize) -> PathBuf {
        self.root
            .join("filled")
            .join(format!("r{row:03}-c{col:03}.f32"))
    }

    /// Whether task `k` of `plan` has its output. A refined window is done once written, or
    /// once every tile that reads it is (assembling the world removes the windows).
    pub fn done(&self, plan: &Plan, k: usize) -> bool {
        let holds = |path: PathBuf, w: Region| {
            std::fs::metadata(path).is_ok_and(|m| m.len() == (w.width * w.height * 4) as u64)
        };
        match plan.task(k) {
            Some(Task::Global) => self.world_info().is_file() && self.world().is_file(),
            Some(Task::Refine(j)) => {
                let (row, col, _) = plan.tile(j);
                holds(self.refined(row, col), stacked(plan.refine_window(j)))
                    || plan
                        .neighbours(j)
                        .all(|t| self.done(plan, plan.tile_task(t)))
            }
            Some(Task::Tile(j)) => {
                let (row, col, window) = plan.tile(j);
                holds(self.tile(row, col), window)
            }
            // A graph is only read by the levels' task.
            Some(Task::Flood(j)) => {
                let (row, col, _) = plan.tile(j);
                self.flood_graph(row, col).is_file() || self.flood_levels().is_file()
            }
            Some(Task::Levels) => self.flood_levels().is_file(),
            Some(Task::Filled(j)) => {
                let (row, col, window) = plan.tile(j);
                holds(self.filled(row, col), window)
            }
            None => false,
        }
    }
}

/// A refined window's file as one RAW R32 field: its heights, then its drainage area below
/// them (twice the window's rows).
fn stacked(window: Region) -> Region {
    Region {
        height: 2 * window.height,
        ..window
    }
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), WorldError> {
    let io = |e: std::io::Error| WorldError::Io(format!("{}: {e}", path.display()));
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let name = path
        .file_name()
        .map_or("out".into(), |n| n.to_string_lossy().into_owned());
    let temporary = path.with_file_name(format!(".{name}.{}.part", std::process::id()));
    std::fs::write(&temporary, bytes).map_err(io)?;
    std::fs::rename(&temporary, path).map_err(io)
}

/// Removes what killed tasks left: their temporary files (`.NAME.PID.part`) in the build's
/// directory and its tiles. Only once every task is done (no task is writing then); returns
/// how many were removed.
pub fn remove_leftovers(dir: &BuildDir) -> usize {
    let mut removed = 0;
    for folder in [
        dir.root.clone(),
        dir.root.join("tiles"),
        dir.root.join("refined"),
        dir.root.join("flood"),
        dir.root.join("filled"),
    ] {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let leftover = name.starts_with('.') && name.ends_with(".part");
            if leftover && std::fs::remove_file(entry.path()).is_ok() {
                removed += 1;
            }
        }
    }
    removed
}

/// Removes the refined windows once every tile is written (the world is assembled): they
/// are the size of the world again, and only the tiles read them.
pub fn remove_refined(dir: &BuildDir) {
    let _ = std::fs::remove_dir_all(dir.root.join("refined"));
}

/// Writes the plan, or checks that the one already in `dir` is the same (a directory holds
/// one build; resuming it must not change it).
pub fn write_plan(dir: &BuildDir, plan: &Plan) -> Result<(), WorldError> {
    if let Ok(text) = std::fs::read_to_string(dir.plan()) {
        let existing = Plan::from_json(&text)?;
        if existing != *plan {
            return Err(WorldError::Plan(format!(
                "{} holds another build's plan (size {}, tile {}, world {}): use another \
                 --out, or remove it",
                dir.plan().display(),
                existing.size,
                existing.tile,
                existing.world
            )));
        }
        return Ok(());
    }
    write_atomically(&dir.plan(), plan.to_json().as_bytes())
}

/// Runs task `k` of the plan in `dir` unless it is done; returns whether it ran.
pub async fn run(dir: &BuildDir, plan: &Plan, k: usize, ctx: &JobCtx) -> Result<bool, WorldError> {
    if k >= plan.tasks() {
        return Err(WorldError::Plan(format!(
            "--task {k}: the build has tasks 0 to {}",
            plan.tasks() - 1
        )));
    }
    if dir.done(plan, k) {
        return Ok(false);
    }
    match plan.task(k) {
        Some(Task::Global) | None => global_build(dir, plan, ctx).await?,
        Some(Task::Refine(j)) => refine(dir, plan, j)?,
        Some(Task::Tile(j)) => tile(dir, plan, j)?,
        Some(Task::Flood(j)) => flood(dir, plan, j)?,
        Some(Task::Levels) => flood_levels(dir, plan)?,
        Some(Task::Filled(j)) => filled(dir, plan, j)?,
    }
    Ok(true)
}

/// The global build: the scene in one piece at the plan's `world` size, what `world.json`
/// records of it, and `preview.tif`'s bytes (the whole world at low resolution, georeferenced
/// over the world's extent). Task 0 writes it; the app and the page save the preview alone,
/// the same bytes, before a batch run.
pub struct GlobalBuild {
    pub field: std::sync::Arc<Heightfield>,
    pub info: WorldInfo,
    pub preview: Vec<u8>,
}

/// Builds the scene of `plan` in one piece at its `world` size on the CPU (the same bits
/// everywhere), with its detail's standard deviations (GSA of seed paper 001).
pub async fn build_global(plan: &Plan, ctx: &JobCtx) -> Result<GlobalBuild, WorldError> {
    let options = RunOptions {
        size: plan.world,
        ..RunOptions::for_scene(&plan.scene)
    };
    let out = Pipeline::new()
        .run(&plan.scene, &options, &Backend::Cpu, ctx)
        .await
        .map_err(|e| WorldError::Build(e.to_string()))?;
    let field = out.field;
    let sigma_bits = if plan.levels == 0 {
        Vec::new()
    } else {
        let analysis = crate::wavelet::analyze(&field, &AnalysisParams::default())
            .map_err(|e| WorldError::Build(format!("the detail's statistics: {e}")))?;
        let tables =
            SigmaTables::build(&analysis, None, plan.levels, field.width(), field.height());
        tables.tables.iter().map(|t| t[0].to_bits()).collect()
    };
    let (min, max) = field
        .data()
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    let channels = if plan.levels == 0 {
        Channels::default()
    } else {
        let map_width = plan.scene.cell_size * plan.scene.size as f64;
        Channels::of(&out.hydrology.rivers, &field, map_width)
    };
    let info = WorldInfo {
        size: field.width(),
        checksum: field.checksum(),
        sigma_bits,
        min,
        max,
        channels,
    };
    let spacing = plan.global_cell_m();
    let centre = plan.scene.location.map(|l| [l.lon, l.lat]);
    let georef = crate::export::map_georef(centre, spacing * plan.world as f64, spacing, 0.0, 0.0);
    let preview = crate::dem::geotiff::write(&field, &georef)
        .map_err(|e| WorldError::Io(format!("the preview: {e}")))?;
    Ok(GlobalBuild {
        field,
        info,
        preview,
    })
}

/// Task 0: the global build ([`build_global`]) and its files.
async fn global_build(dir: &BuildDir, plan: &Plan, ctx: &JobCtx) -> Result<(), WorldError> {
    let global = build_global(plan, ctx).await?;
    write_atomically(&dir.preview(), &global.preview)?;
    write_atomically(
        &dir.world(),
        &crate::dem::raw32::write(&global.field, false),
    )?;
    let text = serde_json::to_string_pretty(&global.info).unwrap_or_default();
    write_atomically(&dir.world_info(), text.as_bytes())
}

/// The global build and its detail's standard deviations, as task 0 left them.
pub fn read_world(dir: &BuildDir, plan: &Plan) -> Result<Global, WorldError> {
    let missing = |what: &Path, e: std::io::Error| {
        WorldError::Io(format!(
            "{}: {e} (run task 0, the global build, first)",
            what.display()
        ))
    };
    let text =
        std::fs::read_to_string(dir.world_info()).map_err(|e| missing(&dir.world_info(), e))?;
    let info: WorldInfo = serde_json::from_str(&text)
        .map_err(|e| WorldError::Io(format!("{}: {e}", dir.world_info().display())))?;
    let bytes = std::fs::read(dir.world()).map_err(|e| missing(&dir.world(), e))?;
    let n = plan.world;
    if info.size != n
        || bytes.len() != n * n * 4
        || info.sigma_bits.len() != plan.levels as usize * 3
    {
        return Err(WorldError::Io(format!(
            "{} is not this plan's {n}^2 global build: remove it and run task 0 again",
            dir.world().display()
        )));
    }
    let field = raw32(&bytes, n, n)?;
    if field.checksum() != info.checksum {
        return Err(WorldError::Io(format!(
            "{} does not match its checksum in {}: remove both and run task 0 again",
            dir.world().display(),
            dir.world_info().display()
        )));
    }
    let sigma = sigma_of(&info, plan);
    Ok(Global {
        field,
        sigma,
        channels: info.channels,
    })
}

/// The detail's standard deviations task 0 recorded in `info`.
fn sigma_of(info: &WorldInfo, plan: &Plan) -> SigmaTables {
    SigmaTables {
        levels: plan.levels,
        tables: info
            .sigma_bits
            .iter()
            .map(|b| vec![f32::from_bits(*b)])
            .collect(),
        source_width: plan.world,
        source_height: plan.world,
    }
}

impl GlobalBuild {
    /// What the tasks after task 0 read of this build ([`read_world`] without the files).
    pub fn global(&self, plan: &Plan) -> Global {
        Global {
            field: (*self.field).clone(),
            sigma: sigma_of(&self.info, plan),
            channels: self.info.channels.clone(),
        }
    }
}

/// What the tasks after task 0 read of the global build: its heights, its detail's standard
/// deviations and the rivers' channels.
pub struct Global {
    pub field: Heightfield,
    pub sigma: SigmaTables,
    pub channels: Channels,
}

/// The cells of `window` of the world of `plan` from its global build: the levels of detail
/// above it, interpolated along its valleys and crests ([`directional`]), with the rivers'
/// channels laid at the world's cells ([`super::channels`]).
pub fn cells(global: &Global, plan: &Plan, window: Region) -> Vec<f32> {
    cells_and_laid(global, plan, window).0
}

/// [`cells`] and what the refinement keeps of their channels ([`Laid`]; empty without
/// levels of detail, where nothing is refined), the channels found once.
pub fn cells_and_laid(global: &Global, plan: &Plan, window: Region) -> (Vec<f32>, Laid) {
    let (world, sigma) = (&global.field, &global.sigma);
    if plan.levels == 0 {
        let n = world.width();
        let mut out = Vec::with_capacity(window.width * window.height);
        for y in window.y0..window.y0 + window.height {
            out.extend_from_slice(
                &world.data()[y * n + window.x0..y * n + window.x0 + window.width],
            );
        }
        return (out, Laid::default());
    }
    let key = rng::seed_key(plan.scene.seed);
    let mut cells = synthesize(world, sigma, plan.levels, key, window);
    directional::correct(world, plan.levels, window, &mut cells);
    let nearest = channels_in(global, plan, window);
    nearest.lay(&mut cells);
    (cells, nearest.laid())
}

/// The nearest channel of each cell of `window` ([`Nearest`]).
pub fn channels_in(global: &Global, plan: &Plan, window: Region) -> Nearest {
    Nearest::find(
        &global.channels,
        &global.field,
        plan.levels,
        window,
        plan.cell_m(),
    )
}

/// Stage 1 of a refined build: tile `k`'s window refined ([`super::refine::refine`]).
fn refine(dir: &BuildDir, plan: &Plan, k: usize) -> Result<(), WorldError> {
    let global = read_world(dir, plan)?;
    let (row, col, _) = plan.tile(k);
    let window = plan.refine_window(k);
    let (heights, laid) = cells_and_laid(&global, plan, window);
    drop(global);
    let mut refined = super::refine::refine(plan, window, heights, &laid)?;
    refined.heights.append(&mut refined.area);
    write_field(&dir.refined(row, col), stacked(window), refined.heights)
}

/// The last stage: tile `k`, its cells of the world, or with refinement the refined windows
/// over it blended ([`super::refine::blend`]).
fn tile(dir: &BuildDir, plan: &Plan, k: usize) -> Result<(), WorldError> {
    let (row, col, window) = plan.tile(k);
    let heights = if plan.refine {
        super::refine::blend(plan, k, |j| read_refined(dir, plan, j))?
    } else {
        cells(&read_world(dir, plan)?, plan, window)
    };
    write_field(&dir.tile(row, col), window, heights)
}

/// Tile `k` flooded alone from its perimeter ([`super::flood::flood_tile`]): the same bits
/// whichever task floods it (the graph's and the fill's).
fn flooded_tile(
    dir: &BuildDir,
    plan: &Plan,
    k: usize,
) -> Result<super::flood::TileFlood, WorldError> {
    let (row, col, window) = plan.tile(k);
    let heights = read_cells(&dir.tile(row, col), window, plan.tile_task(k))?;
    let last = plan.size - 1;
    let on_world_edge = |x: usize, y: usize| {
        let (x, y) = (window.x0 + x, window.y0 + y);
        x == 0 || y == 0 || x == last || y == last
    };
    Ok(super::flood::flood_tile(
        &heights,
        window.width,
        window.height,
        on_world_edge,
    ))
}

/// With filling, the stage after the tiles: tile `k`'s spill graph.
fn flood(dir: &BuildDir, plan: &Plan, k: usize) -> Result<(), WorldError> {
    let (row, col, _) = plan.tile(k);
    let graph = flooded_tile(dir, plan, k)?.graph;
    let text = serde_json::to_string(&graph).map_err(|e| WorldError::Io(e.to_string()))?;
    write_atomically(&dir.flood_graph(row, col), text.as_bytes())
}

/// With filling, one task: every tile's graph joined and flooded from the world's edge
/// ([`super::flood::solve`]); each tile's spill levels, as `f32` bits, in `levels.json`.
fn flood_levels(dir: &BuildDir, plan: &Plan) -> Result<(), WorldError> {
    let graphs = (0..plan.tile_count())
        .map(|k| {
            let (row, col, window) = plan.tile(k);
            let path = dir.flood_graph(row, col);
            let text = std::fs::read_to_string(&path).map_err(|e| {
                WorldError::Io(format!(
                    "{}: {e} (run task {} first)",
                    path.display(),
                    plan.tile_task(k) + plan.tile_count()
                ))
            })?;
            let graph: super::flood::TileGraph = serde_json::from_str(&text)
                .map_err(|e| WorldError::Io(format!("{}: {e}", path.display())))?;
            if (graph.width, graph.height) != (window.width, window.height) {
                return Err(WorldError::Io(format!(
                    "{} is a graph of {} x {} cells, not the tile's {} x {}",
                    path.display(),
                    graph.width,
                    graph.height,
                    window.width,
                    window.height
                )));
            }
            Ok(graph)
        })
        .collect::<Result<Vec<_>, WorldError>>()?;
    let layout = super::flood::Layout {
        size: plan.size,
        tile: plan.tile,
    };
    let levels: Vec<Vec<u32>> = super::flood::solve(layout, &graphs)
        .into_iter()
        .map(|tile| tile.into_iter().map(f32::to_bits).collect())
        .collect();
    let text = serde_json::to_string(&levels).map_err(|e| WorldError::Io(e.to_string()))?;
    write_atomically(&dir.flood_levels(), text.as_bytes())
}

/// With filling, the last stage: tile `k` flooded alone again, then raised to its
/// watersheds' spill levels ([`super::flood::fill_tile`]).
fn filled(dir: &BuildDir, plan: &Plan, k: usize) -> Result<(), WorldError> {
    let (row, col, window) = plan.tile(k);
    let path = dir.flood_levels();
    let text = std::fs::read_to_string(&path).map_err(|e| {
        WorldError::Io(format!(
            "{}: {e} (run task {} first)",
            path.display(),
            plan.levels_task()
        ))
    })?;
    let levels: Vec<Vec<u32>> = serde_json::from_str(&text)
        .map_err(|e| WorldError::Io(format!("{}: {e}", path.display())))?;
    let mine: Vec<f32> = levels
        .get(k)
        .ok_or_else(|| WorldError::Io(format!("{} has no levels for tile {k}", path.display())))?
        .iter()
        .map(|&bits| f32::from_bits(bits))
        .collect();
    let flood = flooded_tile(dir, plan, k)?;
    write_field(
        &dir.filled(row, col),
        window,
        super::flood::fill_tile(flood, &mine),
    )
}

/// Writes the cells of `window` to `path` as RAW R32, atomically.
fn write_field(path: &Path, window: Region, heights: Vec<f32>) -> Result<(), WorldError> {
    let field = Heightfield::from_vec(window.width, window.height, heights)
        .map_err(|e| WorldError::Io(e.to_string()))?;
    write_atomically(path, &crate::dem::raw32::write(&field, false))
}

/// Tile `k`'s refined window, as its task left it.
fn read_refined(dir: &BuildDir, plan: &Plan, k: usize) -> Result<Refined, WorldError> {
    let (row, col, _) = plan.tile(k);
    let window = plan.refine_window(k);
    let mut heights = read_cells(&dir.refined(row, col), stacked(window), k + 1)?;
    let area = heights.split_off(window.width * window.height);
    Ok(Refined { heights, area })
}

/// The world's cells in `window`, from the finished tiles it crosses.
pub fn read_window(dir: &BuildDir, plan: &Plan, window: Region) -> Result<Vec<f32>, WorldError> {
    let mut out = vec![0.0f32; window.width * window.height];
    let per = plan.tiles_per_side();
    let rows = window.y0 / plan.tile..=(window.y0 + window.height - 1) / plan.tile;
    for row in rows {
        for col in window.x0 / plan.tile..=(window.x0 + window.width - 1) / plan.tile {
            let k = row * per + col;
            let (_, _, tile) = plan.tile(k);
            let cells = read_tile(dir, plan, k)?;
            let xs = tile.x0.max(window.x0)..(tile.x0 + tile.width).min(window.x0 + window.width);
            let ys = tile.y0.max(window.y0)..(tile.y0 + tile.height).min(window.y0 + window.height);
            for y in ys {
                let from = (y - tile.y0) * tile.width + xs.start - tile.x0;
                let to = (y - window.y0) * window.width + xs.start - window.x0;
                out[to..to + xs.len()].copy_from_slice(&cells[from..from + xs.len()]);
            }
        }
    }
    Ok(out)
}

/// A finished tile's heights (with filling, the filled tile's).
pub fn read_tile(dir: &BuildDir, plan: &Plan, k: usize) -> Result<Vec<f32>, WorldError> {
    let (row, col, window) = plan.tile(k);
    let path = if plan.fill {
        dir.filled(row, col)
    } else {
        dir.tile(row, col)
    };
    read_cells(&path, window, plan.final_task(k))
}

/// The cells of `window` that task `task` wrote to `path`.
fn read_cells(path: &Path, window: Region, task: usize) -> Result<Vec<f32>, WorldError> {
    let bytes = std::fs::read(path)
        .map_err(|e| WorldError::Io(format!("{}: {e} (run task {task} first)", path.display())))?;
    if bytes.len() != window.width * window.height * 4 {
        return Err(WorldError::Io(format!(
            "{} has {} bytes, not the {} of its {} x {} cells",
            path.display(),
            bytes.len(),
            window.width * window.height * 4,
            window.width,
            window.height
        )));
    }
    Ok(raw32(&bytes, window.width, window.height)?.into_vec())
}

/// A `w x h` field from the RAW R32 bytes the tasks write (their length checked before).
fn raw32(bytes: &[u8], w: usize, h: usize) -> Result<Heightfield, WorldError> {
    crate::dem::raw32::read(bytes, false, Default::default(), Some((w, h)))
        .map(|dem| dem.field)
        .map_err(|e| WorldError::Io(e.to_string()))
}
