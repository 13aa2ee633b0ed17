//! Wide vector instructions for the hot transfer loops: the workspace's one module with
//! `unsafe` code.
//!
//! The crates are built for the baseline x86-64 target (SSE2), which runs on any x86-64 CPU
//! but gives the transfers two `f64` lanes per instruction. [`Wide::detect`] checks once, at
//! run time, whether the CPU has AVX2; a [`Wide`] token is the proof that it does, and
//! [`Wide::run`] calls a closure through a function compiled with AVX2 enabled, so that
//! whatever is inlined into it (the per-particle P2G and G2P bodies, written on four-lane node
//! records) uses four lanes per instruction.
//!
//! Results do not depend on the path taken: Rust never contracts `a * b + c` into a fused
//! multiply-add and never reorders floating-point operations, so the AVX2 and the baseline
//! code perform the same IEEE operations in the same order, lane by lane, and give the same
//! bits (tested in `mpm-explicit`: a scene run through both paths gives identical particles).
//!
//! On other architectures there is no token and every call takes the baseline path.
#![allow(unsafe_code)]

/// Proof that the running CPU has AVX2 (x86-64 only). Obtained from [`Wide::detect`].
#[derive(Clone, Copy, Debug)]
pub struct Wide(());

impl Wide {
    /// The token when the CPU has AVX2, `None` otherwise (and on other architectures). The
    /// environment variable `MPM_NO_WIDE` (any value) forces `None`, to compare both paths.
    pub fn detect() -> Option<Wide> {
        if std::env::var_os("MPM_NO_WIDE").is_some() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            return Some(Wide(()));
        }
        None
    }

    /// Runs `body` through a function compiled with AVX2 enabled; what `body.run()` inlines
    /// (mark it `#[inline(always)]`) is compiled for AVX2 too.
    #[inline(always)]
    pub fn run<B: Body>(self, body: B) -> B::Output {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2")]
            fn avx2<B: Body>(body: B) -> B::Output {
                body.run()
            }
            // SAFETY: a `Wide` exists only when `detect` found AVX2 on this CPU, the one
            // requirement of calling a function compiled with `target_feature(enable = "avx2")`.
            unsafe { avx2(body) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        body.run()
    }
}

/// Work to run on the wide path: implement [`Body::run`] with `#[inline(always)]`, so that it
/// is compiled into the AVX2 function [`Wide::run`] calls. (A closure is not enough: its body
/// is a function of its own, which the compiler need not inline there.)
pub trait Body {
    /// What the work returns.
    type Output;
    /// Does the work.
    fn run(self) -> Self::Output;
}

/// Runs `body` through [`Wide::run`] when `wide` holds a token, directly otherwise.
#[inline(always)]
pub fn dispatch<B: Body>(wide: Option<Wide>, body: B) -> B::Output {
    match wide {
        Some(w) => w.run(body),
        None => body.run(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sum that needs care in floating point.
    struct Sum;

    impl Body for Sum {
        type Output = [f64; 4];
        #[inline(always)]
        fn run(self) -> [f64; 4] {
            let mut s = [0.0f64; 4];
            for k in 0..1000 {
                let x = (k as f64 * 0.37).sin() * 1e3;
                for (l, sl) in s.iter_mut().enumerate() {
                    *sl += x * (l as f64 + 0.1) + 1e-7 * x * x;
                }
            }
            s
        }
    }

    /// Both paths compute the same bits.
    #[test]
    fn paths_agree() {
        let base = dispatch(None, Sum);
        let wide = dispatch(Wide::detect(), Sum);
        assert_eq!(base.map(f64::to_bits), wide.map(f64::to_bits));
        assert!(base[0].abs() > 1.0);
    }
}
