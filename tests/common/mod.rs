//! Helpers shared by the integration tests (each test file that needs them declares
//! `mod common;`).

use std::path::PathBuf;

/// A fresh temp directory `phyxel-{group}-{label}-{pid}`, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(group: &str, label: &str) -> Self {
        let p = std::env::temp_dir().join(format!("phyxel-{group}-{label}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Self(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
