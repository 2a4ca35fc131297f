//! Helpers shared by the integration tests (each test file that needs them declares
//! `mod common;`; not every file uses every helper, hence the `dead_code` allowances).

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};
use std::path::PathBuf;

/// `scene` built with `backend` on its moving objects (`None`: the scene's own), or a
/// panic naming the scene, the backend and the error.
#[allow(dead_code)]
pub fn build(scene: &Scene, backend: Option<&str>) -> World {
    let options = BuildOptions {
        backend: backend.map(str::to_string),
        ..Default::default()
    };
    scene
        .build(&options)
        .unwrap_or_else(|e| panic!("{} ({backend:?}): {e}", scene.name))
}

/// A fresh temp directory `phyxel-{group}-{label}-{pid}`, removed on drop.
#[allow(dead_code)]
pub struct TempDir(pub PathBuf);

impl TempDir {
    #[allow(dead_code)]
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

/// The bits of every phyxel and surfel position and velocity of `w`, in object order:
/// two runs that must agree bitwise compare these.
#[allow(dead_code)]
pub fn state_bits(w: &phyxel::World) -> Vec<u32> {
    w.objects.iter().flat_map(object_bits).collect()
}

/// [`state_bits`] of one object.
#[allow(dead_code)]
pub fn object_bits(o: &phyxel::body::object::Object) -> Vec<u32> {
    let mut out = Vec::new();
    for col in [
        &o.phyxels.pos,
        &o.phyxels.vel,
        &o.surfels.pos,
        &o.surfels.vel,
    ] {
        for v in [&col.x, &col.y, &col.z] {
            out.extend(v.iter().map(|x| x.to_bits()));
        }
    }
    out
}
