//! Integrity check of the files [`crate::write_file`] writes, verified before the HDF5 library
//! parses anything.
//!
//! HDF5 lets a file start with a *user block* that the library skips. mpm-io keeps its
//! checksums there: an FNV-1a 64 hash of the raw values of every contiguous dataset (located by
//! its byte range, so a mismatch names the dataset) and one of every other byte after the block
//! (superblock, object headers, attributes, heaps). The HDF5 library is not hardened against
//! damaged files (a flipped byte in a heap or a shape can crash it, make it allocate absurd
//! amounts of memory or loop), so the reader refuses a file whose checksums do not match before
//! handing it to the library.
//!
//! Block layout, all integers little-endian, `B` bytes with `B` a power of two from 512 to
//! 1 MiB:
//! - bytes 0..8: the magic `MPMSUMS1`;
//! - 8..16: the hash of the whole block with these 8 bytes read as zeros;
//! - 16..24: `B`;
//! - 24..32: the length of the file in bytes;
//! - 32..40: the hash of every byte after the block outside the dataset ranges;
//! - 40..44: the number of dataset entries;
//! - the entries, in file order: the length of the dataset's path (u16), the path (UTF-8, e.g.
//!   `/particles/x`), the offset and length of its values in the file (u64 each) and their
//!   hash (u64);
//! - zeros up to `B`.
//!
//! Each FNV-1a step is a bijection of the hash state, so any single changed byte changes the
//! hash: one damaged byte is always detected, larger damage escapes with a probability of about
//! 2⁻⁶⁴. The hash is FNV-1a 64 over the bytes as stored (offset basis `0xcbf29ce484222325`,
//! prime `0x100000001b3`).

use crate::IoError;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;

/// First bytes of a file with a checksum block.
const MAGIC: &[u8; 8] = b"MPMSUMS1";

/// First bytes of an HDF5 file without a user block (files of mpm-io before checksums).
const HDF5_SIGNATURE: &[u8; 8] = b"\x89HDF\r\n\x1a\n";

/// Smallest user block HDF5 accepts.
const MIN_BLOCK: u64 = 512;

/// Largest checksum block the reader accepts (about 40,000 datasets).
const MAX_BLOCK: u64 = 1 << 20;

/// Bytes of the block before the entries.
const HEAD: usize = 44;

/// Bytes of an entry besides its path.
const ENTRY: usize = 2 + 3 * 8;

/// FNV-1a 64.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// The raw values of one dataset as a byte range of the file.
struct Entry {
    /// Path of the dataset in the file.
    name: String,
    /// First byte.
    offset: u64,
    /// Number of bytes.
    len: u64,
    /// FNV-1a 64 of the bytes.
    hash: u64,
}

/// How much of a file [`verify`] reads.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scope {
    /// Every byte.
    All,
    /// Everything but the values of the datasets (enough to read attributes and shapes).
    Structure,
}

/// The user block size for a file whose datasets have paths of the given lengths.
pub(crate) fn block_size(path_lengths: impl Iterator<Item = usize>) -> u64 {
    let need = HEAD + path_lengths.map(|l| ENTRY + l).sum::<usize>();
    (need as u64).next_power_of_two().max(MIN_BLOCK)
}

/// Whether a reader accepts a file without a checksum block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Verify {
    /// Only a file whose checksum block matches it (the default); a file without a block is
    /// refused with [`IoError::Unverifiable`].
    #[default]
    Required,
    /// Also an HDF5 file without a checksum block (written or rewritten by another tool, or
    /// cut at the front). Unsafe: damage to its values goes unnoticed, and the HDF5 library,
    /// which is not hardened against damaged files, parses its structure unprotected and may
    /// crash or hang on it. Every dataset's size and shape are checked against its storage and
    /// the file's length before any value is read; the rest is left to a caller that reads
    /// such files in a process allowed to die (mpm-cli's `--unchecked` does).
    Unchecked,
}

