//! No heap allocation in the steady state of a step (performance issue): a counting
//! global allocator counts every allocation and reallocation, on every thread (rayon's
//! workers included), while a warmed-up world steps.
//!
//! Reference: zero. Per-step buffers (grids, detections, contact patches, gathers) keep
//! their capacity between steps and the step's flag lists live in a bumpalo arena reset
//! each step, so once the buffers have grown to the contact's size a step allocates
//! nothing. (Writing render surfaces for frames is output work and may allocate; it is
//! off here, as in a run without `--out`.)

use phyxel::scene::{BuildOptions, Scene};
use phyxel::world::phase::Phase;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Steps `world` `n` times on a rayon pool thread, as `phyxel run` does, and returns
/// the allocations made meanwhile. (Called from outside the pool, each parallel loop
/// injects a job into rayon's global queue, which allocates a 1.5 kB block per 63
/// injections: rayon's cost, not the step's.)
fn allocations_over(world: &mut phyxel::World, n: usize) -> u64 {
    rayon::scope(|_| {
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for _ in 0..n {
            world.step();
        }
        ALLOCATIONS.load(Ordering::SeqCst) - before
    })
}

/// The built-in scene `name`, with default options.
fn built(name: &str) -> phyxel::World {
    Scene::builtin(name)
        .unwrap()
        .build(&BuildOptions::default())
        .unwrap()
}

/// The allocations over `n` steps of `world` after `warm_up` steps, checking that the
/// topology phases (self-collision or the fracture check) did work meanwhile.
fn topology_allocations(world: &mut phyxel::World, warm_up: usize, n: usize) -> u64 {
    let work = |w: &phyxel::World| {
        let t = &w.record.times;
        t.work(Phase::SelfCollision) + t.work(Phase::Topology)
    };
    allocations_over(world, warm_up);
    let checked = work(world);
    let allocs = allocations_over(world, n);
    assert!(work(world) > checked, "the topology phases ran");
    allocs
}

/// One test (the counter is global, so nothing else may run in this binary):
/// a falling body (dynamics, advection, broad phase), a body resting on a plane
/// (every contact phase, every step), a ring folded onto itself (self-collision) and a
/// hanging bar that may break (the fracture check) allocate nothing after warm-up, and
/// neither do a falling body of 100k surfels (its box over parallel chunks) and two
/// such bodies in contact advected lazily.
#[test]
fn steady_state_steps_do_not_allocate() {
    let mut falling = built("falling-sphere");
    allocations_over(&mut falling, 20);
    assert_eq!(allocations_over(&mut falling, 100), 0, "falling-sphere");

    let mut resting = built("sphere-on-plane");
    allocations_over(&mut resting, 1500);
    let forced = resting.record.times.work(Phase::Forces);
    let n = 200;
    let allocs = allocations_over(&mut resting, n);
    let per_step = (resting.record.times.work(Phase::Forces) - forced) / n as u64;
    assert!(
        per_step > 50,
        "the ball must rest on the plane ({per_step} contact surfels/step)"
    );
    assert_eq!(
        allocs, 0,
        "sphere-on-plane at rest, {per_step} contact surfels/step"
    );

    // The folded ring of `self-contact` (its arcs touch from about step 350 on):
    // the self-collision force's grid and sums allocate nothing either.
    let mut ring = built("self-contact");
    let allocs = topology_allocations(&mut ring, 600, 100);
    assert_eq!(allocs, 0, "self-contact, arcs in contact");

    // The bar of `plastic-fracture`, made elastic so that it hangs without tearing:
    // the fracture check runs every step and finds one piece, allocating nothing.
    let mut scene = Scene::builtin("plastic-fracture").unwrap();
    scene.objects[1].material.make_elastic();
    let mut bar = scene.build(&BuildOptions::default()).unwrap();
    let allocs = topology_allocations(&mut bar, 300, 100);
    assert_eq!(bar.objects.len(), 2, "the elastic bar stays whole");
    assert_eq!(allocs, 0, "plastic-fracture bar, elastic, hanging");

    // A 100k-surfel falling body: above `broad_phase::PARALLEL_CHUNK` surfels, its box
    // is taken over parallel chunks.
    let big = BuildOptions {
        surfels: Some(100_000),
        ..Default::default()
    };
    let mut fine = Scene::builtin("falling-sphere")
        .unwrap()
        .build(&big)
        .unwrap();
    assert!(fine.objects[0].surfels.len() > phyxel::spatial::broad_phase::PARALLEL_CHUNK);
    allocations_over(&mut fine, 5);
    assert_eq!(
        allocations_over(&mut fine, 20),
        0,
        "falling-sphere, 100k surfels"
    );

    // Two 100k-surfel spheres pressed together, advected lazily (`phyxel run`'s way):
    // the outline, the blocks near the contact, and the rest left stale.
    let mut pressed = Scene::builtin("scale").unwrap().build(&big).unwrap();
    pressed.lazy_advection = true;
    allocations_over(&mut pressed, 300);
    let allocs = allocations_over(&mut pressed, 30);
    assert!(pressed.objects.iter().any(|o| !o.surfels_current()));
    assert_eq!(allocs, 0, "scale, 100k surfels, lazy advection");
}
