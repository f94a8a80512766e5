#!/usr/bin/env python3
"""Offline derivation of the `paper` preset's constants (sim/src/presets.rs). numpy + scipy.

Model: the steady state of sim::physics (all SI):
  thrust     T = k_T w^2                       k_T fixed: 260 g at 1000 rad/s
  torque     Q = Kt I0 + b_v w + k_Q w^2 + k_s (w / 1000)^n_s
             (bearing friction, iron/eddy drag, propeller, high-tip-speed drag rise)
  motor      V_m = d V_bus = Ke w + R I,  Kt = Ke,  I = Q / Kt
  supply     V_bus = V_set - R_src I_bus, I_bus = d I   (R_src = 0.01 ohm leads)
  power      P_bus = V_bus I_bus = V_m I = Q w + R I^2

Step 1 (limits -> Ke, R). At full duty V_m = V_bus, and P_bus is independent of V_set, so the
two published limits (150 g at 9.0 V; ~260 g at 12.6 V, taken as 263 g so that 260 g stays
reachable at 12.5 V) with P_bus from the target curve give two linear equations in Ke and R.

Step 2 (curve -> torque terms). With Ke and R fixed, fit b_v, I0, k_s, n_s to the target
P(T) = 0.157434234 T + 0.341190317 (T/100)^5.34865728 W over 10..260 g, minimising the worst
relative error (least squares, then an L12 refinement). k_Q is pinned at 0.1 x the
momentum-theory ideal k_T^1.5 / sqrt(2 rho A) for a 200 mm disk: the target is linear in T at
low thrust, which a propeller with a realistic figure of merit (P ~ T^1.5) cannot follow --
with k_Q at the ideal value the worst error is ~3 %, with 0.1 x it is 0.30 %. (That ~3 % keeps
the fitted iron-drag and drag-rise terms and a figure of merit of 1; it is not a physical-values
figure. With physical values the miss is ~43 % RMS: the `paper-physical` preset, presets.rs.)
"""
import numpy as np
from scipy.optimize import least_squares, minimize

G = 9.80665
K_T = 0.260 * G / 1000.0**2
R_SRC = 0.01
RHO, AREA = 1.225, np.pi * 0.1**2
K_Q = 0.1 * K_T**1.5 / np.sqrt(2 * RHO * AREA)
T9, T126 = 150.0, 263.0

def target(tg):
    return 0.157434234 * tg + 0.341190317 * (tg / 100.0) ** 5.34865728

def omega(tg):
    return np.sqrt(tg / 1000 * G / K_T)

def vbus(vset, p):
    return 0.5 * (vset + np.sqrt(vset**2 - 4 * R_SRC * p))

def limit_eqs(x):
    ke, r = x
    out = []
    for tg, vs in ((T9, 9.0), (T126, 12.6)):
        p = target(tg); vb = vbus(vs, p); i = p / vb
        out.append(ke * omega(tg) + r * i - vb)
    return out

ke, r = least_squares(limit_eqs, [0.011, 0.17]).x
TG = np.arange(10.0, 261.0, 1.0)

def p_model(p, tg):
    bv, i0, ls, ns = p
    w = omega(tg)
    q = ke * i0 + bv * w + K_Q * w**2 + np.exp(ls) * (w / 1000) ** ns
    i = q / ke
    return ke * w * i + r * i**2

def res(p):
    return (p_model(p, TG) - target(TG)) / target(TG)

best = None
for ns in (8.0, 10.0, 12.0):
    s = least_squares(res, [2e-5, 0.05, -3, ns], bounds=([0, 0, -20, 1], [1e-3, 3, 5, 40]),
                      x_scale=[1e-5, 0.1, 1, 1])
    if best is None or s.cost < best.cost:
        best = s

def obj(p):
    if p[0] < 0 or p[1] < 0:
        return 1e9
    return np.mean(np.abs(res(p)) ** 12) ** (1 / 12)

p = minimize(obj, best.x, method='Nelder-Mead',
             options=dict(maxiter=60000, xatol=1e-14, fatol=1e-16)).x
bv, i0, ls, ns = (float(x) for x in p)
ke, r = float(ke), float(r)
print(f"ke_v_s_per_rad = {ke!r}  (Kv {60 / (2 * np.pi * ke):.2f} rpm/V)")
print(f"resistance_ohm = {r!r}")
print(f"k_t = {K_T!r}\nk_q = {float(K_Q)!r}")
print(f"iron_drag_nm_s = {bv!r}\nno_load_current_a = {i0!r}")
print(f"drag_rise_torque_nm = {float(np.exp(ls))!r}\ndrag_rise_exponent = {ns!r}")
print("max |rel err| 10..260 g: %.3f %%" % (100 * np.max(np.abs(res(p)))))
