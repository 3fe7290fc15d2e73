//! `<texture>`: bitmaps, checkerboards, mesh attributes, and texture parameters.

use super::table::{differs, not_read, read, Param, PluginDoc, Status};
use super::{source, Reader, TEXTURES};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::{Colour, Plugin};
use crate::desc::xml::values;
use crate::desc::{ImageFile, Located, TextureDesc, TextureRef};
use crate::error::Result;
use crate::math::{Mat4, Vec2, Vec3};
use crate::texture::{Texture, UvMapping};

const TO_UV: [Param; 5] = [
    differs(
        "to_uv",
        "transform",
        "identity",
        "a scale and offset of the texture coordinates only",
    ),
    read("uoffset", "float", "0", "(Mitsuba 0.6) become `to_uv`"),
    read("voffset", "float", "0", "(Mitsuba 0.6)"),
    read("uscale", "float", "1", "(Mitsuba 0.6)"),
    read("vscale", "float", "1", "(Mitsuba 0.6)"),
];

/// The textures' rows of the plugin table.
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "texture",
        names: &["bitmap"],
        status: Status::Read,
        note: "PNG, JPEG, EXR, HDR, BMP, TGA, PPM/PGM and PFM images.",
        params: &[
            read("filename", "string", "", "required"),
            differs(
                "filter_type",
                "string",
                "bilinear",
                "`bilinear` (of the full-resolution image: Mitsuba has no MIP maps) or `nearest`",
            ),
            read("wrap_mode", "string", "repeat", "`repeat`, `clamp` or `mirror`"),
            read("raw", "boolean", "false", "true: 8-bit values as they are, not decoded from sRGB"),
            TO_UV[0],
            TO_UV[1],
            TO_UV[2],
            TO_UV[3],
            TO_UV[4],
        ],
    },
    PluginDoc {
        element: "texture",
        names: &["checkerboard"],
        status: Status::Read,
        note: "Read as a float (`eval_1`) it gives `color1` where Mitsuba 3's does.",
        params: &[
            read("color0", "colour", "0.4", ""),
            read("color1", "colour", "0.2", ""),
            TO_UV[0],
            TO_UV[1],
            TO_UV[2],
            TO_UV[3],
            TO_UV[4],
        ],
    },
    PluginDoc {
        element: "texture",
        names: &["mesh_attribute"],
        status: Status::Differs,
        note: "",
        params: &[
            differs(
                "name",
                "string",
                "",
                concat!(
                    "required: `vertex_…` or `face_…`, from a PLY file by Mitsuba's rules (`red green blue`: `vertex_color`; ",
                    "`P_x P_y P_z`: `vertex_P`; …); integer colours are read as fractions of 255 (Mitsuba: as they are)"
                ),
            ),
            read("scale", "float", "1", ""),
        ],
    },
    PluginDoc {
        element: "texture",
        names: &["rawconstant"],
        status: Status::Read,
        note: "A constant used as it is (no conversion from a spectrum).",
        params: &[read("value", "float or vector", "", "required")],
    },
    not_read("texture", &["volume"], Status::Refused, "not read"),
    PluginDoc {
        element: "texture",
        names: &["scale"],
        status: Status::Read,
        note: "Mitsuba 0.6's scaled texture, which Mitsuba 3 cannot read; rdr folds the factor into the texture it wraps \
               (a bump map's gradient by the factor's luminance: exact for a float).",
        params: &[
            read(
                "value",
                "colour or texture",
                "",
                "required: the nested texture (any name), or a constant colour",
            ),
            read("scale", "float or colour", "1", "positive"),
        ],
    },
];

impl<'a> Reader<'a> {
    pub(super) fn texture_ref(&mut self, p: &Plugin<'a>, name: &str, default: Vec3) -> Result<TextureRef> {
        Ok(match p.colour(name, default)? {
            Colour::Constant(c) => {
                if c.min_element() < 0.0 || !c.is_finite() {
                    return Err(p.value_error(name, "a colour must not be negative"));
                }
                TextureRef::Color(c)
            }
            Colour::Texture(t) => TextureRef::Named(Located {
                value: self.texture(t)?,
                source: source(t),
            }),
        })
    }

