//! The figures of a run (the paper's Fig. 3–8 equivalents and noise spectra), drawn
//! from its telemetry to `DIR/plots/*.png` and `*.svg`. Figures may use truth: they
//! are for people judging the run, not for the estimator.

pub mod render;

use crate::sim::files::FileError;
use crate::sim::model::noise::welch_asd;
use crate::sim::msg::{PAIR_OF_ANGULAR, ST_NO_SOLUTION};
use crate::sim::scenario::{Scenario, ARCSEC};
use crate::telemetry::Telemetry;
use render::{decimate, BandStyle, Figure, Panel, Series, BLACK_INDEX};
use std::path::{Path, PathBuf};

const AXES: [&str; 3] = ["x", "y", "z"];
/// Most points per plotted series.
const MAX_POINTS: usize = 4000;

/// Small-angle attitude (rad) of q = (w, x, y, z): 2·sign(w)·(x, y, z).
fn angles(q: &[f64]) -> [f64; 3] {
    let s = if q[0] < 0.0 { -2.0 } else { 2.0 };
    [s * q[1], s * q[2], s * q[3]]
}

/// Centred moving average over `w` samples (the figures' low-pass); NaN samples (gaps)
/// are left out of the average.
fn smooth(x: &[f64], w: usize) -> Vec<f64> {
    let w = w.max(1);
    let mut out = vec![f64::NAN; x.len()];
    let (mut acc, mut count) = (0.0, 0usize);
    for i in 0..x.len() {
        if x[i].is_finite() {
            acc += x[i];
            count += 1;
        }
        if i >= w && x[i - w].is_finite() {
            acc -= x[i - w];
            count -= 1;
        }
        if i + 1 >= w && count > 0 {
            out[i + 1 - w.div_ceil(2)] = acc / count as f64;
        }
    }
    out
}

fn series_xy(t: &[f64], y: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    decimate(t.iter().copied().zip(y).collect(), MAX_POINTS)
}

/// An ASD averaged (in power) over `n` logarithmically equal frequency bins, so the
/// thousands of high-frequency bins do not drown the plot.
fn log_bins(asd: &[(f64, f64)], n: usize) -> Vec<(f64, f64)> {
    let (Some(f0), Some(f1)) = (asd.first().map(|v| v.0), asd.last().map(|v| v.0)) else {
        return Vec::new();
    };
    let width = (f1 / f0).ln() / n as f64;
    let mut out = Vec::new();
    let mut i = 0;
    for b in 1..=n {
        let edge = f0 * (width * b as f64).exp() * (1.0 + 1e-12);
        let (mut sf, mut sp, mut c) = (0.0, 0.0, 0usize);
        while i < asd.len() && asd[i].0 <= edge {
            sf += asd[i].0.ln();
            sp += asd[i].1 * asd[i].1;
            c += 1;
            i += 1;
        }
        if c > 0 {
            out.push(((sf / c as f64).exp(), (sp / c as f64).sqrt()));
        }
    }
    out
}

/// Least-squares line removed.
fn detrend(x: &[f64]) -> Vec<f64> {
    let n = x.len() as f64;
    let mt = (n - 1.0) / 2.0;
    let mx = x.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        sxy += (i as f64 - mt) * (v - mx);
        sxx += (i as f64 - mt).powi(2);
    }
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    x.iter()
        .enumerate()
        .map(|(i, v)| v - mx - b * (i as f64 - mt))
        .collect()
}

struct Data<'a> {
    t: Vec<f64>,
    tel: &'a Telemetry,
    s: &'a Scenario,
    fs: f64,
}

impl Data<'_> {
    fn col(&self, v: &[f64], stride: usize, j: usize) -> Vec<f64> {
        v.iter().skip(j).step_by(stride).copied().collect()
    }

    /// ΔV of angular axis a of IS i [V].
    fn dv(&self, i: usize, a: usize) -> Vec<f64> {
        let p = PAIR_OF_ANGULAR[a];
        self.tel.is_volts[i]
            .chunks(6)
            .map(|c| c[2 * p] - c[2 * p + 1])
            .collect()
    }

    /// ΣV of linear axis j of IS i [V].
    fn sv(&self, i: usize, j: usize) -> Vec<f64> {
        self.tel.is_volts[i]
            .chunks(6)
            .map(|c| c[2 * j] + c[2 * j + 1])
            .collect()
    }
}

