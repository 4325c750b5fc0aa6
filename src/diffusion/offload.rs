//! The diffusion solve as a parcel for the page's Web Worker ([`crate::jobs::worker`]): the
//! problem (starting heights and the fixed-cell mask) and the method go to the worker, the
//! filled field and the solver's numbers come back, so the multigrid runs on another core
//! while the page draws.
//!
//! `f32` values cross as their bits (a decimal round trip through `f64` could round twice);
//! the worker runs the same solver on the same numbers, so the field has the page's bits.

use serde::{Deserialize, Serialize};

use super::multigrid::MultigridParams;
use super::{Constraints, FieldOut, Filled, FixedMask, Method};
use crate::compute::Backend;
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::jobs::parcel::{Array, Parcel, ParcelError, sized};

/// The `kind` of the diffusion's worker calls.
pub const KIND: &str = "diffusion";

/// The solve's inputs.
#[derive(Serialize, Deserialize)]
struct Header {
    width: usize,
    height: usize,
    /// Exactly this many Jacobi sweeps, or the multigrid's settings
    /// (`[tolerance bits, error tolerance bits, max cycles, pre sweeps, post sweeps]`).
    jacobi: Option<u32>,
    multigrid: Option<[u32; 5]>,
}

/// The solve's numbers ([`Filled`] without its field), `f32`s as bits.
#[derive(Serialize, Deserialize)]
struct Solved {
    width: usize,
    height: usize,
    method: String,
    cycles: u32,
    sweeps: u32,
    work_sweeps: u32,
    residual: u32,
    relative_residual: u32,
    converged: bool,
    estimated_error: Option<u32>,
    millis: f64,
}

pub fn task_into_parcel(problem: &Constraints, method: Method) -> Parcel {
    let (jacobi, multigrid) = match method {
        Method::Jacobi { sweeps } => (Some(sweeps), None),
        Method::Multigrid(p) => (
            None,
            Some([
                p.tolerance.to_bits(),
                p.error_tolerance.to_bits(),
                p.max_cycles,
                p.pre_sweeps,
                p.post_sweeps,
            ]),
        ),
    };
    let header = Header {
        width: problem.width(),
        height: problem.height(),
        jacobi,
        multigrid,
    };
    Parcel::new(&header)
        .with(Array::F32(problem.initial().data().to_vec()))
        .with(Array::U32(problem.fixed().words().to_vec()))
}

pub fn task_from_parcel(mut parcel: Parcel) -> Result<(Constraints, Method), ParcelError> {
    let header: Header = parcel.header()?;
    let (w, h) = (header.width, header.height);
    let bad = |what: String| ParcelError::Header(what);
    let initial = Heightfield::from_vec(w, h, sized("heights", parcel.f32s()?, w * h)?)
        .map_err(|e| bad(e.to_string()))?;
    let fixed = FixedMask::from_words(w, h, parcel.u32s()?)
        .ok_or_else(|| bad(format!("a fixed-cell mask that does not fit {w}x{h}")))?;
    let problem = Constraints::new(initial, fixed).map_err(|e| bad(e.to_string()))?;
    let method = match (header.jacobi, header.multigrid) {
        (Some(sweeps), None) => Method::Jacobi { sweeps },
        (
            None,
            Some(
                [
                    tolerance,
                    error_tolerance,
                    max_cycles,
                    pre_sweeps,
                    post_sweeps,
                ],
            ),
        ) => Method::Multigrid(MultigridParams {
            tolerance: f32::from_bits(tolerance),
            error_tolerance: f32::from_bits(error_tolerance),
            max_cycles,
            pre_sweeps,
            post_sweeps,
        }),
        _ => return Err(bad("a method that is neither Jacobi nor multigrid".into())),
    };
    Ok((problem, method))
}

pub fn result_into_parcel(filled: Filled<Heightfield>) -> Parcel {
    let solved = Solved {
        width: filled.field.width(),
        height: filled.field.height(),
        method: filled.method.into(),
        cycles: filled.cycles,
        sweeps: filled.sweeps,
        work_sweeps: filled.work_sweeps.to_bits(),
        residual: filled.residual.to_bits(),
        relative_residual: filled.relative_residual.to_bits(),
        converged: filled.converged,
        estimated_error: filled.estimated_error.map(f32::to_bits),
        millis: filled.millis,
    };
    Parcel::new(&solved).with(Array::F32(filled.field.into_vec()))
}

