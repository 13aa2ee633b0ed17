//! Round trips, atomic writes and error paths of the snapshot/checkpoint files.

use mpm_io::{
    list_files, read_file, read_file_with, read_header, read_header_with, read_layout,
    read_layout_with, reseal, write_file, write_file_with, Data, Field, FieldSpec, FileKind,
    Header, IoError, Storage, Verify,
};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A fresh, empty directory under Cargo's per-target temporary directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mpm-io-tests")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Names of every entry of `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// SplitMix64: deterministic pseudo-random bits without a dependency.
struct Bits(u64);

impl Bits {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Any non-NaN f64 (random bit patterns, so all exponents, infinities and subnormals
    /// occur), with the awkward values planted at the start.
    fn f64s(&mut self, len: usize) -> Vec<f64> {
        let special = [
            -0.0,
            0.0,
            f64::from_bits(1),                      // smallest subnormal
            -f64::from_bits(0x000F_FFFF_FFFF_FFFF), // largest subnormal, negative
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::EPSILON,
            0.1 + 0.2,
        ];
        let mut out: Vec<f64> = special.iter().copied().take(len).collect();
        while out.len() < len {
            let v = f64::from_bits(self.next());
            if !v.is_nan() {
                out.push(v);
            }
        }
        out
    }

    fn u32s(&mut self, len: usize) -> Vec<u32> {
        let mut out = vec![0, u32::MAX, 1];
        out.truncate(len);
        while out.len() < len {
            out.push(self.next() as u32);
        }
        out
    }
}

fn f64_field(name: &str, unit: &str, shape: Vec<usize>, bits: &mut Bits) -> Field {
    let len = shape.iter().product();
    Field {
        name: name.into(),
        unit: unit.into(),
        data: Data::F64 {
            values: bits.f64s(len),
            shape,
        },
    }
}

fn u32_field(name: &str, shape: Vec<usize>, bits: &mut Bits) -> Field {
    let len = shape.iter().product();
    Field {
        name: name.into(),
        unit: "1".into(),
        data: Data::U32 {
            values: bits.u32s(len),
            shape,
        },
    }
}

/// Particle fields of a `dim`-dimensional run with `n` particles, deliberately not in
/// alphabetical order.
fn fields(n: usize, dim: usize, seed: u64) -> Vec<Field> {
    let mut bits = Bits(seed);
    vec![
        f64_field("x", "m", vec![n, dim], &mut bits),
        f64_field("v", "m/s", vec![n, dim], &mut bits),
        f64_field("mass", "kg", vec![n], &mut bits),
        f64_field("stress", "Pa", vec![n, dim, dim], &mut bits),
        f64_field("F", "1", vec![n, dim, dim], &mut bits),
        u32_field("material", vec![n], &mut bits),
        u32_field("cell", vec![n, dim], &mut bits),
        f64_field("B", "m^2", vec![n, dim, dim], &mut bits),
    ]
}

fn header(kind: FileKind, dim: u32) -> Header {
    let mut scene = String::new();
    while scene.len() < 12_000 {
        scene.push_str("[material.\"steel\"] # ünïcödé ✓ <tag> & 'quote'\nE = 2.0e11\n");
    }
    Header {
        kind,
        time: 0.1 + 0.2,
        step: u64::MAX - 7,
        dt: f64::from_bits(0x3EB0_C6F7_A0B5_ED8D), // 1e-6, exactly as stored
        dim,
        units: "SI (m, s, kg, Pa)".into(),
        scene,
        code_version: "0.1.0+g1234abc".into(),
        attrs: vec![
            ("rng_state".into(), f64::from_bits(0x7FEF_FFFF_FFFF_FFFF)),
            ("neg_zero".into(), -0.0),
            ("subnormal".into(), f64::from_bits(3)),
            ("alpha".into(), 1.0 / 3.0),
        ],
    }
}

/// Bit-level equality of everything in two snapshots (`==` would accept 0.0 == -0.0).
fn assert_bit_identical(a: &mpm_io::Snapshot, b_header: &Header, b_fields: &[Field]) {
    let (ha, hb) = (&a.header, b_header);
    assert_eq!(ha.kind, hb.kind);
    assert_eq!(ha.time.to_bits(), hb.time.to_bits());
    assert_eq!(ha.step, hb.step);
    assert_eq!(ha.dt.to_bits(), hb.dt.to_bits());
    assert_eq!(ha.dim, hb.dim);
    assert_eq!(ha.units, hb.units);
    assert_eq!(ha.scene, hb.scene);
    assert_eq!(ha.code_version, hb.code_version);
    assert_eq!(ha.attrs.len(), hb.attrs.len());
    for ((na, va), (nb, vb)) in ha.attrs.iter().zip(&hb.attrs) {
        assert_eq!(na, nb);
        assert_eq!(va.to_bits(), vb.to_bits(), "extra attribute {na}");
    }
    let names = |fs: &[Field]| fs.iter().map(|f| f.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a.fields), names(b_fields), "field order");
    for (fa, fb) in a.fields.iter().zip(b_fields) {
        assert_eq!(fa.unit, fb.unit, "unit of {}", fa.name);
        match (&fa.data, &fb.data) {
            (
                Data::F64 {
                    values: va,
                    shape: sa,
                },
                Data::F64 {
                    values: vb,
                    shape: sb,
                },
            ) => {
                assert_eq!(sa, sb, "shape of {}", fa.name);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(va), bits(vb), "values of {}", fa.name);
            }
            (Data::U32 { .. }, Data::U32 { .. }) => assert_eq!(fa.data, fb.data),
            _ => panic!("number type of {} changed", fa.name),
        }
    }
}

