//! The invariants of an [`OperatorFile`], checked by [`OperatorFile::validate`].
//!
//! Checked in the order of the sections, first failure wins; every message names the section,
//! the position and the rule. The runtime relies on these (an index inside `0..n`, no NaN in a
//! product), so [`OperatorFile::from_bytes`] runs them on every file it returns.

use crate::bytes::checked_product;
use crate::error::FormatError;
use crate::file::{OperatorData, OperatorFile, StoredMatrix};
use crate::half::f16_to_f32;
use crate::{
    bvh, cameras, direct_lights, faces, lightmap, lights, materials, point_lights, smooth,
};

const RGB: [&str; 3] = ["r", "g", "b"];

/// Value counts of every array, from `n`, `k` and `channels`, overflow-checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Sizes {
    /// `n`: order, weights, vertex counts.
    pub n: usize,
    /// `k + 1`: index.
    pub index: usize,
    /// `n * k`: F_k.
    pub fk: usize,
    /// `channels * k * k`: cores.
    pub cores: usize,
    /// `channels * n * k`: plain Y_k.
    pub yk: usize,
    /// `n * 3`: reflectance, emission, normals.
    pub rgb: usize,
    /// `n * 12`: vertices.
    pub vertices: usize,
}

impl Sizes {
    pub(crate) fn new(n: u32, k: u32, channels: u32) -> Result<Self, FormatError> {
        let (n64, k64, c64) = (u64::from(n), u64::from(k), u64::from(channels));
        Ok(Sizes {
            n: checked_product("section ORDER (n)", &[n64])?,
            index: checked_product("section INDEX (k + 1)", &[k64 + 1])?,
            fk: checked_product("section FK (n * k)", &[n64, k64])?,
            cores: checked_product("section CORES (channels * k * k)", &[c64, k64, k64])?,
            yk: checked_product("section YK (channels * n * k)", &[c64, n64, k64])?,
            rgb: checked_product("section REFLECTANCE (n * 3)", &[n64, 3])?,
            vertices: checked_product("section GEOMETRY (n * 12)", &[n64, 12])?,
        })
    }
}

/// The checks on DIMS that do not need the other sections.
pub(crate) fn check_dims(n: u32, k: u32, channels: u32) -> Result<(), FormatError> {
    if channels != 1 && channels != 3 {
        return Err(FormatError::invalid(format!(
            "section DIMS: channels = {channels}, must be 1 (grey) or 3 (RGB)"
        )));
    }
    if k == 0 || k > n {
        return Err(FormatError::invalid(format!(
            "section DIMS: k = {k} patches for n = {n} elements: need 1 <= k <= n"
        )));
    }
    Ok(())
}

impl OperatorFile {
    /// Checks every invariant documented on the fields. Messages name the section, the index and
    /// the problem, e.g. `section FK: element 4, patch 1: value NaN must be finite and >= 0`.
    pub fn validate(&self) -> Result<(), FormatError> {
        self.check(false)
    }

    /// [`validate`](Self::validate); with `streamed`, the stored matrix is left out (it is
    /// empty here and checked piece by piece as it is written, see `write_streamed`).
    pub(crate) fn check(&self, streamed: bool) -> Result<(), FormatError> {
        let f = self;
        check_dims(f.n, f.k, f.channels)?;
        let matrix = f.operator.matrix();
        if matrix.precision() != f.precision {
            return Err(FormatError::invalid(format!(
                "section {}: DIMS says precision {:?} but the data is {:?}",
                matrix_section(f),
                f.precision,
                matrix.precision()
            )));
        }
        let sizes = Sizes::new(f.n, f.k, f.channels)?;
        check_lengths(f, &sizes, streamed)?;
        check_order(&f.order)?;
        check_index(&f.index, f.n)?;
        check_weights(&f.weights)?;
        match &f.operator {
            OperatorData::Factored { fk, cores } => {
                check_fk(fk, f.k as usize)?;
                check_cores(cores, f.k as usize)?;
            }
            OperatorData::PlainYk { yk } => check_yk(yk, f.n as usize, f.k as usize)?,
        }
        check_rgb(
            "REFLECTANCE",
            &f.reflectance,
            |v| (0.0..=1.0).contains(&v),
            "in [0, 1]",
        )?;
        check_rgb("EMISSION", &f.emission, |v| v >= 0.0, ">= 0")?;
        check_geometry(f)?;
        lights::check(f)?;
        check_display(f)
    }
}

