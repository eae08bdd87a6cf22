//! The C functions called from Rust: results agree with lrr-runtime, and every kind of bad
//! argument gives its error code and a message instead of undefined behaviour or a panic.

use std::ffi::{CStr, CString, c_char};
use std::ptr::{null, null_mut};

use lrr_capi::*;
use lrr_formats::{ContainerWriter, kind};
use lrr_runtime::Operator;

/// Two facing unit squares (F = 1 each way), ρ = 0.5, file order reversed, the one at file
/// position 0 (element 1) emitting (1, 2, 3). Encoded by hand as a version 1.0 file (layout in
/// lrr_formats' crate docs; readers of major 1 read it), so this test does not follow every
/// change of `OperatorFile`.
fn plates() -> Vec<u8> {
    let u32s = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let f64s = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let square = |z: f32| [0.0, 0.0, z, 1.0, 0.0, z, 1.0, 1.0, z, 0.0, 1.0, z];
    let mut geometry = vec![4, 4, 0, 0];
    geometry.extend(f32s(&square(1.0)));
    geometry.extend(f32s(&square(0.0)));
    geometry.extend(f32s(&[0.0, 0.0, -1.0, 0.0, 0.0, 1.0]));
    let mut w = ContainerWriter::new();
    w.set_version(1, 0);
    w.add(kind::METADATA, true, b"{}".to_vec());
    // n, k, channels, precision (f32), layout (factored), 3 reserved.
    w.add(kind::DIMS, true, u32s(&[2, 2, 1, 0, 0, 0, 0, 0]));
    w.add(kind::ORDER, true, u32s(&[1, 0]));
    w.add(kind::INDEX, true, u32s(&[0, 1, 2]));
    w.add(kind::WEIGHTS, true, f32s(&[1.0, 1.0]));
    w.add(kind::FK, true, f32s(&[0.0, 1.0, 1.0, 0.0]));
    w.add(
        kind::CORES,
        true,
        f64s(&[4.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 4.0 / 3.0]),
    );
    w.add(kind::REFLECTANCE, true, f32s(&[0.5; 6]));
    w.add(kind::EMISSION, true, f32s(&[1.0, 2.0, 3.0, 0.0, 0.0, 0.0]));
    w.add(kind::GEOMETRY, true, geometry);
    w.to_bytes()
}

fn last_error() -> String {
    // SAFETY: lrr_last_error returns a NUL-terminated string valid until the next failing call
    // on this thread; it is copied at once.
    unsafe { CStr::from_ptr(lrr_last_error()) }
        .to_str()
        .unwrap()
        .to_string()
}

/// Loads `bytes` through the C function; the handle is freed by the caller.
fn load(bytes: &[u8]) -> *mut LrrOperator {
    let mut op = null_mut();
    // SAFETY: valid slice and out-pointer.
    let code = unsafe { lrr_load_bytes(bytes.as_ptr(), bytes.len(), &mut op) };
    assert_eq!(code, LRR_OK, "{}", last_error());
    op
}

#[test]
fn evaluate_matches_the_runtime() {
    let bytes = plates();
    let op = load(&bytes);
    // SAFETY: `op` is live until lrr_free below; buffers have the lengths passed.
    unsafe {
        assert_eq!(lrr_element_count(op), 2);
        let mut emission = [0.0f32; 6];
        assert_eq!(lrr_baked_emission(op, emission.as_mut_ptr(), 6), LRR_OK);
        // Element 1 is file position 0, which emits (1, 2, 3).
        assert_eq!(emission, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0]);
        emission.iter_mut().for_each(|e| *e *= 3.0);
        let mut radiosity = [0.0f32; 6];
        let code = lrr_evaluate(op, emission.as_ptr(), 6, radiosity.as_mut_ptr(), 6);
        assert_eq!(code, LRR_OK, "{}", last_error());
        let rust = Operator::from_bytes(&bytes).unwrap();
        let mut expected = [[0.0f32; 3]; 2];
        rust.evaluate(&[[0.0; 3], [3.0, 6.0, 9.0]], &mut expected)
            .unwrap();
        assert_eq!(radiosity.as_slice(), expected.as_flattened());
        let mut element = u32::MAX;
        let (p, n) = ([0.5f32, 0.5, 0.9], [0.0f32, 0.0, -1.0]);
        assert_eq!(lrr_locate(op, p.as_ptr(), n.as_ptr(), &mut element), LRR_OK);
        assert_eq!(element, 1);
        let n = [0.0f32, 0.0, 1.0];
        assert_eq!(lrr_locate(op, p.as_ptr(), n.as_ptr(), &mut element), LRR_OK);
        assert_eq!(element, 0);
        lrr_free(op);
    }
}

