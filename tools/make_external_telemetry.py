#!/usr/bin/env python3
"""Write a telemetry file in the documented layout from independently generated samples.

This is what another tool (a MATLAB or Python simulation) would write: numpy physics
written from the paper's equations, not our Rust plant. Rigid-body rotation under
square-wave torques, one axis after the other; test-mass accelerations
a_i = w' x r_i + w x (w x r_i) + SRP; drive voltages by inverting Table 1
(w'_x = b_x (V_y1 - V_y2), w'_y = b_y (V_z1 - V_z2), w'_z = b_z (V_x1 - V_x2),
a_j = k_j (V_j1 + V_j2), k = (G_z b_z, G_x b_x, G_y b_y)); star tracker with 0.2" (3 sigma).

    python3 tools/make_external_telemetry.py OUT.h5 [--no-scenario] [--seed N]
        [--duration S] [--break shape|missing|tick|scenario]

With a `scenario` attribute the truths below are declared there (so `taiji-calib
replay` can report errors); with --no-scenario the file carries only the sample rate
and the replay assumes the default scenario (whose truths these defaults match).
"""
import argparse
import numpy as np
import h5py

ARCSEC = np.pi / (180 * 3600)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--no-scenario", action="store_true")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--duration", type=float, default=10000.0)
    ap.add_argument("--break", dest="broken", choices=["shape", "missing", "tick", "scenario", "time", "version"],
                    help="write a deliberately bad file (for the replay's error tests)")
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)

    fs, T = 10.0, a.duration
    n = int(round(T * fs))
    dt = 1.0 / fs
    inertia = np.array([[1000.0, 5.0, -3.0], [5.0, 1100.0, 4.0], [-3.0, 4.0, 900.0]])
    inv_inertia = np.linalg.inv(inertia)
    geometry = np.array([0.02044452, 0.02044452, 0.03066663])
    if a.no_scenario:
        # The default scenario's truths.
        beta = np.array([[5.52143e-8, 5.52143e-8, 7.36191e-8]] * 2)
        r = np.array([[0.2164, -0.1251, 0.0002], [0.2164, 0.1251, 0.0002]])
    else:
        beta = np.array([[5.60e-8, 5.45e-8, 7.30e-8], [5.50e-8, 5.58e-8, 7.41e-8]])
        r = np.array([[0.1500, -0.0800, 0.0300], [0.1450, 0.0900, -0.0250]])
    k = np.stack([geometry[2] * beta[:, 2], geometry[0] * beta[:, 0], geometry[1] * beta[:, 1]], axis=1)

    # Square-wave torque, 1 mHz, 2.5 uN m, axes x, y, z in thirds of the campaign.
    f_man, amp = 1e-3, 2.5e-6
    t_start = np.arange(n) * dt
    third = T / 3
    torque = np.zeros((n, 3))
    for ax in range(3):
        on = (t_start >= ax * third) & (t_start < (ax + 1) * third)
        phase = (t_start - ax * third) * f_man
        torque[on, ax] = amp * np.where(np.cos(2 * np.pi * phase[on]) >= 0, 1.0, -1.0)

    # Rigid body: Euler's equations and quaternion kinematics (w, x, y, z of B relative
    # to N), classic RK4 per sample in plain floats (the torque is constant over it).
    I = inertia.tolist()
    J = inv_inertia.tolist()

    def deriv(st, tau):
        qw, qx, qy, qz, wx, wy, wz = st
        hx = I[0][0] * wx + I[0][1] * wy + I[0][2] * wz
        hy = I[1][0] * wx + I[1][1] * wy + I[1][2] * wz
        hz = I[2][0] * wx + I[2][1] * wy + I[2][2] * wz
        mx = tau[0] - (wy * hz - wz * hy)
        my = tau[1] - (wz * hx - wx * hz)
        mz = tau[2] - (wx * hy - wy * hx)
        return (
            0.5 * (-qx * wx - qy * wy - qz * wz),
            0.5 * (qw * wx + qy * wz - qz * wy),
            0.5 * (qw * wy - qx * wz + qz * wx),
            0.5 * (qw * wz + qx * wy - qy * wx),
            J[0][0] * mx + J[0][1] * my + J[0][2] * mz,
            J[1][0] * mx + J[1][1] * my + J[1][2] * mz,
            J[2][0] * mx + J[2][1] * my + J[2][2] * mz,
        )

    states = np.zeros((n + 1, 7))
    st = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    states[0] = st
    tl = torque.tolist()
    for i in range(n):
        tau = tl[i]
        k1 = deriv(st, tau)
        k2 = deriv(tuple(a + 0.5 * dt * b for a, b in zip(st, k1)), tau)
        k3 = deriv(tuple(a + 0.5 * dt * b for a, b in zip(st, k2)), tau)
        k4 = deriv(tuple(a + dt * b for a, b in zip(st, k3)), tau)
        st = tuple(a + dt / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(st, k1, k2, k3, k4))
        nq = (st[0] ** 2 + st[1] ** 2 + st[2] ** 2 + st[3] ** 2) ** 0.5
        st = (st[0] / nq, st[1] / nq, st[2] / nq, st[3] / nq) + st[4:]
        states[i + 1] = st
    quat = states[1:, :4]
    w_end = states[1:, 4:]
    w_start = states[:-1, 4:]
    wdot_mean = (w_end - w_start) / dt
    w_mid = 0.5 * (w_start + w_end)
    coupling = np.stack([
        np.cross(wdot_mean, r[j]) + np.cross(w_mid, np.cross(w_mid, r[j])) for j in range(2)
    ], axis=1)
    sun_n = np.array([0.5, 0.0, 0.866])
    sun_n /= np.linalg.norm(sun_n)
    qv = -quat[:, 1:]  # conjugate: N -> B
    tt = 2 * np.cross(qv, sun_n)
    sun_b = sun_n + quat[:, :1] * tt + np.cross(qv, tt)

    # SRP: DC 3e-8 m/s^2 along the sun, with a white fluctuation of 1.1e-11 /rtHz.
    srp_white = 1.1e-11 * np.sqrt(fs / 2) * rng.standard_normal(n)
    srp = sun_b * (3e-8 + srp_white)[:, None]
    a_tm = coupling + srp[:, None, :]

    sig_ang = 1e-14 * np.sqrt(fs / 2)
    sig_lin = 3e-15 * np.sqrt(fs / 2)
    sig_rip = 8e-6 * np.sqrt(fs / 2)
    pair_axis = [2, 0, 1]  # electrode pair x carries w'_z, y carries w'_x, z carries w'_y
    volts = np.zeros((2, n, 3, 2))
    for j in range(2):
        for p in range(3):
            ax = pair_axis[p]
            wd = wdot_mean[:, ax] + sig_ang * rng.standard_normal(n)
            lin = a_tm[:, j, p] + sig_lin * rng.standard_normal(n)
            diff = wd / beta[j, ax] * (1 + sig_rip * rng.standard_normal(n))
            s = lin / k[j, p] * (1 + sig_rip * rng.standard_normal(n))
            volts[j, :, p, 0] = 0.5 * (s + diff)
            volts[j, :, p, 1] = 0.5 * (s - diff)

    # Star tracker: true attitude times a small rotation of 0.2"/3 per axis.
    sig_st = 0.2 / 3 * ARCSEC
    e = sig_st * rng.standard_normal((n, 3))
    half = 0.5 * np.linalg.norm(e, axis=1)
    dq = np.concatenate([np.cos(half)[:, None], (np.sinc(half / np.pi) * 0.5)[:, None] * e], axis=1)
    qw, qx, qy, qz = quat.T
    dw, dx, dy, dz = dq.T
    star = np.stack([
        qw * dw - qx * dx - qy * dy - qz * dz,
        qw * dx + qx * dw + qy * dz - qz * dy,
        qw * dy - qx * dz + qy * dw + qz * dx,
        qw * dz + qx * dy - qy * dx + qz * dw,
    ], axis=1)

    with h5py.File(a.out, "w") as f:
        f.attrs["sample_rate_hz"] = fs
        if not a.no_scenario:
            lines = [
                'name = "external"', "seed = 3", f"duration_s = {T!r}", f"sample_rate_hz = {fs!r}",
                "[maneuver]", "axis_order = \"xyz\"",
                "[srp]", "asd_at_3mhz = 1.1e-11",
            ]
            for j in range(2):
                lines += [
                    "[[inertial_sensor]]",
                    f"com_offset_m = [{', '.join(repr(float(x)) for x in r[j])}]",
                    f"beta = [{', '.join(repr(float(x)) for x in beta[j])}]",
                    f"geometry_m = [{', '.join(repr(float(x)) for x in geometry)}]",
                ]
            f.attrs["scenario"] = "\n".join(lines) + "\n"
        t = (np.arange(n) + 1) * dt
        def put(path, data, units):
            d = f.create_dataset(path, data=data)
            d.attrs["units"] = units
        if a.broken == "time":
            t = t.copy()
            t[n // 3] = t[n // 3 - 2]
        put("time", t, "s")
        if a.broken == "version":
            f.attrs["format"] = "taiji-telemetry"
            f.attrs["format_version"] = 99
        if a.broken == "tick":
            tick = np.arange(n)
            tick[n // 2] = tick[n // 2 - 1]
            put("tick", tick, "1")
        if a.broken == "scenario":
            f.attrs["scenario"] = "duration_s = -5.0\n"
        if a.broken != "missing":
            put("star_tracker/attitude", star, "1")
        put("star_tracker/valid", np.ones(n, dtype=np.uint8), "1")
        for j in range(2):
            v = volts[j].reshape(n, 6) if a.broken == "shape" and j == 1 else volts[j]
            put(f"is{j + 1}/voltage", v, "V")
            put(f"is{j + 1}/flags", np.zeros(n, dtype=np.uint8), "1")
    print(f"wrote {a.out}: {n} samples")
    print("truth beta", beta.tolist())
    print("truth r", r.tolist())


if __name__ == "__main__":
    main()
