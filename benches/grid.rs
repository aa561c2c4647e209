//! The "load" benchmark's Rust side (a `harness = false` bench; `scripts/bench.sh` runs it
//! and compares with OpenVDB in the same run).
//!
//! ```text
//! cargo bench --bench grid -- load FILE.vdb [GRID]
//!     One load in this process: VdbFile::open + VoxelGrid::load. Prints a JSON line:
//!     seconds, peak and retained RSS above the process's baseline, memory_bytes().
//!     Run it in a fresh process per measurement (the peak is per process).
//! cargo bench --bench grid -- sample FILE.vdb [GRID] [--points N] [--rays N] [--reps N]
//!     Single-threaded trilinear samples per second, murk's `value_at_index` against
//!     OpenVDB-rs's BoxSampler through a cached ValueAccessor, on the same points:
//!     random points in the active bbox, and coherent rays (0.5-voxel steps).
//!     Prints a JSON line with the medians of the repetitions.
//! ```
//!
//! With no arguments (plain `cargo bench`) it does nothing: the inputs are made at run
//! time by `scripts/bench.sh`.

use glam::DVec3;
use murk::field::random::SplitMix64;
use murk::field::{Field, VoxelGrid};
use murk::vdb::VdbFile;
use openvdb::grid::AnyGrid;
use openvdb::math::Vec3d;
use openvdb::tools::interpolation::{BoxSampler, Sampler};
use std::hint::black_box;
use std::time::Instant;

fn main() {
    // `cargo bench` passes `--bench` to harness-less benches; drop it.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let result = match args.first().map(String::as_str) {
        None => {
            eprintln!("grid bench: nothing to do without arguments (run scripts/bench.sh)");
            Ok(())
        }
        Some("load") => load(&args[1..]),
        Some("sample") => sample(&args[1..]),
        Some(other) => Err(format!("unknown mode {other:?}: expected load or sample")),
    };
    if let Err(e) = result {
        eprintln!("grid bench: {e}");
        std::process::exit(2);
    }
}

/// A field of /proc/self/status, in bytes.
fn status_bytes(field: &str) -> Result<u64, String> {
    let text = std::fs::read_to_string("/proc/self/status").map_err(|e| e.to_string())?;
    let line = text
        .lines()
        .find(|l| l.starts_with(field) && l[field.len()..].starts_with(':'))
        .ok_or_else(|| format!("{field} not in /proc/self/status"))?;
    let kib: u64 = line
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .ok_or("bad status line")?;
    Ok(kib * 1024)
}

/// `struct timespec` on 64-bit Linux.
#[repr(C)]
struct Timespec {
    sec: i64,
    nsec: i64,
}

unsafe extern "C" {
    fn clock_gettime(clock: i32, tp: *mut Timespec) -> i32;
}

const CLOCK_PROCESS_CPUTIME_ID: i32 = 2;
const CLOCK_THREAD_CPUTIME_ID: i32 = 3;

