//! A thrust-stand truth simulator for blind studies of the stand gap diagnosis, written apart
//! from it and in other forms: non-dimensional propeller coefficients (`C_T`, `C_P` with
//! `ρ n² D⁴`) read from a table against tip Reynolds number, a DC motor solved for its torque
//! balance by bisection, iron losses with hysteresis and eddy terms, a two-node winding/case
//! thermal network integrated in time with speed-dependent cooling, an ESC with conduction and
//! switching losses, a battery with a state-of-charge OCV table, ohmic and RC polarisation
//! resistance, and a load cell with tare creep, hysteresis and noise.
//!
//! A [`Scenario`] draws a world from wide families (Kv 300–3000 rpm/V, 20–800 W, bench supply or
//! 3–6S pack), one [`Truth`] (or none, or one outside the diagnosis' library) with a magnitude,
//! and writes training and held-out sweeps as CSV text that any stand-log reader takes. It does
//! not depend on the model or the diagnosis it is used to check.
//!
//! ```
//! let s = stand_sim::Scenario::draw(7);
//! assert!(s.train_csv.starts_with("time_s,throttle,thrust_g"));
//! assert!(s.heldout_csv.lines().count() > 10);
//! ```

pub mod eval;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

const RHO: f64 = 1.204;
const MU: f64 = 1.81e-5;
const G: f64 = 9.806_65;

/// What the world holds beyond the base physics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Truth {
    /// Nothing: stiff supply, constant winding resistance, constant no-load current, constant
    /// ESC efficiency, constant propeller coefficients, an ideal load cell (noise only).
    None,
    /// A battery pack (OCV table, ohmic and RC resistance).
    SupplySag,
    /// The winding heats (two-node thermal network).
    WindingHeating,
    /// Iron losses rise with speed.
    NoLoadCurrent,
    /// ESC switching loss at partial duty.
    EscLoss,
    /// Propeller coefficients vary with tip Reynolds number.
    ReynoldsEffect,
    /// Load-cell tare offset and creep.
    LoadcellDrift,
    /// Outside the library: load-cell hysteresis (down steps read low).
    Hysteresis,
}

impl Truth {
    /// Every truth drawn.
    pub const ALL: [Truth; 8] = [
        Truth::None,
        Truth::SupplySag,
        Truth::WindingHeating,
        Truth::NoLoadCurrent,
        Truth::EscLoss,
        Truth::ReynoldsEffect,
        Truth::LoadcellDrift,
        Truth::Hysteresis,
    ];

    /// The name the diagnosis would use for it (`none`, or `outside` for one it lacks).
    pub fn label(self) -> &'static str {
        match self {
            Truth::None => "none",
            Truth::SupplySag => "supply_sag",
            Truth::WindingHeating => "winding_heating",
            Truth::NoLoadCurrent => "no_load_current",
            Truth::EscLoss => "esc_loss",
            Truth::ReynoldsEffect => "reynolds_effect",
            Truth::LoadcellDrift => "loadcell_drift",
            Truth::Hysteresis => "outside",
        }
    }
}

/// A drawn world.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct World {
    kv: f64,
    r20: f64,
    i0: f64,
    diameter_m: f64,
    ct0: f64,
    cp0: f64,
    supply_v: f64,
    cells: u32,
    esc_eta: f64,
    esc_gamma: f64,
    truth: Truth,
    magnitude: f64,
    /// Scale of the thermal resistances (1/scale of the heat capacities): a larger motor sheds
    /// its heat through lower resistances; set so the steady winding rise at full throttle is
    /// `40 + 100·magnitude` K, as motors are rated for.
    thermal_scale: f64,
}

