//! The session: the document (the scene), its history, the pipeline with its stage cache, the
//! terrain job and the last output.
//!
//! Every change to the scene is an [`Edit`] applied here ([`Session::apply`]), whether the UI
//! or a script made it. A run starts whenever the scene or the run settings differ from what
//! was last submitted ([`Session::poll`]): there are no dirty flags to set and no field lists
//! to keep in step, so a field added to the scene re-runs the pipeline without a line here.
//! While a pointer gesture is in progress (a drag, a slider, a brush stroke) the run waits
//! for its end, so a drag is one run and one undo step.

use crate::compute::{Backend, BackendChoice, ComputePath};
use crate::diffusion::{Method, MultigridParams};
use crate::jobs::JobHandle;
use crate::pipeline::{Output, Pipeline, PipelineError, RunOptions};
use crate::scene::{Edit, EditError, Scene};

use super::arrived::{Arrived, Shown};
use super::history::History;

/// Side of the preview terrain: with Preview on, edits of a larger map regenerate at this
/// size and the full size is generated on demand.
pub const PREVIEW_SIZE: usize = 512;

/// Side of the coarse pass: an edit that has to recompute the terrain of a run at least
/// [`COARSE_FIRST_FROM`] cells a side first shows the terrain at this size (a sixteenth of
/// the cells of a 512^2 preview, so it comes in a fraction of its time), then the run's own.
pub const COARSE_SIZE: usize = 128;

/// Runs of at least this many cells a side go through a coarse pass first.
pub const COARSE_FIRST_FROM: usize = 4 * COARSE_SIZE;

/// Which run of an edit a terrain comes from (what the map says it shows).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Pass {
    /// At [`COARSE_SIZE`], while the run's own size is computed.
    Coarse,
    /// At [`PREVIEW_SIZE`], smaller than the scene (Preview on).
    Preview,
    /// At the scene's own size.
    Full,
}

/// The terrain on the map and the one coming to replace it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OnMap {
    /// Cells a side of the terrain on the map (before detail levels).
    pub size: usize,
    pub pass: Pass,
    /// Cells a side of the scene (of the full-size terrain).
    pub scene: usize,
    /// Cells a side of the run under way, if any.
    pub coming: Option<usize>,
}

impl OnMap {
    /// "map 128^2 (coarse), 512^2 coming", "map 512^2 (preview of 2048^2)", "map 512^2".
    pub fn words(&self) -> String {
        let what = match self.pass {
            Pass::Coarse => " (coarse)".to_owned(),
            Pass::Preview => format!(" (preview of {0}x{0})", self.scene),
            Pass::Full => String::new(),
        };
        let coming = self
            .coming
            .map_or(String::new(), |n| format!(", {n}x{n} coming"));
        format!("map {0}x{0}{what}{coming}", self.size)
    }
}

/// How runs are made: options of the session, not part of the document.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSettings {
    /// The diffusion solver and backend.
    pub solver: SolverSettings,
    /// Edits of a map larger than [`PREVIEW_SIZE`] regenerate at that size (fast); the full
    /// size is generated on demand.
    pub preview: bool,
    /// Each run measures the terrain's realism (the Realism section).
    pub measure_realism: bool,
}

impl Default for RunSettings {
    fn default() -> Self {
        Self {
            solver: SolverSettings::default(),
            preview: true,
            measure_realism: false,
        }
    }
}

/// What a run was started from: a newer scene or settings start another.
struct Submitted {
    /// The session's revision then: while it is unchanged, the scene is too.
    revision: u64,
    scene: Scene,
    settings: RunSettings,
}

/// How the diffusion stage solves and on what: run options, not part of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverSettings {
    /// Multigrid (converged) or the paper's fixed count of Jacobi sweeps.
    pub multigrid: bool,
    /// Residual tolerance of multigrid, as a fraction of the height range.
    pub tolerance: f32,
    /// Sweeps of the Jacobi method.
    pub sweeps: u32,
    pub backend: BackendChoice,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            multigrid: true,
            tolerance: MultigridParams::default().tolerance,
            sweeps: 5500,
            backend: BackendChoice::Auto,
        }
    }
}

impl SolverSettings {
    pub fn method(&self) -> Method {
        if self.multigrid {
            Method::Multigrid(MultigridParams {
                tolerance: self.tolerance,
                ..Default::default()
            })
        } else {
            Method::Jacobi {
                sweeps: self.sweeps,
            }
        }
    }
}

/// What happened to the session's runs since the last poll.
pub enum Event {
    /// A run started on the current scene.
    Started,
    /// A run finished: its output is the session's; this is what the UI shows of it.
    Finished(Box<Shown>),
    /// A run failed or could not start (the message says why, for the user).
    Failed(String),
}

