//! Each side-panel section alone in an egui_kittest harness: what it shows for a scene, and
//! the actions a click returns (the app applies them in one place). One snapshot of a panel
//! as drawn, on the GPU (lavapipe on CI).

mod common;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use strahler::app::panels::{
    Action, DESIGN_ONLY, DemAction, DemInfo, DemPanel, DemView, DetailPanel, DocumentAction,
    DocumentPanel, DocumentView, ErosionPanel, ExportDialog, ExportInfo, MaskAction, MaskPanel,
    MaskView, NetworksView, RealismPanel, RiversPanel, SolverPanel, SolverReport, StartPanel,
    StylePanel, TerrainPanel,
};
use strahler::app::{RunSettings, RunSummaries, Tool};
use strahler::erosion::{ErosionReport, ErosionSettings};
use strahler::scene::{Edit, MaskKind, RiverStroke, Scene, StyleSettings};

/// A panel under test, the scene it reads, and every action it returned.
struct Bench<P> {
    panel: P,
    scene: Scene,
    run: RunSettings,
    actions: Vec<Action>,
}

impl<P> Bench<P> {
    fn new(panel: P, scene: Scene) -> Self {
        Self {
            panel,
            scene,
            run: RunSettings::default(),
            actions: Vec::new(),
        }
    }
}

/// `show` drawn each frame in a tall window; its actions are collected.
fn harness<P: 'static>(
    bench: Bench<P>,
    show: impl Fn(&mut P, &mut egui::Ui, &Scene, &RunSettings) -> Vec<Action> + 'static,
) -> Harness<'static, Bench<P>> {
    Harness::builder()
        .with_size(egui::vec2(320.0, 700.0))
        .build_ui_state(
            move |ui, b: &mut Bench<P>| {
                let actions = show(&mut b.panel, ui, &b.scene, &b.run);
                b.actions.extend(actions);
            },
            bench,
        )
}

fn two_rivers() -> Scene {
    let stroke = |x: f64| RiverStroke {
        estuary: [x, 1.0],
        toward: [x, 0.5],
        phi: 3,
        depth: 5,
    };
    Scene {
        rivers: vec![stroke(0.3), stroke(0.7)],
        ..Scene::default()
    }
}

#[test]
fn rivers_panel_removes_clears_and_picks_tools() {
    let mut h = harness(Bench::new(RiversPanel, two_rivers()), |p, ui, scene, _| {
        p.show(ui, scene, Tool::River)
    });
    h.run();
    assert!(
        h.state().actions.is_empty(),
        "drawing alone asks for nothing"
    );
    h.get_all_by_label("x").nth(1).expect("two rivers").click();
    h.run();
    assert_eq!(h.state().actions, [Action::Edit(Edit::RemoveRiver(1))]);
    h.state_mut().actions.clear();
    h.get_by_label("Delete all rivers").click();
    h.get_by_label("Ridge (D)").click();
    h.run();
    assert!(h.state().actions.contains(&Action::Edit(Edit::ClearRivers)));
    assert!(h.state().actions.contains(&Action::Tool(Tool::Ridge)));
}

