//! The rendered image: a set of named float channels of one size.

use super::OutputError;

/// Channel names, Nuke style: the beauty pass is `R,G,B,A` and `Z`, the other
/// passes are layers `layer.R`, `layer.G`, `layer.B`.
pub mod names {
    /// Beauty red (premultiplied).
    pub const R: &str = "R";
    /// Beauty green (premultiplied).
    pub const G: &str = "G";
    /// Beauty blue (premultiplied).
    pub const B: &str = "B";
    /// Beauty alpha.
    pub const A: &str = "A";
    /// Depth: always stored as 32-bit float; `+inf` where there is no depth.
    pub const Z: &str = "Z";
    /// The beauty colour and alpha channels.
    pub const RGBA: [&str; 4] = [R, G, B, A];

    /// Layer of emitted light.
    pub const EMISSION: &str = "emission";
    /// Layer of all single-scattered light.
    pub const SCATTER: &str = "scatter";
    /// Layer of the shadow (transmittance) term.
    pub const SHADOW: &str = "shadow";

    /// The three channel names `layer.R`, `layer.G`, `layer.B` of a layer.
    pub fn layer_rgb(layer: &str) -> [String; 3] {
        [
            format!("{layer}.R"),
            format!("{layer}.G"),
            format!("{layer}.B"),
        ]
    }

    /// The layer name of the light scattered from sun number `index`:
    /// `scatter_sun0`, `scatter_sun1`, ...
    pub fn scatter_sun(index: usize) -> String {
        format!("scatter_sun{index}")
    }
}

/// Whether a channel holds depth (`Z` or `<layer>.Z`): stored as 32-bit float,
/// and `+inf` in it means "no depth" (an empty pixel).
pub fn is_depth_channel(name: &str) -> bool {
    name == names::Z || name.ends_with(".Z")
}

/// One named channel: `width * height` samples, row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    name: String,
    data: Vec<f32>,
    /// Stored as 32-bit float whatever the file's colour precision.
    float: bool,
}

impl Channel {
    /// The channel name, e.g. `R` or `emission.G`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The samples, row-major, top row first.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Whether the channel is always stored as 32-bit float (depth, or a pass that asks).
    pub fn always_float(&self) -> bool {
        self.float || is_depth_channel(&self.name)
    }
}

/// A pixel rectangle: `x..x + width`, `y..y + height` (y down, top row 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelRect {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Number of columns (at least 1 for rectangles made here).
    pub width: usize,
    /// Number of rows (at least 1 for rectangles made here).
    pub height: usize,
}

impl PixelRect {
    /// The last column inside the rectangle (inclusive, as in an EXR window).
    pub fn max_x(&self) -> usize {
        (self.x + self.width).saturating_sub(1)
    }

    /// The last row inside the rectangle (inclusive, as in an EXR window).
    pub fn max_y(&self) -> usize {
        (self.y + self.height).saturating_sub(1)
    }
}

/// The rendered image as named float channels.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    channels: Vec<Channel>,
}

