//! Deterministic parallel helpers (disjoint segments written by one task each).

/// Segments handled serially below this count.
const GRAIN: usize = 64;

/// Calls `f(s, segment)` for every segment `s` of `data`, where segment `s` is
/// `data[offsets[s] − offsets[0] .. offsets[s + 1] − offsets[0]]`, splitting the segments
/// recursively over rayon. Segments are disjoint, so each is written by exactly one task and the
/// result does not depend on the thread count.
pub(crate) fn for_each_segment<T, F>(data: &mut [T], offsets: &[usize], f: &F)
where
    T: Send,
    F: Fn(usize, &mut [T]) + Sync,
{
    split(data, offsets, 0, f);
}

fn split<T, F>(data: &mut [T], offsets: &[usize], first: usize, f: &F)
where
    T: Send,
    F: Fn(usize, &mut [T]) + Sync,
{
    let n = offsets.len().saturating_sub(1);
    if n <= GRAIN {
        for s in 0..n {
            let range = offsets[s] - offsets[0]..offsets[s + 1] - offsets[0];
            f(first + s, &mut data[range]);
        }
        return;
    }
    let mid = n / 2;
    let (left, right) = data.split_at_mut(offsets[mid] - offsets[0]);
    rayon::join(
        || split(left, &offsets[..=mid], first, f),
        || split(right, &offsets[mid..], first + mid, f),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_cover_data_once() {
        let offsets: Vec<usize> = (0..=500).map(|s| s * (s + 1) / 2).collect();
        let mut data = vec![0usize; offsets[500]];
        for_each_segment(&mut data, &offsets, &|s, seg: &mut [usize]| {
            assert_eq!(seg.len(), s + 1);
            seg.iter_mut().for_each(|x| *x += s + 1);
        });
        for s in 0..500 {
            assert!(data[offsets[s]..offsets[s + 1]].iter().all(|&x| x == s + 1));
        }
    }
}
