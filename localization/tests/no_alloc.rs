//! predict/update must not allocate (sweeps run thousands of filters): counted with a global
//! allocator that tallies allocations made on the current thread.

use atrium_localization::{InitialBelief, Localizer, Mcl, MclParams, OdometryDelta};
use atrium_robots::{LaserScan, Pose2, Reading};
use atrium_worlds::{Cell, OccupancyGrid};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell as StdCell;

struct Counting;

thread_local! {
    static ALLOCATIONS: StdCell<usize> = const { StdCell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> usize {
    ALLOCATIONS.with(|a| a.get())
}

#[test]
fn predict_and_update_do_not_allocate() {
    // 10 × 10 m box with a wall stub, 0.05 m.
    let (w, h) = (200, 200);
    let mut cells = vec![Cell::Free; w * h];
    for j in 0..h {
        for i in 0..w {
            if i == 0 || j == 0 || i == w - 1 || j == h - 1 || (i == 120 && j < 90) {
                cells[j * w + i] = Cell::Occupied;
            }
        }
    }
    let grid = OccupancyGrid {
        origin: [0.0, 0.0],
        resolution: 0.05,
        width: w,
        height: h,
        cells,
    };
    let scan = Reading::Laser(LaserScan {
        stamp: 0.0,
        sensor: "laser".into(),
        mount: Pose2::new(0.1, 0.0, 0.0),
        angle_min: -1.5,
        angle_increment: 0.02,
        range_min: 0.05,
        // A range_max different from the table's nominal one exercises the in-place rebuild.
        range_max: 5.6,
        ranges: (0..151)
            .map(|k| {
                if k % 7 == 0 {
                    5.6
                } else {
                    2.0 + 0.01 * k as f64
                }
            })
            .collect(),
    });
    // Global start: 5000 particles, KLD shrinks and regrows the set, injection is active.
    let mut mcl = Mcl::new(
        "mcl",
        MclParams::default(),
        &grid,
        InitialBelief::Global { regions: vec![] },
        5,
    )
    .unwrap();
    let mut odom = Pose2::default();
    // The counter does see allocations on this thread.
    let probe = allocations();
    std::hint::black_box(Vec::<u8>::with_capacity(16));
    assert_eq!(allocations(), probe + 1);
    let before = allocations();
    for k in 0..50 {
        let next = odom.compose(&Pose2::new(0.05, 0.0, if k % 3 == 1 { 0.1 } else { 0.0 }));
        mcl.predict(&OdometryDelta {
            stamp: k as f64,
            from: odom,
            to: next,
        })
        .unwrap();
        odom = next;
        mcl.update(&scan).unwrap();
        std::hint::black_box(mcl.estimate());
    }
    assert_eq!(allocations() - before, 0);
    assert!(mcl.particle_count() >= 500);
}