impl Frame {
    /// An empty frame (no channels) of this size.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            channels: Vec::new(),
        }
    }

    /// The number of pixels, `width * height` (saturating).
    pub fn pixel_count(&self) -> usize {
        self.width.saturating_mul(self.height)
    }

    /// Add a channel of `width * height` samples (row-major, top row first).
    ///
    /// Fails if the length is wrong, the name is taken, or the name cannot be
    /// stored in an EXR file (empty, longer than 255 bytes, control chars).
    pub fn add_channel(
        &mut self,
        name: impl Into<String>,
        data: Vec<f32>,
    ) -> Result<(), OutputError> {
        let name = name.into();
        validate_channel_name(&name)?;
        let expected = self.width.checked_mul(self.height);
        if expected != Some(data.len()) {
            return Err(OutputError::ChannelLength {
                name,
                len: data.len(),
                expected: expected.unwrap_or(usize::MAX),
                width: self.width,
                height: self.height,
            });
        }
        if self.channel(&name).is_some() {
            return Err(OutputError::DuplicateChannel(name));
        }
        self.channels.push(Channel {
            name,
            data,
            float: false,
        });
        Ok(())
    }

    /// Stores the channel `name` as 32-bit float whatever `--float` says.
    pub fn store_as_float(&mut self, name: &str) {
        if let Some(c) = self.channels.iter_mut().find(|c| c.name == name) {
            c.float = true;
        }
    }

    /// The samples of the channel with this exact name.
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|c| c.name == name)
            .map(|c| c.data.as_slice())
    }

    /// Mutable samples of the channel with this exact name (the length stays fixed).
    pub fn channel_mut(&mut self, name: &str) -> Option<&mut [f32]> {
        self.channels
            .iter_mut()
            .find(|c| c.name == name)
            .map(|c| c.data.as_mut_slice())
    }

    /// The channel names in the order they were added.
    pub fn channel_names(&self) -> Vec<&str> {
        self.channels.iter().map(|c| c.name.as_str()).collect()
    }

    /// All channels in the order they were added.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The bounding box of the pixels where any channel is non-zero, or `None`
    /// if there is none (or the frame has no pixels).
    ///
    /// NaN counts as zero (it is written as 0), and in depth channels
    /// (see [`is_depth_channel`]) `+inf` counts as empty too. Channels whose
    /// length does not match the frame size are ignored.
    pub fn content_bounds(&self) -> Option<PixelRect> {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return None;
        }
        let mut min = (usize::MAX, usize::MAX);
        let mut max = (0usize, 0usize);
        let mut any = false;
        for channel in self
            .channels
            .iter()
            .filter(|c| c.data.len() == self.pixel_count())
        {
            let depth = is_depth_channel(&channel.name);
            for (y, row) in channel.data.chunks_exact(w).enumerate() {
                let occupied =
                    |v: &f32| !(*v == 0.0 || v.is_nan() || (depth && *v == f32::INFINITY));
                let Some(first) = row.iter().position(occupied) else {
                    continue;
                };
                let last = row.iter().rposition(occupied).unwrap_or(first);
                any = true;
                min = (min.0.min(first), min.1.min(y));
                max = (max.0.max(last), max.1.max(y));
            }
        }
        any.then(|| PixelRect {
            x: min.0,
            y: min.1,
            width: max.0 - min.0 + 1,
            height: max.1 - min.1 + 1,
        })
    }

    /// The EXR data window: [`content_bounds`](Self::content_bounds), or a
    /// 1×1 rectangle at the top-left pixel when the frame is entirely empty.
    pub fn data_window(&self) -> PixelRect {
        self.content_bounds().unwrap_or(PixelRect {
            x: 0,
            y: 0,
            width: 1,
            height: 1,
        })
    }
}

