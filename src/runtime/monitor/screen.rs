//! The monitor's screen, drawn with ratatui from a `Snapshot` and the tracker's
//! history: the campaign's progress and maneuver phase, one row per IS and parameter
//! (estimate, 1σ, bound, σ/bound, err/σ with a scenario), the status word with χ²/dof
//! and rejections, latency, each process, and the selected row's convergence plot.

use super::model::{Point, Snapshot, Tracker, AXES, GROUPS, ROWS};
use ratatui::layout::{Constraint, Direction, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{
    Axis, Block, Borders, Cell, Chart, Clear, Dataset, Gauge, GraphType, Paragraph, Row, Table,
};
use ratatui::Frame;

/// What the screen shows besides the snapshot.
pub struct View<'a> {
    pub snap: &'a Snapshot,
    pub history: &'a [Point],
    /// Selected parameter row (its plot is shown).
    pub selected: usize,
    /// A question awaiting y/n (a control action).
    pub confirm: Option<&'a str>,
    /// The last notice (a request sent, the run ended).
    pub notice: Option<&'a str>,
}

impl<'a> View<'a> {
    pub fn of(t: &'a Tracker, snap: &'a Snapshot) -> Self {
        View {
            snap,
            history: &t.history,
            selected: 0,
            confirm: None,
            notice: None,
        }
    }
}

pub fn draw(f: &mut Frame, v: &View) {
    let area = f.area();
    let rows = Layout::default()
        .direction(Direction::Vertical)
        .constraints([
            Constraint::Length(3),
            Constraint::Min(21),
            Constraint::Length(12),
            Constraint::Length(1),
        ])
        .split(area);
    header(f, rows[0], v.snap);
    let mid = Layout::default()
        .direction(Direction::Horizontal)
        .constraints([Constraint::Min(84), Constraint::Length(62)])
        .split(rows[1]);
    parameters(f, mid[0], v);
    let side = Layout::default()
        .direction(Direction::Vertical)
        .constraints([Constraint::Min(8), Constraint::Length(11)])
        .split(mid[1]);
    status(f, side[0], v.snap);
    latency(f, side[1], v.snap);
    let low = Layout::default()
        .direction(Direction::Horizontal)
        .constraints([Constraint::Min(60), Constraint::Length(62)])
        .split(rows[2]);
    plot(f, low[0], v);
    processes(f, low[1], v.snap);
    let keys = match (v.notice, &v.snap.ground) {
        (Some(n), _) => format!(" {n}"),
        (None, Some(_)) => format!(" q quit · ↑/↓ select a row to plot · {UNAVAILABLE}: not carried by the ground link's telemetry"),
        (None, None) => {
            " q quit (the run goes on) · ↑/↓ select a row to plot · s stop the run (asks first)"
                .to_string()
        }
    };
    f.render_widget(
        Paragraph::new(keys).style(Style::default().fg(Color::Gray)),
        rows[3],
    );
    if let Some(q) = v.confirm {
        let w = (q.chars().count() as u16 + 4).min(area.width);
        let r = Rect::new(
            area.x + area.width.saturating_sub(w) / 2,
            area.y + area.height / 2,
            w,
            3,
        );
        f.render_widget(Clear, r);
        f.render_widget(
            Paragraph::new(q)
                .style(Style::default().fg(Color::Yellow))
                .block(Block::default().borders(Borders::ALL).title(" confirm ")),
            r,
        );
    }
}

/// What the screen shows for a figure the source does not carry.
pub const UNAVAILABLE: &str = "n/a";

