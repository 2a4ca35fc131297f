//! How finely the parallel loops split. A rayon task handed to the second thread costs
//! its wake-up (tens of µs on a sleeping thread): a loop that splits into tasks shorter
//! than that runs slower on two threads than on one. The step's loops over points take
//! at least [`point_task`] phyxels ([`SURFEL_TASK`] surfels) a task, and its loops over
//! objects split only when more than one object has work ([`grain`]).

use std::cell::Cell;

/// Phyxels per rayon task in a per-phyxel loop that gathers a stencil (50–100 ns a point)
/// of a body stepping alone: a body below twice this runs its loops on the calling
/// thread.
pub const POINT_TASK: usize = 512;

/// [`POINT_TASK`] for a body stepping beside others: the other thread is awake with
/// their work, so smaller tasks balance the bodies without waking it (three 280-phyxel
/// bodies on two threads are otherwise three tasks, one thread taking two).
pub const SHARED_POINT_TASK: usize = 64;

thread_local! {
    static TASK: Cell<usize> = const { Cell::new(POINT_TASK) };
}

/// Phyxels per task for the per-phyxel loops started on this thread now:
/// [`POINT_TASK`], or what [`with_point_task`] set.
pub fn point_task() -> usize {
    TASK.with(Cell::get)
}

/// Runs `f` with [`point_task`] at `task` on this thread.
pub fn with_point_task<R>(task: usize, f: impl FnOnce() -> R) -> R {
    let before = TASK.with(|t| t.replace(task));
    let out = f();
    TASK.with(|t| t.set(before));
    out
}

/// Surfels per rayon task in advection (a few ns a surfel).
pub const SURFEL_TASK: usize = 8192;

/// The `with_min_len` of a parallel loop over items of which `active` says which have
/// work: one item a task when several have, else one task for the whole loop (a second
/// thread woken for an idle item costs more than the loop; the busy item's own loops
/// still split).
pub fn grain(active: impl IntoIterator<Item = bool>) -> usize {
    let (mut items, mut busy) = (0usize, 0usize);
    for a in active {
        items += 1;
        busy += usize::from(a);
    }
    grain_of(items, busy)
}

/// [`grain`] of a loop over `items` items of which `busy` have work.
pub fn grain_of(items: usize, busy: usize) -> usize {
    if busy > 1 { 1 } else { items.max(1) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_busy_item_keeps_the_loop_whole() {
        assert_eq!(grain([false, true, false]), 3);
        assert_eq!(grain([true, true, false]), 1);
        assert_eq!(grain(std::iter::empty()), 1);
        assert_eq!(grain_of(1, 1), 1);
        assert_eq!(grain_of(4, 2), 1);
    }
}
