//! Writing a LeRobotDataset (v3.0 layout): the other direction of [`super::read_states`],
//! so demonstrations from bags or CSV can be used by the LeRobot tools.
//!
//! Written: `meta/info.json` (`codebase_version` v3.0, `fps`, the features), all frames in
//! `data/chunk-000/file-000.parquet` (columns `timestamp`, `frame_index`, `episode_index`,
//! `index`, `task_index`, `observation.state` and `action`, the state and action as lists
//! of float64 named by joint — float64 so the reader gives back every bit —, the action of
//! a frame being the next frame's state, as position-controlled robots record it),
//! `meta/tasks.parquet` (`task_index`, `task`) and `meta/episodes/chunk-000/file-000.parquet`
//! (`episode_index`, `length`, `dataset_from_index`, `dataset_to_index`,
//! `data/chunk_index`, `data/file_index`). Compression zstd. The directory must not exist
//! or be empty: nothing is overwritten.

use std::path::Path;
use std::sync::Arc;

use parquet::basic::{Compression, ZstdLevel};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::parser::parse_message_type;

use super::LeRobotError;

/// One episode to write: its frames' times (s) and states (row-major, one value per name).
#[derive(Debug, Clone, Copy)]
pub struct EpisodeFrames<'a> {
    /// `task_index` (into the `tasks` of [`write_dataset`]).
    pub task_index: i64,
    /// Time of each frame (s), increasing.
    pub t: &'a [f64],
    /// States, row-major `t.len() × names.len()`.
    pub state: &'a [f64],
}

/// A column's values for one Parquet file.
enum Column {
    Double(Vec<f64>),
    Int(Vec<i64>),
    /// A list column: values, definition and repetition levels.
    List(Vec<f64>, Vec<i16>, Vec<i16>),
    Str(Vec<ByteArray>),
}

