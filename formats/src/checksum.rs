//! Section checksums: XXH64 (seed 0), hand-written.
//!
//! XXH64 (Yann Collet, <https://github.com/Cyan4973/xxHash/blob/dev/doc/xxhash_spec.md>) reads
//! the input 8 bytes at a time, little-endian, into four independent lanes (multiply, rotate,
//! multiply: the CPU overlaps the lanes), then folds the lanes, the length and the tail bytes and
//! finishes with an avalanche. It runs at several GB/s, so verifying a file costs about as much as
//! reading it. Being exactly XXH64, a file can be checked with any other implementation
//! (`xxhsum -H64`, Python's `xxhash.xxh64`).
//!
//! Every step that takes in a word (`acc + w * P2`, rotate, `* P1` with odd `P1`, `^`, `+`) is a
//! bijection of the state for fixed other inputs, so changing any single word, and hence any
//! single byte, always changes the result; other damage goes unnoticed with probability about
//! 2⁻⁶⁴. This detects *corruption* (a bad disk, a cut-off copy, a flipped bit), not *tampering*:
//! it is not a cryptographic hash, and anyone can recompute it after editing a file.

const P1: u64 = 0x9E37_79B1_85EB_CA87;
const P2: u64 = 0xC2B2_AE3D_27D4_EB4F;
const P3: u64 = 0x1656_67B1_9E37_79F9;
const P4: u64 = 0x85EB_CA77_C2B2_AE63;
const P5: u64 = 0x27D4_EB2F_1656_67C5;

/// The XXH64 hash (seed 0) of `data`: the checksum stored for headers and sections.
///
/// ```
/// assert_eq!(lrr_formats::checksum(b""), 0xEF46_DB37_51D8_E999);
/// assert_eq!(lrr_formats::checksum(b"abc"), 0x44BC_2CF5_AD77_0999);
/// ```
pub fn checksum(data: &[u8]) -> u64 {
    let mut stripes = data.chunks_exact(32);
    let mut h = if data.len() >= 32 {
        let mut lanes = [P1.wrapping_add(P2), P2, 0, P1.wrapping_neg()];
        for stripe in &mut stripes {
            for (lane, word) in lanes.iter_mut().zip(stripe.chunks_exact(8)) {
                *lane = round(*lane, le_u64(word));
            }
        }
        let [a, b, c, d] = lanes;
        let mut h = a
            .rotate_left(1)
            .wrapping_add(b.rotate_left(7))
            .wrapping_add(c.rotate_left(12))
            .wrapping_add(d.rotate_left(18));
        for lane in lanes {
            h = merge(h, lane);
        }
        h
    } else {
        P5
    };
    h = h.wrapping_add(data.len() as u64);
    tail(h, stripes.remainder())
}

/// XXH64 of data that arrives in pieces: [`Xxh64::finish`] equals [`checksum`] of the pieces
/// joined, however they were cut (for payloads too large to hold, written as they stream).
///
/// ```
/// let mut h = lrr_formats::Xxh64::new();
/// h.update(b"a");
/// h.update(b"bc");
/// assert_eq!(h.finish(), lrr_formats::checksum(b"abc"));
/// ```
#[derive(Debug, Clone)]
pub struct Xxh64 {
    lanes: [u64; 4],
    buffer: [u8; 32],
    buffered: usize,
    total: u64,
}

impl Default for Xxh64 {
    fn default() -> Self {
        Self::new()
    }
}

impl Xxh64 {
    /// A hasher that has seen nothing (seed 0).
    pub fn new() -> Self {
        Self {
            lanes: [P1.wrapping_add(P2), P2, 0, P1.wrapping_neg()],
            buffer: [0; 32],
            buffered: 0,
            total: 0,
        }
    }

    /// Takes in the next bytes.
    pub fn update(&mut self, mut data: &[u8]) {
        self.total += data.len() as u64;
        if self.buffered > 0 {
            let take = (32 - self.buffered).min(data.len());
            self.buffer[self.buffered..self.buffered + take].copy_from_slice(&data[..take]);
            self.buffered += take;
            data = &data[take..];
            if self.buffered < 32 {
                return;
            }
            let stripe = self.buffer;
            self.stripe(&stripe);
            self.buffered = 0;
        }
        let mut stripes = data.chunks_exact(32);
        for stripe in &mut stripes {
            self.stripe(stripe);
        }
        let rest = stripes.remainder();
        self.buffer[..rest.len()].copy_from_slice(rest);
        self.buffered = rest.len();
    }

    fn stripe(&mut self, stripe: &[u8]) {
        for (lane, word) in self.lanes.iter_mut().zip(stripe.chunks_exact(8)) {
            *lane = round(*lane, le_u64(word));
        }
    }

