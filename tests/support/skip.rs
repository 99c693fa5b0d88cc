//! Missing preconditions of a test (a file, a PyPI package, a device).
//!
//! On a user's machine a test whose precondition is missing prints `SKIP: why` and passes.
//! Under `CROSSYM_NO_SKIP=1` (set by `.ci/run`, where everything a test needs is
//! installed) the same skip is a failure: CI never passes a test that did not run.

/// Whether skips are failures (`CROSSYM_NO_SKIP` set to anything but `0` or empty).
pub fn skips_fail() -> bool {
    std::env::var("CROSSYM_NO_SKIP").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// Reports a missing precondition: prints `SKIP: why`, or panics under `CROSSYM_NO_SKIP`.
#[track_caller]
pub fn skip(why: impl std::fmt::Display) {
    if skips_fail() {
        panic!("SKIP is a failure under CROSSYM_NO_SKIP (CI installs what tests need): {why}");
    }
    eprintln!("SKIP: {why}");
}
