//! `taiji-calib ground`: the ground side of the link (docs/ground.md). Each
//! telecommand's subcommand sends it signed, then prints every telemetry packet that
//! comes back until its exchange is over: exit 0 when it succeeded, 1 on a failure
//! report, 3 when the set did not answer in time. `listen` prints (and saves) the
//! telemetry as it comes; `decode` prints a saved stream; `dictionary` the interface.

use super::args::GroundCmd;
use super::error::CliError;
use super::ground_args::{DictionaryFormat, ExchangeArgs, LinkArgs};
use crate::ground::client::{self, saved, Link, Received};
use crate::ground::describe::{describe, Described};
use crate::ground::dictionary::Function;
use crate::ground::exchange::{Exchange, Keepalive, Outcome};
use crate::ground::publish;
use crate::ground::tc::{self, Reply, Request};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Exit code of a failure report.
const FAILED: u8 = 1;
/// Exit code of an exchange the set did not finish in time.
const TIMED_OUT: u8 = 3;

pub(crate) fn run(cmd: GroundCmd) -> Result<ExitCode, CliError> {
    match cmd {
        GroundCmd::Dictionary { format } => {
            let text = match format {
                DictionaryFormat::Json => serde_json::to_string_pretty(&publish::json())? + "\n",
                DictionaryFormat::Xtce => publish::xtce(),
            };
            // A closed pipe (`| head`) ends the printing, not the command with an error.
            let _ = std::io::stdout().lock().write_all(text.as_bytes());
            Ok(ExitCode::SUCCESS)
        }
        GroundCmd::Decode { file, json } => decode(&file, json),
        GroundCmd::Listen {
            save,
            keepalive,
            seconds,
            link,
        } => listen(save, keepalive, seconds, &link),
        tc => match request(tc)? {
            Some((req, x)) => exchange(&req, &x),
            None => Ok(ExitCode::from(2)),
        },
    }
}

/// The telecommand of a subcommand, and its exchange's options (None: a subcommand
/// that sends none).
fn request(cmd: GroundCmd) -> Result<Option<(Request, ExchangeArgs)>, CliError> {
    Ok(Some(match cmd {
        GroundCmd::Ping { x } => (Request::Ping, x),
        GroundCmd::Start { seed, duration, x } => (
            Request::Function(Function::Start {
                seed,
                duration_s: duration,
            }),
            x,
        ),
        GroundCmd::Stop { x } => (Request::Function(Function::Stop), x),
        GroundCmd::Apply { x } => (Request::Function(Function::Apply), x),
        GroundCmd::Restore { x } => (Request::Function(Function::Restore), x),
        GroundCmd::Shutdown { x } => (Request::Function(Function::Shutdown), x),
        GroundCmd::HkEnable { ids, x } => (Request::HkEnable(tc::structure_ids(&ids)?), x),
        GroundCmd::HkDisable { ids, x } => (Request::HkDisable(tc::structure_ids(&ids)?), x),
        GroundCmd::HkInterval { id, ms, x } => (Request::HkInterval(vec![(id, ms)]), x),
        GroundCmd::HkNow { ids, x } => (Request::HkNow(tc::structure_ids(&ids)?), x),
        GroundCmd::EventEnable { ids, x } => (Request::EventEnable(tc::event_ids(&ids)?), x),
        GroundCmd::EventDisable { ids, x } => (Request::EventDisable(tc::event_ids(&ids)?), x),
        GroundCmd::Get { ids, x } => (Request::Get(tc::parameter_ids(&ids)?), x),
        GroundCmd::Set { values, x } => (Request::Set(tc::assignments(&values)?), x),
        GroundCmd::Dictionary { .. } | GroundCmd::Decode { .. } | GroundCmd::Listen { .. } => {
            return Ok(None)
        }
    }))
}

/// Seconds of option `--name`, finite and ≥ 0.
fn seconds(name: &'static str, value: f64) -> Result<Duration, CliError> {
    if (0.0..1e9).contains(&value) {
        Ok(Duration::from_secs_f64(value))
    } else {
        Err(CliError::Seconds { name, value })
    }
}

