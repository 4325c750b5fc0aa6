//! The jobs the app runs (the session's terrain runs, the GPU kernels at start, the compute
//! check) and what it does with their results, once per frame.

use egui::pos2;
use glam::DVec2;

use super::automation::{Command, JobStatus};
use super::{StrahlerApp, ViewKind, arrived, session};
use crate::jobs::JobHandle;

impl StrahlerApp {
    /// Runs the pipeline on the scene again, even if nothing changed (the Generate button).
    pub fn start_generate(&mut self, ctx: &egui::Context) {
        self.session.regenerate();
        self.poll_session(ctx);
    }

    /// Generates the terrain at the full grid size (with Preview on, edits use a smaller one).
    pub fn generate_full_size(&mut self, ctx: &egui::Context) {
        self.session.generate_full_size();
        self.poll_session(ctx);
    }

    /// Takes the session's finished run and starts the next one when the document changed;
    /// records the history and autosaves once no gesture is in progress.
    pub(super) fn poll_session(&mut self, ctx: &egui::Context) {
        let gesture = ctx.input(|i| i.pointer.any_down());
        if let Some((undo, redo)) = self.session.commit(gesture) {
            self.automation.update(|s| {
                s.undo = undo;
                s.redo = redo;
            });
        }
        let repaint = ctx.clone();
        let events = self.session.poll(&self.path, gesture, move || {
            repaint.request_repaint_after(super::ONE_FRAME)
        });
        for event in events {
            match event {
                session::Event::Started => self.automation.set_scene(self.scene()),
                session::Event::Finished(shown) => self.show_output(ctx, *shown),
                session::Event::Failed(message) => self.set_error(message),
            }
        }
        let wake = ctx.clone();
        if let Some(notice) = self
            .session
            .autosave(move |after| wake.request_repaint_after(after))
        {
            self.messages.notice = Some(notice);
        }
    }

    /// Whether the map shows a preview smaller than the chosen grid size.
    pub fn showing_preview(&self) -> bool {
        self.output()
            .is_some_and(|o| o.hydrology.terrain.width() < self.session.scene().size)
    }

    /// Builds the kernels of the GPU stages the chosen "Compute on" runs in the background,
    /// beside the first terrain, so the first edit finds them ready (in the browser, pipeline
    /// creation would otherwise fall in that edit's job). Nothing where the choice computes on
    /// the CPU: "auto" beside a software adapter (SwiftShader, lavapipe) runs every stage on
    /// the CPU, and building the kernels there only held the page at start. A later choice of
    /// "gpu" builds them then ([`Self::warm_kernels_for_the_choice`]).
    pub(super) fn start_warming_kernels(&mut self, ctx: &egui::Context) {
        let choice = self.session.settings().solver.backend;
        self.check.warmed_for = Some(choice);
        let Ok(crate::compute::Backend::Gpu(gpu)) = choice.resolve(&self.path) else {
            return;
        };
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "GPU kernels",
            move |job| async move {
                crate::pipeline::warm_kernels(&gpu, &job).await?;
                // The 3D view's kernels too, wherever it may make its maps on the GPU: built
                // (and so checked by the browser's compiler) at start, a few milliseconds.
                crate::view3d::gpu_maps::warm(&gpu).await?;
                Ok(())
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.check.kernels = Some(handle),
            Err(err) => log::warn!("the GPU kernels will be built on first use: {err}"),
        }
    }

    /// Builds the kernels of a "Compute on" choice made since the last were built (a script's
    /// `setCompute('gpu')`, the Advanced section), once the last build is done.
    fn warm_kernels_for_the_choice(&mut self, ctx: &egui::Context) {
        let choice = self.session.settings().solver.backend;
        if self.check.kernels.is_none() && self.check.warmed_for != Some(choice) {
            self.start_warming_kernels(ctx);
        }
    }

    /// Whether the GPU kernels are built (or the chosen backend needs none).
    pub fn kernels_ready(&self) -> bool {
        self.check.kernels.is_none()
    }