pub struct Session {
    scene: Scene,
    /// Counts applied edits: what changed since a run or a commit is found without comparing
    /// whole scenes every frame.
    revision: u64,
    /// The revision the history last recorded.
    committed: u64,
    history: History,
    settings: RunSettings,
    pipeline: Pipeline,
    submitted: Option<Submitted>,
    /// The next run is at the full size even with Preview on.
    full_size: bool,
    /// Run again at the next poll, whether or not anything changed.
    rerun: bool,
    job: Option<JobHandle<Result<Arrived, PipelineError>>>,
    /// The size and pass of [`Self::job`].
    running: (usize, Pass),
    /// The run to start once the running coarse pass has finished.
    next: Option<Next>,
    output: Option<Output>,
    /// The pass [`Self::output`] came from.
    shown: Pass,
}

/// A run waiting for the coarse pass before it.
struct Next {
    options: RunOptions,
    backend: Backend,
    pass: Pass,
}

impl Session {
    /// A session on `scene`, its history starting there; the first poll runs it.
    pub fn new(scene: Scene) -> Self {
        Self::restored(scene, Vec::new())
    }

    /// A session on `scene` with `undo` steps before it (oldest first), as an earlier visit
    /// left them.
    pub fn restored(scene: Scene, undo: Vec<crate::scene::Patch>) -> Self {
        let mut history = History::default();
        history.start(scene.clone(), undo);
        Self {
            scene,
            revision: 0,
            committed: 0,
            history,
            settings: RunSettings::default(),
            pipeline: Pipeline::new(),
            submitted: None,
            full_size: false,
            rerun: false,
            job: None,
            running: (0, Pass::Full),
            next: None,
            output: None,
            shown: Pass::Full,
        }
    }

    /// The document.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Applies `edit` to the document (refused with the scene unchanged); the next poll runs
    /// the pipeline on it, and the history records it when the gesture ends.
    pub fn apply(&mut self, edit: Edit) -> Result<(), EditError> {
        self.scene.apply(edit)?;
        self.revision += 1;
        Ok(())
    }

    pub fn settings(&self) -> &RunSettings {
        &self.settings
    }

    /// The run settings; a change starts a run at the next poll.
    pub fn settings_mut(&mut self) -> &mut RunSettings {
        &mut self.settings
    }

    /// The last finished run.
    pub fn output(&self) -> Option<&Output> {
        self.output.as_ref()
    }

    /// The running terrain job, if any.
    pub fn job(&self) -> Option<&JobHandle<Result<Arrived, PipelineError>>> {
        self.job.as_ref()
    }

    /// What the map shows of the last finished run, and the size of the run under way.
    pub fn on_map(&self) -> Option<OnMap> {
        let output = self.output.as_ref()?;
        let coming = match (&self.job, &self.next) {
            (Some(_), _) => Some(self.running.0),
            (None, Some(next)) => Some(next.options.size),
            (None, None) => None,
        };
        Some(OnMap {
            size: output.hydrology.terrain.width(),
            pass: self.shown,
            scene: self.scene.size,
            coming,
        })
    }

    /// Stops the running job and the pass that would follow it; the map keeps what it shows.
    pub fn cancel(&mut self) {
        if let Some(job) = &self.job {
            job.cancel();
        }
        self.next = None;
    }

    /// Runs again at the next poll even if nothing changed (the Generate button).
    pub fn regenerate(&mut self) {
        self.rerun = true;
    }

    /// The next run is at the full grid size (with Preview on, edits use a smaller one).
    pub fn generate_full_size(&mut self) {
        self.full_size = true;
        self.rerun = true;
    }

    /// Whether a run was asked for, or the scene or the settings differ from the last run's.
    pub fn needs_run(&self) -> bool {
        self.rerun
            || self.submitted.as_ref().is_none_or(|s| {
                s.settings != self.settings
                    || (s.revision != self.revision && s.scene != self.scene)
            })
    }

    /// Whether a run is going or due.
    pub fn busy(&self) -> bool {
        self.job.is_some() || self.next.is_some() || self.needs_run()
    }

    /// Takes a finished run, and starts one when the document or the settings changed and
    /// no gesture is in progress (a newer run cancels a running one). `path` is where the
    /// app computes; `repaint` is called when a job has news.
    pub fn poll(
        &mut self,
        path: &ComputePath,
        gesture: bool,
        repaint: impl Fn() + Send + 'static,
    ) -> Vec<Event> {
        let mut events = Vec::new();
        if let Some(result) = self.job.as_ref().and_then(JobHandle::try_take) {
            self.job = None;
            let pass = self.running.1;
            match result {
                Ok(arrived) => {
                    let Arrived {
                        pipeline,
                        output,
                        shown,
                    } = arrived;
                    self.pipeline = pipeline;
                    self.output = Some(output);
                    self.shown = pass;
                    events.push(Event::Finished(shown));
                }
                Err(err) if err.is_cancelled() => self.next = None,
                // The run's own pass follows and says what is wrong, if anything is: a
                // coarse grid may fail where the real one works (a block of a few cells).
                Err(err) if pass == Pass::Coarse => log::info!("the coarse pass failed: {err}"),
                Err(err) => events.push(Event::Failed(format!("Terrain failed: {err}"))),
            }
        }
        if gesture {
            return events;
        }
        if self.needs_run() {
            events.push(match self.start(path, repaint) {
                Ok(()) => Event::Started,
                Err(message) => Event::Failed(message),
            });
            return events;
        }
        if let Some(submitted) = &mut self.submitted {
            // Edits that changed nothing: remember so, not to compare again next frame.
            submitted.revision = self.revision;
        }
        if self.job.is_none()
            && let Some(next) = self.next.take()
            && let Err(message) = self.spawn(next.options, next.backend, next.pass, repaint)
        {
            events.push(Event::Failed(message));
        }
        events
    }

