//! Checks of the axis ticks, the projections and the picture file names.

use super::view::nice_step;
use super::*;

#[test]
fn ticks_are_round_numbers_inside_the_range() {
    let t = ticks(0.0, 0.5, 5);
    let labels: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
    assert_eq!(labels, ["0.0", "0.1", "0.2", "0.3", "0.4", "0.5"]);
    let t = ticks(-0.03, 0.12, 5);
    let labels: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
    assert_eq!(labels, ["0.00", "0.05", "0.10"]);
    assert_eq!(ticks(2.0, 12.0, 5).len(), 6); // 2, 4, …, 12
    assert!(ticks(1.0, 1.0, 5).is_empty());
    assert_eq!(nice_step(0.13), 0.2);
    assert_eq!(nice_step(0.5), 0.5);
}

#[test]
fn projections_are_right_handed_and_iso_keeps_lengths_in_its_plane() {
    let p = [1.0, 2.0, 3.0];
    let proj = |s: &str| Projection::parse(s).expect(s).project(&p);
    assert_eq!(proj("xy"), [1.0, 2.0, 3.0]);
    assert_eq!(proj("yx"), [2.0, 1.0, -3.0]);
    assert_eq!(proj("yz"), [2.0, 3.0, 1.0]);
    assert_eq!(proj("zx"), [3.0, 1.0, 2.0]);
    assert_eq!(proj("xz"), [1.0, 3.0, -2.0]);
    assert!(Projection::parse("xx").is_none() && Projection::parse("xyz").is_none());
    // Iso is a rotation: lengths are kept, y projects straight up, (1, 1, 1) is depth.
    let q = Projection::Iso.project(&p);
    let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!((norm(q) - norm(p)).abs() < 1e-12);
    let y = Projection::Iso.project(&[0.0, 1.0, 0.0]);
    assert!(y[0].abs() < 1e-15 && y[1] > 0.0);
    let d = Projection::Iso.project(&[1.0, 1.0, 1.0]);
    assert!(d[0].abs() < 1e-15 && d[1].abs() < 1e-15);
}

#[test]
fn frame_names_carry_the_field_and_view_when_asked_for() {
    assert_eq!(frame_file_name(10, None, None), "frame_000010.png");
    assert_eq!(
        frame_file_name(10, Some("pressure"), None),
        "frame_000010_pressure.png"
    );
    assert_eq!(
        frame_file_name(3, Some("a/b"), Some("iso")),
        "frame_000003_a_b_iso.png"
    );
}

/// One outlier among 1,000 values does not set the range (the DIQ dam break's pressure: 99 % of
/// the values below 8.9 kPa, one spike at 44.8 kPa); a constant field gets a range around its
/// value; a given range is kept and what lies outside it is counted.
#[test]
fn the_colour_range_runs_from_the_1st_to_the_99th_percentile() {
    let mut values: Vec<f64> = (0..1000).map(|k| k as f64 * 8.9).collect();
    values.push(44_800.0);
    let r = super::colour_range(&values, None);
    assert_eq!(r.range, (89.0, 8811.0));
    assert_eq!(r.clipped, (true, true));
    assert!(
        r.how.contains("10 of 1001 values below it, 10 above"),
        "{}",
        r.how
    );
    let c = super::colour_range(&[2.0; 10], None);
    assert!(c.range.0 < 2.0 && c.range.1 > 2.0 && c.how.contains("constant"));
    let g = super::colour_range(&values, Some((0.0, 1e5)));
    assert_eq!((g.range, g.clipped), ((0.0, 1e5), (false, false)));
}