/// Every figure of a run.
pub fn figures(tel: &Telemetry, s: &Scenario) -> Vec<Figure> {
    let fs = tel.fs;
    let d = Data {
        t: tel
            .truth_tick
            .iter()
            .map(|&k| (k + 1) as f64 / fs)
            .collect(),
        tel,
        s,
        fs,
    };
    vec![
        fig_torque_attitude(&d),
        fig_voltages_star(&d),
        fig_is_srp(&d),
        fig_beta(&d),
        fig_com(&d),
        fig_coupling(&d),
        fig_asd(&d),
    ]
}

fn fig_torque_attitude(d: &Data) -> Figure {
    let mut torque = Panel::new("Torque (Fig. 3a)", "time [s]", "torque [µN m]");
    let mut att = Panel::new("Attitude angle (Fig. 3b)", "time [s]", "angle [arcsec]");
    let mut commanded = Vec::new();
    for a in 0..3 {
        let cmd = d.col(&d.tel.torque_cmd, 3, a);
        let act = d.col(&d.tel.torque, 3, a);
        torque.series.push(Series::line(
            format!("applied {}", AXES[a]),
            series_xy(&d.t, act.iter().map(|v| v * 1e6)),
            a,
        ));
        commanded.push(series_xy(&d.t, cmd.iter().map(|v| v * 1e6)));
        let ang: Vec<f64> = d
            .tel
            .attitude
            .chunks(4)
            .map(|q| angles(q)[a] / ARCSEC)
            .collect();
        att.series.push(Series::line(
            format!("θ{}", AXES[a]),
            series_xy(&d.t, ang.into_iter()),
            a,
        ));
    }
    // Commanded in black over the noisy applied torque of every axis, one legend entry.
    for (a, xy) in commanded.into_iter().enumerate() {
        let label = if a == 0 { "commanded (x, y, z)" } else { "" };
        torque
            .series
            .push(Series::line(label, xy, BLACK_INDEX).dashed());
    }
    Figure {
        name: "fig3_torque_attitude".into(),
        title: "Maneuver: torque and attitude".into(),
        panels: vec![torque, att],
        cols: 2,
    }
}

/// Star-tracker angular acceleration: angles differentiated twice, low-passed [rad/s²].
fn star_acceleration(d: &Data, a: usize) -> Vec<f64> {
    let ang: Vec<f64> = d
        .tel
        .star_q
        .chunks(4)
        .zip(&d.tel.star_valid)
        .map(|(q, &v)| if v != 0 { angles(q)[a] } else { f64::NAN })
        .collect();
    let mut acc = vec![0.0; ang.len()];
    for k in 1..ang.len().saturating_sub(1) {
        acc[k] = (ang[k + 1] - 2.0 * ang[k] + ang[k - 1]) * d.fs * d.fs;
    }
    // 0.05 Hz low-pass as the paper: a 20 s moving average, twice.
    let w = (20.0 * d.fs) as usize;
    smooth(&smooth(&acc, w), w)
}

fn fig_voltages_star(d: &Data) -> Figure {
    let mut volts = Panel::new(
        "IS1 angular drive voltage ΔV (Fig. 4a)",
        "time [s]",
        "ΔV [V]",
    );
    let mut star = Panel::new(
        "Star-tracker angular acceleration, 0.05 Hz low-pass (Fig. 4b)",
        "time [s]",
        "dω/dt [rad/s²]",
    );
    for a in 0..3 {
        volts.series.push(Series::line(
            format!("ΔV, axis {}", AXES[a]),
            series_xy(&d.t, d.dv(0, a).into_iter()),
            a,
        ));
        star.series.push(Series::line(
            format!("dω{}/dt", AXES[a]),
            series_xy(&d.t, star_acceleration(d, a).into_iter()),
            a,
        ));
    }
    Figure {
        name: "fig4_voltages_star_tracker".into(),
        title: "Measurements: drive voltages and star-tracker angular acceleration".into(),
        panels: vec![volts, star],
        cols: 2,
    }
}