/// Whether `path` is a regular file that starts with the HDF5 signature instead of a checksum
/// block: the file a verified read refuses as [`IoError::Unverifiable`] unless
/// [`Verify::Unchecked`]. Reads its first 8 bytes only; any error reading them is `false` (the
/// read that follows reports it).
pub fn is_unsealed(path: &Path) -> bool {
    let head = || -> std::io::Result<[u8; 8]> {
        if !std::fs::metadata(path)?.is_file() {
            return Ok([0; 8]);
        }
        let mut head = [0u8; 8];
        File::open(path)?.read_exact(&mut head)?;
        Ok(head)
    };
    head().is_ok_and(|h| &h == HDF5_SIGNATURE)
}

/// Checks the file at `path` against its checksum block (every byte, or with [`Scope::Structure`]
/// all but the dataset values) before the HDF5 library opens it.
///
/// A file that is not a regular file, or starts with neither a checksum block nor the HDF5
/// signature, is a [`IoError::Format`] error; a mismatch is [`IoError::Damaged`] naming the
/// dataset or part of the file. An HDF5 file without a user block is
/// [`IoError::Unverifiable`], or passes unverified with [`Verify::Unchecked`].
pub(crate) fn verify(path: &Path, scope: Scope, trust: Verify) -> Result<(), IoError> {
    let fs_err = |source| IoError::Fs {
        path: path.to_path_buf(),
        source,
    };
    // Checked before opening: opening a FIFO would wait for a writer.
    if !std::fs::metadata(path).map_err(fs_err)?.is_file() {
        return Err(format_err(path, "not a regular file".into()));
    }
    let mut file = File::open(path).map_err(fs_err)?;
    let len = file.metadata().map_err(fs_err)?.len();
    let mut head = [0u8; 8];
    if len < 8 {
        return Err(not_ours(path));
    }
    file.read_exact(&mut head).map_err(fs_err)?;
    if &head == HDF5_SIGNATURE {
        return match trust {
            Verify::Unchecked => Ok(()),
            Verify::Required => Err(IoError::Unverifiable {
                path: path.to_path_buf(),
            }),
        };
    }
    if &head != MAGIC {
        return Err(not_ours(path));
    }
    let block_err = |m: &str| damaged(path, format!("its checksum block is invalid: {m}"));
    let mut size = [0u8; 8];
    file.seek(SeekFrom::Start(16)).map_err(fs_err)?;
    file.read_exact(&mut size)
        .map_err(|_| block_err("too short"))?;
    let b = u64::from_le_bytes(size);
    if !b.is_power_of_two() || !(MIN_BLOCK..=MAX_BLOCK).contains(&b) || b > len {
        return Err(block_err(&format!("size {b} bytes")));
    }
    let mut block = vec![0u8; b as usize];
    file.seek(SeekFrom::Start(0)).map_err(fs_err)?;
    file.read_exact(&mut block).map_err(fs_err)?;
    let stored = u64_at(&block, 8);
    if block_hash(&block) != stored {
        return Err(block_err("checksum mismatch"));
    }
    let recorded = u64_at(&block, 24);
    if recorded != len {
        return Err(damaged(
            path,
            format!(
                "it is {len} bytes long, its checksum block says {recorded} (truncated or \
                 extended)"
            ),
        ));
    }
    let entries = parse_entries(&block, len).map_err(|m| block_err(&m))?;
    let (meta, values) = hash_file(&mut file, b, len, &entries, scope).map_err(fs_err)?;
    if let Some(e) = entries
        .iter()
        .zip(&values)
        .find_map(|(e, h)| h.filter(|&h| h != e.hash).map(|_| e))
    {
        return Err(damaged(
            path,
            format!(
                "the values of dataset {} do not match their checksum",
                e.name
            ),
        ));
    }
    if meta != u64_at(&block, 32) {
        return Err(damaged(
            path,
            "its HDF5 structure (headers, attributes, the scene text) does not match its checksum"
                .into(),
        ));
    }
    Ok(())
}

