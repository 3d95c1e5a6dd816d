//! STL files, binary and ASCII, read so that a bad file is named by the byte or line where
//! it goes wrong and what was expected there. Written here rather than with `stl_io`, whose
//! errors carry neither ("failed to fill whole buffer" for a cut-off binary file), and
//! which takes any file starting with `solid ` for ASCII, as many binary exports do start
//! (SolidWorks writes `solid` into the 80-byte header).
//!
//! A file is binary when its length is exactly what its triangle count (the `u32` at byte
//! 80) needs, 84 + 50 bytes a triangle; else ASCII when it starts with `solid`; else a
//! binary file of the wrong length, which is the error. Corners at the same position (the
//! same `f32` bits, −0 as +0) become one vertex, as they are in the file's geometry.

use nalgebra::Vector3;

/// The bytes of a binary STL before its triangles: an 80-byte header and a `u32` count.
const HEADER: usize = 84;
/// The bytes of one binary triangle: normal, three corners (12 `f32`), attribute (`u16`).
const TRIANGLE: usize = 50;

/// What is wrong and where: the 1-based line of an ASCII file, or `None` (a binary file's
/// byte offset is in the reason).
pub(crate) struct StlError {
    pub(crate) line: Option<usize>,
    pub(crate) reason: String,
}

type Welded = (Vec<Vector3<f64>>, Vec<[u32; 3]>);

/// The vertices and triangles of the STL file `bytes`.
pub(crate) fn parse(bytes: &[u8]) -> Result<Welded, StlError> {
    let count = bytes
        .get(80..HEADER)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    if let Some(n) = count
        && n.checked_mul(TRIANGLE).and_then(|b| b.checked_add(HEADER)) == Some(bytes.len())
        && n > 0
    {
        return Ok(binary(&bytes[HEADER..], n));
    }
    let text_start = bytes.iter().position(|b| !b.is_ascii_whitespace());
    if text_start.is_some_and(|i| bytes[i..].starts_with(b"solid")) {
        return ascii(bytes);
    }
    let at = |reason: String| StlError { line: None, reason };
    Err(match count {
        None => at(format!(
            "binary STL: {} bytes, shorter than the 84 of its header (80 bytes, then the \
             triangle count at byte 80), and not ASCII (no `solid` at the start)",
            bytes.len()
        )),
        Some(0) => at(format!(
            "binary STL: the count at byte 80 says 0 triangles ({} bytes in the file): \
             no surface",
            bytes.len()
        )),
        Some(n) => {
            let need = (n as u128) * TRIANGLE as u128 + HEADER as u128;
            let whole = bytes.len().saturating_sub(HEADER) / TRIANGLE;
            at(format!(
                "binary STL: the count at byte 80 says {n} triangles, which need 84 + 50 × \
                 {n} = {need} bytes, but the file has {} ({whole} whole triangles: cut off \
                 or not an STL file)",
                bytes.len()
            ))
        }
    })
}

/// The triangles of `corners` (three a triangle) with corners at the same position as one
/// vertex ([`crate::weld`]: numbered by first appearance, −0 as +0).
fn welded(corners: &[Vector3<f64>]) -> Welded {
    let ids = crate::weld(corners);
    let mut vertices = Vec::new();
    for (c, &id) in corners.iter().zip(&ids) {
        if id as usize == vertices.len() {
            vertices.push(*c);
        }
    }
    let triangles = ids.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    (vertices, triangles)
}

fn binary(body: &[u8], n: usize) -> Welded {
    let mut corners = Vec::with_capacity(3 * n);
    for t in body.chunks_exact(TRIANGLE) {
        let f = |i: usize| f64::from(f32::from_le_bytes([t[i], t[i + 1], t[i + 2], t[i + 3]]));
        // Bytes 0..12 are the normal, which the winding gives again.
        for k in 0..3 {
            let at = 12 + 12 * k;
            corners.push(Vector3::new(f(at), f(at + 4), f(at + 8)));
        }
    }
    welded(&corners)
}

