// Each pixel's path samples summed on the GPU, so that a pixel's sums come back where its
// samples' results would (a sixteenth of the bytes at 16 samples a pixel). A chunk's
// pixels take `per_pixel` samples each, laid one pixel after another; the results are
// path.wgsl's. A pixel's sums take the layout of a sample's result: the opacity of its
// samples whose opacity is computed (1 − the mean over the channels of e^{−σt·∫ρ}, as the
// CPU's record takes it), the depth of those whose opacity crosses 0.5 (the half-opacity
// t times the depth rate) and how many there are (w), the density samples taken (as u32
// bits), then the sums of every later float.

struct Sums {
    sigma_t: vec4<f32>,   // the medium's extinction per channel
    pixels: u32,          // the chunk's pixels
    per_pixel: u32,       // samples each
    stride: u32,          // floats of a sample's result, and of a pixel's sums
    sample_floats: u32,   // floats of a sample's input: its pick, then 1 where its
                          // opacity is computed
};

@group(0) @binding(0) var<uniform> S: Sums;
@group(0) @binding(1) var<storage, read> results: array<f32>;
@group(0) @binding(2) var<storage, read> samples: array<f32>;
@group(0) @binding(3) var<storage, read_write> sums: array<f32>;

@compute @workgroup_size(64)
fn path_pixel_sums(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x + id.y * 65535u * 64u;
    if (k >= S.pixels) {
        return;
    }
    let first = k * S.per_pixel;
    let out = k * S.stride;
    var alpha = 0.0;
    var depth = 0.0;
    var depths = 0.0;
    var taken = 0u;
    for (var i = 0u; i < S.per_pixel; i++) {
        let s = first + i;
        let r = s * S.stride;
        taken += u32(results[r + 2u]);
        if (samples[s * S.sample_floats + 4u] != 0.0) {
            let t = exp(-S.sigma_t.xyz * results[r]);
            alpha += clamp((3.0 - (t.x + t.y + t.z)) / 3.0, 0.0, 1.0);
            let half = results[r + 1u];
            if (half >= 0.0) {
                depth += half * results[r + 3u];
                depths += 1.0;
            }
        }
    }
    sums[out] = alpha;
    sums[out + 1u] = depth;
    sums[out + 2u] = bitcast<f32>(taken);
    sums[out + 3u] = depths;
    for (var j = 4u; j < S.stride; j++) {
        var sum = 0.0;
        for (var i = 0u; i < S.per_pixel; i++) {
            sum += results[(first + i) * S.stride + j];
        }
        sums[out + j] = sum;
    }
}
