//! Damaged, truncated and hand-made operator files: every one gets an error, never a panic.

mod common;

use common::{
    DISPLAY_KINDS, entry_at, entry_of, rebuild, reseal, samples, set_entry_u64, table_end,
    with_word,
};
use lrr_formats::{
    Container, ContainerWriter, Display, ErrorKind, FormatError, Layout, OperatorFile, Precision,
    f32_to_f16, kind,
};

fn err(bytes: &[u8]) -> FormatError {
    OperatorFile::from_bytes(bytes).expect_err("damaged file was accepted")
}

#[test]
fn round_trip_is_byte_exact() {
    for file in samples() {
        let bytes = file.to_bytes().unwrap();
        let back = OperatorFile::from_bytes(&bytes).unwrap();
        assert_eq!(back, file);
        assert_eq!(back.to_bytes().unwrap(), bytes);
        // Payloads are aligned, so they can be used in place; LIGHTS and the display sections
        // are optional.
        let c = Container::parse(&bytes).unwrap();
        assert!(c.sections().iter().all(|s| s.offset % 64 == 0));
        // FACES is for display too, but required: without it SMOOTH, LIGHTMAP and the BVH would
        // be misread.
        let optional = |k| {
            k == kind::LIGHTS
                || k == kind::LIGHTMAP
                || k == kind::DIRECT_LIGHTS
                || k == kind::SKY_TRANSFER
                || k == kind::ATLAS
                || DISPLAY_KINDS.contains(&k)
        };
        assert!(
            c.sections()
                .iter()
                .all(|s| s.required() != optional(s.kind))
        );
        let display = file.display != Display::default();
        let expected: Vec<u32> = kind::KNOWN
            .into_iter()
            .filter(|&k| match file.layout() {
                Layout::Factored => k != kind::YK,
                Layout::PlainYk => k != kind::FK && k != kind::CORES,
            })
            .filter(|&k| k != kind::LIGHTS || !file.lights.is_empty())
            .filter(|&k| !DISPLAY_KINDS.contains(&k) || display)
            .filter(|&k| k != kind::LIGHTMAP || file.display.lightmap.is_some())
            .filter(|&k| k != kind::FACES || file.display.faces.is_some())
            .filter(|&k| k != kind::DIRECT_LIGHTS || !file.display.direct_lights.is_empty())
            .filter(|&k| k != kind::SKY_TRANSFER || file.display.sky_transfer.is_some())
            .filter(|&k| {
                k != kind::ATLAS
                    || file
                        .display
                        .lightmap
                        .as_ref()
                        .is_some_and(|l| l.atlas.is_some())
            })
            .collect();
        assert_eq!(c.kinds().collect::<Vec<_>>(), expected);
        // A file is stamped with the lowest minor version that describes it.
        let minor = match (display, file.display.faces.is_some()) {
            (_, true) => 4,
            (true, false) => 2,
            (false, false) => 1,
        };
        assert_eq!(c.version(), (1, minor));
    }
}

#[test]
fn every_prefix_is_truncated() {
    for file in samples() {
        let bytes = file.to_bytes().unwrap();
        for len in 0..bytes.len() {
            let e = err(&bytes[..len]);
            assert_eq!(e.kind, ErrorKind::Truncated, "prefix {len}: {e}");
        }
    }
}

/// Byte ranges a flip must never get through: header, table, every payload.
fn protected(bytes: &[u8]) -> Vec<(usize, usize)> {
    let c = Container::parse(bytes).unwrap();
    let mut ranges = vec![(0, table_end(bytes))];
    for s in c.sections() {
        ranges.push((s.offset as usize, (s.offset + s.length) as usize));
    }
    ranges
}

