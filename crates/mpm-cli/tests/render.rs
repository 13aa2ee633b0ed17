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
    assert!(
        all_low.ends_with("frame_000001_speed_range_1000_2000.png"),
        "{all_low}"
    );
    let (_, _, px) = pixels(Path::new(&all_low));
    assert!(count(&px, low) > 1000, "{} low pixels", count(&px, low));
    assert!(count(&px, high) < 50, "{} high pixels", count(&px, high));
    let all_high = render(
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
    assert!(all_high.ends_with("frame_000001_speed_range_-2000_-1000.png"));
    let (w, h, px) = pixels(Path::new(&all_high));
    assert!(count(&px, high) > 1000 && count(&px, low) < 50);

    // Axes: tick labels (dark, antialiased ink) left of the plot and below it.
    let ink_in = |x0: usize, x1: usize, y0: usize, y1: usize| {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| px[y * w + x].iter().all(|&c| c < 100))
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

#[test]
fn the_automatic_range_ignores_outliers_and_movies_need_ffmpeg() {
    let d = tmpdir("render-range");
    let out = run(WATER_2D, &d);
    let range_line = |extra: &[&str]| {
        let mut args = vec!["render", out.to_str().expect("utf-8"), "--frame", "3"];
        args.extend_from_slice(extra);
        let o = cli(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        (stdout(&o).trim().to_string(), stderr(&o))
    };
    // Speed: the 1st to 99th percentile, with the values outside it counted.
    let (file, text) = range_line(&["--color-by", "speed", "--name", "study"]);
    assert!(file.ends_with("frame_000003_speed_study.png"), "{file}");
    assert!(
        text.contains("colour range of speed: ") && text.contains("(1st to 99th percentile; "),
        "{text}"
    );
    // "…percentile; B of N values below it, A above)": about 1 % on each side (the
    // percentiles' own values are inside).
    let tail = &text[text.find("percentile; ").expect("counts") + 12..];
    let numbers: Vec<usize> = tail
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|t| t.parse().ok())
        .collect();
    let (below, n, above) = (numbers[0], numbers[1], numbers[2]);
    assert!(n > 100, "{text}");
    for k in [below, above] {
        assert!(k <= n / 50 + 1, "{k} of {n}: {text}");
    }
    // A constant field (every particle's material is 0) gets a range around its value.
    let (_, text) = range_line(&["--color-by", "mass"]);
    assert!(text.contains("colour range of mass"), "{text}");
    // --movie without ffmpeg on PATH: the pictures are written and a note says why there is no
    // movie; with a stand-in ffmpeg that writes its last argument, the movie is listed.
    let bin_dir = d.join("fake-bin");
    std::fs::create_dir_all(&bin_dir).expect("dir");
    let all = |path: &str| {
        std::process::Command::new(bin())
            .args(["render", out.to_str().expect("utf-8"), "--all", "--movie"])
            .env("PATH", path)
            .output()
            .expect("render")
    };
    let o = all(bin_dir.to_str().expect("utf-8"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("ffmpeg is not installed"),
        "{}",
        stderr(&o)
    );
    assert!(!stdout(&o).contains("movie"), "{}", stdout(&o));
    let fake = bin_dir.join("ffmpeg");
    std::fs::write(
        &fake,
        "#!/bin/sh\necho \"$@\" > \"$(dirname \"$0\")/args\"\nfor a; do last=$a; done\n\
         [ \"$1\" = -version ] || touch \"$last\"\n",
    )
    .expect("write");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    let o = all(&format!("{}:/usr/bin:/bin", bin_dir.display()));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).trim_end().ends_with("render/movie.mp4"),
        "{}",
        stdout(&o)
    );
    let args = std::fs::read_to_string(bin_dir.join("args")).expect("ffmpeg args");
    assert!(
        args.contains("-start_number 0 -i") && args.contains("frame_%06d.png"),
        "{args}"
    );
}
