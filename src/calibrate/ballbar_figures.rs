//! A fit-file entry that gives a circular test's ballbar diagnostics as a ballbar's software
//! reports them (squareness, scale mismatch, backlash), instead of its radial deviation:
//!
//! ```toml
//! [[ballbar]]
//! plane = "XY"
//! radius_mm = 150.0
//! squareness_urad = 21.3
//! scale_mismatch_ppm = -4.0      # optional
//! backlash_um = [2.0, 1.5]       # optional, first and second axis of the plane
//! ```
//!
//! The fit predicts the same circle (360 points, the entry's centre, direction and pose) on the
//! machine, takes its diagnostics ([`crate::standards::ballbar`]), and uses each figure given as
//! a reading: measured minus predicted, as the amplitude it draws in the radial deviation (mm),
//! so that figures and curves weigh alike: a squareness `α` draws `α·r/2`, a scale mismatch `k`
//! draws `k·r/2`, a backlash `β` draws `β/2`.

use serde::Deserialize;

use crate::standards::{circular, CircularSpec, Setup, StandardsError, TestResult};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallbarFigures {
    /// XY, YZ or ZX.
    pub plane: String,
    /// Default: the middle of the travels.
    pub centre_mm: Option<[f64; 3]>,
    pub radius_mm: f64,
    /// `ccw` or `cw`.
    #[serde(default = "default_direction")]
    pub direction: String,
    #[serde(default)]
    pub pose: String,
    /// The angle between the plane's first and second axes minus 90°, µrad.
    pub squareness_urad: Option<f64>,
    /// The first axis's scale error minus the second's, µm/m.
    pub scale_mismatch_ppm: Option<f64>,
    /// Each axis's backlash (moving + minus moving −), µm.
    pub backlash_um: Option<[f64; 2]>,
}

fn default_direction() -> String {
    "ccw".into()
}

impl BallbarFigures {
    /// The figures given, as `(name, value in its unit, mm of radial deviation per unit)`.
    fn given(&self) -> Vec<(&'static str, f64, f64)> {
        let r = self.radius_mm;
        let mut figures = Vec::new();
        if let Some(v) = self.squareness_urad {
            figures.push(("squareness_urad", v, 1e-6 * r / 2.0));
        }
        if let Some(v) = self.scale_mismatch_ppm {
            figures.push(("scale_mismatch_ppm", v, 1e-6 * r / 2.0));
        }
        if let Some([u, v]) = self.backlash_um {
            figures.push(("backlash_um[0]", u, 1e-3 / 2.0));
            figures.push(("backlash_um[1]", v, 1e-3 / 2.0));
        }
        figures
    }

    /// True where the entry gives no figure to fit.
    pub fn is_empty(&self) -> bool {
        self.given().is_empty()
    }

    /// The circle predicted on `setup`'s machine, with its figures as the curve: predicted and
    /// measured amplitudes (mm) of each figure given.
    pub fn run(&self, setup: &Setup) -> Result<TestResult, StandardsError> {
        let spec = CircularSpec {
            plane: self.plane.clone(),
            centre_mm: self.centre_mm,
            radius_mm: Some(self.radius_mm),
            points: 360,
            direction: self.direction.clone(),
            start_deg: 0.0,
            pose: self.pose.clone(),
            csv: None,
            pitch_mm: None,
        };
        let mut result = circular(setup, &spec)?;
        let diagnostics = result
            .ballbar
            .as_ref()
            .map(|b| b.predicted.clone())
            .ok_or_else(|| {
                StandardsError::Parameter("the circle's diagnostics cannot be computed".into())
            })?;
        let given = self.given();
        let predicted_value = |name: &str| match name {
            "squareness_urad" => diagnostics.squareness_urad,
            "scale_mismatch_ppm" => diagnostics.scale_mismatch_ppm,
            "backlash_um[0]" => diagnostics.backlash_um[0],
            _ => diagnostics.backlash_um[1],
        };
        result.position_label = "figure".into();
        result.positions = (0..given.len()).map(|n| n as f64).collect();
        result.curve_names = vec!["ballbar figures (mm of radial deviation)".into()];
        result.predicted = vec![given
            .iter()
            .map(|&(name, _, per)| predicted_value(name) * per)
            .collect()];
        result.measured = Some(vec![given.iter().map(|&(_, v, per)| v * per).collect()]);
        Ok(result)
    }
}
