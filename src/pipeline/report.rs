//! What a run reports: the hydrology report (rivers, ridges, diffusion, drainage) with the
//! final terrain's size, range and checksum, and a section per later stage.

use serde::Serialize;

use super::{Blended, Detailed, Styled};
use crate::blend::BlockSolve;
use crate::erosion::{Eroded, ErosionReport};
use crate::heightfield::{Checksum, Heightfield};
use crate::jobs::{Cancelled, JobCtx};
use crate::terrain::{StageTime, TerrainReport};

/// What `strahler generate --report` writes and `window.strahler.generate` returns.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The hydrology report, with `size`, `height_range` and `checksum` of the final terrain
    /// and `stages` of every stage.
    #[serde(flatten)]
    pub terrain: TerrainReport,
    /// FNV-1a of the terrain after the hydrology stage (before erosion, detail and blocks).
    pub hydrology_checksum: String,
    pub erosion: Option<ErosionReport>,
    pub style: Option<StyleReport>,
    pub detail: Option<DetailReport>,
    pub blend: Option<BlendReport>,
    /// The final terrain's realism measures, when the run asked for them.
    pub realism: Option<crate::realism::RealismReport>,
}

#[derive(Clone, Debug, Serialize)]
pub struct StyleReport {
    #[serde(flatten)]
    pub stats: crate::wavelet::style::StyleStats,
    pub millis: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct DetailReport {
    pub width: usize,
    pub height: usize,
    pub backend: &'static str,
    pub millis: f64,
    /// RMS of the synthetic detail where the mask leaves it, metres.
    pub rms_unmasked: f64,
    /// RMS under the mask (`None` without one).
    pub rms_masked: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct BlendReport {
    pub blocks: usize,
    pub backend: &'static str,
    pub millis: f64,
    pub converged: bool,
    pub solves: Vec<BlockSolve>,
}

/// The outputs of the stages after hydrology that a run used.
pub(super) struct Later<'a> {
    pub eroded: Option<&'a Eroded>,
    pub styled: Option<&'a Styled>,
    pub detailed: Option<&'a Detailed>,
    pub blended: Option<&'a Blended>,
}

impl Report {
    /// The report of a run whose final terrain is `field`. O(cells) for the checksum and
    /// range, with the job's ticks between slices.
    pub(super) async fn new(
        hydrology: &TerrainReport,
        later: Later<'_>,
        field: &Heightfield,
        stages: Vec<StageTime>,
        ctx: &JobCtx,
    ) -> Result<Self, Cancelled> {
        let Later {
            eroded,
            styled,
            detailed,
            blended,
        } = later;
        let mut terrain = hydrology.clone();
        terrain.stages = stages;
        terrain.size = field.width();
        let mut checksum = Checksum::default();
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for part in field.data().chunks(1 << 16) {
            ctx.tick(0.99, "terrain report").await?;
            checksum.add(part);
            for &v in part.iter().filter(|v| v.is_finite()) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        terrain.checksum = checksum.hex();
        terrain.height_range = if lo <= hi { [lo, hi] } else { [0.0, 0.0] };
        if let Some(e) = eroded {
            terrain.drainage = e.report.drainage.clone();
        }
        if let Some(s) = styled {
            terrain.drainage = s.drainage.clone();
        }
        Ok(Self {
            terrain,
            hydrology_checksum: hydrology.checksum.clone(),
            erosion: eroded.map(|e| e.report.clone()),
            style: styled.map(|s| StyleReport {
                stats: s.stats,
                millis: s.millis,
            }),
            detail: detailed.map(|d| DetailReport {
                width: d.field.width(),
                height: d.field.height(),
                backend: d.backend,
                millis: d.millis,
                rms_unmasked: d.rms.unmasked,
                rms_masked: d.rms.masked,
            }),
            blend: blended.map(|b| BlendReport {
                blocks: b.solves.len(),
                backend: b.backend,
                millis: b.millis,
                converged: b.solves.iter().all(|s| s.converged),
                solves: b.solves.clone(),
            }),
            realism: None,
        })
    }
}
