//! Mitsuba's `principled` and `blendbsdf` plugins (the keys: [`crate::desc::principled`]).

use super::{Plugin, Reader};
use crate::desc::principled::{params, thin_params, Given, RATE_KEYS, TEXTURE_KEYS, THIN_RATE_KEYS, THIN_TEXTURE_KEYS};
use crate::desc::TextureRef;
use crate::error::Result;
use crate::material::Material;
use crate::math::Vec3;

impl<'a> Reader<'a> {
    /// `principled`: each texture key a number, a colour or a `<texture>` (float keys
    /// read a colour texture's luminance); `eta` or `specular` numbers (not both); the
    /// three sampling rates.
    pub(super) fn principled(&mut self, p: &Plugin<'a>) -> Result<Material<TextureRef>> {
        if let Some((_, at)) = p.objects("bsdf").first() {
            return Err(at.error(format!("{} cannot contain a <bsdf>", p.describe())));
        }
        let mut textures = Vec::with_capacity(TEXTURE_KEYS.len());
        for (key, default) in TEXTURE_KEYS {
            textures.push(if key == "base_color" {
                self.texture_ref(p, key, Vec3::splat(default))?
            } else {
                self.float_texture_ref(p, key, Vec3::splat(default))?
            });
        }
        let mut rates = [1.0; 3];
        for (r, key) in rates.iter_mut().zip(RATE_KEYS) {
            *r = p.float(key, 1.0)?;
        }
        let given = Given {
            textures: textures.try_into().unwrap_or_else(|_| unreachable!("11 keys")),
            eta: p.float_opt("eta")?,
            specular: p.float_opt("specular")?,
            rates,
        };
        let params = params(given, |k, m| p.value_error(k, m))?;
        Ok(Material::Principled(Box::new(params)))
    }

    /// `principledthin`: its texture keys (numbers, colours or `<texture>`s) and four rates.
    pub(super) fn principled_thin(&mut self, p: &Plugin<'a>) -> Result<Material<TextureRef>> {
        if let Some((_, at)) = p.objects("bsdf").first() {
            return Err(at.error(format!("{} cannot contain a <bsdf>", p.describe())));
        }
        let mut textures = Vec::with_capacity(THIN_TEXTURE_KEYS.len());
        for (key, default) in THIN_TEXTURE_KEYS {
            textures.push(if key == "base_color" {
                self.texture_ref(p, key, Vec3::splat(default))?
            } else {
                self.float_texture_ref(p, key, Vec3::splat(default))?
            });
        }
        let mut rates = [1.0; 4];
        for (r, key) in rates.iter_mut().zip(THIN_RATE_KEYS) {
            *r = p.float(key, 1.0)?;
        }
        let textures: [TextureRef; 10] = textures.try_into().unwrap_or_else(|_| unreachable!("10 keys"));
        let params = thin_params(textures, rates, |k, m| p.value_error(k, m))?;
        Ok(Material::PrincipledThin(Box::new(params)))
    }

    /// Mitsuba 0.6's `mixturebsdf`: `weights` ("w₁, w₂, …", summing to 1) and as many
    /// nested `<bsdf>`s, read as nested blends: w₁·b₁ + (1 − w₁)·mixture(the rest, rescaled).
    pub(super) fn mixturebsdf(&mut self, p: &Plugin<'a>) -> Result<Material<TextureRef>> {
        let text = p.required_string("weights")?;
        let weights: Vec<f32> = text
            .split([',', ' '])
            .filter(|s| !s.trim().is_empty())
            .map(|s| s.trim().parse::<f32>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| p.value_error("weights", format!("expected numbers such as \"0.3, 0.7\", found \"{text}\"")))?;
        let inner = p.objects("bsdf");
        if inner.len() != weights.len() || inner.len() < 2 {
            return Err(p.error(format!(
                "a mixturebsdf takes as many nested <bsdf>s as weights (at least 2): {} weights, {} bsdfs",
                weights.len(),
                inner.len()
            )));
        }
        let sum: f32 = weights.iter().sum();
        if weights.iter().any(|w| w.is_nan() || *w < 0.0) || (sum - 1.0).abs() > 1e-3 {
            return Err(p.value_error("weights", format!("must be at least 0 and sum to 1, found a sum of {sum}")));
        }
        let mut mix = self.material_value(inner[inner.len() - 1].0)?;
        let mut rest = weights[weights.len() - 1];
        for i in (0..inner.len() - 1).rev() {
            // mix holds components i+1.., whose weights sum to `rest`
            let total = weights[i] + rest;
            let weight = if total > 0.0 { rest / total } else { 0.0 };
            mix = Material::BlendBsdf {
                weight: TextureRef::Color(Vec3::splat(weight)),
                first: Box::new(self.material_value(inner[i].0)?),
                second: Box::new(mix),
            };
            rest = total;
        }
        Ok(mix)
    }

    /// `blendbsdf`: `weight` (required, a number or a `<texture>`) and two nested `<bsdf>`s.
    pub(super) fn blendbsdf(&mut self, p: &Plugin<'a>) -> Result<Material<TextureRef>> {
        if !p.has("weight") {
            return Err(p.error("a blendbsdf needs a weight (a float or a texture)"));
        }
        let weight = self.float_texture_ref(p, "weight", Vec3::splat(0.5))?;
        let inner = p.objects("bsdf");
        if inner.len() != 2 {
            let at = inner.get(2).map_or(p.el, |(_, at)| *at);
            return Err(at.error(format!("a blendbsdf takes two nested <bsdf>s, found {}", inner.len())));
        }
        let first = self.material_value(inner[0].0)?;
        let second = self.material_value(inner[1].0)?;
        Ok(Material::BlendBsdf {
            weight,
            first: Box::new(first),
            second: Box::new(second),
        })
    }
}
