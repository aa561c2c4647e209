//! Motion blur against a peer renderer and closed forms, through the `murk` binary: a
//! real Mantaflow cache blurred by its own velocity grid against Blender 3.4 Cycles, a
//! camera moving over a small still blob (the streak its motion predicts), and a
//! sequence whose frames carry their own velocities.

mod common;
use common::camera::alpha_of;
use common::frames::{ok, same_image, scratch};
use common::motion::ABSORBING;
use common::tools;
use std::fs;
use std::path::Path;

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .display()
        .to_string()
}

/// The Pearson correlation of two images, and the ratio of their energies (sums of
/// squares) `b` over `a`.
fn correlation_and_energy(a: &[f64], b: &[f64]) -> (f64, f64) {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    let energy = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    (ab / (aa * bb).sqrt(), energy(b) / energy(a))
}

/// The camera both renderers look through: 5 units in front of the smoke along −y,
/// looking along +y (rotated 90° about x), a 70 mm lens on a 36 × 24 mm gate.
const STAGE: &str = "#usda 1.0\n\
(\n    upAxis = \"Z\"\n    metersPerUnit = 1\n)\n\n\
def Camera \"shot\"\n{\n\
    float focalLength = 70\n\
    float horizontalAperture = 36\n\
    float verticalAperture = 24\n\
    float2 clippingRange = (0.01, 1000)\n\
    double3 xformOp:translate = (0.9, -5, 0.75)\n\
    float3 xformOp:rotateXYZ = (90, 0, 0)\n\
    uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateXYZ\"]\n\
}\n";

/// A real Mantaflow smoke cache (`fixtures/caches/mantaflow_baked.vdb`, baked by Blender
/// 3.4 with scripts/mantaflow_cache.py: its staggered `velocity` grid as Mantaflow
/// writes it) blurred by a full-frame shutter centred on the frame and by a half-frame
/// one opening on it (which tells the blur's direction), at 24 fps, in murk and in Cycles through
/// the same camera, the velocity read by both as units a second (`velocity_unit`
/// SECOND, scale 1): the blur — the blurred alpha minus the sharp one — correlates
/// ≥ 0.8 between the two renderers and its energy (sum of squares) agrees within 20 %.
/// Measured: correlation 0.973 and 0.991, energy 0.961 and 0.961 (0.996 and 0.998 as
/// sums of |difference|). Cycles at
/// 64 samples: two seeds' blurs correlate 0.998 and their energies differ by 0.4 %, far
/// below the tolerance.
#[test]
fn a_mantaflow_cache_blurs_as_cycles_blurs_it() {
    need!(tools::BLENDER);
    let dir = scratch("peers-cycles");
    fs::write(dir.join("shot.usda"), STAGE).unwrap();
    let cache = fixture("caches/mantaflow_baked.vdb");
    let (res, sigma, fps) = ("64x48", "2", "24");
    let sigma3 = format!("{sigma},{sigma},{sigma}");
    let look = [
        "--camera-file",
        "shot.usda",
        "--res",
        res,
        "--sigma-a",
        &sigma3,
        "--sigma-s",
        "0,0,0",
        "--no-lights",
        "--float",
        "--spp",
        "64",
        "--fps",
        fps,
    ];
    let a = |name: &str| -> Vec<f64> {
        alpha_of(&dir.join(name))
            .into_iter()
            .map(f64::from)
            .collect()
    };
    let mut sharp = vec!["render", &cache, "-o", "murk_sharp.exr"];
    sharp.extend(look);
    ok(&dir, &sharp);
    let ms = a("murk_sharp.exr");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/cycles_motion_blur.py");
    // Centred on the frame, and opening on it: the blur's extent and its direction.
    for (i, shutter) in ["-0.5,0.5", "0,0.5"].into_iter().enumerate() {
        let murk_blur = format!("murk_blur{i}.exr");
        let mut blur = vec!["render", &cache, "-o", &murk_blur];
        blur.extend(look);
        blur.extend(["--shutter", shutter]);
        let err = ok(&dir, &blur);
        // The note that Mantaflow's unit is not per second, and the scale that is.
        assert!(
            err.contains("Mantaflow's") && err.contains("--velocity-scale 0.2344"),
            "{err}"
        );
        let out = tools::command(&tools::BLENDER)
            .args(["-b", "--factory-startup", "-noaudio", "--python"])
            .arg(&script)
            .arg("--")
            .arg(&cache)
            // The cache's voxel size (3 units over 32 voxels).
            .args(["0.09375", sigma, "0.9,-5,0.75", "90,0,0", "70", "36", "24"])
            .args([shutter, fps, "64", res])
            .arg(dir.join(format!("cycles{i}")))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let mb = a(&murk_blur);
        let (cs, cb) = (
            a(&format!("cycles{i}_sharp.exr")),
            a(&format!("cycles{i}_blur.exr")),
        );
        // The sharp images first: the same smoke through the same camera.
        let sharp_diff =
            ms.iter().zip(&cs).map(|(x, y)| (x - y).abs()).sum::<f64>() / ms.len() as f64;
        let ours: Vec<f64> = mb.iter().zip(&ms).map(|(b, s)| b - s).collect();
        let theirs: Vec<f64> = cb.iter().zip(&cs).map(|(b, s)| b - s).collect();
        let (corr, energy) = correlation_and_energy(&theirs, &ours);
        let l1 =
            ours.iter().map(|d| d.abs()).sum::<f64>() / theirs.iter().map(|d| d.abs()).sum::<f64>();
        eprintln!(
            "shutter {shutter}: sharp mean |dA| {sharp_diff:.4}; blur: correlation {corr:.3}, energy murk/Cycles {energy:.3} (sum of squares), {l1:.3} (sum of |d|)"
        );
        assert!(
            sharp_diff <= 0.01,
            "sharp images differ: mean |dA| {sharp_diff}"
        );
        assert!(corr >= 0.8, "shutter {shutter}: blurs correlate {corr}");
        assert!(
            (energy - 1.0).abs() <= 0.2,
            "shutter {shutter}: blur energy ratio {energy}"
        );
    }
}

