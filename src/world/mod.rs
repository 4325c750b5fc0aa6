//! Worlds in tiles (issue 37): a terrain larger than one piece, built as independent tile
//! tasks any batch engine can run, with memory bounded by the tile, not the world.
//!
//! The plan ([`plan`]) builds the scene in one piece at a global size (2049^2 by default,
//! every stage of the pipeline: rivers, ridges, diffusion, erosion...), then adds levels of
//! wavelet detail above it (seed paper 001's GSA synthesis, each level doubling the
//! resolution) up to the world's size, cut into tiles. Each tile task ([`task`]) computes its
//! cells from the global build alone ([`window`]): every cell is a function of its global
//! position, so the tiles are seamless by construction and equal, bit for bit, the whole
//! world amplified in one piece.
//!
//! What is exact and what is bounded:
//! - the global build: exact, one piece (the same bits as `strahler generate` at its size);
//! - the levels of detail: exact, each tile the bits of the whole map's synthesis;
//! - the stages above the global build's resolution: not run per tile. Rivers, ridges,
//!   diffusion and erosion shape the world at the global build's cells (4.9 m on a 10 km map
//!   at 2049^2); finer than that the land is the wavelet detail of their statistics. A
//!   tiled diffusion and erosion refined per tile are the next step (docs/features.md).

pub mod engine;
pub mod plan;
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
