//! `phyxel view --frames DIR`: plays the surfel frames `phyxel run --out DIR` wrote
//! (`surfels_NNNNN.ply`), with a timeline slider.

use phyxel::io::frame::Frame;
use phyxel::io::import::read_frame;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Frames shown per second while playing.
const PLAY_RATE: f64 = 25.0;

/// A folder of frames and the one shown.
pub(crate) struct Replay {
    pub dir: PathBuf,
    /// Frame files by frame number (index = frame number when none is missing).
    files: Vec<PathBuf>,
    /// The frame shown (the slider's value).
    pub index: u64,
    pub playing: bool,
    last_advance: Instant,
    loaded: Option<(u64, Frame)>,
    /// The frame that could not be read (not read again until another is shown).
    failed: Option<u64>,
    pub error: Option<String>,
}

impl Replay {
    /// The surfel frames in `dir`, in frame order; an error when there are none.
    pub(crate) fn open(dir: &Path) -> Result<Self, String> {
        let entries =
            std::fs::read_dir(dir).map_err(|e| format!("--frames {}: {e}", dir.display()))?;
        let mut files: Vec<(u64, PathBuf)> = entries
            .filter_map(|e| e.ok())
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let number = name.strip_prefix("surfels_")?.strip_suffix(".ply")?;
                Some((number.parse().ok()?, e.path()))
            })
            .collect();
        if files.is_empty() {
            return Err(format!(
                "--frames {}: no surfel frames (surfels_NNNNN.ply, written by `phyxel run SCENE \
                 --out DIR`)",
                dir.display()
            ));
        }
        files.sort();
        Ok(Self {
            dir: dir.to_path_buf(),
            files: files.into_iter().map(|f| f.1).collect(),
            index: 0,
            playing: false,
            last_advance: Instant::now(),
            loaded: None,
            failed: None,
            error: None,
        })
    }

    pub(crate) fn len(&self) -> u64 {
        self.files.len() as u64
    }

    /// Moves to the next frame when playing and its time has come (looping).
    pub(crate) fn advance(&mut self) {
        let due = Duration::from_secs_f64(1.0 / PLAY_RATE);
        if self.playing && self.last_advance.elapsed() >= due {
            self.last_advance = Instant::now();
            self.index = (self.index + 1) % self.len();
        }
    }

    /// The frame at `index` (read once) and its index; `None` with `error` set when it
    /// cannot be read.
    pub(crate) fn current(&mut self) -> Option<(&Frame, u64)> {
        let i = self.index.min(self.len() - 1);
        if self.failed == Some(i) {
            return None;
        }
        if self.loaded.as_ref().is_none_or(|l| l.0 != i) {
            match read_frame(&self.files[i as usize]) {
                Ok(f) => {
                    self.loaded = Some((i, f));
                    self.error = None;
                }
                Err(e) => {
                    self.error = Some(e);
                    self.failed = Some(i);
                    return None;
                }
            }
        }
        self.loaded.as_ref().map(|(i, f)| (f, *i))
    }
}
