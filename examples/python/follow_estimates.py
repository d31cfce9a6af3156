#!/usr/bin/env python3
"""Follow the live estimate stream of a running process set from Python, with the
official iceoryx2 bindings (the version matching the crate: pip install iceoryx2==0.9.3).

    python3 examples/python/follow_estimates.py [--bus-prefix taiji_] [--count N] [--timeout S]

Attaches to the `taiji/estimate` service of a run (started with tools/launch or
taiji-supervisor on the same bus prefix) at any moment, and prints one line per
estimate received: tick, status and IS1's β and r with σ. With --count it stops after
N estimates; it stops by itself at the campaign's final estimate. Started before the
run, it waits for the service (up to --timeout seconds, then exits 1 saying so);
a follower that found no run leaves nothing in /dev/shm.

The ctypes layouts below mirror `include/taiji_estimator.h` (TaijiHeader,
TaijiEstimateMsg); the type names carry the layout version, so a client of another
layout is refused by iceoryx2 when it opens the service instead of misreading bytes.
"""
import argparse
import ctypes
import gc
import os
import re
import sys
import time

import iceoryx2 as iox

LAYOUT_VERSION = 1
N_CAUSES = 11
N_GROUPS = 4
EST_FINAL = 1
SERVICE = "taiji/estimate"
# Must equal the crate's bus settings (src/bus/wiring.rs): iceoryx2 checks them on open.
MAX_PUBLISHERS, MAX_SUBSCRIBERS, MAX_NODES = 8, 8, 16
RECORDER_QUEUE = 2048


