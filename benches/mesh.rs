//! The mesh benchmark's Rust side (`harness = false`; `scripts/bench_mesh.sh` makes the
//! inputs and runs it).
//!
//! ```text
//! cargo bench --bench mesh -- MESH.vtu GRID.vdb [--res N] [--rays N] [--out DIR]
//! ```
//! 1. Loads the mesh (read + tetrahedra, adjacency, BVH, lattice) and the VDB grid.
//! 2. Walk speed on one thread: random rays through the mesh, tetrahedra crossed per
//!    second (`MeshGeometry::walk`), and with the integration of the density
//!    (`MeshField::integrate_world`).
//! 3. Renders the density's alpha (σt = 4, no lights) with an orthographic camera at
//!    N×N through the library's march, from the mesh and from the VDB resample, on one
//!    thread and on all; the difference of the two alpha images (mean, RMS, max).
//!    With `--out`, writes both as PNG (8-bit alpha).
//!
//! Prints a JSON line.

use glam::DVec3;
use murk::field::mesh::MeshSource;
use murk::field::random::SplitMix64;
use murk::field::{Field, VoxelGrid};
use murk::integrate::{MarchSettings, Medium, Scratch, Volume, WorldRay, march};
use murk::vdb::VdbFile;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.len() < 2 {
        eprintln!("mesh bench: nothing to do without arguments (run scripts/bench_mesh.sh)");
        return;
    }
    let opt = |k: &str, d: usize| -> usize {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map(PathBuf::from);
    if let Err(e) = run(
        Path::new(&args[0]),
        Path::new(&args[1]),
        opt("--res", 256),
        opt("--rays", 20000),
        out,
    ) {
        eprintln!("mesh bench: {e}");
        std::process::exit(2);
    }
}

fn rng(s: &mut SplitMix64) -> f64 {
    (s.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

fn render(field: &dyn Field, res: usize, threads: usize) -> Result<(Vec<f64>, f64), String> {
    let medium = Medium {
        sigma_a: DVec3::splat(4.0),
        sigma_s: DVec3::ZERO,
        density_scale: 1.0,
        g: 0.0,
    };
    let vol = Volume::of(field, medium);
    let settings = MarchSettings {
        step_voxels: 1.0,
        termination: 0.0,
    };
    let dir = DVec3::new(-1.0, -0.7, -0.5).normalize();
    let u = dir.cross(DVec3::Z).normalize();
    let v = u.cross(dir);
    let c = DVec3::splat(0.5);
    let half = 0.9;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let t0 = Instant::now();
    let img: Vec<f64> = pool.install(|| {
        (0..res * res)
            .into_par_iter()
            .map_init(
                || Scratch::new(0),
                |scratch, i| {
                    let (x, y) = ((i % res) as f64 + 0.5, (i / res) as f64 + 0.5);
                    let o = c
                        + u * (half * (2.0 * x / res as f64 - 1.0))
                        + v * (half * (1.0 - 2.0 * y / res as f64))
                        - dir * 3.0;
                    march(&vol, None, &WorldRay::new(o, dir), &settings, 0.5, scratch).alpha()
                },
            )
            .collect()
    });
    Ok((img, t0.elapsed().as_secs_f64()))
}

fn png(path: &Path, img: &[f64], res: usize) -> Result<(), String> {
    let bytes: Vec<u8> = img
        .iter()
        .map(|a| (a.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    image::save_buffer(
        path,
        &bytes,
        res as u32,
        res as u32,
        image::ExtendedColorType::L8,
    )
    .map_err(|e| e.to_string())
}

fn run(
    vtu: &Path,
    vdb: &Path,
    res: usize,
    rays: usize,
    out: Option<PathBuf>,
) -> Result<(), String> {
    let t0 = Instant::now();
    let src = MeshSource::open(vtu).map_err(|e| e.to_string())?;
    let field = src.field("density").ok_or("no point array 'density'")?;
    let load_mesh = t0.elapsed().as_secs_f64();
    let geo = field.geometry().clone();
    let t0 = Instant::now();
    let file = VdbFile::open(vdb).map_err(|e| e.to_string())?;
    let grid = VoxelGrid::load(&file, "density").map_err(|e| e.to_string())?;
    let load_vdb = t0.elapsed().as_secs_f64();

    // Walk speed, one thread.
    let mut s = SplitMix64(17);
    let ray_list: Vec<(DVec3, DVec3)> = (0..rays)
        .map(|_| {
            let target = DVec3::new(rng(&mut s), rng(&mut s), rng(&mut s));
            let d = DVec3::new(rng(&mut s) - 0.5, rng(&mut s) - 0.5, rng(&mut s) - 0.5).normalize();
            (target - d * 3.0, d)
        })
        .collect();
    let t0 = Instant::now();
    let mut crossed = 0u64;
    for (o, d) in &ray_list {
        crossed += geo.walk(*o, *d, 0.0, 10.0, |_, _, _| {}).steps;
    }
    let walk_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let mut sum = 0.0;
    for (o, d) in &ray_list {
        sum += field.integrate_world(*o, *d, 0.0, 10.0);
    }
    let integrate_s = t0.elapsed().as_secs_f64();
    std::hint::black_box(sum);

    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let (mesh_img, mesh_1) = render(&field, res, 1)?;
    let (_, mesh_n) = render(&field, res, all)?;
    let (vdb_img, vdb_1) = render(&grid, res, 1)?;
    let (_, vdb_n) = render(&grid, res, all)?;
    let n = mesh_img.len() as f64;
    let diffs: Vec<f64> = mesh_img
        .iter()
        .zip(&vdb_img)
        .map(|(a, b)| (a - b).abs())
        .collect();
    let mean = diffs.iter().sum::<f64>() / n;
    let rms = (diffs.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
    let max = diffs.iter().cloned().fold(0.0, f64::max);
    let mean_alpha = mesh_img.iter().sum::<f64>() / n;
    if let Some(dir) = &out {
        std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
        png(&dir.join("mesh_alpha.png"), &mesh_img, res)?;
        png(&dir.join("vdb_alpha.png"), &vdb_img, res)?;
    }
    let r = geo.report();
    println!(
        "{}",
        serde_json::json!({
            "tetrahedra": r.tetrahedra,
            "cells": r.cells,
            "mesh_load_s": load_mesh,
            "mesh_memory_bytes": field.memory_bytes(),
            "vdb_load_s": load_vdb,
            "vdb_memory_bytes": grid.memory_bytes(),
            "vdb_active_voxels": grid.stats().active_voxels,
            "walk_rays": rays,
            "walk_cells_crossed": crossed,
            "walk_cells_per_s_1_thread": crossed as f64 / walk_s,
            "integrate_cells_per_s_1_thread": crossed as f64 / integrate_s,
            "render_res": res,
            "threads": all,
            "mesh_render_s_1_thread": mesh_1,
            "mesh_render_s_all": mesh_n,
            "vdb_render_s_1_thread": vdb_1,
            "vdb_render_s_all": vdb_n,
            "alpha_mean": mean_alpha,
            "alpha_diff_mean": mean,
            "alpha_diff_rms": rms,
            "alpha_diff_max": max,
        })
    );
    Ok(())
}
