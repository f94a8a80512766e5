//! Motor–propeller–ESC–supply physics.
//!
//! State: rotor speed ω (rad/s). Per step, with ESC duty `d` from the pulse width:
//!
//! ```text
//! supply   V_bus = V_set − R_src·I_bus,         I_bus = d·I/η      (bench leads / pack resistance;
//!                                                                  ESC efficiency η, ·η regenerating)
//! duty     d = d_max·u^γ,   u = (pulse − min)/(max − min)          (ESC throttle map; γ = 1: linear)
//! motor    d·V_bus = K_e·ω + R·I                                   (back-EMF + winding/ESC resistance)
//! torque   J·dω/dt = K_t·I − Q(ω),   K_t = K_e
//! load     Q(ω) = K_t·I₀ + b_v·ω + k_Q·ω² + k_s·(ω/1000)^n_s     (friction, iron drag, propeller,
//!                                                                  high-tip-speed drag rise)
//! thrust   T = k_T·ω²
//! ```
//!
//! The mechanical time constant is `J / (K_t²/R + dQ/dω)`; the reachable speed is limited by
//! the bus voltage, so the thrust limit falls with the supply voltage. With synchronous
//! rectification a fast throttle cut drives `I` negative: the motor brakes regeneratively and
//! pushes current back into the supply (which is why the firmware slew-limits spin-down).

/// Standard gravity, m/s².
pub const G: f64 = 9.80665;

/// Brushless motor constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motor {
    /// Speed constant, rpm per volt.
    pub kv_rpm_per_v: f64,
    /// Winding plus ESC on-resistance, Ω.
    pub resistance_ohm: f64,
    /// No-load (friction) current, A.
    pub no_load_current_a: f64,
    /// Iron-loss (eddy) drag, N·m per rad/s.
    pub iron_drag_nm_s: f64,
    /// Rotor plus propeller inertia, kg·m².
    pub inertia_kg_m2: f64,
}

impl Motor {
    /// Back-EMF / torque constant, V·s/rad = N·m/A.
    pub fn ke(&self) -> f64 {
        60.0 / (2.0 * core::f64::consts::PI * self.kv_rpm_per_v)
    }
}

/// Propeller constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Propeller {
    /// Thrust coefficient, N per (rad/s)².
    pub k_t: f64,
    /// Torque coefficient, N·m per (rad/s)².
    pub k_q: f64,
    /// Drag-rise torque at 1000 rad/s, N·m (blade stall/flex at high tip speed).
    pub drag_rise_torque_nm: f64,
    /// Exponent of the drag rise in ω.
    pub drag_rise_exponent: f64,
}

/// ESC constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Esc {
    /// Pulse width for zero duty, µs.
    pub min_us: f64,
    /// Pulse width for full duty, µs.
    pub max_us: f64,
    /// Duty at full throttle (≤ 1).
    pub max_duty: f64,
    /// Exponent `γ` of the throttle-to-duty map `d = d_max·u^γ` (`u` the pulse width's fraction
    /// of `min_us..max_us`); 1 is a linear ESC.
    pub curve_exponent: f64,
    /// Efficiency `η`: the share of the bus power that reaches the motor while driving (switching
    /// and other losses not in the motor's resistance); the bus current is `d·I/η` (`d·I·η`
    /// while regenerating). 1 is a lossless ESC.
    pub efficiency: f64,
}

impl Esc {
    /// Duty cycle for a pulse width.
    pub fn duty(&self, throttle_us: f64) -> f64 {
        let u = ((throttle_us - self.min_us) / (self.max_us - self.min_us)).clamp(0.0, 1.0);
        let shaped = if self.curve_exponent == 1.0 {
            u
        } else {
            u.powf(self.curve_exponent)
        };
        shaped * self.max_duty
    }

    /// Bus current per unit of `d·I` (duty times motor current): `1/η` while the motor is
    /// driven (`drive` true), `η` while it regenerates.
    pub fn bus_factor(&self, drive: bool) -> f64 {
        if drive {
            1.0 / self.efficiency
        } else {
            self.efficiency
        }
    }
}

/// A DC supply: set voltage behind a resistance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Supply {
    /// Open-circuit / set voltage, V.
    pub voltage_v: f64,
    /// Source resistance (leads, pack), Ω.
    pub resistance_ohm: f64,
}

/// What the rig's ESC and motor draw from the bus at one instant, as a function of the bus
/// voltage: `I_bus(V) = d·(d·V − K_e·ω)/R · f` for duty `d`, back-EMF `K_e·ω`, winding
/// resistance `R` and the ESC's bus factor `f` (`1/η` driving, `η` regenerating). An external supply model (see [`crate::world::ExternalBus`]) solves its
/// output against this.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusLoad {
    /// ESC duty cycle (0..1).
    pub duty: f64,
    /// Motor back-EMF, V.
    pub back_emf_v: f64,
    /// Winding plus ESC resistance, Ω.
    pub resistance_ohm: f64,
    /// ESC efficiency (see [`Esc::efficiency`]).
    pub efficiency: f64,
}

impl BusLoad {
    /// Bus current drawn at `bus_voltage_v` (negative when regenerating), A.
    pub fn current_a(&self, bus_voltage_v: f64) -> f64 {
        let drive_v = self.duty * bus_voltage_v - self.back_emf_v;
        let f = if drive_v >= 0.0 {
            1.0 / self.efficiency
        } else {
            self.efficiency
        };
        self.duty * drive_v / self.resistance_ohm * f
    }
}

