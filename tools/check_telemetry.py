#!/usr/bin/env python3
"""Open DIR/telemetry.h5 with h5py and check it against DIR/report.json.

Every documented dataset: present, with the documented shape and `units` attribute;
values consistent with the run (the last estimate row equals the report's estimates
bit for bit, the star tracker and IS voltages agree with the truth streams to within
their noise). Exit 0 when every check passes, 1 with the failures listed otherwise.

    python3 tools/check_telemetry.py DIR
"""
import json
import sys
import tomllib

import h5py
import numpy as np

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def main(run_dir):
    report = json.load(open(f"{run_dir}/report.json"))
    with h5py.File(f"{run_dir}/telemetry.h5", "r") as f:
        a = f.attrs
        check(a["format"] == "taiji-telemetry", "format attribute")
        check(int(a["format_version"]) == 1, "format_version attribute")
        check(str(a["software"]).startswith("taiji-calib "), "software attribute")
        scenario = tomllib.loads(a["scenario"])
        check(scenario["name"] == report["scenario"] == a["scenario_name"], "scenario name")
        check(int(a["seed"]) == report["seed"], "seed attribute")
        check(a["method"] == report["method"], "method attribute")
        check(a["mode"] == report["mode"], "mode attribute")
        fs = float(a["sample_rate_hz"])
        n = int(round(report["duration_s"] * fs))
        ni = len(report["inertial_sensors"])
        check(int(a["n_inertial_sensors"]) == ni, "n_inertial_sensors attribute")
        m = f["estimate/time"].shape[0]
        layout = {
            "time": ((n,), "s"), "tick": ((n,), "1"),
            "command/torque": ((n, 3), "N m"), "truth/torque": ((n, 3), "N m"),
            "truth/attitude": ((n, 4), "1"), "truth/angular_velocity": ((n, 3), "rad/s"),
            "truth/angular_acceleration": ((n, 3), "rad/s^2"),
            "truth/tm_acceleration": ((n, ni, 3), "m/s^2"),
            "truth/srp_acceleration": ((n, 3), "m/s^2"),
            "star_tracker/attitude": ((n, 4), "1"), "star_tracker/valid": ((n,), "1"),
            "estimate/time": ((m,), "s"), "estimate/tick": ((m,), "1"),
            "estimate/beta": ((m, ni, 3), "rad s^-2 V^-1"),
            "estimate/beta_sigma": ((m, ni, 3), "rad s^-2 V^-1"),
            "estimate/k": ((m, ni, 3), "m s^-2 V^-1"), "estimate/k_sigma": ((m, ni, 3), "m s^-2 V^-1"),
            "estimate/com_offset": ((m, ni, 3), "m"), "estimate/com_offset_sigma": ((m, ni, 3), "m"),
            "estimate/n_used": ((m,), "1"), "estimate/n_rejected": ((m,), "1"),
            "estimate/final": ((m,), "1"), "estimate/status": ((m,), "1"),
            "estimate/rejected_by_cause": ((m, 11), "1"), "estimate/chi2_per_dof": ((m, 4), "1"),
        }
        if "faults" in f:
            nf = f["faults/tick"].shape[0]
            for k in ("tick", "kind", "field", "bit", "samples", "before", "after", "sigmas", "detected"):
                layout[f"faults/{k}"] = ((nf,), "1")
        for i in range(ni):
            layout[f"is{i + 1}/voltage"] = ((n, 3, 2), "V")
            layout[f"is{i + 1}/flags"] = ((n,), "1")
        for path, (shape, units) in layout.items():
            if path not in f:
                failures.append(f"missing /{path}")
                continue
            d = f[path]
            check(d.shape == shape, f"/{path} shape {d.shape} != {shape}")
            check(d.attrs.get("units") == units, f"/{path} units {d.attrs.get('units')!r} != {units!r}")
            check(len(d.attrs.get("description", "")) > 0, f"/{path} has no description")
        if failures:
            return

        tick = f["tick"][:]
        check(np.array_equal(tick, np.arange(n)), "tick is 0..N-1")
        check(np.array_equal(f["time"][:], (tick + 1) / fs), "time = (tick+1)/fs")

        # The final estimate row is the report's estimate, exactly.
        check(f["estimate/final"][-1] == 1 and f["estimate/final"][:-1].sum() == 0, "final flag")
        keys = {"beta": "beta", "k": "k", "com_offset": "com_offset"}
        for i, isr in enumerate(report["inertial_sensors"]):
            for key, group in keys.items():
                est = f[f"estimate/{group}"][-1, i]
                sig = f[f"estimate/{group}_sigma"][-1, i]
                check(np.array_equal(est, np.array(isr[key]["estimate"])), f"IS{i + 1} {key} estimate")
                check(np.array_equal(sig, np.array(isr[key]["sigma"])), f"IS{i + 1} {key} sigma")
        check(int(f["estimate/n_used"][-1]) == report["samples_used"], "samples_used")
        check(int(f["estimate/n_rejected"][-1]) == report["samples_rejected"], "samples_rejected")
        check(np.all(np.diff(f["estimate/time"][:]) >= 0), "estimate time never decreases")

        # The star tracker sees the true attitude within its noise (0.2" 3-sigma).
        valid = f["star_tracker/valid"][:] == 1
        q_st = f["star_tracker/attitude"][:][valid]
        q_tr = f["truth/attitude"][:][valid]
        dot = np.abs(np.sum(q_st * q_tr, axis=1))
        angle = 2 * np.arccos(np.clip(dot, -1, 1))
        sigma = scenario.get("star_tracker", {}).get("noise_3sigma_arcsec", 0.2) / 3 * np.pi / 648000
        check(valid.sum() > 0, "some valid star-tracker samples")
        check(np.sqrt(np.mean(angle ** 2)) < 3 * np.sqrt(3) * sigma, "star tracker vs truth")

        # Table 1 with the true scale factors recovers the true accelerations.
        wd = f["truth/angular_acceleration"][:]
        a_tm = f["truth/tm_acceleration"][:]
        pair_of_axis = [1, 2, 0]
        for i, isr in enumerate(report["inertial_sensors"]):
            v = f[f"is{i + 1}/voltage"][:]
            ok = f[f"is{i + 1}/flags"][:] == 0
            beta = np.array(isr["beta"]["truth"])
            k = np.array(isr["k"]["truth"])
            for ax in range(3):
                p = pair_of_axis[ax]
                meas = beta[ax] * (v[ok, p, 0] - v[ok, p, 1])
                res = meas - wd[ok, ax]
                check(np.std(res) < 1e-3 * np.std(wd[:, ax]) + 1e-12, f"IS{i + 1} angular axis {ax}")
                meas = k[ax] * (v[ok, ax, 0] + v[ok, ax, 1])
                res = meas - a_tm[ok, i, ax]
                check(np.std(res) < 1e-12, f"IS{i + 1} linear axis {ax}")
        amp = np.max(np.abs(f["command/torque"][:]), axis=0)
        check(np.all(amp > 0), "every axis is commanded")
        err = f["truth/torque"][:] - f["command/torque"][:]
        check(np.median(np.abs(err)) < 0.1 * amp.max(), "applied torque follows the command")


if __name__ == "__main__":
    main(sys.argv[1])
    if failures:
        print("telemetry check FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("telemetry check passed")
