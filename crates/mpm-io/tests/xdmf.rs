//! The XDMF sidecar: well-formed XML with the expected grids, times, dimensions and
//! references, written atomically.

use mpm_io::{write_xdmf, write_xdmf_pieces, FieldSpec, IoError, SeriesEntry};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mpm-io-xdmf-tests")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn spec(name: &str, shape: &[usize], integer: bool) -> FieldSpec {
    FieldSpec {
        name: name.into(),
        unit: "1".into(),
        shape: shape.to_vec(),
        integer,
        single: false,
    }
}

fn entry(time: f64, step: usize, n: usize, dim: usize) -> SeriesEntry {
    SeriesEntry {
        time,
        file: format!("snap_{step:06}.h5"),
        dim: dim as u32,
        fields: vec![
            spec("x", &[n, dim], false),
            spec("v", &[n, dim], false),
            spec("mass", &[n], false),
            spec("stress", &[n, dim, dim], false),
            spec("material", &[n], true),
            FieldSpec {
                single: true,
                ..spec("pressure", &[n], false)
            },
        ],
    }
}

fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, tag: &str) -> roxmltree::Node<'a, 'i> {
    node.children()
        .find(|c| c.has_tag_name(tag))
        .unwrap_or_else(|| panic!("no <{tag}> in <{}>", node.tag_name().name()))
}

/// (Dimensions, NumberType, Precision, Format, text) of the `DataItem` under `node`.
fn data_item(node: roxmltree::Node) -> (String, String, String, String, String) {
    let d = child(node, "DataItem");
    let a = |k: &str| {
        d.attribute(k)
            .unwrap_or_else(|| panic!("DataItem lacks {k}"))
    };
    (
        a("Dimensions").into(),
        a("NumberType").into(),
        a("Precision").into(),
        a("Format").into(),
        d.text().unwrap().trim().into(),
    )
}

/// Parses `path` and checks it against `entries`, returning the number of Uniform grids.
fn check(path: &Path, entries: &[SeriesEntry]) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).expect("the XDMF file is well-formed XML");
    let root = doc.root_element();
    assert!(root.has_tag_name("Xdmf"));
    assert_eq!(root.attribute("Version"), Some("3.0"));
    let collection = child(child(root, "Domain"), "Grid");
    assert_eq!(collection.attribute("GridType"), Some("Collection"));
    assert_eq!(collection.attribute("CollectionType"), Some("Temporal"));
    let grids: Vec<_> = collection
        .children()
        .filter(|c| c.has_tag_name("Grid"))
        .collect();
    assert_eq!(grids.len(), entries.len());
    for (g, e) in grids.iter().zip(entries) {
        assert_eq!(g.attribute("GridType"), Some("Uniform"));
        let t: f64 = child(*g, "Time")
            .attribute("Value")
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(t.to_bits(), e.time.to_bits(), "time reads back exactly");
        let n = e.fields[0].shape[0];
        let topo = child(*g, "Topology");
        assert_eq!(topo.attribute("TopologyType"), Some("Polyvertex"));
        assert_eq!(topo.attribute("NumberOfElements"), Some(&*n.to_string()));
        assert_eq!(topo.attribute("NodesPerElement"), Some("1"));
        assert_eq!(
            data_item(topo),
            (
                n.to_string(),
                "UInt".into(),
                "4".into(),
                "HDF".into(),
                format!("{}:/mesh/connectivity", e.file)
            )
        );
        let geom = child(*g, "Geometry");
        let want_geom = if e.dim == 2 { "XY" } else { "XYZ" };
        assert_eq!(geom.attribute("GeometryType"), Some(want_geom));
        assert_eq!(
            data_item(geom),
            (
                format!("{n} {}", e.dim),
                "Float".into(),
                "8".into(),
                "HDF".into(),
                format!("{}:/particles/x", e.file)
            )
        );
        let attrs: Vec<_> = g
            .children()
            .filter(|c| c.has_tag_name("Attribute"))
            .collect();
        assert_eq!(
            attrs.len(),
            e.fields.len() - 1,
            "one attribute per non-x field"
        );
        for (a, f) in attrs.iter().zip(e.fields.iter().filter(|f| f.name != "x")) {
            assert_eq!(a.attribute("Name"), Some(&*f.name));
            assert_eq!(a.attribute("Center"), Some("Node"));
            let (dims, number_type, precision, format, reference) = data_item(*a);
            assert_eq!(format, "HDF");
            assert_eq!(reference, format!("{}:/particles/{}", e.file, f.name));
            if f.integer {
                assert_eq!((&*number_type, &*precision), ("UInt", "4"));
            } else if f.single {
                assert_eq!((&*number_type, &*precision), ("Float", "4"));
            } else {
                assert_eq!((&*number_type, &*precision), ("Float", "8"));
            }
            let d = e.dim as usize;
            let (want_type, want_dims) = match f.shape.as_slice() {
                [n] => ("Scalar", format!("{n}")),
                [n, k] if *k == d => ("Vector", format!("{n} {k}")),
                [n, 3, 3] => ("Tensor", format!("{n} 3 3")),
                [n, 2, 2] => ("Matrix", format!("{n} 2 2")),
                other => panic!("unexpected shape {other:?}"),
            };
            assert_eq!(a.attribute("AttributeType"), Some(want_type), "{}", f.name);
            assert_eq!(dims, want_dims, "{}", f.name);
        }
    }
    grids.len()
}

