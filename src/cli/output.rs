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
//! 4. **Only what the user could write.** An existing output the user could not write
//!    themselves (read-only, or another user's file in a shared folder) is refused at the
//!    claim unless `--force` is given: the atomic rename would otherwise bypass its
//!    permissions. A folder, socket or block device is refused. A named pipe or a character
//!    device (`/dev/null`, `/dev/stdout`) is written as it is, in place, as `cat > path`
//!    would; a symbolic link to a file is written through (the link stays a link).
//! 5. **All or none.** [`Outputs::write`] only stages the bytes: each file goes to a hidden
//!    temporary file in its destination's folder and is flushed to disk (`fsync`).
//!    [`Outputs::commit`], called once the whole run succeeded, moves every staged file into
//!    place; a run that fails before it (or an `Outputs` dropped without it) removes its
//!    temporary files and leaves every old file as it was. A failed write never leaves an
//!    empty or truncated file.
//! 6. **No leftovers.** Temporary files are removed on SIGINT, SIGTERM and SIGHUP
//!    ([`install_signal_cleanup`]), and those a killed run (`kill -9`) left behind are
//!    removed by the next run that writes into the same folder (their process is gone).

use std::cell::RefCell;
use std::collections::HashSet;
use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
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
    #[error(
        "{path}: the {role} exists and {why}; make it writable, choose another output name, \
         or pass --force to replace it"
    )]
    NotWritable {
        path: String,
        role: String,
        why: String,
    },
    #[error("{path}: the {role} is {kind}; give the path of a file to write")]
    NotAFile {
        path: String,
        role: String,
        kind: String,
    },
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

/// A file written but not yet moved into place.
enum Staged {
    /// A regular file: its flushed temporary file, renamed over `dest` at the commit.
    File { tmp: PathBuf, dest: PathBuf },
    /// A named pipe or character device: its bytes, written into it at the commit.
    Stream { dest: PathBuf, bytes: Vec<u8> },
}

/// The files a run reads and writes; see the module's rules.
pub struct Outputs {
    inputs: Vec<Entry>,
    outputs: Vec<Entry>,
    force: bool,
    staged: RefCell<Vec<Staged>>,
}

/// Whether a file name is a heightmap that carries a sidecar (PNG, RAW R16 and R32).
fn has_sidecar(path: &Path) -> bool {
    matches!(
        Format::from_name(&path.to_string_lossy()),
        Some(Format::Png | Format::R16 | Format::R32)
    )
}

/// The sidecar beside a PNG or RAW heightmap.
pub fn sidecar_of(path: &Path) -> PathBuf {
    path.with_extension("json")
}

