//! LeRobot datasets (the `LeRobotDataset` layout `lerobot-record` writes, RB-Y1's official
//! data-collection path): per-episode joint-state time series read from the Parquet
//! frames.
//!
//! Layout (LeRobot's documentation; versions `v3.0` and `v2.1`): `meta/info.json` with
//! `codebase_version`, `fps` and `features` (`dtype`, `shape`, `names`); frames in Parquet
//! under `data/` — `data/chunk-XXX/file-XXX.parquet` holding many episodes (v3.0) or one
//! `data/chunk-XXX/episode_XXXXXX.parquet` per episode (v2.1) — with the columns
//! `timestamp`, `frame_index`, `episode_index`, `index`, `task_index` and one per feature:
//! a state as a fixed-length list whose elements `names` names, or one scalar column per
//! named feature (`right_arm_0.pos`, …). Videos (MP4) are not read.
//!
//! Read here: every Parquet file under `data/` (both versions, any codec the writer used:
//! snappy, zstd or none), rows grouped by `episode_index` and ordered by `frame_index`, the
//! state's values as `f64` in the order of its names, time from `timestamp` (s). Refused,
//! naming the file, the column and the problem: a missing or malformed `meta/info.json`,
//! an unknown `codebase_version`, a state feature that is absent or whose shape does not
//! match its names, a missing column, a non-finite value, timestamps that do not increase
//! within an episode, frame indices with a gap, an unreadable (e.g. truncated) Parquet file.
//!
//! [`write_dataset`] writes the other way (v3.0 layout, `write`).

mod write;

pub use write::{write_dataset, EpisodeFrames};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use parquet::file::reader::FileReader;
use parquet::file::serialized_reader::SerializedFileReader;
use parquet::record::{Field, Row};

/// Why a dataset was refused.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LeRobotError {
    /// A file or directory cannot be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// `meta/info.json` is missing or malformed, or does not describe the asked feature.
    #[error("{}: {message}", path.display())]
    Info {
        /// `meta/info.json`.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A Parquet file cannot be read (truncated, corrupt, not Parquet).
    #[error("{}: not a readable Parquet file: {message}", path.display())]
    Parquet {
        /// The file.
        path: PathBuf,
        /// The reader's description.
        message: String,
    },
    /// A column is missing or holds a value that cannot be used.
    #[error("{}: column `{column}`, row {row}: {message}", path.display())]
    Column {
        /// The Parquet file.
        path: PathBuf,
        /// The column.
        column: String,
        /// Row in the file (0-based).
        row: usize,
        /// What is wrong.
        message: String,
    },
    /// An episode's frames are not a clean time series.
    #[error("{}: episode {episode}: {message}", path.display())]
    Episode {
        /// The dataset.
        path: PathBuf,
        /// `episode_index`.
        episode: i64,
        /// What is wrong.
        message: String,
    },
}

/// One episode: its frames' times and states.
#[derive(Debug, Clone, PartialEq)]
pub struct Episode {
    /// `episode_index`.
    pub index: i64,
    /// `task_index` of its first frame.
    pub task_index: i64,
    /// The Parquet file(s) it was read from (the first).
    pub file: PathBuf,
    /// `timestamp` of each frame (s).
    pub t: Vec<f64>,
    /// States, row-major `len × names.len()`.
    pub state: Vec<f64>,
}

/// A dataset's state feature, episode by episode.
#[derive(Debug, Clone, PartialEq)]
pub struct LeRobotStates {
    /// The dataset directory.
    pub dir: PathBuf,
    /// `codebase_version`.
    pub version: String,
    /// `fps`.
    pub fps: f64,
    /// Names of the state's elements (the column order of [`Episode::state`]).
    pub names: Vec<String>,
    /// Episodes in `episode_index` order.
    pub episodes: Vec<Episode>,
}

/// One frame as read, before its episode is assembled.
struct Frame {
    /// `frame_index`.
    index: i64,
    /// `timestamp` (s).
    t: f64,
    /// `task_index`.
    task: i64,
    /// The state's values.
    state: Vec<f64>,
    /// Index of the file it came from.
    file: usize,
}

/// How the state is stored: one list column, or one scalar column per name.
enum StateColumns {
    List(String),
    Scalars(Vec<String>),
}

/// The names of a feature: a list of strings, or an object holding one such list (older
/// datasets: `{"motors": [...]}`).
fn feature_names(v: &serde_json::Value) -> Option<Vec<String>> {
    let list = match v {
        serde_json::Value::Array(a) => a,
        serde_json::Value::Object(o) if o.len() == 1 => o.values().next()?.as_array()?,
        _ => return None,
    };
    list.iter().map(|x| x.as_str().map(String::from)).collect()
}

