//! The `lrr` binary itself: exit codes and the one-line error. (Its presence here also makes
//! `cargo test` build `target/<profile>/lrr`, which the end-to-end tests run as a process.)

use std::process::Command;

#[test]
fn failure_exits_non_zero_with_one_line() {
    let out = Command::new(env!("CARGO_BIN_EXE_lrr"))
        .args(["info", "/nonexistent.lrr"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("lrr: error: /nonexistent.lrr"), "{err}");
}

#[test]
fn help_and_version_succeed() {
    for args in [
        &["--help"][..],
        &["--version"],
        &["bake", "--help"],
        &["probe", "--help"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_lrr"))
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{args:?}");
        assert!(!out.stdout.is_empty());
    }
}
