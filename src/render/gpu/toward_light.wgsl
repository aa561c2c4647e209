// Light toward a point: ∫ρ ds to each light from its deep shadow map (dsm.wgsl) or from a
// shadow ray marched through the grid as src/shadow/march.rs marches it, and the ground
// plane's light (src/integrate/ground.rs). Compiled after march.wgsl and dsm.wgsl.

// The trilinear density at local index point p (VoxelGrid::value_at_index).
fn value_at(p: vec3<f32>) -> f32 {
    let c = floor(p);
    let v = cell_corners(vec3<i32>(c));
    return trilinear(vec4<f32>(v[0], v[1], v[2], v[3]), vec4<f32>(v[4], v[5], v[6], v[7]), p - c);
}

// ∫ρ ds from world point pw (local index point pi) toward light l along a shadow ray:
// over the grid's cells (empty ones skipped), constant cells exactly, the others by the
// midpoint rule on equal steps of at most P.shadow.x voxels (0: exactly, per voxel);
// stopped once past P.shadow.y.
fn march_to_light(l: u32, pw: vec3<f32>, pi: vec3<f32>) -> f32 {
    // The light in index space (light_f 12..14): the sun's direction, or the point
    // light's position.
    let v = vec3<f32>(light_f(l, 12u), light_f(l, 13u), light_f(l, 14u));
    var d = v;
    var dist = BIG;
    if (light_f(l, 0u) != 0.0) {
        let lw = vec3<f32>(light_f(l, 4u), light_f(l, 5u), light_f(l, 6u));
        dist = length(lw - pw);
        if (!(dist > 0.0)) {
            return 0.0;
        }
        d = (v - pi) / dist;
    }
    let r = Ray(pi, d);
    let speed = length(d);
    if (!(speed > 0.0) || !(speed < BIG)) {
        return 0.0;
    }
    var h = 0.0;
    if (P.shadow.x > 0.0) {
        h = P.shadow.x / speed;
    }
    var sum = 0.0;
    var cells = cells_start(r, 0.0, dist);
    var cell: Cell;
    var span: vec2<f32>;
    var budget = 16777216u;
    loop {
        if (budget == 0u || !cells_next(&cells, r, false, &cell, &span)) {
            break;
        }
        let t0 = span.x;
        let t1 = span.y;
        let len = t1 - t0;
        if (cell.lo == cell.hi) {
            sum += cell.hi * len;
        } else if (h > 0.0) {
            let n = u32(clamp(ceil(len / h), 1.0, 1e7));
            let ds = len / f32(n);
            var acc = 0.0;
            for (var k = 0u; k < n && budget > 0u; k++) {
                budget -= 1u;
                acc += value_at(ray_at(r, t0 + (f32(k) + 0.5) * ds));
            }
            sum += acc * ds;
        } else {
            var walk = walk_start(r, t0);
            sum += integral(r, &walk, t0, t1, &budget);
        }
        if (sum > P.shadow.y) {
            break;
        }
    }
    return sum;
}

// ∫ρ ds from world point pw (local index point pi) toward light l, as the light's
// shadows say: its map, a marched ray, or none (0).
fn light_depth(l: u32, pw: vec3<f32>, pi: vec3<f32>) -> f32 {
    if (light_f(l, 1u) == 3.0) {
        return march_to_light(l, pw, pi);
    }
    return density_to_light(l, pw);
}

// The ground plane where the camera ray r (world origin wo, direction wd) meets it at
// |tg| (the sign: the side of the plane the camera is on, the normal's y): the
// irradiance of the lights that light that side, without the volume and through it
// (Ground::light_at), written at results[at..at + 8] (rgb, |tg|, rgb, 0).
fn ground_light(wo: vec3<f32>, wd: vec3<f32>, r: Ray, tg: f32, at: u32) {
    var open = vec3<f32>(0.0);
    var through = vec3<f32>(0.0);
    if (tg != 0.0) {
        let x = wo + wd * abs(tg);
        let xi = ray_at(r, abs(tg));
        let n = vec3<f32>(0.0, sign(tg), 0.0);
        for (var l = 0u; l < min(P.n_lights, MAX_LIGHTS); l++) {
            var irr: vec3<f32>;
            let travel = incident(l, x, &irr);
            let cos_n = dot(n, -travel);
            if (!(cos_n > 0.0)) {
                continue;
            }
            let e = irr * cos_n;
            let tau = P.sigma_t.xyz * light_depth(l, x, xi);
            open += e;
            through += e * exp(-tau);
        }
    }
    results[at] = open.x;
    results[at + 1u] = open.y;
    results[at + 2u] = open.z;
    results[at + 3u] = abs(tg);
    results[at + 4u] = through.x;
    results[at + 5u] = through.y;
    results[at + 6u] = through.z;
    results[at + 7u] = 0.0;
}