/// One scenario: the world, the truth, and its sweeps as CSV.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scenario {
    /// Seed.
    pub seed: u64,
    /// The truth.
    pub truth: Truth,
    /// Its magnitude (0 … 1 of the family's range).
    pub magnitude: f64,
    /// How far the truth moves a fitted model's power, current or voltage on the held-out
    /// sweep (noise-free; see `fitted_impact`), fraction.
    pub power_impact: f64,
    /// Training log: an up-and-down sweep and an up-sweep, separated by a pause.
    #[serde(skip)]
    pub train_csv: String,
    /// Held-out log: one up-and-down sweep.
    #[serde(skip)]
    pub heldout_csv: String,
    #[serde(skip)]
    world: World,
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp()
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Lithium-ion cell open-circuit voltage against state of charge (0…1), a table.
const OCV: [(f64, f64); 7] = [
    (0.0, 3.30),
    (0.1, 3.55),
    (0.2, 3.68),
    (0.4, 3.78),
    (0.6, 3.88),
    (0.8, 4.02),
    (1.0, 4.18),
];

fn interp(table: &[(f64, f64)], x: f64) -> f64 {
    if x <= table[0].0 {
        return table[0].1;
    }
    for w in table.windows(2) {
        if x <= w[1].0 {
            let f = (x - w[0].0) / (w[1].0 - w[0].0);
            return w[0].1 + f * (w[1].1 - w[0].1);
        }
    }
    table[table.len() - 1].1
}

struct State {
    soc: f64,
    v_rc: f64,
    t_wind: f64,
    t_case: f64,
    time_s: f64,
    last_thrust_n: f64,
}

struct Op {
    thrust_n: f64,
    rpm: f64,
    torque_nm: f64,
    v_bus: f64,
    i_bus: f64,
    p_cu: f64,
}

impl World {
    fn coeffs(&self, n_rps: f64) -> (f64, f64) {
        if self.truth != Truth::ReynoldsEffect {
            return (self.ct0, self.cp0);
        }
        // Tip Reynolds number with a chord of a tenth of the diameter.
        let re =
            RHO * (std::f64::consts::PI * n_rps * self.diameter_m) * 0.1 * self.diameter_m / MU;
        // Profile drag falls with Re; thrust barely moves. Table of (log10 Re, CP multiplier).
        let m = self.magnitude;
        let table = [
            (4.0, 1.0 + 0.45 * m),
            (4.5, 1.0 + 0.22 * m),
            (5.0, 1.0),
            (5.5, 1.0 - 0.10 * m),
        ];
        let k = interp(&table, re.max(1.0).log10());
        (self.ct0 * (1.0 + 0.2 * (k - 1.0)), self.cp0 * k)
    }

    fn resistance(&self, s: &State) -> f64 {
        self.r20 * (1.0 + 0.003_93 * (s.t_wind - 20.0))
    }

    fn no_load(&self, omega: f64) -> f64 {
        if self.truth == Truth::NoLoadCurrent {
            let w_ref = self.kv * self.supply_v * std::f64::consts::PI / 30.0;
            let x = omega / w_ref;
            self.i0 * (0.4 + self.magnitude * (2.5 * x + 4.0 * x * x))
        } else {
            self.i0
        }
    }

