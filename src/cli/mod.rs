//! The commands of the `phyxel` binary, one module each; `main.rs` parses the arguments
//! and dispatches to them.

pub mod compare;
pub mod profile;
pub mod render;
pub mod run;
pub mod scenes;
pub mod validate;
#[cfg(feature = "view")]
pub mod view;
