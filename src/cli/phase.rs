//! `murk phase`: tabulate and plot a phase function.

use clap::Subcommand;
use murk::integrate::phase::water_drop::{DEFAULT_RADIUS_UM, WaterDrop};
use murk::output::guard::Role;
use murk::report::phase_plot;
use std::path::PathBuf;

pub const EXAMPLES: &str = "Examples:\n  murk phase water-drop --drop-radius 500 --csv rain.csv --plot rain.png\n  murk phase water-drop --drop-radius 10 --csv fog.csv --spectral";

#[derive(Subcommand, Debug)]
pub enum PhaseCommand {
    /// Water drops: Lorenz–Mie at 17 wavelengths (380–780 nm), averaged over ±10 % of
    /// the radius, in linear Rec.709. Prints where the bows are.
    #[command(after_help = EXAMPLES)]
    WaterDrop {
        /// Drop radius in micrometres (fog ~10, drizzle ~100, rain 500–1000; 0.05–1000).
        #[arg(long, value_name = "MICRONS", default_value_t = DEFAULT_RADIUS_UM, allow_hyphen_values = true)]
        drop_radius: f64,
        /// Write the table: scattering angle, angle from the antisolar point, R, G, B.
        #[arg(long, value_name = "FILE")]
        csv: Option<PathBuf>,
        /// Add one column per wavelength to the CSV.
        #[arg(long)]
        spectral: bool,
        /// Write a plot (PNG): all angles on a log scale, and the bows.
        #[arg(long, value_name = "FILE.png")]
        plot: Option<PathBuf>,
    },
}

pub fn run(command: PhaseCommand) -> anyhow::Result<()> {
    match command {
        PhaseCommand::WaterDrop {
            drop_radius,
            csv,
            spectral,
            plot,
        } => {
            let outputs: Vec<Role> = [(&csv, "the table (--csv)"), (&plot, "the plot (--plot)")]
                .into_iter()
                .filter_map(|(p, what)| p.as_ref().map(|p| Role::new(p, what)))
                .collect();
            super::guard::check_outputs(&[], &outputs)?;
            let drop = WaterDrop::for_render(drop_radius)?;
            if let Some(path) = &csv {
                phase_plot::write_csv(path, &drop, spectral)?;
            }
            if let Some(path) = &plot {
                phase_plot::write_plot(path, &drop)?;
            }
            let (primary, secondary) = phase_plot::bow_maxima(&drop);
            let f = |v: [f64; 3]| format!("R {:.2}°, G {:.2}°, B {:.2}°", v[0], v[1], v[2]);
            super::print_stdout(&format!(
                "water drops {drop_radius} µm: maxima from the antisolar point: primary {}; secondary {}\n",
                f(primary),
                f(secondary)
            ))
        }
    }
}
