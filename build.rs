//! Build script of the `crossym` package: the git commit `crossym --version` prints.
//!
//! Sets `CROSSYM_GIT_HASH` to `git rev-parse --short HEAD`, or to the environment variable
//! of that name when it is set (a build from a tarball or in a container that knows its
//! commit); neither: the binary says `unknown`. It reruns only when HEAD moves (the files
//! `.git/HEAD`, the branch's ref and `packed-refs`), not on every build.

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (!s.is_empty()).then_some(s)
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CROSSYM_GIT_HASH");
    if let Ok(hash) = std::env::var("CROSSYM_GIT_HASH") {
        println!("cargo:rustc-env=CROSSYM_GIT_HASH={hash}");
        return;
    }
    // Not a checkout of this package (e.g. the source unpacked inside another repository's
    // work tree): the enclosing repository's commit would be wrong.
    let manifest_dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let top = git(&["rev-parse", "--show-toplevel"]).map(PathBuf::from);
    let ours = top.as_deref().is_some_and(|t| same_dir(t, &manifest_dir));
    let hash = ours
        .then(|| git(&["rev-parse", "--short", "HEAD"]))
        .flatten()
        .unwrap_or_else(|| "unknown".into());
    if ours {
        // HEAD (a branch name or, detached, the commit), the branch's ref, packed refs;
        // in a linked worktree HEAD is in its git dir and the refs in the common one.
        let git_dir = git(&["rev-parse", "--git-dir"]).map(|d| manifest_dir.join(d));
        let common = git(&["rev-parse", "--git-common-dir"]).map(|d| manifest_dir.join(d));
        let branch = git(&["symbolic-ref", "-q", "HEAD"]);
        let mut watch = Vec::new();
        if let Some(g) = &git_dir {
            watch.push(g.join("HEAD"));
        }
        if let Some(c) = &common {
            if let Some(b) = &branch {
                watch.push(c.join(b));
            }
            watch.push(c.join("packed-refs"));
        }
        // A path that does not exist would rerun the script on every build.
        for p in watch.iter().filter(|p| p.exists()) {
            println!("cargo:rerun-if-changed={}", p.display());
        }
    }
    println!("cargo:rustc-env=CROSSYM_GIT_HASH={hash}");
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}
