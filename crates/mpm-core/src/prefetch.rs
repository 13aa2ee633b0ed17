//! Cache prefetch hints. This is the workspace's one module with `unsafe` code; every other
//! module is compiled under `#![deny(unsafe_code)]` (the workspace lint).
//!
//! [`read`] asks the processor to start loading the cache lines of a value that the caller will
//! read soon, so that the load overlaps other work. A prefetch is only a hint: it makes no
//! visible read, it cannot fault (the processor drops a prefetch of an address it cannot
//! reach), and it changes no result, only when data arrives. The single `unsafe` block exists
//! because Rust declares the `_mm_prefetch` intrinsic with `#[target_feature(enable = "sse")]`,
//! and calling such a function needs `unsafe` even where the feature is part of the target (SSE
//! is in every x86-64 target). The pointer it is given comes from a reference, and is never
//! dereferenced. On other architectures [`read`] does nothing.
//!
//! Where it is used, and what it measured: `mpm-explicit`'s P2G in 3D (see `p2g.rs`).

#![allow(unsafe_code)]

/// Bytes per cache line assumed for the hints (x86-64: 64).
const LINE: usize = 64;

/// Hints that `value` will be read soon: prefetches, into every cache level, each cache line
/// that `value` occupies (`offsets`).
#[inline(always)]
pub fn read<T>(value: &T) {
    let start = (value as *const T).cast::<i8>();
    offsets(std::mem::size_of::<T>(), std::mem::align_of::<T>(), |k| {
        line(start.wrapping_add(k))
    });
}

/// Calls `f` with the byte offsets, within a value of `len` bytes aligned to `align` bytes,
/// whose lines [`read`] hints: the first byte, every [`LINE`] bytes after it, and the last byte,
/// so that every line the value touches holds one of them, wherever the value starts. A value no
/// larger than its alignment (`align` ≤ [`LINE`]) lies in one line and takes one hint; an empty
/// one takes none.
#[inline(always)]
fn offsets(len: usize, align: usize, mut f: impl FnMut(usize)) {
    if len == 0 {
        return;
    }
    f(0);
    if len <= align {
        return;
    }
    let mut offset = LINE;
    while offset < len - 1 {
        f(offset);
        offset += LINE;
    }
    f(len - 1);
}

/// Prefetches the cache line holding `byte` into every level (`T0`).
#[inline(always)]
fn line(byte: *const i8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `_mm_prefetch` is a hint that reads nothing the program can observe and never
    // faults, whatever the address; its only requirement is SSE, which every x86-64 target
    // has (the intrinsic is `unsafe` to call only because of its `#[target_feature]`).
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(byte);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = byte;
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// For every size up to five lines, every alignment up to a line and every start within a
    /// line, the hinted offsets reach exactly the lines the value touches, and a value no
    /// larger than its alignment takes a single hint.
    #[test]
    fn hints_cover_exactly_the_lines_a_value_touches() {
        let mut cases = 0;
        for align in [1, 2, 4, 8, 16, 32, 64] {
            for len in (0..=5 * LINE).filter(|len| len % align == 0) {
                for start in (0..LINE).step_by(align) {
                    let touched: BTreeSet<usize> =
                        (start..start + len).map(|byte| byte / LINE).collect();
                    let (mut hinted, mut hints) = (BTreeSet::new(), 0);
                    offsets(len, align, |k| {
                        assert!(k < len, "offset {k} outside a value of {len} bytes");
                        hinted.insert((start + k) / LINE);
                        hints += 1;
                    });
                    assert_eq!(hinted, touched, "len {len}, align {align}, start {start}");
                    if len <= align {
                        assert_eq!(hints, len.min(1), "len {len}, align {align}");
                    }
                    // At most one hint more than the lines it touches (the last byte's).
                    assert!(hints <= touched.len() + 1);
                    cases += 1;
                }
            }
        }
        assert!(cases > 2000);
    }
}