#[test]
fn start_panel_picks_a_terrain_type_draws_a_new_seed_and_turns_preview_off() {
    let scene = two_rivers();
    let seed = scene.seed;
    let mut h = harness(Bench::new(StartPanel, scene), |p, ui, scene, run| {
        p.show(ui, scene, run)
    });
    h.run();
    assert!(h.state().actions.is_empty());
    h.get_by_label("New seed").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::Edit(Edit::SetSeed(new))] => assert_ne!(*new, seed),
        other => panic!("{other:?}"),
    }
    h.state_mut().actions.clear();
    h.get_by_label("edit at 512").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::Settings(run)] => assert!(!run.preview),
        other => panic!("{other:?}"),
    }
    // The terrain type is the erosion preset, or the design alone.
    h.state_mut().actions.clear();
    h.get_by_label("Terrain type").click();
    h.run();
    h.get_by_label("badlands").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [Action::Edit(Edit::SetErosion(ErosionSettings::preset(
            "badlands"
        )))]
    );
    h.state_mut().actions.clear();
    h.state_mut().scene.erosion = ErosionSettings::preset("badlands");
    h.run();
    h.get_by_label("Terrain type").click();
    h.run();
    h.get_by_label(DESIGN_ONLY).click();
    h.run();
    assert_eq!(h.state().actions, [Action::Edit(Edit::SetErosion(None))]);
    // The coastal plain's rivers fall gently: choosing it sets the design's river slope too.
    h.state_mut().actions.clear();
    h.state_mut().scene.erosion = None;
    h.run();
    h.get_by_label("Terrain type").click();
    h.run();
    h.get_by_label("coastal-plain").click();
    h.run();
    let gentle = strahler::erosion::river_slope("coastal-plain").expect("a slope");
    match h.state().actions.as_slice() {
        [
            Action::Edit(Edit::SetErosion(erosion)),
            Action::Edit(Edit::SetParams(params)),
        ] => {
            assert_eq!(*erosion, ErosionSettings::preset("coastal-plain"));
            assert_eq!(params.river_slope, gentle);
            assert_eq!(params.theta, h.state().scene.params.theta);
        }
        other => panic!("{other:?}"),
    }
    // Placing the map on Earth (for georeferenced exports).
    h.state_mut().actions.clear();
    h.get_by_label("on Earth").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [Action::Edit(Edit::SetLocation(Some(
            strahler::scene::Location {
                lat: 45.9,
                lon: 6.9
            }
        )))]
    );
}

#[test]
fn terrain_panel_edits_the_papers_parameters() {
    let mut h = harness(Bench::new(TerrainPanel, two_rivers()), |p, ui, scene, _| {
        p.show(ui, scene)
    });
    h.run();
    assert!(h.state().actions.is_empty(), "showing asks for nothing");
    h.get_by_label("between points").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::Edit(Edit::SetParams(params))] => assert_eq!(
            params.enrich.distance_rule,
            strahler::skeleton::enrich::DistanceRule::Points
        ),
        other => panic!("{other:?}"),
    }
}

#[test]
fn solver_panel_switches_to_jacobi_generates_and_cancels() {
    let summaries = RunSummaries {
        terrain: Some("42 river nodes".into()),
        ..Default::default()
    };
    let mut h = harness(
        Bench::new(SolverPanel, two_rivers()),
        move |p, ui, scene, run| {
            let report = SolverReport {
                job: Some((0.5, "diffusing".into())),
                summaries: &summaries,
            };
            let mut actions = p.show(ui, scene, run, &report);
            actions.extend(p.show_settings(ui, scene, run));
            actions
        },
    );
    h.run();
    h.get_by_label("42 river nodes");
    h.get_by_label("Jacobi").click();
    h.get_by_label("Generate terrain").click();
    h.get_by_label("Cancel").click();
    h.run();
    let actions = &h.state().actions;
    assert!(
        actions
            .iter()
            .any(|a| matches!(a, Action::Settings(run) if !run.solver.multigrid)),
        "{actions:?}"
    );
    assert!(actions.contains(&Action::Generate), "{actions:?}");
    assert!(actions.contains(&Action::Cancel), "{actions:?}");
}

fn erosion_report() -> ErosionReport {
    ErosionReport {
        preset: "young-mountains".into(),
        steps: 20,
        years: 2e6,
        base_level_cells: 100,
        mean_depth_m: 12.5,
        max_depth_m: 180.0,
        drainage: Default::default(),
        conditioning: Default::default(),
        backend: "cpu",
        millis: 321.0,
        in_worker: false,
        held: None,
    }
}

#[test]
fn erosion_panel_keeps_its_toggle_and_turns_erosion_off() {
    let report = erosion_report();
    let mut h = harness(
        Bench::new(ErosionPanel::default(), Scene::default()),
        move |p, ui, scene, _| p.show(ui, scene, Some(&report)),
    );
    h.run();
    h.get_by_label_contains("Eroded in 321 ms: the land fell 12.5 m on average");
    h.get_by_label("Show before").click();
    h.run();
    assert!(h.state().panel.show_before, "the panel owns the toggle");
    assert!(h.state().actions.is_empty(), "the toggle is not an edit");
    h.get_by_label("Erode the terrain").click();
    h.run();
    assert_eq!(h.state().actions, [Action::Edit(Edit::SetErosion(None))]);
}

