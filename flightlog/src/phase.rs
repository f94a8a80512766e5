//! Flight phases, and their inference from current and altitude when a log has none.
//!
//! The inference uses only the flight's own signals:
//!
//! - **current** (motors on or off): the smoothed current is split into two clusters at the
//!   threshold that maximises the between-cluster variance (Otsu's method on the sorted values).
//!   The split is accepted as *idle vs flying* only if the two clusters are well apart (the idle
//!   mean below half the flying mean and the means at least [`MIN_SEPARATION`] pooled standard
//!   deviations apart) and the idle cluster holds at least 1 % of the samples; otherwise the
//!   motors are taken to run throughout.
//! - **altitude**: the ground level is the 1st percentile of the smoothed altitude; samples
//!   within a band above it (5 % of the altitude range, at least [`MIN_GROUND_BAND_M`]) and
//!   not moving vertically are on the ground, if their run touches the start or the end of the
//!   log (a still period near the ground between flying periods is a low hover). The vertical speed is the slope of the smoothed
//!   altitude over [`SMOOTHING_S`] (at least 2.5 sample intervals); above [`VERTICAL_SPEED_THRESHOLD_M_S`] is a climb, below its
//!   negative a descent, between them a hover.
//! - **both**: motors off near the ground is `Ground`, motors off at the highest plateau (within
//!   the band below the maximum, and clear of the ground band) is `Attached`, motors off
//!   anywhere else is `Transition`; motors on is climb, descend or hover by vertical speed.
//! - **current only**: motors off in a run that touches the start or end of the log is
//!   `Ground`, in a run between two flying runs `Attached` (a mid-flight landing would look the
//!   same; the notes say so); motors on is `Hover`.
//! - **a land detector** (PX4's `vehicle_land_detected.landed`) replaces the altitude ground
//!   test when the log has one.

use serde::{Deserialize, Serialize};

/// What the robot is doing at a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// On the ground (motors off or idling).
    Ground,
    /// Hovering or flying level.
    Hover,
    /// Climbing.
    Climb,
    /// Descending.
    Descend,
    /// Attached to the ceiling, motors off.
    Attached,
    /// Between phases (take-off, landing, attaching, detaching, or not classifiable).
    Transition,
}

impl Phase {
    /// Every phase, in declaration order.
    pub const ALL: [Phase; 6] = [
        Phase::Ground,
        Phase::Hover,
        Phase::Climb,
        Phase::Descend,
        Phase::Attached,
        Phase::Transition,
    ];

    /// The lowercase name used in CSV `phase` columns.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Ground => "ground",
            Phase::Hover => "hover",
            Phase::Climb => "climb",
            Phase::Descend => "descend",
            Phase::Attached => "attached",
            Phase::Transition => "transition",
        }
    }

    /// Parses a CSV `phase` cell (case-insensitive, surrounding spaces ignored).
    pub fn parse(text: &str) -> Option<Phase> {
        let t = text.trim();
        Phase::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(t))
    }

    /// Whether the rotors carry the robot: every phase but `ground` and `attached`. A
    /// `transition` (a VTOL between hover and forward flight, or a take-off, landing,
    /// attaching or detaching) is airborne and powered, so it counts as flying.
    pub fn is_flying(self) -> bool {
        !matches!(self, Phase::Ground | Phase::Attached)
    }
}

impl std::fmt::Display for Phase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Window of the moving averages and of the vertical-speed slope, s (at least 2.5 sample
/// intervals, for logs slower than 2.5 Hz).
pub const SMOOTHING_S: f64 = 1.0;
/// Vertical speed beyond which a flying sample is a climb or a descent, m/s.
pub const VERTICAL_SPEED_THRESHOLD_M_S: f64 = 0.1;
/// Smallest height of the ground (and ceiling) band, m.
pub const MIN_GROUND_BAND_M: f64 = 0.1;
/// Smallest distance between the idle and flying current means, in pooled standard deviations.
pub const MIN_SEPARATION: f64 = 3.0;

/// Which signals a phase inference used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InferenceSignals {
    /// Current (motors on/off) and altitude.
    CurrentAndAltitude,
    /// Current only.
    Current,
    /// Altitude only.
    Altitude,
    /// A land detector for the ground, altitude for climb/descend/hover (and current for
    /// attachment, when present).
    LandDetector,
}

