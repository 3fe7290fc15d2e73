//! The fast OBJ reader (`obj::parse_bytes`) against the straightforward one on the
//! lossily decoded text (`obj::parse_reference`): on generated files of every
//! statement form, number spelling, whitespace kind, comments, bad indices and
//! non-UTF-8 bytes, both give bit-identical data and warnings, or the same error.

mod common;

use common::Rng;
use rdr::geometry::obj::{parse_bytes, parse_reference, ObjData};

fn pick<'a>(rng: &mut Rng, xs: &[&'a str]) -> &'a str {
    xs[rng.below(xs.len())]
}

/// A number in one of the spellings OBJ files (and broken ones) use.
fn number(rng: &mut Rng, valid: bool, out: &mut Vec<u8>) {
    let s = match rng.below(16) {
        // halfway between two f32s, to 17 digits (which read back as exactly that f64):
        // a one-ulp error of the f64 read moves the f32 rounding off the tie
        14 | 15 => {
            let a = rng.rangef(-1e4, 1e4);
            let b = f32::from_bits(a.to_bits() + 1);
            format!("{:.16e}", (a as f64 + b as f64) / 2.0)
        }
        0 => format!("{}", rng.below(2000) as i64 - 1000),
        1..=4 => format!("{:.6}", rng.range(-2.0, 2.0)),
        5 => format!("{}", rng.range(-1e3, 1e3)),
        6 => format!("{:e}", rng.log_range(1e-30, 1e30) * if rng.below(2) == 0 { 1.0 } else { -1.0 }),
        7 => format!("{:.*}", 1 + rng.below(24), rng.range(-1.0, 1.0)),
        8 => format!(
            "+{}.{}E{}{}",
            rng.below(100),
            rng.below(1000),
            pick(rng, &["", "+", "-"]),
            rng.below(if valid { 30 } else { 60 })
        ),
        9 if valid => pick(rng, &["-0", "0.", ".5", "5.e3", "1e-400", "00.000", "-.0e0"]).to_string(),
        9 => pick(
            rng,
            &[
                "1e39", "-1e39", "inf", "NaN", "1e400", "1e-400", "-0", "0.", ".5", "5.e3", "1e", "e3", ".", "-", "+", "1.2.3", "1,5",
                "0x10", "1_0",
            ],
        )
        .to_string(),
        10 => format!("{}{}", "0".repeat(rng.below(25)), rng.below(1_000_000)),
        11 => format!("{}", rng.next_u64()),
        12 => format!("{}.{:019}", rng.below(10), rng.next_u64() % 10_000_000_000_000_000_000),
        _ => format!("{}e-{}", rng.below(1 << 20), rng.below(30)),
    };
    out.extend_from_slice(s.as_bytes());
}

fn space(rng: &mut Rng, out: &mut Vec<u8>) {
    let s: &[u8] = match rng.below(40) {
        0 => b"\t",
        1 => b"  ",
        2 => b"\x0b",
        3 => b"\x0c",
        4 => "\u{a0}".as_bytes(),
        5 => "\u{3000}".as_bytes(),
        6 => b"\r",
        _ => b" ",
    };
    out.extend_from_slice(s);
}

fn index(rng: &mut Rng, have: usize, out: &mut Vec<u8>) {
    let s = match rng.below(30) {
        0 => "0".to_string(),
        1 => format!("{}", have + 1 + rng.below(3)),
        2 => format!("-{}", have + 1),
        3 => pick(rng, &["", "x", "+3", "-", "1.5", "99999999999999999999", "0001"]).to_string(),
        4..=8 if have > 0 => format!("-{}", 1 + rng.below(have)),
        _ if have > 0 => format!("{}", 1 + rng.below(have)),
        _ => "1".to_string(),
    };
    out.extend_from_slice(s.as_bytes());
}

