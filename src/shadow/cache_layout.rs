//! What a shadow cache's grids are: their names, what each holds, and the code the
//! bricks grid gives each brick's level and form. The writer ([`super::cache`]) and the
//! reader ([`super::cache_bricks`]) both go by it.

use super::map::{BRICK, BrickForm, ChartMap, LEVELS, side, spacing};
use glam::IVec3;

/// The quantities a cache stores per level: grid name suffix, index into
/// [`BrickSamples::planes`](super::map::BrickSamples::planes), and what it is.
pub(super) const STORED: [(&str, usize, &str); 4] = [
    (
        "",
        0,
        "integral of density toward the light, world units; optical depth = sigma_t x value",
    ),
    (
        "_dx",
        2,
        "d/dx of the integral across the light, per lattice step (x = murk:chart_e1)",
    ),
    (
        "_dy",
        3,
        "d/dy of the integral across the light, per lattice step (y = murk:chart_e2)",
    ),
    (
        "_dxy",
        4,
        "d2/dxdy of the integral across the light, per lattice step squared",
    ),
];

pub(super) const BRICKS_QUANTITY: &str = "level + 1 + 16 x form of each brick of the shadow map (form 0: tau and its slopes, Hermite; 1: tau alone, trilinear; 2: one tau)";
pub(super) const LINEAR_QUANTITY: &str = "integral of density toward the light of the bricks held as tau alone (trilinear), each brick side(level) samples a side at index key x (2^level + 1): bricks do not share samples";
pub(super) const DARK_QUANTITY: &str = "integral of density toward the light of the bricks held as one value (the light there is below the tolerance), at each brick";

/// What the bricks grid holds per brick: `level + 1 + 16 × form`.
pub(super) fn brick_code(level: u8, form: BrickForm) -> f32 {
    f32::from(level) + 1.0 + 16.0 * f32::from(form.code())
}

/// The level and form a bricks grid's value stands for.
pub(super) fn brick_from_code(v: f32) -> Option<(u8, BrickForm)> {
    if !((1.0..64.0).contains(&v) && v.fract() == 0.0) {
        return None;
    }
    let v = v as u8;
    let level = v % 16;
    (1..=LEVELS as u8).contains(&level).then_some(())?;
    Some((level - 1, BrickForm::from_code(v / 16)?))
}

pub(super) fn grid_name(light: &str, chart: usize, what: &str) -> String {
    format!("dsm_{light}_c{chart}_{what}")
}

/// One grid of a chart's map in a cache.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum StoredGrid {
    /// Each brick's level and form ([`brick_code`]), at the brick.
    Bricks,
    /// Quantity `STORED[quantity]` of the Hermite bricks of `level`.
    Hermite { level: u8, quantity: usize },
    /// τ of the Linear bricks of `level`, each brick apart.
    Linear { level: u8 },
    /// The one τ of each Constant brick, at the brick.
    Dark,
}

impl StoredGrid {
    /// Its name after `dsm_<light>_c<chart>_`.
    pub(super) fn suffix(self) -> String {
        match self {
            StoredGrid::Bricks => "bricks".into(),
            StoredGrid::Hermite { level, quantity } => format!("L{level}{}", STORED[quantity].0),
            StoredGrid::Linear { level } => format!("L{level}_linear"),
            StoredGrid::Dark => "dark".into(),
        }
    }

    /// A signed quantity (τ's slopes); τ and the codes are never negative.
    pub(super) fn signed(self) -> bool {
        matches!(self, StoredGrid::Hermite { quantity, .. } if quantity > 0)
    }

    /// What its values are (`murk:quantity`), and its level (`murk:level`) if it has one.
    pub(super) fn described(self) -> (&'static str, Option<u8>) {
        match self {
            StoredGrid::Bricks => (BRICKS_QUANTITY, None),
            StoredGrid::Hermite { level, quantity } => (STORED[quantity].2, Some(level)),
            StoredGrid::Linear { level } => (LINEAR_QUANTITY, Some(level)),
            StoredGrid::Dark => (DARK_QUANTITY, None),
        }
    }

    /// Its index step in lattice units: a brick's, or its level's sample spacing.
    pub(super) fn step(self) -> f64 {
        match self.described().1 {
            Some(level) => spacing(level),
            None => BRICK as f64,
        }
    }

    /// The grids that hold bricks of `level` in `form`.
    pub(super) fn holding(level: u8, form: BrickForm) -> Vec<StoredGrid> {
        match form {
            BrickForm::Constant => vec![StoredGrid::Dark],
            BrickForm::Linear => vec![StoredGrid::Linear { level }],
            BrickForm::Hermite => (0..STORED.len())
                .map(|quantity| StoredGrid::Hermite { level, quantity })
                .collect(),
        }
    }

    /// The grids a chart map's bricks fill, in the file's order.
    pub(super) fn of(cm: &ChartMap) -> Vec<StoredGrid> {
        let has = |level: Option<u8>, form: BrickForm| {
            cm.bricks
                .iter()
                .any(|b| b.form == form && level.is_none_or(|l| b.level == l))
        };
        let mut out = vec![StoredGrid::Bricks];
        for level in 0..LEVELS as u8 {
            for form in [BrickForm::Hermite, BrickForm::Linear] {
                if has(Some(level), form) {
                    out.extend(StoredGrid::holding(level, form));
                }
            }
        }
        if has(None, BrickForm::Constant) {
            out.extend(StoredGrid::holding(0, BrickForm::Constant));
        }
        out
    }

    /// Its voxels in `cm`, brick by brick, each brick's samples x fastest.
    pub(super) fn voxels(self, cm: &ChartMap) -> Box<dyn Iterator<Item = (IVec3, f32)> + '_> {
        let samples = move |level: u8, form: BrickForm, plane: usize, step: i32| {
            let m = side(level);
            cm.bricks
                .iter()
                .filter(move |b| b.level == level && b.form == form)
                .flat_map(move |b| {
                    let v = cm.brick_quantity(b, plane);
                    (0..m * m * m).map(move |at| {
                        let ijk =
                            IVec3::new((at % m) as i32, (at / m % m) as i32, (at / (m * m)) as i32);
                        (b.key * step + ijk, v[at])
                    })
                })
        };
        match self {
            StoredGrid::Bricks => Box::new(
                cm.bricks
                    .iter()
                    .map(|b| (b.key, brick_code(b.level, b.form))),
            ),
            StoredGrid::Hermite { level, quantity } => Box::new(samples(
                level,
                BrickForm::Hermite,
                STORED[quantity].1,
                1 << level,
            )),
            // Linear bricks hold 16-bit steps: stored apart, a brick's samples not shared
            // with its neighbours', so they read back exactly.
            StoredGrid::Linear { level } => {
                Box::new(samples(level, BrickForm::Linear, 0, (1 << level) + 1))
            }
            StoredGrid::Dark => Box::new(
                cm.bricks
                    .iter()
                    .filter(|b| b.form == BrickForm::Constant)
                    .map(|b| (b.key, cm.brick_quantity(b, 0)[0])),
            ),
        }
    }
}
