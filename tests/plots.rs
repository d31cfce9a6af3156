//! Figures: `run --plots` writes every figure as PNG and SVG; each is non-trivial (not
//! blank, several colours), has labelled axes and a legend where it draws several
//! curves; report.md links them and report.html inlines them.

use std::process::Command;
use taiji::report_doc::FIGURES;

#[test]
fn run_with_plots_writes_every_figure_labelled_and_non_blank() {
    let dir = std::env::temp_dir().join(format!("taiji-plots-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let sc = dir.join("short.toml");
    std::fs::write(&sc, "name = \"short\"\nduration_s = 3000.0\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_taiji-calib"))
        .args(["run", "--plots", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let plots = dir.join("plots");
    for (stem, _) in FIGURES {
        let png = image::open(plots.join(format!("{stem}.png")))
            .unwrap_or_else(|e| panic!("{stem}.png: {e}"))
            .to_rgb8();
        assert!(png.width() >= 1000 && png.height() >= 400, "{stem}: size");
        let non_white = png.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        let frac = non_white as f64 / (png.width() * png.height()) as f64;
        assert!(
            frac > 0.03,
            "{stem}: only {frac:.3} of the pixels are drawn"
        );
        let mut colours: Vec<[u8; 3]> = png.pixels().map(|p| p.0).collect();
        colours.sort_unstable();
        colours.dedup();
        assert!(colours.len() > 20, "{stem}: {} colours", colours.len());

        let svg = std::fs::read_to_string(plots.join(format!("{stem}.svg"))).unwrap();
        let x_label = if stem.contains("asd") {
            "frequency [Hz]"
        } else {
            "time [s]"
        };
        assert!(svg.contains(x_label), "{stem}: no x-axis label");
        assert!(
            svg.contains("ASD [") || svg.contains(" ["),
            "{stem}: no y-axis label"
        );
        assert!(
            svg.matches("<polyline").count() >= 3,
            "{stem}: too few curves"
        );
    }
    // Legends where several curves share a panel.
    let svg = |stem: &str| std::fs::read_to_string(plots.join(format!("{stem}.svg"))).unwrap();
    for (stem, labels) in [
        ("fig3_torque_attitude", &["applied x", "θz"][..]),
        (
            "fig6_beta_convergence",
            &["IS1 ±1σ", "IS2 ±1σ", "truth"][..],
        ),
        ("fig7_com_convergence", &["IS1 ±1σ", "IS2 ±1σ", "truth"][..]),
        (
            "fig8_coupling_acceleration",
            &["measured", "identified"][..],
        ),
        ("fig9_noise_asd", &["model", "truth"][..]),
    ] {
        let text = svg(stem);
        for l in labels {
            assert!(text.contains(l), "{stem}: legend lacks {l:?}");
        }
    }
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    for (stem, _) in FIGURES {
        assert!(
            md.contains(&format!("(plots/{stem}.png)")),
            "report.md lacks {stem}"
        );
    }
    assert_eq!(html.matches("<svg").count(), FIGURES.len());
    assert!(md.contains("| IS2 rz |") && md.contains("CRLB") && md.contains("Requirements"));
}
