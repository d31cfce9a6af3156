#!/usr/bin/env python3
"""Corrupt a recording after the fact, as orbit (or a bad disk) would, with h5py only.

    tools/corrupt_telemetry.py IN.h5 OUT.h5 [--seed N] [--flips N] [--star-flips N]
                               [--outlier-volts V] [--stuck-s S]

Copies IN to OUT, then in OUT:
  * flips one random bit of --flips random values of /is1/voltage and /is2/voltage,
  * flips one random bit of --star-flips random components of /star_tracker/attitude
    (valid samples only),
  * sets one random IS voltage to --outlier-volts,
  * holds one random IS voltage channel at its value for --stuck-s seconds,
and prints what it did as JSON (one object per line) on stdout. `taiji-calib replay`
must reject what matters and still meet the requirements with honest σ.
"""
import argparse
import json
import shutil

import h5py
import numpy as np


def flip(value, bit):
    b = np.array([value], dtype="<f8").view("<u8")
    b ^= np.uint64(1) << np.uint64(bit)
    return float(b.view("<f8")[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--flips", type=int, default=10)
    ap.add_argument("--star-flips", type=int, default=5)
    ap.add_argument("--outlier-volts", type=float, default=1e6)
    ap.add_argument("--stuck-s", type=float, default=300.0)
    a = ap.parse_args()
    shutil.copyfile(a.src, a.dst)
    rng = np.random.default_rng(a.seed)
    with h5py.File(a.dst, "r+") as f:
        n = f["time"].shape[0]
        fs = float(f.attrs.get("sample_rate_hz", 1.0 / (f["time"][1] - f["time"][0])))
        first = int(10 * fs)  # leave the first 10 s as a reference
        ises = [k for k in ("is1/voltage", "is2/voltage") if k in f]
        for _ in range(a.flips):
            ds = f[ises[rng.integers(len(ises))]]
            t, j, c = int(rng.integers(first, n)), int(rng.integers(3)), int(rng.integers(2))
            bit = int(rng.integers(64))
            before = float(ds[t, j, c])
            ds[t, j, c] = flip(before, bit)
            print(json.dumps({"kind": "upset", "dataset": ds.name, "row": t, "index": [j, c],
                              "bit": bit, "before": before, "after": float(ds[t, j, c])}))
        valid = np.flatnonzero(f["star_tracker/valid"][:] != 0)
        valid = valid[valid >= first]
        q = f["star_tracker/attitude"]
        for _ in range(a.star_flips):
            t, k, bit = int(rng.choice(valid)), int(rng.integers(4)), int(rng.integers(64))
            before = float(q[t, k])
            q[t, k] = flip(before, bit)
            print(json.dumps({"kind": "star_upset", "row": t, "component": k, "bit": bit,
                              "before": before, "after": float(q[t, k])}))
        ds = f[ises[rng.integers(len(ises))]]
        t, j, c = int(rng.integers(first, n)), int(rng.integers(3)), int(rng.integers(2))
        ds[t, j, c] = a.outlier_volts
        print(json.dumps({"kind": "outlier", "dataset": ds.name, "row": t, "index": [j, c],
                          "value": a.outlier_volts}))
        ds = f[ises[rng.integers(len(ises))]]
        m = int(a.stuck_s * fs)
        t, j, c = int(rng.integers(first, max(first + 1, n - m))), int(rng.integers(3)), int(rng.integers(2))
        block = ds[t:t + m, j, c]
        ds[t:t + m, j, c] = np.full_like(block, block[0])
        print(json.dumps({"kind": "stuck", "dataset": ds.name, "rows": [t, t + m], "index": [j, c]}))


if __name__ == "__main__":
    main()
