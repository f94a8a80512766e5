#!/usr/bin/env python3
"""Offline derivation of the `ctu-2312-9450` preset (Readytosky 2312 920KV, DJI 9450 prop,
4S pack) from sim/tests/data/ctu_mrs_motor_tests.csv (six throttle steps, 50..100 %).

Model (steady state of sim::physics): throttle fraction u -> duty d = u (linear ESC),
V_m = d V_bus = Ke w + R I, Q(w) = Kt I0 + k_Q w^2 (+ the same optional terms as the paper
preset, unused here), thrust T = k_T w^2, battery V_bus = V_oc - R_b I_bus, I_bus = d I.
k_T is fitted to the (rpm, thrust) pairs; V_oc, R_b to the (current, voltage) pairs; Kv, R,
I0 and k_Q by least squares on relative thrust, current and power errors.
Run: python3 sim/tools/fit_ctu_preset.py
"""
import csv, os
import numpy as np
from scipy.optimize import least_squares

G = 9.80665
here = os.path.dirname(os.path.abspath(__file__))
rows = [r for r in csv.DictReader(open(os.path.join(here, '..', 'tests', 'data', 'ctu_mrs_motor_tests.csv')))
        if r['propeller'] == 'DJI plastic 9450']
T = np.array([float(r['thrust_g']) for r in rows])
RPM = np.array([float(r['rpm']) for r in rows])
V = np.array([float(r['voltage_v']) for r in rows])
I = np.array([float(r['current_a']) for r in rows])
P = np.array([float(r['power_w']) for r in rows])
U = np.linspace(0.5, 1.0, len(rows))
W = RPM * 2 * np.pi / 60
k_t = np.sum(T / 1000 * G * W**2) / np.sum(W**4)
A = np.vstack([np.ones_like(I), -I]).T
v_oc, r_b = np.linalg.lstsq(A, V, rcond=None)[0]

def solve(p, u):
    kv, r, i0, kq = p
    ke = 60 / (2 * np.pi * kv)
    out = []
    for d in np.atleast_1d(u):
        lo, hi = 0.0, 5000.0
        for _ in range(100):
            w = 0.5 * (lo + hi)
            i = (ke * i0 + kq * w**2) / ke
            ib = d * i
            vb = v_oc - r_b * ib
            if d * vb - ke * w - r * i > 0: lo = w
            else: hi = w
        out.append((w, i, ib, vb))
    return np.array(out)

def res(p):
    s = solve(p, U)
    w, ib, vb = s[:, 0], s[:, 2], s[:, 3]
    th = k_t * w**2 / G * 1000
    return np.concatenate([(th - T) / T, (ib - I) / I, (ib * vb - P) / P])

sol = least_squares(res, [920.0, 0.1, 0.5, 1.5e-7], x_scale=[100, 0.05, 0.2, 1e-7],
                    bounds=([500, 0.0, 0.0, 1e-9], [1500, 2.0, 5.0, 1e-5]))
kv, r, i0, kq = sol.x
print("k_t=%r v_oc=%r r_b=%r" % (float(k_t), float(v_oc), float(r_b)))
print("kv_rpm_per_v=%r r_ohm=%r i0_a=%r k_q=%r" % tuple(float(x) for x in sol.x))
s = solve(sol.x, U)
for j, u in enumerate(U):
    w, i, ib, vb = s[j]
    th = k_t * w**2 / G * 1000
    print(f"u={u:.1f} thrust {th:7.1f} ({T[j]:5.0f}, {100*(th/T[j]-1):+5.2f}%)  I {ib:6.2f} ({I[j]:5.2f}, {100*(ib/I[j]-1):+5.2f}%)"
          f"  P {ib*vb:7.2f} ({P[j]:6.2f}, {100*(ib*vb/P[j]-1):+5.2f}%)  rpm {w*60/2/np.pi:6.0f} ({RPM[j]:5.0f})  V {vb:5.2f} ({V[j]:5.2f})")
