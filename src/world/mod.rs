//! Worlds in tiles (issue 37): a terrain larger than one piece, built as independent tile
//! tasks any batch engine can run, with memory bounded by the tile, not the world.
//!
//! The plan ([`plan`]) builds the scene in one piece at a global size (2049^2 by default,
//! every stage of the pipeline: rivers, ridges, diffusion, erosion...), then adds levels of
//! wavelet detail above it (seed paper 001's GSA synthesis, each level doubling the
//! resolution) up to the world's size, refines the erosion there window by window
//! ([`refine`]), and cuts it into tiles. The tasks ([`task`]) run in stages: the global
//! build; each tile's window refined (the detail computed from the global build alone,
//! [`window`]: every cell a function of its global position); each tile blended from the
//! windows over it.
//!
//! What is exact and what is bounded:
//! - the global build: exact, one piece (the same bits as `strahler generate` at its size);
//! - the levels of detail: exact, each tile the bits of the whole map's synthesis with its
//!   interpolation corrected along the global build's valleys and crests
//!   ([`crate::wavelet::directional`], a function of the global build and the cell's
//!   position; with `--no-refine` the whole world is exact);
//! - the refinement: bounded, each window routing only its own water, the windows blended
//!   by a partition of unity (no seam; measured in docs/features.md);
//! - the depression filling (`--fill-depressions`, [`flood`]): exact, the tiled
//!   Priority-Flood of Barnes (2016), the one-piece fill bit for bit;
//! - not done: a diffusion refined per tile.

pub mod channels;
pub mod engine;
pub mod flood;
pub mod plan;
pub mod refine;
pub mod task;
pub mod window;

use thiserror::Error;

pub use plan::Plan;
pub use task::BuildDir;

/// Why a tiled build could not go on.
#[derive(Debug, Error)]
pub enum WorldError {
    /// A bad plan or argument, in words naming it.
    #[error("{0}")]
    Plan(String),
    /// A file could not be read or written, or is not what the plan expects.
    #[error("{0}")]
    Io(String),
    /// The global build failed.
    #[error("the global build: {0}")]
    Build(String),
}
