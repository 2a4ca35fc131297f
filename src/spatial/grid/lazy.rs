//! A grid built on first use after each reset.

use super::Grid;
use crate::columns::Vec3s;
use std::sync::{Mutex, OnceLock};

/// A grid built on first use after each [`LazyGrid::reset`], for queries that are rare
/// (e.g. a far-field fallback): a step that never asks for it never pays for the build.
///
/// Thread-safe (the first caller builds, concurrent callers wait for it) and, once warmed
/// up, allocation-free: a reset keeps the last build's buffers for the next build.
#[derive(Debug, Default)]
pub struct LazyGrid {
    /// The grid of the current points, once someone asked for it.
    built: OnceLock<Grid>,
    /// The previous build, kept for its buffers.
    spare: Mutex<Grid>,
}

impl LazyGrid {
    /// Forgets the current build (the points changed); the next [`LazyGrid::get`] rebuilds
    /// reusing its buffers.
    pub fn reset(&mut self) {
        if let Some(g) = self.built.take() {
            *self.spare.get_mut().unwrap_or_else(|e| e.into_inner()) = g;
        }
    }

    /// The grid of `pos` with cell edge `cell` ([`Grid::rebuild_columns`]), built by the
    /// first call after a reset. Later calls return that build: they must pass the same
    /// points and cell.
    pub fn get(&self, pos: &Vec3s, cell: f32) -> &Grid {
        self.get_with(|g| g.rebuild_columns(pos, cell))
    }

    /// [`LazyGrid::get`] over the points `subset` of `pos` ([`Grid::rebuild_subset`]).
    pub fn get_subset(&self, pos: &Vec3s, subset: &[u32], cell: f32) -> &Grid {
        self.get_with(|g| g.rebuild_subset(pos, subset, cell))
    }

    /// The current build, made by `rebuild` on the spare grid's buffers if there is none.
    fn get_with(&self, rebuild: impl FnOnce(&mut Grid)) -> &Grid {
        self.built.get_or_init(|| {
            let mut spare = self.spare.lock().unwrap_or_else(|e| e.into_inner());
            let mut g = std::mem::take(&mut *spare);
            rebuild(&mut g);
            g
        })
    }
}
