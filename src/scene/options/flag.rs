//! What one render option is, apart from its value: the record each entry of the table in
//! [`super`] becomes, from which the command line's flags, `--help`, the scene file's keys
//! and their docs all come.

use std::path::PathBuf;

/// Where a flag is listed in `murk render --help` (and in the scene-file key docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    Output,
    Camera,
    Grids,
    Look,
    Lights,
    Quality,
    Transport,
    Image,
    Production,
    Sequence,
    Run,
}

impl Group {
    /// The heading the group's flags are listed under.
    pub fn heading(self) -> &'static str {
        match self {
            Group::Output => "Output",
            Group::Camera => "Image and camera",
            Group::Grids => "Grids in their roles",
            Group::Look => "Medium, phase function and emission",
            Group::Lights => "Lights and shadows",
            Group::Quality => "Quality and sampling",
            Group::Transport => "Scattering",
            Group::Image => "The EXR and its preview",
            Group::Production => "Production caches",
            Group::Sequence => "Sequences",
            Group::Run => "Running",
        }
    }
}

/// A flag's default as its docs state it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DefaultValue {
    /// No default: unset means "not asked for".
    None,
    /// A value, written as the flag takes it: giving it must change nothing (a test checks
    /// this for every flag).
    Value(&'static str),
    /// A default that depends on the input or on other flags, described.
    Described(&'static str),
}

/// Which commands take a flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Commands {
    /// `murk render` (and the commands that take its flags: converge, farm openjd).
    Render,
    /// Also `murk bake-shadows`: the flags that decide a shadow map, and how it runs.
    RenderAndBake,
}

/// How a flag takes values, known from its field's type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `--flag VALUE`, once.
    Value,
    /// `--flag`, no value.
    Switch,
    /// `--flag VALUE`, repeatable.
    Repeated,
}

/// One render option: the scene file's key, the flag `--key-with-dashes`, its doc, value
/// name, default and where it is listed.
#[derive(Clone, Copy, Debug)]
pub struct FlagDef {
    /// The scene file's key (`sigma_a`); the flag is the same with dashes (`--sigma-a`).
    pub key: &'static str,
    /// The doc, as written in the table (one line per source line).
    pub doc: &'static str,
    pub value_name: &'static str,
    pub default: DefaultValue,
    pub group: Group,
    pub commands: Commands,
    pub kind: Kind,
}

impl FlagDef {
    /// The long flag, `--sigma-a` for the key `sigma_a`.
    pub fn long(&self) -> String {
        self.key.replace('_', "-")
    }

    /// The doc as one paragraph, with its default appended: the text of `--help` and of
    /// the scene file's key docs.
    pub fn help(&self) -> String {
        let doc = self
            .doc
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        match self.default {
            DefaultValue::None => doc,
            DefaultValue::Value(v) => format!("{doc} [default: {v}]"),
            DefaultValue::Described(d) => format!("{doc} [default: {d}]"),
        }
    }
}

/// A field of [`super::RenderOptions`] as a flag sees it: how it takes a value from the
/// command line and how a flag's value stands over a scene file's.
pub trait Slot: Sized {
    const KIND: Kind;
    /// Sets (or, for a repeated flag, adds) a value given as text.
    fn set(&mut self, raw: &str) -> Result<(), String>;
    /// `self` where given, else `base`.
    fn over(self, base: Self) -> Self;
    /// Whether a value was given (a switch: on).
    fn is_given(&self) -> bool;
}

impl<T: FlagValue> Slot for Option<T> {
    const KIND: Kind = Kind::Value;
    fn set(&mut self, raw: &str) -> Result<(), String> {
        *self = Some(T::parse_flag(raw)?);
        Ok(())
    }
    fn over(self, base: Self) -> Self {
        self.or(base)
    }
    fn is_given(&self) -> bool {
        self.is_some()
    }
}

impl Slot for bool {
    const KIND: Kind = Kind::Switch;
    fn set(&mut self, _raw: &str) -> Result<(), String> {
        *self = true;
        Ok(())
    }
    fn over(self, base: Self) -> Self {
        self || base
    }
    fn is_given(&self) -> bool {
        *self
    }
}

impl<T: FlagValue> Slot for Vec<T> {
    const KIND: Kind = Kind::Repeated;
    fn set(&mut self, raw: &str) -> Result<(), String> {
        self.push(T::parse_flag(raw)?);
        Ok(())
    }
    fn over(self, base: Self) -> Self {
        if self.is_empty() { base } else { self }
    }
    fn is_given(&self) -> bool {
        !self.is_empty()
    }
}

/// A value a flag takes as text.
pub trait FlagValue: Sized {
    fn parse_flag(raw: &str) -> Result<Self, String>;
}

macro_rules! numeric_flag_values {
    ($($t:ty: $what:literal),*) => {$(
        impl FlagValue for $t {
            fn parse_flag(raw: &str) -> Result<Self, String> {
                raw.trim().parse().map_err(|_| format!("\"{raw}\" is not {}", $what))
            }
        }
    )*};
}
numeric_flag_values!(
    f64: "a number",
    f32: "a number",
    u32: "a whole number from 0 to 4294967295",
    u64: "a whole number from 0 to 18446744073709551615",
    usize: "a whole number"
);

impl FlagValue for String {
    fn parse_flag(raw: &str) -> Result<Self, String> {
        Ok(raw.to_string())
    }
}

impl FlagValue for PathBuf {
    fn parse_flag(raw: &str) -> Result<Self, String> {
        Ok(PathBuf::from(raw))
    }
}

/// A value named by one of a few words (`--scattering fast`): the same words as the
/// scene file's, from the type's serde names.
macro_rules! word_flag_values {
    ($($t:ty),*) => {$(
        impl FlagValue for $t {
            fn parse_flag(raw: &str) -> Result<Self, String> {
                use serde::Deserialize;
                use serde::de::IntoDeserializer;
                let words: serde::de::value::StrDeserializer<'_, serde::de::value::Error> =
                    raw.into_deserializer();
                <$t>::deserialize(words).map_err(|e| e.to_string())
            }
        }
    )*};
}
word_flag_values!(
    crate::integrate::ScatteringMode,
    crate::integrate::phase::PhaseKind,
    crate::scene::plan::device::Device
);