#[test]
fn load_from_a_path() {
    let path = std::env::temp_dir().join(format!("lrr-capi-{}.lrr", std::process::id()));
    std::fs::write(&path, plates()).unwrap();
    let c_path = CString::new(path.to_str().unwrap()).unwrap();
    let mut op = null_mut();
    // SAFETY: NUL-terminated path, valid out-pointer; the handle is freed below.
    unsafe {
        assert_eq!(
            lrr_load(c_path.as_ptr(), &mut op),
            LRR_OK,
            "{}",
            last_error()
        );
        assert_eq!(lrr_element_count(op), 2);
        lrr_free(op);
    }
    std::fs::remove_file(&path).unwrap();
    let mut op = std::ptr::dangling_mut::<LrrOperator>(); // garbage the call must overwrite
    // SAFETY: as above.
    let code = unsafe { lrr_load(c_path.as_ptr(), &mut op) };
    assert_eq!(code, LRR_ERROR_IO);
    assert!(op.is_null(), "a failed load leaves a null handle");
    assert!(
        last_error().contains(path.to_str().unwrap()),
        "{}",
        last_error()
    );
}

#[test]
fn bad_loads_are_errors() {
    let mut op = null_mut();
    // SAFETY: each call passes either null or valid pointers with their true lengths.
    unsafe {
        assert_eq!(lrr_load(null(), &mut op), LRR_ERROR_NULL);
        assert!(last_error().contains("path"), "{}", last_error());
        let path = c"ok.lrr";
        assert_eq!(lrr_load(path.as_ptr(), null_mut()), LRR_ERROR_NULL);
        let bad = [0x66u8, 0xff, 0xfe, 0];
        assert_eq!(
            lrr_load(bad.as_ptr().cast::<c_char>(), &mut op),
            LRR_ERROR_UTF8
        );
        assert!(last_error().contains("UTF-8"), "{}", last_error());
        assert_eq!(lrr_load_bytes(null(), 0, &mut op), LRR_ERROR_FORMAT);
        assert_eq!(lrr_load_bytes(null(), 10, &mut op), LRR_ERROR_NULL);
        let junk = b"PK\x03\x04 not an operator";
        assert_eq!(
            lrr_load_bytes(junk.as_ptr(), junk.len(), &mut op),
            LRR_ERROR_FORMAT
        );
        assert!(last_error().contains("not an lrr"), "{}", last_error());
        let mut damaged = plates();
        *damaged.last_mut().unwrap() ^= 1;
        let code = lrr_load_bytes(damaged.as_ptr(), damaged.len(), &mut op);
        assert_eq!(code, LRR_ERROR_FORMAT);
        assert!(last_error().contains("checksum"), "{}", last_error());
        assert!(op.is_null());
        lrr_free(null_mut());
    }
}