#[test]
fn every_flipped_byte_is_detected_or_harmless() {
    for file in samples() {
        let bytes = file.to_bytes().unwrap();
        let protected = protected(&bytes);
        let mut harmless = 0;
        for at in 0..bytes.len() {
            for mask in [0xFF, 0x01] {
                let mut bad = bytes.clone();
                bad[at] ^= mask;
                match OperatorFile::from_bytes(&bad) {
                    Err(_) => {}
                    Ok(decoded) => {
                        let in_use = protected.iter().any(|&(a, b)| (a..b).contains(&at));
                        assert!(!in_use, "flip {mask:#04x} at byte {at} went unnoticed");
                        assert_eq!(decoded, file, "flip at {at} in padding changed the data");
                        harmless += 1;
                    }
                }
            }
        }
        // Only the zero padding between payloads may be flipped harmlessly.
        let used: usize = protected.iter().map(|(a, b)| b - a).sum();
        assert_eq!(harmless, 2 * (bytes.len() - used));
    }
}

#[test]
fn checksum_mismatch_names_the_section() {
    let bytes = samples()[0].to_bytes().unwrap();
    let c = Container::parse(&bytes).unwrap();
    let fk = c.sections()[entry_of(&bytes, kind::FK)];
    let mut bad = bytes.clone();
    bad[fk.offset as usize + 5] ^= 0x10;
    let e = err(&bad);
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(
        e.message.contains("section FK (kind 6): checksum mismatch"),
        "{e}"
    );
    let mut bad = bytes.clone();
    bad[entry_at(3, 16)] ^= 1; // a table field, covered by the header checksum
    assert!(err(&bad).message.contains("header checksum mismatch"));
}

#[test]
fn wrong_magic() {
    let mut bytes = samples()[0].to_bytes().unwrap();
    bytes[1] = b'X';
    let e = err(&bytes);
    assert_eq!(e.kind, ErrorKind::NotLrr);
    assert!(e.message.contains("not an lrr operator file"), "{e}");
    let e = err(b"{\"json\": true}");
    assert_eq!(e.kind, ErrorKind::NotLrr);
}

#[test]
fn other_major_version_is_refused_with_both_versions() {
    let bytes = samples()[0].to_bytes().unwrap();
    let mut v2 = bytes.clone();
    v2[8..10].copy_from_slice(&2u16.to_le_bytes());
    reseal(&mut v2);
    let e = err(&v2);
    assert_eq!(e.kind, ErrorKind::UnsupportedVersion);
    assert!(e.message.contains("version 2.1"), "{e}");
    assert!(e.message.contains("supports version 1.x"), "{e}");
    assert!(
        e.message
            .contains("re-bake with this version of lrr or upgrade the runtime")
    );
    let mut v0 = bytes;
    v0[8..10].copy_from_slice(&0u16.to_le_bytes());
    assert_eq!(err(&v0).kind, ErrorKind::UnsupportedVersion);
}

#[test]
fn newer_minor_version_is_read() {
    for file in samples() {
        let mut bytes = file.to_bytes().unwrap();
        bytes[10..12].copy_from_slice(&7u16.to_le_bytes());
        reseal(&mut bytes);
        assert_eq!(Container::parse(&bytes).unwrap().version(), (1, 7));
        assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), file);
    }
}

/// The sample's sections plus one of `extra_kind`, written by a writer of version 1.4.
fn with_extra_section(file: &OperatorFile, extra_kind: u32, required: bool) -> Vec<u8> {
    let bytes = file.to_bytes().unwrap();
    let c = Container::parse(&bytes).unwrap();
    let mut w = ContainerWriter::new();
    w.set_version(1, 4);
    w.add(
        extra_kind,
        required,
        b"light groups from the future".to_vec(),
    );
    for k in c.kinds() {
        w.add(k, true, c.section(k).unwrap().to_vec());
    }
    w.to_bytes()
}

#[test]
fn unknown_optional_section_is_ignored() {
    for file in samples() {
        let bytes = with_extra_section(&file, 0x4000, false);
        assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), file);
    }
}

#[test]
fn unknown_required_section_is_refused() {
    let bytes = with_extra_section(&samples()[0], 0x4000, true);
    let e = err(&bytes);
    assert_eq!(e.kind, ErrorKind::UnsupportedVersion);
    assert!(e.message.contains("kind 16384"), "{e}");
    assert!(e.message.contains("upgrade the runtime"), "{e}");
}

