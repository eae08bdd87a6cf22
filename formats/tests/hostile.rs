//! Hostile inputs: random damage that gets past the checksums, and a bound on what the reader
//! allocates, measured with a counting allocator.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use common::{Rng, rebuild, reseal, samples, set_entry_u64, table_end};
use lrr_formats::{Container, OperatorFile, kind};

/// Counts the live bytes allocated by each thread, and their peak, so that concurrent tests do not
/// disturb each other's measurements.
struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn track(delta: isize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get().wrapping_add(delta);
        live.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

// SAFETY (all four methods): each forwards its arguments unchanged to the system allocator, so the
// caller's contract for `GlobalAlloc` is passed on as is; the counting touches only thread-locals.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: see above.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            track(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: see above.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            track(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: see above.
        unsafe { System.dealloc(ptr, layout) };
        track(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: see above.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            track(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `from_bytes` and returns the peak of extra bytes this thread held meanwhile.
fn peak_allocation(bytes: &[u8]) -> usize {
    let start = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(start));
    let result = OperatorFile::from_bytes(bytes);
    drop(result);
    (PEAK.with(Cell::get) - start).max(0) as usize
}

/// The bound the crate documents: about the size of the input, plus small bookkeeping.
fn allowed(len: usize) -> usize {
    3 * len + 4096
}

/// One random piece of damage to a valid file; half of them keep every checksum valid.
fn damage(rng: &mut Rng, good: &[u8]) -> Vec<u8> {
    let edge = |rng: &mut Rng, len: usize| -> u64 {
        let choices = [
            0,
            1,
            63,
            64,
            len as u64,
            u64::from(u32::MAX),
            u64::MAX,
            u64::MAX - 63,
        ];
        if rng.below(2) == 0 {
            choices[rng.below(choices.len())]
        } else {
            rng.next() >> rng.below(64)
        }
    };
    match rng.below(5) {
        0 => {
            // Raw flips anywhere: the checksums should catch them.
            let mut bad = good.to_vec();
            for _ in 0..1 + rng.below(8) {
                let at = rng.below(bad.len());
                bad[at] ^= 1 << rng.below(8);
            }
            bad
        }
        1 => {
            // A table field set to an edge value, header resealed.
            let mut bad = good.to_vec();
            let entry = rng.below(10);
            let field = [8, 16][rng.below(2)];
            let value = edge(rng, good.len());
            set_entry_u64(&mut bad, entry, field, value);
            bad
        }
        2 => {
            // The section count changed, header resealed.
            let mut bad = good.to_vec();
            let count = [0u32, 1, 9, 11, 1000, u32::MAX][rng.below(6)];
            bad[12..16].copy_from_slice(&count.to_le_bytes());
            if table_end(&bad) <= bad.len() {
                reseal(&mut bad);
            }
            bad
        }
        3 => {
            // A DIMS word set to an edge value, checksums valid.
            let word = rng.below(8);
            let value = edge(rng, good.len()) as u32;
            rebuild(good, |k, p| {
                if k == kind::DIMS {
                    p[4 * word..4 * word + 4].copy_from_slice(&value.to_le_bytes());
                }
            })
        }
        _ => {
            // A payload rewritten, shortened or lengthened, checksums valid.
            let target = kind::KNOWN[rng.below(kind::KNOWN.len())];
            let (mode, at, byte) = (rng.below(3), rng.next() as usize, rng.next() as u8);
            rebuild(good, |k, p| {
                if k != target {
                    return;
                }
                match mode {
                    0 if !p.is_empty() => {
                        let i = at % p.len();
                        p[i] = byte;
                    }
                    1 => p.truncate(at % (p.len() + 1)),
                    _ => p.extend(std::iter::repeat_n(byte, 1 + at % 64)),
                }
            })
        }
    }
}

#[test]
fn random_damage_never_panics_nor_overallocates() {
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    let (mut refused, mut accepted) = (0, 0);
    for file in samples() {
        let good = file.to_bytes().unwrap();
        for _ in 0..20_000 {
            let bad = damage(&mut rng, &good);
            let peak = peak_allocation(&bad);
            assert!(
                peak <= allowed(bad.len()),
                "{peak} bytes for a {}-byte input",
                bad.len()
            );
            match OperatorFile::from_bytes(&bad) {
                Err(e) => {
                    assert!(!e.message.is_empty());
                    refused += 1;
                }
                Ok(decoded) => {
                    // Whatever got through is a valid operator that writes back to a valid file.
                    decoded.validate().unwrap();
                    let again = decoded.to_bytes().unwrap();
                    assert_eq!(OperatorFile::from_bytes(&again).unwrap(), decoded);
                    accepted += 1;
                }
            }
        }
    }
    assert!(refused > 30_000, "refused {refused}, accepted {accepted}");
}

#[test]
fn valid_and_truncated_files_stay_within_the_allocation_bound() {
    for file in samples() {
        let good = file.to_bytes().unwrap();
        // The counter works: decoding a valid file holds about its size in decoded arrays.
        let full = peak_allocation(&good);
        assert!(full >= good.len() / 2, "{full} bytes for {}", good.len());
        for len in 0..=good.len() {
            let peak = peak_allocation(&good[..len]);
            assert!(peak <= allowed(len), "prefix {len}: {peak} bytes");
        }
    }
}

#[test]
fn random_bytes_after_a_valid_header() {
    let mut rng = Rng(42);
    let good = samples()[0].to_bytes().unwrap();
    for _ in 0..5_000 {
        let len = rng.below(2 * good.len());
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
        let keep = rng.below(table_end(&good) + 1).min(len);
        bytes[..keep].copy_from_slice(&good[..keep]);
        if bytes.len() >= 16 && table_end(&bytes) <= bytes.len() {
            reseal(&mut bytes);
        }
        assert!(peak_allocation(&bytes) <= allowed(len));
        let _ = Container::parse(&bytes);
    }
}