/// An OBJ file; `errors` makes bad statements likely.
fn obj_file(rng: &mut Rng, lines: usize, errors: bool) -> Vec<u8> {
    let mut out = Vec::new();
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    let bad = |rng: &mut Rng| errors && rng.below(60) == 0;
    for _ in 0..lines {
        if rng.below(8) == 0 {
            space(rng, &mut out);
        }
        match rng.below(20) {
            0..=6 => {
                let (kw, n) = *[("v", 3), ("vn", 3), ("vt", 2)]
                    .get(rng.below(3).min(if v < 4 { 0 } else { 2 }))
                    .unwrap();
                out.extend_from_slice(kw.as_bytes());
                let count = if bad(rng) {
                    rng.below(n)
                } else {
                    n + usize::from(rng.below(10) == 0)
                };
                for _ in 0..count {
                    space(rng, &mut out);
                    if bad(rng) {
                        out.extend_from_slice(pick(rng, &["abc", "1e39", "nan", "--1"]).as_bytes());
                    } else {
                        number(rng, !errors, &mut out);
                    }
                }
                match kw {
                    "v" => v += 1,
                    "vn" => vn += 1,
                    _ => vt += 1,
                }
            }
            7..=14 if v >= 3 => {
                out.push(b'f');
                let corners = match rng.below(12) {
                    0 => rng.below(3),
                    1..=6 => 3,
                    7..=9 => 4,
                    _ => 5 + rng.below(6),
                };
                let form = rng.below(4);
                for _ in 0..corners {
                    space(rng, &mut out);
                    let idx = |rng: &mut Rng, have: usize, out: &mut Vec<u8>| {
                        if bad(rng) {
                            index(rng, have, out)
                        } else if rng.below(3) == 0 {
                            out.extend_from_slice(format!("-{}", 1 + rng.below(have.max(1))).as_bytes())
                        } else {
                            out.extend_from_slice(format!("{}", 1 + rng.below(have.max(1))).as_bytes())
                        }
                    };
                    idx(rng, v, &mut out);
                    if form == 1 && vt > 0 {
                        out.push(b'/');
                        idx(rng, vt, &mut out);
                    } else if form == 2 && vn > 0 {
                        out.extend_from_slice(b"//");
                        idx(rng, vn, &mut out);
                    } else if form == 3 && vt > 0 && vn > 0 {
                        out.push(b'/');
                        idx(rng, vt, &mut out);
                        out.push(b'/');
                        idx(rng, vn, &mut out);
                    }
                }
            }
            15 => out.extend_from_slice(pick(rng, &["# comment", "o thing", "g a b", "usemtl red", "s off", "mtllib x.mtl"]).as_bytes()),
            16 => {
                out.extend_from_slice(pick(rng, &["curv 1 2", "weird", "cstype bspline", "vx 1 2 3", "ü 1", "v\u{2003}1 2 3"]).as_bytes())
            }
            17 if errors => out.extend_from_slice(pick(rng, &["\u{fffd}", "v 1 2 3 \u{00e9}", "f 1 2 3\u{a0}"]).as_bytes()),
            18 if errors => {
                // invalid UTF-8 inside a statement
                out.extend_from_slice(b"v 1 \xff2 3");
            }
            _ => {}
        }
        if rng.below(10) == 0 {
            out.extend_from_slice(b" # trailing");
            if rng.below(3) == 0 {
                number(rng, !errors, &mut out);
            }
        }
        out.extend_from_slice(if rng.below(6) == 0 { b"\r\n" } else { b"\n" });
    }
    out
}

fn same(a: &ObjData, b: &ObjData) -> bool {
    let bits3 = |v: &[rdr::math::Vec3]| v.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    let bits2 = |v: &[rdr::math::Vec2]| v.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    bits3(&a.positions) == bits3(&b.positions)
        && bits3(&a.normals) == bits3(&b.normals)
        && bits2(&a.uvs) == bits2(&b.uvs)
        && a.triangles == b.triangles
        && a.warnings == b.warnings
}

fn check(bytes: &[u8]) -> bool {
    let fast = parse_bytes(bytes);
    let slow = parse_reference(&String::from_utf8_lossy(bytes));
    match (&fast, &slow) {
        (Ok(f), Ok(s)) => {
            assert!(same(f, s), "data differ for\n{}", String::from_utf8_lossy(bytes));
            true
        }
        (Err(f), Err(s)) => {
            assert_eq!(
                (f.line, &f.message),
                (s.line, &s.message),
                "errors differ for\n{}",
                String::from_utf8_lossy(bytes)
            );
            false
        }
        _ => panic!(
            "one reader fails: fast {:?}, reference {:?} for\n{}",
            fast.as_ref().err(),
            slow.as_ref().err(),
            String::from_utf8_lossy(bytes)
        ),
    }
}

#[test]
fn fast_reader_matches_the_reference_on_valid_files() {
    let mut rng = Rng::new(7);
    let mut triangles = 0;
    for case in 0..300 {
        let lines = 5 + rng.below(200);
        let bytes = obj_file(&mut rng, lines, false);
        assert!(check(&bytes), "case {case} should parse");
        triangles += parse_bytes(&bytes).unwrap().triangles.len();
    }
    assert!(triangles > 5000, "{triangles} triangles: the generator must make faces");
}

#[test]
fn fast_reader_matches_the_reference_on_broken_files() {
    let mut rng = Rng::new(8);
    let (mut ok, mut failed) = (0, 0);
    for _ in 0..3000 {
        let lines = 1 + rng.below(40);
        let bytes = obj_file(&mut rng, lines, true);
        if check(&bytes) {
            ok += 1;
        } else {
            failed += 1;
        }
    }
    assert!(ok > 200 && failed > 200, "{ok} parsed, {failed} failed: the test needs both");
}

#[test]
fn every_number_spelling_reads_as_std_reads_it() {
    // one vertex per spelling: the fast float path against `str::parse::<f64>`
    let mut rng = Rng::new(9);
    for _ in 0..20_000 {
        let mut line = b"v ".to_vec();
        for _ in 0..3 {
            number(&mut rng, false, &mut line);
            line.push(b' ');
        }
        check(&line);
    }
}