/// Fraction of the samples in each phase (each in 0–1, summing to 1).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseFractions {
    /// On the ground.
    pub ground: f64,
    /// Hovering.
    pub hover: f64,
    /// Climbing.
    pub climb: f64,
    /// Descending.
    pub descend: f64,
    /// Attached.
    pub attached: f64,
    /// In transition.
    pub transition: f64,
}

impl PhaseFractions {
    /// Fractions of each phase in `phases` (all zero when empty).
    pub fn of(phases: &[Phase]) -> Self {
        let mut counts = [0usize; 6];
        for &p in phases {
            counts[p as usize] += 1;
        }
        let n = phases.len().max(1) as f64;
        let f = |p: Phase| counts[p as usize] as f64 / n;
        Self {
            ground: f(Phase::Ground),
            hover: f(Phase::Hover),
            climb: f(Phase::Climb),
            descend: f(Phase::Descend),
            attached: f(Phase::Attached),
            transition: f(Phase::Transition),
        }
    }

    /// The fraction of one phase.
    pub fn get(&self, phase: Phase) -> f64 {
        match phase {
            Phase::Ground => self.ground,
            Phase::Hover => self.hover,
            Phase::Climb => self.climb,
            Phase::Descend => self.descend,
            Phase::Attached => self.attached,
            Phase::Transition => self.transition,
        }
    }
}

/// How phases were inferred: the signals, every threshold used, and the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InferenceMethod {
    /// The signals used.
    pub signals: InferenceSignals,
    /// Current separating idle (attached, ground) from flying, A; `None` when there is no
    /// current or it has no idle level.
    pub current_split_a: Option<f64>,
    /// Mean smoothed current of the idle cluster, A.
    pub idle_current_a: Option<f64>,
    /// Mean smoothed current of the flying cluster, A.
    pub flying_current_a: Option<f64>,
    /// Ground level (1st percentile of the smoothed altitude), m.
    pub ground_altitude_m: Option<f64>,
    /// Highest smoothed altitude, m.
    pub max_altitude_m: Option<f64>,
    /// Height of the ground and ceiling bands, m.
    pub band_m: Option<f64>,
    /// Vertical-speed threshold for climb and descent, m/s (`None` without altitude).
    pub vertical_speed_threshold_m_s: Option<f64>,
    /// Smoothing window, s.
    pub smoothing_s: f64,
    /// Fraction of the samples in each phase.
    pub fractions: PhaseFractions,
    /// For each phase found, what put samples in it.
    #[serde(default)]
    pub evidence: Vec<PhaseEvidence>,
}

/// Why samples were put in a phase.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhaseEvidence {
    /// The phase.
    pub phase: Phase,
    /// Fraction of the samples in it.
    pub fraction: f64,
    /// What put them there, in words.
    pub evidence: String,
}

/// What a vehicle can do that phase inference must not assume: perch (`attached`) and fly
/// as a VTOL (`transition`). Each is `Some(why it is known)` when the vehicle can.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// The robot perches (e.g. `perches = true` in its metadata, and from where).
    pub perches: Option<String>,
    /// The vehicle is a VTOL (from the log's vehicle type, and which field).
    pub vtol: Option<String>,
}

impl Capabilities {
    /// Both capabilities, as [`infer`] assumes (the behaviour before vehicles were known).
    pub fn all() -> Self {
        Self {
            perches: Some("assumed".to_owned()),
            vtol: Some("assumed".to_owned()),
        }
    }
}

impl std::fmt::Display for InferenceMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let signals = match self.signals {
            InferenceSignals::CurrentAndAltitude => "current and altitude",
            InferenceSignals::Current => "current",
            InferenceSignals::Altitude => "altitude",
            InferenceSignals::LandDetector => "land detector and altitude",
        };
        write!(f, "inferred from {signals}")?;
        if let Some(a) = self.current_split_a {
            write!(f, "; idle/flying split at {a:.3} A")?;
        }
        if let Some(g) = self.ground_altitude_m {
            write!(f, "; ground at {g:.2} m")?;
        }
        if let Some(b) = self.band_m {
            write!(f, " ± {b:.2} m")?;
        }
        if let Some(v) = self.vertical_speed_threshold_m_s {
            write!(f, "; climb/descend beyond ±{v:.2} m/s")?;
        }
        write!(f, ";")?;
        for p in Phase::ALL {
            let x = self.fractions.get(p);
            if x > 0.0 {
                write!(f, " {p} {:.1} %", 100.0 * x)?;
            }
        }
        Ok(())
    }
}

