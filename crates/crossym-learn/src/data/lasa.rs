//! LASA handwriting demonstrations (S. M. Khansari-Zadeh, EPFL LASA), the letters of the
//! paper's drawing experiment (Sec. VI-A).
//!
//! A letter file holds several demonstrations of one planar shape, positions in mm in a frame
//! whose origin is the common end point, time in s, velocities in mm/s. Two formats:
//!
//! - **CSV**: a header naming the columns `demo,t,x,y,vx,vy` (any order, extra columns
//!   ignored), then one row per sample. Demonstrations are numbered contiguously from 0 (or
//!   1) and the rows of one demonstration are consecutive; `t` increases within each.
//! - **MAT** (the LASA originals, MAT v5): a variable `demos`, a cell array of 1×1 structs
//!   with fields `pos` (2×N, mm), `t` (1×N, s), `vel` (2×N, mm/s) and, unused here, `acc`
//!   (2×N, mm/s²) and `dt` (s). Read with [`super::mat5`].
//!
//! Every demonstration is checked: at least 2 samples, equal lengths of `t`, `pos`, `vel`,
//! finite values and strictly increasing `t`. Errors name the file and the line or demo.

use std::path::{Path, PathBuf};

use super::mat5::{dims_string, Mat5Error, MatFile, MatValue};

