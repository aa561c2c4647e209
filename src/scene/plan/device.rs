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
