//! Figures: `run --plots` writes every figure as PNG and SVG; each is non-trivial (not
//! blank, several colours), has labelled axes and a legend where it draws several
//! curves; report.md links them and report.html inlines them. Every panel's axes hold
//! all its data, and the styles keep overlapping curves apart.

mod support;
mod tmpdir;
use taiji::analysis::plots::render::{panel_ranges, BandStyle, BLACK_INDEX, FIGURE_WIDTH};
use taiji::analysis::report_doc::FIGURES;
use taiji::sim::estimate::Method;
use taiji::sim::scenario::Scenario;

#[test]
fn run_with_plots_writes_every_figure_labelled_and_non_blank() {
    let dir = tmpdir::TmpDir::new("plots");
    let sc = dir.join("short.toml");
    std::fs::write(&sc, "name = \"short\"\nduration_s = 3000.0\n").unwrap();
    let out = support::calib()
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
        // The y-axis label is the text plotters rotates by 270°; it names a unit.
        let y_labels = y_axis_labels(&svg);
        assert!(
            !y_labels.is_empty()
                && y_labels
                    .iter()
                    .all(|l| l.contains(" [") && l.ends_with(']')),
            "{stem}: y-axis labels without a unit: {y_labels:?}"
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

    // Every number's unit is in its column header; r throughout in µm.
    for header in [
        "| truth [rad s⁻² V⁻¹] | estimate [rad s⁻² V⁻¹] | 1σ [ppm] | error [ppm] |",
        "| truth [m s⁻² V⁻¹] | estimate [m s⁻² V⁻¹] | 1σ [ppm] | error [ppm] |",
        "| truth [µm] | estimate [µm] | 1σ [µm] | error [µm] | CRLB [µm] | CRLB with prior [µm] | data share | requirement [µm] |",
    ] {
        assert!(md.contains(header), "report.md lacks {header:?}");
    }
    let rz = md.lines().find(|l| l.starts_with("| IS1 rz |")).unwrap();
    assert!(!rz.contains("e-") && rz.contains("| 200.000 |"), "{rz}");

    // HTML: inline Markdown rendered, figures at their own width (never scaled down).
    assert!(!html.contains('`'), "report.html shows backticks");
    assert!(!html.contains("**"), "report.html shows Markdown bold");
    assert!(html.contains("<code>short</code>"));
    for w in html.split("<svg width=\"").skip(1) {
        let w: u32 = w.split('"').next().unwrap().parse().unwrap();
        assert!(w <= FIGURE_WIDTH, "figure {w} px wide");
    }
    assert!(html.contains(".fig svg{display:block;max-width:none"));
}

fn short_run_figures() -> Vec<taiji::analysis::plots::render::Figure> {
    let s = Scenario::from_toml_str("name = \"short\"\nduration_s = 3000.0\n").unwrap();
    let (_, tel) = taiji::analysis::campaign::run_recorded(&s, 3, Method::Joint, |_| {});
    taiji::analysis::plots::figures(&tel, &s)
}

#[test]
fn every_panel_range_holds_all_its_lines_and_bands() {
    for f in short_run_figures() {
        for p in &f.panels {
            let ((x0, x1), (y0, y1)) = panel_ranges(p);
            let mut n = 0;
            for s in &p.series {
                let band = s
                    .band
                    .iter()
                    .flatten()
                    .flat_map(|b| [(b.0, b.1), (b.0, b.2)]);
                for (x, y) in s.xy.iter().copied().chain(band) {
                    if !(x.is_finite() && y.is_finite()) || (p.log_log && (x <= 0.0 || y <= 0.0)) {
                        continue;
                    }
                    n += 1;
                    assert!(
                        (x0..=x1).contains(&x) && y > y0 && y < y1,
                        "{} / {}: ({x}, {y:e}) outside {x0}..{x1} × {y0:e}..{y1:e}",
                        f.name,
                        p.title
                    );
                }
            }
            assert!(n > 1, "{} / {}: nothing drawn", f.name, p.title);
        }
    }
}

#[test]
fn convergence_starts_at_the_first_solve_and_keeps_the_two_sensors_apart() {
    let figs = short_run_figures();
    for name in ["fig6_beta_convergence", "fig7_com_convergence"] {
        let f = figs.iter().find(|f| f.name == name).unwrap();
        assert_eq!(f.panels.len(), 6);
        for (i, p) in f.panels.iter().enumerate() {
            // Left column: whole campaign on a symmetric-log axis; right: linear zoom.
            assert_eq!(p.symlog_y.is_some(), i % 2 == 0, "{name} / {}", p.title);
            let (is1, is2) = (&p.series[0], &p.series[1]);
            // The priors at t = 0 are no solve: the first point is the first solve (60 s).
            assert!(is1.xy[0].0 >= 60.0, "{name}: starts at {} s", is1.xy[0].0);
            assert!(!is1.dashed && is1.band_style == BandStyle::Fill);
            assert!(is2.dashed && is2.band_style == BandStyle::Edges);
            assert_ne!(is1.color, is2.color);
        }
    }
    // The commanded torque is black, a colour no applied torque uses.
    let torque = &figs[0].panels[0];
    let (cmd, applied): (Vec<_>, Vec<_>) = torque.series.iter().partition(|s| s.dashed);
    assert_eq!(cmd.len(), 3);
    assert!(cmd.iter().all(|s| s.color == BLACK_INDEX));
    assert!(applied.iter().all(|s| s.color != BLACK_INDEX));
}

/// The texts of an SVG that are rotated by 270° (plotters' y-axis descriptions).
fn y_axis_labels(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let (attrs, rest) = t.split_once('>')?;
            attrs
                .contains("rotate(270")
                .then(|| rest.split('<').next().unwrap_or("").trim().to_string())
        })
        .collect()
}

#[test]
fn the_y_label_check_reads_only_rotated_text() {
    let x_only = r#"<text x="1" y="2">time [s]</text>"#;
    assert!(y_axis_labels(x_only).is_empty());
    let both = r#"<text x="1">time [s]</text><text transform="rotate(270, 8, 2)">
β [ppm]
</text>"#;
    assert_eq!(y_axis_labels(both), ["β [ppm]"]);
}
