//! `strahler info`: version, GPU adapter, limits, and optionally the compute self-test.

use std::fmt::Write as _;

use clap::Args;
use serde::Serialize;

use crate::compute::ComputePath;
use crate::diffusion::selftest::{self, SelfTest};
use crate::gpu::{AdapterSummary, Capabilities};
use crate::jobs::JobCtx;

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Also run the demo diffusion on the CPU and the GPU and compare them.
    #[arg(long)]
    pub check: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct InfoReport {
    version: &'static str,
    compute: String,
    compute_path: String,
    adapter: Option<AdapterSummary>,
    capabilities: Option<Capabilities>,
    no_gpu_reason: Option<String>,
    check: Option<SelfTest>,
}

pub fn run(args: &InfoArgs) -> Result<(), Box<dyn std::error::Error>> {
    let path = super::compute_path(crate::compute::BackendChoice::Auto);
    let check = if args.check {
        Some(pollster::block_on(selftest::run(
            &path,
            &JobCtx::detached(),
        ))?)
    } else {
        None
    };
    let report = InfoReport {
        version: crate::VERSION,
        compute: path.key(),
        compute_path: path.to_string(),
        adapter: path.gpu().map(|g| g.adapter.clone()),
        capabilities: path.gpu().map(|g| g.caps.clone()),
        no_gpu_reason: match &path {
            ComputePath::Cpu { reason } => Some(reason.to_string()),
            ComputePath::Gpu { .. } => None,
        },
        check,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", render_text(&report));
    }
    Ok(())
}

fn render_text(r: &InfoReport) -> String {
    let mut out = String::new();
    let mib = |bytes: u64| format!("{} MiB", bytes >> 20);
    let _ = writeln!(out, "strahler {}", r.version);
    let _ = writeln!(out, "compute path: {}", r.compute_path);
    match (&r.adapter, &r.capabilities) {
        (Some(a), Some(c)) => {
            let _ = writeln!(out, "GPU adapter: {}", a.name);
            let _ = writeln!(out, "  backend:     {}", a.backend);
            let _ = writeln!(out, "  device type: {}", a.device_type);
            let _ = writeln!(out, "  driver:      {}", a.driver);
            let _ = writeln!(out, "limits:");
            let rows = [
                ("max buffer size", mib(c.max_buffer_size)),
                (
                    "max storage buffer binding size",
                    mib(c.max_storage_buffer_binding_size),
                ),
                (
                    "square f32 field in one binding",
                    format!("{0} x {0}", c.max_square_field()),
                ),
                (
                    "storage buffers per stage",
                    c.max_storage_buffers_per_shader_stage.to_string(),
                ),
                (
                    "max workgroup size (x, y)",
                    format!(
                        "{} x {}",
                        c.max_compute_workgroup_size_x, c.max_compute_workgroup_size_y
                    ),
                ),
                (
                    "max invocations per workgroup",
                    c.max_compute_invocations_per_workgroup.to_string(),
                ),
                (
                    "max workgroups per dimension",
                    c.max_compute_workgroups_per_dimension.to_string(),
                ),
                (
                    "timestamp queries (GPU time)",
                    if c.timestamp_query { "yes" } else { "no" }.to_owned(),
                ),
            ];
            for (name, value) in rows {
                let _ = writeln!(out, "  {name:<32} {value}");
            }
        }
        _ => {
            let reason = r.no_gpu_reason.as_deref().unwrap_or("unknown");
            let _ = writeln!(out, "GPU adapter: none ({reason})");
        }
    }
    if let Some(check) = &r.check {
        let _ = writeln!(
            out,
            "self-test: demo diffusion {0} x {0}, {1} Jacobi sweeps",
            check.size, check.sweeps
        );
        let _ = writeln!(out, "  {:<8} {:>10} {:>18}", "backend", "ms", "checksum");
        for run in std::iter::once(&check.cpu).chain(check.gpu.as_ref()) {
            let _ = writeln!(
                out,
                "  {:<8} {:>10.1} {:>18}",
                run.backend, run.millis, run.checksum
            );
        }
        if let (Some(abs), Some(rel)) = (check.max_abs_diff, check.relative_diff) {
            let _ = writeln!(
                out,
                "  GPU vs CPU: max |difference| {abs:.3e} m ({rel:.2e} of the height range)"
            );
        }
    }
    out
}
