//! Format 1.2: the optional display sections (SMOOTH, MATERIALS, POINT_LIGHTS, CAMERAS, BVH),
//! read back, skipped by readers that do not know them, damaged or inconsistent.

mod common;

use common::{DISPLAY_KINDS, rebuild, sample, samples, with_display, with_lights, with_word};
use lrr_formats::{
    Container, ContainerWriter, Display, ErrorKind, FormatError, OperatorFile, Precision, kind,
};

fn err(bytes: &[u8]) -> FormatError {
    OperatorFile::from_bytes(bytes).expect_err("damaged file was accepted")
}

fn displayed() -> OperatorFile {
    samples()[4].clone()
}

/// The sections of `bytes` with `edit` applied to each (kind, required), stamped `1.minor`.
fn rewritten(bytes: &[u8], minor: u16, edit: impl Fn(u32, bool) -> Option<(u32, bool)>) -> Vec<u8> {
    let c = Container::parse(bytes).unwrap();
    let mut w = ContainerWriter::new();
    w.set_version(1, minor);
    for s in c.sections() {
        if let Some((kind, required)) = edit(s.kind, s.required()) {
            w.add(kind, required, c.section(s.kind).unwrap().to_vec());
        }
    }
    w.to_bytes()
}

#[test]
fn every_display_section_round_trips() {
    let file = displayed();
    let bytes = file.to_bytes().unwrap();
    let back = OperatorFile::from_bytes(&bytes).unwrap();
    assert_eq!(back, file);
    assert_eq!(back.to_bytes().unwrap(), bytes);
    let c = Container::parse(&bytes).unwrap();
    assert_eq!(c.version(), (1, 2));
    for k in DISPLAY_KINDS {
        let s = c.sections().iter().find(|s| s.kind == k).unwrap();
        assert!(!s.required(), "{:?}", kind::name(k));
    }
    // Each section alone.
    for (keep, &kind) in DISPLAY_KINDS.iter().enumerate() {
        let mut one = with_lights(sample(Precision::F32, 3));
        let d = &file.display;
        one.display = match keep {
            0 => Display {
                smooth: d.smooth.clone(),
                ..Display::default()
            },
            1 => Display {
                materials: d.materials.clone(),
                ..Display::default()
            },
            2 => Display {
                point_lights: d.point_lights.clone(),
                ..Display::default()
            },
            3 => Display {
                cameras: d.cameras.clone(),
                ..Display::default()
            },
            _ => Display {
                bvh: d.bvh.clone(),
                ..Display::default()
            },
        };
        let bytes = one.to_bytes().unwrap();
        let kinds: Vec<u32> = Container::parse(&bytes).unwrap().kinds().collect();
        assert_eq!(kinds.last(), Some(&kind));
        assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), one);
    }
}

#[test]
fn files_without_display_keep_the_bytes_of_format_1_1() {
    let file = displayed();
    let bytes = file.to_bytes().unwrap();
    // What a 1.1 writer gave for the same operator: the sections up to LIGHTS, stamped 1.1.
    let old = rewritten(&bytes, 1, |k, r| {
        (!DISPLAY_KINDS.contains(&k)).then_some((k, r))
    });
    let bare = OperatorFile {
        display: Display::default(),
        ..file
    };
    assert_eq!(bare.to_bytes().unwrap(), old);
    assert_eq!(OperatorFile::from_bytes(&old).unwrap(), bare);
}

#[test]
fn readers_that_do_not_know_them_skip_them() {
    // A 1.1 reader sees the display sections as unknown optional kinds: this reader, given the
    // same sections under kinds it does not know, must read the operator without display.
    let file = displayed();
    let bytes = file.to_bytes().unwrap();
    let unknown = rewritten(&bytes, 2, |k, r| {
        Some(if DISPLAY_KINDS.contains(&k) {
            (k + 1000, r)
        } else {
            (k, r)
        })
    });
    let read = OperatorFile::from_bytes(&unknown).unwrap();
    assert_eq!(read.display, Display::default());
    assert_eq!(read.operator, file.operator);
    // The sections are read whatever minor version the header names.
    let stamped_1_1 = rewritten(&bytes, 1, |k, r| Some((k, r)));
    assert_eq!(OperatorFile::from_bytes(&stamped_1_1).unwrap(), file);
}