#[test]
fn section_past_the_end() {
    let bytes = samples()[0].to_bytes().unwrap();
    let mut bad = bytes.clone();
    set_entry_u64(
        &mut bad,
        2,
        8,
        (bytes.len() as u64 + 1).next_multiple_of(64),
    );
    assert_eq!(err(&bad).kind, ErrorKind::Truncated);
    let mut bad = bytes.clone();
    set_entry_u64(&mut bad, 9, 16, 1 << 40);
    assert_eq!(err(&bad).kind, ErrorKind::Truncated);
    let mut bad = bytes;
    set_entry_u64(&mut bad, 9, 8, u64::MAX - 63);
    assert_eq!(err(&bad).kind, ErrorKind::Corrupt); // offset + length overflows
}

#[test]
fn overlapping_sections() {
    let bytes = samples()[0].to_bytes().unwrap();
    let mut bad = bytes.clone();
    let first = u64::from_le_bytes(bytes[entry_at(0, 8)..entry_at(0, 16)].try_into().unwrap());
    set_entry_u64(&mut bad, 4, 8, first);
    let e = err(&bad);
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("overlap"), "{e}");
}

#[test]
fn misaligned_offset() {
    let bytes = samples()[0].to_bytes().unwrap();
    let mut bad = bytes.clone();
    let offset = u64::from_le_bytes(bytes[entry_at(9, 8)..entry_at(9, 16)].try_into().unwrap());
    set_entry_u64(&mut bad, 9, 8, offset + 4);
    let e = err(&bad);
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("not a multiple of 64"), "{e}");
}

#[test]
fn duplicate_kind() {
    let mut bytes = samples()[0].to_bytes().unwrap();
    let at = entry_at(3, 0);
    bytes[at..at + 4].copy_from_slice(&kind::ORDER.to_le_bytes());
    reseal(&mut bytes);
    let e = err(&bytes);
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(
        e.message.contains("ORDER (kind 3) appears more than once"),
        "{e}"
    );
}

#[test]
fn missing_section() {
    let bytes = samples()[0].to_bytes().unwrap();
    let c = Container::parse(&bytes).unwrap();
    let mut w = ContainerWriter::new();
    for k in c.kinds().filter(|&k| k != kind::WEIGHTS) {
        w.add(k, true, c.section(k).unwrap().to_vec());
    }
    let e = err(&w.to_bytes());
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("WEIGHTS (kind 5) is missing"), "{e}");
}

#[test]
fn giant_dimensions_are_refused_without_allocating() {
    let bytes = samples()[0].to_bytes().unwrap();
    // n = k = u32::MAX: n * k fits in a u64, the byte sizes do not.
    for channels in [1u32, 3] {
        let bad = rebuild(&bytes, |k, p| {
            if k == kind::DIMS {
                p[..12].copy_from_slice(&[[0xFF; 4], [0xFF; 4], channels.to_le_bytes()].concat());
            }
        });
        let e = err(&bad);
        assert_eq!(e.kind, ErrorKind::Limits, "{e}");
    }
    // Large but addressable: a plain length mismatch.
    let bad = with_word(&bytes, kind::DIMS, 0, 1 << 30);
    let e = err(&bad);
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.starts_with("section "), "{e}");
    assert!(e.message.contains("expected"), "{e}");
}

#[test]
fn dims_codes() {
    let bytes = samples()[0].to_bytes().unwrap();
    let e = err(&with_word(&bytes, kind::DIMS, 3, 7));
    assert_eq!(e.kind, ErrorKind::UnsupportedVersion);
    assert!(e.message.contains("precision code 7"), "{e}");
    let e = err(&with_word(&bytes, kind::DIMS, 4, 2));
    assert_eq!(e.kind, ErrorKind::UnsupportedVersion);
    assert!(e.message.contains("layout code 2"), "{e}");
    // A factored file declared plain: it holds sections of the other layout.
    let e = err(&with_word(&bytes, kind::DIMS, 4, 1));
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(
        e.message
            .contains("section FK (kind 6) is present, but DIMS says the layout is PlainYk"),
        "{e}"
    );
    let e = err(&with_word(&bytes, kind::DIMS, 2, 2));
    assert_eq!(e.kind, ErrorKind::Invalid);
    assert!(e.message.contains("channels = 2"), "{e}");
    // f32 data declared f16: the FK length no longer matches.
    let e = err(&with_word(&bytes, kind::DIMS, 3, 1));
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("FK (kind 6): expected 24 bytes"), "{e}");
    // Reserved words are ignored.
    let ok = with_word(&bytes, kind::DIMS, 7, 99);
    assert_eq!(OperatorFile::from_bytes(&ok).unwrap(), samples()[0]);
}

