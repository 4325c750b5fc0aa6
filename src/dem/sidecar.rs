//! The sidecar JSON beside a PNG or RAW R16 heightmap: the height range (`zmin`, `zmax`),
//! the raster's `width` and `height`, `flip_y`, and keys for people (`decode`, `cell_size_m`,
//! or a curated file's own notes), which are ignored.
//!
//! Rules: the top level is a JSON object; `zmin` and `zmax` come together, are finite
//! numbers within `f32` and `zmin <= zmax` (an inverted range would flip the terrain);
//! `width` and `height` come together and are positive whole numbers; `flip_y` is a boolean.
//! Anything else is an error naming the key, so a malformed sidecar is reported as malformed,
//! never read as a missing range. At most [`MAX_BYTES`] are read.

use super::DemError;

/// The largest sidecar read (a sidecar is a few hundred bytes).
pub const MAX_BYTES: u64 = 1 << 20;

/// What a sidecar says.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sidecar {
    pub z_range: Option<(f32, f32)>,
    /// `(width, height)` in cells.
    pub size: Option<(usize, usize)>,
    pub flip_y: Option<bool>,
}

fn bad(problem: String) -> DemError {
    DemError::Malformed {
        format: "sidecar JSON",
        problem,
    }
}

/// Checks a height range from any source (`source` names it in the message): finite, within
/// `f32`, a finite span, and not inverted.
pub fn check_range(lo: f32, hi: f32, source: &str) -> Result<(), String> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(format!(
            "{source}: the height range {lo},{hi} is not a pair of finite numbers"
        ));
    }
    if lo > hi {
        return Err(format!(
            "{source}: the height range is inverted (min {lo} is above max {hi}); it would \
             flip the terrain upside down"
        ));
    }
    if !(hi - lo).is_finite() {
        return Err(format!(
            "{source}: the height range {lo},{hi} spans more than a 32-bit float holds"
        ));
    }
    Ok(())
}

/// Parses a sidecar.
pub fn parse(bytes: &[u8]) -> Result<Sidecar, DemError> {
    let value: serde_json::Value =
        serde_json::from_slice(bytes).map_err(|e| bad(format!("not valid JSON ({e})")))?;
    let object = value
        .as_object()
        .ok_or_else(|| bad("the top level is not a JSON object ({...})".into()))?;
    let number = |key: &str| -> Result<Option<f64>, DemError> {
        match object.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_f64()
                .filter(|x| x.is_finite())
                .map(Some)
                .ok_or_else(|| bad(format!("\"{key}\" is not a finite number"))),
        }
    };
    let whole = |key: &str| -> Result<Option<usize>, DemError> {
        match object.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_u64()
                .filter(|n| (1..=u64::from(u32::MAX)).contains(n))
                .map(|n| Some(n as usize))
                .ok_or_else(|| bad(format!("\"{key}\" is not a positive whole number"))),
        }
    };
    let z_range = match (number("zmin")?, number("zmax")?) {
        (None, None) => None,
        (Some(lo), Some(hi)) => {
            let (lo32, hi32) = (lo as f32, hi as f32);
            check_range(lo32, hi32, "zmin, zmax").map_err(bad)?;
            Some((lo32, hi32))
        }
        _ => return Err(bad("\"zmin\" and \"zmax\" must come together".into())),
    };
    let size = match (whole("width")?, whole("height")?) {
        (None, None) => None,
        (Some(w), Some(h)) => Some((w, h)),
        _ => return Err(bad("\"width\" and \"height\" must come together".into())),
    };
    let flip_y = match object.get("flip_y") {
        None => None,
        Some(v) => Some(
            v.as_bool()
                .ok_or_else(|| bad("\"flip_y\" is not true or false".into()))?,
        ),
    };
    Ok(Sidecar {
        z_range,
        size,
        flip_y,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_what_the_writer_writes_and_names_what_is_wrong() {
        let ok = br#"{"zmin": -1, "zmax": 88, "width": 3, "height": 2, "flip_y": true,
                      "decode": "z = zmin + v / 65535 * (zmax - zmin)"}"#;
        assert_eq!(
            parse(ok).unwrap(),
            Sidecar {
                z_range: Some((-1.0, 88.0)),
                size: Some((3, 2)),
                flip_y: Some(true)
            }
        );
        for (text, expect) in [
            (&b"{not json"[..], "not valid JSON"),
            (b"[1, 2]", "not a JSON object"),
            (br#"{"zmin": 5, "zmax": 1}"#, "inverted"),
            (br#"{"zmin": "low", "zmax": 1}"#, "\"zmin\""),
            (br#"{"zmin": 1}"#, "together"),
            (br#"{"zmin": -3e38, "zmax": 3e38}"#, "spans more"),
            (br#"{"zmin": 0, "zmax": 1e300}"#, "finite"),
            (br#"{"width": 0, "height": 2}"#, "\"width\""),
            (br#"{"flip_y": "yes"}"#, "\"flip_y\""),
        ] {
            let err = parse(text).unwrap_err().to_string();
            assert!(err.contains(expect), "{err}");
        }
        assert_eq!(parse(b"{}").unwrap(), Sidecar::default());
    }
}
