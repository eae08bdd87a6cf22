//! A frame allocates nothing: every allocation of the process is counted, on every thread, while
//! an evaluator (and the benchmarks' dense-V baseline) renders frames and a one-thread lightmap
//! fills (one test in this binary, so no other test allocates meanwhile).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use lrr_formats::{Layout as OperatorLayout, Precision};
use lrr_runtime::testkit::{baseline::DenseV, faces, synthetic};
use lrr_runtime::{Lightmap, LightmapValues, Rgb, RgbMut};

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

fn count() {
    if COUNTING.load(Ordering::Relaxed) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY (all three methods): each forwards its arguments unchanged to the system allocator, so
// the caller's contract for `GlobalAlloc` is passed on as is; the counting touches only atomics.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: see above.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: see above.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: see above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[test]
fn frames_allocate_nothing() {
    for (layout, channels) in [(OperatorLayout::Factored, 3), (OperatorLayout::PlainYk, 3)] {
        let op = synthetic::operator(3001, 40, channels, Precision::F16, layout, 1).unwrap();
        let n = op.n();
        let e = op.baked_emission();
        let planes: [Vec<f32>; 3] = std::array::from_fn(|c| e.iter().map(|v| v[c]).collect());
        let mut out = vec![[0.0f32; 3]; n];
        let mut out_planes: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let a = vec![1.0f32; op.light_groups().len()];
        let mut eval = op.evaluator(3).unwrap();
        // The benchmarks' dense-V baseline is held to the same rule.
        let mut dense = DenseV::new(&op, 3).unwrap();
        let mut frame = |counting: bool| {
            COUNTING.store(counting, Ordering::SeqCst);
            eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
                .unwrap();
            let [r, g, b] = &mut out_planes;
            let planar = Rgb::Planar(planes.each_ref().map(|p| &p[..]));
            eval.evaluate(planar, RgbMut::Planar([r, g, b])).unwrap();
            eval.evaluate_groups(&a, RgbMut::triples(&mut out)).unwrap();
            std::hint::black_box(eval.read_pass().unwrap());
            dense
                .evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
                .unwrap();
            std::hint::black_box(dense.read_pass().unwrap());
            COUNTING.store(false, Ordering::SeqCst);
        };
        // The first frames may set up the channels' thread-local parking state.
        frame(false);
        frame(false);
        for _ in 0..20 {
            frame(true);
        }
        let allocations = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(
            allocations, 0,
            "{layout:?}: {allocations} allocations in 20 frames"
        );
        assert!(eval.scratch_bytes() >= 12 * n);
        // The counter works: the one-call form allocates its scratch.
        COUNTING.store(true, Ordering::SeqCst);
        op.evaluate(&e, &mut out).unwrap();
        COUNTING.store(false, Ordering::SeqCst);
        assert!(ALLOCATIONS.swap(0, Ordering::SeqCst) > 0);
    }
    // A lightmap fill on one thread, smooth and flat, whole and in its two halves.
    let file = faces::lightmapped(|x, y| [0.1 + x / 2.5, 0.05 + y * 0.7], 97, 61, 3);
    let mut b = vec![[0.0f32; 3]; 2];
    for (s, &id) in faces::ORDER.iter().enumerate() {
        b[id as usize] = faces::EMISSION[s];
    }
    let mut texels = vec![[0.0f32; 3]; 97 * 61];
    for values in [LightmapValues::Smooth, LightmapValues::Flat] {
        let mut map = Lightmap::new(&file, Some(values)).unwrap();
        map.fill(&b, &mut texels).unwrap();
        COUNTING.store(true, Ordering::SeqCst);
        for _ in 0..5 {
            map.fill(&b, &mut texels).unwrap();
            map.fill_samples(&b, &mut texels).unwrap();
            map.dilate(&mut texels).unwrap();
        }
        COUNTING.store(false, Ordering::SeqCst);
        let allocations = ALLOCATIONS.swap(0, Ordering::SeqCst);
        assert_eq!(
            allocations, 0,
            "{values:?} lightmap: {allocations} allocations"
        );
    }
}
