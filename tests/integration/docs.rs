//! The documentation a user reads:
//!
//! - `docs/guide/teach.md` runs top to bottom: its ```` ```sh ```` blocks, in order, as one
//!   `bash -euo pipefail` script in an empty directory with the crossym under test first on
//!   `PATH` (as a user copy-pastes them into one terminal), and the robot it ends with
//!   went where the example recordings say (read back from the runs' bags, compared with
//!   the recordings themselves, not with anything crossym computed);
//! - every relative link and `#anchor` of the repository's Markdown files resolves.
//!
//! The guide's DDS processes use ROS_DOMAIN_ID 131 (no other test uses it).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crossym::data::recording::{open_joint_states, JointRecording, StampSource};
use crossym::sim::MockHwSummary;

use crate::common;

const DOMAIN: u16 = 131;

/// Generous limit on the whole guide (normally ≈ 30 s in the test profile).
const GUIDE_DEADLINE: Duration = Duration::from_secs(300);

/// The moving arm ends within this distance of the demonstrated goal on every joint (rad;
/// 10 % of the 0.5 rad move: a policy that stopped halfway or moved the wrong arm fails).
/// The teach test measures ≈ 0.01 for this recipe.
const FINAL_TOL: f64 = 0.05;

/// The other arm stays within this distance of its rest on every joint, over the whole run
/// (rad; measured ≈ 0.007 by the teach test).
const HOLD_TOL: f64 = 0.03;

/// The blocks of `md` whose info string is exactly `sh`, in order.
fn sh_blocks(md: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    let mut fence: Option<(char, usize)> = None;
    for line in md.lines() {
        if let Some(f) = fence {
            if closes_fence(line, f) {
                fence = None;
                if let Some(b) = current.take() {
                    blocks.push(b);
                }
            } else if let Some(b) = current.as_mut() {
                b.push_str(line);
                b.push('\n');
            }
        } else if let Some((f, info)) = opens_fence(line) {
            fence = Some(f);
            if info == "sh" {
                current = Some(String::new());
            }
        }
    }
    blocks
}

/// A line opening a fenced code block (up to three spaces, then ≥ 3 backticks or tildes):
/// the fence and the info string's first word.
fn opens_fence(line: &str) -> Option<((char, usize), &str)> {
    let indent = line.len() - line.trim_start_matches(' ').len();
    if indent > 3 {
        return None;
    }
    let rest = &line[indent..];
    let c = rest.chars().next().filter(|c| *c == '`' || *c == '~')?;
    let n = rest.chars().take_while(|x| *x == c).count();
    if n < 3 {
        return None;
    }
    let info = rest[n..].trim();
    if c == '`' && info.contains('`') {
        return None;
    }
    Some(((c, n), info.split_whitespace().next().unwrap_or("")))
}

/// True when `line` closes a fence opened with `f`.
fn closes_fence(line: &str, (c, n): (char, usize)) -> bool {
    let t = line.trim_start_matches(' ');
    line.len() - t.len() <= 3
        && t.chars().take_while(|x| *x == c).count() >= n
        && t.trim_start_matches(c).trim().is_empty()
}

/// The joints of the planar dual arm, in the robot's order.
fn joints() -> Vec<String> {
    common::planar().kinematics.joint_names().to_vec()
}

fn read_joint_states(bag: &Path) -> JointRecording {
    open_joint_states(bag, "/joint_states", &joints(), StampSource::Header)
        .unwrap_or_else(|e| panic!("reading {}: {e}", bag.display()))
}

/// The arm swap of the planar dual arm (`P = diag[-1, -1, -1, -1]`, which `crossym check`
/// prints in the guide): the left arm takes the right arm's posture negated and vice versa.
fn mirror(q: &[f64]) -> Vec<f64> {
    let (l, r) = q.split_at(4);
    r.iter().chain(l).map(|v| -v).collect()
}

