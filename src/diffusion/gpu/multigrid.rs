//! Driving `shaders/multigrid.wgsl`: the same FMG + V(2,2) algorithm as
//! `crate::diffusion::multigrid`, with every level's sweeps, restrictions and prolongations
//! on the GPU.
//!
//! The level hierarchy (constraint-aware restriction of the fixed cells and their heights) is
//! built once on the CPU in O(cells) and uploaded; all iterations run on the GPU. Each V-cycle
//! is one submission followed by a 4-byte readback of the residual (an `atomicMax` reduction),
//! awaited without blocking the browser; between cycles the job reports progress and honours
//! cancel. Memory: per level the unknowns, the right-hand side (not on the finest level of a
//! Laplace problem) and the fixed-cell bits.

use wgpu::util::DeviceExt;

use super::{WORKGROUP, bind, pipeline};
use crate::diffusion::multigrid::hierarchy::{self, Level};
use crate::diffusion::multigrid::{COARSEST_SWEEPS, MultigridParams, Solved, Stopping, Work};
use crate::diffusion::{Constraints, DiffusionError, fixed_height_range};
use crate::gpu::{GpuContext, GpuError, read_bytes, read_f32_buffer};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

const SHADER: &str = include_str!("../../../shaders/multigrid.wgsl");

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    fine_w: u32,
    fine_h: u32,
    coarse_w: u32,
    coarse_h: u32,
    colour: u32,
    has_rhs: u32,
    _pad: [u32; 2],
}

struct Pipelines {
    relax: wgpu::ComputePipeline,
    restrict: wgpu::ComputePipeline,
    prolong_add: wgpu::ComputePipeline,
    prolong_replace: wgpu::ComputePipeline,
    residual_max: wgpu::ComputePipeline,
    correction_max: wgpu::ComputePipeline,
}

/// One level's buffers and the bind groups of every operator that touches it.
struct GpuLevel {
    w: u32,
    h: u32,
    u: wgpu::Buffer,
    /// Relax with colour 0 and 1.
    relax: [wgpu::BindGroup; 2],
    /// Operators between this level and the next coarser one (absent on the coarsest).
    restrict: Option<wgpu::BindGroup>,
    prolong_add: Option<wgpu::BindGroup>,
    prolong_replace: Option<wgpu::BindGroup>,
}

impl GpuLevel {
    fn cells(&self) -> usize {
        (self.w * self.h) as usize
    }

    fn groups(&self) -> (u32, u32) {
        (self.w.div_ceil(WORKGROUP), self.h.div_ceil(WORKGROUP))
    }
}

pub(in crate::diffusion) async fn multigrid(
    gpu: &GpuContext,
    problem: &Constraints,
    params: &MultigridParams,
    ctx: &JobCtx,
) -> Result<Solved, DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    gpu.check_field(w, h)?;
    if problem.fixed().count() == 0 {
        return Err(DiffusionError::NoFixedCells);
    }
    let scale = fixed_height_range(problem).max(f32::MIN_POSITIVE);
    let device = &gpu.device;

    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("multigrid.wgsl"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let pipes = Pipelines {
        relax: pipeline(device, &module, "relax"),
        restrict: pipeline(device, &module, "restrict_residual"),
        prolong_add: pipeline(device, &module, "prolong_add"),
        prolong_replace: pipeline(device, &module, "prolong_replace"),
        residual_max: pipeline(device, &module, "residual_max"),
        correction_max: pipeline(device, &module, "correction_max"),
    };
    let cpu_levels = hierarchy::for_problem(problem, None);
    let (levels, checks, result) = upload(gpu, &pipes, &cpu_levels);
    drop(cpu_levels);
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }

    let finest = w * h;
    let mut stats = Work::default();
    let last = levels.len() - 1;

    // Full-multigrid start, one submission.
    let mut encoder = device.create_command_encoder(&Default::default());
    relax(&mut encoder, &pipes, &levels[last], COARSEST_SWEEPS);
    stats.add(levels[last].cells(), finest, COARSEST_SWEEPS);
    for l in (0..last).rev() {
        dispatch(
            &mut encoder,
            &pipes.prolong_replace,
            levels[l].prolong_replace.as_ref(),
            levels[l].groups(),
        );
        v_cycle(&mut encoder, &pipes, &levels, l, params, &mut stats, finest);
    }
    gpu.queue.submit([encoder.finish()]);

    let (residual, correction) = read_checks(gpu, &pipes, &levels, &checks, &result).await?;
    let mut stop = Stopping::new(params, scale, residual, correction);
    while stop.keep_going() {
        ctx.checkpoint(
            stop.progress(),
            &format!("multigrid on the GPU, {}", stop.describe()),
        )
        .await?;
        let mut encoder = device.create_command_encoder(&Default::default());
        v_cycle(&mut encoder, &pipes, &levels, 0, params, &mut stats, finest);
        gpu.queue.submit([encoder.finish()]);
        let (residual, correction) = read_checks(gpu, &pipes, &levels, &checks, &result).await?;
        stop.record(residual, correction);
    }
    let data = read_f32_buffer(gpu, &levels[0].u, finest).await?;
    ctx.set_progress(1.0, "multigrid: done");
    Ok(Solved {
        field: Heightfield::from_vec(w, h, data).map_err(|e| GpuError::Readback(e.to_string()))?,
        cycles: stop.cycles,
        fine_sweeps: stats.fine_sweeps,
        work_sweeps: stats.work_sweeps,
        residual: stop.residual,
        relative_residual: stop.relative_residual(),
        estimated_error: stop.relative_estimate(),
        converged: stop.converged(),
    })
}