/// Prints a packet as a line of text or JSON; false once stdout is closed.
fn emit(d: &Described, json: bool) -> bool {
    let mut out = std::io::stdout().lock();
    let line = if json {
        d.value.to_string()
    } else {
        d.text.clone()
    };
    writeln!(out, "{line}").and_then(|_| out.flush()).is_ok()
}

/// The name of a verification report's stage by its subtype.
fn stage(subtype: u8) -> &'static str {
    match subtype {
        1 | 2 => "acceptance",
        3 | 4 => "start",
        5 | 6 => "progress",
        _ => "completion",
    }
}

/// How waiting for an exchange's end ended.
enum Waited {
    Done,
    Failed(Outcome),
    /// The onboard address refused the datagram: nothing listens there.
    Refused,
    /// The deadline passed; whether anything came.
    Silent {
        heard: bool,
    },
}

/// Prints the telemetry that comes until `ex` is over or `deadline`.
fn wait(
    link: &mut Link,
    ex: &mut Exchange,
    deadline: Instant,
    json: bool,
) -> Result<Waited, CliError> {
    loop {
        match link.receive_until(deadline)? {
            Received::Datagram(d) => {
                let desc = describe(&d);
                emit(&desc, json);
                match ex.take(&desc) {
                    Some(Outcome::Done) => return Ok(Waited::Done),
                    Some(f) => return Ok(Waited::Failed(f)),
                    None => {}
                }
            }
            Received::Refused => return Ok(Waited::Refused),
            Received::Nothing => return Ok(Waited::Silent { heard: ex.heard() }),
        }
    }
}

/// Sends `req`, prints the telemetry until its exchange is over; the exit code.
///
/// The set sends its telemetry, a refused telecommand's failure report included, to
/// the sender of the last accepted telecommand. So that a refusal comes back here, a
/// telecommand other than a ping is preceded by a ping from the same socket (no reports
/// asked for; its 17,2 is printed too), unless `--no-claim` or `--seq` is given.
fn exchange(req: &Request, x: &ExchangeArgs) -> Result<ExitCode, CliError> {
    let timeout = seconds("timeout", x.timeout)?;
    let app_data = req.app_data()?;
    // A start completes once every process of the campaign runs (the bound computed,
    // the set spawned and ready: seconds): by default its start report ends it.
    let ack = x.ack.unwrap_or(match req {
        Request::Function(Function::Start { .. }) => client::ACK_ACCEPTANCE | client::ACK_START,
        _ => client::ACK_ALL,
    });
    Exchange::check(ack, &req.reply())?;
    let mut link = Link::open(&x.link.config())?;
    let deadline = Instant::now() + timeout;
    let json = x.link.json;
    if !x.no_claim && x.link.seq.is_none() && *req != Request::Ping {
        let sent = link.send(17, 1, 0, &[])?;
        let mut ex = Exchange::new(&sent, Reply::Pong)?;
        let waited = wait(&mut link, &mut ex, deadline, json)?;
        if !matches!(waited, Waited::Done) {
            return Ok(ended(waited, (17, 1), &link, x, &ex));
        }
    }
    let (service, subtype) = req.service();
    let sent = link.send(service, subtype, ack, &app_data)?;
    let mut ex = Exchange::new(&sent, req.reply())?;
    eprintln!(
        "sent {service},{subtype} (sequence number {}) to {}",
        sent.seq,
        link.to()
    );
    let waited = wait(&mut link, &mut ex, deadline, json)?;
    Ok(ended(waited, (service, subtype), &link, x, &ex))
}

