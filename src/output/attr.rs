//! The murk attributes of an EXR header: which piece of which frame an image is (written
//! by `murk render --tile`, read back by `murk stitch`), and how the piece stored what the
//! stitch must store the same way.

/// `I/N`: the I-th of N pieces.
pub const TILE: &str = "murk/tile";
/// `Y0-Y1`: the rows of the piece, Y1 excluded.
pub const TILE_ROWS: &str = "murk/tileRows";
/// The frame number, when the render is a frame of a sequence.
pub const FRAME: &str = "murk/frame";
/// `half` or `float`: how colour was asked to be stored (`--float`), for the stitch.
pub const STORAGE: &str = "murk/storage";
/// How the piece wrote what the stitch must write the same way: the colour space its
/// colour is already in (`--colorspace`), the depth where nothing is (`--z-empty`),
/// and whether the data window is cropped (`--crop-data-window`: `true`/`false`).
pub const COLORSPACE: &str = "murk/colorspace";
pub const Z_EMPTY: &str = "murk/zEmpty";
pub const CROP: &str = "murk/cropDataWindow";
/// `X,Y`: the overscan of the frame the piece is a band of (`--overscan`), so that the
/// stitch knows the frame's size beyond its displayWindow.
pub const OVERSCAN: &str = "murk/overscan";
