//! Reading a file with the HDF5 library once its checksums match: the root attributes into a
//! [`Header`], the field order, datasets and [`FieldSpec`]s of `/particles`, and the typed
//! attribute readers, which name what is missing or of an unexpected type.

use super::{
    dataset_path, format_err, h5err, FieldSpec, FileKind, Header, EXTRA_ATTRS_ATTR,
    FIELD_ORDER_ATTR, PARTICLES_GROUP, UNIT_ATTR,
};
use crate::checksum::{self, Scope, Verify};
use crate::IoError;
use hdf5::types::{FloatSize, IntSize, TypeDescriptor, VarLenAscii, VarLenUnicode};
use std::path::Path;

/// Opens `path` with the HDF5 library once its checksums over `scope` match (or, with
/// [`Verify::Unchecked`], when it has none).
pub(super) fn open(path: &Path, scope: Scope, trust: Verify) -> Result<hdf5::File, IoError> {
    checksum::verify(path, scope, trust)?;
    hdf5::File::open(path).map_err(h5err(path, "opening the file as HDF5"))
}

pub(super) fn read_header_from(file: &hdf5::File, path: &Path) -> Result<Header, IoError> {
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

pub(super) fn particles_group(file: &hdf5::File, path: &Path) -> Result<hdf5::Group, IoError> {
    if !file.link_exists(PARTICLES_GROUP) {
        return Err(format_err(path, "missing group /particles".into()));
    }
    file.group(PARTICLES_GROUP)
        .map_err(|e| format_err(path, format!("/particles is not a group: {e}")))
}

pub(super) fn field_order(group: &hdf5::Group, path: &Path) -> Result<Vec<String>, IoError> {
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

pub(super) fn field_dataset(
    group: &hdf5::Group,
    path: &Path,
    name: &str,
) -> Result<hdf5::Dataset, IoError> {
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

pub(super) fn field_spec(
    ds: &hdf5::Dataset,
    path: &Path,
    name: &str,
) -> Result<FieldSpec, IoError> {
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
    // A contiguous dataset's values must lie inside the file.
    let file_len = std::fs::metadata(path)
        .map_err(|source| IoError::Fs {
            path: path.to_path_buf(),
            source,
        })?
        .len();
    if let Some(at) = ds.offset() {
        if at.checked_add(stored).is_none_or(|end| end > file_len) {
            return Err(format_err(
                path,
                format!(
                    "{what}: its {stored} bytes at offset {at} lie past the end of the file \
                     ({file_len} bytes)"
                ),
            ));
        }
    }
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
