//! Round trip through the iceoryx2 tunnel: `ping` publishes its monotonic time on
//! `taiji/ping`, `pong` (on the other host) echoes it on `taiji/pong`; ping measures
//! the round trip with its own clock only (two hosts share no clock), the hop being
//! half of it. Run with `taiji-tunnel` on both hosts (see `tools/two-hosts`):
//!   tunnel_ping pong --bus-prefix P
//!   tunnel_ping ping --bus-prefix P --count 2000
use iceoryx2::prelude::*;
use std::time::{Duration, Instant};
use taiji::bus::timing::monotonic_ns;

fn service(
    node: &Node<ipc::Service>,
    name: &str,
) -> Result<
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u64; 2], ()>,
    String,
> {
    let sn: ServiceName = name.try_into().map_err(|e| format!("{name}: {e:?}"))?;
    node.service_builder(&sn)
        .publish_subscribe::<[u64; 2]>()
        .subscriber_max_buffer_size(64)
        .max_publishers(4)
        .max_subscribers(4)
        .history_size(0)
        .open_or_create()
        .map_err(|e| format!("cannot open {name}: {e:?}"))
}

fn percentile(sorted: &[u64], q: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i] as f64 / 1e3
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).cloned().unwrap_or_default();
    let opt = |k: &str, d: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1).cloned())
            .unwrap_or_else(|| d.to_string())
    };
    let prefix = opt("--bus-prefix", "taiji_ping_");
    let count: usize = opt("--count", "1000")
        .parse()
        .map_err(|e| format!("--count: {e}"))?;
    let wait_s: f64 = opt("--wait-s", "30")
        .parse()
        .map_err(|e| format!("--wait-s: {e}"))?;
    let cfg = taiji::bus::wiring::config(&prefix).map_err(|e| e.to_string())?;
    let node = NodeBuilder::new()
        .config(&cfg)
        .create::<ipc::Service>()
        .map_err(|e| format!("{e:?}"))?;
    let ping = service(&node, "taiji/ping")?;
    let pong = service(&node, "taiji/pong")?;
    match mode.as_str() {
        "pong" => {
            let sub = ping
                .subscriber_builder()
                .create()
                .map_err(|e| format!("{e:?}"))?;
            let publ = pong
                .publisher_builder()
                .create()
                .map_err(|e| format!("{e:?}"))?;
            let t0 = Instant::now();
            let mut echoed = 0usize;
            while echoed < count && t0.elapsed() < Duration::from_secs_f64(wait_s) {
                while let Some(s) = sub.receive().map_err(|e| format!("{e:?}"))? {
                    publ.send_copy(*s.payload()).map_err(|e| format!("{e:?}"))?;
                    echoed += 1;
                }
                std::thread::sleep(Duration::from_micros(20));
            }
            println!("pong: echoed {echoed}");
        }
        "ping" => {
            let publ = ping
                .publisher_builder()
                .create()
                .map_err(|e| format!("{e:?}"))?;
            let sub = pong
                .subscriber_builder()
                .create()
                .map_err(|e| format!("{e:?}"))?;
            // Until the first echo the tunnels are still discovering each other.
            let t0 = Instant::now();
            let mut rtts = Vec::with_capacity(count);
            let mut seq = 0u64;
            let mut lost = 0usize;
            while rtts.len() < count {
                if t0.elapsed() > Duration::from_secs_f64(wait_s) {
                    return Err(format!("only {} echoes in {wait_s} s", rtts.len()));
                }
                seq += 1;
                publ.send_copy([seq, monotonic_ns()])
                    .map_err(|e| format!("{e:?}"))?;
                let sent = Instant::now();
                // Longer than a round trip at the slowest poll (2 × 100 ms + discovery).
                let timeout = 2.0;
                'wait: loop {
                    while let Some(s) = sub.receive().map_err(|e| format!("{e:?}"))? {
                        let [k, t] = *s.payload();
                        if k == seq {
                            rtts.push(monotonic_ns() - t);
                            break 'wait;
                        }
                    }
                    if sent.elapsed() > Duration::from_secs_f64(timeout) {
                        if !rtts.is_empty() {
                            lost += 1;
                        }
                        break;
                    }
                    std::thread::sleep(Duration::from_micros(20));
                }
            }
            rtts.sort_unstable();
            println!(
                "ping: {} round trips, lost {lost}; round trip p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs (one hop ≈ half)",
                rtts.len(),
                percentile(&rtts, 0.5),
                percentile(&rtts, 0.99),
                percentile(&rtts, 1.0)
            );
        }
        _ => {
            return Err(
                "usage: tunnel_ping ping|pong [--bus-prefix P] [--count N] [--wait-s S]".into(),
            )
        }
    }
    Ok(())
}
