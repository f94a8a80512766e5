//! The pack at pack level and the forward integration of its discharge.

use super::battery::BatteryModel;
use super::{CSCALE, RSCALE, SOC, VBIAS, VRC, Vector};

/// Most state-of-charge steps one forward integration takes (over all segments).
pub const MAX_SIM_STEPS: usize = 256;
/// State-of-charge step of the forward integration.
const SOC_STEP: f64 = 0.02;

/// The battery model at pack level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Pack {
    pub battery: BatteryModel,
    pub cells: f64,
    pub capacity_ah: f64,
    /// Series resistance of the pack, Ω (the battery model's).
    pub r0_ohm: f64,
    /// Resistance the filter's resistance scale multiplies, Ω: the model's, or the absolute
    /// prior ([`super::OnlineConfig::extra_resistance_sigma_ohm`]) when that is larger, so that a
    /// pack whose model has (nearly) no resistance can still learn one.
    pub r_ref_ohm: f64,
    /// The reference at the first sample, Ω: the resistance scale's bounds and random walk are
    /// fractions of it, so that a reference raised later (a resynchronisation that reopens
    /// the resistance) leaves them as they were in ohms.
    pub r_init_ohm: f64,
    /// RC-pair resistance of the pack, Ω.
    pub r1_ohm: f64,
    pub tau_s: f64,
    /// Cut-off voltage of the pack under load, V.
    pub cutoff_v: f64,
}

impl Pack {
    pub fn new(b: &BatteryModel) -> Self {
        let n = f64::from(b.cells);
        Self {
            battery: *b,
            cells: n,
            capacity_ah: b.rated_capacity_ah,
            r0_ohm: n * b.series_resistance_cell_ohm,
            r_ref_ohm: n * b.series_resistance_cell_ohm,
            r_init_ohm: n * b.series_resistance_cell_ohm,
            r1_ohm: n * b.rc_resistance_cell_ohm,
            tau_s: b.rc_time_constant_s,
            cutoff_v: n * b.cutoff_cell_v,
        }
    }

    /// Open-circuit voltage of the pack, V.
    pub fn ocv_v(&self, soc: f64) -> f64 {
        self.cells * self.battery.ocv_cell_at(soc)
    }

    /// Pack open-circuit voltage and its slope, V and V per unit of charge.
    pub fn ocv_and_slope(&self, soc: f64) -> (f64, f64) {
        let (v, s) = self.battery.ocv_and_slope(soc);
        (self.cells * v, self.cells * s)
    }

    /// Current delivering `power_w` from a source of voltage `e_v` behind `r_ohm`: the smaller
    /// root of `r·I² − e·I + p = 0`, written `2p / (e + √(e² − 4rp))` so it stays exact as
    /// `r → 0`. When the source cannot deliver the power, the current at its maximum power
    /// (`e / 2r`) and `false`.
    pub fn current_for_power(&self, e_v: f64, r_ohm: f64, power_w: f64) -> (f64, bool) {
        let e = e_v.max(1e-3);
        let disc = e * e - 4.0 * r_ohm.max(0.0) * power_w;
        if disc < 0.0 {
            return (e / (2.0 * r_ohm.max(1e-9)), false);
        }
        (2.0 * power_w / (e + libm::sqrt(disc)), true)
    }
}

/// Where the propulsion can no longer carry the robot (the paper's thrust limit `m_L`, measured
/// per rotor at the minimum battery voltage): the loaded pack voltage below which the rotors'
/// maximum thrust, `T_L·(V / V_L)^k`, falls short of the thrust the robot needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ThrustEnd {
    /// Per-rotor thrust limit, g.
    pub limit_g: f64,
    /// Its standard uncertainty, g.
    pub limit_sigma_g: f64,
    /// Supply voltage of the limit, V.
    pub limit_v: f64,
    /// Exponent `k` of the maximum thrust against the voltage.
    pub exponent: f64,
    /// Per-rotor thrust of the model's hover (eq. 1's take-off mass), g.
    pub hover_g: f64,
    /// Electrical power per gram of thrust at the hover thrust, all rotors, W/g: what turns the
    /// learned power above the model into thrust above it.
    pub watts_per_g: f64,
}

