//! The reader on hand-made files in both byte orders, compressed or not, cut anywhere or
//! malformed.

use super::element::{
    pad, MI_COMPRESSED, MI_DOUBLE, MI_INT16, MI_INT32, MI_INT8, MI_MATRIX, MI_UINT32, MI_UINT8,
    MI_UTF8,
};
use super::*;

/// Builds MAT v5 bytes by hand, in either byte order.
struct W {
    big: bool,
}

impl W {
    fn u32(&self, v: u32) -> [u8; 4] {
        if self.big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    }
    fn header(&self) -> Vec<u8> {
        let mut h = b"MATLAB 5.0 MAT-file, hand-made test".to_vec();
        h.resize(116, b' ');
        h.extend([0u8; 8]);
        h.extend(if self.big {
            0x0100u16.to_be_bytes()
        } else {
            0x0100u16.to_le_bytes()
        });
        h.extend(if self.big { b"MI" } else { b"IM" });
        h
    }
    fn el(&self, ty: u32, data: &[u8]) -> Vec<u8> {
        let mut v = Vec::new();
        v.extend(self.u32(ty));
        v.extend(self.u32(data.len() as u32));
        v.extend(data);
        v.resize(v.len() + pad(data.len()), 0);
        v
    }
    fn small(&self, ty: u32, data: &[u8]) -> Vec<u8> {
        assert!(data.len() <= 4);
        let mut v = Vec::new();
        v.extend(self.u32(((data.len() as u32) << 16) | ty));
        v.extend(data);
        v.resize(8, 0);
        v
    }
    fn matrix(&self, class: u32, dims: &[i32], name: &str, body: &[Vec<u8>]) -> Vec<u8> {
        let mut d = Vec::new();
        d.extend(self.el(MI_UINT32, &[self.u32(class), [0; 4]].concat()));
        let dd: Vec<u8> = dims.iter().flat_map(|&x| self.u32(x as u32)).collect();
        d.extend(self.el(MI_INT32, &dd));
        d.extend(self.el(MI_INT8, name.as_bytes()));
        for b in body {
            d.extend(b);
        }
        self.el(MI_MATRIX, &d)
    }
    fn doubles(&self, v: &[f64]) -> Vec<u8> {
        let b: Vec<u8> = v
            .iter()
            .flat_map(|x| {
                if self.big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect();
        self.el(MI_DOUBLE, &b)
    }
}

fn sample(w: &W) -> Vec<u8> {
    let mut f = w.header();
    // a = [1 2 3; 4 5 6] (column-major 1 4 2 5 3 6), stored as miDOUBLE.
    f.extend(w.matrix(
        6,
        &[2, 3],
        "a",
        &[w.doubles(&[1.0, 4.0, 2.0, 5.0, 3.0, 6.0])],
    ));
    // c = {int16 -7 stored as miINT16 small element, 'hi'}.
    let i16b: Vec<u8> = if w.big {
        (-7i16).to_be_bytes().to_vec()
    } else {
        (-7i16).to_le_bytes().to_vec()
    };
    let scalar = w.matrix(10, &[1, 1], "", &[w.small(MI_INT16, &i16b)]);
    let text = w.matrix(4, &[1, 2], "", &[w.el(MI_UTF8, b"hi")]);
    f.extend(w.matrix(1, &[1, 2], "c", &[scalar, text]));
    // s = struct('pos', uint8 [1;2]) with fixed-width names.
    let pos = w.matrix(6, &[2, 1], "", &[w.el(MI_UINT8, &[1, 2])]);
    let mut names = b"pos\0dt\0\0".to_vec();
    names.truncate(8);
    let dt = w.matrix(6, &[1, 1], "", &[w.doubles(&[0.5])]);
    f.extend(w.matrix(
        2,
        &[1, 1],
        "s",
        &[w.small(MI_INT32, &w.u32(4)), w.el(MI_INT8, &names), pos, dt],
    ));
    f
}

fn check(m: &MatFile) {
    assert_eq!(m.names(), vec!["a", "c", "s"]);
    let a = m.get("a").unwrap();
    assert_eq!(a.dims(), &[2, 3]);
    assert_eq!(a.as_real().unwrap(), &[1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
    let c = m.get("c").unwrap().cell_items().unwrap();
    assert_eq!(c.len(), 2);
    assert_eq!(c[0].scalar(), Some(-7.0));
    assert!(matches!(
        c[0],
        MatValue::Numeric {
            class: NumericClass::Int16,
            ..
        }
    ));
    assert_eq!(c[1].as_str(), Some("hi"));
    let s = m.get("s").unwrap();
    assert_eq!(
        s.field_names().unwrap(),
        &["pos".to_string(), "dt".to_string()]
    );
    assert_eq!(s.field("pos").unwrap().as_real().unwrap(), &[1.0, 2.0]);
    assert_eq!(s.field("dt").unwrap().scalar(), Some(0.5));
    assert!(s.field("vel").is_none());
}

#[test]
fn hand_made_uncompressed_little_and_big_endian() {
    for big in [false, true] {
        let w = W { big };
        let m = MatFile::parse(&sample(&w), "<test>").unwrap();
        assert_eq!(m.big_endian, big);
        assert!(m.description.starts_with("MATLAB 5.0"));
        check(&m);
    }
}

#[test]
fn hand_made_compressed_unpadded_and_padded() {
    for big in [false, true] {
        let w = W { big };
        let plain = sample(&w);
        let body = &plain[128..];
        // Compress each variable separately, as MATLAB does, with and without padding.
        let mut spans = Vec::new();
        let mut p = 0;
        while p < body.len() {
            let b: [u8; 4] = body[p + 4..p + 8].try_into().unwrap();
            let n = if big {
                u32::from_be_bytes(b)
            } else {
                u32::from_le_bytes(b)
            } as usize;
            spans.push(&body[p..p + 8 + n]);
            p += 8 + n;
        }
        let mut unaligned = 0;
        for padded in [false, true] {
            let mut f = w.header();
            for s in &spans {
                let z = miniz_oxide::deflate::compress_to_vec_zlib(s, 6);
                unaligned += usize::from(z.len() % 8 != 0);
                f.extend(w.u32(MI_COMPRESSED));
                f.extend(w.u32(z.len() as u32));
                f.extend(&z);
                if padded {
                    f.resize(f.len() + pad(z.len()), 0);
                }
            }
            let m = MatFile::parse(&f, "<test>").unwrap();
            assert_eq!(m.big_endian, big);
            check(&m);
        }
        assert!(
            unaligned > 0,
            "the test needs compressed lengths that are not multiples of 8"
        );
    }
}

#[test]
fn every_truncation_is_an_error() {
    let f = sample(&W { big: false });
    let ends: Vec<usize> = {
        // Cuts exactly between variables are valid files with fewer variables.
        let mut v = vec![128];
        let mut p = 128;
        while p < f.len() {
            p += 8 + u32::from_le_bytes(f[p + 4..p + 8].try_into().unwrap()) as usize;
            v.push(p);
        }
        v
    };
    for cut in 0..f.len() {
        let r = MatFile::parse(&f[..cut], "<cut>");
        if ends.contains(&cut) {
            assert!(r.is_ok(), "cut {cut}: {r:?}");
        } else {
            let e = r.expect_err(&format!("cut at {cut} must fail"));
            assert!(e.to_string().starts_with("<cut>"), "{e}");
        }
    }
}

#[test]
fn bad_dims_class_and_counts_are_errors() {
    let w = W { big: false };
    let mut f = w.header();
    f.extend(w.matrix(6, &[2, 2], "a", &[w.doubles(&[1.0, 2.0, 3.0])]));
    let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
    assert!(
        e.contains("real part has 3 values, dimensions 2×2 need 4"),
        "{e}"
    );

    let mut f = w.header();
    f.extend(w.matrix(6, &[2, -1], "a", &[w.doubles(&[])]));
    let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
    assert!(e.contains("negative dimension"), "{e}");

    let mut f = w.header();
    f.extend(w.matrix(99, &[1, 1], "a", &[w.doubles(&[1.0])]));
    let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
    assert!(e.contains("unknown array class 99"), "{e}");

    // A cell claiming 2^31-1 × 2^31-1 elements but holding none: an error, no huge allocation.
    let mut f = w.header();
    f.extend(w.matrix(1, &[i32::MAX, i32::MAX], "c", &[]));
    let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
    assert!(e.contains("missing cell element"), "{e}");

    // A small element claiming more than 4 bytes.
    let mut f = w.header();
    f.extend(w.u32((7 << 16) | MI_INT8));
    f.extend([0u8; 4]);
    let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
    assert!(e.contains("claims 7 bytes"), "{e}");

    // Deep nesting is bounded.
    let mut v = w.matrix(6, &[1, 1], "", &[w.doubles(&[1.0])]);
    for _ in 0..(MAX_DEPTH + 2) {
        v = w.matrix(1, &[1, 1], "", &[v]);
    }
    let mut f = w.header();
    f.extend(v);
    let e = MatFile::parse(&f, "x.mat").unwrap_err().to_string();
    assert!(e.contains("nested deeper"), "{e}");
}

#[test]
fn headers_are_checked() {
    let w = W { big: false };
    let good = sample(&w);
    let e = MatFile::parse(&good[..100], "h.mat")
        .unwrap_err()
        .to_string();
    assert!(e.contains("128"), "{e}");
    let mut bad = good.clone();
    bad[126..128].copy_from_slice(b"XX");
    let e = MatFile::parse(&bad, "h.mat").unwrap_err().to_string();
    assert!(e.contains("endian indicator"), "{e}");
    let mut v73 = good.clone();
    v73[124..126].copy_from_slice(&0x0200u16.to_le_bytes());
    let e = MatFile::parse(&v73, "h.mat").unwrap_err().to_string();
    assert!(e.contains("v7.3"), "{e}");
}
