//! Missions (the paper's section III-B, Table I): a plan of hover and ceiling-attached segments,
//! with energy used, energy left and reserved endurance `t_R` (eq. 9) at the end of each.

use crate::EstimateError;
use crate::curve::{PowerCurve, require_finite, require_non_negative};
use crate::model::{Battery, Eq8Form, Estimate, MIN_PER_H, Model, Payload};

/// One segment of a mission plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// Hover for a duration, minutes.
    Hover {
        /// Duration, minutes.
        duration_min: f64,
    },
    /// Attached to the ceiling, motors off, for a duration, minutes.
    Attached {
        /// Duration, minutes.
        duration_min: f64,
    },
    /// Hover until the energy left falls to a fraction of the battery's.
    HoverUntilReserve {
        /// Fraction of `c_B` to keep, 0..1.
        reserve_fraction: f64,
    },
    /// Stay attached until the energy left falls to a fraction of the battery's.
    AttachedUntilReserve {
        /// Fraction of `c_B` to keep, 0..1.
        reserve_fraction: f64,
    },
    /// Hover until the battery is empty (or down to the mission's reserve floor).
    HoverUntilEmpty,
}

impl Segment {
    /// True for segments flown on the rotors.
    pub fn is_hover(&self) -> bool {
        matches!(
            self,
            Self::Hover { .. } | Self::HoverUntilReserve { .. } | Self::HoverUntilEmpty
        )
    }

    pub(crate) fn validate(&self) -> Result<(), EstimateError> {
        match *self {
            Self::Hover { duration_min } | Self::Attached { duration_min } => {
                require_non_negative("segment duration (min)", duration_min)?;
            }
            Self::HoverUntilReserve { reserve_fraction }
            | Self::AttachedUntilReserve { reserve_fraction } => {
                require_finite("reserve fraction", reserve_fraction)?;
                if !(0.0..1.0).contains(&reserve_fraction) {
                    return Err(EstimateError::ReserveFraction {
                        value: reserve_fraction,
                    });
                }
            }
            Self::HoverUntilEmpty => {}
        }
        Ok(())
    }
}

/// How a mission is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MissionOptions {
    /// Form of eq. (8); the consistent form unless the printed one is asked for.
    pub eq8: Eq8Form,
    /// A floor the plan must not go below, as a fraction of `c_B` (0 = run to empty).
    pub reserve_floor_fraction: f64,
}

/// What one segment did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentOutcome {
    /// The planned segment.
    pub segment: Segment,
    /// Mission time when it started, minutes.
    pub start_min: f64,
    /// How long it lasted, minutes (shorter than planned if the battery ran out).
    pub duration_min: f64,
    /// Energy it used, Wh.
    pub energy_used_wh: f64,
    /// Energy left at its end, Wh.
    pub energy_left_wh: f64,
    /// `r_Ep` at its end (eq. 8): the fraction of `c_B` left.
    pub post_ceiling_ratio: f64,
    /// `t_R` at its end (eq. 9): how long the robot could still hover, minutes.
    pub reserved_endurance_min: f64,
}

impl SegmentOutcome {
    /// A placeholder to fill an output buffer with before evaluating a mission.
    pub const EMPTY: Self = Self {
        segment: Segment::HoverUntilEmpty,
        start_min: 0.0,
        duration_min: 0.0,
        energy_used_wh: 0.0,
        energy_left_wh: 0.0,
        post_ceiling_ratio: 0.0,
        reserved_endurance_min: 0.0,
    };
}

/// Where and when a plan ran out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Depletion {
    /// Index of the segment during which it happened.
    pub segment_index: usize,
    /// Mission time when it happened, minutes.
    pub at_min: f64,
    /// True when it hit the mission's reserve floor rather than empty.
    pub hit_reserve_floor: bool,
}

