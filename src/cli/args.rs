//! The command line's render flags, built from the library's one table of render options
//! ([`murk::scene::options::FLAGS`]): each becomes `--key-with-dashes`, listed under its
//! group's heading with its doc and default, and its text is turned into a value by the
//! same table ([`RenderOptions::set_flag`]). Only the flags that are not render options
//! (a sequence's `--skip-existing` and `--tile`) are declared here.

use clap::{Arg, ArgAction, ArgMatches, Args, FromArgMatches};
use murk::render::RenderOptions;
use murk::scene::options::{Commands, FLAGS, FlagDef, Kind};

/// Frame sequences and pieces of frames (for a farm): command-line only.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct SequenceArgs {
    /// Leave frames whose output is already a complete EXR (resume a killed run).
    #[arg(long = "skip-existing", help_heading = "Sequences")]
    pub skip_existing: bool,
    /// Render only the I-th of N bands of rows into a partial EXR, for `murk stitch`.
    #[arg(long, value_name = "I/N", help_heading = "Sequences")]
    pub tile: Option<String>,
}

/// `murk render` flags: every render option, and the sequence flags.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderArgs {
    pub options: RenderOptions,
    pub sequence: SequenceArgs,
}

/// `murk bake-shadows` flags: only what decides a shadow map, so that camera and image
/// flags, which would change nothing, are refused rather than silently ignored. A scene
/// file may still hold them: the bake reads the scene as a render would.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BakeArgs {
    pub options: RenderOptions,
}

impl RenderArgs {
    /// The options these flags give (unset ones stay unset, for a scene file to fill).
    pub fn options(self) -> RenderOptions {
        self.options
    }
}

impl BakeArgs {
    /// The options these flags give.
    pub fn options(self) -> RenderOptions {
        self.options
    }
}

/// The flags of the render options `wanted` takes.
fn flag_defs(bake_only: bool) -> impl Iterator<Item = &'static FlagDef> {
    FLAGS
        .iter()
        .filter(move |f| !bake_only || f.commands == Commands::RenderAndBake)
}

/// One render option as a clap argument.
fn arg(f: &'static FlagDef) -> Arg {
    let mut a = Arg::new(f.key)
        .long(f.long())
        .help(f.help())
        .help_heading(f.group.heading());
    if f.key == "output" {
        a = a.short('o');
    }
    match f.kind {
        Kind::Switch => a.action(ArgAction::SetTrue),
        Kind::Value | Kind::Repeated => {
            let a = a
                .value_name(f.value_name)
                // Values may start with '-' (`--eye -20,5,7`, `--sigma-s -1,2,2` is then
                // refused by its check, naming the flag, rather than by the parser).
                .allow_hyphen_values(true);
            if f.kind == Kind::Repeated {
                a.action(ArgAction::Append)
            } else {
                a.action(ArgAction::Set)
            }
        }
    }
}

fn augment(cmd: clap::Command, bake_only: bool) -> clap::Command {
    cmd.args(flag_defs(bake_only).map(arg))
}

/// The options given in `m`, each parsed by the table.
fn options_from(m: &ArgMatches, bake_only: bool) -> Result<RenderOptions, clap::Error> {
    let mut o = RenderOptions::default();
    for f in flag_defs(bake_only) {
        let given = match f.kind {
            Kind::Switch => {
                if m.get_flag(f.key) {
                    vec![String::new()]
                } else {
                    Vec::new()
                }
            }
            _ => m
                .get_many::<String>(f.key)
                .map(|v| v.cloned().collect())
                .unwrap_or_default(),
        };
        for raw in given {
            o.set_flag(f.key, &raw).map_err(|problem| {
                clap::Error::raw(
                    clap::error::ErrorKind::ValueValidation,
                    format!(
                        "invalid value '{raw}' for '--{} <{}>': {problem}\n",
                        f.long(),
                        f.value_name
                    ),
                )
            })?;
        }
    }
    Ok(o)
}

impl FromArgMatches for RenderArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(RenderArgs {
            options: options_from(m, false)?,
            sequence: SequenceArgs::from_arg_matches(m)?,
        })
    }
    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl Args for RenderArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        SequenceArgs::augment_args(augment(cmd, false))
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

impl FromArgMatches for BakeArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(BakeArgs {
            options: options_from(m, true)?,
        })
    }
    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl Args for BakeArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        augment(cmd, true)
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}