/// The relief's choice is one click in the folded parameters, and an edit like any other.
#[test]
fn erosion_panel_chooses_where_the_relief_comes_from() {
    let report = erosion_report();
    let mut h = harness(
        Bench::new(ErosionPanel::default(), Scene::default()),
        move |p, ui, scene, _| p.show(ui, scene, Some(&report)),
    );
    h.run();
    h.get_by_label("Parameters (young-mountains)").click();
    h.run();
    h.get_by_label("design").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::Edit(Edit::SetErosion(Some(e)))] => {
            assert_eq!(e.relief, strahler::erosion::Relief::Design);
            assert_eq!(e.preset, "custom", "an edited preset is the user's own");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn style_panel_picks_a_bundled_style() {
    let mut h = harness(
        Bench::new(StylePanel, Scene::default()),
        |p, ui, scene, _| p.show(ui, scene, None),
    );
    h.run();
    assert!(h.query_by_label("Style from the uploaded DEM").is_none());
    h.get_by_label("Style").click();
    h.run();
    h.get_by_label("lowland").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [Action::Edit(Edit::SetStyle(StyleSettings::bundled(
            "lowland"
        )))]
    );
}

#[test]
fn realism_panel_asks_each_run_to_measure() {
    let mut h = harness(
        Bench::new(RealismPanel, Scene::default()),
        |p, ui, _, run| p.show(ui, run, None),
    );
    h.run();
    assert!(h.query_by_label("Measured with the next terrain").is_none());
    h.get_by_label("Measure each terrain").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::Settings(run)] => assert!(run.measure_realism),
        other => panic!("{other:?}"),
    }
    h.state_mut().run.measure_realism = true;
    h.run();
    h.get_by_label("Measured with the next terrain");
}

#[test]
fn detail_panel_sets_the_scope_and_shows_the_window_for_local() {
    let mut h = harness(
        Bench::new(DetailPanel, Scene::default()),
        |p, ui, scene, _| p.show(ui, scene),
    );
    h.run();
    assert!(h.query_by_label("Window").is_none(), "global has no window");
    h.get_by_label("Scope").click();
    h.run();
    h.get_by_label("local").click();
    h.run();
    let edited = match h.state().actions.as_slice() {
        [Action::Edit(Edit::SetDetail(detail))] => detail.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(edited.scope, "local");
    h.state_mut().scene.apply(Edit::SetDetail(edited)).unwrap();
    h.run();
    assert!(
        h.query_all_by_label("Window").count() >= 1,
        "local shows its window"
    );
}

/// The mask tools: the brush shows with the mask tool only and is the panel's own; the
/// Paints menu, the layer toggle, the buttons and an error's Dismiss return their actions.
#[test]
fn mask_panel_picks_what_it_paints_and_asks_for_its_buttons() {
    struct Tools {
        panel: MaskPanel,
        tool: Tool,
        kind: MaskKind,
        error: Option<String>,
        actions: Vec<Action>,
    }
    let tools = Tools {
        panel: MaskPanel::default(),
        tool: Tool::Pan,
        kind: MaskKind::Detail,
        error: None,
        actions: Vec::new(),
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(320.0, 500.0))
        .build_ui_state(
            |ui, t: &mut Tools| {
                let view = MaskView {
                    tool: t.tool,
                    shown: false,
                    kind: t.kind,
                    error: t.error.as_deref(),
                    summary: Some("Detail: 1025 x 1025"),
                };
                let actions = t.panel.show(ui, &view);
                t.actions.extend(actions);
            },
            tools,
        );
    h.run();
    assert!(h.state().actions.is_empty(), "showing asks for nothing");
    assert!(
        h.query_by_label("Brush size").is_none(),
        "no brush without the tool"
    );
    h.get_by_label("Paint mask (M)").click();
    h.get_by_label("show mask").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [
            Action::Tool(Tool::Mask),
            Action::Mask(MaskAction::Show(true))
        ]
    );
    h.state_mut().actions.clear();
    h.state_mut().tool = Tool::Mask;
    h.run();
    assert!(
        h.query_by_label("Brush size").is_some(),
        "the brush with the tool"
    );
    h.get_by_label("Paints").click();
    h.run();
    h.get_by_label("hard rock").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [Action::Mask(MaskAction::Paint(MaskKind::HardRock))]
    );
    h.state_mut().actions.clear();
    for button in ["Mask from rivers", "Clear mask", "Export mask PNG"] {
        h.get_by_label(button).click();
        h.run();
    }
    assert_eq!(
        h.state().actions,
        [
            Action::Mask(MaskAction::FromRivers),
            Action::Mask(MaskAction::Clear),
            Action::Mask(MaskAction::Export),
        ]
    );
    h.state_mut().actions.clear();
    h.state_mut().error = Some("no terrain yet".into());
    h.run();
    h.get_by_label("no terrain yet");
    h.get_by_label("Dismiss").click();
    h.run();
    assert_eq!(h.state().actions, [Action::DismissError]);
    // The brush is the panel's: a new size stays with it, and no action is needed.
    h.state_mut().panel.brush.radius = 30.0;
    h.run();
    assert_eq!(h.state().panel.brush.radius, 30.0);
    assert_eq!(h.state().actions, [Action::DismissError]);
}

