//! `OperatorFile::write` streams a factored file's `F_k` in pieces; its bytes are
//! `to_bytes`'s, for every sample file and for an `F_k` of several pieces in both precisions.

mod common;

use lrr_formats::{FK_PIECE, Geometry, OperatorData, OperatorFile, Precision, StoredMatrix};

fn written(file: &OperatorFile, name: &str) -> Vec<u8> {
    let dir = std::env::temp_dir().join(format!("lrr-formats-write-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    file.write(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    bytes
}

#[test]
fn the_samples_are_written_as_encoded() {
    for (i, file) in common::samples().iter().enumerate() {
        assert_eq!(
            written(file, &format!("sample-{i}.lrr")),
            file.to_bytes().unwrap(),
            "sample {i}"
        );
    }
}

/// n elements in 2 patches (the first half in patch 0), `F_k` of 2n values.
fn large(n: usize, precision: Precision) -> OperatorFile {
    let fk: Vec<f32> = (0..2 * n).map(|i| (i % 97) as f32 / 400.0).collect();
    let mut vertices = Vec::with_capacity(12 * n);
    for e in 0..n {
        let x = e as f32;
        vertices.extend([
            x,
            0.0,
            0.0,
            x + 1.0,
            0.0,
            0.0,
            x + 1.0,
            1.0,
            0.0,
            x,
            1.0,
            0.0,
        ]);
    }
    OperatorFile {
        metadata_json: r#"{"scene":"write test"}"#.to_string(),
        n: n as u32,
        k: 2,
        channels: 3,
        precision,
        order: (0..n as u32).rev().collect(),
        index: vec![0, (n / 2) as u32, n as u32],
        weights: vec![1.0 / (n / 2) as f32; n],
        operator: OperatorData::Factored {
            fk: StoredMatrix::from_f32(&fk, precision),
            cores: (0..12).map(|i| 1.0 + f64::from(i) / 8.0).collect(),
        },
        reflectance: vec![0.5; 3 * n],
        emission: (0..3 * n).map(|i| if i < 3 { 5.0 } else { 0.0 }).collect(),
        geometry: Geometry {
            vertex_count: vec![4; n],
            vertices,
            normals: [0.0, 0.0, 1.0].repeat(n),
        },
        lights: Vec::new(),
        display: Default::default(),
    }
}

#[test]
fn an_fk_of_several_pieces_is_written_as_encoded() {
    // 2n = 2.5 pieces of values.
    let n = FK_PIECE * 5 / 4;
    for precision in [Precision::F32, Precision::F16] {
        let file = large(n, precision);
        let bytes = written(&file, &format!("large-{precision:?}.lrr"));
        assert_eq!(bytes, file.to_bytes().unwrap(), "{precision:?}");
        assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), file);
    }
}