    /// A texture parameter Mitsuba reads as a float (`eval_1`: blendbsdf's `weight`,
    /// mask's `opacity`, principled's float keys): as [`Reader::texture_ref`], except
    /// that Mitsuba 3's checkerboard `eval_1` gives `color1` where its `eval` gives
    /// `color0` (checked with 3.9.1: at uv (0.2, 0.2) `eval` is color0, `eval_1`
    /// color1), so a checkerboard read as a float is a twin with the colours swapped.
    pub(super) fn float_texture_ref(&mut self, p: &Plugin<'a>, name: &str, default: Vec3) -> Result<TextureRef> {
        let r = self.texture_ref(p, name, default)?;
        let (Colour::Texture(el), TextureRef::Named(n)) = (p.colour(name, default)?, &r) else {
            return Ok(r);
        };
        let key = el as *const Element;
        if let Some(twin) = self.float_texture_of.get(&key) {
            return Ok(TextureRef::Named(Located {
                value: twin.clone(),
                source: n.source.clone(),
            }));
        }
        let Some(t) = self.textures.iter().find(|t| t.name == n.value) else {
            return Ok(r);
        };
        let Texture::Checkerboard { color0, color1, mapping } = t.texture else {
            return Ok(r);
        };
        let twin = self.unique(Some(&format!("{}-as-float", n.value)), "texture");
        self.textures.push(TextureDesc {
            name: twin.clone(),
            source: t.source.clone(),
            texture: Texture::Checkerboard {
                color0: color1,
                color1: color0,
                mapping,
            },
        });
        self.float_texture_of.insert(key, twin.clone());
        Ok(TextureRef::Named(Located {
            value: twin,
            source: n.source.clone(),
        }))
    }

    /// The name of the texture of a `<texture>` (read once however often referenced).
    pub(super) fn texture(&mut self, el: &'a Element) -> Result<String> {
        if let Some(n) = self.texture_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        self.nest(el)?;
        let t = self.texture_value(el);
        self.depth -= 1;
        let texture = t?;
        let name = self.unique(el.attr("id"), "texture");
        self.textures.push(TextureDesc {
            name: name.clone(),
            source: source(el),
            texture,
        });
        self.texture_of.insert(el as *const Element, name.clone());
        Ok(name)
    }