fn header(f: &mut Frame, r: Rect, s: &Snapshot) {
    let title = match &s.ground {
        Some(g) => format!(" taiji monitor · ground link {} ", g.address),
        None => format!(
            " taiji monitor · bus prefix {} ",
            s.bus_prefix.as_deref().unwrap_or_default()
        ),
    };
    let block = Block::default().borders(Borders::ALL).title(title);
    let Some(run) = &s.run else {
        let text = match &s.ground {
            Some(_) => "waiting for the set's health report (housekeeping structure 2) …",
            None => "waiting for a run on this prefix (the supervisor's status) …",
        };
        f.render_widget(Paragraph::new(text).block(block), r);
        return;
    };
    let pacing = match (run.time_scale, run.period_us, run.pacing) {
        (Some(x), Some(p), _) => format!("real time ×{x} ({p:.0} µs period)"),
        (_, _, Some(_)) => "accelerated lock-step".to_string(),
        (_, _, None) => format!("pacing {UNAVAILABLE}"),
    };
    let phase = match &run.maneuver {
        None => UNAVAILABLE.to_string(),
        Some(m) => match m.axis {
            Some(a) if m.axes_rocked == 1 => format!("rocking {a}, {:+.2e} N m", m.torque_nm),
            Some(_) => format!("{} axes rocked", m.axes_rocked),
            None => "quiet".to_string(),
        },
    };
    let stop = run.stop_requested_by.map_or(String::new(), |p| {
        format!(" · stop requested by monitor pid {p}")
    });
    let who = match (run.campaign, run.supervisor_pid) {
        (Some(c), _) => format!("campaign {c}"),
        (None, Some(p)) => format!("supervisor pid {p}"),
        (None, None) => format!("supervisor pid {UNAVAILABLE}"),
    };
    let label = format!(
        "{} · tick {}/{} ({:.1} %) · t = {:.0} s · {pacing} · maneuver: {phase} · {who}{stop}",
        run.state,
        run.tick,
        run.n_samples,
        100.0 * run.progress,
        run.sim_time_s,
    );
    f.render_widget(
        Gauge::default()
            .block(block)
            .gauge_style(Style::default().fg(Color::Blue).bg(Color::Black))
            .ratio(run.progress.clamp(0.0, 1.0))
            .label(label),
        r,
    );
}

/// A parameter's value for people: β, k relative σ; r in µm.
fn shown(name: &str, v: Option<f64>, relative_to: f64) -> String {
    match (name, v) {
        (_, None) => "—".into(),
        ("r", Some(x)) => format!("{:.3} µm", x * 1e6),
        (_, Some(x)) if relative_to != 0.0 => format!("{:.2e}", x / relative_to.abs()),
        (_, Some(x)) => format!("{x:.3e}"),
    }
}

fn parameters(f: &mut Frame, r: Rect, v: &View) {
    let block = Block::default()
        .borders(Borders::ALL)
        .title(" estimates (β, k: 1σ and bound relative; r: 1σ and bound in µm) ");
    let Some(e) = &v.snap.estimate else {
        f.render_widget(Paragraph::new("no estimate yet").block(block), r);
        return;
    };
    let header = Row::new(
        [
            "IS", "par", "estimate", "1σ", "bound", "σ/bound", "truth", "err/σ",
        ]
        .map(|h| Cell::from(h).style(Style::default().add_modifier(Modifier::BOLD))),
    );
    let rows = e.parameters.iter().enumerate().map(|(i, p)| {
        let est = match p.name {
            "r" => format!("{:+.7} m", p.estimate),
            _ => format!("{:.6e}", p.estimate),
        };
        let rel = p.estimate;
        let ratio = match (p.sigma_over_bound, &v.snap.ground) {
            (Some(x), _) => format!("{x:.2}"),
            (None, Some(_)) => UNAVAILABLE.into(),
            (None, None) => "—".into(),
        };
        let err = p.err_over_sigma.map_or("—".into(), |x| format!("{x:+.2}"));
        let truth = match (p.name, p.truth) {
            (_, None) => "—".into(),
            ("r", Some(t)) => format!("{t:+.7} m"),
            (_, Some(t)) => format!("{t:.6e}"),
        };
        let style = if i == v.selected {
            Style::default().add_modifier(Modifier::REVERSED)
        } else {
            Style::default()
        };
        Row::new(vec![
            Cell::from(format!("IS{}", p.is)),
            Cell::from(format!("{} {}", greek(p.name), p.axis)),
            Cell::from(est),
            Cell::from(shown(p.name, Some(p.sigma), rel)),
            Cell::from(match (p.bound, &v.snap.ground) {
                (None, Some(_)) => UNAVAILABLE.into(),
                (b, _) => shown(p.name, b, rel),
            }),
            Cell::from(ratio),
            Cell::from(truth),
            Cell::from(err),
        ])
        .style(style)
    });
    let widths = [
        Constraint::Length(4),
        Constraint::Length(4),
        Constraint::Length(14),
        Constraint::Length(13),
        Constraint::Length(13),
        Constraint::Length(8),
        Constraint::Length(14),
        Constraint::Length(6),
    ];
    f.render_widget(Table::new(rows, widths).header(header).block(block), r);
}

