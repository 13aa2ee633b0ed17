//! Maps between grid nodes (or cells) and the compact numbering of a system's unknowns.

/// Marks a node without an unknown.
const NONE: usize = usize::MAX;

/// A numbering of the unknowns of a linear system over a subset of `num_nodes` grid nodes or
/// cells (given by their linear indices): for example the nodes with a free component, or the
/// cells that hold fluid. Unknowns are numbered in node order. [`Self::rebuild`] renumbers in
/// place and reports whether anything changed, so a caller can keep a sparsity pattern (and its
/// symbolic factorisation) while the set of unknowns stays the same.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DofMap {
    /// Unknown of each node, `NONE` without one.
    unknown_of: Vec<usize>,
    /// Node of each unknown, ascending.
    node_of: Vec<usize>,
}

impl DofMap {
    /// The empty map (no nodes, no unknowns).
    pub fn new() -> Self {
        Self::default()
    }

    /// The map giving an unknown to each node `i < num_nodes` for which `has_unknown(i)`.
    pub fn from_predicate(num_nodes: usize, has_unknown: impl FnMut(usize) -> bool) -> Self {
        let mut map = Self::new();
        map.rebuild(num_nodes, has_unknown);
        map
    }

    /// Renumbers for `num_nodes` nodes and the predicate `has_unknown`, reusing the storage (it
    /// allocates only to grow beyond its largest size so far). Returns whether the map changed:
    /// a different node count or a different set of nodes with unknowns.
    pub fn rebuild(
        &mut self,
        num_nodes: usize,
        mut has_unknown: impl FnMut(usize) -> bool,
    ) -> bool {
        let mut changed = num_nodes != self.unknown_of.len();
        self.unknown_of.clear();
        self.unknown_of.resize(num_nodes, NONE);
        let old_len = self.node_of.len();
        let mut k = 0;
        for i in 0..num_nodes {
            if has_unknown(i) {
                if k < old_len {
                    changed |= self.node_of[k] != i;
                    self.node_of[k] = i;
                } else {
                    self.node_of.push(i);
                }
                self.unknown_of[i] = k;
                k += 1;
            }
        }
        changed |= k != old_len;
        self.node_of.truncate(k);
        changed
    }

    /// The unknown of node `node`, `None` when it has none or is out of range.
    #[inline]
    pub fn unknown(&self, node: usize) -> Option<usize> {
        self.unknown_of.get(node).copied().filter(|&u| u != NONE)
    }

    /// The node of unknown `unknown` (panics if `unknown ≥ len`).
    #[inline]
    pub fn node(&self, unknown: usize) -> usize {
        self.node_of[unknown]
    }

    /// The nodes with unknowns, ascending; position `k` holds the node of unknown `k`.
    pub fn nodes(&self) -> &[usize] {
        &self.node_of
    }

    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.node_of.len()
    }

    /// Whether there are no unknowns.
    pub fn is_empty(&self) -> bool {
        self.node_of.is_empty()
    }

    /// Number of nodes the map covers.
    pub fn num_nodes(&self) -> usize {
        self.unknown_of.len()
    }
}
