//! `strahler build`: a world larger than one piece (issue 37), as a plan and tile tasks any
//! batch engine can run ([`crate::world`]), assembled into one tiled BigTIFF with overviews.

use std::path::PathBuf;

use clap::Args;

use crate::export::preset::Engine;
use crate::jobs::JobCtx;
use crate::world::{BuildDir, Plan, task};

#[derive(Debug, Args)]
pub struct BuildArgs {
    /// The scene file (JSON, see docs/scene-format.md), or a plan (plan.json: the page's
    /// `worldPlan()`, or a build directory's own), which brings its size, tile and world.
    pub scene: PathBuf,
    /// Cells a side of the world (up to 65536); required with a scene file.
    #[arg(allow_hyphen_values = true, long)]
    pub size: Option<usize>,
    /// Cells a side of a tile, a multiple of 16 (64 to 8192) [default: 2048].
    #[arg(allow_hyphen_values = true, long)]
    pub tile: Option<usize>,
    /// Cells a side of the global build, the scene through every stage in one piece, which
    /// levels of wavelet detail take to --size [default: the largest up to 2049; 4097 for
    /// 32768].
    #[arg(allow_hyphen_values = true, long)]
    pub world: Option<usize>,
    /// The build's directory: its plan, the global build, the tiles and world.tif.
    #[arg(long)]
    pub out: PathBuf,
    /// Run this task only and stop: one task of a batch engine's array (--plan prints the
    /// stages: task 0, the global build; with refinement one task per tile's window; then
    /// one per tile; each stage needs the one before done). A finished task is skipped.
    #[arg(allow_hyphen_values = true, long)]
    pub task: Option<usize>,
    /// Do not refine the erosion at the world's resolution: the tiles are the global build
    /// and its levels of detail alone, every cell exact (half the tasks).
    #[arg(long)]
    pub no_refine: bool,
    /// Fill the world's depressions (flat lakes, as GIS tools' "fill sinks"), exactly, tile
    /// by tile (the tiled Priority-Flood of Barnes 2016): every cell then drains to the
    /// world's edge. Three more stages: a task per tile, one for the world, one per tile.
    #[arg(long)]
    pub fill_depressions: bool,
    /// Write the plan and print its number of tasks, nothing else.
    #[arg(long)]
    pub plan: bool,
    /// Assemble world.tif from the finished tiles, nothing else.
    #[arg(long)]
    pub assemble: bool,
    /// Print how far the build in --out has come (tasks done of all, world.tif or not),
    /// nothing else: for watching a batch engine's run.
    #[arg(long)]
    pub status: bool,
    /// Also write the world as an engine's tiles sharing their edges, on one height range,
    /// in DIR/engine with the numbers to type in: unreal, unity, godot, gaea-wm or gis. The
    /// world must be a whole number of tiles plus one vertex, and the engine must take
    /// tile + 1 vertices (--size 32257 --tile 2016: Unreal's tiles of 2017).
    #[arg(long)]
    pub engine: Option<String>,
}