fn validate_channel_name(name: &str) -> Result<(), OutputError> {
    let reason = if name.is_empty() {
        "it is empty"
    } else if name.len() > 255 {
        "it is longer than 255 bytes"
    } else if name.chars().any(char::is_control) {
        "it contains control characters"
    } else {
        return Ok(());
    };
    Err(OutputError::InvalidChannelName {
        name: name.to_owned(),
        reason,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_with(w: usize, h: usize, chans: &[(&str, Vec<f32>)]) -> Frame {
        let mut f = Frame::new(w, h);
        for (n, d) in chans {
            f.add_channel(*n, d.clone()).unwrap();
        }
        f
    }

    fn set(data: &mut [f32], w: usize, x: usize, y: usize, v: f32) {
        data[y * w + x] = v;
    }

    #[test]
    fn add_channel_checks_length_duplicates_and_names() {
        let mut f = Frame::new(4, 3);
        f.add_channel("R", vec![0.0; 12]).unwrap();
        let e = f.add_channel("G", vec![0.0; 11]).unwrap_err();
        assert!(e.to_string().contains("`G` has 11 samples"), "{e}");
        assert!(matches!(
            f.add_channel("R", vec![0.0; 12]),
            Err(OutputError::DuplicateChannel(_))
        ));
        assert!(f.add_channel("", vec![0.0; 12]).is_err());
        assert!(f.add_channel("a\nb", vec![0.0; 12]).is_err());
        assert!(f.add_channel("x".repeat(256), vec![0.0; 12]).is_err());
        f.add_channel("emission.R", vec![1.0; 12]).unwrap();
        assert_eq!(f.channel_names(), vec!["R", "emission.R"]);
        assert_eq!(f.channel("emission.R").map(|d| d.len()), Some(12));
        assert!(f.channel("Q").is_none());
        f.channel_mut("R").unwrap()[3] = 2.0;
        assert_eq!(f.channel("R").unwrap()[3], 2.0);
    }

    #[test]
    fn layer_names() {
        assert_eq!(
            names::layer_rgb("emission"),
            ["emission.R", "emission.G", "emission.B"]
        );
        assert_eq!(names::scatter_sun(0), "scatter_sun0");
        assert!(is_depth_channel("Z") && is_depth_channel("depth.Z"));
        assert!(!is_depth_channel("R") && !is_depth_channel("ZZ"));
    }

    #[test]
    fn crop_is_bounding_box_over_all_channels() {
        let (w, h) = (16, 10);
        let mut r = vec![0.0; w * h];
        set(&mut r, w, 3, 2, 0.5);
        let mut e = vec![0.0; w * h];
        set(&mut e, w, 9, 7, -1.0); // negative counts as non-zero
        let f = frame_with(w, h, &[("R", r), ("emission.G", e)]);
        let rect = f.content_bounds().unwrap();
        assert_eq!(
            rect,
            PixelRect {
                x: 3,
                y: 2,
                width: 7,
                height: 6
            }
        );
        assert_eq!((rect.max_x(), rect.max_y()), (9, 7));
    }

    #[test]
    fn crop_ignores_infinite_depth_and_nan() {
        let (w, h) = (8, 8);
        let mut z = vec![f32::INFINITY; w * h];
        set(&mut z, w, 5, 6, 3.0); // a finite depth is content
        let mut g = vec![0.0; w * h];
        set(&mut g, w, 0, 0, f32::NAN); // NaN is written as 0: empty
        set(&mut g, w, 2, 1, 1.0);
        let f = frame_with(w, h, &[("Z", z), ("G", g)]);
        assert_eq!(
            f.content_bounds(),
            Some(PixelRect {
                x: 2,
                y: 1,
                width: 4,
                height: 6
            })
        );
    }

    #[test]
    fn crop_counts_infinity_in_colour_channels() {
        let (w, h) = (4, 4);
        let mut b = vec![0.0; w * h];
        set(&mut b, w, 1, 2, f32::INFINITY);
        let f = frame_with(w, h, &[("B", b)]);
        assert_eq!(
            f.content_bounds(),
            Some(PixelRect {
                x: 1,
                y: 2,
                width: 1,
                height: 1
            })
        );
    }

    #[test]
    fn empty_frame_crops_to_top_left_pixel() {
        let (w, h) = (5, 4);
        let f = frame_with(
            w,
            h,
            &[("R", vec![0.0; 20]), ("Z", vec![f32::INFINITY; 20])],
        );
        assert_eq!(f.content_bounds(), None);
        assert_eq!(
            f.data_window(),
            PixelRect {
                x: 0,
                y: 0,
                width: 1,
                height: 1
            }
        );
        assert_eq!(Frame::new(0, 0).content_bounds(), None);
    }

    #[test]
    fn single_pixel_at_far_corner() {
        let (w, h) = (6, 5);
        let mut a = vec![0.0; w * h];
        set(&mut a, w, 5, 4, 1.0);
        let f = frame_with(w, h, &[("A", a)]);
        assert_eq!(
            f.data_window(),
            PixelRect {
                x: 5,
                y: 4,
                width: 1,
                height: 1
            }
        );
    }
}
