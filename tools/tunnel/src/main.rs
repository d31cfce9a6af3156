//! `taiji-tunnel`: the official iceoryx2 Zenoh tunnel (`iceoryx2-services-tunnel` with
//! `iceoryx2-integrations-zenoh-tunnel-backend`, 0.9.3) for one run's bus prefix, used
//! as a library — not a network layer of our own.
//!
//! Why not the `iox2-tunnel-zenoh` CLI: at 0.9.3 it opens the iceoryx2 default
//! configuration (no resource prefix, so it cannot see a run's services), its
//! `--reactive` is `unimplemented!`, and its 100 ms poll caps the lock-step rate (the
//! backend's zenoh subscribers hold 10 samples each, then push back on the link).
//!
//! A crate of its own (`tools/tunnel`), so the main crate never builds zenoh.
//!
//! What crosses: only the services named on the command line (`--service`), fed to the
//! tunnel through its discovery-service hook: the tunnel would otherwise relay every
//! service of the prefix, the truth included, to the other host.

use clap::Parser;
use iceoryx2::config::Config;
use iceoryx2::prelude::*;
use iceoryx2_integrations_zenoh_tunnel_backend::ZenohBackend;
use iceoryx2_services_discovery::service_discovery::{Discovery, Tracker};
use iceoryx2_services_tunnel::{Config as TunnelConfig, Tunnel};
use std::time::{Duration, Instant};

/// Private service through which this process tells the tunnel what to relay.
const DISCOVERY_SERVICE: &str = "taiji/tunnel/discovery";

#[derive(Debug, Clone, clap::Parser)]
#[command(
    name = "taiji-tunnel",
    version,
    about = "Relay a run's iceoryx2 services to another host over Zenoh (the iceoryx2 tunnel)"
)]
struct TunnelArgs {
    /// Prefix of the run's iceoryx2 resources.
    #[arg(long, default_value = "taiji_")]
    bus_prefix: String,
    /// Zenoh endpoint to listen on (e.g. tcp/10.77.0.1:7447); repeatable.
    #[arg(long)]
    listen: Vec<String>,
    /// Zenoh endpoint of the other host's tunnel (retried until it answers); repeatable.
    #[arg(long)]
    connect: Vec<String>,
    /// A service to relay (e.g. taiji/sensor); repeatable; none: every service of the prefix.
    #[arg(long = "service")]
    services: Vec<String>,
    /// Pause between two relay passes [µs] (0: spin). Each pass moves everything pending.
    #[arg(long, default_value_t = 100)]
    poll_us: u64,
    /// Period of service discovery on both sides [ms].
    #[arg(long, default_value_t = 100)]
    discover_ms: u64,
    /// Zenoh link lease [ms]: a link silent this long is closed (what it queued is lost).
    #[arg(long, default_value_t = 10_000)]
    lease_ms: u64,
}

/// The iceoryx2 configuration of a run, as `taiji::bus::wiring::config` makes it: the default
/// with the run's resource prefix; dead nodes are the supervisor's to clean.
fn iceoryx_config(prefix: &str) -> Result<Config, String> {
    let mut c = Config::default();
    c.global.prefix = FileName::new(prefix.as_bytes())
        .map_err(|e| format!("invalid bus prefix {prefix:?}: {e:?}"))?;
    c.global.node.cleanup_dead_nodes_on_creation = false;
    c.global.node.cleanup_dead_nodes_on_destruction = false;
    Ok(c)
}

/// The zenoh configuration of a tunnel: a peer on our endpoints only (no multicast
/// scouting or gossip, so it never meets another run's tunnel on the machine).
fn zenoh_config(args: &TunnelArgs) -> Result<zenoh::Config, String> {
    let mut c = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, k: &str, v: String| {
        c.insert_json5(k, &v)
            .map_err(|e| format!("zenoh configuration {k} = {v}: {e}"))
    };
    let list = |v: &[String]| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
    set(&mut c, "mode", "\"peer\"".into())?;
    set(&mut c, "listen/endpoints", list(&args.listen))?;
    set(&mut c, "connect/endpoints", list(&args.connect))?;
    set(&mut c, "scouting/multicast/enabled", "false".into())?;
    set(&mut c, "transport/link/tx/lease", args.lease_ms.to_string())?;
    Ok(c)
}

