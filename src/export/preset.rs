//! Engine presets: the sizes each engine takes, the format it reads, and the numbers a user
//! types into it so the terrain comes in at its real size and height.
//!
//! - **Unreal Engine** Landscape ("Landscape Technical Guide", recommended sizes table):
//!   127, 253, 505, 1009, 2017, 4033 and 8129 vertices a side; 16-bit PNG or RAW. A sample
//!   `v` stands at `(v - 32768) / 128 * ZScale` cm above the actor, so a Z scale of 100
//!   spans 512 m; the X/Y scale is the vertex spacing in cm ("Landscape Technical Guide",
//!   "Calculating Heightmap Z Scale").
//! - **Unity** Terrain (`TerrainData.heightmapResolution`: `2^n + 1` from 33 to 4097; "Import
//!   Raw Heightmap": 16-bit, byte order Windows (little-endian), its first row at the
//!   terrain's south edge, hence the rows bottom-up). Terrain width and length in metres,
//!   height = the range; the terrain object at `y = zmin`.
//! - **Godot** heightmap plugins (Terrain3D, HTerrain; Godot's `Image` limit of 16384
//!   pixels a side): OpenEXR float heights in metres (or R16 with the range).
//! - **GIS**: float GeoTIFF at the terrain's own size, georeferenced.
//! - **Gaea / World Machine**: RAW R32 floats in metres (or EXR).

use crate::dem::format::Format;

/// An engine (or family of tools) an export is made for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Engine {
    Unreal,
    Unity,
    Godot,
    Gis,
    GaeaWm,
}

/// The largest side Godot's `Image` holds (`Image::MAX_WIDTH`).
pub const GODOT_MAX_SIDE: usize = 16384;

const UNREAL_SIZES: [usize; 7] = [127, 253, 505, 1009, 2017, 4033, 8129];
const UNITY_SIZES: [usize; 8] = [33, 65, 129, 257, 513, 1025, 2049, 4097];
const GODOT_SIZES: [usize; 6] = [257, 513, 1025, 2049, 4097, 8193];
const GAEA_SIZES: [usize; 6] = [256, 512, 1024, 2048, 4096, 8192];

impl Engine {
    pub const ALL: [Engine; 5] = [
        Engine::Unreal,
        Engine::Unity,
        Engine::Godot,
        Engine::Gis,
        Engine::GaeaWm,
    ];