#[test]
fn xdmf_2d_series_has_the_expected_structure() {
    let dir = scratch("series2d");
    let path = dir.join("run.xmf");
    let entries: Vec<_> = [0.0, 1e-7, 0.1 + 0.2, 12.5]
        .iter()
        .enumerate()
        .map(|(i, &t)| entry(t, i * 100, 10 + i, 2))
        .collect();
    write_xdmf(&path, &entries).unwrap();
    assert_eq!(check(&path, &entries), 4);
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.matches("<Time ").count(), 4);
    assert_eq!(text.matches("GeometryType=\"XY\"").count(), 4);
    assert_eq!(text.matches("AttributeType=\"Matrix\"").count(), 4);
}

#[test]
fn xdmf_3d_series_has_the_expected_structure() {
    let dir = scratch("series3d");
    let path = dir.join("run.xmf");
    let entries: Vec<_> = (0..3).map(|i| entry(i as f64 * 0.5, i, 7, 3)).collect();
    write_xdmf(&path, &entries).unwrap();
    assert_eq!(check(&path, &entries), 3);
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.matches("AttributeType=\"Tensor\"").count(), 3);
    assert_eq!(text.matches("GeometryType=\"XYZ\"").count(), 3);
}

#[test]
fn xdmf_empty_series_is_well_formed() {
    let dir = scratch("empty");
    let path = dir.join("run.xmf");
    write_xdmf(&path, &[]).unwrap();
    assert_eq!(check(&path, &[]), 0);
}

#[test]
fn xdmf_escapes_special_characters_in_names() {
    let dir = scratch("escape");
    let path = dir.join("run.xmf");
    let mut e = entry(1.0, 1, 3, 2);
    e.file = "a&b <'c'> \"d\".h5".into();
    e.fields.push(spec("σ<&>\"'", &[3], false));
    write_xdmf(&path, std::slice::from_ref(&e)).unwrap();
    assert_eq!(check(&path, std::slice::from_ref(&e)), 1);
}

#[test]
fn xdmf_is_rewritten_atomically() {
    let dir = scratch("atomic");
    let path = dir.join("run.xmf");
    let mut entries = vec![entry(0.0, 0, 4, 2)];
    write_xdmf(&path, &entries).unwrap();
    for i in 1..5 {
        entries.push(entry(i as f64, i, 4, 2));
        write_xdmf(&path, &entries).unwrap();
        assert_eq!(check(&path, &entries), i + 1);
    }
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["run.xmf"], "no temporary file left behind");
}

#[test]
fn xdmf_rejects_unusable_entries_without_touching_the_file() {
    let dir = scratch("reject");
    let path = dir.join("run.xmf");
    let good = vec![entry(0.0, 0, 4, 2)];
    write_xdmf(&path, &good).unwrap();
    let before = std::fs::read(&path).unwrap();

    let mut no_x = entry(1.0, 1, 4, 2);
    no_x.fields.remove(0);
    let mut wrong_n = entry(1.0, 1, 4, 2);
    wrong_n.fields[2].shape = vec![5];
    let mut bad_time = entry(1.0, 1, 4, 2);
    bad_time.time = f64::NAN;
    let mut bad_dim = entry(1.0, 1, 4, 2);
    bad_dim.dim = 3;
    for (what, e) in [
        ("no x", no_x),
        ("wrong N", wrong_n),
        ("NaN time", bad_time),
        ("dim", bad_dim),
    ] {
        let err = write_xdmf(&path, &[good[0].clone(), e]).unwrap_err();
        assert!(matches!(err, IoError::Format { .. }), "{what}: {err:?}");
    }
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
}

#[test]
fn xdmf_into_a_missing_directory_is_an_error() {
    let dir = scratch("missing");
    let err = write_xdmf(&dir.join("no/run.xmf"), &[entry(0.0, 0, 1, 3)]).unwrap_err();
    assert!(matches!(err, IoError::Fs { .. }), "{err:?}");
}

/// A step written in pieces (one file per rank) is a spatial collection holding one uniform
/// grid per piece, with the step's time; pieces at different times are refused.
#[test]
fn pieces_of_a_step_form_a_spatial_collection() {
    let dir = scratch("pieces");
    let piece = |time: f64, r: usize, n: usize| SeriesEntry {
        file: format!("snap_000001_p{r:04}.h5"),
        ..entry(time, 1, n, 3)
    };
    let first = [entry(0.0, 0, 10, 3)];
    let second = [piece(0.5, 0, 4), piece(0.5, 1, 6)];
    let path = dir.join("run.xmf");
    write_xdmf_pieces(&path, &[&first, &second]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let temporal = child(child(doc.root_element(), "Domain"), "Grid");
    let steps: Vec<_> = temporal.children().filter(|c| c.is_element()).collect();
    assert_eq!(steps.len(), 2);
    assert_eq!(steps[0].attribute("GridType"), Some("Uniform"));
    assert_eq!(steps[1].attribute("CollectionType"), Some("Spatial"));
    assert_eq!(child(steps[1], "Time").attribute("Value"), Some("0.5"));
    let grids: Vec<_> = steps[1]
        .children()
        .filter(|c| c.has_tag_name("Grid"))
        .collect();
    assert_eq!(grids.len(), 2);
    let (dims, _, _, _, file) = data_item(child(grids[1], "Geometry"));
    assert_eq!(dims, "6 3");
    assert_eq!(file, "snap_000001_p0001.h5:/particles/x");
    let skewed = [piece(0.5, 0, 4), piece(0.6, 1, 6)];
    assert!(matches!(
        write_xdmf_pieces(&dir.join("bad.xmf"), &[&skewed]),
        Err(IoError::Format { .. })
    ));
}
