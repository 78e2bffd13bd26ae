//! The floor photographs the forward camera sees, and which of them train
//! the segmentation model and which are held out to test it.
//!
//! All are CC0 photoscans (Poly Haven, ambientCG), converted to gray and
//! cropped to their central 256x256 texels at 512 px per tile; origin,
//! licence and tile sizes are in `data/floors/README.md`. The simulated
//! world ([`FloorLook::world`]) floors its rooms with held-out photographs
//! only, so a model trained by `train-segmenter` is scored on floors it has
//! never seen.

use super::render::Texture;
use super::world::Surface;

/// One floor photograph.
#[derive(Clone, Copy, Debug)]
pub struct FloorPhoto {
    /// File stem under `data/floors/`.
    pub name: &'static str,
    /// The floor kind it shows.
    pub surface: Surface,
    /// Metres covered by 512 texels (the source tile's width).
    pub tile_m: f64,
    /// `true` for the held-out (evaluation) set, `false` for training.
    pub held_out: bool,
    /// The PNG file.
    pub png: &'static [u8],
}

macro_rules! photo {
    ($name:literal, $surface:ident, $tile:expr, $held:expr) => {
        FloorPhoto {
            name: $name,
            surface: Surface::$surface,
            tile_m: $tile,
            held_out: $held,
            png: include_bytes!(concat!("../../../../data/floors/", $name, ".png")),
        }
    };
}

/// Every photograph. Carpets have no recorded size: 1 m per tile is assumed.
pub const PHOTOS: [FloorPhoto; 18] = [
    photo!("ph_herringbone_parquet", Wood, 3.40, false),
    photo!("ph_plank_flooring_04", Wood, 2.00, false),
    photo!("ph_rectangular_parquet", Wood, 2.25, false),
    photo!("ph_laminate_floor_03", Wood, 2.08, true),
    photo!("ph_wooden_floor_01", Wood, 1.99, true),
    photo!("ph_dirty_carpet", Carpet, 1.00, false),
    photo!("ph_tatami_mat", Carpet, 1.80, false),
    photo!("acg_fabric045_rug", Carpet, 1.00, true),
    photo!("ph_anti_skid_tiles", Tile, 1.80, false),
    photo!("ph_floor_tiles_06", Tile, 3.00, false),
    photo!("ph_granite_tile", Tile, 2.30, false),
    photo!("ph_marble_mosaic_tiles", Tile, 2.00, false),
    photo!("ph_terrazzo_tiles", Tile, 2.00, false),
    photo!("ph_brown_floor_tiles", Tile, 1.70, true),
    photo!("ph_interior_tiles", Tile, 1.90, true),
    photo!("ph_marble_01", Tile, 1.50, true),
    photo!("ph_painted_concrete_02", Concrete, 4.00, false),
    photo!("ph_concrete_slab_wall", Concrete, 2.30, true),
];

/// The four floor kinds in [`FloorLook`] slot order.
pub const KINDS: [Surface; 4] = [
    Surface::Wood,
    Surface::Carpet,
    Surface::Tile,
    Surface::Concrete,
];

/// A decoded photograph with its scale.
#[derive(Clone)]
pub struct FloorTexture {
    /// The texels.
    pub texture: Texture,
    /// Metres per texel.
    pub texel_m: f64,
    /// Which photograph.
    pub name: &'static str,
}

impl FloorTexture {
    /// Decodes `photo`.
    pub fn new(photo: &FloorPhoto) -> Self {
        FloorTexture {
            texture: Texture::from_png(photo.png),
            texel_m: photo.tile_m / 512.0,
            name: photo.name,
        }
    }

    /// The gray value at floor point `(x, y)`, metres.
    pub fn at(&self, x: f64, y: f64) -> f64 {
        self.texture.sample(x / self.texel_m, y / self.texel_m)
    }
}

/// Which photograph floors each kind of room.
#[derive(Clone)]
pub struct FloorLook {
    /// One texture per [`KINDS`] slot.
    pub textures: [FloorTexture; 4],
}

impl FloorLook {
    /// The simulated world's floors: one held-out photograph per kind
    /// (wooden_floor_01, fabric045 rug, interior_tiles, concrete_slab_wall).
    pub fn world() -> Self {
        let pick = |name: &str| {
            PHOTOS
                .iter()
                .find(|p| p.name == name)
                .map(FloorTexture::new)
                .unwrap_or_else(|| FloorTexture::new(&PHOTOS[0]))
        };
        FloorLook {
            textures: [
                pick("ph_wooden_floor_01"),
                pick("acg_fabric045_rug"),
                pick("ph_interior_tiles"),
                pick("ph_concrete_slab_wall"),
            ],
        }
    }

    /// The texture of `surface`'s rooms.
    pub fn of(&self, surface: Surface) -> &FloorTexture {
        let slot = KINDS.iter().position(|k| *k == surface).unwrap_or(0);
        &self.textures[slot]
    }
}