fn roundtrip(dir_name: &str, kind: FileKind, dim: usize, n: usize) {
    let dir = scratch(dir_name);
    let path = dir.join("snap_000042.h5");
    let h = header(kind, dim as u32);
    let fs = fields(n, dim, 42 + dim as u64);
    write_file(&path, &h, &fs).unwrap();
    let back = read_file(&path).unwrap();
    assert_bit_identical(&back, &h, &fs);
    assert_eq!(back.header, h);
    assert_eq!(back.field("stress").unwrap().data.shape(), &[n, dim, dim]);

    assert_eq!(read_header(&path).unwrap(), h);
    let (h2, specs) = read_layout(&path).unwrap();
    assert_eq!(h2, h);
    assert_eq!(specs, fs.iter().map(FieldSpec::of).collect::<Vec<_>>());
}

#[test]
fn compressed_and_single_precision_snapshots_round_trip() {
    let dir = scratch("storage");
    let (n, dim) = (3000, 3);
    let h = header(FileKind::Snapshot, dim as u32);
    let fs = fields(n, dim, 7);
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    let write = |name: &str, storage: Storage| {
        let path = dir.join(name);
        write_file_with(&path, &h, &fs, storage).unwrap();
        path
    };
    let plain = write("plain.h5", Storage::default());
    // Compressed f64 is still bit-exact.
    let zipped = write(
        "zipped.h5",
        Storage {
            single: false,
            compression: 4,
        },
    );
    assert_bit_identical(&read_file(&zipped).unwrap(), &h, &fs);
    // f32: every float is the f64 rounded to f32; integers are untouched.
    let single = write(
        "single.h5",
        Storage {
            single: true,
            compression: 0,
        },
    );
    let back = read_file(&single).unwrap();
    let (_, specs) = read_layout(&single).unwrap();
    for ((fa, fb), spec) in back.fields.iter().zip(&fs).zip(&specs) {
        match (&fa.data, &fb.data) {
            (Data::F64 { values: a, .. }, Data::F64 { values: b, .. }) => {
                assert!(spec.single, "{} stored as f32", fa.name);
                for (x, y) in a.iter().zip(b) {
                    assert_eq!(x.to_bits(), f64::from(*y as f32).to_bits(), "{}", fa.name);
                }
            }
            _ => {
                assert!(!spec.single);
                assert_eq!(fa.data, fb.data, "{}", fa.name);
            }
        }
    }
    // Random bits do not compress, but f32 halves the floats.
    let (p, s) = (size(&plain), size(&single));
    assert!(s < p * 6 / 10, "f32 {s} B vs f64 {p} B");
    // A checkpoint is never f32; levels are 0-9.
    let ck = header(FileKind::Checkpoint, dim as u32);
    let single_ck = Storage {
        single: true,
        compression: 0,
    };
    let e = write_file_with(&dir.join("ck.h5"), &ck, &fs, single_ck).unwrap_err();
    assert!(e.to_string().contains("f64"), "{e}");
    let e = write_file_with(
        &dir.join("bad.h5"),
        &h,
        &fs,
        Storage {
            single: false,
            compression: 10,
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("compression level 10"), "{e}");
}

#[test]
fn roundtrip_2d_snapshot_is_bit_exact() {
    roundtrip("rt2d", FileKind::Snapshot, 2, 257);
}

#[test]
fn roundtrip_3d_checkpoint_is_bit_exact() {
    roundtrip("rt3d", FileKind::Checkpoint, 3, 101);
}

#[test]
fn roundtrip_zero_particles() {
    roundtrip("rt0", FileKind::Snapshot, 3, 0);
}

#[test]
fn roundtrip_without_fields_or_extra_attrs() {
    let dir = scratch("rt_empty");
    let path = dir.join("c.h5");
    let h = Header {
        attrs: vec![],
        scene: String::new(),
        ..header(FileKind::Checkpoint, 2)
    };
    write_file(&path, &h, &[]).unwrap();
    let back = read_file(&path).unwrap();
    assert_eq!(back.header, h);
    assert!(back.fields.is_empty());
}

#[test]
fn temporary_file_is_gone_after_success() {
    let dir = scratch("tmp_gone");
    let path = dir.join("snap_000001.h5");
    write_file(&path, &header(FileKind::Snapshot, 2), &fields(10, 2, 1)).unwrap();
    assert_eq!(entries(&dir), ["snap_000001.h5"]);
}

#[test]
fn overwriting_an_existing_file_works() {
    let dir = scratch("overwrite");
    let path = dir.join("snap_000001.h5");
    // A non-HDF5 file in the way, then a real one, then a different real one.
    std::fs::write(&path, b"junk").unwrap();
    let h1 = header(FileKind::Snapshot, 2);
    write_file(&path, &h1, &fields(10, 2, 1)).unwrap();
    let h2 = Header {
        step: 7,
        attrs: vec![("only".into(), 2.5)],
        ..header(FileKind::Checkpoint, 3)
    };
    let f2 = fields(3, 3, 2)[..2].to_vec();
    write_file(&path, &h2, &f2).unwrap();
    let back = read_file(&path).unwrap();
    assert_bit_identical(&back, &h2, &f2);
    assert_eq!(entries(&dir), ["snap_000001.h5"]);
}

#[test]
fn writing_into_a_missing_directory_is_an_error() {
    let dir = scratch("missing_dir");
    let path = dir.join("no/such/dir/snap_000001.h5");
    let err = write_file(&path, &header(FileKind::Snapshot, 2), &fields(4, 2, 1)).unwrap_err();
    assert!(
        matches!(err, IoError::Hdf5 { .. } | IoError::Fs { .. }),
        "{err:?}"
    );
    assert!(!path.exists());
    assert!(entries(&dir).is_empty());
}

#[test]
fn writing_below_a_regular_file_is_an_error() {
    // A parent that is a file fails even for root, unlike a read-only directory.
    let dir = scratch("file_parent");
    let parent = dir.join("not_a_dir");
    std::fs::write(&parent, b"x").unwrap();
    let path = parent.join("snap_000001.h5");
    let err = write_file(&path, &header(FileKind::Snapshot, 2), &fields(4, 2, 1)).unwrap_err();
    assert!(
        matches!(err, IoError::Hdf5 { .. } | IoError::Fs { .. }),
        "{err:?}"
    );
    assert_eq!(entries(&dir), ["not_a_dir"]);
}

#[cfg(unix)]
#[test]
fn writing_into_a_read_only_directory_is_an_error() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch("read_only");
    let ro = dir.join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Root ignores directory permissions: then there is nothing to test.
    let probe = ro.join("probe");
    let writable = std::fs::write(&probe, b"").is_ok();
    let _ = std::fs::remove_file(&probe);
    if !writable {
        let path = ro.join("snap_000001.h5");
        let err = write_file(&path, &header(FileKind::Snapshot, 2), &fields(4, 2, 1)).unwrap_err();
        assert!(
            matches!(err, IoError::Hdf5 { .. } | IoError::Fs { .. }),
            "{err:?}"
        );
        assert!(entries(&ro).is_empty());
    }
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn invalid_input_is_rejected_before_writing() {
    let dir = scratch("invalid");
    let path = dir.join("s.h5");
    let h = header(FileKind::Snapshot, 2);
    let good = fields(4, 2, 1);

    let mut bad_shape = good.clone();
    bad_shape[1].data = Data::F64 {
        values: vec![0.0; 7],
        shape: vec![4, 2],
    };
    let mut slash = good.clone();
    slash[0].name = "a/b".into();
    let mut dup = good.clone();
    dup[1].name = "x".into();
    let mut scalar = good.clone();
    scalar[2].data = Data::F64 {
        values: vec![1.0],
        shape: vec![],
    };
    for (what, fs) in [
        ("shape", &bad_shape),
        ("slash", &slash),
        ("dup", &dup),
        ("scalar", &scalar),
    ] {
        let err = write_file(&path, &h, fs).unwrap_err();
        assert!(matches!(err, IoError::Format { .. }), "{what}: {err:?}");
    }
    let reserved = Header {
        attrs: vec![("time".into(), 1.0)],
        ..h.clone()
    };
    let err = write_file(&path, &reserved, &good).unwrap_err();
    assert!(matches!(err, IoError::Format { .. }), "{err:?}");
    assert!(entries(&dir).is_empty());
}

#[test]
fn reading_a_file_that_is_not_hdf5_is_an_error() {
    let dir = scratch("not_hdf5");
    let text = dir.join("text.h5");
    std::fs::write(&text, "this is not HDF5\n".repeat(100)).unwrap();
    let empty = dir.join("empty.h5");
    std::fs::write(&empty, b"").unwrap();
    for p in [&text, &empty, &dir] {
        let err = read_file(p).unwrap_err();
        assert!(matches!(err, IoError::Format { .. }), "{p:?}: {err:?}");
        assert!(err.to_string().contains(&*p.to_string_lossy()), "{err}");
    }
    let missing = dir.join("missing.h5");
    let err = read_file(&missing).unwrap_err();
    assert!(matches!(err, IoError::Fs { .. }), "{err:?}");
    assert!(read_header(&text).is_err());
}

/// Writes a valid file, changes its layout with `damage`, recomputes its checksums, and returns
/// the error of reading it.
fn read_damaged(name: &str, damage: impl FnOnce(&hdf5::File)) -> IoError {
    let dir = scratch(name);
    let path = dir.join("s.h5");
    write_file(&path, &header(FileKind::Snapshot, 2), &fields(5, 2, 3)).unwrap();
    {
        let file = hdf5::File::open_rw(&path).unwrap();
        damage(&file);
        file.close().unwrap();
    }
    // Without new checksums the change itself is what the reader reports.
    let err = read_file(&path).unwrap_err();
    assert!(matches!(err, IoError::Damaged { .. }), "{err:?}");
    reseal(&path).unwrap();
    read_file(&path).unwrap_err()
}

fn assert_format_error(err: &IoError, needle: &str) {
    match err {
        IoError::Format { message, .. } => {
            assert!(
                message.contains(needle),
                "{message:?} should name {needle:?}"
            )
        }
        other => panic!("expected a format error naming {needle:?}, got {other:?}"),
    }
}

#[test]
fn missing_root_attribute_is_a_format_error() {
    for name in [
        "kind",
        "time",
        "step",
        "dt",
        "dim",
        "units",
        "scene",
        "code_version",
    ] {
        let err = read_damaged(&format!("missing_{name}"), |f| f.delete_attr(name).unwrap());
        assert_format_error(&err, &format!("`{name}`"));
    }
    let err = read_damaged("missing_extra", |f| f.delete_attr("alpha").unwrap());
    assert_format_error(&err, "`alpha`");
    let err = read_damaged("missing_extra_list", |f| {
        f.delete_attr("extra_attrs").unwrap()
    });
    assert_format_error(&err, "`extra_attrs`");
}

#[test]
fn wrongly_typed_attribute_is_a_format_error() {
    let err = read_damaged("wrong_step", |f| {
        f.delete_attr("step").unwrap();
        f.new_attr::<f64>()
            .shape(())
            .create("step")
            .unwrap()
            .write_scalar(&1.0)
            .unwrap();
    });
    assert_format_error(&err, "`step`");
    let err = read_damaged("wrong_kind", |f| {
        f.delete_attr("kind").unwrap();
        f.new_attr::<u32>()
            .shape(())
            .create("kind")
            .unwrap()
            .write_scalar(&1)
            .unwrap();
    });
    assert_format_error(&err, "`kind`");
    let err = read_damaged("bad_kind", |f| {
        f.delete_attr("kind").unwrap();
        let v: hdf5::types::VarLenUnicode = "movie".parse().unwrap();
        f.new_attr::<hdf5::types::VarLenUnicode>()
            .shape(())
            .create("kind")
            .unwrap()
            .write_scalar(&v)
            .unwrap();
    });
    assert_format_error(&err, "`kind`");
}

#[test]
fn damaged_particle_group_is_a_format_error() {
    let err = read_damaged("no_unit", |f| {
        f.dataset("particles/v")
            .unwrap()
            .delete_attr("unit")
            .unwrap()
    });
    assert_format_error(&err, "`unit` on /particles/v");
    let err = read_damaged("no_dataset", |f| f.unlink("particles/mass").unwrap());
    assert_format_error(&err, "/particles/mass");
    let err = read_damaged("no_order", |f| {
        f.group("particles")
            .unwrap()
            .delete_attr("field_order")
            .unwrap()
    });
    assert_format_error(&err, "`field_order`");
    let err = read_damaged("no_group", |f| f.unlink("particles").unwrap());
    assert_format_error(&err, "/particles");
    let err = read_damaged("wrong_dtype", |f| {
        f.unlink("particles/mass").unwrap();
        let ds = f
            .new_dataset::<i16>()
            .shape([5])
            .create("particles/mass")
            .unwrap();
        ds.write_raw(&[1i16; 5]).unwrap();
        let unit: hdf5::types::VarLenUnicode = "kg".parse().unwrap();
        ds.new_attr::<hdf5::types::VarLenUnicode>()
            .shape(())
            .create("unit")
            .unwrap()
            .write_scalar(&unit)
            .unwrap();
    });
    assert_format_error(&err, "/particles/mass");
}

#[test]
fn list_files_skips_temporaries_and_sorts() {
    let dir = scratch("list");
    let h = header(FileKind::Snapshot, 2);
    for step in [10, 2, 0] {
        write_file(
            &dir.join(format!("snap_{step:06}.h5")),
            &h,
            &fields(2, 2, step),
        )
        .unwrap();
    }
    std::fs::write(dir.join(".snap_000003.h5.tmp-1"), b"").unwrap();
    std::fs::write(dir.join("ckpt_000003.h5"), b"").unwrap();
    std::fs::create_dir(dir.join("snap_dir.h5")).unwrap();
    let names: Vec<String> = list_files(&dir, "snap_", ".h5")
        .unwrap()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["snap_000000.h5", "snap_000002.h5", "snap_000010.h5"]
    );
    assert!(list_files(&dir.join("nope"), "snap_", ".h5").is_err());
}