/// The second moment of the columns' alpha (each column summed over the rows): the
/// variance of the image's horizontal profile, in pixels².
fn column_variance(a: &[f32], w: usize) -> f64 {
    let mut col = vec![0f64; w];
    for (i, v) in a.iter().enumerate() {
        col[i % w] += f64::from(*v);
    }
    let s: f64 = col.iter().sum();
    let mean = col
        .iter()
        .enumerate()
        .map(|(i, c)| i as f64 * c)
        .sum::<f64>()
        / s;
    col.iter()
        .enumerate()
        .map(|(i, c)| (i as f64 - mean).powi(2) * c)
        .sum::<f64>()
        / s
}

/// A camera translating sideways over a small still blob smears it into a streak as
/// long as the camera's motion projects: focal length × displacement / depth on the
/// film. The blob (radius 0.1, opaque) sits at the origin, the camera 10 units away
/// along +z looks down −z with a 50 mm lens on a 36 mm gate, 128 pixels wide, and moves
/// along x by 2 units a frame: a full-frame shutter sees it move d = 2 units, a streak
/// of 50/36 × 128 × 2/10 = 35.56 pixels. Every sample sees the still image translated,
/// so the blurred image is the sharp one convolved with a box of that length, whose
/// variance adds L²/12 to the sharp profile's: L = √(12 (σ²blur − σ²sharp)), within
/// 1 % (measured: 35.60 pixels; the blob's depth, ±1 % of the distance, spreads its
/// points' shifts by as much, which changes the variance only to second order).
#[test]
fn a_camera_moving_over_a_still_blob_streaks_it_by_its_projected_motion() {
    need!(tools::PYOPENVDB);
    let dir = scratch("peers-streak");
    let script = "import pyopenvdb as vdb, numpy as np, sys\n\
        i = np.arange(-3, 4, dtype=np.float64)\n\
        x, y, z = np.meshgrid(i, i, i, indexing='ij')\n\
        a = np.where(x * x + y * y + z * z <= 4.0, 40.0, 0.0).astype(np.float32)\n\
        d = vdb.FloatGrid(); d.name = 'density'\n\
        d.copyFromArray(a, ijk=(-3, -3, -3))\n\
        d.transform = vdb.createLinearTransform(0.05)\n\
        d.gridClass = vdb.GridClass.FOG_VOLUME\n\
        vdb.write(sys.argv[1], grids=[d])\n";
    let o = tools::command(&tools::PYOPENVDB)
        .args(["-c", script, dir.join("blob.vdb").to_str().unwrap()])
        .output()
        .expect("/usr/bin/python3 with pyopenvdb");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    fs::write(
        dir.join("shot.toml"),
        "input = \"blob.vdb\"\n\
         [camera]\n\
         focal_length = 50\n\
         horizontal_aperture = 36\n\
         vertical_aperture = 9\n\
         translate = [0, 0, 10]\n\
         [[camera.keys]]\n\
         frame = 0\n\
         translate = [-2, 0, 10]\n\
         [[camera.keys]]\n\
         frame = 2\n\
         translate = [2, 0, 10]\n",
    )
    .unwrap();
    let look = [
        "--frames",
        "1",
        "--res",
        "128x32",
        "--no-lights",
        "--sigma-a",
        "1,1,1",
        "--sigma-s",
        "0,0,0",
        "--float",
        "--spp",
        "64",
    ];
    let mut sharp = vec!["render", "shot.toml", "-o", "sharp.exr"];
    sharp.extend(look);
    ok(&dir, &sharp);
    let mut blur = vec![
        "render",
        "shot.toml",
        "-o",
        "blur.exr",
        "--shutter",
        "-0.5,0.5",
    ];
    blur.extend(look);
    ok(&dir, &blur);
    let w = 128;
    let (s, b) = (
        alpha_of(&dir.join("sharp.exr")),
        alpha_of(&dir.join("blur.exr")),
    );
    let (vs, vb) = (column_variance(&s, w), column_variance(&b, w));
    let streak = (12.0 * (vb - vs)).sqrt();
    let want = 50.0 / 36.0 * w as f64 * 2.0 / 10.0;
    eprintln!(
        "streak {streak:.3} px, closed form {want:.3} px (sharp profile's σ {:.3} px)",
        vs.sqrt()
    );
    assert!(
        (streak - want).abs() <= 0.01 * want,
        "streak {streak} px, want {want}"
    );
    // Nothing beyond the streak: alpha spans the streak and the still blob's own span.
    let span = |a: &[f32]| {
        let cols: Vec<f32> = (0..w)
            .map(|x| (0..32).map(|y| a[y * w + x]).sum())
            .collect();
        let lit: Vec<usize> = (0..w).filter(|x| cols[*x] > 1e-4).collect();
        (lit[lit.len() - 1] - lit[0] + 1) as f64
    };
    let (still, smeared) = (span(&s), span(&b));
    assert!(
        smeared <= want + still + 1.0 && smeared >= want,
        "alpha spans {smeared} columns: streak {want} + the blob's {still}"
    );
}