#[test]
fn bad_buffers_are_errors_and_leave_the_output_alone() {
    let op = load(&plates());
    let e = [1.0f32; 6];
    let mut b = [7.0f32; 7];
    // SAFETY: every pointer is null or valid for the length passed; `op` is live until freed.
    unsafe {
        assert_eq!(lrr_element_count(null()), 0);
        assert_eq!(
            lrr_evaluate(null(), e.as_ptr(), 6, b.as_mut_ptr(), 6),
            LRR_ERROR_NULL
        );
        assert_eq!(
            lrr_evaluate(op, null(), 6, b.as_mut_ptr(), 6),
            LRR_ERROR_NULL
        );
        assert_eq!(
            lrr_evaluate(op, e.as_ptr(), 6, null_mut(), 6),
            LRR_ERROR_NULL
        );
        assert_eq!(
            lrr_evaluate(op, e.as_ptr(), 5, b.as_mut_ptr(), 6),
            LRR_ERROR_LENGTH
        );
        assert!(last_error().contains("3 × 2"), "{}", last_error());
        assert_eq!(
            lrr_evaluate(op, e.as_ptr(), 6, b.as_mut_ptr(), 7),
            LRR_ERROR_LENGTH
        );
        let misaligned = b.as_mut_ptr().cast::<u8>().add(1).cast::<f32>();
        assert_eq!(
            lrr_evaluate(op, e.as_ptr(), 6, misaligned, 6),
            LRR_ERROR_BUFFER
        );
        // In place (the same buffer for both) is refused: the output would alias the input.
        let both = b.as_mut_ptr();
        assert_eq!(lrr_evaluate(op, both, 6, both, 6), LRR_ERROR_BUFFER);
        assert_eq!(lrr_evaluate(op, both.add(1), 6, both, 6), LRR_ERROR_BUFFER);
        let negative = [-1.0f32, 0.0, 0.0, 0.0, 0.0, 0.0];
        let code = lrr_evaluate(op, negative.as_ptr(), 6, b.as_mut_ptr(), 6);
        assert_eq!(code, LRR_ERROR_INPUT);
        let nan = [f32::NAN; 6];
        assert_eq!(
            lrr_evaluate(op, nan.as_ptr(), 6, b.as_mut_ptr(), 6),
            LRR_ERROR_INPUT
        );
        assert!(
            b.iter().all(|x| *x == 7.0),
            "output written on error: {b:?}"
        );
        assert_eq!(lrr_baked_emission(op, b.as_mut_ptr(), 7), LRR_ERROR_LENGTH);
        assert_eq!(lrr_baked_emission(op, null_mut(), 6), LRR_ERROR_NULL);
        let (p, inf) = ([0.0f32; 3], [f32::INFINITY, 0.0, 0.0]);
        let mut id = 0u32;
        assert_eq!(
            lrr_locate(op, p.as_ptr(), inf.as_ptr(), &mut id),
            LRR_ERROR_INPUT
        );
        assert_eq!(lrr_locate(op, null(), p.as_ptr(), &mut id), LRR_ERROR_NULL);
        assert_eq!(
            lrr_locate(op, p.as_ptr(), p.as_ptr(), null_mut()),
            LRR_ERROR_NULL
        );
        lrr_free(op);
    }
}

#[test]
fn operators_are_shared_across_threads() {
    let bytes = plates();
    let op = load(&bytes) as usize; // a handle is immutable: threads may evaluate it at once
    let results: Vec<Vec<f32>> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..4)
            .map(|t| {
                s.spawn(move || {
                    let e = [t as f32; 6];
                    let mut b = [0.0f32; 6];
                    let op = op as *const LrrOperator;
                    // SAFETY: the handle stays live until every thread is joined.
                    let code = unsafe { lrr_evaluate(op, e.as_ptr(), 6, b.as_mut_ptr(), 6) };
                    assert_eq!(code, LRR_OK);
                    b.to_vec()
                })
            })
            .collect();
        workers.into_iter().map(|w| w.join().unwrap()).collect()
    });
    for (t, b) in results.iter().enumerate() {
        // Linear in the emission: thread t's result is t times thread 1's.
        for (x, y) in b.iter().zip(&results[1]) {
            assert!(
                (x - t as f32 * y).abs() <= 1e-6 * x.abs().max(1.0),
                "{results:?}"
            );
        }
    }
    // SAFETY: the last user of the handle.
    unsafe { lrr_free(op as *mut LrrOperator) };
}

/// A 3 × 3 floor of unit squares facing +z (synthetic operator) with a BVH, as file bytes.
fn lit_floor() -> Vec<u8> {
    use lrr_runtime::testkit::{bvh, synthetic};
    let mut file = synthetic::file(
        9,
        3,
        3,
        lrr_runtime::Precision::F32,
        lrr_runtime::Layout::Factored,
        5,
    )
    .unwrap();
    file.display.bvh = Some(bvh::build(&file.geometry));
    file.to_bytes().unwrap()
}

