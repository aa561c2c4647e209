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
        Self::parse(std::env::var(Self::VAR).ok().as_deref())
    }

    /// The variable's value (`None`: unset).
    fn parse(value: Option<&str>) -> Result<LatticeDevice, String> {
        match value.map(str::trim) {
            None | Some("" | "auto") => Ok(LatticeDevice::Auto),
            Some("cpu") => Ok(LatticeDevice::Cpu),
            Some("gpu") => Ok(LatticeDevice::Gpu),
            Some(other) => Err(format!("{}={other}: expected cpu, gpu or auto", Self::VAR)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::LatticeDevice;

    #[test]
    fn the_lattice_device_is_read_from_its_variable_and_a_bad_value_named() {
        assert_eq!(LatticeDevice::parse(None), Ok(LatticeDevice::Auto));
        assert_eq!(LatticeDevice::parse(Some(" ")), Ok(LatticeDevice::Auto));
        assert_eq!(LatticeDevice::parse(Some("auto")), Ok(LatticeDevice::Auto));
        assert_eq!(LatticeDevice::parse(Some("cpu")), Ok(LatticeDevice::Cpu));
        assert_eq!(LatticeDevice::parse(Some("gpu ")), Ok(LatticeDevice::Gpu));
        assert_eq!(
            LatticeDevice::parse(Some("GPU")),
            Err("MURK_GPU_LATTICE=GPU: expected cpu, gpu or auto".into())
        );
    }
}
