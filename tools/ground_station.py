#!/usr/bin/env python3
"""An outside ground station for the set, built only on PyPI's `spacepackets` and
`space-packet-parser` and the standard library: one cycle over the UDP link.

    ground_station.py --to ADDR --key FILE --xtce FILE --report-dir DIR [--seed N]

ping (17,1: 17,2 and 1,7), start campaign with the seed (8,1 function 1), wait for its end
(event 4 requirement_met or 5 requirement_missed), one structure-1 housekeeping report
now (3,27) decoded with space-packet-parser from the XTCE dictionary alone (`taiji-calib
ground dictionary --format xtce`) and compared bit for bit with DIR/campaign-N/report.json
(β, k, r and their σ of both IS), apply the result (function 3), shut the set down
(function 5). Every telecommand is a PUS-C packet built by spacepackets with the
authentication trailer (tools/ground_packets.py's signed_tc); every telemetry packet is
parsed by spacepackets, its CRC checked. Sequence numbers come from KEY.seq beside the key,
as `taiji-calib ground` takes them (locked, so both can be used on one key).

Exit 0 when the cycle completed and every value matched; 1 with a message on a failure
report, a mismatch, a bad packet or a timeout; 2 on bad arguments.
"""
import argparse
import fcntl
import json
import os
import socket
import struct
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ground_packets import APID, signed_tc  # noqa: E402

warnings.simplefilter("ignore", DeprecationWarning)

SOURCE_ID = 0x51  # this station's PUS source ID
CDS_SHORT = 7  # the TM time field's length
EV_REQUIREMENT_MET, EV_REQUIREMENT_MISSED, EV_TABLE_APPLIED = 4, 5, 6
# (name in the XTCE, report.json's group and field) for each compared value.
COMPARED = [
    ("beta", "beta", "estimate"),
    ("beta_sigma", "beta", "sigma"),
    ("k", "k", "estimate"),
    ("k_sigma", "k", "sigma"),
    ("r", "com_offset", "estimate"),
    ("r_sigma", "com_offset", "sigma"),
]


class Failed(Exception):
    """The cycle failed: the message says why."""


class TimedOut(Failed):
    """Nothing, or not what was awaited, came in time."""


def take_seq(key_path):
    """The next anti-replay number from KEY.seq (src/ground/seq.rs's format: the last
    number used, 10 digits; a new file starts at the current Unix time), under flock."""
    path = str(key_path) + ".seq"
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        text = os.read(fd, 64).decode("ascii", "replace").strip()
        if text and not text.isdigit():
            raise Failed(f"sequence counter {path} holds {text!r}, not a number")
        seq = int(text) + 1 if text else int(time.time())
        if seq > 0xFFFFFFFF:
            raise Failed(f"sequence counter {path} is exhausted: a new key is needed")
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{seq:010}\n".encode())
        os.fsync(fd)
        return seq
    finally:
        os.close(fd)  # releases the lock


class Tm:
    """One telemetry packet, parsed by spacepackets (CRC checked)."""

    def __init__(self, raw):
        from spacepackets.ecss.tm import PusTm

        try:
            p = PusTm.unpack(raw, timestamp_len=CDS_SHORT)
        except Exception as e:
            raise Failed(f"spacepackets refused a telemetry packet ({type(e).__name__}: {e}): {raw.hex()}")
        if p.apid != APID:
            raise Failed(f"telemetry of APID {p.apid:#x}, not {APID:#x}: {raw.hex()}")
        self.raw = raw
        self.service = p.service
        self.subtype = p.message_subtype
        self.data = bytes(p.source_data)

    def u16(self, at=0):
        return int.from_bytes(self.data[at : at + 2], "big") if len(self.data) >= at + 2 else None

    def is_event(self, *ids):
        return self.service == 5 and self.u16() in ids

    def __repr__(self):
        return f"{self.service},{self.subtype}" + (f"[{self.u16()}]" if self.u16() is not None else "")


class Station:
    def __init__(self, to, key_path):
        host, port = to.rsplit(":", 1)
        self.to = (host, int(port))
        self.key_path = key_path
        text = Path(key_path).read_text().strip()
        if len(text) != 64:
            raise Failed(f"{key_path}: not a key of 64 hexadecimal characters")
        self.key = bytes.fromhex(text)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.count = 0
        self.heard = []  # every Tm so far

    def send(self, service, subtype, app=b""):
        """Sends a telecommand (all acknowledgements asked); its request ID (4 bytes)."""
        self.count = (self.count + 1) % 0x4000
        tc = signed_tc(self.key, take_seq(self.key_path), self.count, service, subtype, SOURCE_ID, app)
        self.sock.sendto(tc, self.to)
        return tc[:4]

    def listen(self, what, timeout, until):
        """Takes in telemetry until `until(heard)` gives a value (not None), which it returns."""
        t0 = time.monotonic()
        while True:
            got = until(self.heard)
            if got is not None:
                return got
            if time.monotonic() - t0 > timeout:
                raise TimedOut(f"no {what} within {timeout} s; heard (service,subtype[first u16]) {self.heard[-30:]}")
            try:
                raw, _ = self.sock.recvfrom(65536)
            except socket.timeout:
                continue
            except ConnectionRefusedError:  # an ICMP port unreachable: nothing listens yet
                continue
            self.heard.append(Tm(raw))

    def completion(self, rid, mark, what):
        """Finds the index of the request's completion report (1,7) after `mark`; fails on
        its failure report (1,2, 1,4, 1,8)."""

        def find(heard):
            for i in range(mark, len(heard)):
                t = heard[i]
                if t.service == 1 and t.data[:4] == rid:
                    if t.subtype in (2, 4, 8):
                        code = t.u16(4)
                        raise Failed(f"{what}: the set answered 1,{t.subtype}, failure code {code} (see failure_codes)")
                    if t.subtype == 7:
                        return i
            return None

        return find

    def command(self, what, service, subtype, app=b"", timeout=10.0):
        """Sends and waits for the completion report; the indices in `heard` of the first
        packet after sending and of the completion report."""
        mark = len(self.heard)
        rid = self.send(service, subtype, app)
        return mark, self.listen(f"completion of {what}", timeout, self.completion(rid, mark, what))


