//! HDF5 snapshots and checkpoints, and the XDMF sidecar that lets ParaView open a run as a time
//! series (DESIGN §7). This is the only crate of the workspace that links libhdf5; it knows
//! nothing about solvers: callers hand it named arrays.
//!
//! File layout (snapshot and checkpoint alike):
//! - root attributes: `kind` ("snapshot" | "checkpoint", string), `time` (s, f64), `step`
//!   (u64), `dt` (s, f64), `dim` (u32), `units`, `scene` (the scene text) and `code_version`
//!   (strings), `extra_attrs` (1-D string array: the names of the extra attributes, in order),
//!   and one f64 attribute per extra attribute ([`Header::attrs`]);
//! - group `/particles`: one dataset per field, shaped `[N, …]`, f64 or u32 stored natively
//!   (bit-exact round trip; a snapshot may store its f64 fields as f32, and may shuffle and
//!   gzip them in chunks: [`Storage`]), each with a `unit` string attribute; the group's `field_order`
//!   attribute (1-D string array) lists the datasets in the order they were written, which is
//!   the order [`read_file`] returns (the group also tracks link creation order, so h5py lists
//!   them in that order too).
//!
//! - the HDF5 user block (the first 512 bytes or more, which HDF5 skips): FNV-1a 64 checksums
//!   of every dataset's values and of the rest of the file, verified before the HDF5 library
//!   parses the file, so a damaged file is refused with [`IoError::Damaged`] naming the dataset
//!   instead of crashing or hanging the library (layout in the `checksum` module; [`reseal`]
//!   recomputes them after an edit with another HDF5 tool). A file without the block is
//!   refused with [`IoError::Unverifiable`] unless read with [`Verify::Unchecked`].
//!
//! Strings are variable-length UTF-8. Object modification times are not recorded, so writing
//! the same data twice gives byte-identical files.
//!
//! Every file is written to a temporary name in the same directory (`.<name>.tmp-<pid>`,
//! hidden from globs such as `snap_*.h5`), closed, fsynced and renamed into place, and the
//! directory is fsynced, so a reader never sees a half-written file under its final name.
//! [`write_atomically`] does the same for any other file (the CLI's `summary.json`).

mod atomic;
mod checksum;
mod error;
mod snapshot;
mod xdmf;

pub use atomic::write_atomically;
pub use checksum::{is_unsealed, Verify};
pub use error::IoError;
pub use snapshot::{
    list_files, read_file, read_file_with, read_header, read_header_with, read_layout,
    read_layout_with, read_stored, reseal, write_file, write_file_with, Data, Field, FieldSpec,
    FileKind, Header, Snapshot, Storage, CONNECTIVITY_DATASET, EXTRA_ATTRS_ATTR, FIELD_ORDER_ATTR,
    MESH_GROUP, PARTICLES_GROUP, RESERVED_ROOT_ATTRS, UNIT_ATTR,
};
pub use xdmf::{write_xdmf, write_xdmf_pieces, SeriesEntry};
