//! Reading the text input files (scenes, OBJ meshes, a run's `summary.json`): regular files only,
//! with a size cap
//! checked before reading, so that a path to a device, a FIFO or a huge file cannot hang the
//! tool or exhaust its memory.

use std::io::Read;
use std::path::Path;

/// Largest scene file read: 16 MiB (scenes are a few kilobytes).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Largest OBJ mesh file read: 256 MiB (a mesh of [`mpm_core::sampling::MAX_TRIANGLES`] triangles
/// takes about 100 MB of OBJ text).
pub const MAX_MESH_BYTES: u64 = 256 << 20;

/// Largest `summary.json` that `mpm-cli info` reads: 16 MiB (a summary is a few kilobytes).
pub const MAX_SUMMARY_BYTES: u64 = 16 << 20;

/// The text of the regular file at `path`, at most `limit` bytes. The error says why it cannot
/// be read (missing, not a regular file, too large, not UTF-8) without naming the file.
pub fn read_text(path: &Path, limit: u64) -> Result<String, String> {
    // Checked before opening: opening a FIFO waits for a writer, a device never ends.
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a regular file (a directory, device or pipe)".into());
    }
    let too_large = |len: u64| {
        format!(
            "{len} bytes, larger than the limit of {limit} bytes ({} MiB)",
            limit >> 20
        )
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut bytes))
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        // The file grew after the size check.
        return Err(too_large(bytes.len() as u64));
    }
    String::from_utf8(bytes).map_err(|_| "not UTF-8 text".into())
}

/// Reads an OBJ triangle mesh file (a regular file of at most [`MAX_MESH_BYTES`]). Errors are
/// one-line messages naming the file and, for syntax errors, the line.
pub fn read_obj(path: &Path) -> Result<mpm_core::sampling::TriMesh, String> {
    let text = read_text(path, MAX_MESH_BYTES)
        .map_err(|e| format!("cannot read mesh file {}: {e}", path.display()))?;
    mpm_core::sampling::parse_obj(&text).map_err(|e| format!("mesh file {}: {e}", path.display()))
}
