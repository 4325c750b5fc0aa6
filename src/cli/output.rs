//! Safe writes: the one way every subcommand writes a file (heightmaps, their sidecars,
//! layers, reports).
//!
//! The rules, which every new writer must follow by going through [`Outputs`]:
//!
//! 1. **Claimed first.** Every output (and every sidecar it brings) is claimed before any work
//!    is done or any byte is written; [`Outputs::write`] refuses a path that was not claimed.
//! 2. **Nothing the run reads or writes twice is overwritten.** A claimed output equal to an
//!    input, to the scene, to an input's sidecar, or to another output of the same run is
//!    refused. Paths are compared canonicalised (symbolic links, `..`, relative paths
//!    resolved); a path that does not exist yet is compared by its canonical folder and file
//!    name; on Unix two existing paths to the same file (hard links) are the same path.
//! 3. **A sidecar never replaces a file the run did not write.** The `.json` beside a PNG or
//!    RAW R16 output may replace an existing file only when that file is the sidecar Strahler
//!    wrote for that same output (a JSON object with the `decode` key, the output file
//!    present, and no other heightmap of the same stem beside it whose sidecar it could be).
//!    Anything else (a scene, a curated sidecar, an input's sidecar) is refused unless
//!    `--force` is given, and the message names the file and `--force`.
//! 4. **Atomic.** Bytes go to a temporary file in the destination's folder, are flushed to
//!    disk (`fsync`) and renamed over the destination; on any error the temporary file is
//!    removed. A failed write leaves the old file (or nothing), never an empty or truncated
//!    one.

use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

use thiserror::Error;

use crate::dem::format::Format;

/// Why an output was refused or could not be written.
#[derive(Debug, Error)]
pub enum OutputError {
    #[error(
        "{path}: the {role} would overwrite the {other_role} ({other}); choose another output \
         name"
    )]
    Collision {
        path: String,
        role: String,
        other: String,
        other_role: String,
    },
    #[error(
        "{path} already exists and is not the sidecar of {output}: writing {output} would \
         replace it; move it, choose another output name, or pass --force to replace it"
    )]
    SidecarExists { path: String, output: String },
    #[error("cannot write {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write {path}: it was not claimed as an output of this run (a bug)")]
    Unclaimed { path: String },
}

/// A path as compared: canonical, plus the file's identity when it exists.
#[derive(Clone, Debug)]
struct Key {
    path: PathBuf,
    id: Option<(u64, u64)>,
}

impl Key {
    fn of(path: &Path) -> Self {
        let canonical = fs::canonicalize(path).ok().unwrap_or_else(|| {
            let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
            match (abs.parent(), abs.file_name()) {
                (Some(parent), Some(name)) => fs::canonicalize(parent)
                    .map(|p| p.join(name))
                    .unwrap_or(abs.clone()),
                _ => abs,
            }
        });
        Self {
            path: canonical,
            id: file_id(path),
        }
    }

    fn same(&self, other: &Key) -> bool {
        self.path == other.path || (self.id.is_some() && self.id == other.id)
    }
}

#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt as _;
    fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_: &Path) -> Option<(u64, u64)> {
    None
}

struct Entry {
    shown: PathBuf,
    key: Key,
    role: String,
}

/// The files a run reads and writes; see the module's rules.
pub struct Outputs {
    inputs: Vec<Entry>,
    outputs: Vec<Entry>,
    force: bool,
}

/// Whether a file name is a heightmap that carries a sidecar (PNG, RAW R16).
fn has_sidecar(path: &Path) -> bool {
    matches!(
        Format::from_name(&path.to_string_lossy()),
        Some(Format::Png | Format::R16)
    )
}

/// The sidecar beside a PNG or RAW heightmap.
pub fn sidecar_of(path: &Path) -> PathBuf {
    path.with_extension("json")
}

impl Outputs {
    /// `force`: let sidecars replace files this run did not write (`--force`).
    pub fn new(force: bool) -> Self {
        Self {
            inputs: Vec::new(),
            outputs: Vec::new(),
            force,
        }
    }

    /// Registers a file the run reads (`role`: "input", "scene", "mask"...). A PNG or RAW
    /// input's sidecar is registered with it.
    pub fn input(&mut self, path: &Path, role: &str) {
        self.inputs.push(Entry {
            shown: path.to_path_buf(),
            key: Key::of(path),
            role: role.to_owned(),
        });
        if has_sidecar(path) {
            let sidecar = sidecar_of(path);
            self.inputs.push(Entry {
                key: Key::of(&sidecar),
                shown: sidecar,
                role: format!("sidecar of the {role} {}", path.display()),
            });
        }
    }

    /// Claims an output (`role`: "output", "report"...), refusing a path already read or
    /// written by this run.
    pub fn claim(&mut self, path: &Path, role: &str) -> Result<(), OutputError> {
        let key = Key::of(path);
        if let Some(other) = self
            .inputs
            .iter()
            .chain(&self.outputs)
            .find(|e| e.key.same(&key))
        {
            return Err(OutputError::Collision {
                path: path.display().to_string(),
                role: role.to_owned(),
                other: other.shown.display().to_string(),
                other_role: other.role.clone(),
            });
        }
        self.outputs.push(Entry {
            shown: path.to_path_buf(),
            key,
            role: role.to_owned(),
        });
        Ok(())
    }

    /// Claims a heightmap output and, for PNG and RAW R16, its sidecar (rule 3).
    pub fn claim_dem(&mut self, path: &Path, role: &str) -> Result<(), OutputError> {
        self.claim(path, role)?;
        if has_sidecar(path) {
            let sidecar = sidecar_of(path);
            self.claim(&sidecar, &format!("sidecar of the {role}"))?;
            if !self.force && sidecar.exists() && !is_own_sidecar(&sidecar, path) {
                return Err(OutputError::SidecarExists {
                    path: sidecar.display().to_string(),
                    output: path.display().to_string(),
                });
            }
        }
        Ok(())
    }