    /// The hash of everything taken in so far.
    pub fn finish(&self) -> u64 {
        let mut h = if self.total >= 32 {
            let [a, b, c, d] = self.lanes;
            let mut h = a
                .rotate_left(1)
                .wrapping_add(b.rotate_left(7))
                .wrapping_add(c.rotate_left(12))
                .wrapping_add(d.rotate_left(18));
            for lane in self.lanes {
                h = merge(h, lane);
            }
            h
        } else {
            P5
        };
        h = h.wrapping_add(self.total);
        tail(h, &self.buffer[..self.buffered])
    }
}

/// Folds the last `< 32` bytes: whole words, one half word, then single bytes.
fn tail(mut h: u64, rest: &[u8]) -> u64 {
    let mut words = rest.chunks_exact(8);
    for word in &mut words {
        h ^= round(0, le_u64(word));
        h = h.rotate_left(27).wrapping_mul(P1).wrapping_add(P4);
    }
    let mut rest = words.remainder();
    if let Some((half, after)) = rest.split_first_chunk::<4>() {
        h ^= u64::from(u32::from_le_bytes(*half)).wrapping_mul(P1);
        h = h.rotate_left(23).wrapping_mul(P2).wrapping_add(P3);
        rest = after;
    }
    for &byte in rest {
        h ^= u64::from(byte).wrapping_mul(P5);
        h = h.rotate_left(11).wrapping_mul(P1);
    }
    avalanche(h)
}

#[inline(always)]
fn round(acc: u64, word: u64) -> u64 {
    acc.wrapping_add(word.wrapping_mul(P2))
        .rotate_left(31)
        .wrapping_mul(P1)
}

#[inline(always)]
fn merge(acc: u64, lane: u64) -> u64 {
    (acc ^ round(0, lane)).wrapping_mul(P1).wrapping_add(P4)
}

fn avalanche(mut h: u64) -> u64 {
    h ^= h >> 33;
    h = h.wrapping_mul(P2);
    h ^= h >> 29;
    h = h.wrapping_mul(P3);
    h ^ (h >> 32)
}

/// `word` has exactly 8 bytes (from `chunks_exact(8)`).
#[inline(always)]
fn le_u64(word: &[u8]) -> u64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(word);
    u64::from_le_bytes(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference values from libxxhash 0.8.1 (`XXH64(data, len, 0)`).
    #[test]
    fn matches_reference_xxh64() {
        assert_eq!(checksum(b""), 0xef46_db37_51d8_e999);
        assert_eq!(checksum(b"a"), 0xd24e_c4f1_a98c_6e5b);
        assert_eq!(checksum(b"abc"), 0x44bc_2cf5_ad77_0999);
        assert_eq!(
            checksum(b"0123456789abcdef0123456789abcdef"),
            0x642a_9495_8e71_e6c5
        );
        let ramp: Vec<u8> = (0..100u8).collect();
        assert_eq!(checksum(&ramp), 0x6ac1_e580_3216_6597);
        let mut long: Vec<u8> = (0..4).flat_map(|_| 0..=255u8).collect();
        long.extend_from_slice(b"xyz");
        assert_eq!(checksum(&long), 0xe146_cb31_b65b_c21a);
    }

    #[test]
    fn every_single_byte_change_is_detected() {
        // Lengths cover every tail shape (words, half word, bytes) with and without stripes.
        for len in [1usize, 3, 4, 7, 8, 13, 31, 32, 33, 64, 77] {
            let data: Vec<u8> = (0..len).map(|i| (i * 37 + 11) as u8).collect();
            let reference = checksum(&data);
            for at in 0..len {
                for mask in [0x01u8, 0x80, 0xFF] {
                    let mut bad = data.clone();
                    bad[at] ^= mask;
                    assert_ne!(checksum(&bad), reference, "len {len} byte {at} ^ {mask:#x}");
                }
            }
        }
    }

    #[test]
    fn length_matters() {
        // Trailing zeros must not vanish.
        assert_ne!(checksum(&[0; 5]), checksum(&[0; 6]));
        assert_ne!(checksum(&[0; 32]), checksum(&[0; 40]));
    }

    #[test]
    fn streaming_equals_one_shot_for_every_cut() {
        let data: Vec<u8> = (0..300u32).map(|i| (i * 151 + 7) as u8).collect();
        for len in [0usize, 1, 31, 32, 33, 63, 64, 65, 100, 300] {
            let reference = checksum(&data[..len]);
            for piece in [1usize, 3, 8, 31, 32, 33, 97] {
                let mut h = Xxh64::new();
                for chunk in data[..len].chunks(piece) {
                    h.update(chunk);
                }
                assert_eq!(h.finish(), reference, "len {len} in pieces of {piece}");
            }
        }
    }
}
