//! LASA letter data: shipped CSV and MAT files agree, and every
//! malformed input (truncated or corrupt MAT, bad CSV) is a clear error, never a panic.

use std::path::{Path, PathBuf};

use crossym::data::mat5::MatFile;
use crossym::data::{DataError, LetterSet, MatValue};

use crate::common::{path, temp_dir};

const LETTERS: [&str; 2] = ["CShape", "NShape"];

/// The CSV files hold the MAT values rounded to 9 significant digits: relative error ≤ 5·10⁻⁹.
const CSV_REL_TOL: f64 = 5.000_001e-9;

fn shipped(letter: &str, ext: &str) -> PathBuf {
    path(&format!("data/lasa/{letter}.{ext}"))
}

/// Writes `bytes` to `dir/name`, loads it and returns the error message.
fn load_err(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write temp file");
    let msg = match LetterSet::load(&p) {
        Ok(set) => panic!(
            "{name}: expected an error, loaded {} demos",
            set.demos.len()
        ),
        Err(e) => e.to_string(),
    };
    assert!(
        msg.contains(name),
        "error does not name the file {name}: {msg}"
    );
    msg
}

fn assert_contains(msg: &str, needle: &str) {
    assert!(msg.contains(needle), "expected `{needle}` in: {msg}");
}

/// |a − b| within the 9-significant-digit rounding of the CSV.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= CSV_REL_TOL * b.abs()
}

#[test]
fn shipped_csv_and_mat_agree() {
    for letter in LETTERS {
        let csv = LetterSet::from_csv(shipped(letter, "csv")).expect("shipped CSV loads");
        let mat = LetterSet::from_mat(shipped(letter, "mat")).expect("shipped MAT loads");
        assert_eq!(csv.name, letter);
        assert_eq!(mat.name, letter);
        assert_eq!(csv.demos.len(), 7, "{letter}: CSV demos");
        assert_eq!(mat.demos.len(), 7, "{letter}: MAT demos");
        assert!(LetterSet::load(shipped(letter, "mat")).unwrap() == mat);
        assert!(LetterSet::load(shipped(letter, "csv")).unwrap() == csv);

        let (mut pos_abs, mut pos_rel, mut vel_abs, mut t_abs) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (k, (c, m)) in csv.demos.iter().zip(&mat.demos).enumerate() {
            assert_eq!(c.len(), m.len(), "{letter} demo {k}: lengths");
            assert_eq!(
                m.len(),
                1000,
                "{letter} demo {k}: LASA demos have 1000 samples"
            );
            for i in 0..m.len() {
                assert!(
                    close(c.t[i], m.t[i]),
                    "{letter} demo {k} sample {i}: t {} vs {}",
                    c.t[i],
                    m.t[i]
                );
                t_abs = t_abs.max((c.t[i] - m.t[i]).abs());
                for j in 0..2 {
                    let (a, b) = (c.pos[i][j], m.pos[i][j]);
                    assert!(
                        close(a, b),
                        "{letter} demo {k} sample {i}: pos[{j}] {a} vs {b}"
                    );
                    pos_abs = pos_abs.max((a - b).abs());
                    if b != 0.0 {
                        pos_rel = pos_rel.max((a - b).abs() / b.abs());
                    }
                    let (a, b) = (c.vel[i][j], m.vel[i][j]);
                    assert!(
                        close(a, b),
                        "{letter} demo {k} sample {i}: vel[{j}] {a} vs {b}"
                    );
                    vel_abs = vel_abs.max((a - b).abs());
                }
            }
            for d in [c, m] {
                let end = d.pos[d.len() - 1];
                assert!(
                    end[0].hypot(end[1]) <= 1e-9,
                    "{letter} demo {k}: ends at {end:?}, not the origin"
                );
                assert!(
                    d.t.windows(2).all(|w| w[1] > w[0]),
                    "{letter} demo {k}: t not increasing"
                );
                assert_eq!(d.t[0], 0.0, "{letter} demo {k}: t starts at 0");
            }
        }
        eprintln!(
            "{letter}: CSV vs MAT max |Δpos| = {pos_abs:.3e} mm (rel {pos_rel:.3e}), \
             max |Δvel| = {vel_abs:.3e} mm/s, max |Δt| = {t_abs:.3e} s"
        );
        // 9 significant digits of values below 100 mm: under 5·10⁻⁸ mm.
        assert!(pos_abs <= 5e-8, "{letter}: max |Δpos| = {pos_abs:e} mm");
        assert!(
            pos_rel <= CSV_REL_TOL,
            "{letter}: max relative Δpos = {pos_rel:e}"
        );
        assert!(t_abs <= 5e-9, "{letter}: max |Δt| = {t_abs:e} s");
    }
}

