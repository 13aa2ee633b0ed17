//! Snapshot and checkpoint files.

mod read;
mod write;

use crate::atomic::replace_atomically;
use crate::checksum::{self, Scope, Verify};
use crate::IoError;
use read::{field_dataset, field_order, field_spec, open, particles_group, read_header_from};
use std::path::{Path, PathBuf};
use write::{validate, write_hdf5};

/// A named per-particle array with its unit: a dataset under `/particles`. It is the column
/// type the solvers write ([`mpm_core::Column`]): one type from the solver to the file.
pub use mpm_core::columns::Column as Field;
/// Numeric payload of a field, row-major with `shape[0] = N` particles
/// ([`mpm_core::ColumnData`]).
pub use mpm_core::columns::ColumnData as Data;

/// Name, unit, shape and number type of a field, without its values.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldSpec {
    /// Dataset name under `/particles`.
    pub name: String,
    /// Unit string.
    pub unit: String,
    /// Shape `[N, …]`.
    pub shape: Vec<usize>,
    /// Whether the values are integers (`u32`) rather than floating point.
    pub integer: bool,
    /// Whether the file stores the floating-point values as `f32` (a snapshot written with
    /// [`Storage::single`]); [`read_file`] widens them to `f64` exactly.
    pub single: bool,
}

impl FieldSpec {
    /// The name, unit, shape and type of `field` (as stored in `f64`).
    pub fn of(field: &Field) -> Self {
        let (shape, integer) = match &field.data {
            Data::F64 { shape, .. } => (shape.clone(), false),
            Data::U32 { shape, .. } => (shape.clone(), true),
        };
        FieldSpec {
            name: field.name.clone(),
            unit: field.unit.clone(),
            shape,
            integer,
            single: false,
        }
    }
}

/// How the floating-point datasets of a snapshot are stored. The default, `f64` and
/// uncompressed, is the only storage of checkpoints: they must round-trip bit for bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Storage {
    /// Store `f64` fields as `f32` (rounded to nearest), halving their size; snapshots only.
    pub single: bool,
    /// gzip (deflate) level 1–9, applied after HDF5's byte-shuffle filter to chunked datasets;
    /// 0 writes contiguous, uncompressed datasets.
    pub compression: u8,
}

impl Storage {
    /// The spec of `field` as stored with this storage.
    pub fn spec(&self, field: &Field) -> FieldSpec {
        let mut spec = FieldSpec::of(field);
        spec.single = self.single && !spec.integer;
        spec
    }
}

/// Whether a file is an output snapshot or a restart checkpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// Output for viewing.
    Snapshot,
    /// Full solver state for a bitwise resume.
    Checkpoint,
}

/// Root attributes of a file.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Snapshot or checkpoint.
    pub kind: FileKind,
    /// Simulation time (s).
    pub time: f64,
    /// Step count.
    pub step: u64,
    /// Last time step (s).
    pub dt: f64,
    /// Spatial dimension (2 or 3).
    pub dim: u32,
    /// Unit system description, e.g. "SI (m, s, kg, Pa)".
    pub units: String,
    /// The scene file text that produced the run.
    pub scene: String,
    /// Version of the code that wrote the file.
    pub code_version: String,
    /// Extra numeric attributes (name, value), e.g. checkpoint counters stored bit-exactly.
    pub attrs: Vec<(String, f64)>,
}

/// A file read back.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Root attributes.
    pub header: Header,
    /// Particle fields in file order.
    pub fields: Vec<Field>,
}

impl Snapshot {
    /// The field called `name`, if present.
    pub fn field(&self, name: &str) -> Option<&Field> {
        self.fields.iter().find(|f| f.name == name)
    }
}

/// Name of the group holding the particle datasets.
pub const PARTICLES_GROUP: &str = "particles";

/// Group of a snapshot holding its Polyvertex topology for XDMF readers.
pub const MESH_GROUP: &str = "mesh";

/// The dataset of a snapshot's Polyvertex topology: the particle indices `0..N` (u32).
pub const CONNECTIVITY_DATASET: &str = "/mesh/connectivity";

/// Attribute of `/particles`: the dataset names in the order they were written (1-D array of
/// variable-length UTF-8 strings). [`read_file`] returns the fields in this order.
pub const FIELD_ORDER_ATTR: &str = "field_order";

/// Root attribute: the names of the extra numeric attributes ([`Header::attrs`]) in the order
/// they were written (1-D array of variable-length UTF-8 strings).
pub const EXTRA_ATTRS_ATTR: &str = "extra_attrs";

/// Attribute of every dataset: its unit (variable-length UTF-8 string).
pub const UNIT_ATTR: &str = "unit";

