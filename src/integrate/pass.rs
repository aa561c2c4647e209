//! Passes: the per-pixel quantities an integrator produces. One list of [`Pass`]
//! descriptors drives the per-pixel buffer (its slots and how samples are averaged), the
//! channels assembled from it (the beauty sum and the layers) and how the EXR stores
//! them — adding an output layer is adding one descriptor where the integrator declares
//! its passes.

/// What a pass holds, and so how many slots it takes in the per-pixel buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    /// Colour (3 slots), averaged over the pixel's samples.
    Rgb,
    /// The beauty's opacity (1 slot), averaged. Written as `A`.
    Alpha,
    /// Camera-space depth where the sample's opacity crosses 0.5 (2 slots: the sum of
    /// the crossings and their count). Written as `Z`: the mean crossing where the
    /// pixel's mean alpha reaches 0.5, else "empty".
    Depth,
    /// A part of the opacity (1 slot), averaged: one volume's share of it. Written as
    /// `<name>.A`.
    Matte,
}

impl PassKind {
    /// Slots in the per-pixel buffer.
    pub fn slots(self) -> usize {
        match self {
            PassKind::Rgb => 3,
            PassKind::Depth => 2,
            PassKind::Alpha | PassKind::Matte => 1,
        }
    }
}

/// One pass: its layer name and how it is produced and written.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    /// Layer name (`emission` → channels `emission.R/G/B`); ignored for alpha and depth.
    pub name: String,
    pub kind: PassKind,
    /// An [`PassKind::Rgb`] pass summed into the beauty `R,G,B` (emission, scatter and a
    /// visible floor; not the per-light parts of scatter).
    pub in_beauty: bool,
    /// Written as its own layer (`false`: only its share of the beauty is).
    pub layer: bool,
    /// Stored as 32-bit float whatever `--float` says.
    pub float: bool,
}

impl Pass {
    /// A colour layer summed into the beauty.
    pub fn beauty(name: &str) -> Pass {
        Pass {
            name: name.into(),
            kind: PassKind::Rgb,
            in_beauty: true,
            layer: true,
            float: false,
        }
    }
    /// A colour layer that is not part of the beauty (a light's share, a shadow).
    pub fn layer(name: &str) -> Pass {
        Pass {
            in_beauty: false,
            ..Pass::beauty(name)
        }
    }
    /// Opacity, written as `A`.
    pub fn alpha() -> Pass {
        Pass {
            name: "A".into(),
            kind: PassKind::Alpha,
            in_beauty: false,
            layer: false,
            float: false,
        }
    }
    /// A layer of one opacity channel, written as `<name>.A`.
    pub fn matte(name: &str) -> Pass {
        Pass {
            name: name.into(),
            kind: PassKind::Matte,
            in_beauty: false,
            layer: true,
            float: false,
        }
    }
    /// Depth, written as `Z` (always float).
    pub fn depth() -> Pass {
        Pass {
            name: "Z".into(),
            kind: PassKind::Depth,
            in_beauty: false,
            layer: false,
            float: true,
        }
    }
}

/// An integrator's passes with their offsets in the per-pixel buffer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassLayout {
    passes: Vec<Pass>,
    offsets: Vec<usize>,
    slots: usize,
}

impl PassLayout {
    pub fn new(passes: Vec<Pass>) -> Self {
        let mut offsets = Vec::with_capacity(passes.len());
        let mut slots = 0;
        for p in &passes {
            offsets.push(slots);
            slots += p.kind.slots();
        }
        PassLayout {
            passes,
            offsets,
            slots,
        }
    }

    pub fn passes(&self) -> &[Pass] {
        &self.passes
    }

    /// Slots in one pixel's buffer.
    pub fn slots(&self) -> usize {
        self.slots
    }

    /// Offset of pass `i` in the buffer.
    pub fn offset(&self, i: usize) -> usize {
        self.offsets[i]
    }

    /// Index of the pass named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.passes.iter().position(|p| p.name == name)
    }

    /// Offset of the first pass of `kind`.
    pub fn offset_of_kind(&self, kind: PassKind) -> Option<usize> {
        let i = self.passes.iter().position(|p| p.kind == kind)?;
        Some(self.offsets[i])
    }

    /// Offsets of the passes that add up to the beauty.
    pub fn beauty_offsets(&self) -> Vec<usize> {
        (0..self.passes.len())
            .filter(|&i| self.passes[i].in_beauty)
            .map(|i| self.offsets[i])
            .collect()
    }
}

/// The beauty's RGB in a pixel's buffer `acc` (its passes at `beauty`, from
/// [`PassLayout::beauty_offsets`]), the sum of `samples` samples, averaged; 0 where it
/// is not finite.
pub fn beauty_rgb(acc: &[f64], beauty: &[usize], samples: f64) -> [f64; 3] {
    let mut rgb = [0f64; 3];
    for &at in beauty {
        for (c, v) in rgb.iter_mut().enumerate() {
            *v += acc[at + c] / samples;
        }
    }
    rgb.map(|v| if v.is_finite() { v } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_follow_the_slots_of_each_kind() {
        let l = PassLayout::new(vec![
            Pass::alpha(),
            Pass::depth(),
            Pass::beauty("emission"),
            Pass::layer("shadow"),
        ]);
        assert_eq!(
            (0..4).map(|i| l.offset(i)).collect::<Vec<_>>(),
            [0, 1, 3, 6]
        );
        assert_eq!(l.slots(), 9);
        assert_eq!(l.find("shadow"), Some(3));
        assert_eq!(l.offset_of_kind(PassKind::Depth), Some(1));
    }
}
