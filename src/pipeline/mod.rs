//! One pipeline: a [`Scene`] in; the terrain, its layers and its report out.
//!
//! Every front end (the app's jobs, `strahler generate`, `window.strahler.generate`, the
//! export dialog and `exportHeightmap`) builds terrain through [`Pipeline::run`], so the same
//! scene gives the same terrain everywhere. The stages, in order:
//!
//! 1. **hydrology** ([`crate::terrain::generate`]): rivers, ridges, skeleton, MD/MDI
//!    enrichment, diffusion, post-filters, depression filling and the drainage check;
//! 2. **erosion** ([`crate::erosion`]): stream-power fluvial erosion with uplift and
//!    hillslope processes, the drawn rivers as base level (when the scene turns it on);
//! 3. **style** ([`crate::wavelet::style`]): detail from a real terrain's spectrum added
//!    into the existing levels where the terrain is smoother (when the scene has a style);
//! 4. **detail** ([`crate::wavelet`]): new wavelet levels under the painted mask;
//! 5. **blend** ([`crate::blend`]): the scene's DEM blocks, solved in order.
//!
//! A new stage is added here, in [`Pipeline::run`], with the scene fields it depends on in
//! its key.
//!
//! **Stage cache.** Each stage's output is kept with a key made of exactly the scene fields
//! (and run options) it depends on, plus the key of the stage before it; a run recomputes a
//! stage only when its key changed, so a mask stroke re-runs detail and blend, moving a block
//! re-runs blend, and a river edit re-runs everything. Outputs are shared ([`Arc`]), never
//! copied, between the cache, the app and the exports. Each map size (the preview and the
//! full size) keeps its own entries.
//!
//! **GPU copies.** A stage that ran on the GPU keeps its terrain there too (`gpu` in its
//! output, a [`GpuField`] that is the CPU field bit for bit), and the next GPU stage reads
//! that instead of uploading the CPU's field: the hydrology's or the GPU erosion's terrain
//! goes to the detail, the detail's to the blend, the last one to the 3D view
//! ([`Output::gpu`]). A stage on the CPU (style, erosion on the CPU) ends the chain.

mod cache;
mod export;
mod report;

use std::sync::Arc;

use thiserror::Error;
use web_time::Instant;

use crate::blend::{self, BlendError, BlockSolve};
use crate::compute::Backend;
use crate::diffusion::Method;
use crate::erosion::{self, Eroded};
use crate::gpu::{GpuContext, GpuError, GpuField};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::scene::{MaskKind, Scene, SceneError};
use crate::terrain::{self, Generated, StageTime, TerrainError, stage_seed};
use crate::wavelet::{self, AmplifyFailure, synthesis};

pub use cache::StageKey;
use cache::Stages;
pub use export::{ExportSource, HeightmapExport, LayerPng, encode_heightmap, encode_heightmap_in};
pub use report::{BlendReport, DetailReport, Report};

/// Why a run failed; every message names the stage.
#[derive(Debug, Error)]
pub enum PipelineError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Hydrology(#[from] TerrainError),
    #[error("erosion: {0}")]
    Erosion(String),
    #[error("style: {0}")]
    Style(String),
    #[error("detail: {0}")]
    Detail(String),
    #[error("blend: {0}")]
    Blend(String),
    #[error("cancelled")]
    Cancelled(#[from] Cancelled),
}

impl PipelineError {
    /// Whether the run was cancelled (a newer edit replaced it), not failed.
    pub fn is_cancelled(&self) -> bool {
        use crate::diffusion::DiffusionError;
        matches!(
            self,
            PipelineError::Cancelled(_)
                | PipelineError::Hydrology(TerrainError::Cancelled(_))
                | PipelineError::Hydrology(TerrainError::Diffusion(DiffusionError::Cancelled(_)))
        )
    }
}

/// What a run needs besides the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunOptions {
    /// Cells per side of this run (the scene's size, or a preview's).
    pub size: usize,
    /// How the diffusion stage solves (multigrid by default; Jacobi is the paper's baseline).
    pub solver: Method,
    /// Also measure the final terrain's realism (O(cells x 80): about 0.5 s per million
    /// cells natively), for the report.
    pub realism: bool,
}

