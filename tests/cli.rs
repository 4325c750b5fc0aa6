//! The `strahler` command line, run as a user would.

use std::process::Command;

fn strahler(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_strahler"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn info_names_the_adapter_and_limits() {
    let out = strahler(&["info"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("strahler {}", env!("CARGO_PKG_VERSION"))),
        "{text}"
    );
    assert!(text.contains("GPU adapter:"), "{text}");
    if std::env::var_os("STRAHLER_REQUIRE_GPU").is_some() {
        assert!(text.contains("max storage buffer binding size"), "{text}");
        assert!(text.contains("max workgroups per dimension"), "{text}");
    }
    // CI installs Mesa's lavapipe and names it here.
    if let Ok(expected) = std::env::var("STRAHLER_EXPECT_ADAPTER") {
        assert!(
            text.contains(&expected),
            "expected adapter {expected}: {text}"
        );
    }
}

#[test]
fn info_check_json_compares_backends() {
    let out = strahler(&["info", "--check", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    assert_eq!(report["version"], env!("CARGO_PKG_VERSION"));
    let check = &report["check"];
    assert_eq!(check["cpu"]["backend"], "cpu");
    assert_eq!(check["cpu"]["checksum"].as_str().map(str::len), Some(16));
    if report["adapter"].is_object() {
        let rel = check["relative_diff"].as_f64().expect("GPU ran");
        assert!(rel <= 1e-5, "GPU vs CPU differ by {rel}");
    } else {
        assert!(
            std::env::var_os("STRAHLER_REQUIRE_GPU").is_none(),
            "no GPU: {report}"
        );
        assert_eq!(report["compute"], "cpu");
    }
}

#[test]
fn unknown_subcommands_are_refused_with_help() {
    let out = strahler(&["frobnicate"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unrecognized subcommand"), "{err}");
}