/// The DEM panel: the facts of the uploaded DEM, Fill voids only with voids, the question
/// before an extraction replaces a scene with work in it, the typed height range applied,
/// and the placed blocks selected, turned and removed.
#[test]
fn dem_panel_shows_the_dem_asks_before_replacing_and_edits_blocks() {
    struct Dem {
        panel: DemPanel,
        scene: Scene,
        voids: usize,
        selected: Option<usize>,
        actions: Vec<Action>,
    }
    let reference =
        strahler::heightfield::Heightfield::from_vec(4, 4, (0..16).map(|v| v as f32).collect())
            .unwrap();
    let mut scene = two_rivers();
    scene.blend.push(
        strahler::blend::BlendBlock::new("dem.png [0,0 4x4]", &reference, [0.4, 0.4, 0.6, 0.6])
            .unwrap(),
    );
    let dem = Dem {
        panel: DemPanel::default(),
        scene,
        voids: 12,
        selected: None,
        actions: Vec::new(),
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(320.0, 800.0))
        .build_ui_state(
            |ui, d: &mut Dem| {
                let view = DemView {
                    scene: &d.scene,
                    dem: Some(DemInfo {
                        name: "dem.png",
                        width: 300,
                        height: 200,
                        range: (12.0, 840.5),
                        voids: d.voids,
                        cell_size: None,
                        crs: None,
                        needs_range: true,
                        preview: None,
                        window: [0, 0, 200, 200],
                    }),
                    fill: None,
                    features: None,
                    networks: NetworksView::default(),
                    tool: Tool::Pan,
                    selected: d.selected,
                    error: None,
                    summary: None,
                };
                let actions = d.panel.show(ui, &view);
                d.actions.extend(actions);
            },
            dem,
        );
    h.run();
    assert!(h.state().actions.is_empty(), "showing asks for nothing");
    h.get_by_label("300 x 200 cells");
    h.get_by_label("12.0 to 840.5 m");
    h.get_by_label("Fill voids").click();
    h.run();
    assert_eq!(h.state().actions, [Action::Dem(DemAction::FillVoids)]);
    h.state_mut().actions.clear();
    h.state_mut().voids = 0;
    h.run();
    assert!(h.query_by_label("Fill voids").is_none(), "nothing to fill");
    // Two rivers and a block would be replaced: the panel asks first.
    h.get_by_label("Extract features").click();
    h.run();
    assert!(h.state().actions.is_empty(), "asked, not extracted");
    h.get_by_label("This replaces the scene's 2 rivers and 1 block with the DEM's features (Undo brings them back).");
    h.get_by_label("Replace the scene").click();
    h.run();
    assert_eq!(h.state().actions, [Action::Dem(DemAction::ExtractFeatures)]);
    assert!(h.query_by_label("Replace the scene").is_none(), "answered");
    h.state_mut().actions.clear();
    h.state_mut().panel.z_range = (-5.0, 2500.0);
    h.get_by_label("Apply").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [Action::Dem(DemAction::Reread((-5.0, 2500.0)))]
    );
    h.state_mut().actions.clear();
    h.get_by_label("dem.png [0,0 4x4]").click();
    h.run();
    assert_eq!(h.state().actions, [Action::Dem(DemAction::Select(Some(0)))]);
    h.state_mut().actions.clear();
    h.state_mut().selected = Some(0);
    h.run();
    h.get_by_label("Rotate 90").click();
    h.run();
    let turned = match h.state().actions.as_slice() {
        [Action::Edit(Edit::SetBlock { index: 0, block })] => block.quarter_turns,
        other => panic!("{other:?}"),
    };
    assert_eq!(turned, 1);
    h.state_mut().actions.clear();
    h.get_by_label("x").click();
    h.run();
    assert_eq!(
        h.state().actions,
        [
            Action::Edit(Edit::RemoveBlock(0)),
            Action::Dem(DemAction::Select(None))
        ]
    );
}

