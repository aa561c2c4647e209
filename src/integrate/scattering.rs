//! How many times light scatters: the `--scattering` flag and the scene file's
//! `scattering` key, with the `--bounces` each mode takes.

/// `--scattering single|fast|path`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScatteringMode {
    /// Light scattered once toward the camera, by the ray march (no `indirect` layer).
    Single,
    /// An approximation of every scattering order (`integrate::fast`): single scattering
    /// as `single`, the rest from a coarse lattice solved per light. The default.
    #[default]
    Fast,
    /// Unbiased volumetric path tracing: every order, to the noise of `--spp`.
    Path,
}

impl ScatteringMode {
    /// The name the flag and the scene file use.
    pub fn name(self) -> &'static str {
        match self {
            ScatteringMode::Single => "single",
            ScatteringMode::Fast => "fast",
            ScatteringMode::Path => "path",
        }
    }

    /// True when the mode writes light scattered two or more times (the `indirect` layer).
    pub fn has_indirect(self) -> bool {
        self != ScatteringMode::Single
    }
}

/// The most scattering events a path may have by default (`--scattering path`): far
/// past any order that carries light in a medium of albedo ≤ 0.99 (0.99¹⁰⁰⁰⁰ ≈ 2e-44)
/// and past the ~τ² events a path takes in a non-absorbing cloud of optical depth τ up
/// to ~100, so the cap does not bias what is measured; Russian roulette ends absorbing
/// paths long before.
pub const PATH_BOUNCES: u32 = 10_000;

/// The largest `--bounces` accepted.
pub const MAX_BOUNCES: u32 = 1_000_000;