fn fig_is_srp(d: &Data) -> Figure {
    let est = d.tel.estimates.last().copied().unwrap_or_default();
    let mut ang = Panel::new(
        "IS1 angular acceleration β_est·ΔV (Fig. 5a)",
        "time [s]",
        "dω/dt [rad/s²]",
    );
    let mut lin = Panel::new(
        "IS1 linear acceleration k_est·ΣV (Fig. 5b)",
        "time [s]",
        "a [m/s²]",
    );
    let mut srp = Panel::new(
        "SRP acceleration, detrended (Fig. 5c)",
        "time [s]",
        "a [m/s²]",
    );
    for a in 0..3 {
        let b = est.beta[0][a];
        ang.series.push(Series::line(
            format!("dω{}/dt", AXES[a]),
            series_xy(&d.t, d.dv(0, a).into_iter().map(|v| v * b)),
            a,
        ));
        let k = est.k[0][a];
        lin.series.push(Series::line(
            format!("a{}", AXES[a]),
            series_xy(&d.t, d.sv(0, a).into_iter().map(|v| v * k)),
            a,
        ));
        let srp_a = d.col(&d.tel.srp_acc, 3, a);
        srp.series.push(Series::line(
            format!("detrended {}", AXES[a]),
            series_xy(&d.t, detrend(&srp_a).into_iter()),
            a,
        ));
    }
    let mut srp_raw = Panel::new("SRP acceleration (truth)", "time [s]", "a [m/s²]");
    for a in 0..3 {
        srp_raw.series.push(Series::line(
            AXES[a],
            series_xy(&d.t, d.col(&d.tel.srp_acc, 3, a).into_iter()),
            a,
        ));
    }
    Figure {
        name: "fig5_is_accelerations_srp".into(),
        title: "IS accelerations and solar radiation pressure".into(),
        panels: vec![ang, lin, srp_raw, srp],
        cols: 2,
    }
}

/// Convergence of one parameter per axis and IS: (estimate − truth)·scale with ±σ,
/// from the first solve (the priors before it are no estimate). One row per axis: the
/// whole campaign on a symmetric-log axis (the first solves' errors are 10³–10⁴ times
/// the final σ), then the same on a linear axis after the first fifth of the campaign.
fn convergence(
    d: &Data,
    name: &str,
    title: &str,
    y_label: &str,
    value: impl Fn(&crate::sim::msg::EstimateMsg, usize, usize) -> (f64, f64),
) -> Figure {
    let rows: Vec<&crate::sim::msg::EstimateMsg> = d
        .tel
        .estimates
        .iter()
        .filter(|e| e.status & ST_NO_SOLUTION == 0)
        .collect();
    let tt: Vec<f64> = rows
        .iter()
        .map(|e| (e.header.tick + 1) as f64 / d.fs)
        .collect();
    let mut panels = Vec::new();
    for a in 0..3 {
        let mut p = Panel::new(format!("axis {}", AXES[a]), "time [s]", y_label);
        // The linear part of the symmetric-log axis: the largest final σ.
        let mut c = 0.0f64;
        for i in 0..d.tel.n_is {
            let v: Vec<(f64, f64)> = rows.iter().map(|e| value(e, i, a)).collect();
            c = c.max(v.last().map_or(0.0, |v| v.1.abs()));
            let xy = tt.iter().zip(&v).map(|(t, v)| (*t, v.0)).collect();
            let band = tt
                .iter()
                .zip(&v)
                .map(|(t, v)| (*t, v.0 - v.1, v.0 + v.1))
                .collect();
            // IS1 solid over a shaded band; IS2 dashed over its band's edges, so
            // both stay visible where the sensors agree.
            let line = Series::line(format!("IS{} ±1σ", i + 1), xy, i).width(2);
            p.series.push(if i == 0 {
                line.with_band(band, BandStyle::Fill)
            } else {
                line.dashed().with_band(band, BandStyle::Edges)
            });
        }
        if let (Some(t0), Some(t1)) = (tt.first(), tt.last()) {
            p.series.push(
                Series::line("truth", vec![(*t0, 0.0), (*t1, 0.0)], BLACK_INDEX)
                    .dashed()
                    .width(1),
            );
        }
        p.symlog_y = Some(if c.is_finite() && c > 0.0 { c } else { 1.0 });
        let t_zoom = tt.last().copied().unwrap_or(0.0) * 0.2;
        let mut z = p.clone();
        z.symlog_y = None;
        z.title = format!("axis {}, from {t_zoom:.0} s", AXES[a]);
        for s in &mut z.series {
            if s.label == "truth" {
                s.xy[0].0 = t_zoom;
            }
            s.xy.retain(|v| v.0 >= t_zoom);
            if let Some(b) = &mut s.band {
                b.retain(|v| v.0 >= t_zoom);
            }
        }
        p.title = format!("axis {}, whole campaign (symmetric log scale)", AXES[a]);
        panels.push(p);
        panels.push(z);
    }
    Figure {
        name: name.into(),
        title: title.into(),
        panels,
        cols: 2,
    }
}

