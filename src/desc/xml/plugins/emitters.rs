//! `<emitter>` plugins read outside a shape: the environment (`constant`, `envmap`).

use super::table::{differs, not_read, noted, read, PluginDoc, Status};
use super::{source, Reader};
use crate::desc::xml::props::Plugin;
use crate::desc::{EnvMapDesc, ImageFile, Located, TextureDesc};
use crate::error::Result;
use crate::math::{Mat4, Vec2, Vec3};
use crate::texture::{Texture, UvMapping};

/// The emitters' rows of the plugin table (`area` is with the shapes).
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "emitter",
        names: &["point"],
        status: Status::Read,
        note: "",
        params: &[
            read("position", "point", "0, 0, 0", "or `to_world`'s origin"),
            read("to_world", "transform", "identity", ""),
            differs("intensity", "colour", "1", "radiant intensity I, rdr's flux 4πI"),
        ],
    },
    PluginDoc {
        element: "emitter",
        names: &["spot"],
        status: Status::Read,
        note: "At `to_world`'s origin, along its +z; linear falloff in angle.",
        params: &[
            read("to_world", "transform", "identity", ""),
            read("intensity", "colour", "1", ""),
            read("cutoff_angle", "float", "20", "degrees"),
            read("beam_width", "float", "¾ of cutoff_angle", "degrees"),
            read(
                "texture",
                "texture",
                "",
                "an image projected over the cone (then `cutoff_angle` < 90°)",
            ),
        ],
    },
    PluginDoc {
        element: "emitter",
        names: &["projector"],
        status: Status::Read,
        note: "A pinhole at `to_world`'s origin looking along +z; intensity π·scale·E/cos³θ.",
        params: &[
            read("irradiance", "texture", "1", "required: a texture or a colour"),
            read("scale", "float", "1", ""),
            read("fov", "float", "", "degrees along `fov_axis`; without it, `focal_length`"),
            read("fov_axis", "string", "x", ""),
            read("focal_length", "string", "50mm", "on the diagonal"),
            read("to_world", "transform", "identity", ""),
        ],
    },
    PluginDoc {
        element: "emitter",
        names: &["directional"],
        status: Status::Read,
        note: "",
        params: &[
            read("direction", "vector", "0, 0, 1", "of travel; or `to_world`'s +z, not both"),
            read("to_world", "transform", "identity", ""),
            read("irradiance", "colour", "1", ""),
        ],
    },
    PluginDoc {
        element: "emitter",
        names: &["constant"],
        status: Status::Read,
        note: "The environment (one per scene).",
        params: &[read("radiance", "colour", "1", ""), read("to_world", "transform", "identity", "")],
    },
    PluginDoc {
        element: "emitter",
        names: &["envmap"],
        status: Status::Read,
        note: "The environment (one per scene), a latitude-longitude image.",
        params: &[
            read("filename", "string", "", "required"),
            read("scale", "float", "1", ""),
            read("to_world", "transform", "identity", ""),
            noted("filter_type", "string", "rdr filters environments trilinearly"),
            noted("mis_compensation", "boolean", ""),
        ],
    },
    not_read(
        "emitter",
        &["timed_sunsky"],
        Status::Skipped,
        "Mitsuba 3's sun and sky averaged over a time window is not built: warned about and left out (the scene renders without it).",
    ),
    not_read("emitter", &["directionalarea"], Status::Refused, "not read"),
];

impl<'a> Reader<'a> {
    pub(super) fn environment(&mut self, p: &Plugin<'a>) -> Result<EnvMapDesc> {
        let el = p.el;
        let (texture, scale) = if p.ty == "constant" {
            let c = p.rgb("radiance", Vec3::ONE)?;
            if c.min_element() < 0.0 {
                return Err(p.value_error("radiance", "must not be negative"));
            }
            let name = self.unique(el.attr("id").or(Some("environment")), "environment");
            self.textures.push(TextureDesc {
                name: name.clone(),
                source: source(el),
                texture: Texture::Constant(c),
            });
            (name, 1.0)
        } else {
            let path = self.file(el, p, "filename")?;
            let name = self.unique(el.attr("id").or(Some("environment")), "environment");
            self.textures.push(TextureDesc {
                name: name.clone(),
                source: source(el),
                texture: Texture::Image(ImageFile {
                    path,
                    mapping: UvMapping {
                        scale: Vec2::ONE,
                        delta: Vec2::ZERO,
                    },
                    filter: crate::texture::image::ImageFilter::Trilinear,
                    raw: false,
                    wrap: crate::texture::image::WrapMode::Repeat,
                    scale: Vec3::ONE,
                }),
            });
            for k in ["filter_type", "mis_compensation"] {
                p.ignore(k);
            }
            let s = p.float("scale", 1.0)?;
            if s.is_nan() || s < 0.0 {
                return Err(p.value_error("scale", "must not be negative"));
            }
            (name, s)
        };
        let transform = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        if transform.determinant() == 0.0 {
            return Err(p.value_error("to_world", "the transform is singular"));
        }
        p.finish(&[])?;
        Ok(EnvMapDesc {
            source: source(el),
            texture: Located {
                value: texture,
                source: source(el),
            },
            scale,
            transform,
        })
    }
}