/// What can go wrong while loading demonstration data.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DataError {
    /// The file could not be read from disk.
    #[error("cannot read {path}: {source}")]
    Io {
        /// File that was being read.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The MAT file is unreadable (its message names the file and byte offset).
    #[error(transparent)]
    Mat {
        /// The reader's error.
        #[from]
        source: Mat5Error,
    },
    /// A CSV line is malformed (missing column, not a number, non-finite, out of order).
    #[error("{file} line {line}: {message}")]
    Csv {
        /// File name, or `<string>`.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// One demonstration is invalid (too short, inconsistent lengths, non-finite, bad dims).
    #[error("{file}: {demo}: {message}")]
    Demo {
        /// File name, or `<string>`.
        file: String,
        /// Which demonstration (`demo 3` in a CSV, `demos{4}` in a MAT file).
        demo: String,
        /// What is wrong.
        message: String,
    },
    /// The file as a whole has the wrong content (empty, no `demos` variable, …).
    #[error("{file}: {message}")]
    Content {
        /// File name, or `<string>`.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The file extension is neither `.csv` nor `.mat`.
    #[error("{path}: unknown demonstration format (expected a .csv or .mat file)")]
    UnknownFormat {
        /// The offending path.
        path: PathBuf,
    },
    /// A setting or derived dataset is invalid (used by the letter task builder).
    #[error("{message}")]
    Invalid {
        /// What is wrong.
        message: String,
    },
}

/// One demonstration: samples of a planar trajectory ending at the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Demonstration {
    /// Sample times (s), strictly increasing.
    pub t: Vec<f64>,
    /// Positions `[x, y]` (mm).
    pub pos: Vec<[f64; 2]>,
    /// Velocities `[vx, vy]` (mm/s).
    pub vel: Vec<[f64; 2]>,
}

impl Demonstration {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Duration `t_last − t_first` (s); 0 for fewer than 2 samples.
    pub fn duration(&self) -> f64 {
        match (self.t.first(), self.t.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// Checks lengths, sample count, finiteness and increasing time; says what is wrong.
    pub fn validate(&self) -> Result<(), DemonstrationError> {
        let n = self.t.len();
        if self.pos.len() != n || self.vel.len() != n {
            return Err(DemonstrationError::Lengths {
                times: n,
                positions: self.pos.len(),
                velocities: self.vel.len(),
            });
        }
        if n < 2 {
            return Err(DemonstrationError::TooShort { samples: n });
        }
        for i in 0..n {
            if !self.t[i].is_finite() {
                return Err(DemonstrationError::NonFiniteTime {
                    sample: i,
                    t: self.t[i],
                });
            }
            if self.pos[i].iter().any(|v| !v.is_finite()) {
                return Err(DemonstrationError::NonFinitePosition {
                    sample: i,
                    position: self.pos[i],
                });
            }
            if self.vel[i].iter().any(|v| !v.is_finite()) {
                return Err(DemonstrationError::NonFiniteVelocity {
                    sample: i,
                    velocity: self.vel[i],
                });
            }
            if i > 0 && self.t[i] <= self.t[i - 1] {
                return Err(DemonstrationError::TimeNotIncreasing {
                    sample: i,
                    t: self.t[i],
                    previous: self.t[i - 1],
                });
            }
        }
        Ok(())
    }
}

/// What is wrong with one [`Demonstration`] ([`Demonstration::validate`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DemonstrationError {
    /// Times, positions and velocities differ in number.
    #[error("inconsistent lengths: {times} times, {positions} positions, {velocities} velocities")]
    Lengths {
        /// Number of times.
        times: usize,
        /// Number of positions.
        positions: usize,
        /// Number of velocities.
        velocities: usize,
    },
    /// Fewer than 2 samples.
    #[error("{samples} sample(s), at least 2 are needed")]
    TooShort {
        /// Number of samples.
        samples: usize,
    },
    /// A time is NaN or infinite.
    #[error("sample {sample}: t is not finite ({t})")]
    NonFiniteTime {
        /// 0-based sample index.
        sample: usize,
        /// The time (s).
        t: f64,
    },
    /// A position is NaN or infinite.
    #[error("sample {sample}: position {position:?} is not finite")]
    NonFinitePosition {
        /// 0-based sample index.
        sample: usize,
        /// The position (mm).
        position: [f64; 2],
    },
    /// A velocity is NaN or infinite.
    #[error("sample {sample}: velocity {velocity:?} is not finite")]
    NonFiniteVelocity {
        /// 0-based sample index.
        sample: usize,
        /// The velocity (mm/s).
        velocity: [f64; 2],
    },
    /// A time does not increase.
    #[error("sample {sample}: t = {t} s does not increase (previous {previous} s)")]
    TimeNotIncreasing {
        /// 0-based sample index.
        sample: usize,
        /// Its time (s).
        t: f64,
        /// The previous sample's time (s).
        previous: f64,
    },
}

/// All demonstrations of one letter (e.g. `CShape`), in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct LetterSet {
    /// Letter name: the file stem (`CShape`).
    pub name: String,
    /// The demonstrations, in file order.
    pub demos: Vec<Demonstration>,
}

const CSV_COLUMNS: [&str; 6] = ["demo", "t", "x", "y", "vx", "vy"];

impl LetterSet {
    /// Loads a `.csv` or `.mat` letter file, chosen by extension (case-insensitive).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, DataError> {
        let path = path.as_ref();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("csv") => Self::from_csv(path),
            Some("mat") => Self::from_mat(path),
            _ => Err(DataError::UnknownFormat {
                path: path.to_path_buf(),
            }),
        }
    }

    /// Loads a CSV letter file (columns `demo,t,x,y,vx,vy`; mm, s, mm/s).
    pub fn from_csv(path: impl AsRef<Path>) -> Result<Self, DataError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| DataError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let file = path.display().to_string();
        let text = String::from_utf8(bytes).map_err(|e| DataError::Content {
            file: file.clone(),
            message: format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        })?;
        Self::from_csv_str(&stem(path), &file, &text)
    }

    /// Parses CSV text; `name` becomes [`LetterSet::name`], `file` names it in errors.
    pub fn from_csv_str(name: &str, file: &str, text: &str) -> Result<Self, DataError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty());
        let Some((header_line, header)) = lines.next() else {
            return Err(DataError::Content {
                file: file.to_string(),
                message: "empty file: no header line (expected columns demo,t,x,y,vx,vy)".into(),
            });
        };
        let names: Vec<&str> = header
            .split(',')
            .map(|h| h.trim().trim_matches('"'))
            .collect();
        let col = csv_columns(file, header_line, &names)?;

        let mut demos: Vec<Demonstration> = Vec::new();
        let mut ids: Vec<(u64, usize)> = Vec::new(); // (demo number, first line)
        for (line, row) in lines {
            let (id, v) = csv_row(file, line, row, names.len(), &col)?;
            csv_push(file, line, id, v, &mut demos, &mut ids)?;
        }
        if demos.is_empty() {
            return Err(DataError::Content {
                file: file.to_string(),
                message: "no data rows after the header".into(),
            });
        }
        for (d, &(id, first)) in demos.iter().zip(&ids) {
            d.validate().map_err(|e| DataError::Demo {
                file: file.to_string(),
                demo: format!("demo {id} (from line {first})"),
                message: e.to_string(),
            })?;
        }
        Ok(Self {
            name: name.to_string(),
            demos,
        })
    }

    /// Loads an original LASA `.mat` file (variable `demos`, see the module doc).
    pub fn from_mat(path: impl AsRef<Path>) -> Result<Self, DataError> {
        let path = path.as_ref();
        let mat = MatFile::open(path)?;
        Self::from_mat_file(&stem(path), &path.display().to_string(), &mat)
    }

    /// Parses in-memory MAT v5 bytes; `name` becomes [`LetterSet::name`], `file` names it in errors.
    pub fn from_mat_bytes(name: &str, file: &str, bytes: &[u8]) -> Result<Self, DataError> {
        let mat = MatFile::parse(bytes, file)?;
        Self::from_mat_file(name, file, &mat)
    }

    /// Extracts the demonstrations from a parsed MAT file; `file` names it in errors.
    pub fn from_mat_file(name: &str, file: &str, mat: &MatFile) -> Result<Self, DataError> {
        let content = |message: String| DataError::Content {
            file: file.to_string(),
            message,
        };
        let demos = mat.get("demos").ok_or_else(|| {
            content(format!(
                "no variable `demos` (variables: {})",
                mat.names().join(", ")
            ))
        })?;
        // A cell array of 1×1 structs (the LASA layout), or a struct array.
        let structs: Vec<(&MatValue, usize)> = match demos {
            MatValue::Cell { items, .. } => items.iter().map(|v| (v, 0)).collect(),
            MatValue::Struct { .. } => (0..demos.numel()).map(|e| (demos, e)).collect(),
            other => {
                return Err(content(format!(
                    "`demos` is {}, expected a cell array of structs",
                    other.describe()
                )))
            }
        };
        if structs.is_empty() {
            return Err(content("`demos` holds no demonstration".into()));
        }
        let mut out = Vec::with_capacity(structs.len());
        for (k, (s, element)) in structs.into_iter().enumerate() {
            out.push(demonstration(file, k, s, element)?);
        }
        Ok(Self {
            name: name.to_string(),
            demos: out,
        })
    }

    /// Total number of samples over all demonstrations.
    pub fn samples(&self) -> usize {
        self.demos.iter().map(Demonstration::len).sum()
    }
}

