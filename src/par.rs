//! How finely the parallel loops split. A rayon task handed to the second thread costs
//! its wake-up (tens of µs on a sleeping thread): a loop that splits into tasks shorter
//! than that runs slower on two threads than on one. The step's loops over points take
//! at least [`POINT_TASK`] phyxels ([`SURFEL_TASK`] surfels) a task, and its loops over
//! objects split only when more than one object has work ([`grain`]).

/// Phyxels per rayon task in a per-phyxel loop that gathers a stencil (50–100 ns a point):
/// a body below twice this runs its loops on the calling thread.
pub const POINT_TASK: usize = 512;

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
    }
}
