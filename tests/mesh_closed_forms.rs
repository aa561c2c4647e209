//! Meshes against closed forms, through the library's march (`Volume::of` a mesh
//! field): a constant density in a jittered tet mesh of the unit cube, in a mesh of
//! hexahedra, wedges and pyramids, and in a mesh whose cell volumes span > 10,000×
//! gives α = 1 − e^{−σt·ℓ} with ℓ the chord of the hull; a linear point field gives
//! α = 1 − e^{−σt·ℓ·f(chord midpoint)}. And VTK's own interpolation (vtkProbeFilter,
//! stored in fixtures/reference.json) at 60 points of every fixture.

mod common;

use common::march::{medium, ray, rel};
use glam::DVec3;
use murk::field::mesh::{MeshField, MeshSource};
use murk::integrate::Volume;
use serde_json::Value;

fn source(name: &str) -> MeshSource {
    let path = format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
    MeshSource::open(std::path::Path::new(&path)).unwrap_or_else(|e| panic!("{e}"))
}

/// Parametric interval of `o + t·d` inside the box.
fn box_interval(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut a, mut b) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (mut u, mut v) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        a = a.max(u);
        b = b.min(v);
    }
    (a < b).then_some((a, b))
}

fn rng(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*s >> 11) as f64 / (1u64 << 53) as f64
}

/// Rays from outside the box toward random points inside it (unit directions).
fn rays(lo: DVec3, hi: DVec3, n: usize, seed: u64) -> Vec<(DVec3, DVec3)> {
    let mut s = seed;
    let c = (lo + hi) * 0.5;
    let r = (hi - lo).length();
    (0..n)
        .map(|_| {
            let target = lo + (hi - lo) * DVec3::new(rng(&mut s), rng(&mut s), rng(&mut s));
            let dir =
                DVec3::new(rng(&mut s) - 0.5, rng(&mut s) - 0.5, rng(&mut s) - 0.5).normalize();
            let o = target - dir * (2.0 * r) + (c - target) * 0.0;
            (o, dir)
        })
        .collect()
}