/// Bind groups of the two reductions read after each cycle.
struct Checks {
    residual: wgpu::BindGroup,
    /// Over level 1's correction; absent when the finest level is the coarsest.
    correction: Option<wgpu::BindGroup>,
}

/// Creates every level's buffers and bind groups; returns them with the reductions' bind
/// groups and their result buffer.
fn upload(
    gpu: &GpuContext,
    pipes: &Pipelines,
    cpu: &[Level],
) -> (Vec<GpuLevel>, Checks, wgpu::Buffer) {
    let device = &gpu.device;
    let storage = |label: &str, data: &[u8], extra: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: data,
            usage: wgpu::BufferUsages::STORAGE | extra,
        })
    };
    let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    // Bound where a Laplace problem's finest level has no right-hand side (never read).
    let dummy = storage("no rhs", &[0u8; 16], wgpu::BufferUsages::empty());
    let result = storage("residual and correction max", &[0u8; 8], copy);
    let us: Vec<_> = cpu
        .iter()
        .map(|l| storage("u", bytemuck::cast_slice(&l.u), copy))
        .collect();
    let bs: Vec<Option<wgpu::Buffer>> = cpu
        .iter()
        .map(|l| (!l.b.is_empty()).then(|| storage("b", bytemuck::cast_slice(&l.b), copy)))
        .collect();
    let fixed: Vec<_> = cpu
        .iter()
        .map(|l| {
            storage(
                "fixed",
                bytemuck::cast_slice(l.fixed.words()),
                wgpu::BufferUsages::empty(),
            )
        })
        .collect();

    let mut residual_group = None;
    let mut correction_group = None;
    let mut levels = Vec::with_capacity(cpu.len());
    for (l, level) in cpu.iter().enumerate() {
        let coarse = cpu.get(l + 1);
        let make_params = |colour: u32| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("multigrid params"),
                contents: bytemuck::bytes_of(&Params {
                    fine_w: level.w as u32,
                    fine_h: level.h as u32,
                    coarse_w: coarse.map_or(0, |c| c.w as u32),
                    coarse_h: coarse.map_or(0, |c| c.h as u32),
                    colour,
                    has_rhs: u32::from(bs[l].is_some()),
                    _pad: [0; 2],
                }),
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        let params = [make_params(0), make_params(1)];
        let b = bs[l].as_ref().unwrap_or(&dummy);
        let relax = [0, 1].map(|c| {
            bind(
                device,
                &pipes.relax,
                &[(0, &params[c]), (1, &fixed[l]), (2, &us[l]), (3, b)],
            )
        });
        let (restrict, prolong_add, prolong_replace) = match coarse {
            Some(_) => {
                let coarse_b = bs[l + 1].as_ref().unwrap_or(&dummy);
                let base = [(0, &params[0]), (1, &fixed[l]), (2, &us[l])];
                (
                    Some(bind(
                        device,
                        &pipes.restrict,
                        &[base[0], base[1], base[2], (3, b), (4, coarse_b)],
                    )),
                    Some(bind(
                        device,
                        &pipes.prolong_add,
                        &[base[0], base[1], base[2], (4, &us[l + 1])],
                    )),
                    Some(bind(
                        device,
                        &pipes.prolong_replace,
                        &[base[0], base[1], base[2], (4, &us[l + 1])],
                    )),
                )
            }
            None => (None, None, None),
        };
        if l == 1 {
            correction_group = Some(bind(
                device,
                &pipes.correction_max,
                &[(0, &params[0]), (2, &us[1]), (5, &result)],
            ));
        }
        if l == 0 {
            residual_group = Some(bind(
                device,
                &pipes.residual_max,
                &[
                    (0, &params[0]),
                    (1, &fixed[0]),
                    (2, &us[0]),
                    (3, b),
                    (5, &result),
                ],
            ));
        }
        levels.push(GpuLevel {
            w: level.w as u32,
            h: level.h as u32,
            u: us[l].clone(),
            relax,
            restrict,
            prolong_add,
            prolong_replace,
        });
    }
    let checks = Checks {
        residual: residual_group.expect("the hierarchy has a finest level"),
        correction: correction_group,
    };
    (levels, checks, result)
}

fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::ComputePipeline,
    group: Option<&wgpu::BindGroup>,
    (x, y): (u32, u32),
) {
    let Some(group) = group else { return };
    let mut pass = encoder.begin_compute_pass(&Default::default());
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.dispatch_workgroups(x, y, 1);
}

/// `sweeps` red-black sweeps on `level`: each colour's threads cover half the columns.
fn relax(encoder: &mut wgpu::CommandEncoder, pipes: &Pipelines, level: &GpuLevel, sweeps: u32) {
    if sweeps == 0 {
        return;
    }
    let groups = (
        level.w.div_ceil(2).div_ceil(WORKGROUP),
        level.h.div_ceil(WORKGROUP),
    );
    let mut pass = encoder.begin_compute_pass(&Default::default());
    pass.set_pipeline(&pipes.relax);
    for _ in 0..sweeps {
        for colour in &level.relax {
            pass.set_bind_group(0, colour, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
    }
}

/// Encodes one V-cycle from level `top` (correction scheme, as on the CPU).
fn v_cycle(
    encoder: &mut wgpu::CommandEncoder,
    pipes: &Pipelines,
    levels: &[GpuLevel],
    top: usize,
    params: &MultigridParams,
    stats: &mut Work,
    finest: usize,
) {
    let last = levels.len() - 1;
    for l in top..last {
        relax(encoder, pipes, &levels[l], params.pre_sweeps);
        stats.add(levels[l].cells(), finest, params.pre_sweeps);
        dispatch(
            encoder,
            &pipes.restrict,
            levels[l].restrict.as_ref(),
            levels[l + 1].groups(),
        );
        encoder.clear_buffer(&levels[l + 1].u, 0, None);
    }
    relax(encoder, pipes, &levels[last], COARSEST_SWEEPS);
    stats.add(levels[last].cells(), finest, COARSEST_SWEEPS);
    for l in (top..last).rev() {
        dispatch(
            encoder,
            &pipes.prolong_add,
            levels[l].prolong_add.as_ref(),
            levels[l].groups(),
        );
        relax(encoder, pipes, &levels[l], params.post_sweeps);
        stats.add(levels[l].cells(), finest, params.post_sweeps);
    }
}

/// `max |r_i| / n_i` on the finest level and the largest coarse correction of the last
/// cycle, reduced on the GPU and read back (8 bytes).
async fn read_checks(
    gpu: &GpuContext,
    pipes: &Pipelines,
    levels: &[GpuLevel],
    checks: &Checks,
    result: &wgpu::Buffer,
) -> Result<(f32, f32), DiffusionError> {
    gpu.queue.write_buffer(result, 0, &[0u8; 8]);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    dispatch(
        &mut encoder,
        &pipes.residual_max,
        Some(&checks.residual),
        levels[0].groups(),
    );
    if let Some(level) = levels.get(1) {
        dispatch(
            &mut encoder,
            &pipes.correction_max,
            checks.correction.as_ref(),
            level.groups(),
        );
    }
    gpu.queue.submit([encoder.finish()]);
    let bytes = read_bytes(gpu, result, 8).await?;
    let word = |k: usize| {
        f32::from_bits(u32::from_le_bytes([
            bytes[k],
            bytes[k + 1],
            bytes[k + 2],
            bytes[k + 3],
        ]))
    };
    Ok((word(0), word(4)))
}
