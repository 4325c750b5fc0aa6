//! Poisson blending of real terrain into the synthetic terrain (seed paper 000, Sec. VI,
//! Algorithm 1).
//!
//! The user picks a reference block R on an uploaded DEM ([`guide`]), transforms it (height
//! scale, horizontal scale by resampling, quarter turns, mirror), and places it on the map;
//! [`poisson::solve_block`] then solves the block from eq. 9 with the synthetic terrain S on
//! its frame, so R's features appear and its edges meet S without a seam. Several blocks
//! per scene are solved one after the other ([`apply_blocks`]), each on the result of the
//! previous ones; the scene keeps each block's reference so it re-solves after a reload.

pub mod block;
pub mod guide;
pub mod on_gpu;
pub mod poisson;

use thiserror::Error;

pub use block::BlendBlock;
pub use guide::Transform;
pub use poisson::{BlockSolve, solve_block};

use crate::compute::Backend;
use crate::diffusion::{DiffusionError, MultigridParams};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// Why a block could not be blended.
#[derive(Debug, Error)]
pub enum BlendError {
    #[error(
        "the block (row {row}, col {col}, {height} x {width}) does not fit the {map_height} x \
         {map_width} terrain"
    )]
    BlockOutside {
        row: usize,
        col: usize,
        height: usize,
        width: usize,
        map_height: usize,
        map_width: usize,
    },
    #[error("a block needs at least 3 x 3 cells, got {height} x {width}")]
    TooSmall { height: usize, width: usize },
    #[error(
        "the reference window (row {row}, col {col}, {height} x {width}) does not fit the \
         {ref_height} x {ref_width} reference"
    )]
    WindowOutside {
        row: usize,
        col: usize,
        height: usize,
        width: usize,
        ref_height: usize,
        ref_width: usize,
    },
    #[error("the guidance is {}x{} but the block is {}x{}", guide.0, guide.1, block.0, block.1)]
    GuideSize {
        guide: (usize, usize),
        block: (usize, usize),
    },
    #[error(
        "the reference has no data at block row {row}, col {col}: fill its voids first \
         (strahler fill, or Fill voids in the DEM panel)"
    )]
    ReferenceVoid { row: usize, col: usize },
    #[error("the terrain has no data at row {row}, col {col} on the block's boundary")]
    TargetVoid { row: usize, col: usize },
    #[error("the block covers the whole map, so no terrain is left to blend into: make it smaller")]
    NoBoundary,
    #[error("block {index} ({name}): {problem}")]
    Block {
        index: usize,
        name: String,
        problem: String,
    },
    #[error(transparent)]
    Diffusion(#[from] DiffusionError),
}

/// A block of the terrain in cells: top-left (`row`, `col`), row 0 = north.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockRect {
    pub row: usize,
    pub col: usize,
    pub height: usize,
    pub width: usize,
}

impl BlockRect {
    /// Fails unless the block lies inside a `map_width` x `map_height` terrain and is at
    /// least 3 x 3 (one unknown inside a fixed frame).
    pub fn check_inside(&self, map_width: usize, map_height: usize) -> Result<(), BlendError> {
        if self.height < 3 || self.width < 3 {
            return Err(BlendError::TooSmall {
                height: self.height,
                width: self.width,
            });
        }
        let fits = self
            .row
            .checked_add(self.height)
            .is_some_and(|r| r <= map_height)
            && self
                .col
                .checked_add(self.width)
                .is_some_and(|c| c <= map_width);
        if !fits {
            return Err(BlendError::BlockOutside {
                row: self.row,
                col: self.col,
                height: self.height,
                width: self.width,
                map_height,
                map_width,
            });
        }
        Ok(())
    }
}

/// Blends every block of a scene into `terrain`, in order. O(sum of block cells).
pub async fn apply_blocks(
    backend: &Backend,
    terrain: &mut Heightfield,
    blocks: &[BlendBlock],
    ctx: &JobCtx,
) -> Result<Vec<BlockSolve>, BlendError> {
    let mut solves = Vec::with_capacity(blocks.len());
    for (index, block) in blocks.iter().enumerate() {
        let named = |e: BlendError| match e {
            BlendError::Diffusion(DiffusionError::Cancelled(c)) => {
                BlendError::Diffusion(DiffusionError::Cancelled(c))
            }
            other => BlendError::Block {
                index,
                name: block.name.clone(),
                problem: other.to_string(),
            },
        };
        let rect = block.rect_on(terrain.width(), terrain.height());
        let guide = block.guide(rect).map_err(named)?;
        let solve = solve_block(
            backend,
            terrain,
            rect,
            &guide,
            (&MultigridParams::default(), block.feather),
            ctx,
        )
        .await
        .map_err(named)?;
        solves.push(solve);
    }
    Ok(solves)
}