/// The Erosion panel as drawn (the pixels on lavapipe; a few may differ across Mesa versions).
#[test]
fn snapshot_of_the_erosion_panel() {
    if common::gpu().is_none() {
        return;
    }
    let report = erosion_report();
    let mut h = Harness::builder()
        .with_size(egui::vec2(320.0, 420.0))
        .wgpu()
        .build_ui_state(
            move |ui, panel: &mut ErosionPanel| {
                let _ = panel.show(ui, &Scene::default(), Some(&report));
            },
            ErosionPanel::default(),
        );
    h.run();
    // The parameters are folded at first; the picture shows them unfolded.
    h.get_by_label("Parameters (young-mountains)").click();
    h.run();
    h.snapshot_options(
        "panel_erosion",
        &egui_kittest::SnapshotOptions::new().max_failed_pixels(200),
    );
}

/// The DEM panel with a real DEM's preview as the app draws it (shaded relief) and the window
/// to place outlined on it; a drag on the preview picks a new window.
#[test]
fn snapshot_of_the_dem_panel_and_a_window_dragged_on_its_preview() {
    struct Dem {
        panel: DemPanel,
        scene: Scene,
        field: strahler::heightfield::Heightfield,
        texture: Option<egui::TextureHandle>,
        window: [usize; 4],
        actions: Vec<Action>,
    }
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/srtm_n44e005_384.tif"
    ))
    .unwrap();
    let dem =
        strahler::dem::format::read("srtm_n44e005_384.tif", &bytes, &Default::default()).unwrap();
    let state = Dem {
        panel: DemPanel::default(),
        scene: Scene::default(),
        field: dem.field,
        texture: None,
        window: [64, 96, 128, 128],
        actions: Vec::new(),
    };
    let builder = Harness::builder().with_size(egui::vec2(320.0, 560.0));
    let show = |ui: &mut egui::Ui, d: &mut Dem| {
        let field = &d.field;
        let texture = d.texture.get_or_insert_with(|| {
            let image = strahler::app::shaded_relief(field, 90.0);
            ui.ctx()
                .load_texture("dem preview", image, egui::TextureOptions::LINEAR)
        });
        let (zmin, zmax) = field.finite_range().unwrap();
        let view = DemView {
            scene: &d.scene,
            dem: Some(DemInfo {
                name: "srtm_n44e005_384.tif",
                width: field.width(),
                height: field.height(),
                range: (zmin, zmax),
                voids: 0,
                cell_size: Some((90.0, 90.0)),
                crs: None,
                needs_range: false,
                preview: Some(texture.id()),
                window: d.window,
            }),
            fill: None,
            features: None,
            networks: NetworksView::default(),
            tool: Tool::Pan,
            selected: None,
            error: None,
            summary: None,
        };
        let actions = d.panel.show(ui, &view);
        d.actions.extend(actions);
    };
    let mut h = match common::gpu() {
        Some(_) => builder.wgpu().build_ui_state(show, state),
        None => builder.build_ui_state(show, state),
    };
    h.run();
    assert!(h.state().actions.is_empty(), "showing asks for nothing");
    if common::gpu().is_some() {
        h.snapshot_options(
            "panel_dem",
            &egui_kittest::SnapshotOptions::new().max_failed_pixels(400),
        );
    }
    // A drag across the preview's upper-left quarter picks that window (rows and columns
    // of the DEM, whatever the preview's size on screen).
    let rect = h.get_by_label("DEM preview").rect();
    let at = |f: f32| rect.min + rect.size() * f;
    h.hover_at(at(0.0));
    h.drag_at(at(0.0));
    h.run();
    h.hover_at(at(0.25));
    h.run();
    h.hover_at(at(0.5));
    h.run();
    h.drop_at(at(0.5));
    h.run();
    let Some(Action::Dem(DemAction::Window([row, col, height, width]))) = h.state().actions.last()
    else {
        panic!("no window picked: {:?}", h.state().actions);
    };
    assert!(row + col <= 2, "from the corner: {row}, {col}");
    assert!(
        (188..=196).contains(height) && (188..=196).contains(width),
        "half the DEM's side: {height} x {width}"
    );
}

