//! Plots must be drawn, without text, when no font is available (no font is registered in this
//! process).

use mpm_validation::plot::{draw_loglog, LogLogPlot, Series};

#[test]
fn plots_are_drawn_without_text_when_no_font_is_registered() {
    // This file is its own process and registers no font, so any text drawing would fail.
    let dir = std::env::temp_dir().join(format!("mpm-validation-notext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let plot = LogLogPlot {
        title: "t".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        series: vec![
            Series {
                label: "a".into(),
                points: vec![(0.1, 1e-3), (0.05, 2.5e-4), (0.0, 1.0)],
                dashed: false,
            },
            Series {
                label: "fit".into(),
                points: vec![(0.1, 1e-3), (0.05, 2.5e-4)],
                dashed: true,
            },
        ],
        legend_top_right: false,
    };
    let path = dir.join("notext.png");
    draw_loglog(&path, &plot, false).unwrap();
    assert!(std::fs::metadata(&path).unwrap().len() > 1000);
}
