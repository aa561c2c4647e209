//! Where the rendered frame sits against the image a compositor expects (the plate):
//! overscan pixels around it and the pixels' shape. The EXR's displayWindow is the plate
//! and its dataWindow the frame, `overscan` pixels beyond the plate on each side, as
//! distortion workflows (Nuke's LensDistortion, STMaps) expect.

/// The plate of a frame: `overscan` pixels (x, y) rendered beyond each edge, and the
/// pixel aspect ratio (`pixelAspectRatio`, a pixel's width over its height).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plate {
    pub overscan: (usize, usize),
    pub pixel_aspect: f32,
}

impl Default for Plate {
    fn default() -> Plate {
        Plate {
            overscan: (0, 0),
            pixel_aspect: 1.0,
        }
    }
}

impl Plate {
    /// The plate's size within a frame of `width` × `height` (`None`: the overscan
    /// leaves no plate).
    pub fn size(&self, width: usize, height: usize) -> Option<(usize, usize)> {
        let (ox, oy) = self.overscan;
        let w = width.checked_sub(ox.checked_mul(2)?)?;
        let h = height.checked_sub(oy.checked_mul(2)?)?;
        (w > 0 && h > 0).then_some((w, h))
    }

    /// The frame's pixel `(x, y)` in the plate's coordinates (the displayWindow's).
    pub fn from_frame(&self, x: usize, y: usize) -> (i64, i64) {
        (
            x as i64 - self.overscan.0 as i64,
            y as i64 - self.overscan.1 as i64,
        )
    }

    /// `"X,Y"`, as the pieces of a tiled render record it.
    pub fn overscan_text(&self) -> String {
        format!("{},{}", self.overscan.0, self.overscan.1)
    }

    /// The overscan recorded by [`Plate::overscan_text`].
    pub fn parse_overscan(text: &str) -> Option<(usize, usize)> {
        let (x, y) = text.split_once(',')?;
        Some((x.trim().parse().ok()?, y.trim().parse().ok()?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plate_is_the_frame_less_its_overscan() {
        let p = Plate {
            overscan: (8, 4),
            pixel_aspect: 1.0,
        };
        assert_eq!(p.size(116, 58), Some((100, 50)));
        assert_eq!(p.size(16, 58), None);
        assert_eq!(p.from_frame(0, 0), (-8, -4));
        assert_eq!(p.from_frame(108, 54), (100, 50));
        assert_eq!(Plate::parse_overscan(&p.overscan_text()), Some((8, 4)));
        assert_eq!(Plate::parse_overscan("8"), None);
    }
}
