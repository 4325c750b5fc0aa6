//! The erosion stage as a parcel for the page's Web Worker ([`crate::jobs::worker`]): its
//! inputs and its result as owned arrays and a JSON header, so the stage (most of a run on
//! the page's CPU path) runs on another core while the page draws.
//!
//! The worker runs the same [`erode_field`] on the same numbers, so its result has the bits
//! the page's own thread would compute (a browser test checks them against the command
//! line's).

use serde::{Deserialize, Serialize};

use super::Painted;
use super::settings::ErosionSettings;
use super::stage::{Anchors, Eroded, ErosionReport, erode_field};
use crate::compute::Backend;
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::jobs::parcel::{Array, Parcel, ParcelError, sized};
use crate::skeleton::CellKind;
use crate::wavelet::Mask;

/// The `kind` of the erosion's worker calls.
pub const KIND: &str = "erosion";

/// The erosion's inputs, owned.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    pub field: Heightfield,
    pub kinds: Vec<CellKind>,
    pub held: Vec<u32>,
    pub mouths: Vec<u32>,
    pub trunk: Vec<u32>,
    pub order: Vec<u8>,
    pub heights: Vec<f32>,
    pub belt: Vec<(u32, f32)>,
    pub uplift: Option<Mask>,
    pub hard_rock: Option<Mask>,
    pub settings: ErosionSettings,
    pub cell_m: f64,
    pub seed: u64,
}

#[derive(Serialize, Deserialize)]
struct Header {
    settings: ErosionSettings,
    cell_m: f64,
    seed: u64,
    width: usize,
    height: usize,
    /// The painted masks' sizes, where painted.
    uplift: Option<[usize; 2]>,
    hard_rock: Option<[usize; 2]>,
}

impl Task {
    /// The inputs of [`erode_field`], copied.
    pub fn new(
        field: &Heightfield,
        kinds: &[CellKind],
        anchors: Anchors<'_>,
        settings: &ErosionSettings,
        cell_m: f64,
        seed: u64,
    ) -> Self {
        Self {
            field: field.clone(),
            kinds: kinds.to_vec(),
            held: anchors.held.to_vec(),
            mouths: anchors.mouths.to_vec(),
            trunk: anchors.trunk.to_vec(),
            order: anchors.order.to_vec(),
            heights: anchors.heights.to_vec(),
            belt: anchors.belt.to_vec(),
            uplift: anchors.painted.uplift.cloned(),
            hard_rock: anchors.painted.hard_rock.cloned(),
            settings: settings.clone(),
            cell_m,
            seed,
        }
    }