/// Where a flight's phases come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[allow(
    clippy::large_enum_variant,
    reason = "one per flight; boxing would change the variant's public shape"
)]
pub enum PhaseSource {
    /// The log has a phase column.
    Logged,
    /// Inferred by this crate.
    Inferred {
        /// Signals, thresholds and resulting fractions.
        method: InferenceMethod,
        /// Caveats, in words.
        notes: Vec<String>,
    },
    /// No phases: the log has neither phases nor current nor altitude.
    None,
}

/// Signals available for inference, all on the flight's time base.
#[derive(Debug, Clone, Copy)]
pub struct Signals<'a> {
    /// Sample times, s (strictly increasing).
    pub time_s: &'a [f64],
    /// Battery current, A.
    pub current_a: Option<&'a [f64]>,
    /// Altitude, m.
    pub altitude_m: Option<&'a [f64]>,
    /// A land detector's verdict at each sample.
    pub landed: Option<&'a [bool]>,
}

/// Infers a phase for every sample, assuming the vehicle may perch and may be a VTOL
/// ([`Capabilities::all`]); see [`infer_for`].
pub fn infer(signals: Signals<'_>) -> Option<(Vec<Phase>, PhaseSource)> {
    infer_for(signals, &Capabilities::all())
}

/// Infers a phase for every sample of a vehicle with the given capabilities: `attached` only
/// for a robot that perches, `transition` only for a VTOL. Motors off (by current) away from
/// the ground on a vehicle that can do neither means the current has no idle level in the air,
/// so those samples are classified by vertical speed like any flying sample; an idle period
/// between flying periods without altitude is a landing. `None` when there is nothing to
/// infer from (no current, no altitude, no land detector) or the signals' lengths differ from
/// `time_s`.
pub fn infer_for(signals: Signals<'_>, caps: &Capabilities) -> Option<(Vec<Phase>, PhaseSource)> {
    infer_vtol(signals, caps, None)
}