    /// The steady operating point at a throttle in the present state.
    fn operate(&self, throttle: f64, s: &State) -> Op {
        let kt = 30.0 / (std::f64::consts::PI * self.kv);
        let r = self.resistance(s);
        let duty = throttle.powf(self.esc_gamma).clamp(0.0, 1.0);
        let mut v_bus = self.source_voltage(s);
        let mut out = None;
        for _ in 0..8 {
            let vm = duty * v_bus;
            // Bisection on the torque balance.
            let (mut lo, mut hi) = (0.0, vm / kt);
            for _ in 0..80 {
                let w = 0.5 * (lo + hi);
                let im = (vm - kt * w) / r;
                let n = w / std::f64::consts::TAU;
                let (_, cp) = self.coeffs(n);
                let q = cp * RHO * n * n * self.diameter_m.powi(5) / std::f64::consts::TAU;
                if kt * (im - self.no_load(w)) > q {
                    lo = w;
                } else {
                    hi = w;
                }
            }
            let w = 0.5 * (lo + hi);
            let im = ((vm - kt * w) / r).max(0.0);
            let n = w / std::f64::consts::TAU;
            let (ct, cp) = self.coeffs(n);
            let p_motor = vm * im;
            let mut p_bus = p_motor / self.esc_eta;
            if self.truth == Truth::EscLoss {
                // Switching loss: proportional to bus voltage and current, worst at half duty.
                p_bus += self.magnitude * 0.5 * v_bus * im * (4.0 * duty * (1.0 - duty)) * 0.3;
            }
            let i_bus = p_bus / v_bus;
            let v_new = self.terminal_voltage(s, i_bus);
            out = Some(Op {
                thrust_n: ct * RHO * n * n * self.diameter_m.powi(4),
                rpm: w * 30.0 / std::f64::consts::PI,
                torque_nm: cp * RHO * n * n * self.diameter_m.powi(5) / std::f64::consts::TAU,
                v_bus: v_new,
                i_bus,
                p_cu: im * im * r,
            });
            if (v_new - v_bus).abs() < 1e-9 {
                break;
            }
            v_bus = 0.5 * (v_bus + v_new);
        }
        out.expect("at least one iteration")
    }

    fn source_voltage(&self, s: &State) -> f64 {
        if self.truth == Truth::SupplySag {
            self.cells as f64 * interp(&OCV, s.soc) - s.v_rc
        } else {
            self.supply_v
        }
    }

    fn r0(&self) -> f64 {
        // Pack ohmic resistance: magnitude sets it between 5 and 40 mΩ per cell per amp-hour
        // class (scaled to the pack's current).
        self.cells as f64 * (0.004 + 0.03 * self.magnitude)
    }

    fn terminal_voltage(&self, s: &State, i: f64) -> f64 {
        if self.truth == Truth::SupplySag {
            self.source_voltage(s) - self.r0() * i
        } else {
            self.supply_v
        }
    }

    /// Advances the thermal network and the battery over `dt` at an operating point.
    fn advance(&self, s: &mut State, op: &Op, dt: f64, capacity_ah: f64) {
        let steps = (dt / 0.1).ceil().max(1.0) as usize;
        let h = dt / steps as f64;
        for _ in 0..steps {
            if self.truth == Truth::WindingHeating {
                // Two nodes: winding (small heat capacity) and case, cooled faster at speed.
                // Resistances scale with the motor (`thermal_scale`), capacities inversely, so
                // the time constants stay and the steady rise at full throttle is 40–140 K.
                let f = self.thermal_scale;
                let c_w = 8.0 / (1.0 + 3.0 * self.magnitude) / f;
                let c_c = 40.0 / f;
                let r_wc = (1.5 + 6.0 * self.magnitude) * f;
                let r_ca = 6.0 / (1.0 + op.rpm / 10_000.0) * f;
                let q_wc = (s.t_wind - s.t_case) / r_wc;
                s.t_wind += h * (op.p_cu - q_wc) / c_w;
                s.t_case += h * (q_wc - (s.t_case - 20.0) / r_ca) / c_c;
            }
            if self.truth == Truth::SupplySag {
                s.soc -= op.i_bus * h / 3600.0 / capacity_ah;
                let (r1, c1) = (self.r0() * 0.6, 400.0);
                s.v_rc += h * (op.i_bus / c1 - s.v_rc / (r1 * c1));
            }
        }
        s.time_s += dt;
    }
}

impl Scenario {
    /// Draws a scenario (world, truth, magnitude) from a seed and simulates its sweeps.
    pub fn draw(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = Truth::ALL[rng.random_range(0..Truth::ALL.len())];
        let magnitude = 0.15 + 0.85 * rng.random::<f64>();
        Self::with(seed, truth, magnitude)
    }

