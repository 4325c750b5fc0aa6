//! The network comparison of seed paper 000 (Sec. VII, Fig. 8) in the DEM panel: the
//! uploaded DEM's channel network (D8 flow accumulation on the filled DEM, channels from the
//! realism report's initiation area) beside the river networks the scene grew, with the
//! same statistics (Strahler orders, streams per order, bifurcation and length ratios,
//! Tokunaga T_k);
//! `strahler analyze --network` prints the same table.

use super::StrahlerApp;
use super::panels::{NetworkTable, NetworksView};
use crate::jobs::JobHandle;
use crate::realism::ChannelReport;
use crate::river::{NetworkStats, RiverNetwork, stats};

/// The comparison's state: the extraction job and the last table.
#[derive(Default)]
pub struct Comparison {
    job: Option<JobHandle<Result<ChannelReport, String>>>,
    /// The generated networks' pooled statistics and count, taken when the job started.
    generated: Option<(NetworkStats, usize)>,
    table: Option<Table>,
}

/// A row of the table: its label and the values for the DEM, its largest basin and the
/// generated networks.
pub type Row = (String, [String; 3]);

/// The last comparison.
struct Table {
    /// The DEM's file name.
    dem: String,
    /// The channel initiation area used, m².
    channel_area_m2: f64,
    rows: Vec<Row>,
}

impl Comparison {
    pub fn busy(&self) -> bool {
        self.job.is_some()
    }

    /// The last table's rows, if any (label; DEM, its largest basin, generated).
    pub fn rows(&self) -> Option<&[Row]> {
        self.table.as_ref().map(|t| t.rows.as_slice())
    }

    /// What the DEM panel shows of it; `terrain`: a terrain is on the map to compare with.
    pub fn view(&self, terrain: bool) -> NetworksView<'_> {
        NetworksView {
            can_start: terrain && !self.busy(),
            progress: self.job.as_ref().map(|j| (j.progress(), j.message())),
            table: self.table.as_ref().map(|t| NetworkTable {
                dem: &t.dem,
                channel_area_m2: t.channel_area_m2,
                rows: &t.rows,
            }),
        }
    }
}

impl StrahlerApp {
    /// Extracts the uploaded DEM's channel network as a job, to compare with the networks of
    /// the terrain on the map. O(cells log cells) (the Priority-Flood fill).
    pub(super) fn compare_networks(&mut self, ctx: &egui::Context) {
        let Some(loaded) = &self.blend.dem else {
            self.set_error_at(
                super::Place::Dem,
                "Upload a DEM first (DEM panel: Upload DEM, or drop a file).".into(),
            );
            return;
        };
        let Some(output) = self.session.output() else {
            self.set_error_at(
                super::Place::Dem,
                "Generate a terrain first: its rivers are compared with the DEM's.".into(),
            );
            return;
        };
        let networks: Vec<RiverNetwork> = output
            .hydrology
            .rivers
            .iter()
            .map(|r| r.network.clone())
            .collect();
        self.blend.networks.generated = Some((
            stats::analyse(&RiverNetwork::forest(&networks)),
            networks.len(),
        ));
        let field = loaded.dem.field.clone();
        let (w, h) = (field.width(), field.height());
        let (cx, cy) = loaded.dem.georef.cell_size_m(h).unwrap_or((30.0, 30.0));
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "networks",
            move |job| async move {
                job.tick(0.1, "extracting the DEM's channel network")
                    .await
                    .map_err(|e| e.to_string())?;
                crate::realism::extract_channels(field.data(), w, h, cx, cy, None)
                    .map(|c| c.report())
                    .ok_or_else(|| "the DEM's cell size is not positive".to_owned())
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.blend.networks.job = Some(handle),
            Err(err) => self.set_error_at(super::Place::Dem, err.to_string()),
        }
    }

    /// A finished extraction becomes the table.
    pub(super) fn take_networks(&mut self) {
        let Some(result) = self
            .blend
            .networks
            .job
            .as_ref()
            .and_then(JobHandle::try_take)
        else {
            return;
        };
        self.blend.networks.job = None;
        match (result, self.blend.networks.generated.take()) {
            (Ok(dem), Some((generated, count))) => {
                let name = self
                    .blend
                    .dem
                    .as_ref()
                    .map_or(String::new(), |d| d.name.clone());
                let rows = crate::realism::network::comparison_rows(&dem, &generated, count);
                self.blend.networks.table = Some(Table {
                    dem: name,
                    channel_area_m2: dem.channel_area_m2,
                    rows,
                });
            }
            (Err(err), _) if err == "cancelled" => {}
            (Err(err), _) => self.set_error_at(
                super::Place::Dem,
                format!("Network comparison failed: {err}"),
            ),
            (Ok(_), None) => {}
        }
    }
}