/// [`infer_for`] with a VTOL autopilot's own state at each sample (`true`: in transition or
/// in fixed-wing flight, as PX4's `vtol_vehicle_status` says): for a VTOL, `transition` phases
/// then come from that state alone, not from the current.
pub fn infer_vtol(
    signals: Signals<'_>,
    caps: &Capabilities,
    vtol_transition: Option<&[bool]>,
) -> Option<(Vec<Phase>, PhaseSource)> {
    let n = signals.time_s.len();
    let fits = |len: Option<usize>| len.is_none_or(|l| l == n);
    if n == 0
        || !fits(signals.current_a.map(<[f64]>::len))
        || !fits(signals.altitude_m.map(<[f64]>::len))
        || !fits(signals.landed.map(<[bool]>::len))
        || !fits(vtol_transition.map(<[bool]>::len))
    {
        return None;
    }
    if signals.current_a.is_none() && signals.altitude_m.is_none() && signals.landed.is_none() {
        return None;
    }
    let t = signals.time_s;
    let mut notes = Vec::new();

    // Motors on/off from the current's two clusters.
    let mut split = None;
    let motors_on: Option<Vec<bool>> = signals.current_a.map(|current| {
        let smooth = moving_average(t, current, SMOOTHING_S);
        match two_clusters(&smooth) {
            Some(s) => {
                split = Some(s);
                smooth.iter().map(|&c| c > s.threshold).collect()
            }
            None => {
                notes.push(
                    "current has no separate idle level: the motors are taken to run throughout"
                        .to_owned(),
                );
                vec![true; n]
            }
        }
    });

    // Altitude: ground level, band, vertical speed.
    let mut altitude_info = None;
    let vertical: Option<(Vec<f64>, Vec<f64>)> = signals.altitude_m.map(|altitude| {
        // A log slower than 2.5 Hz (1 Hz lab logs, telemetry) would have one sample in the
        // window, and no slope: the window spans at least its neighbours.
        let window = SMOOTHING_S.max(2.5 * median_interval(t));
        let smooth = moving_average(t, altitude, window);
        let speed = slope(t, &smooth, window);
        let mut sorted: Vec<f64> = smooth.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let ground = percentile(&sorted, 0.01);
        let max = sorted.last().copied().unwrap_or(ground);
        let band = (0.05 * (max - ground)).max(MIN_GROUND_BAND_M);
        altitude_info = Some((ground, max, band));
        (smooth, speed)
    });

    let mut phases = Vec::with_capacity(n);
    let mut idle_airborne = 0usize;
    // Ground decided from altitude alone (motors on or unknown, no land detector): kept only in
    // runs that touch the start or the end of the log.
    let mut tentative = vec![false; n];
    for i in 0..n {
        let on = motors_on.as_ref().is_none_or(|m| m[i]);
        let landed = signals.landed.map(|l| l[i]);
        let phase = match (&vertical, altitude_info) {
            (Some((alt, speed)), Some((ground, max, band))) => {
                let near_ground = alt[i] <= ground + band;
                let near_ceiling = alt[i] >= max - band && max - band > ground + band;
                let still = speed[i].abs() <= VERTICAL_SPEED_THRESHOLD_M_S;
                let on_ground = landed.unwrap_or(near_ground && still);
                let by_speed = || {
                    if speed[i] > VERTICAL_SPEED_THRESHOLD_M_S {
                        Phase::Climb
                    } else if speed[i] < -VERTICAL_SPEED_THRESHOLD_M_S {
                        Phase::Descend
                    } else {
                        Phase::Hover
                    }
                };
                // Motors off: on the ground when the land detector says so, or without one when
                // either the smoothed or the raw altitude is near the ground.
                let raw_near_ground = signals.altitude_m.is_some_and(|a| a[i] <= ground + band);
                if !on {
                    if landed.unwrap_or(near_ground || raw_near_ground) {
                        Phase::Ground
                    } else if near_ceiling && caps.perches.is_some() {
                        Phase::Attached
                    } else if caps.vtol.is_some() && vtol_transition.is_none() {
                        Phase::Transition
                    } else if landed == Some(false) {
                        // The land detector says airborne: the current split is not motors
                        // on/off but low and high power in flight.
                        idle_airborne += 1;
                        by_speed()
                    } else {
                        // Neither perching nor a VTOL: motors off means on the ground, whatever
                        // a drifting altitude says.
                        Phase::Ground
                    }
                } else if on_ground {
                    tentative[i] = landed.is_none();
                    Phase::Ground
                } else if speed[i] > VERTICAL_SPEED_THRESHOLD_M_S {
                    Phase::Climb
                } else if speed[i] < -VERTICAL_SPEED_THRESHOLD_M_S {
                    Phase::Descend
                } else {
                    Phase::Hover
                }
            }
            _ => match landed {
                Some(true) => Phase::Ground,
                _ if on => Phase::Hover,
                // Motors off, no altitude: resolved by position below.
                _ => Phase::Transition,
            },
        };
        phases.push(phase);
    }

    let mut low_hovers = 0usize;
    let mut i = 0;
    while i < n {
        if !tentative[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && tentative[i] {
            i += 1;
        }
        if start > 0 && i < n {
            phases[start..i].fill(Phase::Hover);
            low_hovers += 1;
        }
    }
    if low_hovers > 0 {
        notes.push(format!(
            "{low_hovers} still period(s) near the ground level between flying periods taken as \
             low hover; with the motors running (or no current), a landing in between would \
             look the same"
        ));
    }

    if vertical.is_none() && motors_on.is_some() {
        // Current only: idle runs at the ends are ground, idle runs between flights attached.
        let mut i = 0;
        let mut mid_runs = 0usize;
        while i < n {
            if phases[i] != Phase::Transition {
                i += 1;
                continue;
            }
            let start = i;
            while i < n && phases[i] == Phase::Transition {
                i += 1;
            }
            let at_end = start == 0 || i == n;
            let fill = if at_end {
                Phase::Ground
            } else {
                mid_runs += 1;
                if caps.perches.is_some() {
                    Phase::Attached
                } else if caps.vtol.is_some() && vtol_transition.is_none() {
                    Phase::Transition
                } else {
                    Phase::Ground
                }
            };
            phases[start..i].fill(fill);
        }
        if mid_runs > 0 {
            let taken = if caps.perches.is_some() {
                "attached; without altitude a landing in between would look the same"
            } else if caps.vtol.is_some() && vtol_transition.is_none() {
                "transition (VTOL); without altitude a landing in between would look the same"
            } else {
                "landings (the vehicle does not perch, and is no VTOL or reports no transition)"
            };
            notes.push(format!(
                "{mid_runs} idle period(s) between flying periods taken as {taken}"
            ));
        }
    }
    if signals.landed.is_some() && vertical.is_none() {
        notes.push("no altitude: flying samples are all taken as hover".to_owned());
    }

    let signals_used = match (
        signals.landed.is_some(),
        signals.current_a.is_some(),
        signals.altitude_m.is_some(),
    ) {
        (true, _, _) => InferenceSignals::LandDetector,
        (false, true, true) => InferenceSignals::CurrentAndAltitude,
        (false, true, false) => InferenceSignals::Current,
        (false, false, _) => InferenceSignals::Altitude,
    };
    if signals.current_a.is_none() {
        notes.push("no current: attachment to the ceiling cannot be detected".to_owned());
    }
    let vtol_state = vtol_transition.filter(|_| caps.vtol.is_some());
    if let Some(vt) = vtol_state {
        for (p, &t) in phases.iter_mut().zip(vt) {
            if t && *p != Phase::Ground {
                *p = Phase::Transition;
            }
        }
    }
    if idle_airborne > 0 {
        let vehicle = if caps.vtol.is_some() {
            "the vehicle does not perch and its VTOL state says no transition"
        } else {
            "the vehicle neither perches nor is a VTOL"
        };
        notes.push(format!(
            "{idle_airborne} sample(s) with current below the idle/flying split where the land \
             detector says airborne classified by vertical speed: {vehicle}, so low current in \
             the air is low-power flight, not motors off"
        ));
    }
    let fractions = PhaseFractions::of(&phases);
    let evidence = evidence(
        &fractions,
        caps,
        signals_used,
        split.map(|s| s.threshold),
        altitude_info,
        idle_airborne > 0,
        vtol_state.is_some(),
    );
    let method = InferenceMethod {
        evidence,
        signals: signals_used,
        current_split_a: split.map(|s| s.threshold),
        idle_current_a: split.map(|s| s.low_mean),
        flying_current_a: split.map(|s| s.high_mean),
        ground_altitude_m: altitude_info.map(|a| a.0),
        max_altitude_m: altitude_info.map(|a| a.1),
        band_m: altitude_info.map(|a| a.2),
        vertical_speed_threshold_m_s: vertical.as_ref().map(|_| VERTICAL_SPEED_THRESHOLD_M_S),
        smoothing_s: SMOOTHING_S,
        fractions,
    };
    Some((phases, PhaseSource::Inferred { method, notes }))
}

/// What put samples in each phase found, in words.
fn evidence(
    fractions: &PhaseFractions,
    caps: &Capabilities,
    signals: InferenceSignals,
    split_a: Option<f64>,
    altitude: Option<(f64, f64, f64)>,
    idle_airborne: bool,
    vtol_state: bool,
) -> Vec<PhaseEvidence> {
    let motors = match split_a {
        Some(a) => format!("current above {a:.2} A (motors on)"),
        None if signals == InferenceSignals::Altitude => "no current".to_owned(),
        None => "current with no idle level (motors taken on)".to_owned(),
    };
    let idle = split_a.map_or_else(
        || "motors off".to_owned(),
        |a| format!("current below {a:.2} A (motors off)"),
    );
    let ground = match (signals, altitude) {
        (InferenceSignals::LandDetector, _) => "the land detector says landed".to_owned(),
        (_, Some((g, _, band))) => {
            format!(
                "altitude within {band:.2} m of the ground level {g:.2} m, at the log's start or end"
            )
        }
        (_, None) => format!("{idle} in a period at the log's start or end"),
    };
    let speed = |what: &str| {
        if altitude.is_some() {
            let low = if idle_airborne {
                ", or below it where the land detector says airborne (low-power flight)"
            } else {
                ""
            };
            format!("{motors}{low}; vertical speed {what}")
        } else {
            format!("{motors}; no altitude, so all flight is taken as hover")
        }
    };
    let vt = VERTICAL_SPEED_THRESHOLD_M_S;
    let ground = if split_a.is_some()
        && caps.perches.is_none()
        && caps.vtol.is_none()
        && signals != InferenceSignals::LandDetector
    {
        format!("{ground}; or {idle} (neither perching nor a VTOL: motors off is on the ground)")
    } else {
        ground
    };
    Phase::ALL
        .iter()
        .filter(|&&p| fractions.get(p) > 0.0)
        .map(|&phase| PhaseEvidence {
            phase,
            fraction: fractions.get(phase),
            evidence: match phase {
                Phase::Ground => ground.clone(),
                Phase::Hover => speed(&format!("within ±{vt} m/s")),
                Phase::Climb => speed(&format!("above {vt} m/s")),
                Phase::Descend => speed(&format!("below −{vt} m/s")),
                Phase::Attached => format!(
                    "{idle} at the highest plateau (or between flying periods); the robot \
                     perches ({})",
                    caps.perches.as_deref().unwrap_or("")
                ),
                Phase::Transition if vtol_state => format!(
                    "the autopilot's vtol_vehicle_status says transition or fixed-wing flight; \
                     the vehicle is a VTOL ({})",
                    caps.vtol.as_deref().unwrap_or("")
                ),
                Phase::Transition => format!(
                    "{idle} away from the ground; the vehicle is a VTOL ({})",
                    caps.vtol.as_deref().unwrap_or("")
                ),
            },
        })
        .collect()
}

/// An accepted two-cluster split of a signal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split {
    /// Values above this are the high cluster.
    pub threshold: f64,
    /// Mean of the low cluster.
    pub low_mean: f64,
    /// Mean of the high cluster.
    pub high_mean: f64,
}

