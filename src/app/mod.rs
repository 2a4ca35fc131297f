//! The application layer (feature `app`, part of `cli`): the run loop and its summary
//! (`phyxel run --json`), the run's output folder, the validation suite (`phyxel validate`) and the software
//! splat renderer. The engine does not depend on it.

pub mod hint;
pub mod out_dir;
pub mod render;
pub mod summary;
pub mod validate;