/// The Layers row: each box turns its layer on or off, the river order shows with the rivers
/// only, and the erosion stage's layers with an eroded terrain only.
#[test]
fn layers_row_toggles_layers_and_offers_what_exists() {
    use strahler::app::{Layers, layers_section};
    let mut h = Harness::builder()
        .with_size(egui::vec2(320.0, 200.0))
        .build_ui_state(
            |ui, (layers, eroded): &mut (Layers, bool)| layers_section(ui, layers, *eroded),
            (Layers::default(), false),
        );
    h.run();
    assert!(h.query_by_label("drainage area").is_none(), "not eroded");
    assert!(h.query_by_label("from order").is_some(), "rivers are on");
    h.get_by_label("contours").click();
    h.get_by_label("rivers").click();
    h.run();
    let layers = h.state().0;
    assert!(layers.contours && !layers.rivers);
    assert!(h.query_by_label("from order").is_none(), "no rivers drawn");
    h.state_mut().1 = true;
    h.run();
    h.get_by_label("erosion depth").click();
    h.run();
    assert!(h.state().0.erosion_depth && !h.state().0.drainage);
    assert_eq!(
        Layers {
            contours: true,
            rivers: false,
            erosion_depth: true,
            ..Layers::default()
        },
        h.state().0,
        "nothing else changed"
    );
}

/// The document's row: Undo and Redo only when there is a step to take, Open only where a
/// file can be picked, the error and the notice each dismissed by its own button, and the
/// Export button.
#[test]
fn document_row_asks_for_undo_save_open_and_dismissals() {
    struct Doc {
        panel: DocumentPanel,
        can_undo: bool,
        can_open: bool,
        error: Option<String>,
        notice: Option<String>,
        actions: Vec<Action>,
    }
    let doc = Doc {
        panel: DocumentPanel,
        can_undo: false,
        can_open: false,
        error: None,
        notice: None,
        actions: Vec::new(),
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(320.0, 300.0))
        .build_ui_state(
            |ui, d: &mut Doc| {
                let view = DocumentView {
                    can_undo: d.can_undo,
                    can_redo: false,
                    can_open: d.can_open,
                    error: d.error.as_deref(),
                    notice: d.notice.as_deref(),
                };
                let mut actions = d.panel.show(ui, &view);
                actions.extend(d.panel.export_button(ui));
                d.actions.extend(actions);
            },
            doc,
        );
    h.run();
    assert!(h.state().actions.is_empty(), "showing asks for nothing");
    assert!(
        h.query_by_label("Open scene...").is_none(),
        "no picker here"
    );
    h.get_by_label("Undo").click();
    h.run();
    assert!(h.state().actions.is_empty(), "nothing to undo");
    h.state_mut().can_undo = true;
    h.state_mut().can_open = true;
    h.run();
    for button in [
        "Undo",
        "Save scene",
        "Open scene...",
        "Export heightmap... (E)",
    ] {
        h.get_by_label(button).click();
        h.run();
    }
    let asked: Vec<Action> = [
        DocumentAction::Undo,
        DocumentAction::Save,
        DocumentAction::Open,
        DocumentAction::Export,
    ]
    .into_iter()
    .map(Action::Document)
    .collect();
    assert_eq!(h.state().actions, asked);
    h.state_mut().actions.clear();
    h.state_mut().error = Some("scene: size: must be 16 to 8192 cells, got 5".into());
    h.state_mut().notice = Some("Undone".into());
    h.run();
    h.get_by_label("scene: size: must be 16 to 8192 cells, got 5");
    h.get_by_label("Undone");
    let dismiss: Vec<_> = h.get_all_by_label("Dismiss").collect();
    assert_eq!(dismiss.len(), 2, "one for the error, one for the notice");
    dismiss[1].click();
    h.run();
    h.get_all_by_label("Dismiss").next().unwrap().click();
    h.run();
    assert_eq!(
        h.state().actions,
        [
            Action::Document(DocumentAction::DismissNotice),
            Action::DismissError
        ]
    );
}

