#!/usr/bin/env python3
"""The outside ground tool's side of tests/ground_packets.rs: the Python `spacepackets`
package builds authenticated telecommands and parses the set's telemetry, CRC checked.

    ground_packets.py check
        exits 0 when spacepackets can be imported.
    ground_packets.py tc KEYHEX SEQ COUNT SERVICE SUBTYPE SOURCE APPHEX
        prints a PUS-C telecommand of APID 0x120 (hex) whose application data are APPHEX,
        then the authentication trailer: SEQ (u32) and HMAC-SHA-256 under the key,
        truncated to 16 bytes, over the packet from its first byte through SEQ.
    ground_packets.py tm HEX [HEX...]
        parses each telemetry packet (CDS short time, 7 bytes) and prints one JSON line
        per packet: its fields, or {"error": ...} when spacepackets refuses it (the tests
        give it verification, housekeeping, event and parameter reports).
    ground_packets.py xtce FILE HEX [HEX...]
        validates the XTCE dictionary FILE against the XTCE schema that space-packet-parser
        ships (no download), decodes each telemetry packet with it alone (housekeeping
        structures 1 and 2, events, a report of one parameter...), and prints one JSON line
        per packet: every parameter's value (a float as the hex of its binary64 bits).
"""
import hashlib
import hmac
import json
import sys
import warnings

warnings.simplefilter("ignore", DeprecationWarning)

APID = 0x120
TRAILER = 20
MAC = 16
CRC = 2


def signed_tc(key, seq, count, service, subtype, source, app, ack_flags=0xF):
    """The bytes of a PUS-C telecommand of APID 0x120 built by spacepackets: `app`, then
    the authentication trailer (`seq` as u32, the truncated HMAC-SHA-256 under `key`).
    The packet is built with the MAC zeroed, the MAC computed over its bytes before the
    MAC field, and the packet built again with it, so the CRC covers the final bytes."""
    from spacepackets.ecss.tc import PusTc

    app = bytes(app) + int(seq).to_bytes(4, "big")

    def build(mac):
        return PusTc(
            service=int(service),
            message_subtype=int(subtype),
            apid=APID,
            seq_count=int(count),
            source_id=int(source),
            ack_flags=int(ack_flags),
            app_data=app + mac,
        ).pack()

    draft = build(bytes(MAC))
    mac = hmac.new(bytes(key), draft[: -(MAC + CRC)], hashlib.sha256).digest()[:MAC]
    packet = build(mac)
    assert packet[: -(MAC + CRC)] == draft[: -(MAC + CRC)]
    return bytes(packet)


def tc(key_hex, seq, count, service, subtype, source, app_hex):
    key = bytes.fromhex(key_hex)
    print(signed_tc(key, seq, count, service, subtype, source, bytes.fromhex(app_hex)).hex())


def tm(packets):
    from spacepackets.ecss.tm import PusTm

    for h in packets:
        try:
            p = PusTm.unpack(bytes.fromhex(h), timestamp_len=7)
        except Exception as e:  # the refusal is the answer: printed for the test to read
            print(json.dumps({"error": f"{type(e).__name__}: {e}"}))
            continue
        s = p.pus_tm_sec_header
        t = bytes(p.timestamp)
        print(
            json.dumps(
                {
                    "version": p.ccsds_version,
                    "apid": p.apid,
                    "seq_flags": int(p.seq_flags),
                    "seq_count": p.seq_count,
                    "pus_version": int(s.pus_version),
                    "time_ref": s.spacecraft_time_ref,
                    "service": p.service,
                    "subtype": p.message_subtype,
                    "message_counter": s.message_counter,
                    "destination_id": s.dest_id,
                    "time_p_field": t[0],
                    "day": int.from_bytes(t[1:3], "big"),
                    "ms_of_day": int.from_bytes(t[3:7], "big"),
                    "source_data": bytes(p.source_data).hex(),
                }
            )
        )


def xtce(path, packets):
    import struct

    from pathlib import Path

    import space_packet_parser

    xsd = Path(space_packet_parser.__file__).parent / "xtce" / "schemas" / "SpaceSystem.xsd"
    result = space_packet_parser.validate_xtce(
        path, level="all", local_xsd=xsd, allow_schema_download=False, print_results=False, raise_on_error=False
    )
    if not result:
        sys.exit(f"{path} is not valid XTCE: {[str(e) for e in result.errors]}")
    definition = space_packet_parser.load_xtce(path)
    for h in packets:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a packet longer than its container fails
            p = definition.parse_bytes(bytes.fromhex(h))
        values = {}
        for name, v in p.items():
            values[name] = struct.pack(">d", v).hex() if isinstance(v, float) else int(v)
        print(json.dumps(values))


def main(argv):
    if argv[:1] == ["check"]:
        import space_packet_parser  # noqa: F401
        import spacepackets  # noqa: F401
    elif argv[:1] == ["xtce"] and len(argv) >= 2:
        xtce(argv[1], argv[2:])
    elif argv[:1] == ["tc"] and len(argv) == 8:
        tc(*argv[1:])
    elif argv[:1] == ["tm"]:
        tm(argv[1:])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