/// Electrical operating point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Electrical {
    /// Motor (phase-equivalent DC) current, A.
    pub motor_current_a: f64,
    /// Supply current, A (negative when regenerating).
    pub bus_current_a: f64,
    /// Voltage at the rig, V.
    pub bus_voltage_v: f64,
}

/// A motor–propeller–ESC unit with its state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Propulsion {
    /// Motor.
    pub motor: Motor,
    /// Propeller.
    pub prop: Propeller,
    /// ESC.
    pub esc: Esc,
    /// Rotor speed, rad/s.
    pub omega_rad_s: f64,
}

/// A steady operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyState {
    /// Rotor speed, rad/s.
    pub omega_rad_s: f64,
    /// Thrust, g.
    pub thrust_g: f64,
    /// Electrical operating point.
    pub electrical: Electrical,
}

impl SteadyState {
    /// Electrical power drawn from the supply, W.
    pub fn power_w(&self) -> f64 {
        self.electrical.bus_voltage_v * self.electrical.bus_current_a
    }
}

impl Propulsion {
    /// A unit at rest.
    pub fn new(motor: Motor, prop: Propeller, esc: Esc) -> Self {
        Self {
            motor,
            prop,
            esc,
            omega_rad_s: 0.0,
        }
    }

    /// What the unit draws from the bus at pulse width `throttle_us` and its present speed.
    pub fn bus_load(&self, throttle_us: f64) -> BusLoad {
        BusLoad {
            duty: self.esc.duty(throttle_us),
            back_emf_v: self.motor.ke() * self.omega_rad_s,
            resistance_ohm: self.motor.resistance_ohm,
            efficiency: self.esc.efficiency,
        }
    }

    /// Load torque at speed `omega` (excluding static friction at rest), N·m.
    pub fn load_torque_nm(&self, omega: f64) -> f64 {
        let w = omega.max(0.0);
        let friction = if w > 0.0 {
            self.motor.ke() * self.motor.no_load_current_a
        } else {
            0.0
        };
        friction
            + self.motor.iron_drag_nm_s * w
            + self.prop.k_q * w * w
            + self.prop.drag_rise_torque_nm * (w / 1000.0).powf(self.prop.drag_rise_exponent)
    }

    /// Thrust at speed `omega`, g.
    pub fn thrust_g(&self, omega: f64) -> f64 {
        self.prop.k_t * omega * omega / G * 1000.0
    }

    /// Currents and bus voltage for duty `d` at speed `omega`.
    pub fn electrical(&self, d: f64, omega: f64, supply: Supply) -> Electrical {
        let r = self.motor.resistance_ohm;
        let ke = self.motor.ke();
        // I_bus = f d I, I = (d V_bus − Ke ω)/R, V_bus = V_set − R_src I_bus:
        // I_bus (1 + f d² R_src / R) = f d (d V_set − Ke ω) / R; the sign of I (drive or
        // regeneration) is that of d V_set − Ke ω.
        let f = self
            .esc
            .bus_factor(d * supply.voltage_v - ke * omega >= 0.0);
        let bus_current_a = f * d * (d * supply.voltage_v - ke * omega)
            / r
            / (1.0 + f * d * d * supply.resistance_ohm / r);
        let bus_voltage_v = supply.voltage_v - supply.resistance_ohm * bus_current_a;
        let motor_current_a = (d * bus_voltage_v - ke * omega) / r;
        Electrical {
            motor_current_a,
            bus_current_a,
            bus_voltage_v,
        }
    }

    /// Advances the state by `dt_s` at pulse width `throttle_us`; returns the electrical point.
    pub fn step(&mut self, dt_s: f64, throttle_us: f64, supply: Supply) -> Electrical {
        let d = self.esc.duty(throttle_us);
        // Sub-steps keep explicit integration well inside the mechanical time constant.
        let n = 4;
        let h = dt_s / f64::from(n);
        let mut e = Electrical::default();
        for _ in 0..n {
            e = self.electrical(d, self.omega_rad_s, supply);
            let drive = self.motor.ke() * e.motor_current_a;
            let load = self.load_torque_nm(self.omega_rad_s);
            if self.omega_rad_s <= 0.0 && drive <= self.motor.ke() * self.motor.no_load_current_a {
                self.omega_rad_s = 0.0; // static friction holds the rotor
                continue;
            }
            self.omega_rad_s =
                (self.omega_rad_s + (drive - load) / self.motor.inertia_kg_m2 * h).max(0.0);
        }
        e
    }

    /// The steady operating point at `throttle_us` (torque balance by bisection).
    pub fn steady_state(&self, throttle_us: f64, supply: Supply) -> SteadyState {
        let d = self.esc.duty(throttle_us);
        let net = |w: f64| {
            self.motor.ke() * self.electrical(d, w, supply).motor_current_a - self.load_torque_nm(w)
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        while net(hi) > 0.0 && hi < 1e6 {
            hi *= 2.0;
        }
        if net(1e-9) <= 0.0 {
            hi = 0.0;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if net(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let w = 0.5 * (lo + hi);
        SteadyState {
            omega_rad_s: w,
            thrust_g: self.thrust_g(w),
            electrical: self.electrical(d, w, supply),
        }
    }

    /// Mechanical time constant around speed `omega` at duty `d`, s.
    pub fn time_constant_s(&self, omega: f64) -> f64 {
        let ke = self.motor.ke();
        let dw = 1e-3 * omega.max(1.0);
        let dq = (self.load_torque_nm(omega + dw) - self.load_torque_nm((omega - dw).max(0.0)))
            / (2.0 * dw);
        self.motor.inertia_kg_m2 / (ke * ke / self.motor.resistance_ohm + dq)
    }
}