    /// Writes `bytes` to a claimed `path`, atomically.
    pub fn write(&self, path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
        let key = Key::of(path);
        if !self.outputs.iter().any(|e| e.key.same(&key)) {
            return Err(OutputError::Unclaimed {
                path: path.display().to_string(),
            });
        }
        write_atomic(path, bytes)
    }
}

/// Whether `sidecar` is the sidecar Strahler wrote for `output` (rule 3).
fn is_own_sidecar(sidecar: &Path, output: &Path) -> bool {
    if !output.is_file() {
        return false;
    }
    let output_key = Key::of(output);
    let sibling = ["png", "PNG", "r16", "R16", "raw", "RAW"]
        .iter()
        .map(|ext| output.with_extension(ext))
        .any(|p| p.is_file() && !Key::of(&p).same(&output_key));
    if sibling {
        return false;
    }
    let small = fs::metadata(sidecar).is_ok_and(|m| m.is_file() && m.len() <= 64 * 1024);
    small
        && fs::read(sidecar)
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .is_some_and(|v| {
                v.get("decode").and_then(|d| d.as_str()).is_some()
                    && v.get("zmin").is_some()
                    && v.get("zmax").is_some()
            })
}

/// Writes `bytes` to `path` through a temporary file in the same folder, flushed and renamed
/// into place; the temporary file is removed on any error (rule 4).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let io = |source: std::io::Error| OutputError::Io {
        path: path.display().to_string(),
        source,
    };
    let name = path.file_name().ok_or_else(|| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file name",
        ))
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // The output's name, cut to 64 characters, so that any name the file system takes for
    // the output also fits its temporary file (255 bytes is the usual limit).
    let stem: String = name.to_string_lossy().chars().take(64).collect();
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(stem);
    tmp_name.push(format!(
        ".strahler-tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let tmp = dir.join(tmp_name);
    let mut file = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(io)?;
    let result = (|| {
        file.write_all(bytes)?;
        // A replaced file keeps its permissions.
        if let Ok(meta) = fs::metadata(path)
            && meta.is_file()
        {
            let _ = file.set_permissions(meta.permissions());
        }
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if let Err(err) = result {
        let _ = fs::remove_file(&tmp);
        return Err(io(err));
    }
    // The rename itself survives a crash once the folder is flushed (best effort).
    #[cfg(unix)]
    if let Ok(d) = fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("strahler-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| {
                let n = e.unwrap().file_name().to_string_lossy().into_owned();
                n.contains("strahler-tmp").then_some(n)
            })
            .collect()
    }

    /// Issue 33, point 18: an output name the file system takes (240 bytes) is written,
    /// though the output's name and the temporary suffix together would pass 255 bytes.
    #[test]
    fn a_long_output_name_is_written() {
        let dir = scratch("long");
        let path = dir.join(format!("{}.tif", "n".repeat(236)));
        write_atomic(&path, b"long").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"long");
        assert!(leftovers(&dir).is_empty());
    }

    #[test]
    fn atomic_write_replaces_and_cleans_up_on_failure() {
        let dir = scratch("atomic");
        let path = dir.join("a.bin");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two");
        // Renaming over a non-empty folder fails after the temporary file was written.
        let blocked = dir.join("blocked.tif");
        fs::create_dir_all(blocked.join("inside")).unwrap();
        let err = write_atomic(&blocked, b"data").unwrap_err();
        assert!(err.to_string().contains("blocked.tif"), "{err}");
        assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
        let missing = dir.join("no/such/folder/x.tif");
        assert!(write_atomic(&missing, b"x").is_err());
    }

    #[test]
    fn collisions_are_refused_by_canonical_path() {
        let dir = scratch("claims");
        let input = dir.join("in.tif");
        fs::write(&input, b"x").unwrap();
        let mut outputs = Outputs::new(false);
        outputs.input(&input, "input");
        let same = dir.join("sub/../in.tif");
        fs::create_dir_all(dir.join("sub")).unwrap();
        let err = outputs.claim(&same, "output").unwrap_err();
        assert!(err.to_string().contains("input"), "{err}");
        outputs.claim(&dir.join("new.tif"), "output").unwrap();
        assert!(outputs.claim(&dir.join("./new.tif"), "report").is_err());
        assert!(matches!(
            outputs.write(&dir.join("other.tif"), b"x"),
            Err(OutputError::Unclaimed { .. })
        ));
    }

    #[test]
    fn sidecars_replace_only_their_own() {
        let dir = scratch("sidecars");
        let png = dir.join("t.png");
        let json = dir.join("t.json");
        fs::write(&json, b"{\"version\": 1}").unwrap();
        let err = Outputs::new(false).claim_dem(&png, "output").unwrap_err();
        assert!(err.to_string().contains("--force"), "{err}");
        Outputs::new(true).claim_dem(&png, "output").unwrap();
        // Strahler's own sidecar of the same output: replaced on a re-run.
        fs::write(&png, b"png").unwrap();
        fs::write(&json, b"{\"zmin\": 0, \"zmax\": 1, \"decode\": \"z\"}").unwrap();
        Outputs::new(false).claim_dem(&png, "output").unwrap();
        // ... but not when another heightmap of that stem could own it.
        fs::write(dir.join("t.r16"), b"r16").unwrap();
        assert!(Outputs::new(false).claim_dem(&png, "output").is_err());
    }
}
