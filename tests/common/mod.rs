//! Shared helpers for the integration tests.

pub mod app;

use strahler::gpu::GpuContext;

/// A headless GPU for tests. On CI `STRAHLER_REQUIRE_GPU=1` is set and lavapipe is installed,
/// so a missing adapter fails the test instead of skipping it; on a developer machine
/// without Vulkan the GPU half of a test is skipped with a message.
pub fn gpu() -> Option<GpuContext> {
    match pollster::block_on(GpuContext::headless()) {
        Ok(ctx) => Some(ctx),
        Err(err) => {
            assert!(
                std::env::var_os("STRAHLER_REQUIRE_GPU").is_none(),
                "STRAHLER_REQUIRE_GPU is set but no GPU was found: {err}"
            );
            eprintln!("skipping the GPU part: {err}");
            None
        }
    }
}
