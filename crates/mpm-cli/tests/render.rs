//! `mpm-cli render`: one picture per field and view (the default keeps `frame_NNNNNN.png`),
//! `--range` sets the colour map's range, axes are labelled, 3D views differ, bad options exit 2.

mod common;

use common::*;
use std::path::Path;

/// The RGB pixels of a PNG: (width, height, pixels).
fn pixels(path: &Path) -> (usize, usize, Vec<[u8; 3]>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(file).read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let px = buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width as usize, info.height as usize, px)
}

/// Pixels of colour `c`.
fn count(px: &[[u8; 3]], c: [u8; 3]) -> usize {
    px.iter().filter(|p| **p == c).count()
}

fn render(out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["render", out.to_str().expect("utf-8 path")];
    args.extend_from_slice(extra);
    let o = cli(&args);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    stdout(&o).trim().to_string()
}

fn run(scene_text: &str, d: &Path) -> std::path::PathBuf {
    let scene = write(d, "s.toml", scene_text);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    out
}

#[test]
fn pictures_are_named_per_field_and_range_sets_the_colours() {
    let d = tmpdir("render-2d");
    let out = run(WATER_2D, &d);
    let default = render(&out, &["--frame", "1"]);
    assert!(default.ends_with("render/frame_000001.png"), "{default}");
    let pressure = render(&out, &["--frame", "1", "--color-by", "pressure"]);
    assert!(
        pressure.ends_with("render/frame_000001_pressure.png"),
        "{pressure}"
    );
    assert!(Path::new(&default).exists(), "the default picture is kept");

    // Speeds are below 10 m/s: with the range [1000, 2000] every particle gets the low end of
    // viridis, with [-2000, -1000] the high end; only the colour bar has the other end.
    let (low, high) = ([68, 1, 84], [253, 231, 37]);
    let all_low = render(
        &out,
        &[
            "--frame",
            "1",
            "--color-by",
            "speed",
            "--range",
            "1000",
            "2000",
        ],
    );
    let (_, _, px) = pixels(Path::new(&all_low));
    assert!(count(&px, low) > 1000, "{} low pixels", count(&px, low));
    assert!(count(&px, high) < 50, "{} high pixels", count(&px, high));
    render(
        &out,
        &[
            "--frame",
            "1",
            "--color-by",
            "speed",
            "--range",
            "-2000",
            "-1000",
        ],
    );
    let (w, h, px) = pixels(Path::new(&all_low));
    assert!(count(&px, high) > 1000 && count(&px, low) < 50);

    // Axes: tick labels (ink) left of the plot and below it.
    let ink = [30, 30, 30];
    let ink_in = |x0: usize, x1: usize, y0: usize, y1: usize| {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| px[y * w + x] == ink)
            .count()
    };
    assert!(ink_in(0, 40, 60, h - 100) > 50, "no y tick labels");
    assert!(ink_in(100, w - 40, h - 80, h - 50) > 50, "no x tick labels");

    for bad in [
        vec!["--range", "2", "1"],
        vec!["--range", "nan", "1"],
        vec!["--range", "1"],
        vec!["--color-by", "material", "--range", "0", "1"],
        vec!["--view", "iso"],
    ] {
        let mut args = vec!["render", out.to_str().expect("utf-8")];
        args.extend_from_slice(&bad);
        let o = cli(&args);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("error"), "{bad:?}: {}", stderr(&o));
    }
}

#[test]
fn three_d_views_project_differently() {
    let d = tmpdir("render-3d");
    let out = run(JELLY_3D, &d);
    let mut seen = Vec::new();
    for view in ["xy", "zy", "xz", "iso"] {
        let file = render(&out, &["--view", view]);
        assert!(
            file.ends_with(&format!("frame_000002_{view}.png")),
            "{file}"
        );
        let (w, h, px) = pixels(Path::new(&file));
        assert!(w >= 200 && h >= 200);
        assert!(!seen.contains(&px), "{view} looks like another view");
        seen.push(px);
    }
    // The default view is xy.
    let (_, _, px) = pixels(Path::new(&render(&out, &[])));
    assert_eq!(px, seen[0]);
    let o = cli(&["render", out.to_str().expect("utf-8"), "--view", "xq"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("iso"), "the message lists the views");
}