/// The exit code of an exchange, its error said on stderr.
fn ended(waited: Waited, tc: (u8, u8), link: &Link, x: &ExchangeArgs, ex: &Exchange) -> ExitCode {
    let (service, subtype) = tc;
    let to = link.to();
    match waited {
        Waited::Done => return ExitCode::SUCCESS,
        Waited::Failed(Outcome::Failed {
            subtype: report,
            code,
            name,
            meaning,
        }) => {
            eprintln!(
                "error: {service},{subtype} failed at {}: failure {code} {name}: {meaning}",
                stage(report)
            );
            return ExitCode::from(FAILED);
        }
        Waited::Failed(Outcome::Done) => return ExitCode::SUCCESS,
        Waited::Refused => eprintln!(
            "error: nothing listens on {to} (the datagram was refused): is the set up with --ground {to}?"
        ),
        Waited::Silent { heard: true } => eprintln!(
            "error: no end of the exchange within {} s: still waiting for {}",
            x.timeout,
            ex.awaited()
        ),
        Waited::Silent { heard: false } => eprintln!(
            "error: nothing heard from {to} within {} s: is the set up on this address, and is this its key? (a refused telecommand's report goes to the sender of the last accepted one)",
            x.timeout
        ),
    }
    ExitCode::from(TIMED_OUT)
}

/// Receives in slices of this at most (to see a signal or the next keepalive).
const SLICE: Duration = Duration::from_millis(100);

fn listen(
    save: Option<PathBuf>,
    keepalive: f64,
    end: Option<f64>,
    args: &LinkArgs,
) -> Result<ExitCode, CliError> {
    let keepalive = seconds("keepalive", keepalive)?;
    let end = end.map(|s| seconds("seconds", s)).transpose()?;
    let mut file = match &save {
        Some(p) => Some(
            std::fs::OpenOptions::new()
                .append(true)
                .create(true)
                .open(p)
                .map_err(|source| CliError::Save {
                    path: p.clone(),
                    source,
                })?,
        ),
        None => None,
    };
    let mut link = Link::open(&args.config())?;
    client::catch_termination();
    if let Some(local) = link.local() {
        eprintln!("listening on {local} for the telemetry of {}", link.to());
    }
    let t0 = Instant::now();
    let mut keep = Keepalive::new(keepalive);
    let mut refused_said = false;
    loop {
        let now = Instant::now();
        if client::terminated() || end.is_some_and(|e| now - t0 >= e) {
            return Ok(ExitCode::SUCCESS);
        }
        let mut wait = SLICE;
        if let Some(at) = keep.tick(&mut link)? {
            wait = wait.min(at.saturating_duration_since(now));
        }
        if let Some(e) = end {
            wait = wait.min((t0 + e).saturating_duration_since(now));
        }
        match link.receive(wait)? {
            Received::Datagram(d) => {
                if let (Some(f), Some(p)) = (file.as_mut(), &save) {
                    saved::write(f, &d).map_err(|source| CliError::Save {
                        path: p.clone(),
                        source,
                    })?;
                }
                let desc = describe(&d);
                if !emit(&desc, args.json) {
                    return Ok(ExitCode::SUCCESS);
                }
                if let Some(Outcome::Failed {
                    code,
                    name,
                    meaning,
                    ..
                }) = keep.refusal(&desc)
                {
                    eprintln!(
                        "error: the keepalive ping was refused: failure {code} {name}: {meaning}"
                    );
                    return Ok(ExitCode::from(FAILED));
                }
            }
            Received::Refused if !refused_said => {
                refused_said = true;
                let again = if keepalive.is_zero() {
                    "".to_string()
                } else {
                    format!(" yet; pinging again every {} s", keepalive.as_secs_f64())
                };
                eprintln!("nothing listens on {}{again}", link.to());
            }
            Received::Refused | Received::Nothing => {}
        }
    }
}

/// Prints the packets of a saved stream.
fn decode(file: &Path, json: bool) -> Result<ExitCode, CliError> {
    let bytes = std::fs::read(file).map_err(|source| CliError::Save {
        path: file.to_path_buf(),
        source,
    })?;
    let (packets, err) = saved::read(&bytes);
    for p in packets {
        if !emit(&describe(p), json) {
            break;
        }
    }
    match err {
        Some(source) => Err(CliError::Saved {
            path: file.to_path_buf(),
            source,
        }),
        None => Ok(ExitCode::SUCCESS),
    }
}
