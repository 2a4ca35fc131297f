//! `run --flamegraph`: the sampling profiler, its SVG, and the frames of most own time.

use phyxel::io::atomic::AtomicFile;
use std::path::Path;

/// A sampling profiler (timer signal, so no perf permissions are needed) and the file
/// its flamegraph goes to, started (as a hidden temporary, [`AtomicFile`]) before the
/// run so that a bad path fails at once, not after the whole run.
pub(crate) fn start_profiler(
    path: &Path,
) -> Result<(pprof::ProfilerGuard<'static>, AtomicFile), String> {
    let file = AtomicFile::create(path).map_err(|e| e.to_string())?;
    let guard = pprof::ProfilerGuardBuilder::default()
        .frequency(997)
        .blocklist(&["libc", "libgcc", "pthread", "vdso"])
        .build()
        .map_err(|e| format!("cannot start the profiler: {e}"))?;
    Ok((guard, file))
}

/// Frames listed after a flamegraph is written.
pub(crate) const TOP_FRAMES: usize = 5;

/// Writes the flamegraph and returns its samples with the [`TOP_FRAMES`] frames of most
/// own time; `Ok(None)` when the profiler took no sample (a run shorter than its 1 ms
/// period): there is no graph to draw, and an empty SVG is no picture.
///
/// The SVG is drawn into memory and then written: pprof's writer unwraps its own write
/// errors, so a full disk (or `/dev/full`) panicked inside it.
pub(crate) fn write_flamegraph(
    guard: &pprof::ProfilerGuard<'_>,
    mut file: AtomicFile,
) -> Result<Option<OwnTime>, String> {
    use std::io::Write;
    let report = guard.report().build().map_err(|e| e.to_string())?;
    if report.data.is_empty() {
        return Ok(None);
    }
    let mut svg = Vec::new();
    report.flamegraph(&mut svg).map_err(|e| e.to_string())?;
    file.write_all(&svg)
        .and_then(|()| file.commit())
        .map_err(|e| format!("cannot write the flamegraph: {e}"))?;
    // The innermost symbol of a stack (inlined callees first) is the flamegraph's leaf.
    let leaves = report.data.iter().map(|(stack, &n)| {
        let leaf = stack.frames.first().and_then(|f| f.first());
        (
            leaf.map_or_else(|| "[unknown]".to_string(), |s| s.name()),
            n,
        )
    });
    Ok(Some(own_time(leaves, TOP_FRAMES)))
}

/// A profile's sample count and its frames of most own time, with their percentages.
pub(crate) struct OwnTime {
    pub samples: isize,
    pub top: Vec<(String, f64)>,
}

/// Sums the samples of `(leaf frame, samples)` stacks by frame (the symbol hash left
/// out, so that one function is one frame) and keeps the `k` largest, largest first
/// (equal counts by name). These are the widest tops of the flamegraph: where the time
/// is spent, as opposed to the phases that call it.
pub(crate) fn own_time(leaves: impl Iterator<Item = (String, isize)>, k: usize) -> OwnTime {
    let mut by_frame = std::collections::HashMap::<String, isize>::new();
    let mut samples = 0;
    for (name, n) in leaves {
        let name = match name.rsplit_once("::h") {
            Some((f, hash)) if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) => {
                f.to_string()
            }
            _ => name,
        };
        *by_frame.entry(name).or_default() += n;
        samples += n;
    }
    let mut top: Vec<(String, isize)> = by_frame.into_iter().collect();
    top.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    top.truncate(k);
    let share = |n: isize| 100.0 * n as f64 / samples.max(1) as f64;
    OwnTime {
        samples,
        top: top.into_iter().map(|(f, n)| (f, share(n))).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::own_time;

    /// `own_time` against a hand count: samples summed per frame across stacks, symbol
    /// hashes left out (two hashes of one function are one frame; a name that only looks
    /// like a hash suffix is kept whole), shares of all samples, largest first, ties by
    /// name, cut to `k`.
    #[test]
    fn own_time_sums_frames_and_ranks_them() {
        let leaves = [
            ("phyxel::body::advect::h0123456789abcdef", 30),
            ("phyxel::contact::detect", 25),
            ("phyxel::body::advect::h1111111111111111", 15),
            ("f32::mul", 25),
            ("a::hnot_a_hash", 5),
        ];
        let own = own_time(leaves.iter().map(|&(f, n)| (f.to_string(), n)), 3);
        assert_eq!(own.samples, 100);
        let top: Vec<(&str, f64)> = own.top.iter().map(|(f, p)| (f.as_str(), *p)).collect();
        assert_eq!(
            top,
            [
                ("phyxel::body::advect", 45.0),
                ("f32::mul", 25.0),
                ("phyxel::contact::detect", 25.0)
            ]
        );
    }
}