/// What the export dialog knows of a 512^2 terrain of a 10 km map, 0 to 800 m.
fn export_info() -> ExportInfo {
    ExportInfo {
        native: 512,
        cell_m: 10_000.0 / 511.0,
        range: (0.0, 800.0),
        preview_of: None,
        vertical_scale: 1.0,
        textures: Default::default(),
    }
}

/// The export dialog: an engine preset shows the numbers to type in and the files before
/// anything is written, refuses tiles that do not share edges, and asks for the export.
#[test]
fn export_dialog_shows_engine_numbers_and_files_then_asks_for_the_export() {
    use strahler::export::{Engine, MapKind};
    let info = export_info();
    let mut dialog = ExportDialog {
        open: true,
        ..Default::default()
    };
    dialog.choose(Some(Engine::Unreal));
    dialog.maps = vec![MapKind::Splat];
    let mut h = harness(Bench::new(dialog, Scene::default()), move |p, ui, _, _| {
        p.show(ui.ctx(), &info)
    });
    h.run();
    assert!(h.state().actions.is_empty(), "opening asks for nothing");
    h.get_by_label("Scale Z");
    h.get_by_label("Rock above");
    assert!(
        h.query_by_label_contains("strahler-heightmap.png")
            .is_some(),
        "the files are listed"
    );
    h.get_by_label("Download (Enter)").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::Export { request, layers }] => {
            assert_eq!(request.engine, Some(Engine::Unreal));
            assert_eq!(request.size, Some(505));
            assert_eq!(request.maps, vec![MapKind::Splat]);
            assert!(!layers);
        }
        other => panic!("{other:?}"),
    }
    h.state_mut().actions.clear();
    h.state_mut().panel.tiles = (5, 5);
    h.run();
    assert!(
        h.query_by_label_contains("does not split into 5 x 5")
            .is_some(),
        "tiles that do not share edges are refused before writing"
    );
    h.get_by_label("Download (Enter)").click();
    h.run();
    assert!(h.state().actions.is_empty(), "nothing is asked for");
}

/// Folded below the export: a world in tiles larger than the map, the tasks its plan makes,
/// the plan saved for `strahler build`, and its preview built and saved.
#[test]
fn export_dialog_saves_the_plan_of_a_world_in_tiles() {
    let info = export_info();
    let dialog = ExportDialog {
        open: true,
        ..Default::default()
    };
    let mut h = harness(Bench::new(dialog, Scene::default()), move |p, ui, _, _| {
        p.show(ui.ctx(), &info)
    });
    h.run();
    h.get_by_label("A world in tiles").click();
    h.run();
    assert!(
        h.query_by_label_contains("129 tasks: the global build at 2049^2, then 8 x 8 tiles")
            .is_some(),
        "the plan of a 16384^2 world in tiles of 2048"
    );
    h.get_by_label("Save the world plan").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::SaveWorldPlan { size, tile, fill }] => {
            assert_eq!((*size, *tile, *fill), (16_384, 2048, false))
        }
        other => panic!("{other:?}"),
    }
    h.state_mut().actions.clear();
    h.get_by_label("Fill the depressions").click();
    h.run();
    assert!(
        h.query_by_label_contains("258 tasks: the global build at 2049^2")
            .is_some()
            && h.query_by_label_contains("the depressions filled")
                .is_some(),
        "filling adds a task per tile twice and one for the world"
    );
    h.get_by_label("Save the world plan").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::SaveWorldPlan { fill, .. }] => assert!(*fill),
        other => panic!("{other:?}"),
    }
    h.state_mut().actions.clear();
    h.get_by_label("Save the preview").click();
    h.run();
    match h.state().actions.as_slice() {
        [Action::SaveWorldPreview { size, tile }] => {
            assert_eq!((*size, *tile), (16_384, 2048))
        }
        other => panic!("{other:?}"),
    }
}

