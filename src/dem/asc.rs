//! ESRI ASCII grids (`.asc`): a header of `key value` lines (`ncols`, `nrows`, `xllcorner` or
//! `xllcenter`, `yllcorner` or `yllcenter`, `cellsize`, optional `NODATA_value`), then
//! `nrows` rows of `ncols` numbers from north to south.
//!
//! Reading checks the header's size against the limits before allocating, requires exactly
//! `nrows * ncols` values, maps `NODATA_value` and `nan` tokens (GDAL writes them for NaN
//! cells of float rasters) to no-data, and rejects `inf` tokens with their row and column.
//! Writing uses Rust's shortest
//! round-trip formatting of `f32`, so a read of a written file is bit-exact.

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;

/// The no-data value written for NaN cells (unless a height uses it).
pub const NODATA: f32 = -9999.0;

fn bad(problem: String) -> DemError {
    DemError::Malformed {
        format: "ESRI ASCII grid",
        problem,
    }
}

#[derive(Default)]
struct Header {
    ncols: Option<usize>,
    nrows: Option<usize>,
    xll: Option<(f64, bool)>,
    yll: Option<(f64, bool)>,
    cellsize: Option<f64>,
    nodata: Option<f32>,
}

/// Reads a grid from its bytes (ASCII / UTF-8 text).
pub fn read(bytes: &[u8], limits: ReadLimits) -> Result<Dem, DemError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        bad(format!(
            "not text: invalid byte at offset {}",
            e.valid_up_to()
        ))
    })?;
    let mut header = Header::default();
    let mut rest = text;
    // Header lines: a keyword, then a value. The first line starting with a number ends it.
    loop {
        let line_end = rest.find('\n').map_or(rest.len(), |i| i + 1);
        let line = &rest[..line_end];
        let mut tokens = line.split_whitespace();
        let Some(key) = tokens.next() else {
            if line_end == 0 {
                break;
            }
            rest = &rest[line_end..];
            continue;
        };
        if key.parse::<f32>().is_ok() {
            break; // a number (or `nan`): the data starts here
        }
        let value = tokens.next().ok_or_else(|| {
            bad(format!(
                "header line '{}' has no value",
                super::clip(line.trim())
            ))
        })?;
        let number = |what: &str| -> Result<f64, DemError> {
            value
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    bad(format!(
                        "{what} must be a finite number, got '{}'",
                        super::clip(value)
                    ))
                })
        };
        let count = |what: &str| -> Result<usize, DemError> {
            value.parse::<usize>().map_err(|_| {
                bad(format!(
                    "{what} must be a whole number, got '{}'",
                    super::clip(value)
                ))
            })
        };
        match key.to_ascii_lowercase().as_str() {
            "ncols" => header.ncols = Some(count("ncols")?),
            "nrows" => header.nrows = Some(count("nrows")?),
            "xllcorner" => header.xll = Some((number("xllcorner")?, false)),
            "xllcenter" => header.xll = Some((number("xllcenter")?, true)),
            "yllcorner" => header.yll = Some((number("yllcorner")?, false)),
            "yllcenter" => header.yll = Some((number("yllcenter")?, true)),
            "cellsize" | "dx" => header.cellsize = Some(number("cellsize")?),
            "dy" => {}
            "nodata_value" => header.nodata = Some(number("NODATA_value")? as f32),
            other => {
                return Err(bad(format!(
                    "unknown header keyword '{}'",
                    super::clip(other)
                )));
            }
        }
        rest = &rest[line_end..];
    }
    let ncols = header
        .ncols
        .ok_or_else(|| bad("the header has no ncols".into()))?;
    let nrows = header
        .nrows
        .ok_or_else(|| bad("the header has no nrows".into()))?;
    limits.check(ncols as u64, nrows as u64)?;
    let cellsize = header
        .cellsize
        .ok_or_else(|| bad("the header has no cellsize".into()))?;
    if cellsize <= 0.0 {
        return Err(bad(format!("cellsize must be positive, got {cellsize}")));
    }
    let expected = ncols * nrows;
    // Every value takes at least two bytes ("0 "): a short file cannot reserve a large grid.
    let mut data = Vec::with_capacity(expected.min(rest.len() / 2 + 1));
    for token in rest.split_whitespace() {
        if data.len() == expected {
            return Err(bad(format!(
                "more than nrows x ncols = {expected} values (header and data disagree)"
            )));
        }
        let v: f32 = token.parse().map_err(|_| {
            let i = data.len();
            bad(format!(
                "row {}, column {}: '{}' is not a number",
                i / ncols,
                i % ncols,
                super::clip(token)
            ))
        })?;
        if v.is_infinite() {
            let i = data.len();
            return Err(bad(format!(
                "row {}, column {}: '{}' is not a finite height (mark missing cells with \
                 NODATA_value)",
                i / ncols,
                i % ncols,
                super::clip(token)
            )));
        }
        // `nan` (GDAL writes it for NaN cells of float rasters) and NODATA_value: no data.
        data.push(if Some(v) == header.nodata {
            f32::NAN
        } else {
            v
        });
    }
    if data.len() != expected {
        return Err(bad(format!(
            "truncated: nrows x ncols = {expected} values expected, found {}",
            data.len()
        )));
    }
    let field = Heightfield::from_vec(ncols, nrows, data).map_err(|_| DemError::Empty)?;
    // Outer corner of the raster (upper left) for the GeoTIFF-style georeferencing.
    let (xll, x_centre) = header.xll.unwrap_or((0.0, false));
    let (yll, y_centre) = header.yll.unwrap_or((0.0, false));
    let left = if x_centre { xll - cellsize / 2.0 } else { xll };
    let bottom = if y_centre { yll - cellsize / 2.0 } else { yll };
    let top = bottom + cellsize * nrows as f64;
    if !(left.is_finite() && top.is_finite() && (left + cellsize * ncols as f64).is_finite()) {
        return Err(bad(format!(
            "the grid's extent overflows (corner {left}, {bottom}, cell size {cellsize})"
        )));
    }
    let georef = GeoRef {
        pixel_scale: Some(vec![cellsize, cellsize, 0.0]),
        tiepoint: Some(vec![0.0, 0.0, 0.0, left, top, 0.0]),
        ..Default::default()
    };
    Ok(Dem { field, georef })
}

