//! The sweep against a checked one, a closed form, and its own one-thread form.

use super::*;

/// The sweep as first written (f64, every tap bounds-checked): the reference the
/// fast one is held to.
#[allow(clippy::too_many_arguments)]
fn sweep_checked(
    grid: &Grid,
    rho: &[f32],
    rho_j: &[f32],
    d: DVec3,
    sigma_t: f64,
    albedo: f64,
    h: f64,
    radiance: &mut [f32],
) {
    let da = d.abs();
    let a = if da.x >= da.y && da.x >= da.z {
        0
    } else if da.y >= da.z {
        1
    } else {
        2
    };
    let (b, cax) = ((a + 1) % 3, (a + 2) % 3);
    let dv = d.to_array();
    let step = h / da[a]; // world length of the characteristic
    // Upstream point, in nodes, relative to the node along b and c.
    let ob = -step * dv[b] / h;
    let oc = -step * dv[cax] / h;
    let (fb, fc) = (ob.floor(), oc.floor());
    let (wb, wc) = (ob - fb, oc - fc);
    let (fb, fc) = (fb as isize, fc as isize);
    let weights = [
        (0isize, 0isize, (1.0 - wb) * (1.0 - wc)),
        (1, 0, wb * (1.0 - wc)),
        (0, 1, (1.0 - wb) * wc),
        (1, 1, wb * wc),
    ];
    let st = grid.stride;
    let dims = grid.dims;
    let forward = dv[a] > 0.0;
    let sigma_step = sigma_t * step;
    for ia_step in 0..dims[a] {
        let ia = if forward {
            ia_step
        } else {
            dims[a] - 1 - ia_step
        };
        let up_a = if forward {
            ia as isize - 1
        } else {
            ia as isize + 1
        };
        let has_up = up_a >= 0 && (up_a as usize) < dims[a];
        for ic in 0..dims[cax] {
            for ib in 0..dims[b] {
                let n = ia * st[a] + ib * st[b] + ic * st[cax];
                let (mut l_up, mut r_up, mut rj_up) = (0.0f64, 0.0f64, 0.0f64);
                if has_up {
                    for &(db, dc, w) in &weights {
                        if w == 0.0 {
                            continue;
                        }
                        let jb = ib as isize + fb + db;
                        let jc = ic as isize + fc + dc;
                        if jb < 0 || jc < 0 || jb as usize >= dims[b] || jc as usize >= dims[cax] {
                            continue;
                        }
                        let m = up_a as usize * st[a] + jb as usize * st[b] + jc as usize * st[cax];
                        l_up += w * radiance[m] as f64;
                        r_up += w * rho[m] as f64;
                        rj_up += w * rho_j[m] as f64;
                    }
                }
                let r_here = rho[n] as f64;
                let rho_mean = 0.5 * (r_here + r_up);
                if rho_mean <= 0.0 {
                    radiance[n] = l_up as f32;
                    continue;
                }
                let tau = sigma_step * rho_mean;
                let j_here = if r_here > 0.0 {
                    rho_j[n] as f64 / r_here
                } else {
                    0.0
                };
                let j_up = if r_up > 0.0 { rj_up / r_up } else { j_here };
                let j_here = if r_here > 0.0 { j_here } else { j_up };
                let e = (-tau).exp();
                // P = (1 − e^{−τ} − τ·e^{−τ})/τ, by its series where τ is small.
                let p = if tau < 1e-3 {
                    tau * (0.5 - tau / 3.0)
                } else {
                    (1.0 - e - tau * e) / tau
                };
                let one_minus = if tau < 1e-3 {
                    tau * (1.0 - 0.5 * tau)
                } else {
                    1.0 - e
                };
                let l = l_up * e + albedo * (j_here * (one_minus - p) + j_up * p);
                radiance[n] = l.max(0.0) as f32;
            }
        }
    }
}

/// A lumpy medium with a source that is zero in places (edges, holes), on a lattice
/// whose sides differ, so every axis can be the dominant one and both directions.
fn lattice() -> (Grid, Vec<f32>, Vec<f32>) {
    let g = Grid::new([7, 9, 6]);
    let mut rho = vec![0f32; g.len];
    let mut rj = vec![0f32; g.len];
    for n in 0..g.len {
        let [i, j, k] = g.coords(n);
        let v = ((i * 7 + j * 3 + k * 5) % 11) as f32 / 10.0;
        if (i + j + k) % 4 != 0 && i > 0 && j > 0 {
            rho[n] = 0.2 + 2.0 * v;
            rj[n] = if (i * j) % 3 == 0 {
                0.0
            } else {
                rho[n] * (1.0 + v)
            };
        }
    }
    (g, rho, rj)
}