impl ThrustEnd {
    /// Per-rotor thrust the rotors must be able to give when `share` of `extra_w` (power above
    /// the model's hover power) goes into thrust and the controller keeps `headroom` (a
    /// fraction of the mean thrust) above it for its corrections, g.
    pub fn thrust_g(&self, extra_w: f64, share: f64, headroom: f64) -> f64 {
        let mean_g =
            (self.hover_g + share * extra_w / self.watts_per_g.max(1e-6)).max(0.5 * self.hover_g);
        mean_g * (1.0 + headroom.max(0.0))
    }

    /// Loaded pack voltage below which the rotors cannot make `thrust_g`, V.
    pub fn floor_v(&self, thrust_g: f64) -> f64 {
        self.limit_v * libm::pow((thrust_g / self.limit_g).max(1e-6), 1.0 / self.exponent)
    }
}

/// One stretch of a forward integration at constant power.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SimSegment {
    /// Flying (hover power) or not (idle power).
    pub flying: bool,
    /// Longest duration, s (infinite: until `stop_soc` or the cut-off).
    pub duration_s: f64,
    /// The segment ends when the state of charge reaches this.
    pub stop_soc: f64,
    /// Reaching the cut-off is this segment's normal end (hover until empty).
    pub ends_at_cutoff: bool,
}

impl SimSegment {
    pub const EMPTY: Self = Self {
        flying: true,
        duration_s: 0.0,
        stop_soc: 0.0,
        ends_at_cutoff: false,
    };
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SimResult {
    /// Time until the end of the first `plan_len` segments (or the cut-off before), s.
    pub plan_s: f64,
    /// Time until the cut-off or the end of all segments, s.
    pub total_s: f64,
    /// The first `plan_len` segments all ended by their own rule.
    pub plan_completed: bool,
    /// The pack could not deliver the first segment's power at the start.
    pub unreachable_at_start: bool,
    /// Stopped at [`MAX_SIM_STEPS`].
    pub truncated: bool,
    /// State of charge where the integration stopped.
    pub end_soc: f64,
    /// Time spent flying (at `hover_w`) within `plan_s`, s.
    pub plan_flying_s: f64,
}

/// The powers and end voltages of a forward integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SimLoad {
    /// Power drawn flying, W.
    pub hover_w: f64,
    /// Power drawn on the ground or attached, W.
    pub idle_w: f64,
    /// Loaded voltage below which the rotors run out of thrust, V (0: no limit).
    pub fly_floor_v: f64,
    /// Shift of the end voltages (the band's), V.
    pub cutoff_shift_v: f64,
}

