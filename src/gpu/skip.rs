//! What a GPU test does on a machine without a GPU adapter: it **fails**, unless the run asked
//! to skip the GPU explicitly with `STRAHLER_SKIP_GPU=<file>`. A skipping test appends its
//! name to that file, so the run can say how many were skipped (`.ci/test-without-gpu` does).
//!
//! Without this rule a test that found no adapter passed silently, and a machine whose Vulkan
//! driver broke ran none of the 45 GPU tests while reporting them green.

use std::io::Write;

/// The environment variable that asks GPU tests to skip where no adapter is found: its value
/// is the file the skipped tests' names are appended to.
pub const SKIP_VAR: &str = "STRAHLER_SKIP_GPU";

/// Whether this run asked to skip GPU tests that find no adapter.
pub fn requested() -> bool {
    std::env::var_os(SKIP_VAR).is_some_and(|v| !v.is_empty())
}

/// Called by a GPU test that found no adapter (`why`): panics unless skipping was asked for;
/// otherwise records the skip (the test thread's name, which the test harness sets to the
/// test's path) and returns, so the test can return early.
///
/// # Panics
/// When `STRAHLER_SKIP_GPU` is not set: a GPU test must run.
pub fn no_adapter(why: &dyn std::fmt::Display) {
    let log = std::env::var_os(SKIP_VAR);
    let name = std::thread::current()
        .name()
        .unwrap_or("a GPU test")
        .to_owned();
    if let Err(message) = skip(log.as_deref(), &name, why) {
        panic!("{message}");
    }
}

/// The rule of [`no_adapter`], given the variable's value: appends `name` to the log file, or
/// says why the test fails.
fn skip(
    log: Option<&std::ffi::OsStr>,
    name: &str,
    why: &dyn std::fmt::Display,
) -> Result<(), String> {
    let Some(log) = log.filter(|v| !v.is_empty()) else {
        return Err(format!(
            "no GPU adapter: {why}. GPU tests fail without one; install one (Mesa's lavapipe: \
             `.ci/setup test`) or set {SKIP_VAR}=<file> to skip them and list them in <file>"
        ));
    };
    eprintln!("skipping the GPU part of {name}: {why}");
    // Appends of one short line are atomic on local file systems, so parallel tests can share
    // the file.
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(log)
        .and_then(|mut file| writeln!(file, "{name}"))
        .map_err(|err| {
            format!(
                "cannot record the skipped GPU test in {}: {err}",
                log.to_string_lossy()
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_adapter_fails_unless_skipping_was_asked_for() {
        let why = "no adapter here";
        for unset in [None, Some(std::ffi::OsStr::new(""))] {
            let err = skip(unset, "t", &why).expect_err("fails");
            assert!(
                err.contains("no adapter here") && err.contains(SKIP_VAR),
                "{err}"
            );
        }
        let dir = std::env::temp_dir().join(format!("strahler-skip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let log = dir.join("skipped.txt");
        skip(Some(log.as_os_str()), "gpu::a", &why).expect("skipped");
        skip(Some(log.as_os_str()), "gpu::b", &why).expect("skipped");
        let listed = std::fs::read_to_string(&log).expect("log");
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(listed, "gpu::a\ngpu::b\n");
    }
}
