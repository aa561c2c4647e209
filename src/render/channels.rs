//! The frame's channels, assembled from an integrator's passes: the beauty `R,G,B` (the
//! sum of the passes marked for it), `A` and `Z`, then every pass written as a layer
//! (`layer.R/G/B`, or `layer.A` for an opacity's part), in the order the integrator
//! declared them.

use super::pixels::PixelPasses;
use crate::integrate::pass::PassKind;
use crate::output::{Frame, OutputError, names};

pub fn assemble(passes: &PixelPasses) -> Result<Frame, OutputError> {
    let mut frame = Frame::new(passes.width, passes.height);
    let n = passes.width * passes.height;
    let list = passes.layout.passes();
    let in_beauty: Vec<usize> = (0..list.len())
        .filter(|&i| list[i].kind == PassKind::Rgb && list[i].in_beauty)
        .collect();
    for (c, name) in [names::R, names::G, names::B].into_iter().enumerate() {
        let mut sum = vec![0f32; n];
        for (k, &i) in in_beauty.iter().enumerate() {
            let plane = &passes.planes[i][c];
            if k == 0 {
                sum.copy_from_slice(plane);
            } else {
                sum.iter_mut().zip(plane).for_each(|(s, v)| *s += v);
            }
        }
        frame.add_channel(name, sum)?;
    }
    for kind in [PassKind::Alpha, PassKind::Depth] {
        if let Some(i) = list.iter().position(|p| p.kind == kind) {
            frame.add_channel(list[i].name.clone(), passes.planes[i][0].clone())?;
        }
    }
    for (i, pass) in list.iter().enumerate() {
        if pass.kind == PassKind::Rgb && pass.layer {
            for (name, plane) in names::layer_rgb(&pass.name)
                .into_iter()
                .zip(&passes.planes[i])
            {
                frame.add_channel(&name, plane.clone())?;
                if pass.float {
                    frame.store_as_float(&name);
                }
            }
        }
        if pass.kind == PassKind::Matte && pass.layer {
            let name = format!("{}.{}", pass.name, names::A);
            frame.add_channel(&name, passes.planes[i][0].clone())?;
            if pass.float {
                frame.store_as_float(&name);
            }
        }
    }
    Ok(frame)
}