    /// The anchors over this task's arrays.
    fn anchors(&self) -> Anchors<'_> {
        Anchors {
            held: &self.held,
            mouths: &self.mouths,
            trunk: &self.trunk,
            order: &self.order,
            painted: Painted {
                uplift: self.uplift.as_ref(),
                hard_rock: self.hard_rock.as_ref(),
            },
            heights: &self.heights,
            belt: &self.belt,
        }
    }

    /// Erodes on this thread, on the CPU.
    pub async fn run(&self, ctx: &JobCtx) -> Result<Eroded, super::StageError> {
        erode_field(
            &self.field,
            &self.kinds,
            self.anchors(),
            &self.settings,
            self.cell_m,
            self.seed,
            &Backend::Cpu,
            ctx,
        )
        .await
    }

    pub fn into_parcel(self) -> Parcel {
        let size = |m: &Option<Mask>| m.as_ref().map(|m| [m.width(), m.height()]);
        let header = Header {
            settings: self.settings,
            cell_m: self.cell_m,
            seed: self.seed,
            width: self.field.width(),
            height: self.field.height(),
            uplift: size(&self.uplift),
            hard_rock: size(&self.hard_rock),
        };
        let (belt_cells, belt_depth): (Vec<u32>, Vec<f32>) = self.belt.into_iter().unzip();
        let mut parcel = Parcel::new(&header)
            .with(Array::F32(self.field.into_vec()))
            .with(Array::U8(self.kinds.iter().map(|k| *k as u8).collect()))
            .with(Array::U32(self.held))
            .with(Array::U32(self.mouths))
            .with(Array::U32(self.trunk))
            .with(Array::U8(self.order))
            .with(Array::F32(self.heights))
            .with(Array::U32(belt_cells))
            .with(Array::F32(belt_depth));
        for mask in [self.uplift, self.hard_rock].into_iter().flatten() {
            parcel = parcel.with(Array::F32(mask.values().to_vec()));
        }
        parcel
    }

    pub fn from_parcel(mut parcel: Parcel) -> Result<Self, ParcelError> {
        let header: Header = parcel.header()?;
        let cells = header.width * header.height;
        let field = sized("field", parcel.f32s()?, cells)?;
        let field = Heightfield::from_vec(header.width, header.height, field)
            .map_err(|e| ParcelError::Header(e.to_string()))?;
        let kinds = sized("kinds", parcel.u8s()?, cells)?
            .into_iter()
            .map(|code| {
                CellKind::from_code(code).ok_or(ParcelError::Header(format!("cell kind {code}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let held = parcel.u32s()?;
        let mouths = parcel.u32s()?;
        let trunk = parcel.u32s()?;
        let order = parcel.u8s()?;
        let heights = parcel.f32s()?;
        let belt_cells = parcel.u32s()?;
        let belt_depth = sized("belt", parcel.f32s()?, belt_cells.len())?;
        let mut mask = |size: Option<[usize; 2]>| -> Result<Option<Mask>, ParcelError> {
            let Some([w, h]) = size else { return Ok(None) };
            let values = sized("mask", parcel.f32s()?, w * h)?;
            Mask::from_values(w, h, values)
                .map(Some)
                .map_err(|e| ParcelError::Header(e.to_string()))
        };
        let uplift = mask(header.uplift)?;
        let hard_rock = mask(header.hard_rock)?;
        Ok(Self {
            field,
            kinds,
            held,
            mouths,
            trunk,
            order,
            heights,
            belt: belt_cells.into_iter().zip(belt_depth).collect(),
            uplift,
            hard_rock,
            settings: header.settings,
            cell_m: header.cell_m,
            seed: header.seed,
        })
    }
}

/// The eroded terrain as a parcel: its report in the header, the heights and the drainage
/// area as arrays (the GPU's copy never crosses: the worker erodes on the CPU).
pub fn result_into_parcel(eroded: Eroded) -> Parcel {
    let [w, h] = [eroded.field.width(), eroded.field.height()];
    Parcel::new(&(eroded.report, eroded.millis, [w, h]))
        .with(Array::F32(eroded.field.data().to_vec()))
        .with(Array::F32(eroded.drainage_area.data().to_vec()))
}

pub fn result_from_parcel(mut parcel: Parcel) -> Result<Eroded, ParcelError> {
    let (report, millis, [w, h]): (ErosionReport, f64, [usize; 2]) = parcel.header()?;
    let grid = |values: Vec<f32>| {
        Heightfield::from_vec(w, h, values).map_err(|e| ParcelError::Header(e.to_string()))
    };
    let field = grid(sized("heights", parcel.f32s()?, w * h)?)?;
    let drainage_area = grid(sized("drainage area", parcel.f32s()?, w * h)?)?;
    Ok(Eroded {
        field: field.into(),
        drainage_area: drainage_area.into(),
        report,
        millis,
        gpu: None,
    })
}

/// The worker's side of a call of [`KIND`]: decodes the task, erodes, encodes the result.
pub async fn serve(parcel: Parcel, ctx: JobCtx) -> Result<Parcel, String> {
    let task = Task::from_parcel(parcel).map_err(|e| e.to_string())?;
    let eroded = task.run(&ctx).await.map_err(|e| e.to_string())?;
    Ok(result_into_parcel(eroded))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::erosion::settings::Border;

    fn task() -> Task {
        let n = 24;
        let field = Heightfield::from_vec(
            n,
            n,
            (0..n * n)
                .map(|i| ((i % n) + 2 * (i / n)) as f32 * 3.7)
                .collect(),
        )
        .unwrap();
        let mut kinds = vec![CellKind::Free; n * n];
        for x in 0..n {
            kinds[x + n * (n / 2)] = CellKind::River;
        }
        let mut uplift = Mask::new(8, 8).unwrap();
        uplift.paint_segment(
            glam::DVec2::new(1.0, 1.0),
            glam::DVec2::new(6.0, 5.0),
            &crate::wavelet::Brush {
                radius: 2.0,
                hardness: 0.5,
                value: 1.0,
                eraser: false,
            },
        );
        Task {
            field,
            kinds,
            held: vec![3, 40],
            mouths: vec![],
            trunk: (0..n as u32).map(|x| x + (n * (n / 2)) as u32).collect(),
            order: vec![1; n * n],
            heights: vec![0.25; n * n],
            belt: vec![(5, 0.5)],
            uplift: Some(uplift),
            hard_rock: None,
            settings: ErosionSettings {
                steps: 3,
                border: Border::Closed,
                diffusivity: 0.1 + 0.2,
                ..ErosionSettings::default()
            },
            cell_m: 10_000.0 / 24.0,
            seed: u64::MAX - 5,
        }
    }

    #[test]
    fn a_task_crosses_as_a_parcel_unchanged() {
        let task = task();
        let back = Task::from_parcel(task.clone().into_parcel()).unwrap();
        assert_eq!(back, task);
    }

    #[test]
    fn the_result_crosses_with_the_bits_the_thread_computed() {
        let task = task();
        let eroded = pollster::block_on(task.run(&JobCtx::detached())).unwrap();
        let bits = |f: &Heightfield| f.checksum();
        let (field, area) = (bits(&eroded.field), bits(&eroded.drainage_area));
        let report = serde_json::to_string(&eroded.report).unwrap();
        let back = result_from_parcel(result_into_parcel(eroded)).unwrap();
        assert_eq!(bits(&back.field), field);
        assert_eq!(bits(&back.drainage_area), area);
        assert_eq!(serde_json::to_string(&back.report).unwrap(), report);
    }

    #[test]
    fn the_worker_side_erodes_as_the_thread_does() {
        let task = task();
        let here = pollster::block_on(task.run(&JobCtx::detached())).unwrap();
        let there = pollster::block_on(serve(task.into_parcel(), JobCtx::detached())).unwrap();
        let there = result_from_parcel(there).unwrap();
        assert_eq!(there.field.checksum(), here.field.checksum());
    }

    #[test]
    fn a_parcel_that_is_not_an_erosion_task_is_refused() {
        let mut parcel = task().into_parcel();
        parcel.arrays.pop_back();
        let err = pollster::block_on(serve(parcel, JobCtx::detached())).unwrap_err();
        assert!(err.contains("no array left"), "{err}");
    }
}