#[test]
fn lights_give_the_runtimes_emission_and_point_values() {
    let bytes = lit_floor();
    let op = load(&bytes);
    let rust = Operator::from_bytes(&bytes).unwrap();
    // A point light 1.5 over (1.5, 1.5) and a sun at an angle.
    #[rustfmt::skip]
    let lights: [f32; 24] = [
        0.0, 1.5, 1.5, 1.5, 0.0, 0.0, 0.0, 2.0, 3.0, 4.0, 0.0, 0.0,
        2.0, 0.0, 0.0, 0.0, 1.0, 0.0, -2.0, 0.5, 0.5, 0.5, 0.0, 0.0,
    ];
    let base = [0.25f32; 27];
    let mut emission = [0.0f32; 27];
    let mut direct = null_mut();
    // SAFETY: live handles until freed below; every buffer has the length passed.
    unsafe {
        assert_eq!(
            lrr_direct_new(op, 4, &mut direct),
            LRR_OK,
            "{}",
            last_error()
        );
        let code = lrr_direct_emission(
            direct,
            lights.as_ptr(),
            24,
            base.as_ptr(),
            27,
            emission.as_mut_ptr(),
            27,
        );
        assert_eq!(code, LRR_OK, "{}", last_error());
        // The runtime's own direct pass gives the same emission.
        use lrr_runtime::lights::{DirectLighting, Light, reflected};
        let list = [
            Light::Point {
                position: [1.5, 1.5, 1.5],
                intensity: [2.0, 3.0, 4.0],
            },
            Light::Directional {
                direction: [1.0, 0.0, -2.0],
                irradiance: [0.5; 3],
            },
        ];
        let mut pass = DirectLighting::new(rust.file(), 4, 1).unwrap();
        let mut h = vec![[0.0f32; 3]; 9];
        pass.irradiance(&list, &mut h).unwrap();
        let mut want = vec![[0.0f32; 3]; 9];
        reflected(&rust.reflectance(), &h, &[[0.25; 3]; 9], &mut want).unwrap();
        assert_eq!(emission.as_slice(), want.as_flattened());
        // At a point: ρ of the element times the point's irradiance.
        let (p, n) = ([1.5f32, 1.5, 0.0], [0.0f32, 0.0, 1.0]);
        let mut element = 0u32;
        assert_eq!(lrr_locate(op, p.as_ptr(), n.as_ptr(), &mut element), LRR_OK);
        let mut rgb = [0.0f32; 3];
        let code = lrr_direct_at(
            direct,
            lights.as_ptr(),
            24,
            element,
            p.as_ptr(),
            n.as_ptr(),
            rgb.as_mut_ptr(),
        );
        assert_eq!(code, LRR_OK, "{}", last_error());
        let rho = rust.reflectance()[element as usize];
        let sun = 0.5 * 2.0 / 5f32.sqrt();
        let point = [2.0f32, 3.0, 4.0].map(|i| i / (1.5 * 1.5));
        for c in 0..3 {
            let expected = rho[c] * (point[c] + sun);
            assert!(
                (rgb[c] - expected).abs() <= 1e-5 * expected,
                "{rgb:?} vs {expected}"
            );
        }
        // Bad lights name themselves; lengths that are no whole light are refused.
        let mut bad = lights;
        bad[12] = 7.0;
        let code = lrr_direct_emission(
            direct,
            bad.as_ptr(),
            24,
            base.as_ptr(),
            27,
            emission.as_mut_ptr(),
            27,
        );
        assert_eq!(code, LRR_ERROR_INPUT);
        assert!(last_error().contains("light 1: kind 7"), "{}", last_error());
        let code = lrr_direct_emission(
            direct,
            lights.as_ptr(),
            23,
            base.as_ptr(),
            27,
            emission.as_mut_ptr(),
            27,
        );
        assert_eq!(code, LRR_ERROR_LENGTH);
        // No lights: the base, and a null list is fine.
        let code = lrr_direct_emission(
            direct,
            null(),
            0,
            base.as_ptr(),
            27,
            emission.as_mut_ptr(),
            27,
        );
        assert_eq!(code, LRR_OK, "{}", last_error());
        assert_eq!(emission, base);
        assert_eq!(
            lrr_direct_at(
                direct,
                lights.as_ptr(),
                24,
                99,
                p.as_ptr(),
                n.as_ptr(),
                rgb.as_mut_ptr()
            ),
            LRR_ERROR_INPUT
        );
        lrr_direct_free(direct);
        lrr_direct_free(null_mut());
        // A file without a BVH cannot be lit: the error says to re-bake.
        let plain = load(&plates());
        let mut none = null_mut();
        assert_ne!(lrr_direct_new(plain, 4, &mut none), LRR_OK);
        assert!(none.is_null());
        assert!(last_error().contains("BVH"), "{}", last_error());
        lrr_free(plain);
        lrr_free(op);
    }
}