/// Checks a run's recorded joint states: the robot started at `rest`, the joints in
/// `moving` end within [`FINAL_TOL`] of `goal`, the others never leave `rest` by more than
/// [`HOLD_TOL`].
fn check_run(label: &str, run: &JointRecording, rest: &[f64], goal: &[f64], moving: &[usize]) {
    assert!(
        run.len() > 200,
        "{label}: {} joint states recorded",
        run.len()
    );
    let first = run.q(0);
    let last = run.q(run.len() - 1);
    let start_err = (0..8)
        .map(|j| (first[j] - rest[j]).abs())
        .fold(0.0, f64::max);
    let final_err = moving
        .iter()
        .map(|&j| (last[j] - goal[j]).abs())
        .fold(0.0, f64::max);
    let hold = (0..run.len())
        .flat_map(|k| {
            let q = run.q(k);
            (0..8)
                .filter(|j| !moving.contains(j))
                .map(|j| (q[j] - rest[j]).abs())
                .collect::<Vec<_>>()
        })
        .fold(0.0, f64::max);
    eprintln!(
        "docs teach guide, {label}: start {start_err:.4} rad from rest, moving arm ends \
         {final_err:.4} rad from the goal, holding arm within {hold:.4} rad of rest; \
         last {last:.4?}"
    );
    assert!(
        start_err < 1e-3,
        "{label}: the recording starts at {first:?}, not at rest {rest:?}"
    );
    assert!(
        final_err <= FINAL_TOL,
        "{label}: the moving arm ends {final_err:.4} rad from the goal (> {FINAL_TOL}): \
         {last:?} vs {goal:?}"
    );
    assert!(
        hold <= HOLD_TOL,
        "{label}: the holding arm moved {hold:.4} rad from rest (> {HOLD_TOL})"
    );
}

/// The last line of `out` containing `needle`: its `ticks N (stale M)` as `N − M`.
fn commanded_ticks(out: &str, needle: &str) -> Option<u64> {
    let line = out.lines().rev().find(|l| l.contains(needle))?;
    let ticks = line.split("ticks ").nth(1)?;
    let n: u64 = ticks.split_whitespace().next()?.parse().ok()?;
    let stale: u64 = ticks
        .split("(stale ")
        .nth(1)?
        .split(')')
        .next()?
        .parse()
        .ok()?;
    Some(n - stale)
}