fn parquet_err(path: &Path, e: impl std::fmt::Display) -> LeRobotError {
    LeRobotError::Parquet {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Writes one Parquet file of `schema` (message type text) with `columns` in its order.
fn write_file(path: &Path, schema: &str, columns: Vec<Column>) -> Result<(), LeRobotError> {
    let schema = Arc::new(parse_message_type(schema).map_err(|e| parquet_err(path, e))?);
    let props = Arc::new(
        WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::default()))
            .build(),
    );
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| LeRobotError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let file = std::fs::File::create(path).map_err(|source| LeRobotError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut w = SerializedFileWriter::new(file, schema, props).map_err(|e| parquet_err(path, e))?;
    let mut rg = w.next_row_group().map_err(|e| parquet_err(path, e))?;
    let mut columns = columns.into_iter();
    while let Some(mut cw) = rg.next_column().map_err(|e| parquet_err(path, e))? {
        let c = columns
            .next()
            .ok_or_else(|| parquet_err(path, "fewer columns than the schema"))?;
        match c {
            Column::Double(v) => cw.typed::<DoubleType>().write_batch(&v, None, None),
            Column::Int(v) => cw.typed::<Int64Type>().write_batch(&v, None, None),
            Column::List(v, d, r) => cw.typed::<DoubleType>().write_batch(&v, Some(&d), Some(&r)),
            Column::Str(v) => cw.typed::<ByteArrayType>().write_batch(&v, None, None),
        }
        .map_err(|e| parquet_err(path, e))?;
        cw.close().map_err(|e| parquet_err(path, e))?;
    }
    rg.close().map_err(|e| parquet_err(path, e))?;
    w.close().map_err(|e| parquet_err(path, e))?;
    Ok(())
}

/// A list column of `rows` rows of `n` values each (required list of required doubles:
/// definition level 1 per value, repetition level 0 at each row's first value).
fn list_column(values: Vec<f64>, n: usize) -> Column {
    let len = values.len();
    let def = vec![1i16; len];
    let rep = (0..len).map(|i| i16::from(i % n != 0)).collect();
    Column::List(values, def, rep)
}

/// Writes `episodes` (indices 0, 1, …) at `fps` with the state named `names` and the
/// `tasks` into the new dataset `dir`.
pub fn write_dataset(
    dir: &Path,
    fps: f64,
    names: &[String],
    tasks: &[String],
    episodes: &[EpisodeFrames<'_>],
) -> Result<(), LeRobotError> {
    let info_path = dir.join("meta/info.json");
    let bad = |message: String| LeRobotError::Info {
        path: info_path.clone(),
        message,
    };
    check_dataset(dir, fps, names.len(), tasks, episodes).map_err(bad)?;
    let (total, from) = write_frames(dir, names.len(), episodes)?;
    write_file(
        &dir.join("meta/tasks.parquet"),
        "message tasks { REQUIRED INT64 task_index; REQUIRED BYTE_ARRAY task (UTF8); }",
        vec![
            Column::Int((0..tasks.len() as i64).collect()),
            Column::Str(tasks.iter().map(|t| ByteArray::from(t.as_str())).collect()),
        ],
    )?;
    write_episodes(dir, episodes, from)?;
    let info = info_json(fps, names, tasks, episodes.len(), total);
    let text = serde_json::to_string_pretty(&info).map_err(|e| bad(e.to_string()))?;
    std::fs::write(&info_path, text).map_err(|source| LeRobotError::Io {
        path: info_path.clone(),
        source,
    })
}

/// Refuses a non-empty `dir`, nothing to write, and episodes whose sizes or tasks are off.
fn check_dataset(
    dir: &Path,
    fps: f64,
    n: usize,
    tasks: &[String],
    episodes: &[EpisodeFrames<'_>],
) -> Result<(), String> {
    if std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_some()) {
        return Err(format!(
            "{} exists and is not empty: nothing is overwritten",
            dir.display()
        ));
    }
    if !(fps.is_finite() && fps > 0.0) || n == 0 || episodes.is_empty() {
        return Err(format!(
            "fps {fps}, {n} names, {} episodes: nothing to write",
            episodes.len()
        ));
    }
    for (i, e) in episodes.iter().enumerate() {
        if e.state.len() != e.t.len() * n || e.t.is_empty() {
            return Err(format!(
                "episode {i}: {} times and {} values for {n} names",
                e.t.len(),
                e.state.len()
            ));
        }
        if e.task_index < 0 || e.task_index as usize >= tasks.len() {
            return Err(format!("episode {i}: no task {}", e.task_index));
        }
    }
    Ok(())
}

/// Writes every frame (the action is the next frame's state) to the data file; returns
/// the number of frames and each episode's first frame index.
fn write_frames(
    dir: &Path,
    n: usize,
    episodes: &[EpisodeFrames<'_>],
) -> Result<(usize, Vec<i64>), LeRobotError> {
    let (mut ts, mut frame, mut ep, mut index, mut task) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut state, mut action) = (Vec::new(), Vec::new());
    let mut from = Vec::new();
    for (k, e) in episodes.iter().enumerate() {
        from.push(index.len() as i64);
        let len = e.t.len();
        for f in 0..len {
            ts.push(e.t[f]);
            frame.push(f as i64);
            ep.push(k as i64);
            index.push(index.len() as i64);
            task.push(e.task_index);
            state.extend_from_slice(&e.state[f * n..(f + 1) * n]);
            let next = (f + 1).min(len - 1);
            action.extend_from_slice(&e.state[next * n..(next + 1) * n]);
        }
    }
    let total = index.len();
    let list = |name: &str| {
        format!(
            "REQUIRED GROUP {name} (LIST) {{ REPEATED GROUP list {{ REQUIRED DOUBLE element; }} }}"
        )
    };
    let schema = format!(
        "message frames {{ REQUIRED DOUBLE timestamp; REQUIRED INT64 frame_index; \
         REQUIRED INT64 episode_index; REQUIRED INT64 index; REQUIRED INT64 task_index; {} {} }}",
        list("observation.state"),
        list("action")
    );
    write_file(
        &dir.join("data/chunk-000/file-000.parquet"),
        &schema,
        vec![
            Column::Double(ts),
            Column::Int(frame),
            Column::Int(ep),
            Column::Int(index),
            Column::Int(task),
            list_column(state, n),
            list_column(action, n),
        ],
    )?;
    Ok((total, from))
}

/// Writes the episodes' index (length, first and past-last frame, all in one file).
fn write_episodes(
    dir: &Path,
    episodes: &[EpisodeFrames<'_>],
    from: Vec<i64>,
) -> Result<(), LeRobotError> {
    let lengths: Vec<i64> = episodes.iter().map(|e| e.t.len() as i64).collect();
    let to: Vec<i64> = from.iter().zip(&lengths).map(|(f, l)| f + l).collect();
    write_file(
        &dir.join("meta/episodes/chunk-000/file-000.parquet"),
        "message episodes { REQUIRED INT64 episode_index; REQUIRED INT64 length; \
         REQUIRED INT64 dataset_from_index; REQUIRED INT64 dataset_to_index; \
         REQUIRED INT64 data/chunk_index; REQUIRED INT64 data/file_index; }",
        vec![
            Column::Int((0..episodes.len() as i64).collect()),
            Column::Int(lengths),
            Column::Int(from),
            Column::Int(to),
            Column::Int(vec![0; episodes.len()]),
            Column::Int(vec![0; episodes.len()]),
        ],
    )
}

/// The dataset's `meta/info.json` (v3.0).
fn info_json(
    fps: f64,
    names: &[String],
    tasks: &[String],
    episodes: usize,
    total: usize,
) -> serde_json::Value {
    let n = names.len();
    let scalar = |dtype: &str| serde_json::json!({"dtype": dtype, "shape": [1], "names": null});
    let vector = serde_json::json!({"dtype": "float64", "shape": [n], "names": names});
    serde_json::json!({
        "codebase_version": "v3.0",
        "robot_type": null,
        "total_episodes": episodes,
        "total_frames": total,
        "total_tasks": tasks.len(),
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 500,
        "fps": fps,
        "splits": {"train": format!("0:{}", episodes)},
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "video_path": null,
        "features": {
            "observation.state": vector,
            "action": vector,
            "timestamp": scalar("float64"),
            "frame_index": scalar("int64"),
            "episode_index": scalar("int64"),
            "index": scalar("int64"),
            "task_index": scalar("int64"),
        },
    })
}