#[test]
fn identical_inputs_give_identical_bytes() {
    let dir = scratch("identical");
    let (a, b) = (dir.join("a.h5"), dir.join("b.h5"));
    let h = header(FileKind::Checkpoint, 3);
    let fs = fields(20, 3, 9);
    write_file(&a, &h, &fs).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1100));
    write_file(&b, &h, &fs).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

/// Fields whose values occur nowhere else in the file: `x` (`n × dim`), `mass` (`n`) and
/// `material` (`n`, u32), so that a test can find each dataset's values by their bytes.
fn distinct_fields(n: usize, dim: usize) -> Vec<Field> {
    let f64s = |name: &str, unit: &str, shape: Vec<usize>, base: f64| Field {
        name: name.into(),
        unit: unit.into(),
        data: Data::F64 {
            values: (0..shape.iter().product::<usize>())
                .map(|i| base + 0.37 * i as f64)
                .collect(),
            shape,
        },
    };
    vec![
        f64s("x", "m", vec![n, dim], 0.125),
        f64s("mass", "kg", vec![n], 1234.5),
        Field {
            name: "material".into(),
            unit: "1".into(),
            data: Data::U32 {
                values: (0..n as u32).map(|i| 0x5eed_0000 + i).collect(),
                shape: vec![n],
            },
        },
    ]
}

