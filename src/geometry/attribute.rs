//! Mesh attributes: values per vertex or per face a mesh carries (Mitsuba 3's), which
//! the `mesh_attribute` texture reads.

use crate::math::Vec3;

/// How many distinct mesh attribute names a scene's textures may read: each is a slot
/// of the surface interaction, filled where a ray hits.
pub const ATTRIBUTE_SLOTS: usize = 4;

/// A value per vertex or per face a mesh carries (Mitsuba 3's mesh attributes).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// Mitsuba's name: `vertex_…` (one value per position, interpolated with the
    /// barycentrics) or `face_…` (one per triangle).
    pub name: String,
    /// 1 (kept in all three channels: a grey), 3, or 4 (a colour with alpha: the
    /// alpha is dropped, and Mitsuba cannot evaluate it as a texture).
    pub channels: u8,
    pub values: Vec<Vec3>,
}

impl MeshAttribute {
    pub fn per_face(&self) -> bool {
        self.name.starts_with("face_")
    }

    /// A name a `mesh_attribute` texture may ask for (Mitsuba's rule): `vertex_…` or
    /// `face_…`; else the message.
    pub fn check_name(name: &str) -> Result<(), String> {
        match name.strip_prefix("vertex_").or_else(|| name.strip_prefix("face_")) {
            Some(rest) if !rest.is_empty() => Ok(()),
            _ => Err(format!(
                "mesh attribute \"{name}\" must start with \"vertex_\" or \"face_\" (vertex_color, face_color, vertex_NAME for a PLY file's NAME_x ...)"
            )),
        }
    }
}