fn fig_beta(d: &Data) -> Figure {
    let s = d.s;
    convergence(
        d,
        "fig6_beta_convergence",
        "Convergence of β (Fig. 6): estimate − truth, relative, with ±1σ",
        "β_est/β − 1 [ppm]",
        |e, i, a| {
            let b = s.inertial_sensor[i].beta[a];
            ((e.beta[i][a] / b - 1.0) * 1e6, e.beta_sigma[i][a] / b * 1e6)
        },
    )
}

fn fig_com(d: &Data) -> Figure {
    let s = d.s;
    convergence(
        d,
        "fig7_com_convergence",
        "Convergence of the CoM offsets r1, r2 (Fig. 7): estimate − truth with ±1σ",
        "r_est − r [µm]",
        |e, i, a| {
            let r = s.inertial_sensor[i].com_offset_m[a];
            ((e.r_b[i][a] - r) * 1e6, e.r_sigma[i][a] * 1e6)
        },
    )
}

fn fig_coupling(d: &Data) -> Figure {
    let est = d.tel.estimates.last().copied().unwrap_or_default();
    let n = d.t.len();
    let dt = 1.0 / d.fs;
    // ω̇ from the IS angular channel with β̂, ω by integrating it (ω(0) = 0).
    let wd: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            std::array::from_fn(|a| {
                let p = PAIR_OF_ANGULAR[a];
                let c = &d.tel.is_volts[0][6 * k..6 * k + 6];
                est.beta[0][a] * (c[2 * p] - c[2 * p + 1])
            })
        })
        .collect();
    let mut w = [0.0f64; 3];
    let r = nalgebra::Vector3::from(est.r_b[0]);
    let mut coupled = vec![[0.0; 3]; n];
    for k in 0..n {
        let wdk = nalgebra::Vector3::from(wd[k]);
        let w0 = nalgebra::Vector3::from(w);
        let wm = w0 + wdk * (0.5 * dt);
        let acc = crate::sim::model::attitude::coupling_acceleration(&wm, &wdk, &r);
        coupled[k] = acc.into();
        for a in 0..3 {
            w[a] += wd[k][a] * dt;
        }
    }
    let w_smooth = (10.0 * d.fs) as usize;
    let mut panels = Vec::new();
    for j in 0..3 {
        let meas: Vec<f64> = d.sv(0, j).iter().map(|v| v * est.k[0][j]).collect();
        let mean = meas.iter().sum::<f64>() / n as f64;
        let meas: Vec<f64> = smooth(&meas, w_smooth).iter().map(|v| v - mean).collect();
        let model: Vec<f64> = smooth(&coupled.iter().map(|c| c[j]).collect::<Vec<_>>(), w_smooth);
        let mut p = Panel::new(format!("IS1 axis {}", AXES[j]), "time [s]", "a [m/s²]");
        p.series.push(
            Series::line(
                "measured k_est·ΣV − mean (10 s avg)",
                series_xy(&d.t, meas.into_iter()),
                0,
            )
            .width(2),
        );
        p.series.push(
            Series::line(
                "identified A(ω, dω/dt)·r_est",
                series_xy(&d.t, model.into_iter()),
                1,
            )
            .dashed(),
        );
        panels.push(p);
    }
    Figure {
        name: "fig8_coupling_acceleration".into(),
        title: "Measured linear acceleration vs identified CoM coupling (Fig. 8)".into(),
        panels,
        cols: 1,
    }
}