pub fn result_from_parcel(mut parcel: Parcel) -> Result<Filled<Heightfield>, ParcelError> {
    let s: Solved = parcel.header()?;
    let field = Heightfield::from_vec(
        s.width,
        s.height,
        sized("field", parcel.f32s()?, s.width * s.height)?,
    )
    .map_err(|e| ParcelError::Header(e.to_string()))?;
    let method = match s.method.as_str() {
        "multigrid" => "multigrid",
        "jacobi" => "jacobi",
        other => return Err(ParcelError::Header(format!("the method {other:?}"))),
    };
    Ok(Filled {
        field,
        method,
        backend: "cpu",
        cycles: s.cycles,
        sweeps: s.sweeps,
        work_sweeps: f32::from_bits(s.work_sweeps),
        residual: f32::from_bits(s.residual),
        relative_residual: f32::from_bits(s.relative_residual),
        converged: s.converged,
        estimated_error: s.estimated_error.map(f32::from_bits),
        millis: s.millis,
    })
}

/// The worker's side of a call of [`KIND`]: solves on the CPU.
pub async fn serve(parcel: Parcel, ctx: JobCtx) -> Result<Parcel, String> {
    let (problem, method) = task_from_parcel(parcel).map_err(|e| e.to_string())?;
    let filled = super::solve_here(&Backend::Cpu, &problem, method, &ctx)
        .await
        .map_err(|e| e.to_string())?;
    let filled = filled.try_map_field(|field| match field {
        FieldOut::Cpu(field) => Ok(field),
        FieldOut::Gpu(_) => Err("the worker's solve stayed on a GPU"),
    })?;
    Ok(result_into_parcel(filled))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem() -> Constraints {
        let n = 33;
        let mut fixed = FixedMask::new(n, n);
        let mut heights = vec![0.0f32; n * n];
        for x in 0..n {
            fixed.fix(x, 0);
            heights[x] = 0.1 + x as f32 * 7.3;
            fixed.fix(x, n - 1);
            heights[x + n * (n - 1)] = 400.0 - x as f32;
        }
        Constraints::new(Heightfield::from_vec(n, n, heights).unwrap(), fixed).unwrap()
    }

    #[test]
    fn the_worker_side_solves_with_the_bits_of_this_thread() {
        let problem = problem();
        let method = Method::Multigrid(MultigridParams {
            tolerance: 1.0e-6 / 3.0,
            ..MultigridParams::default()
        });
        let ctx = JobCtx::detached();
        let here =
            pollster::block_on(super::super::fill(&Backend::Cpu, &problem, method, &ctx)).unwrap();
        let parcel = pollster::block_on(serve(task_into_parcel(&problem, method), ctx)).unwrap();
        let there = result_from_parcel(parcel).unwrap();
        assert_eq!(there.field.checksum(), here.field.checksum());
        assert_eq!(
            (there.cycles, there.converged, there.residual.to_bits()),
            (here.cycles, here.converged, here.residual.to_bits())
        );
    }

    #[test]
    fn a_task_crosses_unchanged() {
        let problem = problem();
        for method in [
            Method::Jacobi { sweeps: 17 },
            Method::Multigrid(MultigridParams::default()),
        ] {
            let (back, method_back) = task_from_parcel(task_into_parcel(&problem, method)).unwrap();
            assert_eq!(method_back, method);
            assert_eq!(back.initial(), problem.initial());
            assert_eq!(back.fixed(), problem.fixed());
        }
    }

    #[test]
    fn a_mask_that_does_not_fit_is_refused() {
        let mut parcel = task_into_parcel(&problem(), Method::Jacobi { sweeps: 1 });
        parcel.arrays.pop_back();
        parcel.arrays.push_back(Array::U32(vec![0; 3]));
        assert!(task_from_parcel(parcel).is_err());
    }
}