def ping_until_up(st, timeout):
    """17,1 every 0.5 s until one is answered with 17,2 and 1,7 (the set may still be starting)."""
    t0 = time.monotonic()
    while True:
        mark = len(st.heard)
        rid = st.send(17, 1)
        try:
            st.listen("ping", 0.5, st.completion(rid, mark, "ping"))
        except TimedOut:
            if time.monotonic() - t0 > timeout:
                raise Failed(f"the set at {st.to[0]}:{st.to[1]} answered no ping within {timeout} s")
            continue
        if not any((t.service, t.subtype) == (17, 2) for t in st.heard[mark:]):
            raise Failed("a ping completed without its 17,2 reply")
        return


def bits(x):
    return struct.pack(">d", x).hex()


def compare(decoded, report):
    """Each compared value in the decoded report equals report.json's, bit for bit; their count."""
    n = 0
    bad = []
    for i, sensor in enumerate(report["inertial_sensors"]):
        for a, axis in enumerate("xyz"):
            for name, group, field in COMPARED:
                key = f"{name}_is{i + 1}_{axis}"
                if key not in decoded:
                    raise Failed(f"the decoded report has no {key}")
                got, want = float(decoded[key]), float(sensor[group][field][a])
                if bits(got) != bits(want):
                    bad.append(f"{key}: telemetry {got!r} ({bits(got)}) != report.json {want!r} ({bits(want)})")
                n += 1
    if bad:
        raise Failed("the housekeeping estimate differs from report.json:\n  " + "\n  ".join(bad))
    return n


def cycle(args):
    import space_packet_parser

    definition = space_packet_parser.load_xtce(args.xtce)
    st = Station(args.to, args.key)
    t0 = time.monotonic()

    ping_until_up(st, args.up_timeout)
    print(f"ping: 17,2 and 1,7 from {args.to}")

    start = struct.pack(">HQd", 1, args.seed, 0.0)
    mark, _ = st.command(f"start (seed {args.seed})", 8, 1, start, timeout=120.0)
    print(f"start: campaign running, seed {args.seed}")
    end = st.listen(
        "end-of-campaign event (4 or 5)",
        args.campaign_timeout,
        lambda h: next((t for t in h[mark:] if t.is_event(EV_REQUIREMENT_MET, EV_REQUIREMENT_MISSED)), None),
    )
    campaign = int.from_bytes(end.data[2:6], "big")
    met = end.u16() == EV_REQUIREMENT_MET
    print(f"event {end.u16()}: campaign {campaign} {'met' if met else 'missed'} its requirement")

    mark, done = st.command("housekeeping now (3,27)", 3, 27, struct.pack(">BH", 1, 1))
    hk = [t for t in st.heard[mark:done] if (t.service, t.subtype) == (3, 25) and t.u16() == 1]
    if not hk:
        raise Failed("3,27 completed without a structure-1 3,25 report")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a packet longer than its container fails
        decoded = definition.parse_bytes(hk[-1].raw)
    if decoded.get("HK_STRUCTURE_ID") != 1:
        raise Failed(f"space-packet-parser read structure {decoded.get('HK_STRUCTURE_ID')}, not 1")
    path = Path(args.report_dir) / f"campaign-{campaign}" / "report.json"
    report = json.loads(path.read_text())
    n = compare(decoded, report)
    print(f"housekeeping: {n} values decoded from the XTCE equal {path} bit for bit")

    mark, _ = st.command("apply (function 3)", 8, 1, struct.pack(">H", 3))
    applied = [t for t in st.heard[mark:] if t.is_event(EV_TABLE_APPLIED)]
    print(f"apply: 1,7{', event table_applied' if applied else ''}")
    st.command("shutdown (function 5)", 8, 1, struct.pack(">H", 5))
    print("shutdown: 1,7")
    print(f"ok: {len(st.heard)} telemetry packets parsed, CRC checked, in {time.monotonic() - t0:.1f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--to", required=True, help="the set's ground address, HOST:PORT")
    ap.add_argument("--key", required=True, help="the telecommand key file (64 hex characters)")
    ap.add_argument("--xtce", required=True, help="the XTCE dictionary (taiji-calib ground dictionary --format xtce)")
    ap.add_argument("--report-dir", required=True, help="the set's --out folder, holding campaign-N/report.json")
    ap.add_argument("--seed", type=int, default=1, help="the campaign's seed (1)")
    ap.add_argument("--up-timeout", type=float, default=60.0, help="seconds to wait for a first answer (60)")
    ap.add_argument("--campaign-timeout", type=float, default=600.0, help="seconds to wait for its end (600)")
    args = ap.parse_args()
    if not 0 <= args.seed < 2**64:
        ap.error("--seed must fit in a u64")
    try:
        cycle(args)
    except (Failed, OSError, KeyError, ValueError) as e:
        print(f"ground_station: FAILED: {type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