/// Discharges the pack from state `x` through `segs`, at `load.hover_w` when flying and `load.idle_w`
/// otherwise, until the terminal voltage reaches the cut-off (`pack.cutoff_v`, flying also
/// `fly_floor_v` where the rotors run out of thrust, whichever is higher, moved by
/// `cutoff_shift_v`: the band moves it by the uncertainty of the voltage the pack will show
/// there), the pack cannot deliver the power, or the segments end. Midpoint rule in state-of-charge steps of at most [`SOC_STEP`]; the
/// cut-off time is interpolated linearly in voltage within the step that crosses it.
pub(super) fn simulate(
    pack: &Pack,
    x: &Vector,
    segs: &[SimSegment],
    plan_len: usize,
    load: &SimLoad,
) -> SimResult {
    let SimLoad {
        hover_w,
        idle_w,
        fly_floor_v,
        cutoff_shift_v,
    } = *load;
    let mut s = if x[SOC].is_finite() {
        x[SOC].clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut v1 = if x[VRC].is_finite() { x[VRC] } else { 0.0 };
    let r = pack.r_ref_ohm * x[RSCALE].max(0.0);
    let bias = if x[VBIAS].is_finite() { x[VBIAS] } else { 0.0 };
    let q_as = 3600.0 * pack.capacity_ah * x[CSCALE].max(0.05);
    let mut t = 0.0;
    let mut plan_s = None;
    let mut plan_completed = plan_len == 0;
    let mut unreachable_at_start = false;
    let mut truncated = false;
    let mut steps = 0;
    let mut flying_s = 0.0;
    let mut plan_flying_s = None;
    let relax = |v1: f64, i: f64, dt: f64| {
        let target = i * pack.r1_ohm;
        if pack.tau_s > 0.0 {
            target + (v1 - target) * libm::exp(-dt / pack.tau_s)
        } else {
            target
        }
    };
    'all: for (j, seg) in segs.iter().enumerate() {
        let p = if seg.flying { hover_w } else { idle_w }.max(0.05);
        // Flying, the flight also ends where the rotors run out of thrust.
        let cutoff_v = if seg.flying {
            pack.cutoff_v.max(fly_floor_v)
        } else {
            pack.cutoff_v
        } + cutoff_shift_v;
        let mut t_seg = 0.0;
        let t_seg_start = t;
        let mut prev: Option<(f64, f64)> = None;
        let ended_by_rule;
        loop {
            let e = pack.ocv_v(s) - v1 + bias;
            let (i, ok) = pack.current_for_power(e, r, p);
            let v = e - i * r;
            if !ok || v <= cutoff_v {
                if let Some((tp, vp)) = prev {
                    if ok && vp > v {
                        t = tp + (vp - cutoff_v) / (vp - v) * (t - tp);
                    }
                } else if j == 0 && steps == 0 && !ok {
                    unreachable_at_start = true;
                }
                ended_by_rule = seg.ends_at_cutoff;
                if seg.flying {
                    flying_s += t - t_seg_start;
                }
                if j < plan_len {
                    plan_completed = ended_by_rule && j + 1 == plan_len;
                    plan_s = Some(t);
                    plan_flying_s = Some(flying_s);
                }
                break 'all;
            }
            if s <= seg.stop_soc + 1e-12 || t_seg >= seg.duration_s {
                ended_by_rule = true;
                break;
            }
            if steps >= MAX_SIM_STEPS {
                truncated = true;
                if seg.flying {
                    flying_s += t - t_seg_start;
                }
                if j < plan_len {
                    plan_s = Some(t);
                    plan_flying_s = Some(flying_s);
                }
                break 'all;
            }
            steps += 1;
            let mut ds = SOC_STEP.min(s - seg.stop_soc);
            // Midpoint current.
            let e_mid = pack.ocv_v(s - 0.5 * ds) - v1 + bias;
            let (i_mid, ok_mid) = pack.current_for_power(e_mid, r, p);
            let i_step = if ok_mid { i_mid } else { i };
            let mut dt = ds * q_as / i_step.max(1e-9);
            if t_seg + dt > seg.duration_s {
                dt = seg.duration_s - t_seg;
                ds = dt * i_step / q_as;
            }
            prev = Some((t, v));
            s -= ds;
            t += dt;
            t_seg += dt;
            v1 = relax(v1, i_step, dt);
        }
        if seg.flying {
            flying_s += t - t_seg_start;
        }
        if ended_by_rule && j + 1 == plan_len {
            plan_completed = true;
            plan_s = Some(t);
            plan_flying_s = Some(flying_s);
        }
    }
    SimResult {
        plan_s: plan_s.unwrap_or(t),
        total_s: t,
        plan_completed,
        unreachable_at_start,
        truncated,
        end_soc: s,
        plan_flying_s: plan_flying_s.unwrap_or(flying_s),
    }
}
