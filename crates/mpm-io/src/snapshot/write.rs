//! Writing a file with the HDF5 library: the checks of the inputs, the root attributes, the
//! `/particles` datasets (contiguous, or chunked with the shuffle and deflate filters), a
//! snapshot's `/mesh/connectivity`, and the attribute writers.

use super::{
    dataset_path, format_err, h5err, Data, Field, FileKind, Header, Storage, CONNECTIVITY_DATASET,
    EXTRA_ATTRS_ATTR, FIELD_ORDER_ATTR, MESH_GROUP, PARTICLES_GROUP, RESERVED_ROOT_ATTRS,
    UNIT_ATTR,
};
use crate::IoError;
use hdf5::plist::group_create::LinkCreationOrder;
use hdf5::types::VarLenUnicode;
use std::path::Path;
use std::str::FromStr;

pub(super) fn validate(path: &Path, header: &Header, fields: &[Field]) -> Result<(), IoError> {
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
pub(super) fn write_hdf5(
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