/// Totals of an evaluated mission.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MissionSummary {
    /// Total mission time, minutes.
    pub total_min: f64,
    /// Time flown on the rotors (`t_F`), minutes.
    pub flight_min: f64,
    /// Time attached (`t_A`), minutes.
    pub attached_min: f64,
    /// Energy left at the end, Wh.
    pub energy_left_wh: f64,
    /// Set when the plan ran the battery below zero or below the reserve floor.
    pub depletion: Option<Depletion>,
    /// Number of segments evaluated (all of them unless the battery ran out).
    pub segments_evaluated: usize,
    /// The hover estimate (eqs. 1–6) the mission is built on.
    pub estimate: Estimate,
}

impl<C: PowerCurve> Model<C> {
    /// Evaluates a mission plan, writing one outcome per segment into `out` (which must be at
    /// least as long as `plan`). Does not allocate.
    ///
    /// Hover spends `p_M + p_I`; attached spends `p_I` in the consistent form of eq. (8), or
    /// `t_E · t_A / t_C` of the battery (times in hours) in the printed form. A segment that
    /// would go below zero or below the reserve floor is cut where that happens and the plan
    /// stops there, reported in [`MissionSummary::depletion`].
    pub fn evaluate_mission(
        &self,
        battery: &Battery,
        payload: &Payload,
        plan: &[Segment],
        options: &MissionOptions,
        out: &mut [SegmentOutcome],
    ) -> Result<MissionSummary, EstimateError> {
        if out.len() < plan.len() {
            return Err(EstimateError::OutputTooShort {
                needed: plan.len(),
                given: out.len(),
            });
        }
        let floor = options.reserve_floor_fraction;
        require_finite("reserve floor fraction", floor)?;
        if !(0.0..1.0).contains(&floor) {
            return Err(EstimateError::ReserveFraction { value: floor });
        }
        for s in plan {
            s.validate()?;
        }
        let est = self.estimate(battery, payload)?;
        let c_b = est.battery_energy_wh;
        let hover_w = est.motor_power_w + est.idle_power_w;
        // Energy fraction of the battery spent per attached minute, from eq. (8).
        let attached_per_min =
            options
                .eq8
                .attached_fraction(1.0, est.endurance_min, est.ceiling_endurance_min)
                * c_b;
        let hover_per_min = hover_w / MIN_PER_H;
        let floor_wh = floor * c_b;

        let mut t = 0.0;
        let mut flight = 0.0;
        let mut attached = 0.0;
        let mut left = c_b;
        let mut depletion = None;
        let mut evaluated = 0;
        for (i, seg) in plan.iter().enumerate() {
            let (per_min, wanted_min, target_wh) = match *seg {
                Segment::Hover { duration_min } => (hover_per_min, Some(duration_min), floor_wh),
                Segment::Attached { duration_min } => {
                    (attached_per_min, Some(duration_min), floor_wh)
                }
                Segment::HoverUntilReserve { reserve_fraction } => {
                    (hover_per_min, None, reserve_fraction * c_b)
                }
                Segment::AttachedUntilReserve { reserve_fraction } => {
                    (attached_per_min, None, reserve_fraction * c_b)
                }
                Segment::HoverUntilEmpty => (hover_per_min, None, floor_wh),
            };
            let available_min = ((left - target_wh) / per_min).max(0.0);
            let (duration, ran_out) = match wanted_min {
                Some(d) if d <= available_min => (d, false),
                Some(_) => (available_min, true),
                // "until" segments stop at their target; below the floor counts as running out.
                None => (available_min, target_wh < floor_wh),
            };
            let used = duration * per_min;
            let start = t;
            t += duration;
            left -= used;
            if seg.is_hover() {
                flight += duration;
            } else {
                attached += duration;
            }
            let r_ep = left / c_b;
            out[i] = SegmentOutcome {
                segment: *seg,
                start_min: start,
                duration_min: duration,
                energy_used_wh: used,
                energy_left_wh: left,
                post_ceiling_ratio: r_ep,
                reserved_endurance_min: left / hover_w * MIN_PER_H,
            };
            evaluated = i + 1;
            if ran_out {
                depletion = Some(Depletion {
                    segment_index: i,
                    at_min: t,
                    hit_reserve_floor: floor_wh > 0.0,
                });
                break;
            }
        }
        Ok(MissionSummary {
            total_min: t,
            flight_min: flight,
            attached_min: attached,
            energy_left_wh: left,
            depletion,
            segments_evaluated: evaluated,
            estimate: est,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curve::FnCurve;
    use crate::model::{Platform, post_ceiling_ratio, reserve_ratio, reserved_endurance_min};

    fn model() -> Model<FnCurve<impl Fn(f64) -> f64>> {
        Model::new(
            FnCurve::new(|t: f64| 0.12 * t, (0.0, 300.0)),
            Platform {
                structure_mass_kg: 0.431,
                avionics_power_w: 2.44,
                rotor_count: 4,
            },
        )
    }

    const TABLE_I: [Segment; 7] = [
        Segment::Hover { duration_min: 2.0 },
        Segment::Attached { duration_min: 30.0 },
        Segment::Hover { duration_min: 2.0 },
        Segment::Attached { duration_min: 30.0 },
        Segment::Hover { duration_min: 2.0 },
        Segment::Attached { duration_min: 30.0 },
        Segment::HoverUntilEmpty,
    ];

    #[test]
    fn mission_matches_closed_form_eqs_7_to_9_in_both_forms() {
        let m = model();
        let b = Battery::from_density(0.144, 164.0).unwrap();
        for form in [Eq8Form::Consistent, Eq8Form::PrintedHours] {
            let mut out = [SegmentOutcome::EMPTY; 7];
            let opts = MissionOptions {
                eq8: form,
                ..Default::default()
            };
            let s = m
                .evaluate_mission(&b, &Payload::default(), &TABLE_I, &opts, &mut out)
                .unwrap();
            let e = s.estimate;
            let r_e = reserve_ratio(e.endurance_min, 6.0);
            let r_ep =
                post_ceiling_ratio(form, r_e, e.endurance_min, 90.0, e.ceiling_endurance_min);
            let t_r =
                reserved_endurance_min(e.battery_energy_wh, r_ep, e.motor_power_w, e.idle_power_w);
            assert!((out[5].reserved_endurance_min - t_r).abs() < 1e-9);
            assert!((s.total_min - (96.0 + t_r)).abs() < 1e-9);
            assert!(s.energy_left_wh.abs() < 1e-9);
            assert_eq!(s.segments_evaluated, 7);
            assert!(s.depletion.is_none());
        }
    }

    #[test]
    fn running_out_reports_segment_and_minute() {
        let m = model();
        let b = Battery::from_density(0.05, 164.0).unwrap();
        let plan = [
            Segment::Hover { duration_min: 2.0 },
            Segment::Hover {
                duration_min: 100.0,
            },
            Segment::Attached { duration_min: 1.0 },
        ];
        let mut out = [SegmentOutcome::EMPTY; 3];
        let s = m
            .evaluate_mission(
                &b,
                &Payload::default(),
                &plan,
                &MissionOptions::default(),
                &mut out,
            )
            .unwrap();
        let d = s.depletion.unwrap();
        assert_eq!(d.segment_index, 1);
        assert!((d.at_min - s.estimate.endurance_min).abs() < 1e-9);
        assert_eq!(s.segments_evaluated, 2);
        assert!(!d.hit_reserve_floor);
    }

    #[test]
    fn reserve_floor_stops_the_plan_early() {
        let m = model();
        let b = Battery::from_density(0.144, 164.0).unwrap();
        let plan = [Segment::HoverUntilEmpty];
        let mut out = [SegmentOutcome::EMPTY; 1];
        let opts = MissionOptions {
            reserve_floor_fraction: 0.2,
            ..Default::default()
        };
        let s = m
            .evaluate_mission(&b, &Payload::default(), &plan, &opts, &mut out)
            .unwrap();
        assert!((s.total_min - 0.8 * s.estimate.endurance_min).abs() < 1e-9);
        assert!((out[0].post_ceiling_ratio - 0.2).abs() < 1e-12);
    }
}
