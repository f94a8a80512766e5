#!/usr/bin/env python3
"""Offline derivation of the `ctu-2312-9450` preset (Readytosky 2312 920KV, DJI 9450 propeller,
4S pack) from sim/tests/data/ctu_mrs_motor_tests.csv (six throttle steps, 50..100 %), with the
motor on physical values. Plain Python, no packages.

Fixed, physical (see sim/src/presets.rs for the sources):
  K_v 920 rpm/V (the motor's name), R 0.1 ohm and I0 0.5 A (typical for the class, not a
  datasheet), ESC efficiency 0.95 (typical).
Taken from the table (sim::physics steady state: d V_bus = Ke w + R I, Q = Ke I0 + k_Q w^2,
I_bus = d I / eta, T = k_T w^2, V_bus = V_oc - R_b I_bus):
  C_T   least squares of thrust against rho n^2 D^4 (the table's rpm and thrust columns);
  C_P   per row, shaft power Ke w (I - I0) with I solving eta V I_bus = Ke w I + R I^2, over
        rho n^3 D^5; the mean of the rows (the table has no torque column);
  pack  V_oc, R_b: straight line through the table's voltage against its current;
  duty  the duty each row needs, (Ke w + R I(C_P)) / V_bus, then d = d_max u^gamma by least
        squares of ln d on ln u (the table's throttle axis; no part in power at a given thrust).
Run: python3 sim/tools/fit_ctu_preset.py
"""
import math
import os

G, RHO, D = 9.80665, 1.225, 9.4 * 0.0254
KV, R, I0, ETA = 920.0, 0.1, 0.5, 0.95
KE = 60 / (2 * math.pi * KV)

here = os.path.dirname(os.path.abspath(__file__))
path = os.path.join(here, '..', 'tests', 'data', 'ctu_mrs_motor_tests.csv')
lines = open(path).read().splitlines()
rows = [l.split(',') for l in lines[1:] if l.split(',')[1] == 'DJI plastic 9450']
T = [float(r[2]) * G / 1000 for r in rows]
RPM = [float(r[3]) for r in rows]
V = [float(r[4]) for r in rows]
I = [float(r[5]) for r in rows]
P = [float(r[6]) for r in rows]
U = [0.5 + 0.1 * k for k in range(len(rows))]
N = [x / 60 for x in RPM]
W = [x * 2 * math.pi / 60 for x in RPM]

a = [RHO * n * n * D**4 for n in N]
ct = sum(t * ai for t, ai in zip(T, a)) / sum(ai * ai for ai in a)
mi, mv = sum(I) / len(I), sum(V) / len(V)
r_b = -sum((i - mi) * (v - mv) for i, v in zip(I, V)) / sum((i - mi) ** 2 for i in I)
v_oc = mv + r_b * mi
cps = []
for k in range(len(rows)):
    pin = ETA * V[k] * I[k]
    im = (-KE * W[k] + math.sqrt((KE * W[k]) ** 2 + 4 * R * pin)) / (2 * R)
    cps.append(KE * W[k] * (im - I0) / (RHO * N[k] ** 3 * D**5))
cp = sum(cps) / len(cps)
duty = []
for k in range(len(rows)):
    q = cp * RHO * N[k] ** 2 * D**5 / (2 * math.pi)
    duty.append((KE * W[k] + R * (q / KE + I0)) / V[k])
x = [math.log(u) for u in U]
y = [math.log(d) for d in duty]
mx, my = sum(x) / len(x), sum(y) / len(y)
gamma = sum((xi - mx) * (yi - my) for xi, yi in zip(x, y)) / sum((xi - mx) ** 2 for xi in x)
d_max = math.exp(my - gamma * mx)
fm = math.sqrt(2 / math.pi) * ct**1.5 / cp
print(f"C_T {ct:.5f}  C_P {cp:.5f} (rows {min(cps):.4f}..{max(cps):.4f})  figure of merit {fm:.3f}")
print(f"pack V_oc {v_oc:.6f} V, R_b {r_b:.6f} ohm")
print(f"duty needed: {', '.join(f'{d:.3f}' for d in duty)} -> d = {d_max:.4f} u^{gamma:.4f}")