    pub(super) fn texture_value(&mut self, el: &'a Element) -> Result<Texture<ImageFile>> {
        let p = Plugin::new(el, self.ids)?;
        let t = match p.ty.as_str() {
            "bitmap" => {
                let to_uv = self.to_uv(&p)?;
                let path = self.file(el, &p, "filename")?;
                // Mitsuba has no MIP maps: its bilinear reads the full-resolution image
                let filter = match p.string("filter_type", "bilinear")?.as_str() {
                    "bilinear" => crate::texture::image::ImageFilter::Bilinear,
                    "nearest" => crate::texture::image::ImageFilter::Nearest,
                    other => return Err(p.value_error("filter_type", format!("unknown filter_type \"{other}\" (bilinear, nearest)"))),
                };
                let w = p.string("wrap_mode", "repeat")?;
                let wrap = crate::texture::image::WrapMode::parse(&w).ok_or_else(|| {
                    p.value_error(
                        "wrap_mode",
                        format!("unknown wrap_mode \"{w}\" ({})", crate::texture::image::WrapMode::NAMES),
                    )
                })?;
                let raw = p.boolean("raw", false)?;
                // Mitsuba's row 0 is v = 0, rdr's is v = 1
                Texture::Image(ImageFile {
                    path,
                    mapping: UvMapping {
                        scale: to_uv.0,
                        delta: Vec2::new(to_uv.1.x, 1.0 - to_uv.0.y - to_uv.1.y),
                    },
                    filter,
                    raw,
                    wrap,
                    scale: Vec3::ONE,
                })
            }
            "checkerboard" => {
                let to_uv = self.to_uv(&p)?;
                Texture::Checkerboard {
                    color0: p.rgb("color0", Vec3::splat(0.4))?,
                    color1: p.rgb("color1", Vec3::splat(0.2))?,
                    // the same cells as Mitsuba's in its v, which runs the other way
                    mapping: UvMapping {
                        scale: Vec2::new(to_uv.0.x, -to_uv.0.y),
                        delta: Vec2::new(to_uv.1.x, to_uv.0.y + to_uv.1.y),
                    },
                }
            }
            "rawconstant" => {
                // Mitsuba 3: a float or a 3D vector, used as it is (no spectrum conversion)
                let value = match (p.float_opt("value"), p.point_opt("value")) {
                    (Ok(Some(v)), _) => Vec3::splat(v),
                    (_, Ok(Some(v))) => v,
                    _ => return Err(p.error(format!("{} needs the property \"value\" (a float or a vector)", p.describe()))),
                };
                if !(value.min_element() >= 0.0 && value.is_finite()) {
                    return Err(p.value_error("value", "must be finite and not negative"));
                }
                Texture::Constant(value)
            }
            "mesh_attribute" => {
                let name = p.required_string("name")?;
                crate::geometry::mesh::MeshAttribute::check_name(&name).map_err(|m| p.value_error("name", m))?;
                let scale = p.float("scale", 1.0)?;
                if !scale.is_finite() {
                    return Err(p.value_error("scale", "must be a finite number"));
                }
                Texture::MeshAttribute { name, slot: 0, scale }
            }
            "scale" => {
                let s = p.rgb("scale", Vec3::ONE)?;
                if !(s.min_element() > 0.0 && s.is_finite()) {
                    return Err(p.value_error("scale", "must be positive and finite"));
                }
                let nested = p.objects("texture");
                let inner = match nested.as_slice() {
                    [] => match p.rgb_opt("value")? {
                        Some(c) => Texture::Constant(c),
                        None => return Err(p.error(format!("{} needs a nested texture (or a colour \"value\")", p.describe()))),
                    },
                    &[(nested, _)] => {
                        self.nest(nested)?;
                        let t = self.texture_value(nested);
                        self.depth -= 1;
                        t?
                    }
                    [_, (_, at), ..] => return Err(at.error(format!("{} takes one nested texture", p.describe()))),
                };
                scaled(inner, s).ok_or_else(|| p.value_error("scale", "must be a number around a mesh_attribute"))?
            }
            other => return Err(p.error(format!("unsupported texture \"{other}\" (supported: {TEXTURES})"))),
        };
        p.finish(&["texture"])?;
        Ok(t)
    }

    /// `to_uv` (or the 0.6 `uscale`, `vscale`, `uoffset`, `voffset`) as scale and offset.
    pub(super) fn to_uv(&self, p: &Plugin) -> Result<(Vec2, Vec2)> {
        let legacy = ["uoffset", "voffset", "uscale", "vscale"].iter().any(|k| p.has(k));
        let m = if legacy {
            let o = Vec3::new(p.float("uoffset", 0.0)?, p.float("voffset", 0.0)?, 0.0);
            let s = Vec3::new(p.float("uscale", 1.0)?, p.float("vscale", 1.0)?, 1.0);
            values::scale(s) * values::translate(o)
        } else {
            p.transform_opt("to_uv")?.unwrap_or(Mat4::IDENTITY)
        };
        let (s, o) = (Vec2::new(m.x_axis.x, m.y_axis.y), Vec2::new(m.w_axis.x, m.w_axis.y));
        if m.x_axis.y != 0.0 || m.y_axis.x != 0.0 || s.x == 0.0 || s.y == 0.0 {
            return Err(p.value_error("to_uv", "only a scale and offset of the texture coordinates are supported"));
        }
        Ok((s, o))
    }
}

/// `t` times `s`: Mitsuba 0.6's `scale` texture folded into the texture it wraps
/// (`None`: a mesh attribute's scale is a number, `s` a colour).
fn scaled(t: Texture<ImageFile>, s: Vec3) -> Option<Texture<ImageFile>> {
    Some(match t {
        Texture::Constant(c) => Texture::Constant(c * s),
        Texture::Checkerboard { color0, color1, mapping } => Texture::Checkerboard {
            color0: color0 * s,
            color1: color1 * s,
            mapping,
        },
        Texture::Image(f) => Texture::Image(ImageFile { scale: f.scale * s, ..f }),
        Texture::MeshAttribute { name, slot, scale } if s.x == s.y && s.y == s.z => Texture::MeshAttribute {
            name,
            slot,
            scale: scale * s.x,
        },
        Texture::MeshAttribute { .. } => return None,
    })
}