    /// A scenario with a given truth and magnitude (the world still drawn from the seed).
    pub fn with(seed: u64, truth: Truth, magnitude: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_5eed);
        let kv = log_uniform(&mut rng, 300.0, 3000.0);
        let cells = rng.random_range(3..=6u32);
        let supply_v = cells as f64 * 3.9;
        let p_max = log_uniform(&mut rng, 20.0, 800.0);
        let ct0 = 0.09 + 0.04 * rng.random::<f64>();
        let cp0 = 0.035 + 0.025 * rng.random::<f64>();
        let n_max = 0.8 * kv * supply_v / 60.0;
        let diameter_m = (p_max / (cp0 * RHO * n_max.powi(3))).powf(0.2);
        let i_max = p_max / (0.8 * supply_v);
        let r20 = (0.04 + 0.08 * rng.random::<f64>()) * p_max / (i_max * i_max);
        let i0 = (0.02 + 0.04 * rng.random::<f64>()) * i_max;
        let mut world = World {
            kv,
            r20,
            i0,
            diameter_m,
            ct0,
            cp0,
            supply_v,
            cells,
            esc_eta: 0.93 + 0.05 * rng.random::<f64>(),
            esc_gamma: 0.8 + 0.4 * rng.random::<f64>(),
            truth,
            magnitude,
            thermal_scale: 1.0,
        };
        if truth == Truth::WindingHeating {
            let cold = State {
                soc: 1.0,
                v_rc: 0.0,
                t_wind: 20.0,
                t_case: 20.0,
                time_s: 0.0,
                last_thrust_n: 0.0,
            };
            let full = world.operate(1.0, &cold);
            let r_full = 1.5 + 6.0 * magnitude + 6.0 / (1.0 + full.rpm / 10_000.0);
            world.thermal_scale = (40.0 + 100.0 * magnitude) / (full.p_cu.max(1e-6) * r_full);
        }
        let capacity_ah = i_max / 15.0 * (1.0 + rng.random::<f64>());
        let mut noise = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        // Training: an up-and-down sweep (as RCbenchmark step tests run), a pause, an up-sweep.
        let mut first = up(10, 0.25);
        let mut back: Vec<f64> = first.iter().rev().skip(1).copied().collect();
        first.append(&mut back);
        let train_sched = [first, up(10, 0.28)];
        let train_csv = simulate(&world, &train_sched, &mut noise, capacity_ah, 1.0, 1.0);
        let mut schedule = up(8, 0.3);
        let mut down: Vec<f64> = schedule.iter().rev().skip(1).copied().collect();
        schedule.append(&mut down);
        let held_sched = [schedule];
        let heldout_csv = simulate(&world, &held_sched, &mut noise, capacity_ah, 0.85, 1.0);
        let mut quiet = ChaCha8Rng::seed_from_u64(0);
        let power_impact = fitted_impact(
            &simulate(&world, &train_sched, &mut quiet, capacity_ah, 1.0, 0.0),
            &simulate(&world, &held_sched, &mut quiet, capacity_ah, 0.85, 0.0),
        );
        Self {
            seed,
            truth,
            magnitude,
            power_impact,
            train_csv,
            heldout_csv,
            world,
        }
    }
}

fn up(n: usize, from: f64) -> Vec<f64> {
    (0..n)
        .map(|i| from + (1.0 - from) * i as f64 / (n - 1) as f64)
        .collect()
}

const DWELL_S: f64 = 4.0;

