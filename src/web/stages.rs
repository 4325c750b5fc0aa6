//! The page's Web Worker ([`crate::jobs::worker`]): the stages it runs for the page, by the
//! `kind` of each call.

use std::future::Future;
use std::pin::Pin;

use crate::jobs::JobCtx;
use crate::jobs::parcel::Parcel;

/// Serves the page's calls in this worker.
pub fn serve() {
    crate::jobs::worker::serve(run);
}

fn run(
    kind: String,
    parcel: Parcel,
    ctx: JobCtx,
) -> Pin<Box<dyn Future<Output = Result<Parcel, String>>>> {
    Box::pin(async move {
        match kind.as_str() {
            crate::erosion::offload::KIND => crate::erosion::offload::serve(parcel, ctx).await,
            crate::diffusion::offload::KIND => crate::diffusion::offload::serve(parcel, ctx).await,
            other => Err(format!("the worker runs no stage called {other:?}")),
        }
    })
}