fn summary(p: &Path) -> MockHwSummary {
    let text = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn teach_guide_runs_top_to_bottom() {
    let t0 = Instant::now();
    let guide = std::fs::read_to_string(common::path("docs/guide/teach.md")).unwrap();
    let blocks = sh_blocks(&guide);
    assert!(
        blocks.len() >= 8,
        "{} sh blocks in docs/guide/teach.md",
        blocks.len()
    );
    let dir = common::temp_dir("docs-teach");
    let script = dir.join("guide.sh");
    std::fs::write(&script, blocks.join("\n")).unwrap();
    let log = dir.join("guide.log");
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_crossym"));
    let path = std::env::join_paths(std::iter::once(bin.parent().unwrap().to_path_buf()).chain(
        std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()),
    ))
    .unwrap();
    let out = std::fs::File::create(&log).unwrap();
    let mut child = {
        use std::os::unix::process::CommandExt;
        Command::new("bash")
            .args(["-euo", "pipefail"])
            .arg(&script)
            .current_dir(&dir)
            .env("PATH", path)
            .env("CROSSYM_REPO", common::root())
            .env("ROS_DOMAIN_ID", DOMAIN.to_string())
            .env("ROS_DISTRO", "humble")
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::from(out.try_clone().unwrap()))
            .stderr(Stdio::from(out))
            // Its own process group: whatever the guide left running is ended below.
            .process_group(0)
            .spawn()
            .expect("bash starts")
    };
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if t0.elapsed() > GUIDE_DEADLINE {
            break None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    // The mock hardware and node of a guide that failed half-way would run on.
    let _ = Command::new("kill")
        .args(["-KILL", "--", &format!("-{}", child.id())])
        .stderr(Stdio::null())
        .status();
    let _ = child.wait();
    let output = std::fs::read_to_string(&log).unwrap_or_default();
    let tail = || {
        let lines: Vec<&str> = output.lines().collect();
        lines[lines.len().saturating_sub(60)..].join("\n")
    };
    let status = status.unwrap_or_else(|| {
        panic!(
            "docs/guide/teach.md did not finish within {GUIDE_DEADLINE:?}\n{}",
            tail()
        )
    });
    assert!(
        status.success(),
        "docs/guide/teach.md failed ({status}); its sh blocks are in {}\n{}",
        script.display(),
        tail()
    );
    let t_guide = t0.elapsed();

    // What the guide's steps promise to write.
    let task = dir.join("my-task");
    for f in [
        "figures/demos_task.png",
        "figures/augmented.png",
        "policies/pick.safetensors",
        "policies/pick.json",
        "results/table2.md",
        "figures/rollout.png",
    ] {
        let len = std::fs::metadata(task.join(f)).map_or(0, |m| m.len());
        assert!(len > 0, "the guide did not write my-task/{f}\n{}", tail());
    }
    // Both runs replay bit for bit, the second with its condition set by a parameter.
    assert_eq!(
        output.matches("replay: OK (max deviation 0.000e0").count(),
        2,
        "{}",
        tail()
    );

    // The demonstrated task, read from the example recording held out for testing.
    let demo = read_joint_states(&common::path("tests/data/docs/recordings/pick_4"));
    let rest = demo.q(0).to_vec();
    let goal = demo.q(demo.len() - 1).to_vec();
    assert!(
        (0..3).all(|j| (goal[j] - rest[j]).abs() > 0.3),
        "the example task moves the left arm: {rest:?} → {goal:?}"
    );

    // Run 1, σ = +1: the left arm performs the task, the right arm holds. Run 2, σ = −1:
    // the right arm performs the mirror image, the left arm holds.
    let runs = [
        (
            "σ = +1",
            "run-1",
            "σ +1",
            rest.clone(),
            goal.clone(),
            [0, 1, 2, 3],
        ),
        (
            "σ = −1",
            "run-2",
            "σ -1",
            mirror(&rest),
            mirror(&goal),
            [4, 5, 6, 7],
        ),
    ];
    for (label, run, status, rest, goal, moving) in runs {
        let s = summary(&task.join(format!("{run}.json")));
        assert_eq!(s.violation_count, 0, "{s:?}");
        assert_eq!(s.commands_invalid, 0, "{s:?}");
        assert!(s.commands_received >= 200, "{s:?}");
        assert!(
            commanded_ticks(&output, status).is_some_and(|n| n >= 250),
            "the node's status did not show 250 commanded ticks under {label}\n{}",
            tail()
        );
        check_run(
            label,
            &read_joint_states(&task.join(run)),
            &rest,
            &goal,
            &moving,
        );
    }
    eprintln!(
        "docs teach guide: {} sh blocks in {:.1} s (checks {:.1} s)",
        blocks.len(),
        t_guide.as_secs_f64(),
        (t0.elapsed() - t_guide).as_secs_f64()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// GitHub's anchor of a heading's text: lower case; characters other than letters,
/// digits, spaces, `-` and `_` dropped; spaces to `-`.
fn slug(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// A heading's raw text as GitHub renders it: links reduced to their text, HTML tags
/// dropped (backticks and other punctuation are dropped by [`slug`]).
fn heading_text(raw: &str) -> String {
    let mut out = String::new();
    let mut rest = raw;
    while let Some(i) = rest.find(['[', '<']) {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        if tail.starts_with('<') {
            match tail.find('>') {
                Some(j) => rest = &tail[j + 1..],
                None => {
                    out.push_str(tail);
                    rest = "";
                }
            }
            continue;
        }
        // `[text](target)`: keep `text`.
        match (tail.find("]("), link_end(tail)) {
            (Some(j), Some(k)) => {
                out.push_str(&tail[1..j]);
                rest = &tail[k..];
            }
            _ => {
                out.push('[');
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// For `tail` starting with `[`: the byte index just past the `)` of `[text](target)`.
fn link_end(tail: &str) -> Option<usize> {
    let j = tail.find("](")?;
    if tail[1..j].contains('[') && !tail[1..j].contains(']') {
        return None;
    }
    let mut depth = 0usize;
    for (k, c) in tail[j + 1..].char_indices() {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return Some(j + 1 + k + 1);
                }
            }
            _ => {}
        }
    }
    None
}

/// `line` with its inline code spans removed.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(i) = rest.find('`') {
        out.push_str(&rest[..i]);
        let n = rest[i..].chars().take_while(|c| *c == '`').count();
        let fence = "`".repeat(n);
        let after = &rest[i + n..];
        match after.find(&fence) {
            Some(j) => rest = &after[j + n..],
            None => {
                out.push_str(&rest[i..]);
                rest = "";
            }
        }
    }
    out.push_str(rest);
    out
}

/// A Markdown file's anchors (its headings' slugs, duplicates numbered `-1`, `-2`, …, and
/// explicit `id` / `name` attributes) and its links (target, line number), both outside
/// fenced code blocks and inline code.
struct Parsed {
    anchors: Vec<String>,
    links: Vec<(String, usize)>,
}

fn parse_markdown(md: &str) -> Parsed {
    let mut anchors = Vec::new();
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut links = Vec::new();
    let mut fence: Option<(char, usize)> = None;
    for (n, line) in md.lines().enumerate() {
        if let Some(f) = fence {
            if closes_fence(line, f) {
                fence = None;
            }
            continue;
        }
        if let Some((f, _)) = opens_fence(line) {
            fence = Some(f);
            continue;
        }
        let text = without_code_spans(line);
        let t = line.trim_start_matches(' ');
        let hashes = t.chars().take_while(|c| *c == '#').count();
        if line.len() - t.len() <= 3
            && (1..=6).contains(&hashes)
            && (t.len() == hashes || t[hashes..].starts_with([' ', '\t']))
        {
            let raw = t[hashes..].trim();
            let raw = raw.trim_end_matches('#').trim_end();
            let base = slug(&heading_text(raw));
            let k = seen.entry(base.clone()).or_insert(0);
            anchors.push(if *k == 0 {
                base.clone()
            } else {
                format!("{base}-{k}")
            });
            *k += 1;
        }
        for attr in ["id=\"", "name=\""] {
            for (i, _) in text.match_indices(attr) {
                let v = &text[i + attr.len()..];
                if let Some(end) = v.find('"') {
                    anchors.push(v[..end].to_string());
                }
            }
        }
        // Inline links and images: `](target)`.
        let mut from = 0;
        while let Some(i) = text[from..].find("](") {
            let start = from + i + 2;
            let mut depth = 1usize;
            let mut end = None;
            for (k, c) in text[start..].char_indices() {
                match c {
                    '(' => depth += 1,
                    ')' => {
                        depth -= 1;
                        if depth == 0 {
                            end = Some(start + k);
                            break;
                        }
                    }
                    _ => {}
                }
            }
            let Some(end) = end else { break };
            let inner = text[start..end].trim();
            let target = match inner.strip_prefix('<') {
                Some(r) => r.split('>').next().unwrap_or(""),
                None => inner.split_whitespace().next().unwrap_or(""),
            };
            links.push((target.to_string(), n + 1));
            from = end;
        }
        // Reference definitions: `[label]: target`.
        let d = text.trim_start();
        if d.starts_with('[') && !d.starts_with("[^") {
            if let Some(j) = d.find("]:") {
                if let Some(target) = d[j + 2..].split_whitespace().next() {
                    links.push((target.trim_matches(['<', '>']).to_string(), n + 1));
                }
            }
        }
        // HTML links and images.
        for attr in ["href=\"", "src=\""] {
            for (i, _) in text.match_indices(attr) {
                let v = &text[i + attr.len()..];
                if let Some(end) = v.find('"') {
                    links.push((v[..end].to_string(), n + 1));
                }
            }
        }
    }
    Parsed { anchors, links }
}

/// The repository's Markdown files: tracked and untracked-but-not-ignored ones (`git
/// ls-files`), or, without git, every `*.md` outside `target/`, `.git/` and `results/`;
/// not those under `vendor/` (third-party sources with their upstream's documentation).
fn markdown_files(root: &Path) -> Vec<PathBuf> {
    let mut files = markdown_files_with_vendor(root);
    files.retain(|f| !f.starts_with(root.join("vendor")));
    files
}

fn markdown_files_with_vendor(root: &Path) -> Vec<PathBuf> {
    let git = Command::new("git")
        .args([
            "ls-files",
            "-z",
            "--cached",
            "--others",
            "--exclude-standard",
            "--",
            "*.md",
        ])
        .current_dir(root)
        .output();
    if let Ok(out) = git {
        if out.status.success() && !out.stdout.is_empty() {
            let mut files: Vec<PathBuf> = out
                .stdout
                .split(|b| *b == 0)
                .filter(|p| !p.is_empty())
                .map(|p| root.join(String::from_utf8_lossy(p).as_ref()))
                .filter(|p| p.is_file())
                .collect();
            files.sort();
            files.dedup();
            return files;
        }
    }
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name();
            if p.is_dir() {
                if !matches!(
                    name.to_str(),
                    Some("target" | ".git" | "results" | "node_modules")
                ) {
                    walk(&p, out);
                }
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    walk(root, &mut files);
    files.sort();
    files
}

/// `%20`-style escapes decoded (ASCII only).
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = std::str::from_utf8(&b[i + 1..i + 3]).ok();
            if let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Every dead relative link and missing anchor of the Markdown files under `root`, as
/// `file:line: target (why)`.
fn dead_links(root: &Path) -> Vec<String> {
    let files = markdown_files(root);
    let mut anchors: BTreeMap<PathBuf, Vec<String>> = BTreeMap::new();
    let mut anchors_of = |p: &Path| -> Option<Vec<String>> {
        let key = p.canonicalize().ok()?;
        if let Some(a) = anchors.get(&key) {
            return Some(a.clone());
        }
        let a = parse_markdown(&std::fs::read_to_string(&key).ok()?).anchors;
        anchors.insert(key, a.clone());
        Some(a)
    };
    let mut dead = Vec::new();
    for file in &files {
        let Ok(md) = std::fs::read_to_string(file) else {
            continue;
        };
        let rel = file
            .strip_prefix(root)
            .unwrap_or(file)
            .display()
            .to_string();
        for (target, line) in parse_markdown(&md).links {
            let lower = target.to_ascii_lowercase();
            if target.is_empty()
                || lower.contains("://")
                || lower.starts_with("mailto:")
                || lower.starts_with("tel:")
            {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let path = percent_decode(path);
            let dest = if path.is_empty() {
                file.clone()
            } else if let Some(abs) = path.strip_prefix('/') {
                root.join(abs)
            } else {
                file.parent().unwrap().join(&path)
            };
            if !dest.exists() {
                dead.push(format!("{rel}:{line}: {target} (no such file)"));
                continue;
            }
            let Some(anchor) = anchor else { continue };
            if dest.is_dir() || dest.extension().is_none_or(|x| x != "md") {
                // GitHub's anchors into source files are line numbers (`#L10`): not checked.
                if dest.is_dir() {
                    dead.push(format!(
                        "{rel}:{line}: {target} (an anchor into a directory)"
                    ));
                }
                continue;
            }
            let have = anchors_of(&dest).unwrap_or_default();
            if !have.iter().any(|a| *a == percent_decode(anchor)) {
                dead.push(format!(
                    "{rel}:{line}: {target} (no heading with this anchor)"
                ));
            }
        }
    }
    dead
}

#[test]
fn slugs_and_links_are_found_as_github_renders_them() {
    assert_eq!(slug("Teach a new task"), "teach-a-new-task");
    assert_eq!(slug("5. Train"), "5-train");
    assert_eq!(
        slug(&heading_text(
            "`crossym eval --protocol paper`: Table II (ours & the paper's)"
        )),
        "crossym-eval---protocol-paper-table-ii-ours--the-papers"
    );
    assert_eq!(
        slug("The checks: descend, lift, compose"),
        "the-checks-descend-lift-compose"
    );
    assert_eq!(
        slug("π_MRT, joint space — λ = 1"),
        "π_mrt-joint-space--λ--1"
    );
    assert_eq!(
        slug(&heading_text("See [the node guide](node.md) <sup>1</sup>")),
        "see-the-node-guide-1"
    );
    let p = parse_markdown(
        "# A\n\n## A\n\n```sh\n# not a heading [x](nowhere.md)\n```\n\n### A #\n\
         see [b](b.md#a-1) and ![img](fig.png \"title\"), not `[c](c.md)`\n\
         [ref]: <d.md>\n<a id=\"here\"></a>\n",
    );
    assert_eq!(p.anchors, ["a", "a-1", "a-2", "here"]);
    assert_eq!(
        p.links,
        [
            ("b.md#a-1".to_string(), 10),
            ("fig.png".to_string(), 10),
            ("d.md".to_string(), 11)
        ]
    );
    assert_eq!(
        sh_blocks("```sh\na\n```\n```text\nb\n```\n~~~sh\nc\n~~~\n````sh\nd\n```\ne\n````\n"),
        ["a\n", "c\n", "d\n```\ne\n"]
    );
}

#[test]
fn relative_links_and_anchors_resolve() {
    let t0 = Instant::now();
    let root = common::root();
    let files = markdown_files(&root);
    assert!(
        files.iter().any(|f| f.ends_with("docs/guide/teach.md")),
        "{files:?}"
    );
    let dead = dead_links(&root);
    eprintln!(
        "docs links: {} Markdown files checked in {:.2} s",
        files.len(),
        t0.elapsed().as_secs_f64()
    );
    assert!(
        dead.is_empty(),
        "{} dead relative links or anchors:\n{}",
        dead.len(),
        dead.join("\n")
    );
}
