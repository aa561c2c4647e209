//! The stability cases that render a small `.vdb` written to a temporary directory
//! with [`render_image`], as `murk render` would: bad voxels, a translated grid, an
//! empty grid, a single voxel, a very hot temperature grid.

use super::ReportError;
use super::check::{CaseResult, Check, plan_scatter_bound};
use crate::integrate::blackbody::BlackbodyTable;
use crate::output::Frame;
use crate::render::{RenderOptions, RenderPlan, render_image};
use crate::vdb::{FloatGridOut, write_float_grids};
use glam::{DMat4, DVec3, IVec3};
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, ReportError>;

/// A temporary directory for the rendered cases, removed when dropped.
pub struct Scratchpad(PathBuf);

impl Scratchpad {
    pub fn new() -> Result<Self> {
        let dir = std::env::temp_dir().join(format!("murk-stability-{}", std::process::id()));
        std::fs::create_dir_all(&dir)
            .map_err(|e| ReportError::write(&dir, format!("cannot create: {e}")))?;
        Ok(Scratchpad(dir))
    }
    fn vdb(&self, name: &str, grids: Vec<FloatGridOut>) -> Result<PathBuf> {
        let path = self.0.join(format!("{name}.vdb"));
        write_float_grids(&path, &grids, &[])?;
        Ok(path)
    }
}

impl Drop for Scratchpad {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn grid(name: &str, m: DMat4, voxels: Vec<(IVec3, f32)>) -> FloatGridOut {
    FloatGridOut {
        name: name.into(),
        index_to_world: m,
        voxels,
        metadata: Vec::new(),
    }
}

/// A lumpy blob of about 16 voxels across (deterministic), for the rendered cases.
fn blob_voxels() -> Vec<(IVec3, f32)> {
    let mut v = Vec::new();
    for i in -8..8 {
        for j in -8..8 {
            for k in -8..8 {
                let r2 = (i * i + j * j + k * k) as f32 / 40.0;
                let lump = 1.0 + 0.3 * ((i as f32 * 0.9).sin() * (k as f32 * 0.7).cos());
                let d = (2.0 * lump * (-r2).exp()).max(0.0);
                if d > 1e-3 {
                    v.push((IVec3::new(i, j, k), d));
                }
            }
        }
    }
    v
}

/// Renders `vdb` at 24×24 (quiet, in memory) with `adjust` applied to the options, by
/// single scattering: the cases' bounds and closed forms are single scattering's.
fn render(vdb: &Path, adjust: impl FnOnce(&mut RenderOptions)) -> Result<(Frame, RenderPlan)> {
    let mut o = RenderOptions {
        output: Some(vdb.with_extension("exr")),
        res: Some("24x24".into()),
        light: vec!["sun:0.6,1,0.5:1,1,1:6".into()],
        quiet: true,
        scattering: Some(crate::integrate::ScatteringMode::Single),
        ..Default::default()
    };
    adjust(&mut o);
    let plan = RenderPlan::new(&o, vdb.to_path_buf())?;
    let image = render_image(&plan)?;
    Ok((image.frame, plan))
}

/// NaN, +Inf, −Inf and negative voxels injected: the image equals that of the grid with
/// those voxels 0 (what the loader sanitises them to).
pub fn bad_voxels(pad: &Scratchpad) -> Result<CaseResult> {
    let m = DMat4::from_scale(DVec3::splat(0.05));
    let clean = blob_voxels();
    let mut dirty = clean.clone();
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -3.0];
    let mut sanitised = clean.clone();
    for (n, (ijk, v)) in dirty.iter_mut().enumerate() {
        if n % 7 == 3 {
            *v = bad[(n / 7) % bad.len()];
            sanitised[n] = (*ijk, 0.0);
        }
    }
    let (got, plan) = render(&pad.vdb("dirty", vec![grid("density", m, dirty)])?, |_| {})?;
    let (want, _) = render(
        &pad.vdb("sanitised", vec![grid("density", m, sanitised)])?,
        |_| {},
    )?;
    let mut check = Check::new(plan_scatter_bound(&plan), 0.0);
    check.frame(&got);
    check.compare_frames("dirty vs sanitised", &got, &want);
    Ok(check.finish(
        "bad_voxels",
        "NaN, ±Inf and negative voxels: the image of the sanitised grid",
    ))
}