/// Rebuilt files whose checksums match but whose values break an invariant.
#[test]
fn invalid_values_with_valid_checksums() {
    let [rgb, grey, ..] = samples();
    let rgb = rgb.to_bytes().unwrap();
    let grey = grey.to_bytes().unwrap();
    let nan = f32::NAN.to_bits();
    let cases = [
        (
            with_word(&rgb, kind::INDEX, 1, 7),
            "section INDEX: index[1] = 7 and index[2] = 6",
        ),
        (
            with_word(&rgb, kind::INDEX, 1, 0),
            "section INDEX: index[0] = 0 and index[1] = 0",
        ),
        (
            with_word(&rgb, kind::ORDER, 2, 3),
            "section ORDER: position 2 repeats element id 3",
        ),
        (
            with_word(&rgb, kind::ORDER, 5, 6),
            "section ORDER: position 5 holds element id 6",
        ),
        (
            with_word(&rgb, kind::FK, 7, nan),
            "section FK: element 3, patch 1: value NaN",
        ),
        (
            with_word(&rgb, kind::WEIGHTS, 4, 0),
            "section WEIGHTS: element 4: weight 0",
        ),
        (
            with_word(&rgb, kind::EMISSION, 0, (-1.0f32).to_bits()),
            "section EMISSION: element 0, channel r",
        ),
        (
            with_word(&rgb, kind::REFLECTANCE, 1, 2.0f32.to_bits()),
            "section REFLECTANCE: element 0, channel g",
        ),
        (
            with_word(&rgb, kind::GEOMETRY, 0, 0x0404_0405),
            "section GEOMETRY: element 0: 5 vertices",
        ),
    ];
    for (bytes, expected) in cases {
        let e = err(&bytes);
        assert_eq!(e.kind, ErrorKind::Invalid, "{e}");
        assert!(
            e.message.starts_with(expected),
            "got {:?}, expected {expected:?}",
            e.message
        );
    }
    // A NaN and a negative value in the f16 form factors.
    for h in [0x7E00u16, f32_to_f16(-0.5), 0x7C00] {
        let bad = rebuild(&grey, |k, p| {
            if k == kind::FK {
                p[6..8].copy_from_slice(&h.to_le_bytes());
            }
        });
        let e = err(&bad);
        assert_eq!(e.kind, ErrorKind::Invalid);
        assert!(
            e.message
                .starts_with("section FK: element 1, patch 1: value"),
            "{e}"
        );
    }
    let bad = rebuild(&rgb, |k, p| {
        if k == kind::METADATA {
            p[0] = 0xC3;
        }
    });
    assert!(err(&bad).message.contains("METADATA: not valid UTF-8"));
    let grey_ok = OperatorFile::from_bytes(&grey).unwrap();
    assert_eq!(grey_ok.precision, Precision::F16);
}