    /// Runs the CPU/GPU self-test in the background.
    pub fn start_selftest(&mut self, ctx: &egui::Context) {
        let path = self.path.clone();
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "self-test",
            move |job| async move { crate::diffusion::selftest::run(&path, &job).await },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.check.job = Some(handle),
            Err(err) => self.set_error(err.to_string()),
        }
    }

    /// The backend the diffusion settings (Advanced) ask for, or `None` after telling the user why
    /// there is none (the GPU was requested but does not compute).
    pub(super) fn backend(&mut self) -> Option<crate::compute::Backend> {
        match self.settings().backend.resolve(&self.path) {
            Ok(backend) => Some(backend),
            Err(err) => {
                self.set_error(err.to_string());
                None
            }
        }
    }

    pub(super) fn set_error(&mut self, message: String) {
        self.set_error_at(super::Place::Top, message);
    }

    /// An error of an action taken in the section at `place`: shown there and at the top.
    pub(super) fn set_error_at(&mut self, place: super::Place, message: String) {
        log::warn!("{message}");
        self.automation
            .update(|s| s.last_error = Some(message.clone()));
        self.messages.error = Some(message);
        self.messages.error_at = place;
        self.messages.errors += 1;
    }

    /// Puts a finished run on the map with its overlays and publishes its summaries.
    pub(super) fn show_output(&mut self, ctx: &egui::Context, shown: arrived::Shown) {
        let arrived::Shown {
            constraints,
            summary,
            picture,
            before,
            erosion_layers,
        } = shown;
        let Some(output) = self.session.output().cloned() else {
            return;
        };
        let g = &output.hydrology;
        let size = g.terrain.width();
        let r = &output.report.terrain;
        self.summaries.terrain = Some(format!(
            "{} river nodes, Strahler order {}, {} ridges; {:.1}% of river cells drain along \
             the river, {} pits",
            r.rivers.nodes,
            r.rivers.max_order,
            r.ridges.edges,
            r.drainage.river_fraction * 100.0,
            r.drainage.pit_cells
        ));
        let p = |v: DVec2| pos2(v.x as f32, v.y as f32);
        self.canvas.overlay.rivers = g
            .rivers
            .iter()
            .flat_map(|river| {
                let order = crate::river::stats::strahler_orders(&river.network);
                river
                    .network
                    .link_pairs()
                    .map(|(a, b)| {
                        (
                            p(river.network.nodes[a]),
                            p(river.network.nodes[b]),
                            order[b],
                        )
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        self.canvas.overlay.ridges = g
            .ridges
            .iter()
            .map(|r| (p(DVec2::from(r.a)), p(DVec2::from(r.b))))
            .collect();
        self.canvas.map.set_constraints(ctx, constraints);
        self.canvas.map.set_erosion_layers(ctx, erosion_layers);
        // The mask stays at the full size, whatever size this run had (the detail stage
        // resamples it), so a preview never blurs what the user painted.
        self.fit_mask(self.session.scene().size);
        self.canvas.map.set_mask(ctx, Some(&self.canvas.mask));
        self.show_detail_status(&output);
        self.show_blend_status(&output);
        let pass = self
            .session
            .on_map()
            .map_or(super::session::Pass::Full, |m| m.pass);
        self.automation
            .set_terrain(output.field.clone(), output.cell_m, pass);
        let realism = output.report.realism.clone();
        self.automation.update(|s| s.realism = realism);
        self.canvas.showing_before = self.panels.erosion.show_before && before.is_some();
        let shown = if self.canvas.showing_before {
            before.clone()
        } else {
            None
        };
        self.show_picture(ctx, shown.unwrap_or_else(|| picture.clone()));
        self.canvas.pictures = Some((picture, before));
        self.automation.update(|s| {
            s.last_run = Some(summary.clone());
            s.worker = super::status_bar::worker_words();
            s.threads = super::status_bar::worker_threads();
        });
        self.summaries.last_run = Some((size, summary));
        self.messages.error = None;
    }

    /// Applies one script command (number `number`, for the results it sends back).
    fn apply_command(&mut self, ctx: &egui::Context, number: u64, command: Command) {
        match command {
            Command::Edit(edit) => self.edit(edit),
            Command::MaskFromRivers => self.mask_from_rivers(ctx),
            Command::PaintMask(kind, a, b, brush) => {
                self.choose_mask(kind);
                self.canvas.mask.paint_segment(a, b, &brush);
                self.set_mask(ctx, self.canvas.mask.clone());
            }
            Command::LoadDem { name, bytes } => self.load_dem(ctx, &name, bytes),
            Command::RestoreDem { name, bytes } => self.restore_dem(ctx, &name, bytes),
            Command::ImportMask { name, bytes } => self.import_mask(ctx, &name, &bytes),
            Command::FillVoids => self.fill_dem_voids(ctx),
            Command::ExtractFeatures => self.extract_features(ctx),
            Command::PlaceBlock {
                window,
                rect,
                quarter_turns,
                mirror,
                z_scale,
                feather,
            } => {
                let transform = crate::blend::Transform {
                    quarter_turns,
                    mirror,
                    z_scale,
                };
                self.place_block(window, Some(rect), transform, feather)
            }
            Command::OpenScene { name, bytes } => self.open_scene(&name, &bytes),
            Command::Export(request) => self.export_for_script(ctx, *request, number),
            Command::FileRefused {
                name,
                message,
                place,
            } => self.set_error_at(place, format!("{name}: {message}")),
            Command::Undo => self.undo(),
            Command::Redo => self.redo(),
            Command::SetView(view) => self.set_view(view),
            // Refused as the Advanced section would refuse it: 'gpu' where nothing computes
            // on a GPU (a script may ask before the app has started, when the page could not
            // check it yet).
            Command::Compute(choice) => match choice.resolve(&self.path) {
                Ok(_) => self.session.settings_mut().solver.backend = choice,
                Err(err) => self.set_error(err.to_string()),
            },
            Command::View3dMaps(maps) => {
                self.set_view(ViewKind::ThreeD);
                self.view3d.set_maps(maps);
            }
            Command::SetCamera(request) => {
                self.set_view(ViewKind::ThreeD);
                self.view3d.request_camera(request);
            }
        }
    }

    /// Takes finished results and publishes job progress. Called once per frame.
    pub(super) fn poll_jobs(&mut self, ctx: &egui::Context) {
        let (commands, applied) = self.automation.take_commands();
        let scripted = !commands.is_empty();
        let first = applied + 1 - commands.len() as u64;
        for (number, command) in (first..).zip(commands) {
            let errors_before = self.messages.errors;
            self.apply_command(ctx, number, command);
            if self.messages.errors != errors_before
                && let Some(message) = &self.messages.error
            {
                self.automation.refuse(number, message.clone());
            }
        }
        if scripted {
            // Scripts see their edits in `scene()` once their promise resolves.
            self.automation.set_scene(self.scene());
        }
        self.automation.mark_applied(applied);
        if self.canvas.mask_overlay_stale {
            self.canvas.mask_overlay_stale = false;
            self.canvas.map.set_mask(ctx, Some(&self.canvas.mask));
        }
        if let Some((name, target, bytes)) = self
            .canvas
            .import_job
            .as_ref()
            .and_then(JobHandle::try_take)
        {
            self.canvas.import_job = None;
            match bytes {
                Ok(bytes) if target == super::canvas::ImportTarget::Mask => {
                    self.import_mask(ctx, &name, &bytes)
                }
                Ok(bytes) if target == super::canvas::ImportTarget::Scene => {
                    self.open_scene(&name, &bytes)
                }
                Ok(bytes) => self.load_dem(ctx, &name, bytes),
                Err(err) => {
                    let place = match target {
                        super::canvas::ImportTarget::Mask => super::Place::Mask,
                        super::canvas::ImportTarget::Dem => super::Place::Dem,
                        super::canvas::ImportTarget::Scene => super::Place::Top,
                    };
                    self.set_error_at(place, format!("{name}: {err}"))
                }
            }
        }
        self.take_filled_dem(ctx);
        self.take_features();
        self.take_exports();
        self.take_networks();
        // After the jobs whose results edit the scene (features, an opened file): a run of
        // the new scene starts in this frame, so a script waiting for the page to settle
        // never sees it idle with the scene changed and its terrain not yet started.
        self.poll_session(ctx);
        if let Some(result) = self.check.kernels.as_ref().and_then(JobHandle::try_take) {
            self.check.kernels = None;
            if let Err(err) = result {
                log::warn!("{err}; each stage builds its kernels when it first runs");
            }
        }
        self.warm_kernels_for_the_choice(ctx);
        if let Some(result) = self.check.job.as_ref().and_then(JobHandle::try_take) {
            self.check.job = None;
            self.check.result = Some(result.map_err(|err| err.to_string()));
        }
        // The first running job, in pipeline order, is the one scripts see.
        let job = job_status(&self.session.job())
            .or_else(|| job_status(&self.blend.fill_job.as_ref()))
            .or_else(|| job_status(&self.blend.features_job.as_ref()))
            .or_else(|| job_status(&self.check.job.as_ref()))
            .or_else(|| job_status(&self.export.running.first().map(|e| &e.job)));
        self.automation.update(|s| s.job = job);
        if self.busy() {
            // Keep the progress bar moving; results trigger a repaint when they land. In the
            // browser jobs share the main thread with painting, and a frame can cost 250 ms
            // where the page is composited in software (headless Chromium here), so the bar
            // moves at 2 Hz there and leaves the job its time; natively jobs have threads.
            let every = if cfg!(target_arch = "wasm32") {
                500
            } else {
                100
            };
            ctx.request_repaint_after(std::time::Duration::from_millis(every));
        }
    }
}

/// A running job's name, progress and message.
fn job_status<T>(job: &Option<&JobHandle<T>>) -> Option<JobStatus> {
    job.map(|j| JobStatus {
        name: j.name().to_owned(),
        progress: j.progress(),
        message: j.message(),
        seconds_left: j.time_left().map(|d| d.as_secs_f64()),
    })
}
