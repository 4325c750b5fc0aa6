//! The engine-export options `generate` and `convert` share (`--preset`, `--tiles`,
//! `--maps`, `--normals`): they turn `--out`/OUT into a set of files named after it, made by
//! [`crate::export::files`].

use std::path::{Path, PathBuf};

use clap::Args;

use crate::dem::format::Format;
use crate::export::{Engine, MapKind, NormalConvention, Request};

use super::output::Outputs;

#[derive(Debug, Args, Default)]
pub struct PackageArgs {
    /// An engine preset: unreal, unity, godot, gis or gaea-wm. The heightmap is written at a
    /// size the engine takes (its largest not above the terrain's, or --export-size / --size)
    /// in a format it reads, with STEM-ENGINE.json and .txt giving the numbers to type in.
    #[arg(long, value_name = "ENGINE", value_parser = parse_engine)]
    pub preset: Option<Engine>,
    /// Split the heightmap into COLUMNSxROWS tiles that share their edges (STEM_x0_y0.EXT ...
    /// and STEM-tiles.json), one height range for all.
    #[arg(long, value_name = "CxR", value_parser = parse_tiles)]
    pub tiles: Option<(usize, usize)>,
    /// Texture maps beside the heightmap, comma-separated: normal, slope, curvature, flow,
    /// erosion, water, splat, basins (STEM-normal.png ...).
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_map)]
    pub maps: Vec<MapKind>,
    /// Normal map convention: gl (OpenGL: Unity, Godot, Blender) or dx (DirectX: Unreal)
    /// [default: dx for unreal, else gl].
    #[arg(long, value_name = "gl|dx", value_parser = parse_normals)]
    pub normals: Option<NormalConvention>,
}

impl PackageArgs {
    /// Whether any option asks for more than one plain heightmap.
    pub fn wanted(&self) -> bool {
        self.preset.is_some() || self.tiles.is_some() || !self.maps.is_empty()
    }

    /// The request writing `out` (its stem and format) at `size` (`None`: the preset's
    /// default or the terrain's own, `native`).
    pub fn request(
        &self,
        out: &Path,
        size: Option<usize>,
        flip_y: bool,
        z_scale: f32,
        native: usize,
    ) -> Result<Request, String> {
        let format = Format::from_name(&out.to_string_lossy()).ok_or_else(|| {
            format!(
                "{}: unknown output format; use .png, .r16, .r32, .exr, .tif, .asc or .hgt",
                out.display()
            )
        })?;
        let mut request = match self.preset {
            Some(engine) => Request::for_engine(engine, native),
            None => Request::heightmap(format),
        };
        request.format = format;
        if size.is_some() {
            request.size = size;
        }
        request.flip_y |= flip_y;
        request.z_scale = z_scale;
        request.tiles = self.tiles;
        request.maps = self.maps.clone();
        if let Some(n) = self.normals {
            request.normals = n;
        }
        request.stem = out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "strahler-heightmap".into());
        Ok(request)
    }
}

/// Where the files of `request` go: beside `out`.
pub fn paths(out: &Path, request: &Request) -> Vec<PathBuf> {
    let dir = out.parent().unwrap_or(Path::new(""));
    request.names().iter().map(|n| dir.join(n)).collect()
}

/// Claims every file `request` writes beside `out`.
pub fn claim(outputs: &mut Outputs, out: &Path, request: &Request) -> Result<(), String> {
    for path in paths(out, request) {
        outputs.claim(&path, "export").map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Writes `files` beside `out` (claimed by [`claim`]) and says what was written.
pub fn write(outputs: &Outputs, out: &Path, files: &[crate::export::File]) -> Result<(), String> {
    let dir = out.parent().unwrap_or(Path::new(""));
    for file in files {
        outputs
            .write(&dir.join(&file.name), &file.bytes)
            .map_err(|e| e.to_string())?;
    }
    let names: Vec<&str> = files.iter().map(|f| f.name.as_str()).collect();
    println!("export: {}", names.join(", "));
    Ok(())
}

fn parse_engine(text: &str) -> Result<Engine, String> {
    Engine::from_key(text).ok_or_else(|| {
        let keys: Vec<_> = Engine::ALL.iter().map(|e| e.key()).collect();
        format!("unknown preset {text:?}; use one of {}", keys.join(", "))
    })
}

fn parse_tiles(text: &str) -> Result<(usize, usize), String> {
    let (c, r) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("tiles are COLUMNSxROWS, e.g. 2x2, got {text:?}"))?;
    let whole = |v: &str| {
        v.trim()
            .parse::<usize>()
            .ok()
            .filter(|n| (1..=64).contains(n))
            .ok_or_else(|| format!("{v:?} is not a number of tiles from 1 to 64"))
    };
    Ok((whole(c)?, whole(r)?))
}

fn parse_map(text: &str) -> Result<MapKind, String> {
    MapKind::from_key(text).ok_or_else(|| {
        let keys: Vec<_> = MapKind::ALL.iter().map(|m| m.key()).collect();
        format!("unknown map {text:?}; use {}", keys.join(", "))
    })
}

fn parse_normals(text: &str) -> Result<NormalConvention, String> {
    match text.to_ascii_lowercase().as_str() {
        "gl" | "opengl" => Ok(NormalConvention::OpenGl),
        "dx" | "directx" => Ok(NormalConvention::DirectX),
        _ => Err(format!("normals are gl or dx, got {text:?}")),
    }
}