#[test]
fn shipped_mat_has_the_lasa_layout() {
    for letter in LETTERS {
        let mat = MatFile::open(shipped(letter, "mat")).expect("shipped MAT parses");
        assert!(!mat.big_endian);
        assert!(
            mat.description.starts_with("MATLAB 5.0 MAT-file"),
            "{}",
            mat.description
        );
        assert_eq!(mat.names(), vec!["dt", "demos"]);
        assert!(mat
            .get("dt")
            .and_then(MatValue::scalar)
            .is_some_and(|dt| dt > 0.0));
        let demos = mat.get("demos").unwrap();
        assert_eq!(demos.dims(), &[1, 7]);
        for item in demos.cell_items().unwrap() {
            assert_eq!(item.dims(), &[1, 1]);
            assert_eq!(
                item.field_names().unwrap(),
                &["pos", "t", "vel", "acc", "dt"]
            );
            for (f, dims) in [
                ("pos", [2, 1000]),
                ("t", [1, 1000]),
                ("vel", [2, 1000]),
                ("acc", [2, 1000]),
            ] {
                assert_eq!(item.field(f).unwrap().dims(), &dims, "{letter}: {f}");
            }
            // Per-demo sampling period: t is uniform with step dt.
            let dt = item.field("dt").and_then(MatValue::scalar).unwrap();
            let t = item.field("t").and_then(MatValue::as_real).unwrap();
            assert!((t[1] - t[0] - dt).abs() < 1e-12 && (t[999] - 999.0 * dt).abs() < 1e-9);
        }
    }
}

/// Offset of the second top-level element of the real files (the compressed `demos`):
/// the 128-byte header, then the compressed `dt` (8-byte tag + 43 bytes, unpadded).
fn demos_element(bytes: &[u8]) -> usize {
    let n = u32::from_le_bytes(bytes[132..136].try_into().unwrap()) as usize;
    let at = 136 + n;
    assert_eq!(
        u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()),
        15,
        "miCOMPRESSED"
    );
    at
}