/// A sequence whose frames carry their own velocity grids blurs each frame from its own:
/// a box (density 1, x from 0 to 1.95 with the trilinear reach of its last voxels to
/// −0.05 and 2.0, 1 unit deep) moving +x at 24 units a second in frame 1 and −x in frame
/// 2, seen through a shutter that opens on the frame (`0,0.5`: half a frame, 1/48 s),
/// smears 0.5 units ahead of its motion: beyond its +x edge in frame 1, beyond its −x
/// edge in frame 2, each column's alpha the closed form of the still box averaged over
/// the displacements: within 6e-3 (16 rows of 64 samples: measured up to 4.3e-3 where the
/// ramp ends, the shutter's stratified times' noise, which 1024 samples take to 8e-4),
/// and within 5e-4 on average over each ramp's columns (measured 3.3e-4). Frame 3,
/// written without a
/// velocity grid, renders sharp — the same image as without a shutter — with one note
/// (a sequence says each note once, at the first frame that has it).
#[test]
fn a_sequence_blurs_each_frame_from_its_own_velocity() {
    need!(tools::PYOPENVDB, tools::IDIFF);
    let dir = scratch("peers-sequence");
    let script = "import pyopenvdb as vdb, numpy as np, sys\n\
        def box():\n\
        \x20   d = vdb.FloatGrid(); d.name = 'density'\n\
        \x20   d.copyFromArray(np.ones((40, 40, 20), dtype=np.float32), ijk=(0, 0, 0))\n\
        \x20   d.transform = vdb.createLinearTransform(0.05)\n\
        \x20   d.gridClass = vdb.GridClass.FOG_VOLUME\n\
        \x20   return d\n\
        for frame, vx in ((1, 24.0), (2, -24.0)):\n\
        \x20   v = vdb.Vec3SGrid(); v.name = 'vel'\n\
        \x20   a = np.zeros((80, 50, 30, 3), dtype=np.float32); a[..., 0] = vx\n\
        \x20   v.copyFromArray(a, ijk=(-20, -5, -5))\n\
        \x20   v.transform = vdb.createLinearTransform(0.05)\n\
        \x20   vdb.write('%s/box_%04d.vdb' % (sys.argv[1], frame), grids=[box(), v])\n\
        vdb.write(sys.argv[1] + '/box_0003.vdb', grids=[box()])\n";
    let o = tools::command(&tools::PYOPENVDB)
        .args(["-c", script, dir.to_str().unwrap()])
        .output()
        .expect("/usr/bin/python3 with pyopenvdb");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, h, width) = (128usize, 16usize, 4.0);
    let camera = [
        "--camera",
        "ortho",
        "--eye",
        "1,1,5",
        "--look-at",
        "1,1,0",
        "--ortho-width",
        "4",
        "--res",
        "128x16",
    ];
    let look = [&camera[..], &ABSORBING[..], &["--fps", "24"]].concat();
    let mut args = vec![
        "render",
        "box_####.vdb",
        "-o",
        "seq_####.exr",
        "--shutter",
        "0,0.5",
    ];
    args.extend(&look);
    let err = ok(&dir, &args);
    let notes: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("no velocity grid"))
        .collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].contains("0003") || notes[0].contains("frame 3"),
        "{err}"
    );
    let mut sharp = vec!["render", "box_0003.vdb", "-o", "sharp3.exr"];
    sharp.extend(&look);
    ok(&dir, &sharp);
    same_image(&dir.join("seq_0003.exr"), &dir.join("sharp3.exr"));

    let sigma_t = 1.5;
    // The still box's alpha along −z at x: the density's fraction at x (ramps to 0 at
    // −0.05 and 2.0) through its depth of 1.
    let still = |x: f64| {
        let r = ((x + 0.05) / 0.05).min((2.0 - x) / 0.05).clamp(0.0, 1.0);
        -(-sigma_t * r).exp_m1()
    };
    let (px, x0) = (width / w as f64, 1.0 - width / 2.0);
    for (frame, shift) in [(1, 0.5), (2, -0.5)] {
        let a = alpha_of(&dir.join(format!("seq_{frame:04}.exr")));
        let m = 200;
        let mut worst = (0.0, 0, 0.0, 0.0);
        let (mut bias, mut ramp) = (0.0, 0);
        for i in 0..w {
            let mut want = 0.0;
            for u in 0..m {
                let x = x0 + (i as f64 + (u as f64 + 0.5) / m as f64) * px;
                for k in 0..m {
                    // At time t in the shutter the box has moved by shift · t / (1/2 frame).
                    want += still(x - shift * (k as f64 + 0.5) / m as f64);
                }
            }
            want /= (m * m) as f64;
            let got = (0..h).map(|y| f64::from(a[y * w + i])).sum::<f64>() / h as f64;
            if want > 0.01 && want < 0.75 {
                bias += got - want;
                ramp += 1;
            }
            if (got - want).abs() > worst.0 {
                worst = ((got - want).abs(), i, got, want);
            }
        }
        eprintln!(
            "frame {frame}: largest |Δα| {:.2e} (column {}: {} against {})",
            worst.0, worst.1, worst.2, worst.3
        );
        let bias = bias / f64::from(ramp);
        eprintln!("frame {frame}: mean Δα over the {ramp} ramp columns {bias:+.1e}");
        assert!(worst.0 < 6e-3, "frame {frame}: {worst:?}");
        assert!(
            bias.abs() < 5e-4 && ramp >= 30,
            "frame {frame}: bias {bias} over {ramp}"
        );
        // Ahead of the motion the smear; behind it nothing past the box.
        let col = |x: f64| ((x - x0) / px) as usize;
        let (ahead, behind) = if shift > 0.0 {
            (2.25, -0.1)
        } else {
            (-0.3, 2.05)
        };
        assert!(a[col(ahead)] > 0.1, "frame {frame}: {:?}", &a[..w]);
        assert!(a[col(behind)] == 0.0, "frame {frame}: {:?}", &a[..w]);
    }
}