/// Otsu's two-cluster split of `values`, if the clusters are well apart (see the module docs).
pub fn two_clusters(values: &[f64]) -> Option<Split> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 4 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    // Prefix sums for O(n) scanning of every split point.
    let mut sum = Vec::with_capacity(n + 1);
    let mut sum2 = Vec::with_capacity(n + 1);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    sum.push(0.0);
    sum2.push(0.0);
    for &x in &v {
        s += x;
        s2 += x * x;
        sum.push(s);
        sum2.push(s2);
    }
    let total = s;
    let mut best: Option<(f64, usize)> = None;
    for k in 1..n {
        if v[k] <= v[k - 1] {
            continue; // split only between distinct values
        }
        let (n0, n1) = (k as f64, (n - k) as f64);
        let m0 = sum[k] / n0;
        let m1 = (total - sum[k]) / n1;
        let between = n0 * n1 * (m1 - m0) * (m1 - m0);
        if best.is_none_or(|(b, _)| between > b) {
            best = Some((between, k));
        }
    }
    let (_, k) = best?;
    let (n0, n1) = (k as f64, (n - k) as f64);
    let m0 = sum[k] / n0;
    let m1 = (total - sum[k]) / n1;
    let var0 = (sum2[k] / n0 - m0 * m0).max(0.0);
    let var1 = ((sum2[n] - sum2[k]) / n1 - m1 * m1).max(0.0);
    let pooled = ((var0 + var1) / 2.0).sqrt();
    let separated = m1 - m0 >= MIN_SEPARATION * pooled;
    let idle_like = m0 < 0.5 * m1 && m1 > 0.0;
    let big_enough = n0 >= 0.01 * n as f64 && n1 >= 0.01 * n as f64;
    (separated && idle_like && big_enough).then_some(Split {
        threshold: 0.5 * (v[k - 1] + v[k]),
        low_mean: m0,
        high_mean: m1,
    })
}