/// Writes `field` with the georeferencing's corner and cell size when known (else corner 0, 0
/// and `cell_size`). A non-finite or non-positive cell size, or a corner that is not finite,
/// is refused rather than written.
pub fn write(field: &Heightfield, georef: &GeoRef, cell_size: f64) -> Result<Vec<u8>, DemError> {
    crate::jobs::run_inline(|ctx| async move { write_in(field, georef, cell_size, &ctx).await })
}

/// [`write`] in a job: a tick after each row.
pub async fn write_in(
    field: &Heightfield,
    georef: &GeoRef,
    cell_size: f64,
    ctx: &crate::jobs::JobCtx,
) -> Result<Vec<u8>, DemError> {
    use std::fmt::Write as _;
    let cell = georef.cell_size().map_or(cell_size, |(sx, _)| sx);
    let (left, top) = georef
        .tiepoint
        .as_ref()
        .filter(|t| t.len() >= 6 && t[0] == 0.0 && t[1] == 0.0)
        .map_or((0.0, cell * field.height() as f64), |t| (t[3], t[4]));
    let bottom = top - cell * field.height() as f64;
    if !(cell.is_finite() && cell > 0.0) {
        return Err(DemError::Write(format!(
            "an ASCII grid needs a positive, finite cell size, got {cell}"
        )));
    }
    if !(left.is_finite() && bottom.is_finite() && top.is_finite()) {
        return Err(DemError::Write(format!(
            "the grid's corner ({left}, {bottom}) is not finite"
        )));
    }
    let mut nodata = NODATA;
    for _ in 0..8 {
        if !field.data().contains(&nodata) {
            break;
        }
        nodata = nodata * 10.0 - 9.0;
    }
    let mut out = String::with_capacity(field.data().len() * 8 + 200);
    let _ = writeln!(out, "ncols {}", field.width());
    let _ = writeln!(out, "nrows {}", field.height());
    let _ = writeln!(out, "xllcorner {left}");
    let _ = writeln!(out, "yllcorner {bottom}");
    let _ = writeln!(out, "cellsize {cell}");
    let _ = writeln!(out, "NODATA_value {nodata}");
    for (y, row) in field.data().chunks(field.width()).enumerate() {
        ctx.tick_of(y, field.height(), "writing the ASCII grid")
            .await
            .map_err(|_| DemError::Cancelled)?;
        for (i, &z) in row.iter().enumerate() {
            if i > 0 {
                out.push(' ');
            }
            let _ = write!(out, "{}", if z.is_finite() { z } else { nodata });
        }
        out.push('\n');
    }
    Ok(out.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_grid_reads_back_bit_exactly() {
        let data = vec![1.5, -0.1, f32::NAN, 1e-7, 12345.678, -9999.0];
        let field = Heightfield::from_vec(3, 2, data.clone()).unwrap();
        let bytes = write(&field, &GeoRef::default(), 30.0).unwrap();
        let back = read(&bytes, ReadLimits::default()).unwrap();
        for (a, b) in data.iter().zip(back.field.data()) {
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
        }
        assert_eq!(back.georef.cell_size(), Some((30.0, 30.0)));
    }

    #[test]
    fn bad_grids_are_named() {
        let ok = "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n";
        assert!(read(ok.as_bytes(), ReadLimits::default()).is_ok());
        let short = "ncols 2\nnrows 2\ncellsize 1\n1 2\n3\n";
        let e = read(short.as_bytes(), ReadLimits::default()).unwrap_err();
        assert!(e.to_string().contains("truncated"), "{e}");
        let inf = "ncols 2\nnrows 1\ncellsize 1\n1 inf\n";
        let e = read(inf.as_bytes(), ReadLimits::default()).unwrap_err();
        assert!(e.to_string().contains("row 0, column 1"), "{e}");
        let huge = "ncols 100000\nnrows 100000\ncellsize 1\n1\n";
        assert!(matches!(
            read(huge.as_bytes(), ReadLimits::default()),
            Err(DemError::TooLarge { .. })
        ));
        let long = format!("ncols 2\nnrows 1\ncellsize 1\n1 {}\n", "x".repeat(100_000));
        let e = read(long.as_bytes(), ReadLimits::default()).unwrap_err();
        assert!(e.to_string().len() < 200, "{e}");
        let inf_corner = GeoRef {
            pixel_scale: Some(vec![f64::INFINITY, 1.0, 0.0]),
            ..Default::default()
        };
        let field = Heightfield::filled(2, 2, 1.0).unwrap();
        assert!(write(&field, &GeoRef::default(), f64::NAN).is_err());
        assert!(write(&field, &inf_corner, 1.0).is_err());
        let nodata = "ncols 2\nnrows 1\ncellsize 1\nNODATA_value -1\n5 -1\n";
        let dem = read(nodata.as_bytes(), ReadLimits::default()).unwrap();
        assert!(dem.field.data()[1].is_nan());
    }
}