/// Fills the checksum block of the file at `disk` (reported as `path` in errors), which the
/// HDF5 library has written and closed with a user block: the byte range of every contiguous
/// dataset is looked up, everything is hashed and the block written.
pub(crate) fn seal(disk: &Path, path: &Path) -> Result<(), IoError> {
    let h5 = |e: hdf5::Error| IoError::Hdf5 {
        path: path.to_path_buf(),
        message: format!("locating the datasets for the checksums: {e}"),
    };
    let (b, mut entries) = {
        let file = hdf5::File::open(disk).map_err(h5)?;
        let mut entries = Vec::new();
        dataset_ranges(&file, &mut entries).map_err(h5)?;
        let b = file.userblock();
        file.close().map_err(h5)?;
        (b, entries)
    };
    if !(MIN_BLOCK..=MAX_BLOCK).contains(&b) {
        return Err(format_err(
            path,
            format!(
                "the file's user block has {b} bytes; the checksums need one of {MIN_BLOCK} to \
                 {MAX_BLOCK} bytes"
            ),
        ));
    }
    entries.sort_by_key(|e| e.offset);
    let fs_err = |source| IoError::Fs {
        path: path.to_path_buf(),
        source,
    };
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .open(disk)
        .map_err(fs_err)?;
    let len = file.metadata().map_err(fs_err)?.len();
    let mut block = Vec::with_capacity(b as usize);
    block.extend_from_slice(MAGIC);
    block.extend_from_slice(&[0; 8]);
    block.extend_from_slice(&b.to_le_bytes());
    block.extend_from_slice(&len.to_le_bytes());
    block.extend_from_slice(&[0; 8]); // the structure hash, filled in below
    block.extend_from_slice(&(entries.len() as u32).to_le_bytes());
    let (meta, values) = hash_file(&mut file, b, len, &entries, Scope::All).map_err(fs_err)?;
    for (e, h) in entries.iter_mut().zip(values) {
        e.hash = h.unwrap_or_default();
        block.extend_from_slice(&(e.name.len() as u16).to_le_bytes());
        block.extend_from_slice(e.name.as_bytes());
        block.extend_from_slice(&e.offset.to_le_bytes());
        block.extend_from_slice(&e.len.to_le_bytes());
        block.extend_from_slice(&e.hash.to_le_bytes());
    }
    if block.len() as u64 > b {
        return Err(format_err(
            path,
            format!(
                "the checksums need {} bytes, the user block has {b}",
                block.len()
            ),
        ));
    }
    block.resize(b as usize, 0);
    block[32..40].copy_from_slice(&meta.to_le_bytes());
    let own = block_hash(&block);
    block[8..16].copy_from_slice(&own.to_le_bytes());
    // The block is checked against its limits by the reader; a file it would refuse is not
    // written.
    parse_entries(&block, len).map_err(|m| format_err(path, m))?;
    file.seek(SeekFrom::Start(0)).map_err(fs_err)?;
    file.write_all(&block).map_err(fs_err)
}

/// The byte ranges of the contiguous datasets under `group`, recursively. Datasets without one
/// (chunked, compact or empty) are covered by the structure hash.
fn dataset_ranges(group: &hdf5::Group, out: &mut Vec<Entry>) -> hdf5::Result<()> {
    for ds in group.datasets()? {
        if let Some(offset) = ds.offset() {
            out.push(Entry {
                name: ds.name(),
                offset,
                len: ds.storage_size(),
                hash: 0,
            });
        }
    }
    for g in group.groups()? {
        dataset_ranges(&g, out)?;
    }
    Ok(())
}