impl Outputs {
    /// `force`: let outputs replace files this run may not replace on its own: sidecars it
    /// did not write, read-only files and other users' files (`--force`).
    pub fn new(force: bool) -> Self {
        Self {
            inputs: Vec::new(),
            outputs: Vec::new(),
            force,
            staged: RefCell::new(Vec::new()),
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
    /// written by this run (rule 2) and one the user could not write (rule 4).
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
        check_destination(path, role, self.force)?;
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

    /// Stages `bytes` for a claimed `path` (rule 5): nothing is in place before
    /// [`Outputs::commit`].
    pub fn write(&self, path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
        let key = Key::of(path);
        if !self.outputs.iter().any(|e| e.key.same(&key)) {
            return Err(OutputError::Unclaimed {
                path: path.display().to_string(),
            });
        }
        let staged = if is_stream(path) {
            Staged::Stream {
                dest: path.to_path_buf(),
                bytes: bytes.to_vec(),
            }
        } else {
            let dest = through_link(path);
            let tmp = stage_file(&dest, bytes)?;
            Staged::File { tmp, dest }
        };
        self.staged.borrow_mut().push(staged);
        Ok(())
    }

    /// Moves every staged file into place: the pipes and devices are written first (they
    /// are the ones that can fail), then every temporary file is renamed over its
    /// destination. On an error the files not yet in place are removed.
    pub fn commit(self) -> Result<(), OutputError> {
        let staged = std::mem::take(&mut *self.staged.borrow_mut());
        let (streams, files): (Vec<_>, Vec<_>) = staged
            .into_iter()
            .partition(|s| matches!(s, Staged::Stream { .. }));
        let mut files = files.into_iter();
        let result = (|| {
            for stream in streams {
                if let Staged::Stream { dest, bytes } = stream {
                    write_stream(&dest, &bytes)?;
                }
            }
            for file in files.by_ref() {
                if let Staged::File { tmp, dest } = file {
                    let moved = fs::rename(&tmp, &dest);
                    forget_temp(&tmp);
                    if let Err(source) = moved {
                        let _ = fs::remove_file(&tmp);
                        return Err(OutputError::Io {
                            path: dest.display().to_string(),
                            source,
                        });
                    }
                    sync_folder(&dest);
                }
            }
            Ok(())
        })();
        for file in files {
            if let Staged::File { tmp, .. } = file {
                remove_temp(&tmp);
            }
        }
        result
    }
}

impl Drop for Outputs {
    /// A run that did not commit leaves nothing behind (rule 5).
    fn drop(&mut self) {
        for staged in self.staged.get_mut().drain(..) {
            if let Staged::File { tmp, .. } = staged {
                remove_temp(&tmp);
            }
        }
    }
}

/// Rule 4: an existing destination must be a file the user could write, a named pipe or a
/// character device.
fn check_destination(path: &Path, role: &str, force: bool) -> Result<(), OutputError> {
    let Ok(meta) = fs::metadata(path) else {
        return Ok(());
    };
    if is_stream(path) {
        return Ok(());
    }
    if !meta.is_file() {
        return Err(OutputError::NotAFile {
            path: path.display().to_string(),
            role: role.to_owned(),
            kind: crate::dem::file_kind(&meta).to_owned(),
        });
    }
    if force {
        return Ok(());
    }
    let why = if meta.permissions().readonly() {
        Some("is read-only".to_owned())
    } else {
        // Opening for writing (without truncating) asks the system whether this user may
        // write the file itself; nothing in it changes.
        fs::OpenOptions::new()
            .write(true)
            .open(path)
            .err()
            .map(|e| format!("you may not write it ({e})"))
    };
    match why {
        None => Ok(()),
        Some(why) => Err(OutputError::NotWritable {
            path: path.display().to_string(),
            role: role.to_owned(),
            why,
        }),
    }
}

/// Whether `path` (or what it links to) is a named pipe or a character device, which are
/// written in place.
fn is_stream(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo() || m.file_type().is_char_device())
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        false
    }
}

/// The file a symbolic link points to (so the link stays a link), else `path` itself.
fn through_link(path: &Path) -> PathBuf {
    match fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => fs::canonicalize(path).unwrap_or(path.to_owned()),
        _ => path.to_path_buf(),
    }
}

/// Writes `bytes` into a pipe or device as it is (no temporary file can stand in for it).
fn write_stream(dest: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let io = |source: std::io::Error| OutputError::Io {
        path: dest.display().to_string(),
        source,
    };
    let mut file = fs::OpenOptions::new().write(true).open(dest).map_err(io)?;
    file.write_all(bytes).map_err(io)?;
    file.flush().map_err(io)
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

/// The temporary files of this process not yet in place (removed on a signal, rule 6).
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The folders whose leftovers this process has already cleaned.
static CLEANED: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);

/// The marker in every temporary file's name: `.<name>.strahler-tmp-<pid>-<n>`.
const TEMP_MARK: &str = ".strahler-tmp-";

fn forget_temp(tmp: &Path) {
    if let Ok(mut live) = LIVE_TEMPS.lock() {
        live.retain(|p| p != tmp);
    }
}

fn remove_temp(tmp: &Path) {
    let _ = fs::remove_file(tmp);
    forget_temp(tmp);
}

