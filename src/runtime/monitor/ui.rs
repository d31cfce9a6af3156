//! The interactive terminal loop: read the bus, redraw every frame, take keys. `q`
//! leaves the monitor only; `s` asks "stop the run? y/n" and, on y, sends the stop
//! request to the supervisor until its status names this monitor. When a run ends the
//! monitor detaches (a new run on the prefix is watched from its start) and keeps the
//! last screen.

use super::feed::Feed;
use super::model::{Tracker, Truth, ROWS};
use super::{detach, pump, HostNames, MonitorArgs, MonitorError, FRAME, SILENT};
use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use crossterm::terminal::{
    disable_raw_mode, enable_raw_mode, EnterAlternateScreen, LeaveAlternateScreen,
};
use ratatui::backend::CrosstermBackend;
use std::time::{Duration, Instant};

/// Resend a stop request this often until the supervisor's status names this monitor.
const REQUEST_EVERY: Duration = Duration::from_millis(200);
/// Give up resending after this long (the run may have ended meanwhile).
const REQUEST_FOR: Duration = Duration::from_secs(10);

const QUESTION: &str = "Stop the run? Every process stops, the supervisor exits 130. y / n";

/// Restores the terminal however the loop ends.
struct TerminalGuard;

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        let _ = disable_raw_mode();
        let _ = crossterm::execute!(std::io::stdout(), LeaveAlternateScreen);
    }
}

pub fn run(
    args: &MonitorArgs,
    truth: Option<Truth>,
    hosts: &HostNames,
    timeout: Duration,
) -> Result<u8, MonitorError> {
    enable_raw_mode().map_err(MonitorError::Terminal)?;
    let _guard = TerminalGuard;
    crossterm::execute!(std::io::stdout(), EnterAlternateScreen).map_err(MonitorError::Terminal)?;
    let mut term = ratatui::Terminal::new(CrosstermBackend::new(std::io::stdout()))
        .map_err(MonitorError::Terminal)?;
    let prefix = args.bus_prefix.as_str();
    let mut t = Tracker::new(truth);
    let mut feed: Option<Feed> = None;
    let mut selected = 0usize;
    let mut confirm = false;
    let mut notice: Option<String> = None;
    let mut stop_sent: Option<Instant> = None;
    let mut last_try: Option<Instant> = None;
    let t0 = Instant::now();
    loop {
        // Attach to a run when there is one (a new one after the last ended).
        if feed.is_none() && last_try.is_none_or(|at| at.elapsed() >= FRAME) {
            last_try = Some(Instant::now());
            if let Some(f) = Feed::attach(prefix)? {
                if t.ended() {
                    t = Tracker::new(t.truth);
                }
                notice = None;
                feed = Some(f);
            } else if timeout > Duration::ZERO && t.status.is_none() && t0.elapsed() > timeout {
                drop(term);
                return Err(MonitorError::NoRun {
                    prefix: prefix.to_string(),
                    timeout_s: timeout.as_secs_f64(),
                });
            }
        }
        if feed.as_ref().is_some_and(Feed::terminated) {
            break;
        }
        if let Some(f) = feed.as_mut() {
            pump(f, &mut t)?;
            if let (Some(at), Some(f)) = (stop_sent, feed.as_mut()) {
                let acked = t.status.is_some_and(|s| s.stop_requested_by != 0);
                if acked || at.elapsed() > REQUEST_FOR {
                    stop_sent = None;
                } else {
                    f.request_stop()?;
                }
            }
            let silent = t.status_at.is_some_and(|s| s.elapsed() > SILENT);
            if t.ended() || silent {
                if let Some(f) = feed.take() {
                    detach(f, prefix);
                }
                notice = Some(
                    "the run ended; this is its last state. q quit · a new run on the prefix is shown when it starts"
                        .into(),
                );
            }
        }
        let snap = t.snapshot(prefix, hosts, Instant::now());
        let mut view = super::screen::View::of(&t, &snap);
        view.selected = selected;
        view.confirm = confirm.then_some(QUESTION);
        view.notice = notice.as_deref();
        term.draw(|f| super::screen::draw(f, &view))
            .map_err(MonitorError::Terminal)?;
        if !event::poll(REQUEST_EVERY.min(FRAME)).map_err(MonitorError::Terminal)? {
            continue;
        }
        let Event::Key(k) = event::read().map_err(MonitorError::Terminal)? else {
            continue;
        };
        if k.kind != KeyEventKind::Press {
            continue;
        }
        let ctrl_c = k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
        if confirm {
            confirm = false;
            if k.code == KeyCode::Char('y') {
                match feed.as_mut() {
                    Some(f) => {
                        f.request_stop()?;
                        stop_sent = Some(Instant::now());
                        notice = Some("stop requested; waiting for the supervisor".into());
                    }
                    None => notice = Some("no run attached: nothing to stop".into()),
                }
            } else {
                notice = Some("not stopped".into());
            }
            continue;
        }
        match k.code {
            KeyCode::Char('q') | KeyCode::Esc => break,
            _ if ctrl_c => break,
            KeyCode::Down | KeyCode::Char('j') => selected = (selected + 1) % ROWS,
            KeyCode::Up | KeyCode::Char('k') => selected = (selected + ROWS - 1) % ROWS,
            KeyCode::Char('s') => confirm = true,
            _ => {}
        }
    }
    drop(term);
    if let Some(f) = feed.take() {
        detach(f, prefix);
    }
    Ok(0)
}