/// Display faces (FACES, format 1.4): damaged with valid checksums, missing, or met by a reader
/// that does not know them.
#[test]
fn damaged_or_unknown_faces_are_refused() {
    let faced = samples()[5].clone();
    assert!(faced.display.faces.is_some());
    let bytes = faced.to_bytes().unwrap();
    // FACES: F (word 0), reserved (1), 9 elements (words 2-10), 9 vertex counts padded to 12
    // bytes (words 11-13), then the vertices (word 14 on).
    let cases: [(u32, usize, u32, ErrorKind, &str); 6] = [
        (
            kind::FACES,
            0,
            10,
            ErrorKind::Corrupt,
            "section FACES (kind 19): expected",
        ),
        (
            kind::FACES,
            0,
            u32::MAX,
            ErrorKind::Corrupt,
            "section FACES (kind 19): expected",
        ),
        (
            kind::FACES,
            2,
            6,
            ErrorKind::Invalid,
            "section FACES: face 0: element 6 is not below n = 6",
        ),
        (
            kind::FACES,
            4,
            0,
            ErrorKind::Invalid,
            "section FACES: element 1 (file position) has no face",
        ),
        (
            kind::FACES,
            11,
            0x0303_0305,
            ErrorKind::Invalid,
            "section FACES: face 0: 5 vertices",
        ),
        (
            kind::FACES,
            14,
            f32::NAN.to_bits(),
            ErrorKind::Invalid,
            "section FACES: face 0: vertex 0: coordinate NaN",
        ),
    ];
    for (k, word, value, kind_, expected) in cases {
        let e = err(&with_word(&bytes, k, word, value));
        assert_eq!(e.kind, kind_, "{e}");
        assert!(
            e.message.starts_with(expected),
            "{e} (expected {expected:?})"
        );
    }
    // The reserved word is skipped.
    let reserved = with_word(&bytes, kind::FACES, 1, 7);
    assert_eq!(OperatorFile::from_bytes(&reserved).unwrap(), faced);
    // Without FACES the other display sections no longer fit the elements.
    let c = Container::parse(&bytes).unwrap();
    let mut w = ContainerWriter::new();
    for s in c.sections().iter().filter(|s| s.kind != kind::FACES) {
        w.add(s.kind, s.required(), c.section(s.kind).unwrap().to_vec());
    }
    let e = err(&w.to_bytes());
    assert_eq!(e.kind, ErrorKind::Corrupt, "{e}");
    assert!(
        e.message.starts_with("section SMOOTH (kind 13): expected"),
        "{e}"
    );
    // A reader that does not know FACES (1.3 and older: here, the same payload under a kind
    // unknown to this reader) refuses the file, because the section is marked required...
    let renamed = |required: bool| {
        let mut w = ContainerWriter::new();
        w.set_version(1, 4);
        for s in c.sections() {
            let (k, r) = match s.kind {
                kind::FACES => (0x4000 + kind::FACES, required),
                k => (k, s.required()),
            };
            w.add(k, r, c.section(s.kind).unwrap().to_vec());
        }
        w.to_bytes()
    };
    assert!(
        c.sections()
            .iter()
            .find(|s| s.kind == kind::FACES)
            .unwrap()
            .required()
    );
    let e = err(&renamed(true));
    assert_eq!(e.kind, ErrorKind::UnsupportedVersion, "{e}");
    assert!(e.message.contains("marked required but is unknown"), "{e}");
    assert!(e.message.contains("format version 1.4"), "{e}");
    // ...where, had it been optional, it would have misread SMOOTH (here caught by its size).
    let e = err(&renamed(false));
    assert_eq!(e.kind, ErrorKind::Corrupt, "{e}");
}

#[test]
fn trailing_bytes_are_refused() {
    let mut bytes = samples()[1].to_bytes().unwrap();
    bytes.extend_from_slice(&[0; 64]);
    assert_eq!(err(&bytes).kind, ErrorKind::Corrupt);
}

#[test]
fn read_and_write_name_the_path() {
    let dir = std::env::temp_dir().join(format!("lrr-formats-corrupt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sample.lrr");
    let [file, ..] = samples();
    file.write(&path).unwrap();
    assert_eq!(OperatorFile::read(&path).unwrap(), file);
    let mut bytes = std::fs::read(&path).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    let e = OperatorFile::read(&path).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.starts_with(&path.display().to_string()), "{e}");
    let missing = dir.join("missing.lrr");
    let e = OperatorFile::read(&missing).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Io);
    assert!(e.message.contains("missing.lrr"), "{e}");
    // An invalid struct is not written.
    let mut broken = file;
    broken.weights[0] = 0.0;
    assert_eq!(broken.write(&path).unwrap_err().kind, ErrorKind::Invalid);
    std::fs::remove_dir_all(&dir).unwrap();
}
