#!/usr/bin/env python3
"""Rewrite a taiji-calib recording as the small, uncompressed, contiguous file another
tool would write (h5py's defaults: superblock 0, no metadata checksums, so a mutation
reaches the reader's parsing instead of failing a checksum), for the telemetry fuzz
target's seeds (fuzz/seeds/telemetry/):

    python3 fuzz/seeds/telemetry_seeds.py IN.h5 OUT.h5 [--huge GROUP N]

Copies every dataset and the root attributes (the scenario's TOML among them).
--huge faults N (or estimate N) declares that group's datasets N rows long without
writing any (chunked, nothing allocated: reading them gives fill values).

The seeds were made from `taiji-calib run --record --record-compression 9` of 10 s
scenarios at 10 Hz with a written maneuver (frequency_hz = 0.1, schedule =
"simultaneous", torque_amplitude_nm = 1e-6 on each axis; one with [faults]), which are
also seeds themselves (calib_*.h5).
"""
import argparse
import h5py


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--huge", nargs=2, metavar=("GROUP", "N"))
    a = ap.parse_args()
    with h5py.File(a.inp, "r") as src, h5py.File(a.out, "w") as dst:
        for k, v in src.attrs.items():
            dst.attrs[k] = v

        def copy(name, obj):
            if isinstance(obj, h5py.Dataset):
                if a.huge and name.startswith(a.huge[0] + "/"):
                    n = int(a.huge[1])
                    dst.create_dataset(name, shape=(n,) + obj.shape[1:],
                                       maxshape=(None,) + obj.shape[1:],
                                       chunks=(1024,) + obj.shape[1:], dtype=obj.dtype)
                else:
                    dst.create_dataset(name, data=obj[...])
        src.visititems(copy)


if __name__ == "__main__":
    main()
