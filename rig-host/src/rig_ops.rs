//! Rig operations outside a sweep's steps: bring the rig to a clean `Disarmed`
//! ([`disarm_clean`]), keep the link alive while waiting ([`idle`]), and calibrate the load
//! cell with known masses ([`calibrate`], [`MassPlacer`]).

use rig_protocol::{Clock, Rig, RigState};

use crate::error::{HostError, LinkError, rig_err};

/// Things that must be known to place masses on the load cell during a calibration.
pub trait MassPlacer {
    /// Puts `mass_g` on the load cell (0: removes everything) and returns when it is there.
    fn place(&mut self, mass_g: f64) -> Result<(), HostError>;
}

/// Brings the rig to `Disarmed` whatever its state (a latched fault, for instance the host
/// timeout left by a host that was killed, is cleared by re-arming, then disarmed); returns
/// the faults that were latched.
pub fn disarm_clean<R: Rig>(rig: &mut R) -> Result<rig_protocol::FaultSet, HostError>
where
    R::Error: LinkError,
{
    let st = rig.status().map_err(rig_err("status"))?;
    if st.state == RigState::Faulted {
        rig.arm()
            .map_err(rig_err("re-arm to clear a latched fault"))?;
    }
    if st.state != RigState::Disarmed {
        rig.disarm().map_err(rig_err("disarm"))?;
    }
    while rig.take_fault().map_err(rig_err("fault check"))?.is_some() {}
    Ok(if st.state == RigState::Faulted {
        st.faults
    } else {
        rig_protocol::FaultSet::EMPTY
    })
}

/// Waits `seconds` of rig time while keeping the link alive.
pub fn idle<R: Rig>(rig: &mut R, clock: &dyn Clock, seconds: f64) -> Result<(), HostError>
where
    R::Error: LinkError,
{
    let end = clock.now_us() + (seconds * 1e6) as u64;
    while clock.now_us() < end {
        rig.next_sample().map_err(rig_err("idle"))?;
    }
    Ok(())
}

/// Tares, then calibrates the load cell with known masses (0, then each of `masses_g`);
/// returns the calibration and a description for the log.
pub fn calibrate<R: Rig>(
    rig: &mut R,
    clock: &dyn Clock,
    masses_g: &[f64],
    placer: &mut dyn MassPlacer,
    tare_samples: u16,
) -> Result<(rig_protocol::Calibration, String), HostError>
where
    R::Error: LinkError,
{
    disarm_clean(rig)?;
    placer.place(0.0)?;
    idle(rig, clock, 0.5)?;
    rig.tare(tare_samples).map_err(rig_err("tare"))?;
    let mut cal = None;
    for &m in masses_g {
        placer.place(m)?;
        idle(rig, clock, 0.5)?;
        cal = Some(rig.calibrate(m as f32).map_err(rig_err("calibrate"))?);
    }
    placer.place(0.0)?;
    idle(rig, clock, 0.5)?;
    let cal =
        cal.ok_or_else(|| HostError::Invalid("calibration needs at least one mass".into()))?;
    let text = format!(
        "{} points ({} g), {:.7} g/count",
        cal.points,
        masses_g
            .iter()
            .map(|m| format!("{m}"))
            .collect::<Vec<_>>()
            .join(", "),
        cal.scale_g_per_count
    );
    Ok((cal, text))
}