/// `solid`, then per triangle `facet normal x y z`, `outer loop`, three `vertex x y z`,
/// `endloop`, `endfacet`; `endsolid`. Keywords and numbers are checked, and any other text
/// is an error naming its line; a missing `endsolid` at the end is tolerated (some
/// exporters leave it out).
fn ascii(bytes: &[u8]) -> Result<Welded, StlError> {
    let text = std::str::from_utf8(bytes).map_err(|e| StlError {
        line: Some(
            1 + bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count(),
        ),
        reason: "ASCII STL: not text (a byte that is not UTF-8)".into(),
    })?;
    // Lines end at `\n`, `\r\n` or a lone `\r` (classic Mac OS exports); non-empty ones,
    // numbered from 1, split into words.
    let text = text.replace("\r\n", "\n").replace('\r', "\n");
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split_whitespace().collect::<Vec<_>>()))
        .filter(|(_, w)| !w.is_empty());
    let mut corners = Vec::new();
    let bad = |line: usize, reason: String| StlError {
        line: Some(line),
        reason: format!("ASCII STL: {reason}"),
    };
    let last_line = text.lines().count().max(1);
    let mut next = |want: &str| -> Result<(usize, Vec<&str>), StlError> {
        lines.next().ok_or_else(|| {
            bad(
                last_line,
                format!("the file ends where `{want}` was expected"),
            )
        })
    };
    let (n, words) = next("solid")?;
    if words[0] != "solid" {
        return Err(bad(
            n,
            format!("expected `solid`, found `{}`", words.join(" ")),
        ));
    }
    while let Ok((n, words)) = next("facet normal") {
        match words[0] {
            "endsolid" => break,
            "facet" if words.get(1) == Some(&"normal") && words.len() == 5 => {}
            _ => {
                return Err(bad(
                    n,
                    format!(
                        "expected `facet normal x y z` or `endsolid`, found `{}`",
                        words.join(" ")
                    ),
                ));
            }
        }
        let expect = |(n, words): (usize, Vec<&str>), want: &[&str]| {
            if words == want {
                Ok(())
            } else {
                Err(bad(
                    n,
                    format!("expected `{}`, found `{}`", want.join(" "), words.join(" ")),
                ))
            }
        };
        expect(next("outer loop")?, &["outer", "loop"])?;
        for _ in 0..3 {
            let (n, words) = next("vertex x y z")?;
            let xyz = (words.len() == 4 && words[0] == "vertex")
                .then(|| {
                    let f = |s: &str| s.parse::<f32>().ok().filter(|x| x.is_finite());
                    Some([f(words[1])?, f(words[2])?, f(words[3])?])
                })
                .flatten()
                .ok_or_else(|| {
                    bad(
                        n,
                        format!(
                            "expected `vertex x y z` with three finite numbers, found `{}`",
                            words.join(" ")
                        ),
                    )
                })?;
            corners.push(xyz.map(f64::from).into());
        }
        expect(next("endloop")?, &["endloop"])?;
        expect(next("endfacet")?, &["endfacet"])?;
    }
    if corners.is_empty() {
        return Err(bad(last_line, "no `facet` in the file: no surface".into()));
    }
    Ok(welded(&corners))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary_file(header: &[u8], corners: &[[f32; 9]]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b[..header.len()].copy_from_slice(header);
        b.extend((corners.len() as u32).to_le_bytes());
        for c in corners {
            b.extend([0f32, 0.0, 1.0].iter().flat_map(|x| x.to_le_bytes()));
            b.extend(c.iter().flat_map(|x| x.to_le_bytes()));
            b.extend([0u8, 0]);
        }
        b
    }

    const TWO: [[f32; 9]; 2] = [
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0, 1.0, 1.0, 0.0, -0.0, 1.0, 0.0],
    ];

    #[test]
    fn binary_files_load_welded_even_with_solid_in_the_header() {
        for header in [&b"binary"[..], b"solid exported by a CAD tool"] {
            let (v, t) =
                parse(&binary_file(header, &TWO)).unwrap_or_else(|e| panic!("{}", e.reason));
            // Four positions: (0, 1, 0) and (−0, 1, 0) are one.
            assert_eq!(v.len(), 4);
            assert_eq!(t, vec![[0, 1, 2], [1, 3, 2]]);
        }
    }

    #[test]
    fn a_cut_off_or_empty_binary_file_says_how_long_it_is_and_should_be() {
        let whole = binary_file(b"x", &TWO);
        let e = parse(&whole[..120]).expect_err("cut off");
        assert!(
            e.reason.contains("says 2 triangles")
                && e.reason.contains("= 184 bytes")
                && e.reason.contains("has 120")
                && e.reason.contains("0 whole triangles"),
            "{}",
            e.reason
        );
        let e = parse(&whole[..40]).expect_err("shorter than the header");
        assert!(
            e.reason.contains("40 bytes") && e.reason.contains("84"),
            "{}",
            e.reason
        );
        let e = parse(&binary_file(b"x", &[])).expect_err("no triangles");
        assert!(e.reason.contains("0 triangles"), "{}", e.reason);
        let e = parse(b"").expect_err("empty");
        assert!(e.reason.contains("0 bytes"), "{}", e.reason);
    }

    #[test]
    fn ascii_errors_name_the_line_and_what_was_expected() {
        let good = "solid t\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      \
                    vertex 1 0 0\n      vertex 0 1 0\n    endloop\n  endfacet\nendsolid t\n";
        let (v, t) = parse(good.as_bytes()).unwrap_or_else(|e| panic!("{}", e.reason));
        assert_eq!((v.len(), t.len()), (3, 1));
        // No `endsolid`: tolerated.
        let (_, t) = parse(good.trim_end().trim_end_matches("endsolid t").as_bytes())
            .unwrap_or_else(|e| panic!("{}", e.reason));
        assert_eq!(t.len(), 1);
        for (broken, line, want) in [
            (
                good.replace("vertex 1 0 0", "vertex 1 nan 0"),
                5,
                "three finite numbers",
            ),
            (
                good.replace("vertex 1 0 0", "vertex 1 0"),
                5,
                "vertex x y z",
            ),
            (good.replace("outer loop", "outer"), 3, "`outer loop`"),
            (good.replace("endloop", "end"), 7, "`endloop`"),
            (
                good.replace("facet normal 0 0 1", "facet nonsense"),
                2,
                "`facet normal",
            ),
            (good.replace("solid t\n", "solid t\n\n\n"), 0, ""),
        ] {
            let r = parse(broken.as_bytes());
            if line == 0 {
                // Blank lines are fine.
                assert!(r.is_ok());
                continue;
            }
            let e = r.err().unwrap_or_else(|| panic!("accepted: {broken}"));
            assert_eq!(e.line, Some(line), "{}", e.reason);
            assert!(e.reason.contains(want), "{}", e.reason);
        }
        // Old Mac OS line ends, and Windows ones.
        for ends in ["\r", "\r\n"] {
            let (_, t) = parse(good.replace('\n', ends).as_bytes())
                .unwrap_or_else(|e| panic!("{}", e.reason));
            assert_eq!(t.len(), 1);
            let e = parse(
                good.replace("endloop", "end")
                    .replace('\n', ends)
                    .as_bytes(),
            )
            .expect_err("broken");
            assert_eq!(e.line, Some(7), "{}", e.reason);
        }
        let e = parse(b"solid t\n  facet normal 0 0 1\n    outer loop\n").expect_err("cut");
        assert!(
            e.reason.contains("ends where `vertex x y z`"),
            "{}",
            e.reason
        );
        let e = parse(b"solid empty\nendsolid empty\n").expect_err("empty");
        assert!(e.reason.contains("no surface"), "{}", e.reason);
    }
}