/// The byte offset in `bytes` of the little-endian values of `data` (a dataset's payload).
fn payload_offset(bytes: &[u8], data: &Data) -> usize {
    let raw: Vec<u8> = match data {
        Data::F64 { values, .. } => values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        Data::U32 { values, .. } => values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    };
    let at: Vec<usize> = (0..=bytes.len() - raw.len())
        .filter(|&i| bytes[i..i + raw.len()] == raw[..])
        .collect();
    assert_eq!(at.len(), 1, "the values are stored once");
    at[0]
}

#[test]
fn every_flipped_byte_is_detected_before_hdf5_parses_the_file() {
    let dir = scratch("flips");
    let (good, bad) = (dir.join("good.h5"), dir.join("bad.h5"));
    let h = Header {
        scene: "[simulation]\ndim = 2\n".into(),
        ..header(FileKind::Checkpoint, 2)
    };
    let fs = distinct_fields(3, 2);
    write_file(&good, &h, &fs).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let x_at = payload_offset(&bytes, &fs[0].data);
    let (mut damaged, mut named_x, mut not_ours) = (0, 0, 0);
    std::fs::copy(&good, &bad).unwrap();
    let mut file = std::fs::OpenOptions::new().write(true).open(&bad).unwrap();
    // Flips bit `i % 8` of byte `i` in place (rewriting the file each time is slow on some
    // file systems).
    let mut put = |i: usize, byte: u8| {
        file.seek(SeekFrom::Start(i as u64)).unwrap();
        file.write_all(&[byte]).unwrap();
    };
    for i in 0..bytes.len() {
        put(i, bytes[i] ^ (1 << (i % 8)));
        let err = read_file(&bad).unwrap_err();
        put(i, bytes[i]);
        match err {
            IoError::Damaged { message, .. } => {
                damaged += 1;
                let in_x = (x_at..x_at + 3 * 2 * 8).contains(&i);
                assert_eq!(
                    message.contains("/particles/x"),
                    in_x,
                    "byte {i}: {message}"
                );
                named_x += usize::from(in_x);
            }
            // The magic itself: not recognised as a file of mpm-io at all.
            IoError::Format { message, .. } if i < 8 => {
                assert!(message.contains("not an mpm-io"), "{message}");
                not_ours += 1;
            }
            other => panic!("byte {i}: {other:?}"),
        }
    }
    eprintln!(
        "{} bytes: {damaged} damaged, {not_ours} not recognised",
        bytes.len()
    );
    assert_eq!(
        (damaged + not_ours, named_x, not_ours),
        (bytes.len(), 48, 8)
    );
    // A truncated or extended file is damaged too.
    for len in [bytes.len() - 1, bytes.len() + 1] {
        let mut b = bytes.clone();
        b.resize(len, 0);
        std::fs::write(&bad, &b).unwrap();
        let err = read_file(&bad).unwrap_err();
        assert!(err.to_string().contains("truncated or extended"), "{err}");
    }
}