impl RunOptions {
    /// The scene's own size, default solver.
    pub fn for_scene(scene: &Scene) -> Self {
        Self {
            size: scene.size,
            solver: Method::Multigrid(crate::diffusion::MultigridParams::default()),
            realism: false,
        }
    }
}

/// The wavelet detail stage's output.
#[derive(Debug)]
pub struct Detailed {
    pub field: Arc<Heightfield>,
    pub rms: synthesis::DetailRms,
    pub millis: f64,
    pub backend: &'static str,
    /// `field` on the GPU that made it (the GPU path).
    pub gpu: Option<GpuField>,
}

/// The style stage's output.
#[derive(Debug)]
pub struct Styled {
    pub field: Arc<Heightfield>,
    pub stats: wavelet::style::StyleStats,
    pub drainage: crate::terrain::Drainage,
    pub millis: f64,
}

/// The blend stage's output.
#[derive(Debug)]
pub struct Blended {
    pub field: Arc<Heightfield>,
    pub solves: Vec<BlockSolve>,
    pub millis: f64,
    pub backend: &'static str,
    /// `field` on the GPU the terrain before it was on, if it was there.
    pub gpu: Option<GpuField>,
}

/// A finished run: every stage's output (shared with the cache) and the final terrain.
#[derive(Clone, Debug)]
pub struct Output {
    pub hydrology: Arc<Generated>,
    pub erosion: Option<Arc<Eroded>>,
    pub style: Option<Arc<Styled>>,
    pub detail: Option<Arc<Detailed>>,
    pub blend: Option<Arc<Blended>>,
    /// The final terrain (the last stage's output).
    pub field: Arc<Heightfield>,
    /// [`Output::field`], bit for bit, on the backend's GPU, when the stages left it there
    /// (what the 3D view's GPU rasters start from instead of an upload).
    pub gpu: Option<GpuField>,
    /// Horizontal size of a cell of [`Output::field`] in metres.
    pub cell_m: f64,
    pub report: Report,
    /// The stages this run computed (the others came from the cache), in order.
    pub computed: Vec<&'static str>,
}

impl Output {
    /// The terrain after hydrology and erosion, before detail and blocks (what the mask and
    /// the skeleton's layers line up with).
    pub fn base(&self) -> &Heightfield {
        match &self.erosion {
            Some(e) => &e.field,
            None => &self.hydrology.terrain,
        }
    }
}

/// The pipeline with its stage cache. Cloning is cheap (the outputs are shared), so a job
/// can take a copy, run, and hand the updated cache back.
#[derive(Clone, Debug, Default)]
pub struct Pipeline {
    /// One set of cached stages per map size, most recently used first (at most three: the
    /// coarse pass, the preview and the full size).
    sizes: Vec<Stages>,
}

/// Map sizes whose stages are kept: the app's coarse pass, its preview and the full size.
const SIZES_KEPT: usize = 3;

impl Pipeline {
    pub fn new() -> Self {
        Self::default()
    }

    /// Runs every stage of `scene` at `options.size` on `backend`, reusing the cached
    /// outputs whose keys are unchanged. Cost: that of the stages recomputed (see each
    /// stage); a run with nothing changed is O(1) plus the report.
    pub async fn run(
        &mut self,
        scene: &Scene,
        options: &RunOptions,
        backend: &Backend,
        ctx: &JobCtx,
    ) -> Result<Output, PipelineError> {
        let sized = sized(scene, options.size);
        sized.validate()?;
        let scene = &sized;

        let position = self.sizes.iter().position(|s| s.size == options.size);
        let mut stages = match position {
            Some(i) => self.sizes.remove(i),
            None => Stages::new(options.size),
        };
        let result = run_stages(&mut stages, scene, options, backend, ctx).await;
        self.sizes.insert(0, stages);
        self.sizes.truncate(SIZES_KEPT);
        result
    }

    /// Whether a run of `scene` with `options` on `backend` would find its terrain (the
    /// hydrology and, when the scene erodes, the erosion) in the cache, so that only the
    /// later stages (style, detail, blocks), if any, would run. O(scene's JSON).
    pub fn has_terrain_for(&self, scene: &Scene, options: &RunOptions, backend: &Backend) -> bool {
        let Some(stages) = self.sizes.iter().find(|s| s.size == options.size) else {
            return false;
        };
        let scene = sized(scene, options.size);
        let key = hydrology_key(&scene, options, backend);
        let eroded = match &scene.erosion {
            Some(settings) => stages
                .erosion
                .get(erosion_key(key, settings, &scene.erosion_masks))
                .is_some(),
            None => true,
        };
        stages.hydrology.get(key).is_some() && eroded
    }
}