fn simulate(
    w: &World,
    sweeps: &[Vec<f64>],
    rng: &mut ChaCha8Rng,
    capacity_ah: f64,
    soc0: f64,
    noise: f64,
) -> String {
    let mut s = State {
        soc: soc0,
        v_rc: 0.0,
        t_wind: 20.0,
        t_case: 20.0,
        time_s: 0.0,
        last_thrust_n: 0.0,
    };
    let mut csv =
        String::from("time_s,throttle,thrust_g,voltage_v,current_a,power_w,rpm,torque_nm\n");
    let full = w.operate(1.0, &s);
    let t_full_g = full.thrust_n / G * 1000.0;
    let offset_g = if w.truth == Truth::LoadcellDrift {
        0.03 * w.magnitude * t_full_g
    } else {
        0.0
    };
    for (k, sweep) in sweeps.iter().enumerate() {
        if k > 0 {
            // A pause at idle between sweeps: the winding cools, the pack recovers.
            let idle = w.operate(0.05, &s);
            w.advance(&mut s, &idle, 60.0, capacity_ah);
        }
        // Idle row before the sweep (the pack's open-circuit voltage, the load cell's tare).
        let idle = w.operate(0.0, &s);
        let mut tare_g = noise * (0.002 * t_full_g) * gauss(rng);
        if w.truth == Truth::LoadcellDrift {
            tare_g += offset_g + 0.06 * w.magnitude * t_full_g * (1.0 - (-s.time_s / 90.0).exp());
        }
        push_row(
            &mut csv, &s, 0.0, tare_g, idle.v_bus, 0.0, 0.0, 0.0, rng, noise,
        );
        for &u in sweep {
            let op = w.operate(u, &s);
            w.advance(&mut s, &op, DWELL_S, capacity_ah);
            let op = w.operate(u, &s);
            let mut reading_g = op.thrust_n / G * 1000.0;
            if w.truth == Truth::LoadcellDrift {
                let creep = 0.06 * w.magnitude * t_full_g * (1.0 - (-s.time_s / 90.0).exp());
                reading_g += offset_g + creep;
            }
            if w.truth == Truth::Hysteresis && op.thrust_n < s.last_thrust_n {
                reading_g -= 0.06 * w.magnitude * t_full_g;
            }
            s.last_thrust_n = op.thrust_n;
            push_row(
                &mut csv,
                &s,
                u,
                reading_g + noise * (0.002 * t_full_g) * gauss(rng),
                op.v_bus,
                op.i_bus,
                op.rpm,
                op.torque_nm,
                rng,
                noise,
            );
        }
    }
    csv
}

#[allow(clippy::too_many_arguments)]
fn push_row(
    csv: &mut String,
    s: &State,
    throttle: f64,
    thrust_g: f64,
    v: f64,
    i: f64,
    rpm: f64,
    q: f64,
    rng: &mut ChaCha8Rng,
    noise: f64,
) {
    let v_m = v * (1.0 + noise * 0.0005 * gauss(rng));
    let i_m = i * (1.0 + noise * 0.004 * gauss(rng));
    let rpm_m = (rpm * (1.0 + noise * 0.002 * gauss(rng))).round();
    let q_m = q * (1.0 + noise * 0.01 * gauss(rng));
    csv.push_str(&format!(
        "{:.2},{throttle:.4},{thrust_g:.4},{v_m:.5},{i_m:.5},{:.5},{rpm_m},{q_m:.6}\n",
        s.time_s,
        v_m * i_m
    ));
}

/// Rows of a simulated CSV: (thrust reading g, voltage V, current A, power W).
fn rows(csv: &str) -> Vec<[f64; 4]> {
    csv.lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            [v[2], v[3], v[4], v[5]]
        })
        .collect()
}

/// Least squares on a small basis by normal equations and Gaussian elimination.
#[allow(clippy::needless_range_loop)] // row operations read clearest with indices
fn basis_fit(x: &[f64], y: &[f64]) -> [f64; 5] {
    let phi = |x: f64| [1.0, x.sqrt(), x, x * x.sqrt(), x * x];
    let mut a = [[0.0f64; 6]; 5];
    for (xi, yi) in x.iter().zip(y) {
        let f = phi(*xi);
        for r in 0..5 {
            for c in 0..5 {
                a[r][c] += f[r] * f[c];
            }
            a[r][5] += f[r] * yi;
        }
    }
    for (r, row) in a.iter_mut().enumerate() {
        row[r] += 1e-12 * (1.0 + row[r].abs());
    }
    for col in 0..5 {
        let piv = (col..5)
            .max_by(|p, q| a[*p][col].abs().total_cmp(&a[*q][col].abs()))
            .unwrap_or(col);
        a.swap(col, piv);
        let d = a[col][col];
        if d.abs() < 1e-300 {
            continue;
        }
        for r in 0..5 {
            if r != col {
                let f = a[r][col] / d;
                for c in col..6 {
                    a[r][c] -= f * a[col][c];
                }
            }
        }
    }
    let mut out = [0.0; 5];
    for r in 0..5 {
        out[r] = if a[r][r].abs() > 1e-300 {
            a[r][5] / a[r][r]
        } else {
            0.0
        };
    }
    out
}

