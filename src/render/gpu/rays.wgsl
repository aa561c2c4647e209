// Camera rays made on the GPU from each sample's pixel, as the CPU's pixel loop makes them
// (render/pixels.rs: `sample_point`, `camera_sample`; gpu/pixels.rs): the camera's rays as
// affine maps of the pixel position (`Camera::ray_affine`, made in f64 on the host), cut
// to the film's clipping planes, to a holdout's depth and to a visible ground plane; the
// jitter inside the pixel and the step's offset drawn from the same hashes of the seed,
// the pixel and the sample as the CPU's `unit_random` (the top 24 of its 53 bits). Also
// the 64-bit arithmetic on (lo, hi) pairs of u32 that the hashes and the path tracer's
// streams take. Compiled with march.wgsl.

struct CameraRays {
    origin0: vec4<f32>,  // the world origin of the ray through pixel position (0, 0), w: 1
                         // where directions are normalised (a pinhole)
    origin_x: vec4<f32>, // and its change per pixel right, w: 1 where the film's clipping
    origin_y: vec4<f32>, // planes cut rays; per pixel down
    dir0: vec4<f32>,     // the direction before normalising, the same way
    dir_x: vec4<f32>,
    dir_y: vec4<f32>,
    index0: vec4<f32>,   // the origin in the density's index space, the same way
    index_x: vec4<f32>,
    index_y: vec4<f32>,
    to_index_x: vec4<f32>, // world → index directions: the linear map's columns
    to_index_y: vec4<f32>,
    to_index_z: vec4<f32>,
    forward: vec4<f32>,  // the view axis
    clip: vec4<f32>,     // the near and far clipping planes' depths, the ground's height
    keys: vec4<u32>,     // the seed (lo, hi), the overscan in x and in y
    flags: vec4<u32>,    // the stratified grid's side (0: the job's samples), 1 where those
                         // are the pixel's centre, the ground (0: none, 1: unseen, 2:
                         // seen and opaque)
};

@group(0) @binding(10) var<uniform> C: CameraRays;

const F32_MAX: f32 = 3.40282347e38;

// ---- SplitMix64 on (lo, hi) pairs of u32 ----

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// The full 64-bit product of two u32.
fn mul32(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// The low 64 bits of a · b.
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let p = mul32(a.x, b.x);
    return vec2<u32>(p.x, p.y + a.x * b.y + a.y * b.x);
}

// a >> n for 0 < n < 32.
fn shr64(a: vec2<u32>, n: u32) -> vec2<u32> {
    return vec2<u32>((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}

fn mix64(z0: vec2<u32>) -> vec2<u32> {
    var z = mul64(z0 ^ shr64(z0, 30u), vec2<u32>(0x1CE4E5B9u, 0xBF58476Du));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x133111EBu, 0x94D049BBu));
    return z ^ shr64(z, 31u);
}

// ---- camera rays ----

// A pixel coordinate less the overscan, as the CPU's usize wraps it, widened to 64 bits.
fn pixel_key(x: u32, overscan: u32) -> vec2<u32> {
    return vec2<u32>(x - overscan, select(0u, 0xffffffffu, x < overscan));
}

// seed + x·C1 + y·C2 (wrapping): what the CPU's `unit_random` and `stream_key` hash the
// pixel (its streams' coordinates sx, sy) by, before the sample's part.
fn pixel_hash(sx: vec2<u32>, sy: vec2<u32>) -> vec2<u32> {
    let z = add64(C.keys.xy, mul64(sx, vec2<u32>(0x7F4A7C15u, 0x9E3779B9u)));
    return add64(z, mul64(sy, vec2<u32>(0x27D4EB4Fu, 0xC2B2AE3Du)));
}