/// The display sections (format 1.2), each against the file's elements and light groups; the
/// display faces (FACES, 1.4) first: SMOOTH, LIGHTMAP and the BVH are defined on them.
fn check_display(f: &OperatorFile) -> Result<(), FormatError> {
    let d = &f.display;
    if let Some(faces) = &d.faces {
        faces::check(f, faces)?;
    }
    if let Some(s) = &d.smooth {
        smooth::check(f, s)?;
    }
    if let Some(m) = &d.materials {
        materials::check(f, m)?;
    }
    point_lights::check(f, &d.point_lights)?;
    direct_lights::check(&d.direct_lights)?;
    if let Some(t) = &d.sky_transfer {
        if Some(t.len()) != (f.n as usize).checked_mul(9) {
            return Err(FormatError::invalid(format!(
                "section SKY_TRANSFER: {} values for {} elements (9 each)",
                t.len(),
                f.n
            )));
        }
        // |T_lm| ≤ ∫ |Y_lm| cos ≤ π max|Y_lm| < 3.5: anything larger is no projection.
        if let Some(i) = t.iter().position(|v| !(v.is_finite() && v.abs() <= 4.0)) {
            return Err(FormatError::invalid(format!(
                "section SKY_TRANSFER: element {} coefficient {} is {}, not a transfer \
                 coefficient (finite, at most 4 in magnitude)",
                i / 9,
                i % 9,
                t[i]
            )));
        }
    }
    cameras::check(&d.cameras)?;
    if let Some(l) = &d.lightmap {
        lightmap::check(f, l)?;
    }
    match &d.bvh {
        Some(b) => bvh::check(f, b),
        None => Ok(()),
    }
}

fn matrix_section(f: &OperatorFile) -> &'static str {
    match f.operator {
        OperatorData::Factored { .. } => "FK",
        OperatorData::PlainYk { .. } => "YK",
    }
}

fn check_lengths(f: &OperatorFile, s: &Sizes, streamed: bool) -> Result<(), FormatError> {
    let g = &f.geometry;
    let (matrix, cores) = match &f.operator {
        OperatorData::Factored { fk, cores } => (("FK", "n * k", s.fk, fk.len()), cores.len()),
        OperatorData::PlainYk { yk } => (("YK", "channels * n * k", s.yk, yk.len()), s.cores),
    };
    let arrays = [
        ("ORDER", "n", s.n, f.order.len()),
        ("INDEX", "k + 1", s.index, f.index.len()),
        ("WEIGHTS", "n", s.n, f.weights.len()),
        matrix,
        ("CORES", "channels * k * k", s.cores, cores),
        ("REFLECTANCE", "n * 3", s.rgb, f.reflectance.len()),
        ("EMISSION", "n * 3", s.rgb, f.emission.len()),
        ("GEOMETRY", "n vertex counts", s.n, g.vertex_count.len()),
        (
            "GEOMETRY",
            "n * 12 vertex coordinates",
            s.vertices,
            g.vertices.len(),
        ),
        (
            "GEOMETRY",
            "n * 3 normal coordinates",
            s.rgb,
            g.normals.len(),
        ),
    ];
    for (i, (section, formula, expected, found)) in arrays.into_iter().enumerate() {
        if expected != found && !(streamed && i == 3) {
            return Err(FormatError::invalid(format!(
                "section {section}: expected {formula} = {expected} values, found {found}"
            )));
        }
    }
    Ok(())
}

fn check_order(order: &[u32]) -> Result<(), FormatError> {
    let n = order.len();
    let mut seen = vec![false; n];
    for (pos, &id) in order.iter().enumerate() {
        let rule = "ids must be a permutation of 0..n";
        match seen.get_mut(id as usize) {
            None => {
                return Err(FormatError::invalid(format!(
                    "section ORDER: position {pos} holds element id {id} >= n = {n} ({rule})"
                )));
            }
            Some(true) => {
                return Err(FormatError::invalid(format!(
                    "section ORDER: position {pos} repeats element id {id} ({rule})"
                )));
            }
            Some(slot) => *slot = true,
        }
    }
    Ok(())
}

/// `index` has `k + 1 >= 2` entries (checked before).
fn check_index(index: &[u32], n: u32) -> Result<(), FormatError> {
    if let Some(&first) = index.first().filter(|&&v| v != 0) {
        return Err(FormatError::invalid(format!(
            "section INDEX: index[0] = {first}, must be 0"
        )));
    }
    for (p, pair) in index.windows(2).enumerate() {
        if pair[1] <= pair[0] {
            return Err(FormatError::invalid(format!(
                "section INDEX: index[{p}] = {} and index[{}] = {}: offsets must increase \
                 strictly (patch {p} would be empty or negative)",
                pair[0],
                p + 1,
                pair[1]
            )));
        }
    }
    match index.last() {
        Some(&last) if last != n => Err(FormatError::invalid(format!(
            "section INDEX: index[{}] = {last}, must be n = {n}",
            index.len() - 1
        ))),
        _ => Ok(()),
    }
}

