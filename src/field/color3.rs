//! A colour field made of three scalar fields, one a channel: Blender writes smoke
//! colour as the float grids `color_r`, `color_g`, `color_b`.

use super::{ColorField, ColorParts, Field, IndexToWorld, lattice_offset};
use glam::{DVec3, Vec3};

/// Three scalar fields as one colour field, in the first one's index space.
pub struct ChannelColor {
    channels: [Box<dyn Field>; 3],
    /// Per channel after the first, the shift from the first's local index space to its
    /// own when on one lattice; else it is sampled at the world point.
    offsets: [Option<DVec3>; 2],
}

impl ChannelColor {
    pub fn new(r: Box<dyn Field>, g: Box<dyn Field>, b: Box<dyn Field>) -> Self {
        let offsets = [
            lattice_offset(g.transform(), r.transform()),
            lattice_offset(b.transform(), r.transform()),
        ];
        ChannelColor {
            channels: [r, g, b],
            offsets,
        }
    }
}

impl ColorField for ChannelColor {
    fn transform(&self) -> &IndexToWorld {
        self.channels[0].transform()
    }

    fn color_at_index(&self, p: DVec3) -> Vec3 {
        let r = self.channels[0].value_at_index(p);
        let at = |c: usize| match self.offsets[c - 1] {
            Some(o) => self.channels[c].value_at_index(p + o),
            None => self.channels[c].value_at_world(self.transform().index_to_world(p)),
        };
        Vec3::new(r, at(1), at(2))
    }

    fn parts(&self) -> Option<ColorParts<'_>> {
        let [r, g, b] = &self.channels;
        Some(ColorParts::Channels([r.as_ref(), g.as_ref(), b.as_ref()]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::VoxelGrid;
    use glam::{DMat4, IVec3};

    fn constant(v: f32, shift: i32) -> Box<dyn Field> {
        let voxels = (0..8).flat_map(move |i| {
            (0..8).flat_map(move |j| (0..8).map(move |k| (IVec3::new(i + shift, j, k), v)))
        });
        Box::new(VoxelGrid::from_voxels("c", voxels, DMat4::IDENTITY).unwrap())
    }

    #[test]
    fn three_grids_make_one_colour_on_and_off_one_lattice() {
        // g's voxels are shifted (its content centre differs): same lattice, offset.
        let c = ChannelColor::new(constant(0.9, 0), constant(0.5, 2), constant(0.2, 0));
        let centre = c.transform().world_to_index(DVec3::new(3.5, 3.5, 3.5));
        assert_eq!(c.color_at_index(centre), Vec3::new(0.9, 0.5, 0.2));
        // Where g has no voxels (world x < 2 minus its stencil) its channel is 0.
        let left = c.transform().world_to_index(DVec3::new(0.5, 3.5, 3.5));
        assert_eq!(c.color_at_index(left).y, 0.0);
    }
}
