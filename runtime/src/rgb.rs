//! RGB buffers owned by the caller, interleaved or planar, one value per element in original id
//! order: what a frame reads (emission) and writes (radiosity).

use crate::error::{RuntimeError, input};

/// Read-only RGB values per element (original element ids).
#[derive(Debug, Clone, Copy)]
pub enum Rgb<'a> {
    /// `[r0, g0, b0, r1, g1, b1, …]`: `3 n` values.
    Interleaved(&'a [f32]),
    /// Three planes `[r, g, b]` of `n` values each.
    Planar([&'a [f32]; 3]),
}

/// Writable RGB values per element (original element ids).
#[derive(Debug)]
pub enum RgbMut<'a> {
    /// `[r0, g0, b0, r1, g1, b1, …]`: `3 n` values.
    Interleaved(&'a mut [f32]),
    /// Three planes `[r, g, b]` of `n` values each.
    Planar([&'a mut [f32]; 3]),
}

impl<'a> Rgb<'a> {
    /// Interleaved values from `[r, g, b]` triples.
    pub fn triples(values: &'a [[f32; 3]]) -> Self {
        Rgb::Interleaved(values.as_flattened())
    }

    /// Refuses a buffer that does not hold `n` elements.
    pub(crate) fn check(&self, n: usize, what: &str) -> Result<(), RuntimeError> {
        check_lengths(self.lengths(), n, what)
    }

    fn lengths(&self) -> Lengths {
        match self {
            Rgb::Interleaved(v) => Lengths::Interleaved(v.len()),
            Rgb::Planar(p) => Lengths::Planar(p.each_ref().map(|c| c.len())),
        }
    }
}

impl<'a> RgbMut<'a> {
    /// Interleaved values from `[r, g, b]` triples.
    pub fn triples(values: &'a mut [[f32; 3]]) -> Self {
        RgbMut::Interleaved(values.as_flattened_mut())
    }

    /// Refuses a buffer that does not hold `n` elements.
    pub(crate) fn check(&self, n: usize, what: &str) -> Result<(), RuntimeError> {
        let lengths = match self {
            RgbMut::Interleaved(v) => Lengths::Interleaved(v.len()),
            RgbMut::Planar(p) => Lengths::Planar(p.each_ref().map(|c| c.len())),
        };
        check_lengths(lengths, n, what)
    }
}

enum Lengths {
    Interleaved(usize),
    Planar([usize; 3]),
}

fn check_lengths(lengths: Lengths, n: usize, what: &str) -> Result<(), RuntimeError> {
    match lengths {
        Lengths::Interleaved(len) if len != 3 * n => Err(input(format!(
            "{what}: an interleaved RGB buffer must hold 3 values for each of the n = {n} \
             elements ({} values), found {len}",
            3 * n
        ))),
        Lengths::Planar(lens) if lens != [n; 3] => Err(input(format!(
            "{what}: each plane of a planar RGB buffer must hold one value for each of the \
             n = {n} elements, found planes of {lens:?}"
        ))),
        _ => Ok(()),
    }
}

impl Rgb<'_> {
    /// Element `i` of a checked buffer (`i < n`). A match per element: the branch always goes
    /// the same way, and this is O(n) next to the frame's O(nk) pass.
    #[inline]
    pub(crate) fn at(&self, i: usize) -> [f32; 3] {
        match self {
            Rgb::Interleaved(v) => [v[3 * i], v[3 * i + 1], v[3 * i + 2]],
            Rgb::Planar([r, g, b]) => [r[i], g[i], b[i]],
        }
    }
}

impl RgbMut<'_> {
    /// Sets element `i` of a checked buffer (`i < n`).
    #[inline]
    pub(crate) fn set(&mut self, i: usize, v: [f32; 3]) {
        match self {
            RgbMut::Interleaved(out) => out[3 * i..3 * i + 3].copy_from_slice(&v),
            RgbMut::Planar([r, g, b]) => (r[i], g[i], b[i]) = (v[0], v[1], v[2]),
        }
    }

    /// Element `i` of a checked buffer (`i < n`).
    #[inline]
    pub(crate) fn get(&self, i: usize) -> [f32; 3] {
        match self {
            RgbMut::Interleaved(v) => [v[3 * i], v[3 * i + 1], v[3 * i + 2]],
            RgbMut::Planar([r, g, b]) => [r[i], g[i], b[i]],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_are_checked_with_a_clear_message() {
        let v = [0.0f32; 9];
        assert!(Rgb::Interleaved(&v).check(3, "emission").is_ok());
        let e = Rgb::Interleaved(&v[..8]).check(3, "emission").unwrap_err();
        assert_eq!(
            e.to_string(),
            "emission: an interleaved RGB buffer must hold 3 values for each of the n = 3 \
             elements (9 values), found 8"
        );
        let e = Rgb::Planar([&v[..3], &v[..3], &v[..2]])
            .check(3, "emission")
            .unwrap_err();
        assert!(e.to_string().contains("planes of [3, 3, 2]"), "{e}");
        let mut w = [0.0f32; 6];
        let [a, b] = w.split_at_mut(3).into();
        assert!(RgbMut::Planar([a, b, &mut []]).check(3, "out").is_err());
    }

    #[test]
    fn forms_agree() {
        let inter = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let planes = [[1.0, 4.0], [2.0, 5.0], [3.0, 6.0]];
        let a = Rgb::Interleaved(&inter);
        let b = Rgb::Planar(planes.each_ref().map(|p| &p[..]));
        let mut out = [[0.0f32; 2]; 3];
        let [r, g, bl] = &mut out;
        let mut w = RgbMut::Planar([r, g, bl]);
        for i in 0..2 {
            assert_eq!(a.at(i), b.at(i));
            w.set(i, a.at(i));
            assert_eq!(w.get(i), a.at(i));
        }
        assert_eq!(out, planes);
    }
}