/// Writes `bytes` to a new temporary file in `dest`'s folder and flushes it to disk; the
/// file is removed on any error.
fn stage_file(dest: &Path, bytes: &[u8]) -> Result<PathBuf, OutputError> {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let io = |source: std::io::Error| OutputError::Io {
        path: dest.display().to_string(),
        source,
    };
    let name = dest.file_name().ok_or_else(|| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file name",
        ))
    })?;
    let dir = folder_of(dest);
    remove_leftovers(dir);
    // The output's name, cut to 64 characters, so that any name the file system takes for
    // the output also fits its temporary file (255 bytes is the usual limit).
    let stem: String = name.to_string_lossy().chars().take(64).collect();
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(stem);
    tmp_name.push(format!(
        "{TEMP_MARK}{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let tmp = dir.join(tmp_name);
    // Created and listed under one lock: the signal thread, which removes the listed files
    // and exits holding that lock, never misses a file or lets one be made after it ran.
    let mut file = {
        let mut live = LIVE_TEMPS.lock().unwrap_or_else(|e| e.into_inner());
        let file = fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(io)?;
        live.push(tmp.clone());
        file
    };
    let result = (|| {
        file.write_all(bytes)?;
        // A replaced file keeps its permissions.
        if let Ok(meta) = fs::metadata(dest)
            && meta.is_file()
        {
            let _ = file.set_permissions(meta.permissions());
        }
        file.sync_all()
    })();
    match result {
        Ok(()) => Ok(tmp),
        Err(err) => {
            drop(file);
            remove_temp(&tmp);
            Err(io(err))
        }
    }
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The rename itself survives a crash once the folder is flushed (best effort).
fn sync_folder(dest: &Path) {
    #[cfg(unix)]
    if let Ok(d) = fs::File::open(folder_of(dest)) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dest;
}

/// Removes, once per folder and process, the temporary files that runs killed outright
/// (`kill -9`, a crash) left in `dir`: those whose process no longer exists (rule 6).
fn remove_leftovers(dir: &Path) {
    let Ok(mut cleaned) = CLEANED.lock() else {
        return;
    };
    let key = fs::canonicalize(dir).unwrap_or(dir.to_path_buf());
    if !cleaned.get_or_insert_with(HashSet::new).insert(key) {
        return;
    }
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if let Some(pid) = leftover_pid(&name)
            && pid != std::process::id()
            && !process_alive(pid)
            && entry.file_type().is_ok_and(|t| t.is_file())
        {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// The process id in a temporary file's name `.<name>.strahler-tmp-<pid>-<n>`.
fn leftover_pid(name: &str) -> Option<u32> {
    if !name.starts_with('.') {
        return None;
    }
    let (_, tail) = name.rsplit_once(TEMP_MARK)?;
    let (pid, n) = tail.split_once('-')?;
    n.parse::<u32>().ok()?;
    pid.parse().ok()
}

#[cfg(unix)]
fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return true;
    };
    // Signal 0 checks that the process exists; EPERM means it exists under another user.
    // SAFETY: kill with signal 0 sends nothing; it only reads the process table.
    let rc = unsafe { libc::kill(pid, 0) };
    rc == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
}

#[cfg(not(unix))]
fn process_alive(_: u32) -> bool {
    true
}

/// Removes this process's temporary files when it is interrupted (SIGINT, SIGTERM,
/// SIGHUP), then exits with 128 + the signal's number, as a shell reports it. The signals
/// are blocked in every thread and waited for by one thread of their own, so the clean-up
/// runs outside a signal handler. Call it first in `main`, before any thread is started.
#[cfg(unix)]
pub fn install_signal_cleanup() {
    // SAFETY: plain libc calls on a sigset_t owned here; pthread_sigmask only changes this
    // thread's mask, which the threads started later inherit.
    let set = unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            libc::sigaddset(&mut set, sig);
        }
        if libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return;
        }
        set
    };
    let spawned = std::thread::Builder::new()
        .name("strahler-signals".into())
        .spawn(move || {
            let mut sig: libc::c_int = 0;
            // SAFETY: sigwait reads the set and writes the received signal into `sig`.
            if unsafe { libc::sigwait(&set, &mut sig) } != 0 {
                return;
            }
            // The lock is held until the process ends, so no file is staged after these.
            let live = LIVE_TEMPS.lock().unwrap_or_else(|e| e.into_inner());
            for tmp in live.iter() {
                let _ = fs::remove_file(tmp);
            }
            std::process::exit(128 + sig);
        });
    if spawned.is_err() {
        // Without the waiting thread the signals must not stay blocked.
        // SAFETY: as above.
        unsafe {
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        }
    }
}

#[cfg(not(unix))]
pub fn install_signal_cleanup() {}

#[cfg(test)]
mod tests {
    use super::*;

    /// A test's own empty folder in the system's temporary one, removed when the test ends
    /// (passed or failed).
    struct Scratch(PathBuf);