// `unit_random(seed, x, y, s, k)` of the CPU, to 24 bits.
fn unit_random(sx: vec2<u32>, sy: vec2<u32>, s: u32, k: u32) -> f32 {
    let z = add64(pixel_hash(sx, sy), mul64(vec2<u32>(k, s), vec2<u32>(0x9E3779F9u, 0x165667B1u)));
    return f32(mix64(z).y >> 8u) * (1.0 / 16777216.0);
}

// The random stream of the sample `pick` names (`sample_point`'s): its index, one more on
// the stratified grid (the centre's is 0).
fn pick_stream(pick: vec4<f32>) -> u32 {
    let s = u32(pick.w);
    return select(s, s + 1u, C.flags.x > 0u);
}

// The key of every random stream of the sample `pick` names (`SampleRng::stream_key`).
fn stream_key(pick: vec4<f32>) -> vec2<u32> {
    let sx = pixel_key(u32(pick.x), C.keys.z);
    let sy = pixel_key(u32(pick.y), C.keys.w);
    let s = vec2<u32>(pick_stream(pick), 0u);
    return mix64(add64(pixel_hash(sx, sy), mul64(s, vec2<u32>(0x9E3779F9u, 0x165667B1u))));
}

// A sample's ray, from its pick (the pixel's x and y, the holdout's depth there or −1,
// the sample's index in the pixel), as the march's `Sample` holds one.
fn camera_sample(pick: vec4<f32>) -> Sample {
    let x = u32(pick.x);
    let y = u32(pick.y);
    let s = u32(pick.w);
    let sx = pixel_key(x, C.keys.z);
    let sy = pixel_key(y, C.keys.w);
    // The jitter inside the pixel and the sample's stream (sample_point).
    var jitter = vec2<f32>(0.5);
    let stream = pick_stream(pick);
    let grid = C.flags.x;
    if (grid > 0u) {
        let cell = vec2<f32>(f32(s % grid), f32(s / grid));
        let u = vec2<f32>(unit_random(sx, sy, stream, 1u), unit_random(sx, sy, stream, 2u));
        jitter = (cell + u) / f32(grid);
    } else if (C.flags.y == 0u) {
        jitter = vec2<f32>(unit_random(sx, sy, s, 1u), unit_random(sx, sy, s, 2u));
    }
    let px = pick.x + jitter.x;
    let py = pick.y + jitter.y;
    let o = C.origin0.xyz + C.origin_x.xyz * px + C.origin_y.xyz * py;
    var d = C.dir0.xyz + C.dir_x.xyz * px + C.dir_y.xyz * py;
    if (C.origin0.w != 0.0) {
        d = normalize(d);
    }
    let io = C.index0.xyz + C.index_x.xyz * px + C.index_y.xyz * py;
    let id = C.to_index_x.xyz * d.x + C.to_index_y.xyz * d.y + C.to_index_z.xyz * d.z;
    // The clipping planes (camera.clip), then the holdout (camera_sample).
    var t_min = 0.0;
    var t_max = F32_MAX;
    if (C.origin_x.w != 0.0) {
        let cos_f = max(dot(d, C.forward.xyz), 1e-30);
        t_min = C.clip.x / cos_f;
        t_max = min(C.clip.y / cos_f, F32_MAX);
    }
    if (pick.z >= 0.0) {
        let t = pick.z / dot(d, C.forward.xyz);
        if (t < t_max) {
            t_max = max(t, 0.0);
        }
    }
    // Where the ray meets the ground before its end, signed by the side the camera is
    // on (0: not seen); a seen ground is opaque.
    var tg = 0.0;
    if (C.flags.z != 0u && d.y != 0.0) {
        let t = (C.clip.z - o.y) / d.y;
        if (t > 0.0 && t <= t_max) {
            tg = select(-t, t, o.y >= C.clip.z);
            if (C.flags.z == 2u) {
                t_max = t;
            }
        }
    }
    let u = unit_random(sx, sy, stream, 0u);
    return Sample(vec4<f32>(o, u), vec4<f32>(d, t_max), vec4<f32>(io, t_min), vec4<f32>(id, tg));
}