#[test]
fn the_fast_sweep_equals_the_checked_one_in_every_direction() {
    let (g, rho, rj) = lattice();
    for (t, d) in [
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, -1.0, 0.0),
        DVec3::new(0.3, 0.2, -0.9),
        DVec3::new(-0.7, 0.69, 0.1),
        DVec3::new(0.5, -0.5, 0.5),
        DVec3::new(-0.2, -0.95, -0.3),
        DVec3::new(0.6, 0.1, 0.79),
    ]
    .iter()
    .enumerate()
    {
        let d = d.normalize();
        let (mut fast, mut slow) = (vec![0f32; g.len], vec![0f32; g.len]);
        // From light (τ of a step ≪ 1, the series) to thick (τ ≫ 1).
        for sigma in [0.001, 0.5, 30.0] {
            let rj1: Vec<[f32; 1]> = rj.iter().map(|v| [*v]).collect();
            let mut fast1 = vec![[0f32; 1]; g.len];
            sweep(
                &g,
                &rho,
                &rj1,
                d,
                [sigma],
                [0.9],
                0.7,
                &mut fast1,
                &mut vec![[0f32; 1]; g.len],
                1,
            );
            fast.iter_mut().zip(&fast1).for_each(|(f, v)| *f = v[0]);
            sweep_checked(&g, &rho, &rj, d, sigma, 0.9, 0.7, &mut slow);
            let scale = slow.iter().fold(0f32, |m, v| m.max(*v));
            assert!(scale > 0.0, "direction {t}: nothing swept");
            for (n, (a, b)) in fast.iter().zip(&slow).enumerate() {
                assert!(
                    (a - b).abs() <= 2e-5 * scale,
                    "direction {t}, σ {sigma}, node {:?}: {a} against {b}",
                    g.coords(n)
                );
            }
        }
    }
}

#[test]
fn three_channels_swept_together_are_each_swept_alone() {
    let (g, rho, rj) = lattice();
    let d = DVec3::new(-0.4, 0.3, 0.87).normalize();
    let (sigma, albedo) = ([0.2, 3.0, 40.0], [0.99, 0.5, 0.9]);
    // Each channel's source a different multiple of the lumpy one.
    let rj3: Vec<[f32; 3]> = rj.iter().map(|v| [*v, 2.0 * v, 0.5 * v]).collect();
    let mut l3 = vec![[0f32; 3]; g.len];
    sweep(
        &g,
        &rho,
        &rj3,
        d,
        sigma,
        albedo,
        0.7,
        &mut l3,
        &mut vec![[0f32; 3]; g.len],
        2,
    );
    for ch in 0..3 {
        let rj1: Vec<[f32; 1]> = rj3.iter().map(|v| [v[ch]]).collect();
        let mut l1 = vec![[0f32; 1]; g.len];
        sweep(
            &g,
            &rho,
            &rj1,
            d,
            [sigma[ch]],
            [albedo[ch]],
            0.7,
            &mut l1,
            &mut vec![[0f32; 1]; g.len],
            1,
        );
        for (a, b) in l3.iter().zip(&l1) {
            assert_eq!(a[ch], b[0], "channel {ch}");
        }
        assert!(l1.iter().any(|v| v[0] > 0.0), "channel {ch}: nothing swept");
    }
}

