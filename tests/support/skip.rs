//! Missing preconditions of a test (a file, a PyPI package, a device).
//!
//! On a user's machine a test whose precondition is missing prints `SKIP: why` and passes.
//! Two switches make a skip visible to CI, where everything a test needs is installed:
//! - `CROSSYM_NO_SKIP=1`: the skip is a failure (the test panics with the reason).
//! - `CROSSYM_SKIP_LOG=FILE`: the skip appends one line `SKIP: why (at file:line)` to
//!   `FILE`, whether or not the test then fails. libtest captures what a passing test
//!   prints, so the log, not the test output, is what a CI script checks (`.ci/run` fails
//!   when the file is not empty after the tests).

use std::io::Write;

/// Whether skips are failures (`CROSSYM_NO_SKIP` set to anything but `0` or empty).
pub fn skips_fail() -> bool {
    std::env::var("CROSSYM_NO_SKIP").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// Reports a missing precondition: appends it to `CROSSYM_SKIP_LOG` when set, prints
/// `SKIP: why`, or panics under `CROSSYM_NO_SKIP`.
#[track_caller]
pub fn skip(why: impl std::fmt::Display) {
    let at = std::panic::Location::caller();
    if let Some(path) = std::env::var_os("CROSSYM_SKIP_LOG").filter(|p| !p.is_empty()) {
        // One write per line (O_APPEND): test threads and test processes may share the file.
        let line = format!("SKIP: {why} (at {}:{})\n", at.file(), at.line());
        let written = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .and_then(|mut f| f.write_all(line.as_bytes()));
        if let Err(e) = written {
            panic!(
                "CROSSYM_SKIP_LOG={}: cannot record a skip ({e}): {why}",
                std::path::Path::new(&path).display()
            );
        }
    }
    if skips_fail() {
        panic!("SKIP is a failure under CROSSYM_NO_SKIP (CI installs what tests need): {why}");
    }
    eprintln!("SKIP: {why}");
}