    /// The key on the command line and in `exportHeightmap`.
    pub fn key(self) -> &'static str {
        match self {
            Engine::Unreal => "unreal",
            Engine::Unity => "unity",
            Engine::Godot => "godot",
            Engine::Gis => "gis",
            Engine::GaeaWm => "gaea-wm",
        }
    }

    pub fn from_key(key: &str) -> Option<Engine> {
        Engine::ALL
            .into_iter()
            .find(|e| e.key().eq_ignore_ascii_case(key))
    }

    pub fn label(self) -> &'static str {
        match self {
            Engine::Unreal => "Unreal Engine",
            Engine::Unity => "Unity",
            Engine::Godot => "Godot",
            Engine::Gis => "GIS (QGIS, GDAL)",
            Engine::GaeaWm => "Gaea / World Machine",
        }
    }

    /// The sizes the engine takes, smallest first; empty: the terrain's own size only.
    pub fn sizes(self) -> &'static [usize] {
        match self {
            Engine::Unreal => &UNREAL_SIZES,
            Engine::Unity => &UNITY_SIZES,
            Engine::Godot => &GODOT_SIZES,
            Engine::Gis => &[],
            Engine::GaeaWm => &GAEA_SIZES,
        }
    }

    /// The formats it reads, the usual one first.
    pub fn formats(self) -> &'static [Format] {
        match self {
            Engine::Unreal => &[Format::Png, Format::R16],
            Engine::Unity => &[Format::R16],
            Engine::Godot => &[Format::Exr, Format::R16],
            Engine::Gis => &[Format::GeoTiff],
            Engine::GaeaWm => &[Format::R32, Format::Exr],
        }
    }

    /// Whether rows are written bottom-up (Unity's RAW import).
    pub fn flip_y(self) -> bool {
        self == Engine::Unity
    }

    /// The size it gets by default for a terrain of `native` cells a side: the largest it
    /// takes that does not enlarge the terrain (the smallest when all do), or the terrain's
    /// own.
    pub fn default_size(self, native: usize) -> usize {
        let sizes = self.sizes();
        match sizes.iter().rev().find(|&&n| n <= native) {
            Some(&n) => n,
            None => sizes.first().copied().unwrap_or(native),
        }
    }

    /// Checks that the engine takes `size` and `format`, with the sizes it takes named.
    pub fn check(self, size: usize, native: usize, format: Format) -> Result<(), String> {
        let sizes = self.sizes();
        let ok = if sizes.is_empty() {
            size == native
        } else {
            sizes.contains(&size)
        };
        if !ok {
            let list = if sizes.is_empty() {
                format!("the terrain's own size, {native}")
            } else {
                sizes
                    .iter()
                    .map(usize::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(format!(
                "{} takes {list} cells a side, not {size}",
                self.label()
            ));
        }
        if !self.formats().contains(&format) {
            let names: Vec<_> = self.formats().iter().map(|f| f.extension()).collect();
            return Err(format!(
                "{} reads .{} here, not .{}",
                self.label(),
                names.join(" or ."),
                format.extension()
            ));
        }
        Ok(())
    }
}

/// The numbers to type into the engine for a heightmap of `size` vertices a side spanning
/// `extent_m` metres with heights `zmin..zmax` metres.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EngineNumbers {
    pub engine: &'static str,
    pub size: usize,
    pub format: &'static str,
    pub extent_m: f64,
    /// Vertex spacing in metres.
    pub spacing_m: f64,
    pub zmin_m: f64,
    pub zmax_m: f64,
    /// Metres per step of the 16-bit range (0 for float formats).
    pub metres_per_step: f64,
    pub flip_y: bool,
    /// Each line: what to set, and its value.
    pub settings: Vec<(String, String)>,
}

/// Unreal's centimetres per 16-bit step at Z scale 1 (`1 / 128`).
const UNREAL_CM_PER_STEP_AT_SCALE_1: f64 = 1.0 / 128.0;

impl EngineNumbers {
    pub fn new(
        engine: Engine,
        format: Format,
        size: usize,
        extent_m: f64,
        (zmin, zmax): (f64, f64),
    ) -> Self {
        let spacing = extent_m / (size.max(2) - 1) as f64;
        let range = zmax - zmin;
        let sixteen = matches!(format, Format::Png | Format::R16);
        let metres_per_step = if sixteen { range / 65535.0 } else { 0.0 };
        let m = |v: f64| format!("{v:.3} m");
        let mut settings: Vec<(String, String)> = Vec::new();
        let mut set = |k: &str, v: String| settings.push((k.to_owned(), v));
        match engine {
            Engine::Unreal => {
                // 65535 steps must span the range: steps * ZScale / 128 cm = range * 100 cm.
                let z_scale = range * 100.0 / (65535.0 * UNREAL_CM_PER_STEP_AT_SCALE_1);
                // Sample 0 (zmin) stands 32768 steps below the actor.
                let location_z = zmin * 100.0 + 32768.0 * z_scale * UNREAL_CM_PER_STEP_AT_SCALE_1;
                set("Scale X", format!("{:.4}", spacing * 100.0));
                set("Scale Y", format!("{:.4}", spacing * 100.0));
                set("Scale Z", format!("{z_scale:.4}"));
                set("Location Z (cm)", format!("{location_z:.1}"));
            }
            Engine::Unity => {
                set("Terrain Width", m(extent_m));
                set("Terrain Length", m(extent_m));
                set("Terrain Height", m(range));
                set("Heightmap Resolution", size.to_string());
                set("Depth / Byte Order", "Bit 16 / Windows".into());
                set("Flip Vertically", "off (rows are written bottom-up)".into());
                set("Position Y", m(zmin));
            }
            Engine::Godot => {
                set("Vertex spacing", m(spacing));
                if sixteen {
                    set("Min height", m(zmin));
                    set("Max height", m(zmax));
                } else {
                    set("Height scale", "1 (EXR holds metres)".into());
                }
            }
            Engine::Gis => {
                set("Cell size", m(spacing));
                set(
                    "CRS",
                    "local metric grid, north-west corner at (0, 0)".into(),
                );
            }
            Engine::GaeaWm => {
                set("Resolution", size.to_string());
                set("Terrain width", m(extent_m));
                set("Height", m(range));
                set("Base height", m(zmin));
            }
        }
        EngineNumbers {
            engine: engine.key(),
            size,
            format: format.extension(),
            extent_m,
            spacing_m: spacing,
            zmin_m: zmin,
            zmax_m: zmax,
            metres_per_step,
            flip_y: engine.flip_y(),
            settings,
        }
    }

