//! `<emitter>` plugins read outside a shape: the environment (`constant`, `envmap`).

use super::{source, Reader};
use crate::desc::xml::props::Plugin;
use crate::desc::{EnvMapDesc, ImageFile, Located, TextureDesc};
use crate::error::Result;
use crate::math::{Mat4, Vec2, Vec3};
use crate::texture::{Texture, UvMapping};

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
