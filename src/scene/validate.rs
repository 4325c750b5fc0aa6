//! The checks of [`Scene::validate`], one function per section of the scene, in the order
//! their first error is reported. Every message names the field and the accepted values.

use super::*;

/// The error for `field`, saying what is wrong with it.
fn bad(field: &str, problem: String) -> Result<(), SceneError> {
    Err(SceneError::Invalid {
        field: field.to_owned(),
        problem,
    })
}

/// A part of the scene an edit changes: [`Scene::check_part`] runs the checks of
/// [`Scene::validate`] that such a change can break, with the same messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Part {
    /// The grid (size and cell size), which bounds the detail's output and the map's width.
    Map,
    Rivers,
    Sketch,
    Params,
    Detail,
    /// Block `i` and the blocks' totals.
    Block(usize),
    Erosion,
    Style,
    Textures,
    Location,
    /// A change no check can refuse: the seed, a painted mask (valid as made), a removal, or
    /// a whole scene (one opened, extracted or taken back by undo).
    Unchecked,
}

impl Scene {
    /// The checks of `part`, naming the first bad field.
    pub(super) fn check_part(&self, part: Part) -> Result<(), SceneError> {
        match part {
            Part::Map => {
                self.check_map()?;
                self.check_detail_settings()?;
                self.check_extent()
            }
            Part::Rivers => self.check_rivers(),
            Part::Sketch => self.check_sketch(),
            Part::Params => {
                self.check_paper_params()?;
                self.check_enrichment_and_filters()
            }
            Part::Detail => self.check_detail_settings(),
            Part::Block(i) => {
                self.check_blend_totals()?;
                self.check_block(i)
            }
            Part::Erosion => self.check_erosion(),
            Part::Style => self.check_style(),
            Part::Textures => self.check_textures(),
            Part::Location => self.check_location(),
            Part::Unchecked => Ok(()),
        }
    }