/// Centred moving average over a time window (samples within ±window/2), O(n).
pub fn moving_average(time_s: &[f64], values: &[f64], window_s: f64) -> Vec<f64> {
    let n = values.len().min(time_s.len());
    let half = window_s / 2.0;
    let mut out = Vec::with_capacity(n);
    let (mut lo, mut hi) = (0usize, 0usize);
    let mut acc = 0.0f64;
    let mut count = 0usize;
    for i in 0..n {
        while hi < n && time_s[hi] <= time_s[i] + half {
            if values[hi].is_finite() {
                acc += values[hi];
                count += 1;
            }
            hi += 1;
        }
        while lo < hi && time_s[lo] < time_s[i] - half {
            if values[lo].is_finite() {
                acc -= values[lo];
                count -= 1;
            }
            lo += 1;
        }
        out.push(if count > 0 {
            acc / count as f64
        } else {
            values[i]
        });
    }
    out
}

/// Median interval between samples, s (0 with fewer than two).
fn median_interval(time_s: &[f64]) -> f64 {
    let mut d: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// Slope of `values` over a window centred on each sample, per second; 0 where the window has
/// no time span.
pub fn slope(time_s: &[f64], values: &[f64], window_s: f64) -> Vec<f64> {
    let n = values.len().min(time_s.len());
    let half = window_s / 2.0;
    let (mut lo, mut hi) = (0usize, 0usize);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        while lo < i && time_s[lo] < time_s[i] - half {
            lo += 1;
        }
        if hi < i {
            hi = i;
        }
        while hi + 1 < n && time_s[hi + 1] <= time_s[i] + half {
            hi += 1;
        }
        let dt = time_s[hi] - time_s[lo];
        out.push(if dt > 0.0 {
            (values[hi] - values[lo]) / dt
        } else {
            0.0
        });
    }
    out
}