fn greek(name: &str) -> &str {
    if name == "beta" {
        "β"
    } else {
        name
    }
}

fn status(f: &mut Frame, r: Rect, s: &Snapshot) {
    let block = Block::default().borders(Borders::ALL).title(" status ");
    let Some(e) = &s.estimate else {
        f.render_widget(Paragraph::new("—").block(block), r);
        return;
    };
    let colour = if e.status_word == 0 {
        Color::Green
    } else {
        Color::Yellow
    };
    let mut lines = vec![
        Line::from(vec![
            Span::raw("status "),
            Span::styled(
                format!("{} (word {:#x})", e.status, e.status_word),
                Style::default().fg(colour).add_modifier(Modifier::BOLD),
            ),
            Span::raw(format!(
                " · tick {} · solved at {}{}",
                e.tick,
                e.solved_tick,
                if e.is_final { " · FINAL" } else { "" }
            )),
        ]),
        Line::from(format!(
            "χ²/dof {} · σ ×{}",
            e.chi2_per_dof
                .iter()
                .map(|(g, v)| format!("{g} {v:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            e.sigma_inflation
                .map_or(UNAVAILABLE.to_string(), |x| format!("{x:.2}"))
        )),
        Line::from(format!(
            "samples used {} · rejected {} ({} ticks in the last {:.0} s)",
            e.samples_used,
            e.samples_rejected,
            e.ticks_in_window,
            super::model::WINDOW.as_secs_f64()
        )),
    ];
    let causes: Option<Vec<String>> = e.rejections.as_ref().map(|r| {
        r.iter()
            .filter(|c| c.count > 0)
            .map(|c| format!("{} {} ({:.1}/s)", c.cause, c.count, c.rate_per_s))
            .collect()
    });
    lines.push(Line::from(match causes {
        None => format!("rejections by cause: {UNAVAILABLE}"),
        Some(c) if c.is_empty() => "rejections by cause: none".to_string(),
        Some(c) => format!("rejections by cause: {}", c.join(", ")),
    }));
    f.render_widget(
        Paragraph::new(lines)
            .block(block)
            .wrap(ratatui::widgets::Wrap { trim: true }),
        r,
    );
}

fn latency(f: &mut Frame, r: Rect, s: &Snapshot) {
    let Some(l) = &s.latency else {
        let block = Block::default().borders(Borders::ALL).title(" latency ");
        f.render_widget(Paragraph::new("—").block(block), r);
        return;
    };
    let title = " latency [µs] p50 / p99 / max ";
    let block = Block::default().borders(Borders::ALL).title(title);
    let q = |x: &super::model::Quantiles| format!("{:.1} / {:.1} / {:.1}", x.p50, x.p99, x.max);
    let mut lines = vec![Line::from(match &l.end_to_end_us {
        Some(e) => format!(
            "last {:.0} s: end to end {} ({} samples)",
            l.window_s,
            q(e),
            e.count.unwrap_or(0)
        ),
        None => format!("last {:.0} s: end to end {UNAVAILABLE}", l.window_s),
    })];
    for (seg, s) in &l.segments_us {
        lines.push(Line::from(format!("  {seg} out: {}", q(s))));
    }
    if let Some(e) = &l.end_to_end_since_start_us {
        lines.push(Line::from(format!("since start: end to end {}", q(e))));
    }
    for (hop, h) in &l.hops_since_start_us {
        lines.push(Line::from(format!("  hop {hop}: {}", q(h))));
    }
    let missed = match (l.realtime, l.missed_deadlines, l.missed_deadlines_in_window) {
        (Some(false), ..) => "no deadline (accelerated)".to_string(),
        (_, None, _) => UNAVAILABLE.to_string(),
        (_, Some(m), Some(n)) => format!("{m} ({n} in the window)"),
        (_, Some(m), None) => m.to_string(),
    };
    lines.push(Line::from(format!(
        "missed deadlines {missed} · samples lost {}",
        l.samples_lost
    )));
    f.render_widget(Paragraph::new(lines).block(block), r);
}

fn processes(f: &mut Frame, r: Rect, s: &Snapshot) {
    let block = Block::default().borders(Borders::ALL).title(" processes ");
    let header = Row::new(
        ["process", "host", "state", "beat ago", "restarts", "tick"]
            .map(|h| Cell::from(h).style(Style::default().add_modifier(Modifier::BOLD))),
    );
    let rows = s.processes.iter().map(|p| {
        let alloc = p
            .loop_allocations
            .map_or(String::new(), |a| format!(" alloc {a}"));
        Row::new(vec![
            Cell::from(p.name.trim_start_matches("taiji-").to_string()),
            Cell::from(p.host.clone().unwrap_or_else(|| UNAVAILABLE.into())),
            Cell::from(p.state),
            Cell::from(
                p.heartbeat_age_ms
                    .map_or_else(|| "—".into(), |a| format!("{a:.0} ms")),
            ),
            Cell::from(p.restarts.to_string()),
            Cell::from(match p.next_tick {
                Some(t) => format!("{t}{alloc}"),
                None => UNAVAILABLE.to_string(),
            }),
        ])
    });
    let widths = [
        Constraint::Length(10),
        Constraint::Length(7),
        Constraint::Length(9),
        Constraint::Length(8),
        Constraint::Length(8),
        Constraint::Length(13),
    ];
    f.render_widget(Table::new(rows, widths).header(header).block(block), r);
}

/// The selected row over the campaign: σ/bound (1 at the bound) and, with a scenario,
/// err/σ (within ±2 most of the time when σ is honest).
fn plot(f: &mut Frame, r: Rect, v: &View) {
    let k = v.selected.min(ROWS - 1);
    let (is, g, a) = (k / 9, (k % 9) / 3, k % 3);
    let title = format!(
        " IS{} {} {}: σ/bound (blue) and err/σ (yellow) over the campaign ",
        is + 1,
        greek(GROUPS[g].0),
        AXES[a]
    );
    let block = Block::default().borders(Borders::ALL).title(title);
    let n = v.snap.run.as_ref().map_or(1, |r| r.n_samples.max(1)) as f64;
    let ratio: Vec<(f64, f64)> = v
        .history
        .iter()
        .filter_map(|p| {
            let x = p.sigma[k] / p.bound[k];
            x.is_finite().then_some((p.tick as f64 / n, x))
        })
        .collect();
    let truth = v.snap.estimate.as_ref().and_then(|e| {
        e.parameters
            .iter()
            .find(|p| p.is == is + 1 && p.name == GROUPS[g].0 && p.axis == AXES[a])
            .and_then(|p| p.truth)
    });
    let err: Vec<(f64, f64)> = match truth {
        Some(t) => v
            .history
            .iter()
            .filter_map(|p| {
                let x = (p.value[k] - t) / p.sigma[k];
                x.is_finite().then_some((p.tick as f64 / n, x))
            })
            .collect(),
        None => Vec::new(),
    };
    let top = ratio
        .iter()
        .chain(&err)
        .map(|(_, y)| y.abs())
        .fold(3.0f64, f64::max)
        .min(20.0);
    let bottom = if err.is_empty() { 0.0 } else { -top };
    let datasets = vec![
        Dataset::default()
            .name("σ/bound")
            .marker(Marker::Braille)
            .graph_type(GraphType::Line)
            .style(Style::default().fg(Color::Cyan))
            .data(&ratio),
        Dataset::default()
            .name("err/σ")
            .marker(Marker::Braille)
            .graph_type(GraphType::Line)
            .style(Style::default().fg(Color::Yellow))
            .data(&err),
    ];
    let chart = Chart::new(datasets)
        .block(block)
        .x_axis(
            Axis::default()
                .title("campaign")
                .bounds([0.0, 1.0])
                .labels(["0", "0.5", "1"]),
        )
        .y_axis(Axis::default().bounds([bottom, top]).labels([
            format!("{bottom:.0}"),
            format!("{:.1}", (bottom + top) / 2.0),
            format!("{top:.0}"),
        ]));
    f.render_widget(chart, r);
}
