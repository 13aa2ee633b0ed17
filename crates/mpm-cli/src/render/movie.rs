//! `render --movie`: the rendered frames assembled into an MP4 or a GIF by `ffmpeg`, when it is
//! installed (it is not a dependency: without it the command says so and keeps the pictures).

use super::MovieFormat;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Frames per second of the movie.
const FPS: u32 = 10;

/// Why no movie was made, for the user.
#[derive(Debug)]
pub(super) struct Skipped(pub String);

/// Assembles `count` consecutive pictures `dir/frame_NNNNNN{suffix}.png` from frame `first` into
/// `dir/movie{suffix}.mp4` (or `.gif`) with the `ffmpeg` found on `PATH`.
pub(super) fn assemble(
    dir: &Path,
    first: u64,
    count: usize,
    suffix: &str,
    format: MovieFormat,
) -> Result<PathBuf, Skipped> {
    if count < 2 {
        return Err(Skipped(
            "--movie: a single frame makes no movie (render more with --all)".into(),
        ));
    }
    let found = Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !found {
        return Err(Skipped(
            "--movie: ffmpeg is not installed (not found on PATH); the pictures are written, \
             no movie"
                .into(),
        ));
    }
    let (extension, filters): (&str, &[&str]) = match format {
        // Even sizes for yuv420p.
        MovieFormat::Mp4 => (
            "mp4",
            &[
                "-vf",
                "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                "-pix_fmt",
                "yuv420p",
            ],
        ),
        MovieFormat::Gif => (
            "gif",
            &["-vf", "split[a][b];[a]palettegen[p];[b][p]paletteuse"],
        ),
    };
    let out = dir.join(format!("movie{suffix}.{extension}"));
    let pattern = dir.join(format!("frame_%06d{suffix}.png"));
    let result = Command::new("ffmpeg")
        .args(["-y", "-loglevel", "error", "-framerate", &FPS.to_string()])
        .args(["-start_number", &first.to_string(), "-i"])
        .arg(&pattern)
        .args(["-frames:v", &count.to_string()])
        .args(filters)
        .arg(&out)
        .stdout(Stdio::null())
        .output();
    match result {
        Ok(o) if o.status.success() && out.exists() => Ok(out),
        Ok(o) => Err(Skipped(format!(
            "--movie: ffmpeg failed ({}): {}",
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        ))),
        Err(e) => Err(Skipped(format!("--movie: cannot run ffmpeg: {e}"))),
    }
}