/// The `q`-quantile (0–1) of sorted values, nearest rank; 0 when empty.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn time(n: usize, rate_hz: f64) -> Vec<f64> {
        (0..n).map(|i| i as f64 / rate_hz).collect()
    }

    #[test]
    fn two_clusters_finds_idle_and_flying() {
        let mut v = vec![0.2; 100];
        v.extend(vec![8.0; 300]);
        let s = two_clusters(&v).unwrap();
        assert!(s.threshold > 0.2 && s.threshold < 8.0);
        assert!((s.low_mean - 0.2).abs() < 1e-12 && (s.high_mean - 8.0).abs() < 1e-12);
        // One level with noise: no split.
        let noisy: Vec<f64> = (0..400)
            .map(|i| 8.0 + 0.1 * ((i * 7919) % 13) as f64)
            .collect();
        assert!(two_clusters(&noisy).is_none());
    }

    #[test]
    fn a_one_hertz_log_climbs_hovers_and_descends_as_its_altitude_says() {
        // 1 Hz: 10 s on the ground, a climb at 1 m/s for 30 s, 30 s of hover, a descent.
        let t = time(110, 1.0);
        let alt: Vec<f64> = (0..110)
            .map(|k| match k {
                0..10 => 0.0,
                10..40 => (k - 10) as f64,
                40..70 => 30.0,
                70..100 => 30.0 - (k - 70) as f64,
                _ => 0.0,
            })
            .collect();
        let i: Vec<f64> = (0..110)
            .map(|k| if (10..100).contains(&k) { 9.0 } else { 0.3 })
            .collect();
        let (phases, _) = infer(Signals {
            time_s: &t,
            current_a: Some(&i),
            altitude_m: Some(&alt),
            landed: None,
        })
        .unwrap();
        assert_eq!(
            [phases[3], phases[25], phases[55], phases[85], phases[106]],
            [
                Phase::Ground,
                Phase::Climb,
                Phase::Hover,
                Phase::Descend,
                Phase::Ground
            ]
        );
    }

    #[test]
    fn current_only_ground_at_ends_attached_between() {
        // 10 Hz: ground 5 s, hover 10 s, attached 10 s, hover 10 s, ground 5 s.
        let t = time(400, 10.0);
        let i: Vec<f64> = (0..400)
            .map(|k| match k {
                0..50 | 350.. => 0.3,
                150..250 => 0.3,
                _ => 9.0,
            })
            .collect();
        let (phases, source) = infer(Signals {
            time_s: &t,
            current_a: Some(&i),
            altitude_m: None,
            landed: None,
        })
        .unwrap();
        assert_eq!(phases[10], Phase::Ground);
        assert_eq!(phases[100], Phase::Hover);
        assert_eq!(phases[200], Phase::Attached);
        assert_eq!(phases[390], Phase::Ground);
        let PhaseSource::Inferred { method, notes } = source else {
            panic!()
        };
        assert_eq!(method.signals, InferenceSignals::Current);
        assert!(method.fractions.attached > 0.2 && method.fractions.attached < 0.3);
        assert!(!notes.is_empty());
    }

    #[test]
    fn altitude_and_current_profile() {
        // 20 Hz: ground 5 s, climb 2 s to 2 m (1 m/s), hover 10 s, climb 1 s to 2.5 m and attach
        // 20 s (motors off), descend 5 s to 0, ground 5 s.
        let rate = 20.0;
        let mut alt = Vec::new();
        let mut cur = Vec::new();
        let mut push = |secs: f64, f: &dyn Fn(f64) -> (f64, f64)| {
            let k = (secs * rate) as usize;
            for j in 0..k {
                let (a, c) = f(j as f64 / rate);
                alt.push(a);
                cur.push(c);
            }
        };
        push(5.0, &|_| (0.0, 0.2));
        push(2.0, &|s| (s, 10.0));
        push(10.0, &|_| (2.0, 9.0));
        push(1.0, &|s| (2.0 + 0.5 * s, 9.5));
        push(20.0, &|_| (2.5, 0.25));
        push(5.0, &|s| (2.5 - 0.5 * s, 8.5));
        push(5.0, &|_| (0.0, 0.2));
        let t = time(alt.len(), rate);
        let (phases, source) = infer(Signals {
            time_s: &t,
            current_a: Some(&cur),
            altitude_m: Some(&alt),
            landed: None,
        })
        .unwrap();
        let at = |s: f64| phases[(s * rate) as usize];
        assert_eq!(at(2.0), Phase::Ground);
        assert_eq!(at(6.0), Phase::Climb);
        assert_eq!(at(12.0), Phase::Hover);
        assert_eq!(at(28.0), Phase::Attached);
        assert_eq!(at(41.0), Phase::Descend);
        assert_eq!(at(46.0), Phase::Ground);
        let PhaseSource::Inferred { method, .. } = source else {
            panic!()
        };
        assert_eq!(method.signals, InferenceSignals::CurrentAndAltitude);
        let total: f64 = Phase::ALL.iter().map(|&p| method.fractions.get(p)).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert!(method.to_string().contains("attached"));
    }

    #[test]
    fn altitude_only_ground_at_the_ends_low_hover_between() {
        // 10 Hz: ground 3 s, up to 1 m and back (4 s), still at ground level 3 s, up and back
        // (4 s), ground 3 s.
        let peak = |k: usize, start: usize| 1.0 - (k as f64 - start as f64 - 20.0).abs() / 20.0;
        let alt: Vec<f64> = (0..170)
            .map(|k| match k {
                30..70 => peak(k, 30),
                100..140 => peak(k, 100),
                _ => 0.0,
            })
            .collect();
        let t = time(alt.len(), 10.0);
        let (phases, source) = infer(Signals {
            time_s: &t,
            current_a: None,
            altitude_m: Some(&alt),
            landed: None,
        })
        .unwrap();
        assert_eq!(phases[10], Phase::Ground);
        assert_eq!(phases[85], Phase::Hover);
        assert_eq!(phases[160], Phase::Ground);
        let PhaseSource::Inferred { notes, .. } = source else {
            panic!()
        };
        assert!(notes.iter().any(|n| n.contains("low hover")), "{notes:?}");
    }

    #[test]
    fn transition_only_for_a_vtol_and_from_its_own_state_when_logged() {
        // 10 Hz, current only: idle 5 s, flying 10 s, idle 10 s (in the air or landed?),
        // flying 10 s, idle 5 s.
        let t = time(400, 10.0);
        let i: Vec<f64> = (0..400)
            .map(|k| match k {
                0..50 | 150..250 | 350.. => 0.3,
                _ => 9.0,
            })
            .collect();
        let signals = Signals {
            time_s: &t,
            current_a: Some(&i),
            altitude_m: None,
            landed: None,
        };
        let quad = Capabilities::default();
        let (phases, _) = infer_for(signals, &quad).unwrap();
        assert!(!phases.contains(&Phase::Transition) && !phases.contains(&Phase::Attached));
        assert_eq!(phases[200], Phase::Ground); // a landing, not a perch
        let vtol = Capabilities {
            vtol: Some("MAV_TYPE 22".to_owned()),
            ..Capabilities::default()
        };
        let (phases, source) = infer_for(signals, &vtol).unwrap();
        assert_eq!(phases[200], Phase::Transition);
        let PhaseSource::Inferred { method, .. } = source else {
            panic!()
        };
        let e = method
            .evidence
            .iter()
            .find(|e| e.phase == Phase::Transition)
            .unwrap();
        assert!(e.evidence.contains("MAV_TYPE 22"), "{e:?}");
        // The autopilot's own VTOL state says transition at 10–12 s only.
        let state: Vec<bool> = (0..400).map(|k| (100..120).contains(&k)).collect();
        let (phases, _) = infer_vtol(signals, &vtol, Some(&state)).unwrap();
        assert_eq!(phases[110], Phase::Transition);
        assert_ne!(phases[200], Phase::Transition);
        assert_eq!(
            phases.iter().filter(|&&p| p == Phase::Transition).count(),
            20
        );
    }

    #[test]
    fn nothing_to_infer_from() {
        let t = time(10, 1.0);
        assert!(
            infer(Signals {
                time_s: &t,
                current_a: None,
                altitude_m: None,
                landed: None,
            })
            .is_none()
        );
        let short = [1.0];
        assert!(
            infer(Signals {
                time_s: &t,
                current_a: Some(&short),
                altitude_m: None,
                landed: None,
            })
            .is_none()
        );
    }
}