fn check_weights(weights: &[f32]) -> Result<(), FormatError> {
    match weights.iter().position(|&w| !(w > 0.0 && w <= 1.0)) {
        Some(e) => Err(FormatError::invalid(format!(
            "section WEIGHTS: element {e}: weight {} must be finite and in (0, 1]",
            weights[e]
        ))),
        None => Ok(()),
    }
}

pub(crate) fn check_fk(fk: &StoredMatrix, k: usize) -> Result<(), FormatError> {
    let ok = |v: f32| v.is_finite() && v >= 0.0;
    let bad = match fk {
        StoredMatrix::F32(v) => v.iter().position(|&x| !ok(x)),
        StoredMatrix::F16(v) => v.iter().position(|&h| !ok(f16_to_f32(h))),
    };
    match (bad, fk) {
        (Some(i), StoredMatrix::F32(v)) => Err(fk_error(i, k, &format!("{}", v[i]))),
        (Some(i), StoredMatrix::F16(v)) => {
            let value = format!("{} (f16 {:#06x})", f16_to_f32(v[i]), v[i]);
            Err(fk_error(i, k, &value))
        }
        (None, _) => Ok(()),
    }
}

fn fk_error(i: usize, k: usize, value: &str) -> FormatError {
    FormatError::invalid(format!(
        "section FK: element {}, patch {}: value {value} must be finite and >= 0",
        i / k,
        i % k
    ))
}

/// `Y_c` values may have either sign; they must be finite.
fn check_yk(yk: &StoredMatrix, n: usize, k: usize) -> Result<(), FormatError> {
    let bad = match yk {
        StoredMatrix::F32(v) => v.iter().position(|x| !x.is_finite()),
        StoredMatrix::F16(v) => v.iter().position(|&h| !f16_to_f32(h).is_finite()),
    };
    match bad {
        Some(i) => Err(FormatError::invalid(format!(
            "section YK: channel {}, element {}, patch {}: value {} must be finite",
            i / (n * k),
            i / k % n,
            i % k,
            yk.get(i).unwrap_or(f32::NAN)
        ))),
        None => Ok(()),
    }
}

fn check_cores(cores: &[f64], k: usize) -> Result<(), FormatError> {
    match cores.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(FormatError::invalid(format!(
            "section CORES: channel {}, row {}, column {}: value {} must be finite",
            i / (k * k),
            i / k % k,
            i % k,
            cores[i]
        ))),
        None => Ok(()),
    }
}

fn check_rgb(
    section: &str,
    values: &[f32],
    ok: impl Fn(f32) -> bool,
    rule: &str,
) -> Result<(), FormatError> {
    match values.iter().position(|&v| !(v.is_finite() && ok(v))) {
        Some(i) => Err(FormatError::invalid(format!(
            "section {section}: element {}, channel {}: value {} must be finite and {rule}",
            i / 3,
            RGB[i % 3],
            values[i]
        ))),
        None => Ok(()),
    }
}

