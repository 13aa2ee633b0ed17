//! What a scatter writes: the per-node value type ([`NodeValue`]), one output channel
//! ([`Output`]), and a channel set ([`Channels`]) with its per-block storage
//! ([`BlockStorage`]), implemented for tuples of one to six channels.

use crate::math::Real;
use nalgebra::SMatrix;
use std::ops::AddAssign;

/// A per-node quantity that can be scattered: summed with `+=` from [`zero`](Self::zero), in
/// the units of whatever the caller scatters. Implemented for `Real` (and `f32`), the integer
/// types and fixed-size matrices of `Real` (`Vector<D>`, `Matrix<D>`); implement it for a custom
/// per-node type to scatter that.
pub trait NodeValue: Copy + PartialEq + AddAssign + Send + Sync {
    /// The additive identity.
    fn zero() -> Self;
}

macro_rules! node_value {
    ($($t:ty),*) => {
        $(impl NodeValue for $t {
            #[inline]
            fn zero() -> Self {
                0 as $t
            }
        })*
    };
}

node_value!(f64, f32, u8, u16, u32, u64, usize, i8, i16, i32, i64, isize);

/// Every fixed-size matrix of `Real`: `Vector<D>`, `Matrix<D>`, …
impl<const R: usize, const C: usize> NodeValue for SMatrix<Real, R, C> {
    #[inline]
    fn zero() -> Self {
        Self::zeros()
    }
}

/// One output channel of a scatter: a per-node array, resized to the grid's node count and
/// zeroed before the sums are added, or nothing.
pub trait Output {
    /// The per-node value.
    type Value: NodeValue;
    /// The array the sums go to, or `None` when this channel is not scattered.
    fn array(&mut self) -> Option<&mut Vec<Self::Value>>;
    /// Whether this channel is scattered.
    fn enabled(&self) -> bool;
}

impl<T: NodeValue> Output for &mut Vec<T> {
    type Value = T;
    fn array(&mut self) -> Option<&mut Vec<T>> {
        Some(&mut **self)
    }
    fn enabled(&self) -> bool {
        true
    }
}

impl<T: NodeValue> Output for Option<&mut Vec<T>> {
    type Value = T;
    fn array(&mut self) -> Option<&mut Vec<T>> {
        self.as_deref_mut()
    }
    fn enabled(&self) -> bool {
        self.is_some()
    }
}

/// The private node storage of one block: a tuple of `Vec<T>`, one per channel, each of
/// `window.len()` entries while its channel is scattered and empty otherwise.
pub trait BlockStorage: Default + Send + Sync {
    /// Zeroes every channel whose bit is set in `enabled` (bit `c` for channel `c`; the gate,
    /// channel 0, is always enabled) to `len` nodes and empties the others.
    fn reset(&mut self, enabled: u32, len: usize);
    /// Whether local node `k` received anything: its gate value is not zero.
    fn received(&self, k: usize) -> bool;
    /// Bytes held (lengths, not capacities).
    fn bytes(&self) -> usize;
}

/// A set of output channels scattered together: a tuple `(&mut Vec<T0>, O1, O2, …)` of up to six
/// channels whose first one, the gate, is always present and the others are any [`Output`].
pub trait Channels {
    /// The matching block storage, `(Vec<T0>, Vec<T1>, …)`.
    type Storage: BlockStorage;
    /// Consecutive nodes of every scattered output array, written by one task.
    type Slab<'s>: Send
    where
        Self: 's;
    /// Bit `c` set: channel `c` is scattered.
    fn enabled(&self) -> u32;
    /// Sizes every scattered output array to `num_nodes` and splits it into slabs of
    /// `slab_len` nodes (the last may be shorter); the values are stale until
    /// [`Self::zero_slab`].
    fn slabs(&mut self, num_nodes: usize, slab_len: usize) -> Vec<Self::Slab<'_>>;
    /// Zeroes every array of a slab.
    fn zero_slab<'s>(slab: &mut Self::Slab<'s>)
    where
        Self: 's;
    /// Adds local node `k` of `block` to node `node` of the slab in every scattered output.
    fn add<'s>(slab: &mut Self::Slab<'s>, node: usize, block: &Self::Storage, k: usize)
    where
        Self: 's;
}

macro_rules! channel_tuple {
    ($($i:tt $T:ident $O:ident),*) => {
        impl<T0: NodeValue, $($T: NodeValue),*> BlockStorage for (Vec<T0>, $(Vec<$T>,)*) {
            fn reset(&mut self, _enabled: u32, len: usize) {
                self.0.clear();
                self.0.resize(len, T0::zero());
                $(
                    self.$i.clear();
                    if _enabled & (1 << $i) != 0 {
                        self.$i.resize(len, $T::zero());
                    }
                )*
            }

            #[inline]
            fn received(&self, k: usize) -> bool {
                self.0[k] != T0::zero()
            }

            fn bytes(&self) -> usize {
                self.0.len() * std::mem::size_of::<T0>()
                    $(+ self.$i.len() * std::mem::size_of::<$T>())*
            }
        }

        impl<'a, T0: NodeValue, $($O: Output),*> Channels for (&'a mut Vec<T0>, $($O,)*) {
            type Storage = (Vec<T0>, $(Vec<$O::Value>,)*);

            fn enabled(&self) -> u32 {
                1 $(| (u32::from(self.$i.enabled()) << $i))*
            }

            type Slab<'s> = (&'s mut [T0], $(Option<&'s mut [$O::Value]>,)*) where Self: 's;

            fn slabs(&mut self, num_nodes: usize, slab_len: usize) -> Vec<Self::Slab<'_>> {
                self.0.resize(num_nodes, T0::zero());
                $(
                    if let Some(out) = self.$i.array() {
                        out.resize(num_nodes, NodeValue::zero());
                    }
                )*
                let mut parts = (
                    self.0.chunks_mut(slab_len),
                    $(self.$i.array().map(|out| out.chunks_mut(slab_len)),)*
                );
                (0..num_nodes.div_ceil(slab_len))
                    .filter_map(|_| {
                        Some((
                            parts.0.next()?,
                            $(match parts.$i.as_mut() {
                                Some(it) => Some(it.next()?),
                                None => None,
                            },)*
                        ))
                    })
                    .collect()
            }

            fn zero_slab<'s>(slab: &mut Self::Slab<'s>) where Self: 's {
                slab.0.fill(T0::zero());
                $(
                    if let Some(out) = slab.$i.as_deref_mut() {
                        out.fill(NodeValue::zero());
                    }
                )*
            }

            #[inline]
            fn add<'s>(slab: &mut Self::Slab<'s>, node: usize, block: &Self::Storage, k: usize)
            where
                Self: 's,
            {
                slab.0[node] += block.0[k];
                $(
                    if let Some(out) = slab.$i.as_deref_mut() {
                        out[node] += block.$i[k];
                    }
                )*
            }
        }
    };
}

channel_tuple!();
channel_tuple!(1 T1 O1);
channel_tuple!(1 T1 O1, 2 T2 O2);
channel_tuple!(1 T1 O1, 2 T2 O2, 3 T3 O3);
channel_tuple!(1 T1 O1, 2 T2 O2, 3 T3 O3, 4 T4 O4);
channel_tuple!(1 T1 O1, 2 T2 O2, 3 T3 O3, 4 T4 O4, 5 T5 O5);