/// Reads the state of `dir`: the feature `state` (a list feature with `names`), or, when
/// `state` names no feature, the scalar features listed in `scalars` (e.g.
/// `right_arm_0.pos`), each its own column.
pub fn read_states(
    dir: &Path,
    state: &str,
    scalars: &[String],
) -> Result<LeRobotStates, LeRobotError> {
    let info_path = dir.join("meta/info.json");
    let info_err = |message: String| info_error(&info_path, message);
    let (info, version, fps) = read_info(&info_path)?;
    let features = info["features"]
        .as_object()
        .ok_or_else(|| info_err("no `features` object".into()))?;
    let (columns, names) = state_columns(features, state, scalars, &info_path)?;
    let mut files = Vec::new();
    parquet_files(&dir.join("data"), &mut files)?;
    if files.is_empty() {
        return Err(info_err(format!(
            "no Parquet file under {}",
            dir.join("data").display()
        )));
    }
    files.sort();
    let mut frames: BTreeMap<i64, Vec<Frame>> = BTreeMap::new();
    for (fi, file) in files.iter().enumerate() {
        read_file(file, &columns, names.len(), |ep, frame, t, task, st| {
            frames.entry(ep).or_default().push(Frame {
                index: frame,
                t,
                task,
                state: st,
                file: fi,
            });
        })?;
    }
    let mut episodes = Vec::with_capacity(frames.len());
    for (index, rows) in frames {
        episodes.push(assemble_episode(dir, index, rows, &files, names.len())?);
    }
    Ok(LeRobotStates {
        dir: dir.to_path_buf(),
        version,
        fps,
        names,
        episodes,
    })
}

/// The error for a bad `meta/info.json` at `info_path`.
fn info_error(info_path: &Path, message: String) -> LeRobotError {
    LeRobotError::Info {
        path: info_path.to_path_buf(),
        message,
    }
}

/// Reads `meta/info.json`: the JSON, its supported `codebase_version` and its `fps`.
fn read_info(info_path: &Path) -> Result<(serde_json::Value, String, f64), LeRobotError> {
    let info_err = |message: String| info_error(info_path, message);
    let text = std::fs::read_to_string(info_path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound {
            info_err(
                "missing: not a LeRobot dataset (expected meta/info.json in the directory)".into(),
            )
        } else {
            LeRobotError::Io {
                path: info_path.to_path_buf(),
                source,
            }
        }
    })?;
    let info: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| info_err(format!("not JSON: {e}")))?;
    let version = info["codebase_version"]
        .as_str()
        .ok_or_else(|| info_err("no `codebase_version`".into()))?
        .to_string();
    if version != "v3.0" && version != "v2.1" {
        return Err(info_err(format!(
            "codebase_version `{version}` is not supported (v3.0 and v2.1 are)"
        )));
    }
    let fps = info["fps"]
        .as_f64()
        .filter(|f| f.is_finite() && *f > 0.0)
        .ok_or_else(|| info_err("`fps` is not a positive number".into()))?;
    Ok((info, version, fps))
}