/// A CSV error at `line` of `file`.
fn csv_error(file: &str, line: usize, message: String) -> DataError {
    DataError::Csv {
        file: file.to_string(),
        line,
        message,
    }
}

/// Index of each of [`CSV_COLUMNS`] in the header `names` (at `header_line` of `file`).
fn csv_columns(file: &str, header_line: usize, names: &[&str]) -> Result<[usize; 6], DataError> {
    let csv_err = |line: usize, message: String| csv_error(file, line, message);
    let mut col = [0usize; 6];
    for (k, want) in CSV_COLUMNS.iter().enumerate() {
        let hits: Vec<usize> = names
            .iter()
            .enumerate()
            .filter(|(_, n)| *n == want)
            .map(|(i, _)| i)
            .collect();
        match hits.as_slice() {
            [i] => col[k] = *i,
            [] => {
                return Err(csv_err(
                    header_line,
                    format!(
                        "missing column `{want}` (header has: {}; expected demo,t,x,y,vx,vy)",
                        names.join(", ")
                    ),
                ))
            }
            _ => {
                return Err(csv_err(
                    header_line,
                    format!("column `{want}` appears {} times", hits.len()),
                ))
            }
        }
    }
    Ok(col)
}

/// The demonstration number and `t, x, y, vx, vy` of the CSV row `row` at `line` of
/// `file`, whose header has `columns` columns at `col`.
fn csv_row(
    file: &str,
    line: usize,
    row: &str,
    columns: usize,
    col: &[usize; 6],
) -> Result<(u64, [f64; 5]), DataError> {
    let csv_err = |line: usize, message: String| csv_error(file, line, message);
    let fields: Vec<&str> = row.split(',').map(str::trim).collect();
    if fields.len() != columns {
        return Err(csv_err(
            line,
            format!(
                "{} fields, the header has {} columns",
                fields.len(),
                columns
            ),
        ));
    }
    let raw_id = fields[col[0]].trim_matches('"');
    let id: u64 = raw_id.parse().map_err(|_| {
        csv_err(
            line,
            format!("column demo is not a non-negative integer: `{raw_id}`"),
        )
    })?;
    let mut v = [0.0; 5];
    for k in 0..5 {
        let name = CSV_COLUMNS[k + 1];
        let raw = fields[col[k + 1]].trim_matches('"');
        let x: f64 = raw
            .parse()
            .map_err(|_| csv_err(line, format!("column {name} is not a number: `{raw}`")))?;
        if !x.is_finite() {
            return Err(csv_err(
                line,
                format!("column {name} is not finite: `{raw}`"),
            ));
        }
        v[k] = x;
    }
    Ok((id, v))
}

