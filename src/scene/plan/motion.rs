//! Motion blur: the shutter (`shutter`, `fps`) and how the velocity grid moves the
//! volume (`velocity_grid`, `velocity_scale`, `velocity_unit`).

use super::defaults;
use super::look::GridChoice;
use crate::scene::options::RenderOptions;

/// When the camera samples are taken, and how the volume moves meanwhile.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionPlan {
    /// `(open, close)` in frames from the frame's time; `None`: every sample at it.
    pub shutter: Option<(f64, f64)>,
    pub fps: f64,
    pub velocity_grid: GridChoice,
    pub velocity_scale: f64,
    /// The velocity grid is per second (else per frame).
    pub per_second: bool,
}

/// The longest shutter accepted, in frames either side of the frame: a shutter open
/// longer than this is not a blur within one frame.
pub const MAX_SHUTTER_FRAMES: f64 = 16.0;

impl MotionPlan {
    pub(super) fn from_options(o: &RenderOptions) -> Result<MotionPlan, String> {
        let fps = o.fps.unwrap_or(defaults::FPS);
        if !(fps > 0.0 && fps <= 1e6) {
            return Err(format!(
                "{{fps}} {fps} must be a number of frames per second in (0, 1e6]"
            ));
        }
        let velocity_scale = o.velocity_scale.unwrap_or(defaults::VELOCITY_SCALE);
        if !velocity_scale.is_finite() {
            return Err(format!(
                "{{velocity_scale}} {velocity_scale} must be a finite number"
            ));
        }
        let per_second = match o
            .velocity_unit
            .as_deref()
            .unwrap_or(defaults::VELOCITY_UNIT)
        {
            "second" | "s" => true,
            "frame" => false,
            other => {
                return Err(format!(
                    "{{velocity_unit}} `{other}` is not a unit: second or frame"
                ));
            }
        };
        let shutter = match o.shutter.as_deref() {
            None => None,
            Some(text) => Some(shutter(text)?),
        };
        Ok(MotionPlan {
            shutter,
            fps,
            velocity_grid: GridChoice::from(&o.velocity_grid),
            velocity_scale,
            per_second,
        })
    }

    /// The velocity's time units in a frame, times the scale: what multiplies a time
    /// in frames to give the advection's time offset.
    pub fn velocity_per_frame(&self) -> f64 {
        let unit = if self.per_second { 1.0 / self.fps } else { 1.0 };
        unit * self.velocity_scale
    }

    /// The largest |time| (frames from the frame) a sample is taken at.
    pub fn max_offset(&self) -> f64 {
        self.shutter.map_or(0.0, |(a, b)| a.abs().max(b.abs()))
    }
}

/// `OPEN,CLOSE`: two finite frame offsets, open ≤ close, within
/// ±[`MAX_SHUTTER_FRAMES`].
fn shutter(text: &str) -> Result<(f64, f64), String> {
    let bad = |why: &str| format!("{{shutter}} `{text}` {why}");
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [open, close] = parts[..] else {
        return Err(bad("must be OPEN,CLOSE in frames, e.g. -0.25,0.25"));
    };
    let num = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
    let (Some(open), Some(close)) = (num(open), num(close)) else {
        return Err(bad("must be two numbers of frames, e.g. -0.25,0.25"));
    };
    if open > close {
        return Err(bad("opens after it closes: OPEN must not exceed CLOSE"));
    }
    if open.abs() > MAX_SHUTTER_FRAMES || close.abs() > MAX_SHUTTER_FRAMES {
        return Err(bad(&format!(
            "is open more than {MAX_SHUTTER_FRAMES} frames from the frame"
        )));
    }
    Ok((open, close))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shutters_parse_and_bad_ones_say_why() {
        assert_eq!(shutter("-0.25,0.25"), Ok((-0.25, 0.25)));
        assert_eq!(shutter(" 0 , 0.5 "), Ok((0.0, 0.5)));
        assert_eq!(shutter("0.2,0.2"), Ok((0.2, 0.2)));
        for (text, why) in [
            ("0.5,-0.5", "opens after it closes"),
            ("0.5", "OPEN,CLOSE"),
            ("a,b", "two numbers"),
            ("0,nan", "two numbers"),
            ("0,100", "more than 16 frames"),
        ] {
            let e = shutter(text).unwrap_err();
            assert!(e.contains(why) && e.starts_with("{shutter}"), "{text}: {e}");
        }
    }

    #[test]
    fn velocity_per_frame_follows_the_unit_and_scale() {
        let mut o = RenderOptions::default();
        let p = MotionPlan::from_options(&o).unwrap();
        assert_eq!((p.shutter, p.velocity_per_frame()), (None, 1.0 / 24.0));
        o.velocity_unit = Some("frame".into());
        o.velocity_scale = Some(2.0);
        o.fps = Some(30.0);
        assert_eq!(
            MotionPlan::from_options(&o).unwrap().velocity_per_frame(),
            2.0
        );
        o.velocity_unit = Some("minute".into());
        assert!(MotionPlan::from_options(&o).is_err());
        o.velocity_unit = None;
        o.fps = Some(0.0);
        assert!(MotionPlan::from_options(&o).is_err());
    }
}