fn check_geometry(f: &OperatorFile) -> Result<(), FormatError> {
    faces::check_polygons("GEOMETRY", "element", &f.geometry)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ErrorKind;
    use crate::file::Precision;
    use crate::testdata::{plain_sample, sample};

    fn message(edit: impl FnOnce(&mut OperatorFile)) -> String {
        let mut f = sample(Precision::F32, 3);
        edit(&mut f);
        let err = f.validate().unwrap_err();
        assert_eq!(err.kind, ErrorKind::Invalid, "{err}");
        assert!(f.to_bytes().is_err());
        err.message
    }

    #[test]
    fn samples_are_valid() {
        sample(Precision::F32, 3).validate().unwrap();
        sample(Precision::F16, 1).validate().unwrap();
        plain_sample(Precision::F16, 3).validate().unwrap();
    }

    #[test]
    fn plain_yk_messages() {
        let mut f = plain_sample(Precision::F32, 3);
        if let OperatorData::PlainYk {
            yk: StoredMatrix::F32(v),
        } = &mut f.operator
        {
            v[2 * 12 + 5] = f32::INFINITY;
        }
        let e = f.validate().unwrap_err();
        assert_eq!(
            e.message,
            "section YK: channel 2, element 2, patch 1: value inf must be finite"
        );
        let mut f = plain_sample(Precision::F16, 1);
        f.precision = Precision::F32;
        let e = f.validate().unwrap_err();
        assert!(
            e.message.starts_with("section YK: DIMS says precision F32"),
            "{e}"
        );
        let mut f = plain_sample(Precision::F32, 3);
        f.channels = 1;
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .starts_with("section YK: expected channels * n * k = 12"),
            "{e}"
        );
    }

    #[test]
    fn messages_name_section_index_and_problem() {
        type Edit = Box<dyn FnOnce(&mut OperatorFile)>;
        let cases: Vec<(Edit, &str)> = vec![
            (Box::new(|f| f.channels = 2), "section DIMS: channels = 2"),
            (
                Box::new(|f| f.k = 7),
                "section DIMS: k = 7 patches for n = 6",
            ),
            (
                Box::new(|f| f.precision = Precision::F16),
                "section FK: DIMS says precision F16",
            ),
            (
                Box::new(|f| f.order[4] = 9),
                "section ORDER: position 4 holds element id 9",
            ),
            (
                Box::new(|f| f.order[4] = f.order[0]),
                "section ORDER: position 4 repeats",
            ),
            (
                Box::new(|f| f.index[1] = 0),
                "section INDEX: index[0] = 0 and index[1] = 0",
            ),
            (
                Box::new(|f| f.index[1] = 7),
                "section INDEX: index[1] = 7 and index[2] = 6",
            ),
            (
                Box::new(|f| f.index[0] = 1),
                "section INDEX: index[0] = 1, must be 0",
            ),
            (
                Box::new(|f| f.index[2] = 5),
                "section INDEX: index[2] = 5, must be n = 6",
            ),
            (
                Box::new(|f| f.weights[3] = 0.0),
                "section WEIGHTS: element 3: weight 0",
            ),
            (
                Box::new(|f| f.weights[2] = 1.5),
                "section WEIGHTS: element 2: weight 1.5",
            ),
            (
                Box::new(|f| f.weights[1] = f32::NAN),
                "section WEIGHTS: element 1: weight NaN",
            ),
            (
                Box::new(|f| {
                    let OperatorData::Factored { fk, .. } = &mut f.operator else {
                        unreachable!()
                    };
                    *fk = StoredMatrix::F32(vec![
                        0.1,
                        0.2,
                        0.0,
                        0.0,
                        0.1,
                        0.2,
                        0.3,
                        f32::NAN,
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                    ])
                }),
                "section FK: element 3, patch 1: value NaN",
            ),
            (
                Box::new(|f| {
                    if let OperatorData::Factored { cores, .. } = &mut f.operator {
                        cores[6] = f64::INFINITY;
                    }
                }),
                "section CORES: channel 1, row 1, column 0: value inf",
            ),
            (
                Box::new(|f| f.reflectance[4] = 1.01),
                "section REFLECTANCE: element 1, channel g: value 1.01",
            ),
            (
                Box::new(|f| f.emission[17] = -1.0),
                "section EMISSION: element 5, channel b: value -1",
            ),
            (
                Box::new(|f| {
                    f.weights.pop();
                }),
                "section WEIGHTS: expected n = 6 values, found 5",
            ),
            (
                Box::new(|f| f.geometry.vertex_count[2] = 5),
                "section GEOMETRY: element 2: 5 vertices",
            ),
            (
                Box::new(|f| f.geometry.vertices[13] = f32::NAN),
                "section GEOMETRY: element 1: vertex 0: coordinate NaN",
            ),
            (
                Box::new(|f| f.geometry.vertices[12 + 10] = 1.0),
                "section GEOMETRY: element 1: a triangle",
            ),
            (
                Box::new(|f| f.geometry.normals[3] = 0.5),
                "section GEOMETRY: element 1: normal [0.5, 0.0, 1.0]",
            ),
        ];
        for (edit, expected) in cases {
            let got = message(edit);
            assert!(
                got.starts_with(expected),
                "got {got:?}, expected {expected:?}"
            );
        }
    }

    #[test]
    #[cfg(target_pointer_width = "64")]
    fn sizes_overflow_is_limits() {
        // n * k fits in 64 bits, its byte size does not.
        let sizes = Sizes::new(u32::MAX, u32::MAX, 1).unwrap();
        let err = checked_product("section FK", &[sizes.fk as u64, 4]).unwrap_err();
        assert_eq!(err.kind, ErrorKind::Limits);
        let err = Sizes::new(u32::MAX, u32::MAX, 3).unwrap_err();
        assert_eq!(err.kind, ErrorKind::Limits);
        assert!(err.message.contains("CORES"), "{err}");
    }
}