    /// Runs the pipeline on the scene, cancelling a running job (a newer edit always wins).
    /// The job works on a copy of the stage cache (the outputs are shared, not copied) and
    /// hands the updated cache back with its result.
    fn start(
        &mut self,
        path: &ComputePath,
        repaint: impl Fn() + Send + 'static,
    ) -> Result<(), String> {
        let edited = self
            .submitted
            .as_ref()
            .is_none_or(|s| s.scene != self.scene);
        self.submitted = Some(Submitted {
            revision: self.revision,
            scene: self.scene.clone(),
            settings: self.settings.clone(),
        });
        let full_size = std::mem::take(&mut self.full_size);
        self.rerun = false;
        self.next = None;
        if self.scene.rivers.is_empty() && self.scene.sketch.is_empty() {
            self.job = None;
            return Err(
                "Draw a river to make terrain: choose Draw river and drag on the map.".into(),
            );
        }
        let backend: Backend = self
            .settings
            .solver
            .backend
            .resolve(path)
            .map_err(|err| err.to_string())?;
        let mut options = RunOptions {
            size: self.scene.size,
            solver: self.settings.solver.method(),
            realism: self.settings.measure_realism,
        };
        let mut pass = Pass::Full;
        if self.settings.preview && !full_size && options.size > PREVIEW_SIZE {
            options.size = PREVIEW_SIZE;
            pass = Pass::Preview;
        }
        // An edit whose terrain must be computed anew shows a coarse one first; a run of the
        // scene on the map (Generate, full size, other settings) replaces it directly.
        let coarse_first = edited
            && options.size >= COARSE_FIRST_FROM
            && !self
                .pipeline
                .has_terrain_for(&self.scene, &options, &backend);
        if coarse_first {
            self.next = Some(Next {
                options,
                backend: backend.clone(),
                pass,
            });
            let coarse = RunOptions {
                size: COARSE_SIZE,
                realism: false,
                ..options
            };
            return self.spawn(coarse, backend, Pass::Coarse, repaint);
        }
        self.spawn(options, backend, pass, repaint)
    }

    /// Starts the terrain job of one pass, cancelling a running one.
    fn spawn(
        &mut self,
        options: RunOptions,
        backend: Backend,
        pass: Pass,
        repaint: impl Fn() + Send + 'static,
    ) -> Result<(), String> {
        let scene = self.scene.clone();
        let mut pipeline = self.pipeline.clone();
        self.running = (options.size, pass);
        let coarse = pass == Pass::Coarse;
        let spawned = crate::jobs::spawn(
            "terrain",
            move |job| async move {
                // The coarse pass (128^2: tens of milliseconds on the page's thread, its
                // diffusion and erosion in the Web Worker) does not yield between its steps:
                // where the page is composited in software each yield let a repaint of over
                // 100 ms in before the next step.
                let job = if coarse { job.unyielding() } else { job };
                // One bar: the stages, then the map's picture (a few per cent of a run).
                let stages = job.part(0.0, 0.95);
                let output = pipeline.run(&scene, &options, &backend, &stages).await?;
                Arrived::prepare(pipeline, output, &job.part(0.95, 1.0)).await
            },
            repaint,
        );
        // Replacing the handle drops (and so cancels) a stale job.
        self.job = Some(spawned.map_err(|err| err.to_string())?);
        Ok(())
    }

    /// Records the document in the history once a gesture is over (a drag or a brush stroke
    /// is one step). Returns the undo and redo depths when they changed.
    pub fn commit(&mut self, gesture: bool) -> Option<(usize, usize)> {
        if gesture || self.committed == self.revision {
            return None;
        }
        self.committed = self.revision;
        self.history.commit(&self.scene)
    }

    /// Back (`back`) or forward one step; false when there is no step that way.
    pub fn step_history(&mut self, back: bool) -> bool {
        let Some(scene) = self.history.step(back) else {
            return false;
        };
        self.scene = scene;
        self.revision += 1;
        // The step is the history's own doing, not a new edit to record.
        self.committed = self.revision;
        true
    }

    pub fn can_undo(&self) -> bool {
        self.history.can_undo()
    }

    pub fn can_redo(&self) -> bool {
        self.history.can_redo()
    }

    /// Undo and redo steps available.
    pub fn history_depths(&self) -> (usize, usize) {
        self.history.depths()
    }

    /// Saves the document to browser storage when it is due (web only); `Some` says why it
    /// failed, for the user. `wake` asks for a frame when the next save will be due.
    pub fn autosave(&mut self, wake: impl FnOnce(std::time::Duration)) -> Option<String> {
        self.history.autosave(wake)
    }
}