/// α through a constant-density field (cell data 1) against 1 − e^{−σt·chord}, by the
/// march at several step sizes.
fn constant_alpha(name: &str, lo: DVec3, hi: DVec3) {
    let src = source(name);
    let f = src.field("one").expect("array 'one'");
    for (k, (o, d)) in rays(lo, hi, 60, 11).into_iter().enumerate() {
        let (a, b) = box_interval(o, d, lo, hi).unwrap();
        let chord = b - a;
        let direct = f.geometry().chord_length(o, d, 0.0, 1e9);
        assert!(
            (direct - chord).abs() <= 1e-9,
            "{name} ray {k}: walk {direct} vs {chord}"
        );
        for sigma_t in [0.5, 3.0] {
            let vol = Volume::of(&f, medium(sigma_t, 0.0, 0.0));
            let want = -(-sigma_t * chord).exp_m1();
            for step in [0.5, 2.0] {
                let got = ray(&vol, None, o, d, step, 0.37).alpha();
                assert!(
                    rel(got, want) <= 1e-6,
                    "{name} ray {k} σt {sigma_t} step {step}: α {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn constant_density_in_a_jittered_tet_cube() {
    constant_alpha("tets_zlib.vtu", DVec3::ZERO, DVec3::ONE);
}

#[test]
fn constant_density_in_hexahedra_wedges_and_pyramids() {
    let src = source("mixed_zlib.vtu");
    let by_type = src.mesh.cells_by_type();
    assert_eq!(by_type.len(), 3, "{by_type:?}");
    constant_alpha("mixed_zlib.vtu", DVec3::ZERO, DVec3::new(3.0, 2.0, 2.0));
}

#[test]
fn constant_density_with_cell_volumes_spanning_ten_thousand_times() {
    let src = source("graded.vtu");
    let m = &src.mesh;
    let vols: Vec<f64> = (0..m.cells())
        .map(|c| {
            let p: Vec<DVec3> = m
                .cell(c)
                .iter()
                .map(|&i| DVec3::from_array(m.points[i as usize]))
                .collect();
            ((p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0]) / 6.0).abs()
        })
        .collect();
    let (mn, mx) = vols
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(mx / mn > 1e4, "volume ratio {}", mx / mn);
    constant_alpha("graded.vtu", DVec3::ZERO, DVec3::ONE);
}

/// A linear point field f = 0.2 + 0.5x + 0.3y + 0.1z is reproduced exactly by linear
/// tets and by the isoparametric hexahedra, wedges and pyramids: ∫f = ℓ·f(midpoint).
#[test]
fn linear_point_field_is_reproduced_exactly() {
    let f = |p: DVec3| 0.2 + 0.5 * p.x + 0.3 * p.y + 0.1 * p.z;
    for (name, hi) in [
        ("tets_binary.vtu", DVec3::ONE),
        ("graded.vtu", DVec3::ONE),
        ("mixed_appended.vtu", DVec3::new(3.0, 2.0, 2.0)),
    ] {
        let src = source(name);
        let field = src.field("linear").unwrap();
        for (k, (o, d)) in rays(DVec3::ZERO, hi, 40, 5).into_iter().enumerate() {
            let (a, b) = box_interval(o, d, DVec3::ZERO, hi).unwrap();
            let integral = (b - a) * f(o + d * (0.5 * (a + b)));
            let direct = field.integrate_world(o, d, 0.0, 1e9);
            assert!(
                rel(direct, integral) <= 1e-9,
                "{name} ray {k}: ∫f {direct} vs {integral}"
            );
            let sigma_t = 1.3;
            let vol = Volume::of(&field, medium(sigma_t, 0.0, 0.0));
            let want = -(-sigma_t * integral).exp_m1();
            let got = ray(&vol, None, o, d, 1.0, 0.5).alpha();
            assert!(rel(got, want) <= 1e-6, "{name} ray {k}: α {got} vs {want}");
        }
    }
}

/// Values at 60 points per fixture against VTK's interpolation: the weights of
/// vtkCell::EvaluatePosition in the cell that contains the point (point data linear in
/// tets, parametric in the others; cell data constant). vtkProbeFilter's own answers
/// are stored beside them but accept a neighbouring cell within 1e-3 of its parametric
/// range and extrapolate there, so they differ on faces (cell data) and next to much
/// larger cells (2e-4 in the graded mesh).
#[test]
fn values_match_vtk_interpolation() {
    let root = env!("CARGO_MANIFEST_DIR");
    let r: Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{root}/fixtures/reference.json")).unwrap(),
    )
    .unwrap();
    let files = r["meshes"]["files"].as_object().unwrap();
    let (mut checked, mut skipped) = (0, 0);
    for (name, want) in files {
        let src = source(name);
        let pts = want["probe"]["points"].as_array().unwrap();
        let cells = want["in_cell"]["cell"].as_array().unwrap();
        let tets_only = src.mesh.cells_by_type().len() == 1;
        for (array, vals) in want["in_cell"]["values"].as_object().unwrap() {
            // VTK's reference holds a vector array's first component.
            let field: MeshField = src.component_field(array, 0).unwrap();
            let cell_data = src.mesh.cell_array(array).is_some();
            for (i, p) in pts.iter().enumerate() {
                if cells[i].as_i64().unwrap() < 0 {
                    continue;
                }
                let p = DVec3::new(
                    p[0].as_f64().unwrap(),
                    p[1].as_f64().unwrap(),
                    p[2].as_f64().unwrap(),
                );
                let w = vals[i].as_f64().unwrap();
                let vtk_cell = cells[i].as_u64().unwrap() as usize;
                let mine = field.cell_at_world_point(p).expect("inside") as usize;
                if mine != vtk_cell {
                    // Only where VTK's bilinear face and murk's two triangles part: the
                    // non-planar quads around the sheared point of the mixed mesh.
                    let sheared = 18;
                    assert!(
                        src.mesh.cell(mine).contains(&sheared)
                            && src.mesh.cell(vtk_cell).contains(&sheared),
                        "{name} point {i} {p}: cell {mine}, VTK's {vtk_cell}"
                    );
                    skipped += 1;
                    continue;
                }
                let got = field.value_at_world_point(p);
                // VTK's Newton iteration for hexahedra, wedges and pyramids stops at
                // a parametric change of 1e-3 (quadratic convergence: ~1e-7 left).
                let tol = if cell_data || tets_only {
                    1e-12 * (1.0 + w.abs())
                } else {
                    1e-6 * (1.0 + w.abs())
                };
                assert!(
                    (got - w).abs() <= tol,
                    "{name} {array} point {i} {p}: {got} vs VTK {w}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 11 * 50, "{checked} values checked");
    assert!(
        skipped * 20 < checked,
        "{skipped} of {checked} in another cell"
    );
}

/// Lit by a sun with shadows (the shadow module's exact density integral through the
/// mesh), constant density in the jittered tet cube scatters exactly what the analytic
/// constant box of the same cube does: the march, the shadows and the phase see the
/// same medium. Alpha to 1e-9; the scattered light to 1e-5 at 0.1-voxel steps (the
/// segments end at the mesh lattice's brick faces, not the box's cells, and the source
/// term's quadrature over them differs by that much).
#[test]
fn single_scattering_with_shadows_matches_the_analytic_box() {
    use common::march::Sun;
    use murk::field::shapes::ConstantBox;
    let src = source("tets_zlib.vtu");
    let mesh = src.field("one").unwrap();
    let cube = ConstantBox::new(DVec3::ZERO, DVec3::ONE, 1.0, 0.02).unwrap();
    let toward = DVec3::new(0.3, 0.5, 0.8).normalize();
    let mut s = 9;
    for k in 0..20 {
        let target = DVec3::new(rng(&mut s), rng(&mut s), rng(&mut s));
        let d = DVec3::new(rng(&mut s) - 0.5, rng(&mut s) - 0.5, rng(&mut s) - 0.5).normalize();
        let o = target - d * 3.0;
        let m = medium(0.4, 1.1, 0.3);
        let got = {
            let sun = Sun {
                field: &mesh,
                toward,
                irradiance: 2.0,
            };
            ray(&Volume::of(&mesh, m), Some(&sun), o, d, 0.1, 0.5)
        };
        let want = {
            let sun = Sun {
                field: &cube,
                toward,
                irradiance: 2.0,
            };
            ray(
                &Volume::of(&cube, m),
                Some(&sun),
                o,
                d,
                0.1 * got_voxel(&mesh) / 0.02,
                0.5,
            )
        };
        assert!(got.scatter.x > 0.0, "ray {k}: no light");
        assert!(
            rel(got.alpha(), want.alpha()) <= 1e-9,
            "ray {k}: α {} vs {}",
            got.alpha(),
            want.alpha()
        );
        assert!(
            rel(got.scatter.x, want.scatter.x) <= 1e-5,
            "ray {k}: scatter {} vs box {}",
            got.scatter.x,
            want.scatter.x
        );
    }
}

/// World size of the mesh lattice's voxel (steps are in voxels: the box marches the
/// same world step).
fn got_voxel(f: &MeshField) -> f64 {
    use murk::field::Field;
    f.transform().voxel_size().x
}
