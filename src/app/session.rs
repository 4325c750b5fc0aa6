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
    job: Option<JobHandle<Result<Arrived, PipelineError>>>,
    output: Option<Output>,
}

impl Session {
    /// A session on `scene`, its history starting there; the first poll runs it.
    pub fn new(scene: Scene) -> Self {
        Self::restored(scene, Vec::new())
    }

    /// A session on `scene` with `undo` steps before it (oldest first), as an earlier visit
    /// left them.
    pub fn restored(scene: Scene, undo: Vec<Scene>) -> Self {
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
            job: None,
            output: None,
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

    /// Runs again at the next poll even if nothing changed (the Generate button).
    pub fn regenerate(&mut self) {
        self.submitted = None;
    }

    /// The next run is at the full grid size (with Preview on, edits use a smaller one).
    pub fn generate_full_size(&mut self) {
        self.full_size = true;
        self.submitted = None;
    }

    /// Whether the scene or the settings differ from the last run's.
    pub fn needs_run(&self) -> bool {
        self.submitted.as_ref().is_none_or(|s| {
            s.settings != self.settings || (s.revision != self.revision && s.scene != self.scene)
        })
    }

    /// Whether a run is going or due.
    pub fn busy(&self) -> bool {
        self.job.is_some() || self.needs_run()
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
            match result {
                Ok(arrived) => {
                    let Arrived {
                        pipeline,
                        output,
                        shown,
                    } = arrived;
                    self.pipeline = pipeline;
                    self.output = Some(output);
                    events.push(Event::Finished(shown));
                }
                Err(err) if err.is_cancelled() => {}
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
        } else if let Some(submitted) = &mut self.submitted {
            // Edits that changed nothing: remember so, not to compare again next frame.
            submitted.revision = self.revision;
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
        self.submitted = Some(Submitted {
            revision: self.revision,
            scene: self.scene.clone(),
            settings: self.settings.clone(),
        });
        let full_size = std::mem::take(&mut self.full_size);
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
        let scene = self.scene.clone();
        let mut options = RunOptions {
            size: scene.size,
            solver: self.settings.solver.method(),
            realism: self.settings.measure_realism,
        };
        if self.settings.preview && !full_size {
            options.size = options.size.min(PREVIEW_SIZE);
        }
        let mut pipeline = self.pipeline.clone();
        let spawned = crate::jobs::spawn(
            "terrain",
            move |job| async move {
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