#[test]
fn a_lightmap_fills_the_runtimes_texels_and_refuses_bad_buffers() {
    use lrr_runtime::testkit::faces::lightmapped;
    let bytes = lightmapped(|x, y| [0.1 + x / 2.5, 0.05 + y * 0.7], 37, 23, 2)
        .to_bytes()
        .unwrap();
    let op = load(&bytes);
    let rust = Operator::from_bytes(&bytes).unwrap();
    let b: Vec<[f32; 3]> = vec![[1.0, 0.5, 0.25], [0.0, 0.25, 2.0]];
    let mut want = vec![[0.0f32; 3]; 37 * 23];
    lrr_runtime::Lightmap::new(rust.file(), None)
        .unwrap()
        .fill(&b, &mut want)
        .unwrap();
    let flat: Vec<f32> = b.concat();
    let mut map = null_mut();
    let (mut w, mut h) = (0u32, 0u32);
    let mut texels = vec![f32::NAN; 3 * 37 * 23];
    // SAFETY: live handles until freed below; every buffer has the length passed.
    unsafe {
        assert_eq!(lrr_lightmap_new(op, &mut map), LRR_OK, "{}", last_error());
        // The operator may go first: the lightmap keeps what it needs.
        lrr_free(op);
        assert_eq!(lrr_lightmap_size(map, &mut w, &mut h), LRR_OK);
        assert_eq!((w, h), (37, 23));
        let code = lrr_lightmap_fill(map, flat.as_ptr(), 6, texels.as_mut_ptr(), texels.len());
        assert_eq!(code, LRR_OK, "{}", last_error());
        let got: Vec<[f32; 3]> = texels.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        assert_eq!(got, want);
        // A short texel buffer, a missing one, a short radiosity: errors that say so.
        let before = texels.clone();
        let code = lrr_lightmap_fill(map, flat.as_ptr(), 6, texels.as_mut_ptr(), 30);
        assert_eq!(code, LRR_ERROR_LENGTH);
        assert!(
            last_error().contains("37×23 atlas needs 3 × 851"),
            "{}",
            last_error()
        );
        let code = lrr_lightmap_fill(map, flat.as_ptr(), 6, null_mut(), 0);
        assert_eq!(code, LRR_ERROR_NULL);
        let code = lrr_lightmap_fill(map, flat.as_ptr(), 3, texels.as_mut_ptr(), texels.len());
        assert_eq!(code, LRR_ERROR_LENGTH);
        // The radiosity inside the texels: overlapping buffers.
        let code = lrr_lightmap_fill(map, texels.as_ptr(), 6, texels.as_mut_ptr(), texels.len());
        assert_eq!(code, LRR_ERROR_BUFFER, "{}", last_error());
        assert_eq!(texels.len(), before.len());
        assert_eq!(lrr_lightmap_size(null(), &mut w, &mut h), LRR_ERROR_NULL);
        lrr_lightmap_free(map);
        lrr_lightmap_free(null_mut());
    }
    // A file without an atlas is refused in one line that says how to get one.
    let mut file = lightmapped(|x, y| [x / 2.0, y], 8, 8, 1);
    file.display.lightmap = None;
    let op = load(&file.to_bytes().unwrap());
    let mut map = null_mut();
    // SAFETY: a live handle, freed below.
    unsafe {
        assert_eq!(lrr_lightmap_new(op, &mut map), LRR_ERROR_INPUT);
        assert!(map.is_null());
        lrr_free(op);
    }
    assert!(last_error().contains("re-bake"), "{}", last_error());
}