/// `scene` at `size` cells a side over the same map width.
fn sized(scene: &Scene, size: usize) -> Scene {
    let mut sized = scene.clone();
    sized.size = size;
    sized.cell_size = scene.map_width() / size.max(1) as f64;
    sized
}

/// The hydrology stage's key: the grid, the seed, the design and how it is solved.
fn hydrology_key(scene: &Scene, options: &RunOptions, backend: &Backend) -> StageKey {
    StageKey::start("hydrology")
        .with(&(scene.size, scene.cell_size, scene.seed))
        .with(&scene.rivers)
        .with(&scene.params)
        .with(&scene.sketch)
        .with(&format!("{:?}", options.solver))
        .with(&backend.key())
}

/// The erosion stage's key, after the hydrology's `key`: its settings and the masks painted
/// for it.
fn erosion_key(
    key: StageKey,
    settings: &erosion::ErosionSettings,
    masks: &crate::scene::ErosionMasks,
) -> StageKey {
    key.then("erosion").with(settings).with(masks)
}

/// The stages in the order they fill a run's progress bar.
#[derive(Clone, Copy)]
enum Bar {
    Hydrology,
    Erosion,
    Style,
    Detail,
    Blend,
    Report,
}

/// Each stage's span of a run's progress bar, in proportion to about its share of the time
/// (natively on the CPU at 512^2-2048^2, erosion takes most of a run and the terrain most of
/// the rest); stages the scene does not have take none. A stage found in the cache fills its
/// span at once.
fn bar_spans(scene: &Scene, options: &RunOptions) -> [(f32, f32); 6] {
    let on = |yes: bool, weight: f32| if yes { weight } else { 0.0 };
    let weights = [
        1.0,
        on(scene.erosion.is_some(), 3.0),
        on(scene.style.is_some(), 0.5),
        on(scene.detail.levels > 0, 0.5),
        on(!scene.blend.is_empty(), 0.5),
        0.05 + on(options.realism, 0.25),
    ];
    let total: f32 = weights.iter().sum();
    let mut from = 0.0;
    weights.map(|w| {
        let span = (from / total, (from + w) / total);
        from += w;
        span
    })
}