#[test]
fn inconsistent_display_values_name_section_and_item() {
    let bytes = displayed().to_bytes().unwrap();
    // (kind, payload word, value, expected message start)
    let cases: [(u32, usize, u32, &str); 8] = [
        // SMOOTH: 2 head words, then 24 corners; element 0 corner 0 is word 2.
        (
            kind::SMOOTH,
            2,
            99,
            "section SMOOTH: element 0 corner 0: smooth vertex 99",
        ),
        // Element 1 (a triangle): its 4th corner, word 2 + 7.
        (
            kind::SMOOTH,
            9,
            3,
            "section SMOOTH: element 1 corner 3: a triangle's unused",
        ),
        // MATERIALS: 2 head words, 2 records of 16 words, then element materials.
        (
            kind::MATERIALS,
            34 + 4,
            2,
            "section MATERIALS: element 4 (file position): material 2",
        ),
        (
            kind::MATERIALS,
            2 + 16 + 7,
            0.5f32.to_bits(),
            "section MATERIALS: material 1 \"mirror ✨\": ior 0.5",
        ),
        // POINT_LIGHTS: light 0's group is word 2 + 3.
        (
            kind::POINT_LIGHTS,
            5,
            2,
            "section POINT_LIGHTS: point light 0 \"bulb\": group 2",
        ),
        // CAMERAS: fov is word 2 + 3.
        (
            kind::CAMERAS,
            5,
            190.0f32.to_bits(),
            "section CAMERAS: camera 0 \"\": fov_y_deg 190",
        ),
        // BVH: node 2's first triangle slot (word 2 + 16 + 3) moves into node 1's.
        (
            kind::BVH,
            21,
            4,
            "section BVH: node 2: triangles[4] is also in leaf 1",
        ),
        // The first triangle id repeated.
        (
            kind::BVH,
            2 + 24 + 1,
            0,
            "section BVH: triangles[1] repeats triangle 0",
        ),
    ];
    for (k, word, value, expected) in cases {
        let e = err(&with_word(&bytes, k, word, value));
        assert_eq!(e.kind, ErrorKind::Invalid, "{e}");
        assert!(
            e.message.starts_with(expected),
            "{e} (expected {expected:?})"
        );
    }
}

#[test]
fn damaged_display_structure_is_corrupt() {
    let bytes = displayed().to_bytes().unwrap();
    let cases: [(u32, usize, u32, &str); 6] = [
        (
            kind::SMOOTH,
            0,
            u32::MAX,
            "section SMOOTH (kind 13): expected",
        ),
        (
            kind::MATERIALS,
            0,
            3,
            "section MATERIALS (kind 14): 3 materials",
        ),
        (
            kind::MATERIALS,
            2 + 11,
            u32::MAX,
            "section MATERIALS (kind 14): material 0: its name",
        ),
        (
            kind::POINT_LIGHTS,
            0,
            1 << 30,
            "section POINT_LIGHTS (kind 15): 1073741824 point lights",
        ),
        (
            kind::CAMERAS,
            2 + 7,
            1,
            "section CAMERAS (kind 16): camera 0: its name of 1 bytes",
        ),
        (kind::BVH, 1, 10, "section BVH (kind 17): expected"),
    ];
    for (k, word, value, expected) in cases {
        let e = err(&with_word(&bytes, k, word, value));
        assert_eq!(e.kind, ErrorKind::Corrupt, "{e}");
        assert!(
            e.message.starts_with(expected),
            "{e} (expected {expected:?})"
        );
    }
    for k in DISPLAY_KINDS {
        let e = err(&rebuild(&bytes, |kind, p| {
            if kind == k {
                p.push(0);
            }
        }));
        assert_eq!(e.kind, ErrorKind::Corrupt, "{e}");
        assert!(e.message.contains(kind::name(k).unwrap()), "{e}");
    }
}

#[test]
fn a_file_with_display_and_without_lights_refuses_a_grouped_point_light() {
    let mut file = with_display(sample(Precision::F32, 3));
    let e = file.to_bytes().unwrap_err();
    assert!(
        e.message
            .contains("group 1 names no light group (the file has 0"),
        "{e}"
    );
    file.display.point_lights[0].group = lrr_formats::PointLight::FIXED;
    OperatorFile::from_bytes(&file.to_bytes().unwrap()).unwrap();
}