#[test]
fn damaged_values_still_give_the_header() {
    let dir = scratch("damaged_values");
    let path = dir.join("c.h5");
    let h = header(FileKind::Checkpoint, 3);
    let fs = distinct_fields(4, 3);
    write_file(&path, &h, &fs).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let at = payload_offset(&bytes, &fs[1].data);
    bytes[at + 5] ^= 0x10;
    std::fs::write(&path, &bytes).unwrap();
    let err = read_file(&path).unwrap_err();
    assert!(matches!(err, IoError::Damaged { .. }), "{err:?}");
    let text = err.to_string();
    assert!(
        text.contains("/particles/mass") && text.contains("c.h5"),
        "{text}"
    );
    assert_eq!(read_header(&path).unwrap(), h);
    assert_eq!(read_layout(&path).unwrap().0, h);
}

#[test]
fn files_without_checksums_are_refused_unless_unchecked() {
    // A plain HDF5 file with no user block, as another HDF5 tool writes it. Cutting off the
    // user block leaves one (HDF5 addresses are relative to the superblock).
    let dir = scratch("legacy");
    let (path, plain) = (dir.join("new.h5"), dir.join("plain.h5"));
    let h = header(FileKind::Snapshot, 2);
    let fs = distinct_fields(6, 2);
    write_file(&path, &h, &fs).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let block = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    assert!(block >= 512 && block.is_power_of_two());
    std::fs::write(&plain, &bytes[block..]).unwrap();
    for err in [
        read_file(&plain).unwrap_err(),
        read_header(&plain).unwrap_err(),
        read_layout(&plain).unwrap_err(),
    ] {
        assert!(matches!(err, IoError::Unverifiable { .. }), "{err:?}");
        assert!(err.to_string().contains("no checksum block"), "{err}");
    }
    // The 8-byte test tells them apart from sealed files (and from anything else).
    assert!(mpm_io::is_unsealed(&plain) && !mpm_io::is_unsealed(&path));
    assert!(!mpm_io::is_unsealed(&dir) && !mpm_io::is_unsealed(&dir.join("missing.h5")));
    let unchecked = Verify::Unchecked;
    assert_bit_identical(&read_file_with(&plain, unchecked).unwrap(), &h, &fs);
    assert_eq!(read_header_with(&plain, unchecked).unwrap(), h);
    assert_eq!(read_layout_with(&plain, unchecked).unwrap().0, h);
    // Unchecked, damaged values go unnoticed (what makes the option unsafe)...
    let mut b = bytes[block..].to_vec();
    let at = payload_offset(&b, &fs[0].data);
    b[at] ^= 1;
    std::fs::write(&plain, &b).unwrap();
    assert_ne!(read_file_with(&plain, unchecked).unwrap().fields[0], fs[0]);
    // ...but a dataset whose declared shape needs more bytes than it stores is refused before
    // anything is allocated for it. The shape's first extent (6 rows) is found in the dataset's
    // object header as a little-endian u64 right before the second extent and patched to 2^40.
    let rows = 6u64.to_le_bytes();
    let cols = 2u64.to_le_bytes();
    let dims: Vec<u8> = rows.iter().chain(&cols).copied().collect();
    let at = bytes[block..]
        .windows(16)
        .position(|w| w == dims.as_slice())
        .expect("a [6, 2] dataspace");
    let mut b = bytes[block..].to_vec();
    b[at..at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    std::fs::write(&plain, &b).unwrap();
    let err = read_file_with(&plain, unchecked).unwrap_err();
    assert!(
        matches!(err, IoError::Format { .. } | IoError::Hdf5 { .. }),
        "{err:?}"
    );
}
