//! Format 1.1: the plain `Y_k` layout and the optional LIGHTS section, damaged or inconsistent.

mod common;

use common::{plain_sample, rebuild, sample, samples, with_lights, with_word};
use lrr_formats::{
    Container, ContainerWriter, ErrorKind, FormatError, Layout, OperatorFile, Precision, kind,
};

fn err(bytes: &[u8]) -> FormatError {
    OperatorFile::from_bytes(bytes).expect_err("damaged file was accepted")
}

/// Copies the sections of `bytes` except `drop`, with the version stamped `major.minor`.
fn without(bytes: &[u8], drop: u32, minor: u16) -> Vec<u8> {
    let c = Container::parse(bytes).unwrap();
    let mut w = ContainerWriter::new();
    w.set_version(1, minor);
    for s in c.sections().iter().filter(|s| s.kind != drop) {
        w.add(s.kind, s.required(), c.section(s.kind).unwrap().to_vec());
    }
    w.to_bytes()
}

#[test]
fn version_1_0_files_still_read() {
    // A 1.0 writer wrote exactly these sections (factored, no LIGHTS).
    for precision in [Precision::F32, Precision::F16] {
        let file = sample(precision, 3);
        let old = without(&file.to_bytes().unwrap(), kind::LIGHTS, 0);
        assert_eq!(Container::parse(&old).unwrap().version(), (1, 0));
        assert_eq!(OperatorFile::from_bytes(&old).unwrap(), file);
    }
}

#[test]
fn lights_are_optional_for_old_readers() {
    let file = with_lights(sample(Precision::F32, 3));
    let bytes = file.to_bytes().unwrap();
    let c = Container::parse(&bytes).unwrap();
    let lights = c
        .sections()
        .iter()
        .find(|s| s.kind == kind::LIGHTS)
        .unwrap();
    assert!(!lights.required());
    // What a reader that skips LIGHTS sees: the same operator without groups.
    let skipped = OperatorFile::from_bytes(&without(&bytes, kind::LIGHTS, 1)).unwrap();
    assert_eq!(skipped.lights, vec![]);
    assert_eq!(skipped.operator, file.operator);
}

#[test]
fn plain_layout_round_trips_in_both_precisions() {
    for file in [
        plain_sample(Precision::F32, 3),
        plain_sample(Precision::F16, 1),
    ] {
        let bytes = file.to_bytes().unwrap();
        let back = OperatorFile::from_bytes(&bytes).unwrap();
        assert_eq!(back.layout(), Layout::PlainYk);
        assert_eq!(back, file);
    }
}

#[test]
fn plain_files_need_yk_and_refuse_fk() {
    let bytes = plain_sample(Precision::F32, 3).to_bytes().unwrap();
    let e = err(&without(&bytes, kind::YK, 1));
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("section YK (kind 11) is missing"), "{e}");
    // A plain file declared factored.
    let e = err(&with_word(&bytes, kind::DIMS, 4, 0));
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("YK (kind 11) is present"), "{e}");
    // YK of the wrong length for the channels.
    let e = err(&with_word(&bytes, kind::DIMS, 2, 1));
    assert_eq!(e.kind, ErrorKind::Corrupt);
    assert!(e.message.contains("YK (kind 11): expected 48 bytes"), "{e}");
    // Factored files refuse a YK section.
    let factored = sample(Precision::F32, 3).to_bytes().unwrap();
    let c = Container::parse(&factored).unwrap();
    let mut w = ContainerWriter::new();
    for k in c.kinds() {
        w.add(k, true, c.section(k).unwrap().to_vec());
    }
    w.add(kind::YK, true, vec![0; 48]);
    let e = err(&w.to_bytes());
    assert!(e.message.contains("YK (kind 11) is present"), "{e}");
}

#[test]
fn invalid_plain_values_and_lights_with_valid_checksums() {
    let plain = plain_sample(Precision::F32, 3).to_bytes().unwrap();
    let e = err(&with_word(&plain, kind::YK, 30, f32::NAN.to_bits()));
    assert_eq!(e.kind, ErrorKind::Invalid);
    assert!(
        e.message
            .starts_with("section YK: channel 2, element 3, patch 0: value NaN"),
        "{e}"
    );
    let lit = samples()[0].to_bytes().unwrap();
    // Word layout of the first record (k = 2): 2 head, 2 record head, 12 x, 2 name ("lamp"),
    // 2 positions, 6 emission.
    let cases = [
        (18, 7, "positions[0] = 7 and positions[1] = 4"),
        (19, 6, "position 6 is not below n = 6"),
        (20, (-1.0f32).to_bits(), "value -1 must be finite and >= 0"),
        (5, 0x7FF8_0000, "x of patch 0 channel 0: value NaN"),
        (5, (2.0f64.to_bits() >> 32) as u32, "x must be Vᵀ E_g"),
        (16, u32::from_le_bytes(*b"sun "), "both named"),
    ];
    for (word, value, expected) in cases {
        let mut bytes = with_word(&lit, kind::LIGHTS, word, value);
        if expected == "both named" {
            // Make the first name equal the second ("sun ☀"): length 6, bytes "sun \xe2\x98\x80".
            bytes = rebuild(&lit, |k, p| {
                if k == kind::LIGHTS {
                    let second = "sun ☀".as_bytes();
                    p[8..12].copy_from_slice(&(second.len() as u32).to_le_bytes());
                    p[64..64 + second.len()].copy_from_slice(second);
                }
            });
        }
        let e = err(&bytes);
        assert_eq!(e.kind, ErrorKind::Invalid, "{e}");
        assert!(e.message.starts_with("section LIGHTS: group"), "{e}");
        assert!(e.message.contains(expected), "{e} (expected {expected:?})");
    }
}

#[test]
fn damaged_lights_structure_is_corrupt() {
    let lit = samples()[2].to_bytes().unwrap();
    let cases: [(usize, u32, &str); 4] = [
        (0, 3, "group 2"),
        (2, u32::MAX, "the name runs past the end"),
        (3, 0, "must both be at least 1"),
        (3, 1 << 30, "the positions runs past the end"),
    ];
    for (word, value, expected) in cases {
        let e = err(&with_word(&lit, kind::LIGHTS, word, value));
        assert_eq!(e.kind, ErrorKind::Corrupt, "{e}");
        assert!(e.message.starts_with("section LIGHTS (kind 12): "), "{e}");
        assert!(e.message.contains(expected), "{e} (expected {expected:?})");
    }
    let e = err(&rebuild(&lit, |k, p| {
        if k == kind::LIGHTS {
            p[64] = 0xC0;
        }
    }));
    assert!(e.message.contains("not valid UTF-8"), "{e}");
    let e = err(&rebuild(&lit, |k, p| {
        if k == kind::LIGHTS {
            p.extend_from_slice(&[0; 8]);
        }
    }));
    assert!(e.message.contains("but the payload has"), "{e}");
}