/// How far a smooth fit in thrust — the terms a motor–propeller power law can take
/// (`1, √T, T, T^1.5, T²`), fitted to the noise-free training sweeps — misses the noise-free
/// held-out sweep's power or current, and how far the voltage leaves its idle value: the share
/// of the truth a fitted model cannot absorb, as a fraction.
fn fitted_impact(train_csv: &str, held_csv: &str) -> f64 {
    let tr = rows(train_csv);
    let he = rows(held_csv);
    let tmax = tr.iter().map(|r| r[0]).fold(0.0f64, f64::max).max(1e-9);
    let spin = |r: &&[f64; 4]| r[0] > 0.05 * tmax;
    let x: Vec<f64> = tr.iter().filter(spin).map(|r| r[0] / tmax).collect();
    let mut worst: f64 = 0.0;
    for k in [2usize, 3] {
        let y: Vec<f64> = tr.iter().filter(spin).map(|r| r[k]).collect();
        let c = basis_fit(&x, &y);
        for r in he.iter().filter(spin) {
            let xi = r[0] / tmax;
            let f = c[0] + c[1] * xi.sqrt() + c[2] * xi + c[3] * xi * xi.sqrt() + c[4] * xi * xi;
            worst = worst.max(((f - r[k]) / r[k]).abs());
        }
    }
    let idle_v = he.first().map(|r| r[1]).unwrap_or(f64::NAN);
    for r in he.iter().filter(spin) {
        worst = worst.max(((r[1] - idle_v) / idle_v).abs());
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenarios_are_reproducible_and_differ_by_seed() {
        let a = Scenario::draw(3);
        let b = Scenario::draw(3);
        let c = Scenario::draw(4);
        assert_eq!(a.train_csv, b.train_csv);
        assert_ne!(a.train_csv, c.train_csv);
    }

    #[test]
    fn a_world_without_an_effect_has_no_impact() {
        for seed in 0..5 {
            let s = Scenario::with(seed, Truth::None, 0.5);
            // A smooth fit absorbs a world without an effect to well under the 2 % threshold.
            assert!(s.power_impact < 0.005, "{}", s.power_impact);
        }
    }

    #[test]
    fn a_pack_sags_with_current() {
        let s = Scenario::with(11, Truth::SupplySag, 0.8);
        let rows: Vec<Vec<f64>> = s
            .train_csv
            .lines()
            .skip(1)
            .map(|l| {
                l.split(',')
                    .map(|v| v.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        let idle_v = rows[0][3];
        let top = rows
            .iter()
            .max_by(|a, b| a[4].total_cmp(&b[4]))
            .expect("rows");
        assert!(
            top[3] < idle_v - 0.05 * top[4] * 0.01,
            "{} vs {idle_v}",
            top[3]
        );
        assert!(top[3] < idle_v * 0.99);
        assert!(s.power_impact > 0.0);
    }

    #[test]
    fn power_is_thrust_consistent_across_the_range() {
        let s = Scenario::with(5, Truth::None, 0.0);
        let mut last = 0.0;
        for l in s.train_csv.lines().skip(2).take(9) {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            assert!(v[2] > last * 0.98, "thrust rises with throttle");
            last = v[2];
            assert!(v[5] > 0.0);
        }
    }
}