pub fn run(args: &BuildArgs) -> Result<(), Box<dyn std::error::Error>> {
    let plan = plan_of(args)?;
    let engine = args
        .engine
        .as_deref()
        .map(|key| engine_for(key, &plan))
        .transpose()?;
    let dir = BuildDir::new(&args.out);
    let tasks = plan.tasks();
    if args.status {
        println!("{}", status_line(&dir, &plan));
        return Ok(());
    }
    task::write_plan(&dir, &plan)?;
    if args.plan {
        println!("{}", plan_line(&plan));
        return Ok(());
    }
    let ctx = JobCtx::detached();
    if let Some(k) = args.task {
        let started = web_time::Instant::now();
        let ran = pollster::block_on(task::run(&dir, &plan, k, &ctx))?;
        let how = if ran { "done" } else { "already done, skipped" };
        println!(
            "task {k} of {tasks}: {how} in {:.1} s",
            started.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    if !args.assemble {
        run_all(&dir, &plan, &ctx)?;
    }
    assemble(&dir, &plan)?;
    if let Some(engine) = engine {
        let tiles = pollster::block_on(crate::world::engine::write(&dir, &plan, engine, &ctx))?;
        println!(
            "{}: {} x {} {} tiles of {} vertices sharing their edges",
            dir.engine().display(),
            tiles.per_side,
            tiles.per_side,
            engine.label(),
            tiles.side
        );
        print!("{}", tiles.numbers.text());
    }
    Ok(())
}

/// The engine `--engine KEY` names, checked against the plan before any task runs.
fn engine_for(key: &str, plan: &Plan) -> Result<Engine, Box<dyn std::error::Error>> {
    let engine = Engine::from_key(key).ok_or_else(|| {
        let keys: Vec<&str> = Engine::ALL.iter().map(|e| e.key()).collect();
        format!(
            "--engine: unknown engine {key:?}; use one of {}",
            keys.join(", ")
        )
    })?;
    crate::world::engine::check(plan, engine)?;
    Ok(engine)
}

/// How far the build in `dir` has come: the tasks done, of each stage, and `world.tif`.
fn status_line(dir: &BuildDir, plan: &Plan) -> String {
    let stages: Vec<(usize, usize)> = plan
        .stages()
        .into_iter()
        .map(|(range, _)| {
            let all = range.clone().count();
            (range.filter(|&k| dir.done(plan, k)).count(), all)
        })
        .collect();
    let done: usize = stages.iter().map(|s| s.0).sum();
    let each: Vec<String> = stages
        .iter()
        .enumerate()
        .map(|(s, (of, all))| format!("stage {s} {of}/{all}"))
        .collect();
    let world = if dir.world_tif().is_file() {
        format!("{} written", dir.world_tif().display())
    } else {
        "world.tif not yet".into()
    };
    format!(
        "tasks done: {done} of {} ({}); {world}",
        plan.tasks(),
        each.join(", ")
    )
}

/// What the plan is: its tasks, world, tiles and levels in a line, then a line a stage
/// (`stage S: tasks A-B, what they do`), in the order they must run.
fn plan_line(plan: &Plan) -> String {
    let per = plan.tiles_per_side();
    let stages = plan.stages();
    let mut text = format!(
        "plan: {} tasks in {} stages, {}^2 cells in {per} x {per} tiles of {}, {} levels of \
         detail{}",
        plan.tasks(),
        stages.len(),
        plan.size,
        plan.tile,
        plan.levels,
        match (plan.refine, plan.fill) {
            (true, true) => ", the erosion refined per tile, the depressions filled",
            (true, false) => ", the erosion refined per tile",
            (false, true) => ", the depressions filled",
            (false, false) => "",
        }
    );
    for (s, (tasks, what)) in stages.iter().enumerate() {
        text.push_str(&format!(
            "\nstage {s}: tasks {}-{}, {what}",
            tasks.start(),
            tasks.end()
        ));
    }
    text
}

/// The plan the arguments ask for: from a plan file as it is (the flags may only repeat it),
/// or for a scene file at `--size` in tiles of `--tile`.
fn plan_of(args: &BuildArgs) -> Result<Plan, Box<dyn std::error::Error>> {
    const DEFAULT_TILE: usize = 2048;
    let text = std::fs::read_to_string(&args.scene)
        .map_err(|e| format!("{}: {e}", args.scene.display()))?;
    let looks_like_plan = serde_json::from_str::<serde_json::Value>(&text)
        .is_ok_and(|v| v.get("tile").is_some() && v.get("world").is_some());
    if looks_like_plan {
        let mut plan =
            Plan::from_json(&text).map_err(|e| format!("{}: {e}", args.scene.display()))?;
        if args.no_refine {
            plan = plan.without_refinement();
        }
        if args.fill_depressions {
            plan = plan.with_fill();
        }
        let differs = args.size.is_some_and(|s| s != plan.size)
            || args.tile.is_some_and(|t| t != plan.tile)
            || args.world.is_some_and(|w| w != plan.world);
        if differs {
            return Err(format!(
                "{} is a plan (size {}, tile {}, world {}): --size, --tile and --world may \
                 only repeat it",
                args.scene.display(),
                plan.size,
                plan.tile,
                plan.world
            )
            .into());
        }
        return Ok(plan);
    }
    let scene = super::generate::read_scene(&args.scene)?;
    let size = args
        .size
        .ok_or("--size: give the world's cells a side (a scene file has no world size)")?;
    let mut plan = Plan::new(&scene, size, args.tile.unwrap_or(DEFAULT_TILE), args.world)?;
    if args.no_refine {
        plan = plan.without_refinement();
    }
    if args.fill_depressions {
        plan = plan.with_fill();
    }
    Ok(plan)
}

/// Every task not yet done, in order, with the count, the stage and the time left on stderr.
fn run_all(dir: &BuildDir, plan: &Plan, ctx: &JobCtx) -> Result<(), Box<dyn std::error::Error>> {
    let tasks = plan.tasks();
    let stages = plan.stages();
    let stage_of = |k: usize| stages.iter().position(|(r, _)| r.contains(&k)).unwrap_or(0);
    let mut clock = StageClock::new(stages.len());
    for k in 0..tasks {
        let started = web_time::Instant::now();
        if pollster::block_on(task::run(dir, plan, k, ctx))? {
            clock.add(stage_of(k), started.elapsed().as_secs_f64());
        }
        let left = clock
            .left((k + 1..tasks).map(stage_of))
            .map_or(String::new(), |s| format!(", about {s:.0} s left"));
        eprintln!(
            "tasks {} of {tasks} done (stage {}){left}",
            k + 1,
            stage_of(k)
        );
    }
    Ok(())
}

/// The time the tasks of each stage took so far, for the time left: the stages' tasks take
/// different times (a refined window about three tiles), so each stage is timed alone.
struct StageClock {
    /// Seconds and tasks run, a stage.
    spent: Vec<(f64, usize)>,
}

impl StageClock {
    fn new(stages: usize) -> Self {
        Self {
            spent: vec![(0.0, 0); stages],
        }
    }

    fn add(&mut self, stage: usize, seconds: f64) {
        self.spent[stage].0 += seconds;
        self.spent[stage].1 += 1;
    }

    /// Seconds the tasks of these stages will take at the rates so far. A stage not timed
    /// yet goes at the latest timed stage's rate after the global build (one task of its
    /// own, no guide to the tiles'); `None` before any such stage has a task timed.
    fn left(&self, stages: impl Iterator<Item = usize>) -> Option<f64> {
        let rate = |(seconds, ran): (f64, usize)| (ran > 0).then(|| seconds / ran as f64);
        let latest = self.spent.iter().skip(1).rev().find_map(|&s| rate(s));
        let mut sum = 0.0;
        for s in stages {
            sum += rate(self.spent[s]).or(latest)?;
        }
        Some(sum)
    }
}

/// `world.tif` in the build's directory from the finished tiles.
fn assemble(dir: &BuildDir, plan: &Plan) -> Result<(), Box<dyn std::error::Error>> {
    let missing: Vec<usize> = (0..plan.tile_count())
        .map(|k| plan.final_task(k))
        .filter(|&k| !dir.done(plan, k))
        .collect();
    if let Some(first) = missing.first() {
        return Err(format!(
            "{} of {} tiles are not built yet (task {first} first): run their tasks, then \
             --assemble",
            missing.len(),
            plan.tile_count()
        )
        .into());
    }
    let leftovers = task::remove_leftovers(dir);
    if leftovers > 0 {
        eprintln!("removed {leftovers} temporary files that killed tasks left");
    }
    let cell_m = plan.cell_m();
    let width_m = plan.size as f64 * cell_m;
    let centre = plan.scene.location.map(|l| [l.lon, l.lat]);
    let georef = crate::export::map_georef(centre, width_m, cell_m, 0.0, 0.0);
    let per = plan.tiles_per_side();
    let path = dir.world_tif();
    let written = crate::dem::cog::write(
        &path,
        plan.size,
        plan.size,
        plan.tile,
        &georef,
        |row, col| {
            task::read_tile(dir, plan, row * per + col)
                .map_err(|e| crate::dem::DemError::Write(e.to_string()))
        },
    )?;
    task::remove_refined(dir);
    println!(
        "{}: {}^2 cells, tiled {} x {}, {} overviews, {:.1} MB",
        path.display(),
        plan.size,
        plan.tile,
        plan.tile,
        written.images - 1,
        written.bytes as f64 / 1e6
    );
    Ok(())
}