/// Run the tunnel until SIGINT/SIGTERM (Ok) or a failure (Err).
fn run(args: &TunnelArgs) -> Result<(), String> {
    if args.listen.is_empty() && args.connect.is_empty() {
        return Err(
            "give --listen or --connect (a zenoh endpoint such as tcp/10.77.0.1:7447)".into(),
        );
    }
    let cfg = iceoryx_config(&args.bus_prefix)?;
    let zcfg = zenoh_config(args)?;
    let node = NodeBuilder::new()
        .name(&NodeName::new("taiji-tunnel-feed").map_err(|e| format!("{e:?}"))?)
        .config(&cfg)
        .create::<ipc::Service>()
        .map_err(|e| format!("cannot create the tunnel's iceoryx2 node: {e:?}"))?;
    let feed_name: ServiceName = DISCOVERY_SERVICE
        .try_into()
        .map_err(|e| format!("invalid service name {DISCOVERY_SERVICE}: {e:?}"))?;
    let feed = node
        .service_builder(&feed_name)
        .publish_subscribe::<Discovery>()
        .subscriber_max_buffer_size(256)
        .history_size(0)
        .open_or_create()
        .map_err(|e| format!("cannot create {DISCOVERY_SERVICE}: {e:?}"))?
        .publisher_builder()
        .create()
        .map_err(|e| format!("cannot create the publisher of {DISCOVERY_SERVICE}: {e:?}"))?;
    let tcfg = TunnelConfig {
        discovery_service: Some(DISCOVERY_SERVICE.into()),
    };
    let mut tunnel = Tunnel::<ipc::Service, ZenohBackend<ipc::Service>>::create(&tcfg, &cfg, &zcfg)
        .map_err(|e| {
            format!(
                "cannot create the tunnel (zenoh endpoints {:?} {:?}): {e}",
                args.listen, args.connect
            )
        })?;
    let mut tracker = Tracker::<ipc::Service>::new(&cfg);
    let wanted = |name: &str| {
        name != DISCOVERY_SERVICE
            && (args.services.is_empty() || args.services.iter().any(|s| s == name))
    };
    log::info!(
        "taiji-tunnel: prefix {:?}, listen {:?}, connect {:?}, relaying {}",
        args.bus_prefix,
        args.listen,
        args.connect,
        if args.services.is_empty() {
            "every service".to_string()
        } else {
            args.services.join(", ")
        }
    );
    let discover_every = Duration::from_millis(args.discover_ms.max(1));
    let poll = Duration::from_micros(args.poll_us);
    let mut next_discovery = Instant::now();
    loop {
        if Instant::now() >= next_discovery {
            next_discovery = Instant::now() + discover_every;
            let (added, _removed) = tracker.sync().map_err(|e| {
                format!(
                    "cannot list the services of prefix {:?}: {e:?}",
                    args.bus_prefix
                )
            })?;
            for id in added {
                let Some(d) = tracker.get(&id) else { continue };
                let name = d.static_details.name().as_str();
                if !wanted(name) {
                    continue;
                }
                log::info!("taiji-tunnel: relaying {name}");
                let sample = feed
                    .loan_uninit()
                    .map_err(|e| format!("{DISCOVERY_SERVICE}: loan failed: {e:?}"))?;
                sample
                    .write_payload(Discovery::Added(d.static_details.clone()))
                    .send()
                    .map_err(|e| format!("{DISCOVERY_SERVICE}: send failed: {e:?}"))?;
            }
            // Ours first (the feed above), then what the other host announced.
            if let Err(e) = tunnel.discover() {
                log::warn!("taiji-tunnel: discovery: {e}");
            }
        }
        if let Err(e) = tunnel.propagate() {
            log::warn!("taiji-tunnel: relay: {e}");
        }
        if node.wait(poll).is_err() {
            return Ok(());
        }
    }
}

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .format_target(false)
        .init();
    set_log_level_from_env_or(LogLevel::Error);
    let args = TunnelArgs::parse();
    match run(&args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("taiji-tunnel: error: {e}");
            std::process::ExitCode::from(2)
        }
    }
}