/// Where the state is stored and its names: the list feature `state`, or the scalar
/// features `scalars` when `state` names no feature.
fn state_columns(
    features: &serde_json::Map<String, serde_json::Value>,
    state: &str,
    scalars: &[String],
    info_path: &Path,
) -> Result<(StateColumns, Vec<String>), LeRobotError> {
    let info_err = |message: String| info_error(info_path, message);
    match features.get(state) {
        Some(f) => {
            let names = feature_names(&f["names"])
                .ok_or_else(|| info_err(format!("feature `{state}` has no list of `names`")))?;
            let shape: Vec<u64> = f["shape"]
                .as_array()
                .map(|a| a.iter().filter_map(|x| x.as_u64()).collect())
                .unwrap_or_default();
            if shape != [names.len() as u64] {
                return Err(info_err(format!(
                    "feature `{state}` has shape {:?} but {} names",
                    f["shape"],
                    names.len()
                )));
            }
            Ok((StateColumns::List(state.to_string()), names))
        }
        None if !scalars.is_empty() => {
            for c in scalars {
                let f = features
                    .get(c)
                    .ok_or_else(|| info_err(format!("no feature `{c}`")))?;
                let shape = f["shape"].as_array().map(|a| a.len()).unwrap_or(0);
                if shape != 1 || f["shape"][0].as_u64() != Some(1) {
                    return Err(info_err(format!(
                        "feature `{c}` has shape {:?}, not [1] (a scalar per frame)",
                        f["shape"]
                    )));
                }
            }
            Ok((StateColumns::Scalars(scalars.to_vec()), scalars.to_vec()))
        }
        None => Err(info_err(format!(
            "no feature `{state}` (features: {})",
            features.keys().cloned().collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// Episode `index` from its frames (any order): consecutive frame indices, increasing
/// timestamps, `n` state values per frame.
fn assemble_episode(
    dir: &Path,
    index: i64,
    mut rows: Vec<Frame>,
    files: &[PathBuf],
    n: usize,
) -> Result<Episode, LeRobotError> {
    rows.sort_by_key(|r| r.index);
    let bad = |message: String| LeRobotError::Episode {
        path: dir.to_path_buf(),
        episode: index,
        message,
    };
    for (k, w) in rows.windows(2).enumerate() {
        if w[1].index != w[0].index + 1 {
            return Err(bad(format!(
                "frame_index jumps from {} to {} (frames missing or repeated)",
                w[0].index, w[1].index
            )));
        }
        if w[1].t <= w[0].t {
            return Err(bad(format!(
                "timestamp of frame {} ({} s) is not after frame {}'s ({} s)",
                k + 1,
                w[1].t,
                k,
                w[0].t
            )));
        }
    }
    let mut state = Vec::with_capacity(rows.len() * n);
    let mut t = Vec::with_capacity(rows.len());
    for r in &rows {
        t.push(r.t);
        state.extend_from_slice(&r.state);
    }
    Ok(Episode {
        index,
        task_index: rows[0].task,
        file: files[rows[0].file].clone(),
        t,
        state,
    })
}

/// The tasks of the dataset `dir`: `(task_index, task)`, from `meta/tasks.parquet` (v3.0:
/// columns `task_index` and the task string, named `task` or, as pandas writes a
/// DataFrame's index, `__index_level_0__`) or `meta/tasks.jsonl` (v2.1).
pub fn read_tasks(dir: &Path) -> Result<Vec<(i64, String)>, LeRobotError> {
    let jsonl = dir.join("meta/tasks.jsonl");
    if jsonl.exists() {
        let text = std::fs::read_to_string(&jsonl).map_err(|source| LeRobotError::Io {
            path: jsonl.clone(),
            source,
        })?;
        return text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .enumerate()
            .map(|(k, l)| {
                let v: serde_json::Value =
                    serde_json::from_str(l).map_err(|e| LeRobotError::Column {
                        path: jsonl.clone(),
                        column: "task".into(),
                        row: k,
                        message: format!("not JSON: {e}"),
                    })?;
                match (v["task_index"].as_i64(), v["task"].as_str()) {
                    (Some(i), Some(t)) => Ok((i, t.to_string())),
                    _ => Err(LeRobotError::Column {
                        path: jsonl.clone(),
                        column: "task".into(),
                        row: k,
                        message: "needs `task_index` and `task`".into(),
                    }),
                }
            })
            .collect();
    }
    let path = dir.join("meta/tasks.parquet");
    let file = std::fs::File::open(&path).map_err(|source| LeRobotError::Io {
        path: path.clone(),
        source,
    })?;
    let reader = SerializedFileReader::new(file).map_err(|e| LeRobotError::Parquet {
        path: path.clone(),
        message: e.to_string(),
    })?;
    let rows = reader
        .get_row_iter(None)
        .map_err(|e| LeRobotError::Parquet {
            path: path.clone(),
            message: e.to_string(),
        })?;
    let mut tasks = Vec::new();
    for (k, r) in rows.enumerate() {
        let r = r.map_err(|e| LeRobotError::Parquet {
            path: path.clone(),
            message: format!("row {k}: {e}"),
        })?;
        let (mut index, mut task) = (None, None);
        for (name, f) in r.get_column_iter() {
            match (name.as_str(), f) {
                ("task_index", Field::Long(i)) => index = Some(*i),
                ("task_index", Field::Int(i)) => index = Some(i64::from(*i)),
                ("task" | "__index_level_0__", Field::Str(t)) => task = Some(t.clone()),
                _ => {}
            }
        }
        match (index, task) {
            (Some(i), Some(t)) => tasks.push((i, t)),
            _ => {
                return Err(LeRobotError::Column {
                    path: path.clone(),
                    column: "task".into(),
                    row: k,
                    message: "needs `task_index` and a task string".into(),
                })
            }
        }
    }
    Ok(tasks)
}

/// Every `.parquet` file below `dir`.
fn parquet_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), LeRobotError> {
    let rd = std::fs::read_dir(dir).map_err(|source| LeRobotError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for e in rd {
        let p = e
            .map_err(|source| LeRobotError::Io {
                path: dir.to_path_buf(),
                source,
            })?
            .path();
        if p.is_dir() {
            parquet_files(&p, out)?;
        } else if p.extension().is_some_and(|x| x == "parquet") {
            out.push(p);
        }
    }
    Ok(())
}

/// A number of a frame's column as `f64` (floats and integers).
fn number(f: &Field) -> Option<f64> {
    Some(match f {
        Field::Float(x) => f64::from(*x),
        Field::Double(x) => *x,
        Field::Int(x) => f64::from(*x),
        Field::Long(x) => *x as f64,
        Field::Short(x) => f64::from(*x),
        Field::Byte(x) => f64::from(*x),
        Field::UInt(x) => f64::from(*x),
        Field::ULong(x) => *x as f64,
        _ => return None,
    })
}

/// Reads the frames of one Parquet file, calling `row(episode, frame, t, task, state)`.
fn read_file(
    path: &Path,
    columns: &StateColumns,
    n: usize,
    mut row: impl FnMut(i64, i64, f64, i64, Vec<f64>),
) -> Result<(), LeRobotError> {
    let file = std::fs::File::open(path).map_err(|source| LeRobotError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let reader = SerializedFileReader::new(file).map_err(|e| LeRobotError::Parquet {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let rows = reader
        .get_row_iter(None)
        .map_err(|e| LeRobotError::Parquet {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    for (k, r) in rows.enumerate() {
        let r = r.map_err(|e| LeRobotError::Parquet {
            path: path.to_path_buf(),
            message: format!("row {k}: {e}"),
        })?;
        let fields = RowFields { path, k, row: &r };
        let episode = fields.int("episode_index", fields.get("episode_index"))?;
        let frame = fields.int("frame_index", fields.get("frame_index"))?;
        let task = match fields.get("task_index") {
            None => 0,
            f => fields.int("task_index", f)?,
        };
        let t = fields
            .get("timestamp")
            .and_then(number)
            .ok_or_else(|| fields.err("timestamp", "missing or not a number".into()))?;
        if !t.is_finite() {
            return Err(fields.err("timestamp", format!("{t} is not finite")));
        }
        let state = fields.state(columns, n)?;
        row(episode, frame, t, task, state);
    }
    Ok(())
}

/// Row `k` of the Parquet file `path`, read field by field.
struct RowFields<'a> {
    path: &'a Path,
    k: usize,
    row: &'a Row,
}

impl<'a> RowFields<'a> {
    /// The error for this row's `column`.
    fn err(&self, column: &str, message: String) -> LeRobotError {
        LeRobotError::Column {
            path: self.path.to_path_buf(),
            column: column.to_string(),
            row: self.k,
            message,
        }
    }

    /// The field of the column `name`, if the row has it.
    fn get(&self, name: &str) -> Option<&'a Field> {
        self.row
            .get_column_iter()
            .find(|(c, _)| c.as_str() == name)
            .map(|(_, f)| f)
    }

    /// The integer `f` of the column `name`.
    fn int(&self, name: &str, f: Option<&Field>) -> Result<i64, LeRobotError> {
        match f {
            Some(Field::Long(x)) => Ok(*x),
            Some(Field::Int(x)) => Ok(i64::from(*x)),
            Some(other) => Err(self.err(name, format!("not an integer: {other}"))),
            None => Err(self.err(name, "missing".into())),
        }
    }

    /// The row's `n` state values, all finite.
    fn state(&self, columns: &StateColumns, n: usize) -> Result<Vec<f64>, LeRobotError> {
        let mut state = Vec::with_capacity(n);
        match columns {
            StateColumns::List(name) => {
                let Some(Field::ListInternal(list)) = self.get(name) else {
                    return Err(self.err(name, "missing or not a list".into()));
                };
                let el = list.elements();
                if el.len() != n {
                    return Err(
                        self.err(name, format!("{} values, the feature names {n}", el.len()))
                    );
                }
                for (i, f) in el.iter().enumerate() {
                    let v =
                        number(f).ok_or_else(|| self.err(name, format!("element {i} is {f}")))?;
                    state.push(v);
                }
            }
            StateColumns::Scalars(names) => {
                for name in names {
                    let f = self
                        .get(name)
                        .ok_or_else(|| self.err(name, "missing".into()))?;
                    let v = match f {
                        Field::ListInternal(l) if l.elements().len() == 1 => {
                            number(&l.elements()[0])
                        }
                        f => number(f),
                    }
                    .ok_or_else(|| self.err(name, format!("not a number: {f}")))?;
                    state.push(v);
                }
            }
        }
        if let Some(i) = state.iter().position(|v| !v.is_finite()) {
            let column = match columns {
                StateColumns::List(c) => c.clone(),
                StateColumns::Scalars(c) => c[i].clone(),
            };
            return Err(self.err(&column, format!("element {i} is {} (not finite)", state[i])));
        }
        Ok(state)
    }
}