    /// The short text beside the heightmap: what to type where.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{} x {} {} heightmap, {:.1} m across ({:.3} m between vertices), heights {:.2} to \
             {:.2} m",
            self.size,
            self.size,
            self.format,
            self.extent_m,
            self.spacing_m,
            self.zmin_m,
            self.zmax_m
        );
        if self.metres_per_step > 0.0 {
            out.push_str(&format!(", {:.4} m per 16-bit step", self.metres_per_step));
        }
        out.push_str(".\n");
        for (k, v) in &self.settings {
            out.push_str(&format!("{k}: {v}\n"));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unreal: a Z scale of 100 spans 512 m, sample 32768 sits at the actor, and the
    /// documented sizes are `components x sections x quads + 1`.
    #[test]
    fn unreal_numbers_follow_its_documented_mapping() {
        let n = EngineNumbers::new(
            Engine::Unreal,
            Format::Png,
            1009,
            1008.0,
            (0.0, 65535.0 / 128.0),
        );
        let get = |k: &str| {
            n.settings
                .iter()
                .find(|(key, _)| key == k)
                .map(|(_, v)| v.parse::<f64>().unwrap())
                .unwrap()
        };
        assert!((get("Scale Z") - 100.0).abs() < 1e-9);
        assert!((get("Scale X") - 100.0).abs() < 1e-9);
        // Sample 0 at -32768 / 128 m below the actor: the actor at 256 m puts it at 0.
        assert!((get("Location Z (cm)") - 25600.0).abs() < 0.1);
        for size in Engine::Unreal.sizes() {
            let quads = size - 1;
            assert!(
                [(63, 1), (63, 2), (127, 1), (127, 2)]
                    .iter()
                    .any(|(q, s)| quads % (q * s) == 0),
                "{size}"
            );
        }
    }

    #[test]
    fn sizes_follow_each_engine_rule() {
        for n in Engine::Unity.sizes() {
            assert!((n - 1).is_power_of_two() && (33..=4097).contains(n));
        }
        assert!(Engine::Godot.sizes().iter().all(|&n| n <= GODOT_MAX_SIDE));
        assert_eq!(Engine::Unreal.default_size(4096), 4033);
        assert_eq!(Engine::Unity.default_size(1024), 513);
        assert_eq!(Engine::Unreal.default_size(64), 127);
        assert_eq!(Engine::Gis.default_size(777), 777);
        let err = Engine::Unreal.check(1024, 1024, Format::Png).unwrap_err();
        assert!(err.contains("1009, 2017"), "{err}");
        let err = Engine::Unity.check(513, 1024, Format::Png).unwrap_err();
        assert!(err.contains(".r16"), "{err}");
        assert!(Engine::Gis.check(777, 777, Format::GeoTiff).is_ok());
        assert_eq!(Engine::from_key("GAEA-WM"), Some(Engine::GaeaWm));
    }

    #[test]
    fn unity_and_step_numbers() {
        let n = EngineNumbers::new(Engine::Unity, Format::R16, 513, 2000.0, (100.0, 1100.0));
        assert!(n.flip_y);
        assert!((n.metres_per_step - 1000.0 / 65535.0).abs() < 1e-12);
        assert!(
            n.text().contains("Terrain Height: 1000.000 m"),
            "{}",
            n.text()
        );
        let f = EngineNumbers::new(Engine::GaeaWm, Format::R32, 512, 2000.0, (0.0, 1.0));
        assert_eq!(f.metres_per_step, 0.0);
    }
}