async fn run_stages(
    stages: &mut Stages,
    scene: &Scene,
    options: &RunOptions,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Output, PipelineError> {
    let mut computed = Vec::new();
    let mut times = Vec::new();
    let spans = bar_spans(scene, options);
    let part = |stage: Bar| {
        let (from, to) = spans[stage as usize];
        ctx.part(from, to)
    };

    // 1. Hydrology: everything up to the conditioned, drained terrain.
    let key = hydrology_key(scene, options, backend);
    let hydrology = match stages.hydrology.get(key) {
        Some(cached) => cached,
        None => {
            let mut params = scene.terrain_params();
            params.solver = options.solver;
            let ctx = &part(Bar::Hydrology);
            let generated = terrain::generate(&scene.strokes(), &params, backend, ctx).await?;
            computed.push("hydrology");
            stages.hydrology.put(key, generated)
        }
    };
    times.extend(hydrology.report.stages.iter().cloned());
    let mut field = hydrology.terrain.clone();
    // The terrain on the GPU too, while the GPU stages hand it on (the CPU stage, style,
    // and erosion on the CPU leave it on the CPU only).
    let mut on_gpu = hydrology.gpu.clone();
    let mut key = key;

    // 2. Erosion, on when the scene has an erosion section.
    let mut eroded = None;
    if let Some(settings) = &scene.erosion {
        key = erosion_key(key, settings, &scene.erosion_masks);
        let out = match stages.erosion.get(key) {
            Some(cached) => cached,
            None => {
                let clock = Instant::now();
                let ctx = &part(Bar::Erosion);
                ctx.checkpoint(0.0, "eroding").await?;
                let seed = stage_seed(scene.seed, "erosion");
                let uplift = scene.mask(MaskKind::Uplift)?;
                let hard_rock = scene.mask(MaskKind::HardRock)?;
                let painted = erosion::Painted {
                    uplift: uplift.as_ref(),
                    hard_rock: hard_rock.as_ref(),
                };
                let out = erosion::erode_terrain(
                    &hydrology,
                    settings,
                    painted,
                    scene.cell_size,
                    seed,
                    backend,
                    ctx,
                )
                .await
                .map_err(|e| match e {
                    erosion::StageError::Cancelled(c) => PipelineError::Cancelled(c),
                    other => PipelineError::Erosion(other.to_string()),
                })?;
                computed.push("erosion");
                let millis = clock.elapsed().as_secs_f64() * 1e3;
                // The report says it too: the Erosion section's "Eroded in ... ms" and
                // `generate --report` read it there.
                let report = erosion::ErosionReport {
                    millis,
                    ..out.report
                };
                stages.erosion.put(
                    key,
                    Eroded {
                        millis,
                        report,
                        ..out
                    },
                )
            }
        };
        on_gpu = out.gpu.clone();
        eroded = Some(follow(&mut field, &mut times, "erosion", out));
    }

    // 3. Style from real terrain.
    let mut styled = None;
    if let Some(settings) = &scene.style {
        key = key
            .then("style")
            .with(settings)
            .with(&scene.detail.mask_png);
        let out = match stages.style.get(key) {
            Some(cached) => cached,
            None => {
                let ctx = &part(Bar::Style);
                let out = style(scene, settings, &field, &hydrology, ctx).await?;
                computed.push("style");
                stages.style.put(key, out)
            }
        };
        styled = Some(follow(&mut field, &mut times, "style", out));
        on_gpu = None;
    }

    // 4. Wavelet detail under the painted mask.
    let mut detailed = None;
    if scene.detail.levels > 0 {
        key = key.then("detail").with(&scene.detail);
        let out = match stages.detail.get(key) {
            Some(cached) => cached,
            None => {
                let ctx = &part(Bar::Detail);
                let out = detail(scene, &field, on_gpu.as_ref(), backend, ctx).await?;
                computed.push("detail");
                stages.detail.put(key, out)
            }
        };
        on_gpu = out.gpu.clone();
        detailed = Some(follow(&mut field, &mut times, "detail", out));
    }

    // 5. Blocks of real terrain.
    let mut blended = None;
    if !scene.blend.is_empty() {
        key = key.then("blend").with(&scene.blend);
        let out = match stages.blend.get(key) {
            Some(cached) => cached,
            None => {
                let ctx = &part(Bar::Blend);
                let out = blend_blocks(scene, &field, on_gpu.as_ref(), backend, ctx).await?;
                computed.push("blend");
                stages.blend.put(key, out)
            }
        };
        on_gpu = out.gpu.clone();
        blended = Some(follow(&mut field, &mut times, "blend", out));
    }
    stages.forget_unused(
        scene.erosion.is_some(),
        styled.is_some(),
        detailed.is_some(),
        blended.is_some(),
    );

    let ctx = &part(Bar::Report);
    ctx.checkpoint(0.0, "terrain report").await?;
    let cell_m = scene.map_width() / field.width().max(1) as f64;
    let later = report::Later {
        eroded: eroded.as_deref(),
        styled: styled.as_deref(),
        detailed: detailed.as_deref(),
        blended: blended.as_deref(),
    };
    let mut report = Report::new(&hydrology.report, later, &field, times, ctx).await?;
    if options.realism {
        ctx.checkpoint(0.2, "measuring realism").await?;
        let mouths = &hydrology.skeleton.mouths;
        report.realism = Some(crate::realism::RealismReport::of_terrain(
            &field, cell_m, cell_m, mouths,
        ));
    }
    ctx.set_progress(1.0, "done");
    Ok(Output {
        hydrology,
        erosion: eroded,
        style: styled,
        detail: detailed,
        blend: blended,
        field,
        gpu: on_gpu,
        cell_m,
        report,
        computed,
    })
}

/// What every stage after hydrology hands on: its terrain and how long it took.
trait StageOutput {
    fn field(&self) -> &Arc<Heightfield>;
    fn millis(&self) -> f64;
}

macro_rules! stage_output {
    ($($t:ty),*) => {$(
        impl StageOutput for $t {
            fn field(&self) -> &Arc<Heightfield> {
                &self.field
            }
            fn millis(&self) -> f64 {
                self.millis
            }
        }
    )*};
}
stage_output!(Eroded, Styled, Detailed, Blended);

/// A stage's output becomes the terrain the next stage reads; its time joins the report.
fn follow<T: StageOutput>(
    field: &mut Arc<Heightfield>,
    times: &mut Vec<StageTime>,
    name: &'static str,
    out: Arc<T>,
) -> Arc<T> {
    times.push(StageTime {
        name,
        ms: out.millis(),
    });
    *field = out.field().clone();
    out
}

/// The style stage: the style's missing detail added into the terrain's own levels, faded
/// out near the rivers, sketched valleys and their banks and under the painted mask; river
/// cells keep their heights exactly; then depressions are filled and drainage measured.
async fn style(
    scene: &Scene,
    settings: &crate::scene::StyleSettings,
    field: &Heightfield,
    hydrology: &Generated,
    ctx: &JobCtx,
) -> Result<Styled, PipelineError> {
    let clock = Instant::now();
    ctx.checkpoint(0.92, "style from real terrain").await?;
    let kinds = &hydrology.skeleton.kinds;
    let near = erosion::nearest_channel(field, kinds);
    let mask = scene.mask(MaskKind::Detail)?;
    let keep = wavelet::style::Keep {
        distance: &near.distance,
        banks: scene.erosion.as_ref().map_or(1, |e| e.river_band) + 1,
        mask: mask.as_ref(),
    };
    let seed = stage_seed(scene.seed, "style");
    let (mut out, stats) =
        wavelet::style::apply(field, settings.gamma, settings.strength, &keep, seed)
            .map_err(|e| PipelineError::Style(e.to_string()))?;
    // The rivers stay exactly where the design put them.
    for ((v, &original), kind) in out.data_mut().iter_mut().zip(field.data()).zip(kinds) {
        if matches!(
            kind,
            crate::skeleton::CellKind::River | crate::skeleton::CellKind::Valley
        ) {
            *v = original;
        }
    }
    // Measured as the erosion measured it: the branches it shaped drain as branches.
    let shaped = match &scene.erosion {
        Some(e) => erosion::shaped_kinds(&hydrology.skeleton, e.relief),
        None => std::borrow::Cow::Borrowed(kinds.as_slice()),
    };
    let (_, drainage) = crate::terrain::drainage::condition_and_measure(
        &mut out,
        &shaped,
        &hydrology.skeleton.mouths,
        ctx,
    )
    .await?;
    Ok(Styled {
        field: Arc::new(out),
        stats,
        drainage,
        millis: clock.elapsed().as_secs_f64() * 1e3,
    })
}

/// The detail stage: new wavelet levels of `source` (seed paper 001) under the scene's mask,
/// interpolated along the source's valleys and crests ([`wavelet::directional`]; the detail's
/// RMS is measured before, on the synthesis). A GPU that cannot hold the output falls back to
/// the CPU rather than failing.
async fn detail(
    scene: &Scene,
    source: &Heightfield,
    on_gpu: Option<&GpuField>,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Detailed, PipelineError> {
    let params = scene.detail.params(stage_seed(scene.seed, "detail"));
    synthesis::check(source, &params).map_err(|e| PipelineError::Detail(e.to_string()))?;
    let mask = scene.mask(MaskKind::Detail)?;
    let n = synthesis::output_len(source.width(), params.levels);
    let backend = &backend.fitting(n, n);
    let clock = Instant::now();
    let out = wavelet::amplify_from(backend, source, on_gpu, &params, mask.as_ref(), ctx)
        .await
        .map_err(|e| match e {
            AmplifyFailure::Cancelled(c) => PipelineError::Cancelled(c),
            AmplifyFailure::Wavelet(w) => PipelineError::Detail(w.to_string()),
        })?;
    let mut millis = clock.elapsed().as_secs_f64() * 1e3;
    ctx.tick(0.97, "measuring the detail").await?;
    // Measured on the GPU beside the synthesis where the device runs the heavy stages; the
    // CPU's measure counts in the stage's time (the tick before it does not).
    let rms = match out.rms {
        Some(measured) => measured,
        None => {
            let clock = Instant::now();
            let rms = synthesis::detail_rms(source, &out.field, params.levels, mask.as_ref());
            millis += clock.elapsed().as_secs_f64() * 1e3;
            rms
        }
    };
    // The synthesis's linear interpolation, corrected along the source's valleys and crests
    // on either backend (on the CPU: one pass, from the source alone), so both give it.
    let clock = Instant::now();
    let mut field = out.field;
    let following = ctx.part(0.98, 1.0);
    wavelet::directional::correct_field(source, params.levels, &mut field, &following).await?;
    if let (Some(kept), Backend::Gpu(gpu)) = (&out.gpu, backend) {
        kept.write(gpu, field.data());
    }
    millis += clock.elapsed().as_secs_f64() * 1e3;
    Ok(Detailed {
        field: Arc::new(field),
        rms,
        millis,
        backend: backend.key(),
        gpu: out.gpu,
    })
}

/// The blend stage: every block of the scene solved into `terrain`, in order (seed 000,
/// Sec. VI, Algorithm 1). With `terrain` also on the backend's GPU (`on_gpu`), the result
/// stays there too ([`blend::on_gpu::follow`]); a GPU failure there only drops that copy.
async fn blend_blocks(
    scene: &Scene,
    terrain: &Heightfield,
    on_gpu: Option<&GpuField>,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Blended, PipelineError> {
    let clock = Instant::now();
    let mut field = terrain.clone();
    let solves = blend::apply_blocks(backend, &mut field, &scene.blend, ctx)
        .await
        .map_err(|e| match e {
            BlendError::Diffusion(crate::diffusion::DiffusionError::Cancelled(c)) => {
                PipelineError::Cancelled(c)
            }
            other => PipelineError::Blend(other.to_string()),
        })?;
    let mut gpu = None;
    if let (Some(before), Backend::Gpu(context)) = (on_gpu, backend) {
        let (w, h) = (field.width(), field.height());
        let rects: Vec<_> = scene.blend.iter().map(|b| b.rect_on(w, h)).collect();
        match blend::on_gpu::follow(context, before, &field, &rects).await {
            Ok(kept) => gpu = kept,
            Err(err) => log::warn!("the blended terrain stays on the CPU: {err}"),
        }
    }
    Ok(Blended {
        field: Arc::new(field),
        solves,
        millis: clock.elapsed().as_secs_f64() * 1e3,
        backend: backend.key(),
        gpu,
    })
}

/// Why the kernels could not be built ahead of time (the stage that needs one builds it, or
/// reports why, when it runs).
#[derive(Debug, Error)]
pub enum WarmError {
    #[error("building the GPU kernels: {0}")]
    Gpu(#[from] GpuError),
    #[error("cancelled")]
    Cancelled(#[from] Cancelled),
}

/// Builds every compute kernel the pipeline's GPU stages use on `gpu` (diffusion, the
/// post-filters and blending; the wavelet detail; erosion and depression filling), yielding
/// between them, so that the first run on the device, in the browser the first edit, does not
/// wait for them, whichever stages the user then runs there ("Compute on" auto or gpu).
/// Later calls cost a few map lookups.
pub async fn warm_kernels(gpu: &GpuContext, ctx: &JobCtx) -> Result<(), WarmError> {
    ctx.checkpoint(0.0, "building the GPU kernels").await?;
    crate::diffusion::warm_gpu(gpu).await?;
    ctx.checkpoint(0.5, "building the GPU kernels").await?;
    wavelet::gpu::warm(gpu).await?;
    ctx.checkpoint(0.8, "building the GPU kernels").await?;
    erosion::gpu::warm(gpu).await?;
    terrain::drainage::gpu::warm(gpu).await?;
    ctx.set_progress(1.0, "GPU kernels built");
    Ok(())
}

/// Runs `scene` once at its own size on `backend` (the command line and scripts).
pub async fn generate(
    scene: &Scene,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Output, PipelineError> {
    let options = RunOptions {
        realism: true,
        ..RunOptions::for_scene(scene)
    };
    Pipeline::new().run(scene, &options, backend, ctx).await
}

#[cfg(test)]
mod tests;