/// The entries of a checksum block, checked: paths valid UTF-8 within the block, ranges in file
/// order, disjoint and between the block and the end of the file (`len` bytes).
fn parse_entries(block: &[u8], len: u64) -> Result<Vec<Entry>, String> {
    let b = block.len();
    if b < HEAD {
        return Err("too short".into());
    }
    let n = u32::from_le_bytes([block[40], block[41], block[42], block[43]]) as usize;
    if n > (b - HEAD) / ENTRY {
        return Err(format!("{n} entries do not fit in {b} bytes"));
    }
    let mut at = HEAD;
    let mut end = b as u64;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let bad = |what: &str| format!("entry {i}: {what}");
        let name_len = block
            .get(at..at + 2)
            .map(|s| u16::from_le_bytes([s[0], s[1]]) as usize)
            .ok_or_else(|| bad("past the end of the block"))?;
        let fixed = at + 2 + name_len;
        if fixed + 24 > b {
            return Err(bad("past the end of the block"));
        }
        let name = std::str::from_utf8(&block[at + 2..fixed])
            .map_err(|_| bad("the dataset path is not UTF-8"))?
            .to_owned();
        let (offset, n_bytes, hash) = (
            u64_at(block, fixed),
            u64_at(block, fixed + 8),
            u64_at(block, fixed + 16),
        );
        match offset.checked_add(n_bytes) {
            Some(stop) if offset >= end && stop <= len => end = stop,
            _ => {
                return Err(bad(&format!(
                    "{name}: byte range outside the file or out of order"
                )))
            }
        }
        out.push(Entry {
            name,
            offset,
            len: n_bytes,
            hash,
        });
        at = fixed + 24;
    }
    Ok(out)
}

/// Hashes the file after the first `b` bytes up to `len`: the bytes outside `entries` into one
/// hash, and each entry's range into its own (skipped, giving `None`, with
/// [`Scope::Structure`]). `entries` are sorted, disjoint and inside `b..len`.
fn hash_file(
    file: &mut File,
    b: u64,
    len: u64,
    entries: &[Entry],
    scope: Scope,
) -> std::io::Result<(u64, Vec<Option<u64>>)> {
    let mut buf = vec![0u8; 1 << 16];
    let mut meta = Fnv::new();
    let mut values = Vec::with_capacity(entries.len());
    file.seek(SeekFrom::Start(b))?;
    let mut pos = b;
    for e in entries {
        hash_span(file, e.offset - pos, &mut meta, &mut buf)?;
        if scope == Scope::All {
            let mut h = Fnv::new();
            hash_span(file, e.len, &mut h, &mut buf)?;
            values.push(Some(h.0));
        } else {
            file.seek(SeekFrom::Start(e.offset + e.len))?;
            values.push(None);
        }
        pos = e.offset + e.len;
    }
    hash_span(file, len - pos, &mut meta, &mut buf)?;
    Ok((meta.0, values))
}

/// Feeds the next `n` bytes of `file` into `h`.
fn hash_span(file: &mut File, mut n: u64, h: &mut Fnv, buf: &mut [u8]) -> std::io::Result<()> {
    while n > 0 {
        let k = usize::try_from(n).map_or(buf.len(), |n| n.min(buf.len()));
        file.read_exact(&mut buf[..k])?;
        h.update(&buf[..k]);
        n -= k as u64;
    }
    Ok(())
}

/// The hash of a checksum block with its own hash (bytes 8..16) read as zeros.
fn block_hash(block: &[u8]) -> u64 {
    let mut h = Fnv::new();
    h.update(&block[..8]);
    h.update(&[0; 8]);
    h.update(&block[16..]);
    h.0
}

/// The little-endian u64 at `at` (the caller has checked the bounds).
fn u64_at(block: &[u8], at: usize) -> u64 {
    let mut v = [0u8; 8];
    v.copy_from_slice(&block[at..at + 8]);
    u64::from_le_bytes(v)
}

fn format_err(path: &Path, message: String) -> IoError {
    IoError::Format {
        path: path.to_path_buf(),
        message,
    }
}

fn damaged(path: &Path, message: String) -> IoError {
    IoError::Damaged {
        path: path.to_path_buf(),
        message,
    }
}

fn not_ours(path: &Path) -> IoError {
    format_err(
        path,
        "not an mpm-io snapshot or checkpoint (it starts with neither a checksum block nor the \
         HDF5 signature)"
            .into(),
    )
}