#[test]
fn an_axis_sweep_through_a_uniform_medium_is_the_closed_form() {
    // Along +x through a uniform medium with a uniform J: L = ω·J·(1 − e^{−σρ·(x + h/2)}),
    // x the distance from the first plane (whose step back into the empty outside
    // holds density on its half, the mean of the two ends).
    let g = Grid::new([12, 3, 3]);
    let rho = vec![2.0f32; g.len];
    let rj = vec![[2.0 * 1.5; 1]; g.len];
    let mut l = vec![[0f32; 1]; g.len];
    let (sigma, albedo, h) = (0.4, 0.8, 0.5);
    sweep(
        &g,
        &rho,
        &rj,
        DVec3::X,
        [sigma],
        [albedo],
        h,
        &mut l,
        &mut vec![[0f32; 1]; g.len],
        1,
    );
    for (n, [got]) in l.iter().enumerate() {
        let x = (g.coords(n)[0] as f64 + 0.5) * h;
        let want = albedo * 1.5 * (1.0 - (-sigma * 2.0 * x).exp());
        assert!(
            (*got as f64 - want).abs() < 1e-5,
            "node {:?}: {got} against {want}",
            g.coords(n)
        );
    }
}

/// The sweep as it was before it was split into pieces (one thread, node order in
/// place): the split one is held to it bit for bit.
#[allow(clippy::too_many_arguments)]
fn sweep_serial<const C: usize>(
    grid: &Grid,
    rho: &[f32],
    rho_j: &[[f32; C]],
    d: DVec3,
    sigma_t: [f64; C],
    albedo: [f64; C],
    h: f64,
    radiance: &mut [[f32; C]],
) {
    let da = d.abs();
    let a = if da.x >= da.y && da.x >= da.z {
        0
    } else if da.y >= da.z {
        1
    } else {
        2
    };
    // The row axis b is the other axis with the smaller stride, so a row's nodes are
    // near each other in memory.
    let (b, cax) = if a == 0 { (1, 2) } else { (0, 3 - a) };
    let dv = d.to_array();
    let step = h / da[a]; // world length of the characteristic
    // Upstream point, in nodes, relative to the node along b and c (|o| ≤ 1).
    let ob = -step * dv[b] / h;
    let oc = -step * dv[cax] / h;
    let (fb, fc) = (ob.floor(), oc.floor());
    let (wb, wc) = (ob - fb, oc - fc);
    let (fb, fc) = (fb as isize, fc as isize);
    let w = [
        ((1.0 - wb) * (1.0 - wc)) as f32,
        (wb * (1.0 - wc)) as f32,
        ((1.0 - wb) * wc) as f32,
        (wb * wc) as f32,
    ];
    let st = grid.stride;
    let dims = grid.dims;
    let (nb, nc) = (dims[b] as isize, dims[cax] as isize);
    let forward = dv[a] > 0.0;
    let node = Node {
        sigma_step: sigma_t.map(|s| (s * step) as f32),
        albedo: albedo.map(|a| a as f32),
    };
    let zero = [0f32; C];
    // Rows (along b) whose four upstream nodes are all in range: ib + fb ≥ 0 and
    // ib + fb + 1 < nb.
    let ib_lo = (-fb).clamp(0, nb) as usize;
    let ib_hi = (nb - 1 - fb).clamp(ib_lo as isize, nb) as usize;
    for ia_step in 0..dims[a] {
        let ia = if forward {
            ia_step
        } else {
            dims[a] - 1 - ia_step
        };
        let up_a = if forward {
            ia as isize - 1
        } else {
            ia as isize + 1
        };
        let plane = ia * st[a];
        if up_a < 0 || up_a as usize >= dims[a] {
            // The first plane: nothing comes in from outside the lattice.
            for ic in 0..dims[cax] {
                for ib in 0..dims[b] {
                    let n = plane + ib * st[b] + ic * st[cax];
                    radiance[n] = node.radiance(&zero, 0.0, &zero, rho[n], &rho_j[n]);
                }
            }
            continue;
        }
        let up_plane = up_a as usize * st[a];
        for ic in 0..dims[cax] {
            let jc = ic as isize + fc;
            let row = plane + ic * st[cax];
            // The upstream values at the foot, with bounds checks.
            let checked = |ib: usize, radiance: &[[f32; C]]| -> ([f32; C], f32, [f32; C]) {
                let (mut l, mut r, mut rj) = ([0f32; C], 0.0f32, [0f32; C]);
                for (k, wk) in w.iter().enumerate() {
                    let (jb, jc) = (ib as isize + fb + (k & 1) as isize, jc + (k >> 1) as isize);
                    if *wk == 0.0 || jb < 0 || jc < 0 || jb >= nb || jc >= nc {
                        continue;
                    }
                    let m = up_plane + jb as usize * st[b] + jc as usize * st[cax];
                    r += wk * rho[m];
                    for ch in 0..C {
                        l[ch] += wk * radiance[m][ch];
                        rj[ch] += wk * rho_j[m][ch];
                    }
                }
                (l, r, rj)
            };
            if jc < 0 || jc + 1 >= nc {
                for ib in 0..dims[b] {
                    let n = row + ib * st[b];
                    let (l, r, rj) = checked(ib, radiance);
                    radiance[n] = node.radiance(&l, r, &rj, rho[n], &rho_j[n]);
                }
                continue;
            }
            for ib in (0..ib_lo).chain(ib_hi..dims[b]) {
                let n = row + ib * st[b];
                let (l, r, rj) = checked(ib, radiance);
                radiance[n] = node.radiance(&l, r, &rj, rho[n], &rho_j[n]);
            }
            // The row's interior: the four upstream nodes m, m + sb, m + sc, m + sb + sc.
            let (sb, sc) = (st[b], st[cax]);
            let up_row = up_plane + jc as usize * sc;
            for ib in ib_lo..ib_hi {
                let n = row + ib * sb;
                let m = up_row + (ib as isize + fb) as usize * sb;
                let taps = [m, m + sb, m + sc, m + sb + sc];
                let (mut l, mut r, mut rj) = ([0f32; C], 0.0f32, [0f32; C]);
                for (t, wk) in taps.iter().zip(&w) {
                    r += wk * rho[*t];
                    for ch in 0..C {
                        l[ch] += wk * radiance[*t][ch];
                        rj[ch] += wk * rho_j[*t][ch];
                    }
                }
                radiance[n] = node.radiance(&l, r, &rj, rho[n], &rho_j[n]);
            }
        }
    }
}