    impl std::ops::Deref for Scratch {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    fn scratch(name: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("strahler-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    /// One output, claimed, written and committed.
    fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
        let mut outputs = Outputs::new(false);
        outputs.claim(path, "output")?;
        outputs.write(path, bytes)?;
        outputs.commit()
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
        // A folder is refused at the claim ...
        let blocked = dir.join("blocked.tif");
        fs::create_dir_all(blocked.join("inside")).unwrap();
        let err = write_atomic(&blocked, b"data").unwrap_err();
        assert!(err.to_string().contains("is a folder"), "{err}");
        // ... and renaming over one that appeared after the claim fails after the
        // temporary file was written, which is then removed.
        let late = dir.join("late.tif");
        let mut outputs = Outputs::new(false);
        outputs.claim(&late, "output").unwrap();
        outputs.write(&late, b"data").unwrap();
        fs::create_dir_all(late.join("inside")).unwrap();
        let err = outputs.commit().unwrap_err();
        assert!(err.to_string().contains("late.tif"), "{err}");
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

    /// Issue 33, point 21: outputs staged by a run that fails before its commit are not
    /// written, and leave no temporary file.
    #[test]
    fn a_run_that_fails_writes_nothing() {
        let dir = scratch("none");
        let (a, b) = (dir.join("a.tif"), dir.join("b.json"));
        fs::write(&a, b"old").unwrap();
        {
            let mut outputs = Outputs::new(false);
            outputs.claim(&a, "output").unwrap();
            outputs.claim(&b, "report").unwrap();
            outputs.write(&a, b"new").unwrap();
            outputs.write(&b, b"{}").unwrap();
            // Dropped without a commit, as when a later step of the run fails.
        }
        assert_eq!(fs::read(&a).unwrap(), b"old");
        assert!(!b.exists());
        assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    }

    /// Issue 33, point 3: a read-only output is refused unless forced; the message says why
    /// and how to go on.
    #[cfg(unix)]
    #[test]
    fn read_only_outputs_are_refused_unless_forced() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = scratch("readonly");
        let path = dir.join("kept.tif");
        fs::write(&path, b"mine").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o444)).unwrap();
        let err = Outputs::new(false).claim(&path, "output").unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("read-only") && text.contains("--force"),
            "{text}"
        );
        assert_eq!(fs::read(&path).unwrap(), b"mine");
        let mut outputs = Outputs::new(true);
        outputs.claim(&path, "output").unwrap();
        outputs.write(&path, b"new").unwrap();
        outputs.commit().unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
    }

    /// Issue 33, point 2: a symbolic link to a file is written through (the link stays a
    /// link), a named pipe is written in place, a socket or folder is refused.
    #[cfg(unix)]
    #[test]
    fn links_and_pipes_are_written_as_asked() {
        let dir = scratch("special");
        let target = dir.join("target.tif");
        fs::write(&target, b"old").unwrap();
        let link = dir.join("link.tif");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomic(&link, b"through").unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(&target).unwrap(), b"through");

        let fifo = dir.join("pipe.json");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo reads the NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || fs::read(&fifo).unwrap())
        };
        write_atomic(&fifo, b"streamed").unwrap();
        assert_eq!(reader.join().unwrap(), b"streamed");
        let meta = fs::symlink_metadata(&fifo).unwrap();
        assert!(std::os::unix::fs::FileTypeExt::is_fifo(&meta.file_type()));

        let socket = dir.join("s.sock");
        let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        let err = Outputs::new(true).claim(&socket, "report").unwrap_err();
        assert!(err.to_string().contains("a socket"), "{err}");
        assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    }

    /// Issue 33, point 4: temporary files of a process that is gone (killed with -9) are
    /// removed by the next write into their folder; a live process's are kept.
    #[cfg(unix)]
    #[test]
    fn leftovers_of_killed_runs_are_removed() {
        let dir = scratch("leftovers");
        // Above any pid_max Linux allows (2^22), so no such process exists.
        let dead = dir.join(".out.tif.strahler-tmp-999999999-0");
        let alive = dir.join(format!(
            ".out.tif.strahler-tmp-{}-99999",
            std::process::id()
        ));
        let other = dir.join(".notes.strahler-tmp-x");
        for p in [&dead, &alive, &other] {
            fs::write(p, b"partial").unwrap();
        }
        write_atomic(&dir.join("out.tif"), b"x").unwrap();
        assert!(!dead.exists());
        assert!(alive.exists() && other.exists());
        assert_eq!(leftover_pid(".a.strahler-tmp-12-3"), Some(12));
        assert_eq!(leftover_pid("a.strahler-tmp-12-3"), None);
        assert_eq!(leftover_pid(".a.strahler-tmp-12-x"), None);
    }
}