/// Appends the sample `v` of demonstration `id` (CSV `line` of `file`) to `demos`, opening
/// a new demonstration (listed in `ids` with its first line) when `id` changes; refuses
/// numbers out of sequence and times that do not increase.
fn csv_push(
    file: &str,
    line: usize,
    id: u64,
    v: [f64; 5],
    demos: &mut Vec<Demonstration>,
    ids: &mut Vec<(u64, usize)>,
) -> Result<(), DataError> {
    let csv_err = |line: usize, message: String| csv_error(file, line, message);
    match ids.last() {
        Some(&(prev, _)) if prev == id => {}
        Some(&(prev, _)) if prev + 1 == id => {}
        Some(&(prev, _)) => {
            return Err(csv_err(
                line,
                format!(
                    "demo {id} follows demo {prev}: demos must be numbered contiguously with their rows together"
                ),
            ))
        }
        None if id <= 1 => {}
        None => return Err(csv_err(line, format!("first demo is numbered {id}, expected 0 or 1"))),
    }
    if ids.last().map(|&(p, _)| p) != Some(id) {
        ids.push((id, line));
        demos.push(Demonstration {
            t: Vec::new(),
            pos: Vec::new(),
            vel: Vec::new(),
        });
    }
    let d = demos
        .last_mut()
        .ok_or_else(|| csv_err(line, "internal: no current demo".into()))?;
    if let Some(&prev) = d.t.last() {
        if v[0] <= prev {
            return Err(csv_err(
                line,
                format!(
                    "t = {} s does not increase within demo {id} (previous row: {prev} s)",
                    v[0]
                ),
            ));
        }
    }
    d.t.push(v[0]);
    d.pos.push([v[1], v[2]]);
    d.vel.push([v[3], v[4]]);
    Ok(())
}

/// Demonstration `k` of `demos` (element `element` of the struct `s`), checked.
fn demonstration(
    file: &str,
    k: usize,
    s: &MatValue,
    element: usize,
) -> Result<Demonstration, DataError> {
    let label = format!("demos{{{}}}", k + 1);
    let demo_err = |message: String| DataError::Demo {
        file: file.to_string(),
        demo: label.clone(),
        message,
    };
    if !matches!(s, MatValue::Struct { .. }) {
        return Err(demo_err(format!("is {}, expected a struct", s.describe())));
    }
    let field = |f: &str| {
        s.field_of(element, f).ok_or_else(|| {
            demo_err(format!(
                "has no field `{f}` (fields: {})",
                s.field_names().unwrap_or(&[]).join(", ")
            ))
        })
    };
    let (pos, t, vel) = (field("pos")?, field("t")?, field("vel")?);
    let real = |v: &MatValue, f: &str| -> Result<Vec<f64>, DataError> {
        v.as_real().map(<[f64]>::to_vec).ok_or_else(|| {
            demo_err(format!(
                "`{f}` is {}, expected a real numeric array",
                v.describe()
            ))
        })
    };
    let n = t.numel();
    let t_dims = t.dims();
    if t_dims.len() != 2 || (t_dims[0] != 1 && t_dims[1] != 1) {
        return Err(demo_err(format!(
            "`t` is {}, expected 1×N",
            dims_string(t_dims)
        )));
    }
    let rows2 = |v: &MatValue, f: &str| -> Result<Vec<[f64; 2]>, DataError> {
        if v.dims() != [2, n] {
            return Err(demo_err(format!(
                "`{f}` is {}, expected 2×{n} (`t` has {n} samples)",
                dims_string(v.dims())
            )));
        }
        Ok(real(v, f)?.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
    };
    let d = Demonstration {
        t: real(t, "t")?,
        pos: rows2(pos, "pos")?,
        vel: rows2(vel, "vel")?,
    };
    d.validate().map_err(|e| demo_err(e.to_string()))?;
    Ok(d)
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}