#[test]
fn truncated_mat_is_an_error_at_every_cut() {
    let bytes = std::fs::read(shipped("CShape", "mat")).unwrap();
    let demos_at = demos_element(&bytes);
    let mut cuts: Vec<usize> = vec![
        0, 1, 4, 64, 116, 124, 126, 127, 128, 129, 132, 135, 136, 150, 170,
    ];
    cuts.extend([
        demos_at - 1,
        demos_at,
        demos_at + 1,
        demos_at + 4,
        demos_at + 7,
        demos_at + 8,
    ]);
    cuts.extend([
        demos_at + 9,
        demos_at + 100,
        bytes.len() / 2,
        bytes.len() - 8,
        bytes.len() - 1,
    ]);
    cuts.extend((200..bytes.len()).step_by(4999));
    for &cut in &cuts {
        let r = LetterSet::from_mat_bytes("CShape", "CShape.mat", &bytes[..cut]);
        let e = r.expect_err(&format!("cut at {cut} must fail")).to_string();
        assert!(e.starts_with("CShape.mat"), "cut at {cut}: {e}");
        if cut == 128 {
            assert_contains(&e, "no variable `demos` (variables: )");
        } else if cut == demos_at {
            // A valid file holding only `dt`.
            assert_contains(&e, "no variable `demos` (variables: dt)");
        } else if cut < 128 {
            assert_contains(&e, "128");
        } else if cut > demos_at + 8 {
            assert_contains(&e, "truncated data element (miCOMPRESSED)");
        } else {
            assert_contains(&e, "truncated");
        }
    }
    // The same through a file on disk.
    let dir = temp_dir("trunc");
    let e = load_err(&dir, "CShape_cut.mat", &bytes[..bytes.len() / 3]);
    assert_contains(&e, "truncated data element (miCOMPRESSED)");
    assert_contains(&e, &format!("byte {demos_at}"));

    // Cut inside the compressed stream with its length patched to match: the inflater itself
    // sees a truncated zlib stream.
    for cut in [
        demos_at + 10,
        demos_at + 3000,
        bytes.len() / 2,
        bytes.len() - 5,
    ] {
        let mut b = bytes[..cut].to_vec();
        let n = (cut - demos_at - 8) as u32;
        b[demos_at + 4..demos_at + 8].copy_from_slice(&n.to_le_bytes());
        let e = LetterSet::from_mat_bytes("CShape", "CShape.mat", &b)
            .unwrap_err()
            .to_string();
        assert_contains(
            &e,
            &format!("CShape.mat: byte {demos_at}: cannot inflate compressed element of {n} bytes"),
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn corrupted_zlib_stream_is_an_error() {
    let bytes = std::fs::read(shipped("NShape", "mat")).unwrap();
    let demos_at = demos_element(&bytes);
    let dir = temp_dir("zlib");
    // Garbage in the middle of the deflate stream.
    let mut b = bytes.clone();
    for x in &mut b[demos_at + 5000..demos_at + 5032] {
        *x ^= 0xa5;
    }
    let e = load_err(&dir, "NShape_garbled.mat", &b);
    assert_contains(
        &e,
        &format!("byte {demos_at}: cannot inflate compressed element"),
    );
    // A broken zlib header.
    let mut b = bytes.clone();
    b[demos_at + 8] = 0;
    let e = load_err(&dir, "NShape_zhdr.mat", &b);
    assert_contains(&e, "cannot inflate");
    // One flipped bit near the end: caught by the Adler-32 checksum at the latest.
    let mut b = bytes.clone();
    let k = b.len() - 64;
    b[k] ^= 0x10;
    let e = load_err(&dir, "NShape_bit.mat", &b);
    assert_contains(&e, "cannot inflate");
    std::fs::remove_dir_all(dir).ok();
}

/// The real `demos` element inflated, patched by `f`, and compressed back into the file.
fn patch_inflated(bytes: &[u8], f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let at = demos_element(bytes);
    let n = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap()) as usize;
    let mut raw = miniz_oxide::inflate::decompress_to_vec_zlib(&bytes[at + 8..at + 8 + n]).unwrap();
    f(&mut raw);
    let z = miniz_oxide::deflate::compress_to_vec_zlib(&raw, 6);
    let mut out = bytes[..at + 4].to_vec();
    out.extend((z.len() as u32).to_le_bytes());
    out.extend(z);
    out
}

/// Offset of the first `[2, 1000]` dimensions element body (demos{1}.pos) in inflated data.
fn first_pos_dims(raw: &[u8]) -> usize {
    let pat: Vec<u8> = [2i32, 1000].iter().flat_map(|v| v.to_le_bytes()).collect();
    raw.windows(8)
        .position(|w| w == pat.as_slice())
        .expect("pos dims")
}

#[test]
fn wrong_dims_and_layout_inside_the_mat_are_errors() {
    let bytes = std::fs::read(shipped("CShape", "mat")).unwrap();
    let dir = temp_dir("dims");
    // Consistent storage, wrong shape: 4×500.
    let b = patch_inflated(&bytes, |raw| {
        let k = first_pos_dims(raw);
        raw[k..k + 4].copy_from_slice(&4i32.to_le_bytes());
        raw[k + 4..k + 8].copy_from_slice(&500i32.to_le_bytes());
    });
    let e = load_err(&dir, "CShape_4x500.mat", &b);
    assert_contains(&e, "demos{1}: `pos` is 4×500, expected 2×1000");
    // Dimensions that do not match the stored values.
    let b = patch_inflated(&bytes, |raw| {
        let k = first_pos_dims(raw);
        raw[k + 4..k + 8].copy_from_slice(&999i32.to_le_bytes());
    });
    let e = load_err(&dir, "CShape_2x999.mat", &b);
    assert_contains(&e, "real part has 2000 values, dimensions 2×999 need 1998");
    assert_contains(
        &e,
        "of the data inflated from the compressed element at byte",
    );
    // Negative dimension.
    let b = patch_inflated(&bytes, |raw| {
        let k = first_pos_dims(raw);
        raw[k..k + 4].copy_from_slice(&(-2i32).to_le_bytes());
    });
    assert_contains(
        &load_err(&dir, "CShape_neg.mat", &b),
        "negative dimension -2",
    );
    // A field renamed: `vel` → `vex`.
    let b = patch_inflated(&bytes, |raw| {
        let k = raw
            .windows(4)
            .position(|w| w == b"vel\0")
            .expect("field names");
        raw[k + 2] = b'x';
    });
    assert_contains(
        &load_err(&dir, "CShape_novel.mat", &b),
        "demos{1}: has no field `vel` (fields: pos, t, vex, acc, dt)",
    );
    // A non-finite sample.
    let b = patch_inflated(&bytes, |raw| {
        let k = first_pos_dims(raw);
        // dims (8) + name tag (8, empty name) + real tag (8) → first value.
        let v = k + 8 + 8 + 8;
        raw[v..v + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    });
    assert_contains(
        &load_err(&dir, "CShape_nan.mat", &b),
        "demos{1}: sample 0: position [NaN",
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn wrong_header_is_an_error() {
    let bytes = std::fs::read(shipped("CShape", "mat")).unwrap();
    let dir = temp_dir("hdr");
    let mut b = bytes.clone();
    b[126..128].copy_from_slice(b"XY");
    assert_contains(
        &load_err(&dir, "CShape_endian.mat", &b),
        "endian indicator at byte 126 is \"XY\"",
    );
    let mut b = bytes.clone();
    b[124..126].copy_from_slice(&0x0200u16.to_le_bytes());
    assert_contains(
        &load_err(&dir, "CShape_v73.mat", &b),
        "MAT v7.3 (HDF5), which is not supported",
    );
    let mut b = bytes.clone();
    b[124..126].copy_from_slice(&0x0101u16.to_le_bytes());
    assert_contains(
        &load_err(&dir, "CShape_ver.mat", &b),
        "version 0x0101, expected 0x0100",
    );
    // A CSV file with a .mat name.
    let csv = std::fs::read(shipped("CShape", "csv")).unwrap();
    assert_contains(
        &load_err(&dir, "CShape_text.mat", &csv),
        "not a readable MAT v5 file",
    );
    assert_contains(
        &load_err(&dir, "empty.mat", b""),
        "the file has 0 bytes, a MAT v5 header alone has 128",
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn malformed_csv_is_an_error() {
    let text = std::fs::read_to_string(shipped("CShape", "csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let dir = temp_dir("csv");
    let with_line = |n: usize, new: &str| {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        l[n - 1] = new.to_string();
        l.join("\n")
    };
    // Line 17 (data row 16 of demo 0): vy is not a number.
    let row: Vec<&str> = lines[16].split(',').collect();
    let bad = with_line(
        17,
        &format!("{},{},{},{},{},abc", row[0], row[1], row[2], row[3], row[4]),
    );
    assert_contains(
        &load_err(&dir, "CShape.csv", bad.as_bytes()),
        "CShape.csv line 17: column vy is not a number: `abc`",
    );
    // NaN and infinity.
    let bad = with_line(
        30,
        &format!("{},{},NaN,{},{},{}", row[0], row[1], row[3], row[4], row[5]),
    );
    assert_contains(
        &load_err(&dir, "nan.csv", bad.as_bytes()),
        "nan.csv line 30: column x is not finite: `NaN`",
    );
    let bad = with_line(
        31,
        &format!("{},{},{},{},inf,{}", row[0], row[1], row[2], row[3], row[5]),
    );
    assert_contains(
        &load_err(&dir, "inf.csv", bad.as_bytes()),
        "line 31: column vx is not finite: `inf`",
    );
    // Missing column: drop vy everywhere.
    let dropped: String = lines
        .iter()
        .map(|l| l.rsplit_once(',').unwrap().0)
        .collect::<Vec<_>>()
        .join("\n");
    assert_contains(
        &load_err(&dir, "novy.csv", dropped.as_bytes()),
        "novy.csv line 1: missing column `vy` (header has: demo, t, x, y, vx;",
    );
    // A row with a missing field.
    let bad = with_line(5, &lines[4][..lines[4].rfind(',').unwrap()]);
    assert_contains(
        &load_err(&dir, "short.csv", bad.as_bytes()),
        "short.csv line 5: 5 fields, the header has 6 columns",
    );
    // Empty file, blank file, header only.
    assert_contains(
        &load_err(&dir, "empty.csv", b""),
        "empty.csv: empty file: no header line",
    );
    assert_contains(&load_err(&dir, "blank.csv", b"\n  \n"), "empty file");
    assert_contains(
        &load_err(&dir, "header.csv", b"demo,t,x,y,vx,vy\n"),
        "header.csv: no data rows after the header",
    );
    // Demos not numbered contiguously (demo 2 renamed 3).
    let renum: String = lines
        .iter()
        .map(|l| {
            if let Some(r) = l.strip_prefix("2,") {
                format!("3,{r}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let e = load_err(&dir, "gap.csv", renum.as_bytes());
    assert_contains(
        &e,
        "line 2002: demo 3 follows demo 1: demos must be numbered contiguously",
    );
    // Time going backwards.
    let row: Vec<&str> = lines[10].split(',').collect();
    let bad = with_line(
        11,
        &format!("{},0,{},{},{},{}", row[0], row[2], row[3], row[4], row[5]),
    );
    assert_contains(
        &load_err(&dir, "back.csv", bad.as_bytes()),
        "back.csv line 11: t = 0 s does not increase within demo 0",
    );
    // A demo of a single sample.
    let single = "demo,t,x,y,vx,vy\n0,0,1,2,3,4\n0,0.1,0,0,0,0\n1,0,1,2,3,4\n";
    assert_contains(
        &load_err(&dir, "single.csv", single.as_bytes()),
        "single.csv: demo 1 (from line 4): 1 sample(s), at least 2 are needed",
    );
    // Not a demo number.
    let bad = with_line(3, &lines[2].replacen('0', "x", 1));
    assert_contains(
        &load_err(&dir, "id.csv", bad.as_bytes()),
        "id.csv line 3: column demo is not a non-negative integer: `x`",
    );
    // Not UTF-8.
    assert_contains(
        &load_err(&dir, "bin.csv", &[0xff, 0xfe, 0x00, 0x41]),
        "bin.csv: not UTF-8 text",
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn csv_columns_may_be_reordered_and_extra() {
    let text = "x,y,demo,t,vx,vy,note\r\n1,2,0,0,0.5,0.5,a\r\n0,0,0,0.5,0,0,b\r\n";
    let set = LetterSet::from_csv_str("Tiny", "<string>", text).unwrap();
    assert_eq!(set.demos.len(), 1);
    assert_eq!(set.demos[0].pos, vec![[1.0, 2.0], [0.0, 0.0]]);
    assert_eq!(set.demos[0].t, vec![0.0, 0.5]);
    assert_eq!(set.samples(), 2);
}

#[test]
fn missing_file_and_unknown_extension_are_errors() {
    let missing = path("data/lasa/NoSuchLetter.csv");
    let e = LetterSet::load(&missing).unwrap_err();
    assert!(matches!(e, DataError::Io { .. }), "{e:?}");
    assert_contains(&e.to_string(), "NoSuchLetter.csv");
    let e = LetterSet::load(path("data/lasa/NoSuchLetter.mat"))
        .unwrap_err()
        .to_string();
    assert_contains(&e, "NoSuchLetter.mat");
    let e = LetterSet::load(path("data/lasa/README.md"))
        .unwrap_err()
        .to_string();
    assert_contains(
        &e,
        "README.md: unknown demonstration format (expected a .csv or .mat file)",
    );
}

#[test]
fn mutated_mat_structure_never_panics() {
    use rand::Rng;
    // The real file with its `demos` element stored uncompressed, so that mutations hit tags,
    // flags, dimensions and names directly.
    let bytes = std::fs::read(shipped("CShape", "mat")).unwrap();
    let at = demos_element(&bytes);
    let n = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap()) as usize;
    let raw = miniz_oxide::inflate::decompress_to_vec_zlib(&bytes[at + 8..at + 8 + n]).unwrap();
    let mut plain = bytes[..at].to_vec();
    plain.extend(&raw);
    let uncompressed = LetterSet::from_mat_bytes("CShape", "plain.mat", &plain).unwrap();
    assert!(uncompressed == LetterSet::from_mat(shipped("CShape", "mat")).unwrap());

    let mut rng = crate::common::rng(7);
    let (mut ok, mut err) = (0, 0);
    for i in 0..400 {
        let mut b = plain.clone();
        // Mostly the structural head (the 200 bytes of cell, first struct, field names and the
        // first field's tags before its doubles), else anywhere.
        let k = if i % 4 == 0 {
            rng.random_range(at..b.len())
        } else {
            rng.random_range(at..at + 200)
        };
        match i % 3 {
            0 => b[k] ^= 1 << rng.random_range(0..8),
            1 => b[k] = rng.random(),
            _ => {
                let k = k.min(b.len() - 4);
                b[k..k + 4].copy_from_slice(&rng.random::<u32>().to_le_bytes());
            }
        }
        match LetterSet::from_mat_bytes("C", "mutated.mat", &b) {
            Ok(_) => ok += 1,
            Err(e) => {
                assert!(e.to_string().starts_with("mutated.mat"), "{e}");
                err += 1;
            }
        }
    }
    eprintln!("mutations: {ok} still load, {err} rejected with an error");
    assert!(
        err > 100,
        "most structural mutations must be rejected ({err})"
    );
}