/// CPU seconds used so far by this process or thread. On a machine shared with other
/// work this is steadier than wall time (a descheduled thread uses none).
fn cpu_seconds(clock: i32) -> f64 {
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let rc = unsafe { clock_gettime(clock, &mut ts) };
    if rc == 0 {
        ts.sec as f64 + ts.nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

/// Resets VmHWM to the current RSS (Linux ≥ 4.0); false if not allowed.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn path_and_grid(args: &[String]) -> Result<(String, String), String> {
    let path = args.first().ok_or("missing FILE.vdb")?.clone();
    let grid = args
        .get(1)
        .filter(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "density".into());
    Ok((path, grid))
}

fn load_murk(path: &str, grid: &str) -> Result<VoxelGrid, String> {
    let file = VdbFile::open(path).map_err(|e| e.to_string())?;
    VoxelGrid::load(&file, grid).map_err(|e| e.to_string())
}

fn load(args: &[String]) -> Result<(), String> {
    let (path, name) = path_and_grid(args)?;
    let baseline = status_bytes("VmRSS")?;
    let peak_reset = reset_peak();
    let (t, cpu) = (Instant::now(), cpu_seconds(CLOCK_PROCESS_CPUTIME_ID));
    let grid = load_murk(&path, &name)?;
    let seconds = t.elapsed().as_secs_f64();
    let cpu_seconds = cpu_seconds(CLOCK_PROCESS_CPUTIME_ID) - cpu;
    let peak = status_bytes("VmHWM")?;
    let after = status_bytes("VmRSS")?;
    let out = serde_json::json!({
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
        "baseline_bytes": baseline,
        "peak_bytes": peak.saturating_sub(baseline),
        "retained_bytes": after.saturating_sub(baseline),
        "peak_reset": peak_reset,
        "active_voxels": grid.stats().active_voxels,
        "structure_bytes": grid.memory_bytes(),
    });
    println!("{out}");
    Ok(())
}

/// Uniform points in a box (same points for both samplers).
fn in_box(rng: &mut SplitMix64, lo: DVec3, hi: DVec3) -> DVec3 {
    rng.vec(0.0, 1.0) * (hi - lo) + lo
}

/// A ray segment in file index space: `n` samples at `start + k·step`.
struct RaySeg {
    start: DVec3,
    step: DVec3,
    n: u32,
}

fn flag(args: &[String], name: &str, default: usize) -> Result<usize, String> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .filter(|v| *v > 0)
            .ok_or_else(|| format!("{name} needs a positive integer")),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median timings of `reps` passes: thread CPU seconds, wall seconds, and the sum.
struct Timed {
    cpu: f64,
    wall: f64,
    sum: f64,
}

fn timed(reps: usize, mut pass: impl FnMut() -> f64) -> Timed {
    let (mut cpu, mut wall) = (Vec::with_capacity(reps), Vec::with_capacity(reps));
    let mut sum = 0.0;
    pass(); // warm the caches and the accessor's first lookups
    for _ in 0..reps {
        let (t, c) = (Instant::now(), cpu_seconds(CLOCK_THREAD_CPUTIME_ID));
        sum = black_box(pass());
        cpu.push(cpu_seconds(CLOCK_THREAD_CPUTIME_ID) - c);
        wall.push(t.elapsed().as_secs_f64());
    }
    Timed {
        cpu: median(cpu),
        wall: median(wall),
        sum,
    }
}

/// Sum of `f` over the points (the sum keeps the samples from being optimised away).
fn sum_points(points: &[DVec3], f: impl Fn(DVec3) -> f32) -> f64 {
    points.iter().map(|p| f(black_box(*p)) as f64).sum()
}

/// Sum of `f` along every ray, its points shifted by `-shift` (file → local index space).
fn sum_rays(rays: &[RaySeg], shift: DVec3, f: impl Fn(DVec3) -> f32) -> f64 {
    let mut sum = 0.0;
    for r in rays {
        let mut p = r.start - shift;
        for _ in 0..r.n {
            sum += f(black_box(p)) as f64;
            p += r.step;
        }
    }
    sum
}

fn sample(args: &[String]) -> Result<(), String> {
    let (path, name) = path_and_grid(args)?;
    let n_points = flag(args, "--points", 1_000_000)?;
    let n_rays = flag(args, "--rays", 10_000)?;
    let reps = flag(args, "--reps", 5)?;

    let grid = load_murk(&path, &name)?;
    let (_meta, grids) = openvdb::io::read_file(&path).map_err(|e| e.to_string())?;
    let vgrid = grids
        .iter()
        .find_map(|g| match g {
            AnyGrid::Float(f) if f.name() == name => Some(f),
            _ => None,
        })
        .ok_or_else(|| format!("no float grid {name:?} in {path}"))?;
    let (lo, hi) = grid
        .stats()
        .active_index_bbox
        .ok_or("the grid has no active voxels")?;
    let (lo, hi) = (
        glam::IVec3::from_array(lo).as_dvec3(),
        glam::IVec3::from_array(hi).as_dvec3(),
    );
    let origin = grid.transform().origin.as_dvec3();

    // Random points in the active bbox (file index space).
    let mut rng = SplitMix64(0x5EED);
    let points: Vec<DVec3> = (0..n_points).map(|_| in_box(&mut rng, lo, hi)).collect();
    let local: Vec<DVec3> = points.iter().map(|p| *p - origin).collect();
    // Coherent rays: chords between two random points of the bbox, 0.5-voxel steps.
    let rays: Vec<RaySeg> = (0..n_rays)
        .map(|_| {
            let (a, b) = (in_box(&mut rng, lo, hi), in_box(&mut rng, lo, hi));
            let len = (b - a).length();
            let n = (len / 0.5).floor() as u32 + 1;
            RaySeg {
                start: a,
                step: (b - a).normalize_or_zero() * 0.5,
                n,
            }
        })
        .collect();
    let ray_samples: u64 = rays.iter().map(|r| r.n as u64).sum();

    // Both samplers must agree before their speeds mean anything.
    let max_diff = {
        let acc = vgrid.accessor();
        points
            .iter()
            .zip(&local)
            .take(100_000)
            .fold(0f64, |m, (p, q)| {
                let a = BoxSampler::sample(&acc, Vec3d::new(p.x, p.y, p.z)) as f64;
                m.max((a - grid.value_at_index(*q) as f64).abs())
            })
    };

    // The renderer calls through `&dyn Field`; black_box keeps it from devirtualising.
    let dyn_grid: &dyn Field = black_box(&grid);
    let vdb = |acc: &openvdb::tree::ValueAccessor<'_, _>, p: DVec3| {
        BoxSampler::sample(acc, Vec3d::new(p.x, p.y, p.z))
    };
    let runs = [
        (
            "murk_points",
            timed(reps, || sum_points(&local, |p| grid.value_at_index(p))),
            n_points as u64,
        ),
        (
            "murk_dyn_points",
            timed(reps, || sum_points(&local, |p| dyn_grid.value_at_index(p))),
            n_points as u64,
        ),
        (
            "openvdb_rs_points",
            timed(reps, || {
                let acc = vgrid.accessor();
                sum_points(&points, |p| vdb(&acc, p))
            }),
            n_points as u64,
        ),
        (
            "murk_rays",
            timed(reps, || sum_rays(&rays, origin, |p| grid.value_at_index(p))),
            ray_samples,
        ),
        (
            "murk_dyn_rays",
            timed(reps, || {
                sum_rays(&rays, origin, |p| dyn_grid.value_at_index(p))
            }),
            ray_samples,
        ),
        (
            "openvdb_rs_rays",
            timed(reps, || {
                let acc = vgrid.accessor();
                sum_rays(&rays, DVec3::ZERO, |p| vdb(&acc, p))
            }),
            ray_samples,
        ),
    ];
    let mut out = serde_json::json!({
        "file": path,
        "points": n_points,
        "rays": n_rays,
        "ray_samples": ray_samples,
        "reps": reps,
        "max_abs_diff": max_diff,
    });
    for (name, t, n) in &runs {
        // Samples per CPU second of the sampling thread, and per wall second.
        out[format!("{name}_per_s")] = (*n as f64 / t.cpu.max(1e-12)).into();
        out[format!("{name}_per_wall_s")] = (*n as f64 / t.wall.max(1e-12)).into();
        out[format!("{name}_sum")] = t.sum.into();
    }
    println!("{out}");
    Ok(())
}