    /// Checks every value, naming the first bad field.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.check_map()?;
        self.check_rivers()?;
        self.check_detail()?;
        self.check_blend()?;
        self.check_paper_params()?;
        self.check_sketch()?;
        self.check_enrichment_and_filters()?;
        self.check_erosion()?;
        self.check_style()?;
        self.check_textures()?;
        self.check_extent()?;
        self.check_location()?;
        Ok(())
    }

    /// The place on Earth, if any: a latitude UTM covers and a longitude.
    fn check_location(&self) -> Result<(), SceneError> {
        let Some(Location { lat, lon }) = self.location else {
            return Ok(());
        };
        let lats = crate::dem::utm::LATITUDES;
        if !(lat.is_finite() && lats.contains(&lat)) {
            return bad(
                "location.lat",
                format!(
                    "must be a latitude from {} to {} degrees (the UTM zones), got {lat}",
                    lats.start(),
                    lats.end()
                ),
            );
        }
        if !(lon.is_finite() && (-180.0..=180.0).contains(&lon)) {
            return bad(
                "location.lon",
                format!("must be a longitude from -180 to 180 degrees, got {lon}"),
            );
        }
        Ok(())
    }

    /// The map: the format version, the grid, the cell size and the vertical scale.
    fn check_map(&self) -> Result<(), SceneError> {
        if self.version != VERSION {
            return bad(
                "version",
                format!("this build reads version {VERSION}, got {}", self.version),
            );
        }
        if !(16..=8192).contains(&self.size) {
            return bad(
                "size",
                format!("must be 16 to 8192 cells, got {}", self.size),
            );
        }
        if !(self.cell_size.is_finite() && self.cell_size >= MIN_CELL_SIZE_M) {
            return bad(
                "cell_size",
                format!(
                    "must be a number of metres from {MIN_CELL_SIZE_M} up, got {}",
                    self.cell_size
                ),
            );
        }
        if !(self.vertical_scale.is_finite() && (1e-4..=1e4).contains(&self.vertical_scale)) {
            return bad(
                "vertical_scale",
                format!(
                    "must be a factor from 0.0001 to 10000 on every height, got {}",
                    self.vertical_scale
                ),
            );
        }
        Ok(())
    }

    /// The river strokes.
    fn check_rivers(&self) -> Result<(), SceneError> {
        if self.rivers.len() > MAX_RIVERS {
            return bad(
                "rivers",
                format!("at most {MAX_RIVERS} rivers, got {}", self.rivers.len()),
            );
        }
        for (i, r) in self.rivers.iter().enumerate() {
            for (name, p) in [("estuary", r.estuary), ("toward", r.toward)] {
                if !p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)) {
                    return bad(
                        &format!("rivers[{i}].{name}"),
                        format!("must lie in [0, 1] x [0, 1], got {p:?}"),
                    );
                }
            }
            if !(1..=6).contains(&r.phi) {
                return bad(
                    &format!("rivers[{i}].phi"),
                    format!("must be 1 to 6, got {}", r.phi),
                );
            }
            if !(1..=16).contains(&r.depth) {
                return bad(
                    &format!("rivers[{i}].depth"),
                    format!("must be 1 to 16, got {}", r.depth),
                );
            }
        }
        Ok(())
    }

    /// The detail settings and the painted masks.
    fn check_detail(&self) -> Result<(), SceneError> {
        self.check_detail_settings()?;
        self.detail.mask()?;
        self.mask(super::MaskKind::Uplift)?;
        self.mask(super::MaskKind::HardRock)?;
        Ok(())
    }

    /// The detail levels, scope and window; the output size is checked here, before any
    /// stage runs.
    fn check_detail_settings(&self) -> Result<(), SceneError> {
        let d = &self.detail;
        if d.levels > crate::wavelet::synthesis::MAX_LEVELS {
            return bad(
                "detail.levels",
                format!(
                    "must be 0 to {}, got {}",
                    crate::wavelet::synthesis::MAX_LEVELS,
                    d.levels
                ),
            );
        }
        if d.levels > 0 {
            // Checked here, before any stage runs, not after the whole pipeline.
            let side = crate::wavelet::synthesis::output_len(self.size, d.levels) as u64;
            let limit = crate::wavelet::synthesis::MAX_OUTPUT_CELLS;
            if side * side > limit {
                return bad(
                    "detail.levels",
                    format!(
                        "{} levels turn the {size} x {size} terrain into {side} x {side} cells, \
                         above the limit of {limit} cells; use fewer levels or a smaller size",
                        d.levels,
                        size = self.size
                    ),
                );
            }
        }
        if !["global", "local", "local-paper"].contains(&d.scope.as_str()) {
            return bad(
                "detail.scope",
                format!(
                    "must be \"global\", \"local\" or \"local-paper\", got {:?}",
                    d.scope
                ),
            );
        }
        if d.window == 0 || d.window > 65 || d.window.is_multiple_of(2) {
            return bad(
                "detail.window",
                format!("must be an odd number from 1 to 65, got {}", d.window),
            );
        }
        Ok(())
    }

    /// The blended blocks, their references measured from their headers.
    fn check_blend(&self) -> Result<(), SceneError> {
        self.check_blend_totals()?;
        (0..self.blend.len()).try_for_each(|i| self.check_block(i))
    }

    /// How many blocks there are and how many cells their references hold together.
    fn check_blend_totals(&self) -> Result<(), SceneError> {
        if self.blend.len() > MAX_BLEND_BLOCKS {
            return bad(
                "blend",
                format!(
                    "at most {MAX_BLEND_BLOCKS} blocks, got {}",
                    self.blend.len()
                ),
            );
        }
        // The references' sizes from their headers, before any is decoded: the work of
        // decoding and resampling them is bounded with the scene.
        let reference_cells = self
            .blend
            .iter()
            .filter_map(crate::blend::BlendBlock::reference_cells)
            .fold(0u64, u64::saturating_add);
        if reference_cells > MAX_BLEND_REFERENCE_CELLS {
            return bad(
                "blend",
                format!(
                    "the blocks' references hold {reference_cells} cells together, above the \
                     limit of {MAX_BLEND_REFERENCE_CELLS} (two 8192 x 8192 windows); place \
                     smaller windows or fewer blocks"
                ),
            );
        }
        Ok(())
    }

    /// Block `i` (there is none to check past the end).
    fn check_block(&self, i: usize) -> Result<(), SceneError> {
        match self.blend.get(i).map(crate::blend::BlendBlock::validate) {
            Some(Err((field, problem))) => bad(&format!("blend[{i}].{field}"), problem),
            _ => Ok(()),
        }
    }

    /// The hydrology paper's parameters: theta, the river slope, alpha and the noise of eq. 5.
    fn check_paper_params(&self) -> Result<(), SceneError> {
        let p = &self.params;
        if !(p.theta.is_finite() && (1.0..=89.0).contains(&p.theta)) {
            return bad(
                "params.theta",
                format!("must be 1 to 89 degrees, got {}", p.theta),
            );
        }
        if !(p.river_slope.is_finite() && (0.0..=1.0).contains(&p.river_slope)) {
            return bad(
                "params.river_slope",
                format!("must be 0 to 1, got {}", p.river_slope),
            );
        }
        let most = crate::river::course::MAX_WANDER;
        if !(p.wander.is_finite() && (0.0..=most).contains(&p.wander)) {
            return bad(
                "params.wander",
                format!("must be 0 to {most} stroke lengths, got {}", p.wander),
            );
        }
        let widest = crate::river::hydraulic::MAX_ANGLE_DEG;
        let angle = p.meanders.angle_deg;
        if !(angle.is_finite() && (0.0..=widest).contains(&angle)) {
            return bad(
                "params.meanders.angle_deg",
                format!("must be 0 to {widest} degrees, got {angle}"),
            );
        }
        let widths = crate::river::hydraulic::WAVELENGTH_WIDTHS;
        let wavelength = p.meanders.wavelength_widths;
        if !(wavelength.is_finite() && widths.contains(&wavelength)) {
            return bad(
                "params.meanders.wavelength_widths",
                format!(
                    "must be {} to {} channel widths, got {wavelength}",
                    widths.start(),
                    widths.end()
                ),
            );
        }
        if !(p.alpha.is_finite() && (0.0..=10.0).contains(&p.alpha)) {
            return bad("params.alpha", format!("must be 0 to 10, got {}", p.alpha));
        }
        if !(p.noise.amplitude.is_finite() && (0.0..=10_000.0).contains(&p.noise.amplitude)) {
            return bad(
                "params.noise.amplitude",
                format!("must be 0 to 10000 m, got {}", p.noise.amplitude),
            );
        }
        if !(1..=16).contains(&p.noise.octaves) {
            return bad(
                "params.noise.octaves",
                format!("must be 1 to 16, got {}", p.noise.octaves),
            );
        }
        if !(p.noise.roughness.is_finite() && (0.0..=1.0).contains(&p.noise.roughness)) {
            return bad(
                "params.noise.roughness",
                format!("must be 0 to 1, got {}", p.noise.roughness),
            );
        }
        Ok(())
    }

    /// The sketched ridges, valleys and peaks.
    fn check_sketch(&self) -> Result<(), SceneError> {
        let s = &self.sketch;
        let items = s.ridges.len() + s.valleys.len() + s.peaks.len();
        if items > MAX_SKETCH_ITEMS {
            return bad(
                "sketch",
                format!(
                    "at most {MAX_SKETCH_ITEMS} ridges, valleys and peaks together, got {items}"
                ),
            );
        }
        let points: usize = s
            .ridges
            .iter()
            .chain(&s.valleys)
            .map(|l| l.points.len())
            .sum();
        if points > MAX_SKETCH_POINTS_TOTAL {
            return bad(
                "sketch",
                format!(
                    "at most {MAX_SKETCH_POINTS_TOTAL} points in all lines together, got {points}"
                ),
            );
        }
        let in_map = |p: &[f64; 2]| p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v));
        let height_ok =
            |h: Option<f64>| h.is_none_or(|h| h.is_finite() && (-11_000.0..=9_000.0).contains(&h));
        for (kind, lines) in [
            ("ridges", &self.sketch.ridges),
            ("valleys", &self.sketch.valleys),
        ] {
            for (i, line) in lines.iter().enumerate() {
                let field = format!("sketch.{kind}[{i}]");
                if line.points.len() < 2 {
                    return bad(&format!("{field}.points"), "needs at least 2 points".into());
                }
                if line.points.len() > MAX_SKETCH_POINTS {
                    return bad(
                        &format!("{field}.points"),
                        format!(
                            "at most {MAX_SKETCH_POINTS} points, got {}",
                            line.points.len()
                        ),
                    );
                }
                if let Some(p) = line.points.iter().find(|p| !in_map(p)) {
                    return bad(
                        &format!("{field}.points"),
                        format!("{p:?} is outside [0, 1] x [0, 1]"),
                    );
                }
                if !height_ok(line.height) {
                    return bad(
                        &format!("{field}.height"),
                        "must be -11000 to 9000 m".into(),
                    );
                }
                if let Some(h) = &line.heights {
                    if h.len() != line.points.len() {
                        return bad(
                            &format!("{field}.heights"),
                            format!(
                                "needs one height per point ({}), got {}",
                                line.points.len(),
                                h.len()
                            ),
                        );
                    }
                    if h.iter().any(|v| !height_ok(Some(*v))) {
                        return bad(
                            &format!("{field}.heights"),
                            "every height must be -11000 to 9000 m".into(),
                        );
                    }
                }
            }
        }
        for (i, peak) in self.sketch.peaks.iter().enumerate() {
            if !in_map(&peak.at) {
                return bad(
                    &format!("sketch.peaks[{i}].at"),
                    format!("{:?} is outside [0, 1] x [0, 1]", peak.at),
                );
            }
            if !height_ok(peak.height) {
                return bad(
                    &format!("sketch.peaks[{i}].height"),
                    "must be -11000 to 9000 m".into(),
                );
            }
        }
        Ok(())
    }

    /// MD/MDI enrichment and the post-filters.
    fn check_enrichment_and_filters(&self) -> Result<(), SceneError> {
        let p = &self.params;
        if p.enrich.passes > 16 {
            return bad(
                "params.enrich.passes",
                format!("must be 0 to 16, got {}", p.enrich.passes),
            );
        }
        if !(1..=64).contains(&p.enrich.distance_limit) {
            return bad(
                "params.enrich.distance_limit",
                format!("must be 1 to 64 cells, got {}", p.enrich.distance_limit),
            );
        }
        if let Err((field, problem)) = p.post.validate() {
            return bad(&format!("params.post.{field}"), problem);
        }
        Ok(())
    }

    /// The erosion section.
    fn check_erosion(&self) -> Result<(), SceneError> {
        if let Some(Err((field, problem))) = self.erosion.as_ref().map(|e| e.validate()) {
            return bad(&format!("erosion.{field}"), problem);
        }
        Ok(())
    }

    /// The style section.
    fn check_style(&self) -> Result<(), SceneError> {
        if let Some(style) = &self.style {
            if let Some(g) = style
                .gamma
                .iter()
                .find(|g| !(g.is_finite() && (1.0..=6.0).contains(*g)))
            {
                return bad("style.gamma", format!("each must be 1 to 6, got {g}"));
            }
            if !(style.strength.is_finite() && (0.0..=2.0).contains(&style.strength)) {
                return bad(
                    "style.strength",
                    format!("must be 0 to 2, got {}", style.strength),
                );
            }
        }
        Ok(())
    }

    fn check_textures(&self) -> Result<(), SceneError> {
        self.textures.check()
    }

    /// The map's width, from the size and the cell size.
    fn check_extent(&self) -> Result<(), SceneError> {
        if !(self.map_width().is_finite() && self.map_width() <= MAX_MAP_WIDTH_M) {
            return bad(
                "cell_size",
                format!(
                    "the map would be {} m wide; at most 10000 km",
                    self.map_width()
                ),
            );
        }
        Ok(())
    }
}

impl super::TextureRules {
    /// The splat map's rules, each within its range.
    pub fn check(&self) -> Result<(), SceneError> {
        let t = self;
        let within = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
        for (field, value, lo, hi) in [
            ("textures.rock_slope_deg", t.rock_slope_deg, 1.0, 89.0),
            ("textures.snow_above", t.snow_above, 0.0, 1.0),
            ("textures.sediment_area_m2", t.sediment_area_m2, 1.0, 1e12),
            ("textures.softness", t.softness, 0.0, 1.0),
        ] {
            if !within(value, lo, hi) {
                return bad(field, format!("must be {lo} to {hi}, got {value}"));
            }
        }
        Ok(())
    }
}