/// Root attribute names used by the layout itself; an extra attribute may not take one.
pub const RESERVED_ROOT_ATTRS: [&str; 9] = [
    "kind",
    "time",
    "step",
    "dt",
    "dim",
    "units",
    "scene",
    "code_version",
    EXTRA_ATTRS_ATTR,
];

impl FileKind {
    /// The value of the `kind` attribute: `"snapshot"` or `"checkpoint"`.
    pub fn as_str(self) -> &'static str {
        match self {
            FileKind::Snapshot => "snapshot",
            FileKind::Checkpoint => "checkpoint",
        }
    }

    /// Parses the value of the `kind` attribute.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "snapshot" => Some(FileKind::Snapshot),
            "checkpoint" => Some(FileKind::Checkpoint),
            _ => None,
        }
    }
}

/// Writes `fields` with `header` to `path` atomically (temporary file in the same directory,
/// then rename), with a checksum of every dataset and of the rest of the file in the HDF5 user
/// block (see [`read_file`]).
///
/// The temporary file is `<dir>/.<name>.tmp-<pid>`; it is closed, fsynced, renamed over `path`
/// (replacing an existing file) and the directory is fsynced. On failure the temporary file is
/// removed and `path` is untouched. Inputs that cannot be stored faithfully (a value count
/// that does not match the shape, a field name containing `/`, duplicate names, an extra
/// attribute named like a reserved one, a NUL inside a string) are rejected with
/// [`IoError::Format`] before anything is created.
pub fn write_file(path: &Path, header: &Header, fields: &[Field]) -> Result<(), IoError> {
    write_file_with(path, header, fields, Storage::default())
}

/// [`write_file`] with the floating-point datasets stored as `storage` says (`f32` and/or
/// shuffled and gzip-compressed in chunks). A checkpoint with [`Storage::single`], a level
/// above 9, or compression with a libhdf5 lacking the deflate filter give [`IoError::Format`].
pub fn write_file_with(
    path: &Path,
    header: &Header,
    fields: &[Field],
    storage: Storage,
) -> Result<(), IoError> {
    validate(path, header, fields)?;
    if storage.single && header.kind == FileKind::Checkpoint {
        return Err(format_err(
            path,
            "a checkpoint must store f64 values (it is resumed bit for bit), not f32".into(),
        ));
    }
    if storage.compression > 9 {
        return Err(format_err(
            path,
            format!(
                "compression level {} (1-9, or 0 for none)",
                storage.compression
            ),
        ));
    }
    if storage.compression > 0 && !hdf5::filters::deflate_available() {
        return Err(format_err(
            path,
            "compression needs the deflate (zlib) filter, which this libhdf5 lacks".into(),
        ));
    }
    let block = checksum::block_size(
        fields
            .iter()
            .map(|f| dataset_path(&f.name).len())
            .chain([CONNECTIVITY_DATASET.len()]),
    );
    replace_atomically(path, |tmp| {
        write_hdf5(tmp, path, header, fields, (storage, block))?;
        checksum::seal(tmp, path)
    })
}

/// Recomputes the checksums of a file written by [`write_file`] and then changed with another
/// HDF5 tool (for example an attribute edited with h5py), so that [`read_file`] accepts it
/// again. The file must keep the user block `write_file` gave it.
pub fn reseal(path: &Path) -> Result<(), IoError> {
    checksum::seal(path, path)
}

/// Reads a file written by [`write_file`].
///
/// Before the HDF5 library parses the file, every byte is checked against the checksums in its
/// user block: a damaged file gives [`IoError::Damaged`] naming the dataset whose values, or the
/// part of the file, that does not match; an HDF5 file without the block gives
/// [`IoError::Unverifiable`] (see [`read_file_with`]). A file that is neither gives
/// [`IoError::Format`].
///
/// Fields come back in the order they were written (the `field_order` attribute of
/// `/particles`); extra attributes in the order of the root `extra_attrs` attribute. A missing
/// attribute, group or dataset, or one of an unexpected type, shape or size, gives
/// [`IoError::Format`] naming it; a file that is not HDF5 gives [`IoError::Hdf5`]; a file that
/// cannot be accessed gives [`IoError::Fs`].
pub fn read_file(path: &Path) -> Result<Snapshot, IoError> {
    read_file_with(path, Verify::Required)
}

/// [`read_file`], also accepting a file without a checksum block with
/// [`Verify::Unchecked`] (unsafe; see there). Every dataset's type, shape and size is checked
/// against its storage and the file's length before any value is read.
pub fn read_file_with(path: &Path, trust: Verify) -> Result<Snapshot, IoError> {
    read_stored(path, trust).map(|(snapshot, _)| snapshot)
}