/// The grid translated by 1e3 … 1e6 world units (the camera frames it): the image
/// unchanged to 1e-5.
pub fn translated(pad: &Scratchpad) -> Result<CaseResult> {
    let scale = DMat4::from_scale(DVec3::splat(0.05));
    let (want, plan) = render(
        &pad.vdb("origin", vec![grid("density", scale, blob_voxels())])?,
        |_| {},
    )?;
    let mut check = Check::new(plan_scatter_bound(&plan), 1e-5);
    check.frame(&want);
    for exponent in 3..=6 {
        let t = 10f64.powi(exponent);
        let m = DMat4::from_translation(DVec3::new(t, -0.5 * t, 0.25 * t)) * scale;
        let (got, _) = render(
            &pad.vdb(
                &format!("moved{exponent}"),
                vec![grid("density", m, blob_voxels())],
            )?,
            |_| {},
        )?;
        check.frame(&got);
        check.compare_frames(&format!("translated by 1e{exponent}"), &got, &want);
    }
    Ok(check.finish(
        "translated",
        "the grid translated by 1e3 to 1e6 world units: image unchanged to 1e-5",
    ))
}

/// An empty grid: a transparent black image, no error.
pub fn empty_grid(pad: &Scratchpad) -> Result<CaseResult> {
    let (f, plan) = render(
        &pad.vdb("empty", vec![grid("density", DMat4::IDENTITY, Vec::new())])?,
        |_| {},
    )?;
    let mut check = Check::new(plan_scatter_bound(&plan), 0.0);
    check.frame(&f);
    check.compare("largest alpha", check_max(&f, "A"), 0.0);
    check.compare("largest red", check_max(&f, "R"), 0.0);
    Ok(check.finish("empty_grid", "an empty grid: transparent image, no error"))
}

fn check_max(f: &Frame, channel: &str) -> f64 {
    f.channel(channel).map_or(f64::NAN, |c| {
        c.iter().fold(0.0f64, |m, v| m.max(v.abs() as f64))
    })
}

/// One active voxel (density 5): visible, bounded; its opacity is at most that of its
/// trilinear footprint's thickest chord, `1 − e^{−σt·ρ·2h}`.
pub fn single_voxel(pad: &Scratchpad) -> Result<CaseResult> {
    let h = 0.1;
    let path = pad.vdb(
        "single",
        vec![grid(
            "density",
            DMat4::from_scale(DVec3::splat(h)),
            vec![(IVec3::ZERO, 5.0)],
        )],
    )?;
    let (f, plan) = render(&path, |_| {})?;
    let mut check = Check::new(plan_scatter_bound(&plan), 0.0);
    check.frame(&f);
    let sigma_t = (plan.medium.sigma_a + plan.medium.sigma_s).max_element();
    let alpha = check_max(&f, "A");
    let ceiling = -(-sigma_t * 5.0 * 2.0 * h * 3f64.sqrt()).exp_m1();
    if !(alpha > 0.0 && alpha <= ceiling) {
        check.fail(format!("largest alpha {alpha} not in (0, {ceiling}]"));
    }
    check.note(format!("largest alpha {alpha:.4}"));
    Ok(check.finish("single_voxel", "a single active voxel"))
}

/// Temperature 1e5 K on the blob (blackbody emission, 1e4 times that of 1000 K to the
/// fourth): finite, and emission under ε_max × the longest chord through the bounds.
pub fn hot_temperature(pad: &Scratchpad) -> Result<CaseResult> {
    let m = DMat4::from_scale(DVec3::splat(0.05));
    let temperature: Vec<(IVec3, f32)> = blob_voxels()
        .into_iter()
        .map(|(ijk, _)| (ijk, 1e5))
        .collect();
    let path = pad.vdb(
        "hot",
        vec![
            grid("density", m, blob_voxels()),
            grid("temperature", m, temperature),
        ],
    )?;
    let (f, plan) = render(&path, |_| {})?;
    // ε per world unit: the blackbody colour (luminance-normalised, so a channel may
    // exceed 1) × (T/1000)⁴ × intensity, as the render's own table gives it; the longest
    // chord is the diagonal of the bounds grown by the stencil's voxel.
    let rgb = BlackbodyTable::new(200.0, 40000.0, 2048).rgb_normalized(1e5);
    let eps = rgb.iter().fold(0.0f64, |m, c| m.max(*c))
        * (1e5f64 / 1000.0).powi(4)
        * plan.emission.blackbody_intensity;
    let chord = DVec3::splat(17.0 * 0.05).length();
    let mut check = Check::new(plan_scatter_bound(&plan) + eps * chord, 0.0);
    check.frame(&f);
    check.note(format!(
        "largest radiance {:.3e}",
        check_max(&f, "R").max(check_max(&f, "B"))
    ));
    Ok(check.finish(
        "hot_temperature",
        "temperature 1e5 K: blackbody emission stays finite and bounded",
    ))
}