/// Split into pieces on several threads, the sweep is the one-thread sweep to the bit,
/// in every direction (each axis dominant, both ways, the foot on either side of the
/// node's row and column) and with the lattice's edge rows checked: on a lattice whose
/// planes are large enough to be split (MIN_PIECE_NODES).
#[test]
fn a_sweep_split_over_threads_is_the_serial_sweep_to_the_bit() {
    let g = Grid::new([40, 37, 33]);
    let mut rho = vec![0f32; g.len];
    let mut rj = vec![[0f32; 3]; g.len];
    for n in 0..g.len {
        let [i, j, k] = g.coords(n);
        let v = ((i * 7 + j * 3 + k * 5) % 11) as f32 / 10.0;
        if (i + j + k) % 4 != 0 && i > 0 && j + 1 < g.dims[1] {
            rho[n] = 0.2 + 2.0 * v;
            if (i * j) % 3 != 0 {
                rj[n] = [rho[n] * (1.0 + v), rho[n] * v, 0.3 * rho[n]];
            }
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    let dirs = [
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(-1.0, 0.0, 0.0),
        DVec3::new(0.0, -1.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.3, 0.2, -0.9),
        DVec3::new(-0.7, 0.69, 0.1),
        DVec3::new(0.5, -0.5, 0.5),
        DVec3::new(-0.2, -0.95, -0.3),
        DVec3::new(0.6, 0.1, 0.79),
        DVec3::new(-0.6, -0.3, -0.74),
    ];
    for (t, d) in dirs.iter().enumerate() {
        let d = d.normalize();
        let (sigma, albedo) = ([0.2, 3.0, 40.0], [0.99, 0.5, 0.9]);
        let mut want = vec![[0f32; 3]; g.len];
        sweep_serial(&g, &rho, &rj, d, sigma, albedo, 0.7, &mut want);
        assert!(
            want.iter().any(|v| v[0] > 0.0),
            "direction {t}: nothing swept"
        );
        for pieces in [1, 2, 3, 8] {
            let mut got = vec![[f32::NAN; 3]; g.len];
            let mut planes = vec![[f32::NAN; 3]; g.len];
            pool.install(|| {
                sweep(
                    &g,
                    &rho,
                    &rj,
                    d,
                    sigma,
                    albedo,
                    0.7,
                    &mut got,
                    &mut planes,
                    pieces,
                )
            });
            for (n, (a, b)) in got.iter().zip(&want).enumerate() {
                assert!(
                    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "direction {t}, {pieces} pieces, node {:?}: {a:?} against {b:?}",
                    g.coords(n)
                );
            }
        }
    }
}