/// [`read_file_with`], also returning how each field is stored ([`read_layout`]), from one
/// opening of the file.
pub fn read_stored(path: &Path, trust: Verify) -> Result<(Snapshot, Vec<FieldSpec>), IoError> {
    let file = open(path, Scope::All, trust)?;
    let header = read_header_from(&file, path)?;
    let group = particles_group(&file, path)?;
    let mut datasets = Vec::new();
    for name in field_order(&group, path)? {
        let ds = field_dataset(&group, path, &name)?;
        let spec = field_spec(&ds, path, &name)?;
        datasets.push((ds, spec));
    }
    let specs: Vec<FieldSpec> = datasets.iter().map(|(_, s)| s.clone()).collect();
    let mut fields = Vec::new();
    for (ds, spec) in datasets {
        let name = spec.name;
        let data = if spec.single {
            Data::F64 {
                values: ds
                    .read_raw::<f32>()
                    .map_err(h5err(path, &dataset_path(&name)))?
                    .into_iter()
                    .map(f64::from)
                    .collect(),
                shape: spec.shape,
            }
        } else if spec.integer {
            Data::U32 {
                values: ds
                    .read_raw::<u32>()
                    .map_err(h5err(path, &dataset_path(&name)))?,
                shape: spec.shape,
            }
        } else {
            Data::F64 {
                values: ds
                    .read_raw::<f64>()
                    .map_err(h5err(path, &dataset_path(&name)))?,
                shape: spec.shape,
            }
        };
        if data.value_count() != data.shape().iter().product::<usize>() {
            return Err(format_err(
                path,
                format!(
                    "{}: value count does not match its shape",
                    dataset_path(&name)
                ),
            ));
        }
        fields.push(Field {
            name,
            unit: spec.unit,
            data,
        });
    }
    Ok((Snapshot { header, fields }, specs))
}

/// Reads only the root attributes of a file written by [`write_file`] (no particle data; the
/// checksums of everything but the particle values are verified).
pub fn read_header(path: &Path) -> Result<Header, IoError> {
    read_header_with(path, Verify::Required)
}

/// [`read_header`], also accepting a file without a checksum block with
/// [`Verify::Unchecked`] (unsafe; see there).
pub fn read_header_with(path: &Path, trust: Verify) -> Result<Header, IoError> {
    let file = open(path, Scope::Structure, trust)?;
    read_header_from(&file, path)
}

/// Reads the root attributes and the name, unit, shape and number type of every field, in
/// file order, without reading the values (e.g. to rebuild the XDMF sidecar of a run; the
/// checksums of everything but the particle values are verified).
pub fn read_layout(path: &Path) -> Result<(Header, Vec<FieldSpec>), IoError> {
    read_layout_with(path, Verify::Required)
}

/// [`read_layout`], also accepting a file without a checksum block with
/// [`Verify::Unchecked`] (unsafe; see there).
pub fn read_layout_with(path: &Path, trust: Verify) -> Result<(Header, Vec<FieldSpec>), IoError> {
    let file = open(path, Scope::Structure, trust)?;
    let header = read_header_from(&file, path)?;
    let group = particles_group(&file, path)?;
    let mut specs = Vec::new();
    for name in field_order(&group, path)? {
        let ds = field_dataset(&group, path, &name)?;
        specs.push(field_spec(&ds, path, &name)?);
    }
    Ok((header, specs))
}

/// Files in `dir` whose names start with `prefix` and end with `suffix` (e.g. `"snap_"`,
/// `".h5"`), sorted by name; hidden files (leading `.`, such as the temporary files of
/// [`write_file`]) and non-files are skipped. With zero-padded step numbers the name order
/// is the time order.
pub fn list_files(dir: &Path, prefix: &str, suffix: &str) -> Result<Vec<PathBuf>, IoError> {
    let fs_err = |source| IoError::Fs {
        path: dir.to_path_buf(),
        source,
    };
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(fs_err)? {
        let entry = entry.map_err(fs_err)?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        if name.starts_with('.')
            || name.len() < prefix.len() + suffix.len()
            || !name.starts_with(prefix)
            || !name.ends_with(suffix)
        {
            continue;
        }
        let path = entry.path();
        if path.is_file() {
            out.push(path);
        }
    }
    out.sort();
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Errors

fn dataset_path(name: &str) -> String {
    format!("/{PARTICLES_GROUP}/{name}")
}

fn format_err(path: &Path, message: String) -> IoError {
    IoError::Format {
        path: path.to_path_buf(),
        message,
    }
}

/// Maps an HDF5 error to [`IoError::Hdf5`] for `path`, prefixing the message with `context`.
fn h5err(path: &Path, context: impl Into<String>) -> impl FnOnce(hdf5::Error) -> IoError {
    let path = path.to_path_buf();
    let context = context.into();
    move |e| IoError::Hdf5 {
        path,
        message: format!("{context}: {e}"),
    }
}