fn fig_asd(d: &Data) -> Figure {
    let s = d.s;
    let fs = d.fs;
    let seg = 1 << 14;
    let asd_series = |label: &str, x: &[f64], color: usize| {
        Series::line(label, log_bins(&welch_asd(x, fs, seg), 150), color)
    };
    let flat = |label: &str, level: f64, color: usize| {
        Series::line(
            label,
            vec![(fs / seg as f64, level), (fs / 2.0, level)],
            color,
        )
        .dashed()
    };
    let n = d.t.len();
    // Star tracker: measured minus true angle, x axis.
    let st: Vec<f64> = (0..n)
        .filter(|&k| d.tel.star_valid[k] != 0)
        .map(|k| {
            angles(&d.tel.star_q[4 * k..4 * k + 4])[0]
                - angles(&d.tel.attitude[4 * k..4 * k + 4])[0]
        })
        .collect();
    let sigma_st = s.star_tracker.noise_3sigma_arcsec / 3.0 * ARCSEC;
    let mut p_st = Panel::new("Star-tracker noise (x)", "frequency [Hz]", "ASD [rad/√Hz]");
    p_st.log_log = true;
    p_st.series.push(asd_series("measured − truth", &st, 0));
    p_st.series.push(flat(
        "model 0.2″ (3σ) white",
        sigma_st * (2.0 / fs).sqrt(),
        5,
    ));

    let is = &s.inertial_sensor[0];
    let fe = &s.front_end;
    let wd_true = d.col(&d.tel.omega_dot, 3, 0);
    let wd_meas: Vec<f64> = d.dv(0, 0).iter().map(|v| is.beta[0] * v).collect();
    let a_true: Vec<f64> = d.tel.tm_acc.chunks(3 * d.tel.n_is).map(|c| c[0]).collect();
    let a_meas: Vec<f64> = d.sv(0, 0).iter().map(|v| is.k()[0] * v).collect();
    // IS readout noise (x): measurement with the true scale factor minus truth, against
    // the additive readout noise ⊕ the ripple on the signal's RMS.
    let readout = |title: &str, units: &str, label: &str, meas: &[f64], truth: &[f64], asd: f64| {
        let err: Vec<f64> = meas.iter().zip(truth).map(|(m, t)| m - t).collect();
        let rms = (truth.iter().map(|v| v * v).sum::<f64>() / truth.len() as f64).sqrt();
        let mut p = Panel::new(title, "frequency [Hz]", units);
        p.log_log = true;
        p.series.push(asd_series(label, &err, 0));
        p.series.push(flat(
            "model: readout ⊕ ripple",
            (asd.powi(2) + (fe.ripple_rthz * rms).powi(2)).sqrt(),
            5,
        ));
        p
    };
    let p_ang = readout(
        "IS1 angular readout noise (x)",
        "ASD [rad s⁻² /√Hz]",
        "β·ΔV − dω/dt (truth)",
        &wd_meas,
        &wd_true,
        fe.angular_noise_rthz,
    );
    let p_lin = readout(
        "IS1 linear readout noise (x)",
        "ASD [m s⁻² /√Hz]",
        "k·ΣV − a (truth)",
        &a_meas,
        &a_true,
        fe.linear_noise_rthz,
    );

    // SRP fluctuation along the sun: |a_srp| minus its mean.
    let srp: Vec<f64> = d
        .tel
        .srp_acc
        .chunks(3)
        .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
        .collect();
    let mut p_srp = Panel::new("SRP fluctuation", "frequency [Hz]", "ASD [m s⁻² /√Hz]");
    p_srp.log_log = true;
    p_srp.series.push(asd_series("|a_SRP| (truth)", &srp, 0));
    let f0 = fs / seg as f64;
    let model: Vec<(f64, f64)> = (0..60)
        .map(|i| {
            let f = f0 * (fs / 2.0 / f0).powf(i as f64 / 59.0);
            (f, s.srp.asd_at_3mhz * (f / 3e-3).powf(-1.0 / 3.0))
        })
        .collect();
    p_srp.series.push(
        Series::line(
            format!(
                "model {}·(f/3 mHz)^−1/3",
                render::log_tick_label(s.srp.asd_at_3mhz)
            ),
            model,
            5,
        )
        .dashed(),
    );
    Figure {
        name: "fig9_noise_asd".into(),
        title: "Noise amplitude spectral densities against their models".into(),
        panels: vec![p_st, p_ang, p_lin, p_srp],
        cols: 2,
    }
}

/// A figure that could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    /// The drawing backend failed on figure or panel `what` (`detail`: its error).
    #[error("cannot draw {what}: {detail}")]
    Draw { what: String, detail: String },
}

impl PlotError {
    /// A drawing error of `what` (the backend's errors are generic: kept as their text).
    pub(crate) fn draw(what: String, e: impl std::fmt::Debug) -> Self {
        PlotError::Draw {
            what,
            detail: format!("{e:?}"),
        }
    }
}

/// Write every figure to `dir/plots/`; returns the PNG paths.
pub fn write_all(tel: &Telemetry, s: &Scenario, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots)
        .map_err(|source| PlotError::from(FileError::create(plots.clone(), source)))?;
    let mut out = Vec::new();
    for f in figures(tel, s) {
        render::write(&f, &plots)?;
        out.push(plots.join(format!("{}.png", f.name)));
    }
    Ok(out)
}