/// The status bar alone: the compute path, what the map shows, the running job's bar with
/// its stage and the time left, the active tool's hint and the height under the pointer.
#[test]
fn status_bar_shows_the_path_the_job_and_the_pointer() {
    use strahler::app::panels::{JobLine, StatusBar, StatusInfo};
    use strahler::app::{Hover, OnMap, Pass, Tool};
    use strahler::compute::{ComputePath, CpuReason};
    struct State {
        bar: StatusBar,
        path: ComputePath,
        job: Option<JobLine>,
        map: Option<OnMap>,
    }
    let state = State {
        bar: StatusBar,
        path: ComputePath::Cpu {
            reason: CpuReason::BrowserWithoutWebGpu,
        },
        job: Some(JobLine {
            name: "terrain".into(),
            progress: 0.4,
            message: "eroding: step 3 of 20".into(),
            left: Some(std::time::Duration::from_secs(12)),
        }),
        map: Some(OnMap {
            size: 128,
            pass: Pass::Coarse,
            scene: 2048,
            coming: Some(512),
        }),
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(1200.0, 40.0))
        .build_ui_state(
            |ui, s: &mut State| {
                let info = StatusInfo {
                    path: &s.path,
                    job: s.job.clone(),
                    map: s.map,
                    tool: Tool::River,
                    hover: Some(Hover {
                        map: egui::pos2(0.25, 0.5),
                        height: Some(812.34),
                    }),
                    worker: None,
                };
                s.bar.show(ui, &info);
            },
            state,
        );
    h.run();
    h.get_by_label("CPU (this browser has no WebGPU)");
    h.get_by_label("terrain 40%: eroding: step 3 of 20, about 12 s left");
    h.get_by_label("Tool: draw river (R) - press at the estuary, drag upstream");
    h.get_by_label("x 0.2500  y 0.5000  812.3 m");
    h.get_by_label("map 128x128 (coarse), 512x512 coming");
    // No job: no bar; the preview on the map says what it is a preview of.
    h.state_mut().job = None;
    h.state_mut().map = Some(OnMap {
        size: 512,
        pass: Pass::Preview,
        scene: 2048,
        coming: None,
    });
    h.run();
    assert!(h.query_by_label_contains("terrain 40%").is_none());
    h.get_by_label("map 512x512 (preview of 2048x2048)");
}

/// The compute check alone: its button asks for a check, not while one runs; a finished
/// check on the CPU path says there is no GPU to compare with.
#[test]
fn check_panel_asks_for_a_check_and_shows_the_result() {
    use strahler::app::panels::{CheckPanel, CheckReport};
    use strahler::compute::{ComputePath, CpuReason};
    use strahler::diffusion::selftest::SelfTest;
    struct State {
        panel: CheckPanel,
        running: bool,
        result: Option<Result<SelfTest, String>>,
        actions: Vec<Action>,
    }
    let path = ComputePath::Cpu {
        reason: CpuReason::BrowserWithoutWebGpu,
    };
    let test = pollster::block_on(strahler::diffusion::selftest::run(
        &path,
        &strahler::jobs::JobCtx::detached(),
    ))
    .unwrap();
    let state = State {
        panel: CheckPanel,
        running: false,
        result: None,
        actions: Vec::new(),
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(320.0, 300.0))
        .build_ui_state(
            |ui, s: &mut State| {
                let report = CheckReport {
                    running: s.running,
                    result: s.result.as_ref(),
                };
                let actions = s.panel.show(ui, &report);
                s.actions.extend(actions);
            },
            state,
        );
    h.run();
    h.get_by_label("Compare CPU and GPU").click();
    h.run();
    assert_eq!(h.state().actions, [Action::CompareBackends]);
    h.state_mut().actions.clear();
    h.state_mut().running = true;
    h.run();
    h.get_by_label("Compare CPU and GPU").click();
    h.run();
    assert!(h.state().actions.is_empty(), "not while a check runs");
    h.state_mut().running = false;
    let checksum = test.cpu.checksum.clone();
    h.state_mut().result = Some(Ok(test));
    h.run();
    h.get_by_label_contains(&format!("checksum {checksum}"));
    h.get_by_label("No GPU compute on this path: CPU only.");
    h.state_mut().result = Some(Err("the device was lost".into()));
    h.run();
    h.get_by_label("Check failed: the device was lost");
}