/// `--ground` without `--once`: the same screen from the ground link's telemetry. `q`
/// leaves; there is no stop from here (send `taiji-calib ground stop`).
pub fn run_ground(
    args: &MonitorArgs,
    to: std::net::SocketAddr,
    truth: Option<Truth>,
    timeout: Duration,
) -> Result<u8, MonitorError> {
    let mut g = super::ground::GroundFeed::open(args, to)?;
    crate::ground::client::catch_termination();
    enable_raw_mode().map_err(MonitorError::Terminal)?;
    let _guard = TerminalGuard;
    crossterm::execute!(std::io::stdout(), EnterAlternateScreen).map_err(MonitorError::Terminal)?;
    let mut term = ratatui::Terminal::new(CrosstermBackend::new(std::io::stdout()))
        .map_err(MonitorError::Terminal)?;
    let mut t = Tracker::new(truth);
    let mut selected = 0usize;
    let t0 = Instant::now();
    while !crate::ground::client::terminated() {
        g.pump(&mut t, Duration::from_millis(5))?;
        if g.new_campaign {
            t = Tracker::new(t.truth);
        }
        let silent = g.heard_at.map_or(t0.elapsed(), |at| at.elapsed());
        if g.heard_at.is_none() && timeout > Duration::ZERO && silent > timeout {
            drop(term);
            return Err(MonitorError::NoTelemetry {
                address: to,
                timeout_s: timeout.as_secs_f64(),
                why: if g.nothing_listens {
                    " (nothing listens there: is the set up with --ground?)"
                } else {
                    " (is the set up, on this address, with this key?)"
                },
            });
        }
        let notice = match (&g.refused, g.nothing_listens) {
            (Some(why), _) => Some(format!("the set refused the monitor's ping: {why}")),
            (None, true) => Some(format!("nothing listens on {to} (yet); q quit")),
            _ if silent > SILENT => Some(format!(
                "no telemetry from {to} for {:.0} s; this is its last state. q quit",
                silent.as_secs_f64()
            )),
            _ => None,
        };
        let now = Instant::now();
        let mut snap = t.snapshot("", &super::HostNames(None), now);
        g.finish(&mut snap, now);
        let mut view = super::screen::View::of(&t, &snap);
        view.selected = selected;
        view.notice = notice.as_deref();
        term.draw(|f| super::screen::draw(f, &view))
            .map_err(MonitorError::Terminal)?;
        if !event::poll(FRAME).map_err(MonitorError::Terminal)? {
            continue;
        }
        let Event::Key(k) = event::read().map_err(MonitorError::Terminal)? else {
            continue;
        };
        if k.kind != KeyEventKind::Press {
            continue;
        }
        let ctrl_c = k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
        match k.code {
            KeyCode::Char('q') | KeyCode::Esc => break,
            _ if ctrl_c => break,
            KeyCode::Down | KeyCode::Char('j') => selected = (selected + 1) % ROWS,
            KeyCode::Up | KeyCode::Char('k') => selected = (selected + ROWS - 1) % ROWS,
            _ => {}
        }
    }
    drop(term);
    Ok(0)
}
