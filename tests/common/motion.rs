//! The motion-blur tests' shared view of their moving box (tests/motion_blur/): the box
//! of density 1 whose +x edge is at x = 1.95, seen from the front.

/// An orthographic camera 3.2 world units wide, centred on the box's +x edge.
pub const BOX_CAMERA: [&str; 8] = [
    "--camera",
    "ortho",
    "--eye",
    "1.95,1,5",
    "--look-at",
    "1.95,1,0",
    "--ortho-width",
    "3.2",
];

/// 96×8 pixels: the box's edge and its streak, a few rows.
pub const BOX_RES: [&str; 2] = ["--res", "96x8"];

/// Absorbing only (σa 1.5, no lights: alpha is 1 − e^{−1.5 × the density crossed}),
/// float, 64 samples a pixel.
pub const ABSORBING: [&str; 8] = [
    "--no-lights",
    "--sigma-a",
    "1.5,1.5,1.5",
    "--sigma-s",
    "0,0,0",
    "--float",
    "--spp",
    "64",
];