class Header(ctypes.Structure):
    _fields_ = [
        ("seq", ctypes.c_uint64),
        ("tick", ctypes.c_uint64),
        ("sim_time_ns", ctypes.c_int64),
        ("publish_ns", ctypes.c_uint64),
        ("origin_ns", ctypes.c_uint64),
        ("due_ns", ctypes.c_uint64),
        ("epoch", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return f"taiji::v{LAYOUT_VERSION}::Header"


Vec3x2 = (ctypes.c_double * 3) * 2


class EstimateMsg(ctypes.Structure):
    _fields_ = [
        ("header", Header),
        ("solved_tick", ctypes.c_uint64),
        ("beta", Vec3x2),
        ("beta_sigma", Vec3x2),
        ("k", Vec3x2),
        ("k_sigma", Vec3x2),
        ("r_b", Vec3x2),
        ("r_sigma", Vec3x2),
        ("n_used", ctypes.c_uint64),
        ("n_rejected", ctypes.c_uint64),
        ("flags", ctypes.c_uint64),
        ("status", ctypes.c_uint64),
        ("rejected_by_cause", ctypes.c_uint64 * N_CAUSES),
        ("tick_rejections", ctypes.c_uint64),
        ("chi2_per_dof", ctypes.c_double * N_GROUPS),
        ("sigma_inflation", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return f"taiji::v{LAYOUT_VERSION}::EstimateMsg"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bus-prefix", default="taiji_")
    ap.add_argument("--count", type=int, default=0, help="stop after N estimates (0: until the final one)")
    ap.add_argument(
        "--timeout",
        type=float,
        default=60.0,
        help="give up after S seconds without a run (waiting for it to start) or without data",
    )
    ap.add_argument("--quiet", action="store_true", help="print only the summary line")
    ap.add_argument(
        "--never-read",
        type=float,
        default=0.0,
        metavar="S",
        help="attach, then never read for S seconds (a stalled client: the set must not notice)",
    )
    args = ap.parse_args()

    iox.set_log_level_from_env_or(iox.LogLevel.Error)
    config = iox.config.default()
    config.global_cfg.prefix = iox.FileName.new(args.bus_prefix)
    name = iox.ServiceName.new(SERVICE)
    # Wait for the run without a node: `does_exist` only reads the service directory,
    # while a node would create the prefix's management object in /dev/shm, which
    # iceoryx2 never removes (the supervisor does, at the end of a run).
    deadline = time.monotonic() + args.timeout
    announced = False
    while not iox.Service.does_exist(name, config, iox.MessagingPattern.PublishSubscribe, iox.ServiceType.Ipc):
        if time.monotonic() > deadline:
            print(
                f"follow_estimates: no run on prefix {args.bus_prefix!r} after {args.timeout:g} s "
                f"({SERVICE} does not exist; start one with tools/launch, or raise --timeout)",
                file=sys.stderr,
            )
            return 1
        if not announced:
            print(f"follow_estimates: waiting for a run on prefix {args.bus_prefix!r}", file=sys.stderr, flush=True)
            announced = True
        time.sleep(0.1)
    node = iox.NodeBuilder.new().config(config).create(iox.ServiceType.Ipc)
    try:
        return follow(args, node, name)
    finally:
        # Ports and service hold the node: release them all before looking for others.
        del node
        gc.collect()
        release_global_mgmt(config, args.bus_prefix)


def release_global_mgmt(config, prefix: str) -> None:
    """Remove the prefix's management object when no node of it is left (the run ended
    while this follower was still attached, so the supervisor had to leave it); the same
    rule as the supervisor's `bus::release`."""
    try:
        if iox.Node.list(iox.ServiceType.Ipc, config):
            return
    except Exception:
        return
    suffix = config.global_cfg.node.global_mgmt_suffix.to_string()
    pattern = re.compile(re.escape(prefix) + r"[0-9a-fA-F]{40}_node\..*" + re.escape(suffix) + "$")
    for entry in os.listdir("/dev/shm"):
        if pattern.match(entry):
            try:
                os.remove(os.path.join("/dev/shm", entry))
            except OSError:
                pass


def follow(args, node, name) -> int:
    """Open the run's estimate service and print what arrives."""
    try:
        service = (
            node.service_builder(name)
            .publish_subscribe(EstimateMsg)
            .max_publishers(MAX_PUBLISHERS)
            .max_subscribers(MAX_SUBSCRIBERS)
            .max_nodes(MAX_NODES)
            .subscriber_max_buffer_size(RECORDER_QUEUE)
            .history_size(0)
            .open()
        )
    except Exception as e:  # the bindings raise their own error types
        why = str(e) or type(e).__name__
        if "IncompatibleTypes" in why or "Incompatible" in type(e).__name__:
            why = (
                f"the run's estimate type is not {EstimateMsg.type_name()} "
                f"(this client speaks message layout version {LAYOUT_VERSION})"
            )
        print(f"follow_estimates: cannot open {SERVICE} on prefix {args.bus_prefix!r}: {why}", file=sys.stderr)
        return 2
    subscriber = service.subscriber_builder().create()
    print(f"follow_estimates: attached to {SERVICE} on prefix {args.bus_prefix!r}", flush=True)
    if args.never_read > 0:
        time.sleep(args.never_read)
        return 0

    received, last = 0, time.monotonic()
    first_tick = last_tick = None
    while True:
        sample = subscriber.receive()
        if sample is None:
            if time.monotonic() - last > args.timeout:
                print(f"follow_estimates: no estimate for {args.timeout} s", file=sys.stderr)
                return 1
            time.sleep(0.001)
            continue
        m = sample.payload().contents
        received += 1
        last = time.monotonic()
        tick = m.header.tick
        first_tick = tick if first_tick is None else first_tick
        last_tick = tick
        if not args.quiet:
            b, bs = m.beta[0], m.beta_sigma[0]
            r, rs = m.r_b[0], m.r_sigma[0]
            print(
                f"tick {tick:7d} status {m.status:#04x} "
                f"beta1 [{b[0]:.6e} {b[1]:.6e} {b[2]:.6e}] ± [{bs[0]:.1e} {bs[1]:.1e} {bs[2]:.1e}] "
                f"r1 [{r[0]:+.6f} {r[1]:+.6f} {r[2]:+.6f}] m ± [{rs[0]:.1e} {rs[1]:.1e} {rs[2]:.1e}]"
            )
        final = m.flags & EST_FINAL
        del sample
        if final or (args.count and received >= args.count):
            break
    print(f"follow_estimates: {received} estimates, ticks {first_tick}..{last_tick}, final={bool(final)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
