//! Snapshot and checkpoint files.

use crate::atomic::replace_atomically;
use crate::checksum::{self, Scope};
use crate::IoError;
use hdf5::plist::group_create::LinkCreationOrder;
use hdf5::types::{FloatSize, IntSize, TypeDescriptor, VarLenAscii, VarLenUnicode};
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Numeric payload of a field, row-major with `shape[0] = N` particles.
#[derive(Clone, Debug, PartialEq)]
pub enum Data {
    /// 64-bit floats.
    F64 {
        /// Values, row-major.
        values: Vec<f64>,
        /// Shape `[N, …]`.
        shape: Vec<usize>,
    },
    /// 32-bit unsigned integers (indices).
    U32 {
        /// Values, row-major.
        values: Vec<u32>,
        /// Shape `[N, …]`.
        shape: Vec<usize>,
    },
}

/// A named per-particle array with its unit.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Dataset name under `/particles`.
    pub name: String,
    /// Unit string (e.g. "m", "m/s", "kg", "Pa", "1").
    pub unit: String,
    /// The data.
    pub data: Data,
}

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
        let mut spec = field.spec();
        spec.single = self.single && !spec.integer;
        spec
    }
}

impl Field {
    /// The field's name, unit, shape and type.
    pub fn spec(&self) -> FieldSpec {
        let (shape, integer) = match &self.data {
            Data::F64 { shape, .. } => (shape.clone(), false),
            Data::U32 { shape, .. } => (shape.clone(), true),
        };
        FieldSpec {
            name: self.name.clone(),
            unit: self.unit.clone(),
            shape,
            integer,
            single: false,
        }
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

impl Data {
    /// Shape `[N, …]` of the array.
    pub fn shape(&self) -> &[usize] {
        match self {
            Data::F64 { shape, .. } | Data::U32 { shape, .. } => shape,
        }
    }

    /// Number of stored values (the slice length, not the number of particles).
    fn value_count(&self) -> usize {
        match self {
            Data::F64 { values, .. } => values.len(),
            Data::U32 { values, .. } => values.len(),
        }
    }
}

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
/// part of the file, that does not match (files written before mpm-io had checksums, HDF5 with
/// no user block, are read unverified). A file that is neither gives [`IoError::Format`].
///
/// Fields come back in the order they were written (the `field_order` attribute of
/// `/particles`); extra attributes in the order of the root `extra_attrs` attribute. A missing
/// attribute, group or dataset, or one of an unexpected type, gives [`IoError::Format`] naming
/// it; a file that is not HDF5 gives [`IoError::Hdf5`]; a file that cannot be accessed gives
/// [`IoError::Fs`].
pub fn read_file(path: &Path) -> Result<Snapshot, IoError> {
    let file = open(path, Scope::All)?;
    let header = read_header_from(&file, path)?;
    let group = particles_group(&file, path)?;
    let mut fields = Vec::new();
    for name in field_order(&group, path)? {
        let ds = field_dataset(&group, path, &name)?;
        let spec = field_spec(&ds, path, &name)?;
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
    Ok(Snapshot { header, fields })
}

/// Reads only the root attributes of a file written by [`write_file`] (no particle data; the
/// checksums of everything but the particle values are verified).
pub fn read_header(path: &Path) -> Result<Header, IoError> {
    let file = open(path, Scope::Structure)?;
    read_header_from(&file, path)
}

/// Reads the root attributes and the name, unit, shape and number type of every field, in
/// file order, without reading the values (e.g. to rebuild the XDMF sidecar of a run; the
/// checksums of everything but the particle values are verified).
pub fn read_layout(path: &Path) -> Result<(Header, Vec<FieldSpec>), IoError> {
    let file = open(path, Scope::Structure)?;
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
// Writing

fn validate(path: &Path, header: &Header, fields: &[Field]) -> Result<(), IoError> {
    let no_nul = |what: &str, s: &str| {
        if s.contains('\0') {
            Err(format_err(path, format!("{what} contains a NUL character")))
        } else {
            Ok(())
        }
    };
    no_nul("units", &header.units)?;
    no_nul("scene", &header.scene)?;
    no_nul("code_version", &header.code_version)?;
    for (i, (name, _)) in header.attrs.iter().enumerate() {
        if name.is_empty() {
            return Err(format_err(
                path,
                "an extra attribute has an empty name".into(),
            ));
        }
        no_nul(&format!("extra attribute name {name:?}"), name)?;
        if RESERVED_ROOT_ATTRS.contains(&name.as_str()) {
            return Err(format_err(
                path,
                format!("extra attribute `{name}` clashes with a reserved root attribute"),
            ));
        }
        if header.attrs[..i].iter().any(|(n, _)| n == name) {
            return Err(format_err(
                path,
                format!("extra attribute `{name}` is repeated"),
            ));
        }
    }
    for (i, f) in fields.iter().enumerate() {
        let name = &f.name;
        if name.is_empty() || name == "." || name.contains('/') || name.contains('\0') {
            return Err(format_err(
                path,
                format!("invalid field name {name:?} (empty, \".\", or containing '/' or NUL)"),
            ));
        }
        if fields[..i].iter().any(|g| &g.name == name) {
            return Err(format_err(path, format!("field `{name}` is repeated")));
        }
        no_nul(&format!("unit of field `{name}`"), &f.unit)?;
        let shape = f.data.shape();
        if shape.is_empty() {
            return Err(format_err(
                path,
                format!("field `{name}` has an empty shape; expected [N, …]"),
            ));
        }
        let expected = shape.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
        if expected != Some(f.data.value_count()) {
            return Err(format_err(
                path,
                format!(
                    "field `{name}` has {} values but shape {shape:?}",
                    f.data.value_count()
                ),
            ));
        }
    }
    Ok(())
}

/// Writes the HDF5 file, leaving a user block of `block` bytes for the checksums.
fn write_hdf5(
    tmp: &Path,
    path: &Path,
    header: &Header,
    fields: &[Field],
    (storage, block): (Storage, u64),
) -> Result<(), IoError> {
    let tmp_name = tmp
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let err = |what: &str| h5err(path, format!("writing {what} (temporary file {tmp_name})"));

    let file = hdf5::File::with_options()
        .with_fcpl(|p| p.obj_track_times(false).userblock(block))
        .create(tmp)
        .map_err(err("the file"))?;
    {
        let root: &hdf5::Location = &file;
        write_str_attr(root, "kind", header.kind.as_str()).map_err(err("attribute kind"))?;
        write_scalar_attr(root, "time", &header.time).map_err(err("attribute time"))?;
        write_scalar_attr(root, "step", &header.step).map_err(err("attribute step"))?;
        write_scalar_attr(root, "dt", &header.dt).map_err(err("attribute dt"))?;
        write_scalar_attr(root, "dim", &header.dim).map_err(err("attribute dim"))?;
        write_str_attr(root, "units", &header.units).map_err(err("attribute units"))?;
        write_str_attr(root, "scene", &header.scene).map_err(err("attribute scene"))?;
        write_str_attr(root, "code_version", &header.code_version)
            .map_err(err("attribute code_version"))?;
        let extra_names: Vec<&str> = header.attrs.iter().map(|(n, _)| n.as_str()).collect();
        write_str_list_attr(root, EXTRA_ATTRS_ATTR, &extra_names)
            .map_err(err("attribute extra_attrs"))?;
        for (name, value) in &header.attrs {
            write_scalar_attr(root, name, value).map_err(err(&format!("attribute {name}")))?;
        }

        let group = file
            .create_group_builder()
            .with_gcpl(|p| {
                p.obj_track_times(false)
                    .link_creation_order(LinkCreationOrder::Tracked)
            })
            .create(PARTICLES_GROUP)
            .map_err(err("group /particles"))?;
        let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
        write_str_list_attr(&group, FIELD_ORDER_ATTR, &names)
            .map_err(err("attribute /particles field_order"))?;
        for f in fields {
            let what = dataset_path(&f.name);
            let ds = match &f.data {
                Data::F64 { values, shape } if storage.single => {
                    let single: Vec<f32> = values.iter().map(|&v| v as f32).collect();
                    let ds = dataset_builder::<f32>(&group, shape, storage)
                        .create(f.name.as_str())
                        .map_err(err(&what))?;
                    ds.write_raw(single.as_slice()).map_err(err(&what))?;
                    ds
                }
                Data::F64 { values, shape } => {
                    let ds = dataset_builder::<f64>(&group, shape, storage)
                        .create(f.name.as_str())
                        .map_err(err(&what))?;
                    ds.write_raw(values.as_slice()).map_err(err(&what))?;
                    ds
                }
                Data::U32 { values, shape } => {
                    let ds = dataset_builder::<u32>(&group, shape, storage)
                        .create(f.name.as_str())
                        .map_err(err(&what))?;
                    ds.write_raw(values.as_slice()).map_err(err(&what))?;
                    ds
                }
            };
            write_str_attr(&ds, UNIT_ATTR, &f.unit).map_err(err(&format!("{what} unit")))?;
        }
        if header.kind == FileKind::Snapshot {
            write_connectivity(&file, fields).map_err(err(CONNECTIVITY_DATASET))?;
        }
        // Every handle into the file (group, datasets, attributes) is dropped here, so the
        // close below really releases the file.
    }
    file.close().map_err(err("(closing) the file"))
}

/// Rows of a dataset per compressed chunk: about 256 KiB of values per chunk.
const CHUNK_VALUES: usize = 1 << 15;

/// A dataset of `T` shaped `shape` under `group`: contiguous, or, with compression, chunked
/// along the particles (whole rows, about [`CHUNK_VALUES`] values a chunk) with the shuffle
/// and deflate filters. An empty dataset stays contiguous (chunks cannot be empty).
fn dataset_builder<T: hdf5::H5Type>(
    group: &hdf5::Group,
    shape: &[usize],
    storage: Storage,
) -> hdf5::DatasetBuilderEmptyShape {
    let b = group.new_dataset::<T>();
    let total: usize = shape.iter().product();
    if storage.compression == 0 || total == 0 {
        return b.shape(shape);
    }
    let row: usize = shape.iter().skip(1).product::<usize>().max(1);
    let mut chunk = shape.to_vec();
    chunk[0] = (CHUNK_VALUES / row).clamp(1, shape[0]);
    b.shape(shape)
        .chunk(chunk)
        .shuffle()
        .deflate(storage.compression)
}

/// A snapshot's `/mesh/connectivity`: `0, 1, …, N−1` (u32), N the rows of `x`, for XDMF
/// readers that need an explicit Polyvertex topology (meshio). Nothing when there is no `x`.
fn write_connectivity(file: &hdf5::File, fields: &[Field]) -> hdf5::Result<()> {
    let Some(n) = fields
        .iter()
        .find(|f| f.name == "x")
        .and_then(|f| f.data.shape().first().copied())
    else {
        return Ok(());
    };
    let ids: Vec<u32> = (0..n as u32).collect();
    let group = file
        .create_group_builder()
        .with_gcpl(|p| p.obj_track_times(false))
        .create(MESH_GROUP)?;
    group
        .new_dataset::<u32>()
        .shape([n])
        .create("connectivity")?
        .write_raw(&ids)
}

fn write_scalar_attr<T: hdf5::H5Type>(
    loc: &hdf5::Location,
    name: &str,
    value: &T,
) -> hdf5::Result<()> {
    let attr = loc.new_attr::<T>().shape(()).create(name)?;
    attr.write_scalar(value)
}

fn write_str_attr(loc: &hdf5::Location, name: &str, value: &str) -> hdf5::Result<()> {
    let v = VarLenUnicode::from_str(value).map_err(|e| hdf5::Error::from(e.to_string()))?;
    write_scalar_attr(loc, name, &v)
}

fn write_str_list_attr(loc: &hdf5::Location, name: &str, values: &[&str]) -> hdf5::Result<()> {
    let list = values
        .iter()
        .map(|s| VarLenUnicode::from_str(s).map_err(|e| hdf5::Error::from(e.to_string())))
        .collect::<hdf5::Result<Vec<_>>>()?;
    let attr = loc
        .new_attr::<VarLenUnicode>()
        .shape([list.len()])
        .create(name)?;
    attr.write_raw(list.as_slice())
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Opens `path` with the HDF5 library once its checksums over `scope` match.
fn open(path: &Path, scope: Scope) -> Result<hdf5::File, IoError> {
    checksum::verify(path, scope)?;
    hdf5::File::open(path).map_err(h5err(path, "opening the file as HDF5"))
}

fn read_header_from(file: &hdf5::File, path: &Path) -> Result<Header, IoError> {
    let root: &hdf5::Location = file;
    let owner = "the root group";
    let kind_str = read_str_attr(root, path, owner, "kind")?;
    let kind = FileKind::parse(&kind_str).ok_or_else(|| {
        format_err(
            path,
            format!("attribute `kind` is {kind_str:?}, expected \"snapshot\" or \"checkpoint\""),
        )
    })?;
    let time = read_num_attr::<f64>(root, path, owner, "time", F64)?;
    let step = read_num_attr::<u64>(root, path, owner, "step", U64)?;
    let dt = read_num_attr::<f64>(root, path, owner, "dt", F64)?;
    let dim = read_num_attr::<u32>(root, path, owner, "dim", U32)?;
    let units = read_str_attr(root, path, owner, "units")?;
    let scene = read_str_attr(root, path, owner, "scene")?;
    let code_version = read_str_attr(root, path, owner, "code_version")?;
    let mut attrs = Vec::new();
    for name in read_str_list_attr(root, path, owner, EXTRA_ATTRS_ATTR)? {
        let value = read_num_attr::<f64>(root, path, owner, &name, F64)?;
        attrs.push((name, value));
    }
    Ok(Header {
        kind,
        time,
        step,
        dt,
        dim,
        units,
        scene,
        code_version,
        attrs,
    })
}

fn particles_group(file: &hdf5::File, path: &Path) -> Result<hdf5::Group, IoError> {
    if !file.link_exists(PARTICLES_GROUP) {
        return Err(format_err(path, "missing group /particles".into()));
    }
    file.group(PARTICLES_GROUP)
        .map_err(|e| format_err(path, format!("/particles is not a group: {e}")))
}

fn field_order(group: &hdf5::Group, path: &Path) -> Result<Vec<String>, IoError> {
    let names = read_str_list_attr(group, path, "/particles", FIELD_ORDER_ATTR)?;
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            return Err(format_err(
                path,
                format!("attribute `field_order` of /particles lists `{name}` twice"),
            ));
        }
    }
    Ok(names)
}

fn field_dataset(group: &hdf5::Group, path: &Path, name: &str) -> Result<hdf5::Dataset, IoError> {
    let what = dataset_path(name);
    if name.is_empty() || name.contains('/') || !group.link_exists(name) {
        return Err(format_err(
            path,
            format!("missing dataset {what} (listed in `field_order`)"),
        ));
    }
    group
        .dataset(name)
        .map_err(|e| format_err(path, format!("{what} is not a dataset: {e}")))
}

fn field_spec(ds: &hdf5::Dataset, path: &Path, name: &str) -> Result<FieldSpec, IoError> {
    let what = dataset_path(name);
    let unit = read_str_attr(ds, path, &what, UNIT_ATTR)?;
    let shape = ds.shape();
    if shape.is_empty() {
        return Err(format_err(
            path,
            format!("{what} is a scalar; expected shape [N, …]"),
        ));
    }
    let td = ds
        .dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(h5err(path, &what))?;
    let (integer, single) = match td {
        F64 => (false, false),
        F32 => (false, true),
        U32 => (true, false),
        other => {
            return Err(format_err(
                path,
                format!("{what} has type {other}, expected f64, f32 or u32"),
            ))
        }
    };
    // Checked before anything is allocated for the values: a damaged shape in a file without
    // checksums must not ask for more memory than the file holds. A contiguous dataset stores
    // exactly its values; a chunked (deflated) one at least 1/1032 of them, deflate's largest
    // ratio, plus chunk overhead.
    let size = if integer || single { 4 } else { 8 };
    let needed = shape
        .iter()
        .try_fold(size, |acc: u64, &d| acc.checked_mul(d as u64));
    let stored = ds.storage_size();
    let fits = match needed {
        Some(n) if ds.is_chunked() => n <= stored.saturating_mul(1032).saturating_add(1 << 20),
        Some(n) => n == stored,
        None => false,
    };
    if !fits {
        return Err(format_err(
            path,
            format!(
                "{what} stores {} bytes, its shape {shape:?} needs {}",
                ds.storage_size(),
                needed.map_or("more than 2^64".into(), |n| n.to_string())
            ),
        ));
    }
    Ok(FieldSpec {
        name: name.to_owned(),
        unit,
        shape,
        integer,
        single,
    })
}

const F64: TypeDescriptor = TypeDescriptor::Float(FloatSize::U8);
const F32: TypeDescriptor = TypeDescriptor::Float(FloatSize::U4);
const U64: TypeDescriptor = TypeDescriptor::Unsigned(IntSize::U8);
const U32: TypeDescriptor = TypeDescriptor::Unsigned(IntSize::U4);

/// Opens attribute `name` of `loc` (described as `owner` in messages) and returns it with its
/// type; a missing attribute is a format error.
fn open_attr(
    loc: &hdf5::Location,
    path: &Path,
    owner: &str,
    name: &str,
) -> Result<(hdf5::Attribute, TypeDescriptor), IoError> {
    let names = loc.attr_names().map_err(h5err(path, owner))?;
    if !names.iter().any(|n| n == name) {
        return Err(format_err(
            path,
            format!("missing attribute `{name}` on {owner}"),
        ));
    }
    let what = format!("attribute `{name}` on {owner}");
    let attr = loc.attr(name).map_err(h5err(path, &what))?;
    let td = attr
        .dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(|e| format_err(path, format!("{what} has an unsupported type: {e}")))?;
    Ok((attr, td))
}

fn read_num_attr<T: hdf5::H5Type>(
    loc: &hdf5::Location,
    path: &Path,
    owner: &str,
    name: &str,
    expected: TypeDescriptor,
) -> Result<T, IoError> {
    let (attr, td) = open_attr(loc, path, owner, name)?;
    let what = format!("attribute `{name}` on {owner}");
    if td != expected || !attr.is_scalar() {
        return Err(format_err(
            path,
            format!(
                "{what} is {td} of shape {:?}, expected a scalar {expected}",
                attr.shape()
            ),
        ));
    }
    attr.read_scalar::<T>().map_err(h5err(path, &what))
}

fn read_str_attr(
    loc: &hdf5::Location,
    path: &Path,
    owner: &str,
    name: &str,
) -> Result<String, IoError> {
    let (attr, td) = open_attr(loc, path, owner, name)?;
    let what = format!("attribute `{name}` on {owner}");
    if !attr.is_scalar() {
        return Err(format_err(
            path,
            format!(
                "{what} has shape {:?}, expected a scalar string",
                attr.shape()
            ),
        ));
    }
    let bytes = match td {
        TypeDescriptor::VarLenUnicode => attr
            .read_scalar::<VarLenUnicode>()
            .map_err(h5err(path, &what))?
            .as_bytes()
            .to_vec(),
        TypeDescriptor::VarLenAscii => attr
            .read_scalar::<VarLenAscii>()
            .map_err(h5err(path, &what))?
            .as_bytes()
            .to_vec(),
        other => {
            return Err(format_err(
                path,
                format!("{what} has type {other}, expected a variable-length string"),
            ))
        }
    };
    String::from_utf8(bytes).map_err(|_| format_err(path, format!("{what} is not valid UTF-8")))
}

fn read_str_list_attr(
    loc: &hdf5::Location,
    path: &Path,
    owner: &str,
    name: &str,
) -> Result<Vec<String>, IoError> {
    let (attr, td) = open_attr(loc, path, owner, name)?;
    let what = format!("attribute `{name}` on {owner}");
    if td != TypeDescriptor::VarLenUnicode || attr.ndim() != 1 {
        return Err(format_err(
            path,
            format!(
                "{what} is {td} of shape {:?}, expected a 1-D array of variable-length UTF-8 \
                 strings",
                attr.shape()
            ),
        ));
    }
    attr.read_raw::<VarLenUnicode>()
        .map_err(h5err(path, &what))?
        .iter()
        .map(|s| {
            std::str::from_utf8(s.as_bytes())
                .map(str::to_owned)
                .map_err(|_| format_err(path, format!("{what} holds invalid UTF-8")))
        })
        .collect()
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
