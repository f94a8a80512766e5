//! Load-cell zero and scale: tare from a mean of readings, scale from a multi-point
//! calibration with known masses (least squares through the tared zero).

use heapless::Vec;

/// Most calibration points kept.
pub const MAX_POINTS: usize = 8;

/// Zero offset and scale of a load cell.
#[derive(Debug, Clone)]
pub struct LoadCell {
    offset_counts: i32,
    tared: bool,
    scale_g_per_count: f32,
    /// (net counts, known mass g)
    points: Vec<(f32, f32), MAX_POINTS>,
}

/// Adding a calibration point failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CalibrationError {
    /// No tare yet.
    #[error("calibration needs a tare first")]
    NotTared,
    /// Mass not finite or not positive, or the reading did not move from zero.
    #[error(
        "calibration point rejected: mass must be positive and the reading must differ from zero"
    )]
    BadPoint,
}

impl LoadCell {
    /// A load cell with a nominal scale (until calibrated) and no tare.
    pub fn new(nominal_scale_g_per_count: f32) -> Self {
        Self {
            offset_counts: 0,
            tared: false,
            scale_g_per_count: nominal_scale_g_per_count,
            points: Vec::new(),
        }
    }

    /// Sets the zero from the mean of readings; clears calibration points.
    pub fn tare(&mut self, mean_counts: i32) {
        self.offset_counts = mean_counts;
        self.tared = true;
        self.points.clear();
    }

    /// Whether a tare has been done.
    pub fn is_tared(&self) -> bool {
        self.tared
    }

    /// The zero, counts.
    pub fn offset_counts(&self) -> i32 {
        self.offset_counts
    }

    /// The scale, g per count.
    pub fn scale_g_per_count(&self) -> f32 {
        self.scale_g_per_count
    }

    /// Calibration points collected since the last tare.
    pub fn points(&self) -> usize {
        self.points.len()
    }

    /// Adds a point (mean raw reading with `mass_g` on the cell) and refits the scale by least
    /// squares through the zero: `scale = Σ mᵢcᵢ / Σ cᵢ²`. With more than [`MAX_POINTS`]
    /// points the oldest is dropped.
    pub fn add_point(
        &mut self,
        mean_raw_counts: f32,
        mass_g: f32,
    ) -> Result<f32, CalibrationError> {
        if !self.tared {
            return Err(CalibrationError::NotTared);
        }
        let net = mean_raw_counts - self.offset_counts as f32;
        if !(mass_g.is_finite() && mass_g > 0.0 && net.is_finite() && libm::fabsf(net) >= 1.0) {
            return Err(CalibrationError::BadPoint);
        }
        if self.points.is_full() {
            self.points.remove(0);
        }
        let _ = self.points.push((net, mass_g));
        let (mut smc, mut scc) = (0.0f64, 0.0f64);
        for &(c, m) in &self.points {
            smc += f64::from(m) * f64::from(c);
            scc += f64::from(c) * f64::from(c);
        }
        self.scale_g_per_count = (smc / scc) as f32;
        Ok(self.scale_g_per_count)
    }

    /// Grams for a raw reading.
    pub fn grams(&self, raw_counts: i32) -> f32 {
        (raw_counts.wrapping_sub(self.offset_counts)) as f32 * self.scale_g_per_count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multi_point_least_squares() {
        let mut lc = LoadCell::new(1.0);
        assert_eq!(lc.add_point(100.0, 10.0), Err(CalibrationError::NotTared));
        lc.tare(8000);
        // true scale 0.01 g/count, readings with ±1 count error
        lc.add_point(8000.0 + 10_001.0, 100.0).unwrap();
        lc.add_point(8000.0 + 19_999.0, 200.0).unwrap();
        let k = lc.add_point(8000.0 + 50_000.0, 500.0).unwrap();
        assert!((k - 0.01).abs() < 1e-6, "{k}");
        assert!((lc.grams(8000 + 25_000) - 250.0).abs() < 0.01);
        assert_eq!(lc.add_point(8000.0, 10.0), Err(CalibrationError::BadPoint));
        assert_eq!(
            lc.add_point(9000.0, f32::NAN),
            Err(CalibrationError::BadPoint)
        );
        lc.tare(0);
        assert_eq!(lc.points(), 0);
    }
}
