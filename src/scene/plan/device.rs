//! `--device`: where the pixel loop runs (a value of its own, so that the option table
//! can name it without importing the plan).

/// `--device cpu|gpu|auto`: where the pixel loop runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Device {
    /// The CPU's threads. The default.
    #[default]
    Cpu,
    /// A GPU through wgpu; a scene it cannot render is an error.
    Gpu,
    /// A GPU when one is found (not a device that itself runs on the CPU, such as
    /// lavapipe) and it renders every feature of the scene, else the CPU.
    Auto,
}

/// Where `--scattering fast`'s lattice is swept when the frame renders on a GPU. Not a
/// render option: the environment variable [`LatticeDevice::VAR`] (`cpu`, `gpu` or
/// `auto`) sets it, for measuring one against the other; a library caller sets the
/// plan's field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LatticeDevice {
    /// On the GPU the frame renders on, unless that runs on the CPU (lavapipe), where
    /// murk's own sweeps are faster.
    #[default]
    Auto,
    /// On the CPU, gathered on the GPU.
    Cpu,
    /// On the GPU the frame renders on, whatever it is.
    Gpu,
}

impl LatticeDevice {
    pub const VAR: &str = "MURK_GPU_LATTICE";

    /// From [`LatticeDevice::VAR`]; unset or empty is `Auto`.
    pub fn from_env() -> Result<LatticeDevice, String> {
        match std::env::var(Self::VAR).as_deref().map(str::trim) {
            Err(_) | Ok("" | "auto") => Ok(LatticeDevice::Auto),
            Ok("cpu") => Ok(LatticeDevice::Cpu),
            Ok("gpu") => Ok(LatticeDevice::Gpu),
            Ok(other) => Err(format!("{}={other}: expected cpu, gpu or auto", Self::VAR)),
        }
    }
}
