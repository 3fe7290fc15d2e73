//! `<bsdf>`: materials, the wrappers around them (twosided, bumpmap, normalmap, mask) and their helpers.

use super::table::{differs, not_read, noted, read, refused, Param, PluginDoc, Status};
use super::{source, Reader, BSDFS, MAX_NESTING};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::{Colour, Plugin};
use crate::desc::xml::values;
use crate::desc::{Located, MaterialDesc, Source, TextureRef};
use crate::error::Result;
use crate::material::{Distribution, Material};
use crate::math::Vec3;

const INT_IOR_BK7: Param = read(
    "int_ior",
    "float or name",
    "bk7",
    "a number or a name from Mitsuba's table; η = int/ext",
);
const EXT_IOR: Param = read("ext_ior", "float or name", "air", "");
const SPECULAR_REFLECTANCE: Param = differs("specular_reflectance", "colour", "1", "a colour (rdr takes no texture here)");
const SPECULAR_TRANSMITTANCE: Param = differs("specular_transmittance", "colour", "1", "a colour (rdr takes no texture here)");
const ALPHA: Param = read(
    "alpha",
    "float texture",
    "0.1",
    "a number in [0, 10] or a texture (its value at the point)",
);
const ALPHA_U: Param = read("alpha_u", "float texture", "0.1", "with `alpha_v`, instead of `alpha`");
const ALPHA_V: Param = read("alpha_v", "float texture", "0.1", "");
const DISTRIBUTION: Param = read("distribution", "string", "beckmann", "`beckmann` or `ggx`");
const SAMPLE_VISIBLE: Param = noted("sample_visible", "boolean", "rdr samples visible normals where it can");
const MATERIAL: Param = read("material", "string", "none", "a named conductor (`Au`, `Cu`, …) or `none`");
const ETA: Param = read("eta", "texture", "0", "with `k`, instead of `material`; a colour or a texture");
const K: Param = read("k", "texture", "1", "a colour or a texture");
const EXT_ETA: Param = differs("ext_eta", "float", "", "(Mitsuba 0.6) folded into η and k, with a warning");
const CONDUCTOR_TINT: Param = read("specular_reflectance", "texture", "1", "a colour or a texture");
const PERTURB: [Param; 2] = [
    read("flip_invalid_normals", "boolean", "true", ""),
    read("use_shadowing_function", "boolean", "true", ""),
];

/// The BSDFs' rows of the plugin table.
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "bsdf",
        names: &["diffuse"],
        status: Status::Read,
        note: "",
        params: &[
            read("reflectance", "texture", "0.5", "a colour or a texture"),
            read("diffuse_reflectance", "texture", "0.5", "(Mitsuba 0.6) the same"),
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["dielectric", "thindielectric"],
        status: Status::Read,
        note: "",
        params: &[INT_IOR_BK7, EXT_IOR, SPECULAR_REFLECTANCE, SPECULAR_TRANSMITTANCE],
    },
    PluginDoc {
        element: "bsdf",
        names: &["roughdielectric"],
        status: Status::Read,
        note: "",
        params: &[
            INT_IOR_BK7,
            EXT_IOR,
            SPECULAR_REFLECTANCE,
            SPECULAR_TRANSMITTANCE,
            ALPHA,
            ALPHA_U,
            ALPHA_V,
            DISTRIBUTION,
            SAMPLE_VISIBLE,
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["conductor"],
        status: Status::Read,
        note: "The defaults (η 0, k 1) make a perfect mirror.",
        params: &[MATERIAL, ETA, K, EXT_ETA, CONDUCTOR_TINT],
    },
    PluginDoc {
        element: "bsdf",
        names: &["roughconductor"],
        status: Status::Read,
        note: "Reflects on its front only, as Mitsuba's (a `twosided` makes it two-sided).",
        params: &[
            MATERIAL,
            ETA,
            K,
            EXT_ETA,
            CONDUCTOR_TINT,
            ALPHA,
            ALPHA_U,
            ALPHA_V,
            DISTRIBUTION,
            SAMPLE_VISIBLE,
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["plastic"],
        status: Status::Read,
        note: "",
        params: &[
            read("diffuse_reflectance", "texture", "0.5", "a colour or a texture"),
            SPECULAR_REFLECTANCE,
            read("int_ior", "float or name", "polypropylene", "1.49"),
            EXT_IOR,
            read("nonlinear", "boolean", "false", ""),
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["roughplastic"],
        status: Status::Read,
        note: "",
        params: &[
            read("diffuse_reflectance", "texture", "0.5", "a colour or a texture"),
            SPECULAR_REFLECTANCE,
            read("int_ior", "float or name", "polypropylene", "1.49"),
            EXT_IOR,
            read("nonlinear", "boolean", "false", ""),
            read(
                "alpha",
                "float",
                "0.1",
                "a number in [0, 10], as in Mitsuba 3 (its coating tables need one roughness)",
            ),
            refused("alpha_u", "float", "", "roughplastic is isotropic"),
            refused("alpha_v", "float", "", "roughplastic is isotropic"),
            DISTRIBUTION,
            SAMPLE_VISIBLE,
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["twosided"],
        status: Status::Read,
        note: "One or two nested non-transmitting bsdfs (the second is the back).",
        params: &[],
    },
    PluginDoc {
        element: "bsdf",
        names: &["bumpmap"],
        status: Status::Read,
        note: "One nested `<texture>` (the heights) and one nested `<bsdf>`.",
        params: &[read("scale", "float", "1", ""), PERTURB[0], PERTURB[1]],
    },
    PluginDoc {
        element: "bsdf",
        names: &["normalmap"],
        status: Status::Read,
        note: "One nested `<bsdf>`.",
        params: &[
            read("normalmap", "texture", "0.5, 0.5, 1", "required: the normals"),
            PERTURB[0],
            PERTURB[1],
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["mask"],
        status: Status::Read,
        note: "Around one nested `<bsdf>`; outermost only.",
        params: &[read("opacity", "float texture", "0.5", "a number or a texture")],
    },
    PluginDoc {
        element: "bsdf",
        names: &["principled"],
        status: Status::Read,
        note: "Each parameter but the rates and `eta`/`specular` a number, colour or texture.",
        params: &[
            read("base_color", "texture", "0.5", ""),
            read("roughness", "float texture", "0.5", ""),
            read("metallic", "float texture", "0", ""),
            read("spec_tint", "float texture", "0", ""),
            read("anisotropic", "float texture", "0", ""),
            read("sheen", "float texture", "0", ""),
            read("sheen_tint", "float texture", "0", ""),
            read("clearcoat", "float texture", "0", ""),
            read("clearcoat_gloss", "float texture", "0", ""),
            read("spec_trans", "float texture", "0", ""),
            read("flatness", "float texture", "0", ""),
            read("eta", "float", "", "or `specular`, not both"),
            read("specular", "float", "0.5", ""),
            read("main_specular_sampling_rate", "float", "1", ""),
            read("clearcoat_sampling_rate", "float", "1", ""),
            read("diffuse_reflectance_sampling_rate", "float", "1", ""),
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["principledthin"],
        status: Status::Read,
        note: "Each parameter but the rates a number, colour or texture.",
        params: &[
            read("base_color", "texture", "0.5", ""),
            read("roughness", "float texture", "0.5", ""),
            read("anisotropic", "float texture", "0", ""),
            read("spec_trans", "float texture", "0", ""),
            read("eta", "float texture", "1.5", ""),
            read("spec_tint", "float texture", "0", ""),
            read("sheen", "float texture", "0", ""),
            read("sheen_tint", "float texture", "0", ""),
            read("flatness", "float texture", "0", ""),
            read("diff_trans", "float texture", "0", "up to 2"),
            read("specular_reflectance_sampling_rate", "float", "1", ""),
            read("specular_transmittance_sampling_rate", "float", "1", ""),
            read("diffuse_reflectance_sampling_rate", "float", "1", ""),
            read("diffuse_transmittance_sampling_rate", "float", "1", ""),
        ],
    },
    PluginDoc {
        element: "bsdf",
        names: &["blendbsdf"],
        status: Status::Read,
        note: "Two nested bsdfs, the first at weight 0.",
        params: &[read("weight", "float texture", "0.5", "required: a number or a texture")],
    },
    not_read(
        "bsdf",
        &[
            "hair",
            "measured",
            "pplastic",
            "polarizer",
            "retarder",
            "circular",
            "measured_polarized",
            "null",
        ],
        Status::Refused,
        "not read",
    ),
    PluginDoc {
        element: "bsdf",
        names: &["mixturebsdf"],
        status: Status::Read,
        note: "(Mitsuba 0.6; Mitsuba 3 refuses it) as many nested bsdfs as weights, read as nested `blendbsdf`s.",
        params: &[read(
            "weights",
            "string",
            "",
            "required: \"w₁, w₂, …\", each at least 0, summing to 1",
        )],
    },
    PluginDoc {
        element: "bsdf",
        names: &["phong"],
        status: Status::Read,
        note: "(Mitsuba 0.6; Mitsuba 3 cannot read it) Lambertian plus the normalised modified Phong lobe, sampled as 0.6 samples it.",
        params: &[
            read("diffuse_reflectance", "texture", "0.5", "a colour or a texture"),
            differs("specular_reflectance", "colour", "0.2", "a constant colour only"),
            differs("exponent", "float", "30", "a number only, at least 0"),
        ],
    },
];

impl<'a> Reader<'a> {
    pub(super) fn default_material(&mut self) -> String {
        if let Some(m) = self.materials.iter().find(|m| m.name == "__default_diffuse") {
            return m.name.clone();
        }
        self.materials.push(MaterialDesc {
            name: "__default_diffuse".into(),
            source: Source::Json(String::new()),
            material: Material::Diffuse {
                texture: TextureRef::Color(Vec3::splat(0.5)),
                twosided: false,
            },
        });
        "__default_diffuse".into()
    }

    /// The name of the material of a `<bsdf>` (read once however often referenced).
    pub(super) fn material(&mut self, el: &'a Element) -> Result<String> {
        if let Some(n) = self.material_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        let material = self.material_value(el)?;
        let name = self.unique(el.attr("id"), "bsdf");
        self.materials.push(MaterialDesc {
            name: name.clone(),
            source: source(el),
            material,
        });
        self.material_of.insert(el as *const Element, name.clone());
        Ok(name)
    }

    pub(super) fn nest(&mut self, el: &Element) -> Result<()> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(el.error("materials and textures nested too deeply (a circular reference?)"));
        }
        Ok(())
    }

    pub(super) fn material_value(&mut self, el: &'a Element) -> Result<Material<TextureRef>> {
        self.nest(el)?;
        let r = self.material_inner(el);
        self.depth -= 1;
        r
    }

    pub(super) fn material_inner(&mut self, el: &'a Element) -> Result<Material<TextureRef>> {
        let p = Plugin::new(el, self.ids)?;
        let m = match p.ty.as_str() {
            "diffuse" => {
                let name = if el.legacy && p.has("diffuse_reflectance") {
                    "diffuse_reflectance"
                } else {
                    "reflectance"
                };
                Material::Diffuse {
                    texture: self.texture_ref(&p, name, Vec3::splat(0.5))?,
                    twosided: false,
                }
            }
            "twosided" => {
                let inner = p.objects("bsdf");
                let Some((b, _)) = inner.first() else {
                    return Err(p.error("a twosided bsdf needs a nested <bsdf>"));
                };
                if let Some((_, at)) = inner.get(2) {
                    return Err(at.error("a twosided bsdf takes one or two nested <bsdf>s"));
                }
                let front = self.material_value(b)?;
                let back = match inner.get(1) {
                    Some((b, _)) => Some(self.material_value(b)?),
                    None => None,
                };
                for (m, (_, at)) in std::iter::once(&front).chain(back.as_ref()).zip(&inner) {
                    if matches!(m, Material::Mask { .. }) {
                        return Err(at.error("a mask must be the outermost bsdf (put the twosided inside it)"));
                    }
                    if matches!(m, Material::TwoSided { .. }) || matches!(m, Material::Diffuse { twosided: true, .. }) {
                        return Err(at.error("twosided cannot wrap another twosided bsdf"));
                    }
                    let new_transmitting = matches!(
                        m,
                        Material::Principled(_) | Material::PrincipledThin(_) | Material::BlendBsdf { .. }
                    ) && m.transmits();
                    if back.is_some() && m.transmits()
                        || new_transmitting
                        || matches!(m, Material::ThinDielectric { .. } | Material::RoughDielectric { .. })
                    {
                        return Err(at.error("twosided wraps only reflecting bsdfs (this one transmits light)"));
                    }
                }
                match (front, back) {
                    // rdr's own two-sided diffuse; its roughconductor is two-sided already
                    (Material::Diffuse { texture, .. }, None) => Material::Diffuse { texture, twosided: true },
                    (mut m @ Material::RoughConductor { .. }, None) => {
                        if let Material::RoughConductor { twosided, .. } = &mut m {
                            *twosided = true;
                        }
                        m
                    }
                    // smooth glass is the same from both sides (the 0.6 course files wrap it)
                    (m @ (Material::Glass { .. } | Material::Refraction { .. }), None) => {
                        self.ids.convert_note(
                            el,
                            "<bsdf type=\"twosided\"> around a dielectric is read as the dielectric alone: the JSON has no twosided, and converting back writes the dielectric unwrapped",
                        );
                        m
                    }
                    (front, back) => Material::TwoSided {
                        front: Box::new(front),
                        back: back.map(Box::new),
                    },
                }
            }
            "bumpmap" | "normalmap" | "mask" => return self.wrapper(p),
            "dielectric" => Material::Glass {
                reflect: colour_of(&p, "specular_reflectance")?,
                transmit: colour_of(&p, "specular_transmittance")?,
                eta: ior_ratio(&p, "bk7")?,
            },
            "roughconductor" => {
                let (alpha_x, alpha_y, alpha_textures) = self.alphas(&p)?;
                let (eta, k, eta_k_textures) = self.conductor_eta_k(&p)?;
                p.ignore("sample_visible");
                Material::RoughConductor {
                    texture: self.texture_ref(&p, "specular_reflectance", Vec3::ONE)?,
                    eta_i: Vec3::ONE,
                    eta_t: eta.max(Vec3::splat(1e-4)),
                    k,
                    alpha_x,
                    alpha_y,
                    alpha_textures,
                    eta_k_textures,
                    distribution: distribution(&p)?,
                    // Mitsuba's reflects on its front only (a twosided makes it two-sided)
                    twosided: false,
                }
            }
            "conductor" => {
                let (eta, k, eta_k_textures) = self.conductor_eta_k(&p)?;
                Material::Conductor {
                    texture: self.texture_ref(&p, "specular_reflectance", Vec3::ONE)?,
                    eta,
                    k,
                    eta_k_textures,
                }
            }
            "thindielectric" => Material::ThinDielectric {
                reflect: colour_of(&p, "specular_reflectance")?,
                transmit: colour_of(&p, "specular_transmittance")?,
                eta: ior_ratio(&p, "bk7")?,
            },
            "roughdielectric" => {
                let (alpha_x, alpha_y, alpha_textures) = self.alphas(&p)?;
                p.ignore("sample_visible");
                Material::RoughDielectric {
                    reflect: colour_of(&p, "specular_reflectance")?,
                    transmit: colour_of(&p, "specular_transmittance")?,
                    eta: ior_ratio(&p, "bk7")?,
                    alpha_x,
                    alpha_y,
                    alpha_textures,
                    distribution: distribution(&p)?,
                }
            }
            "plastic" | "roughplastic" => {
                let texture = self.texture_ref(&p, "diffuse_reflectance", Vec3::splat(0.5))?;
                let specular = colour_of(&p, "specular_reflectance")?;
                let eta = ior_ratio(&p, "polypropylene")?;
                if eta == 1.0 {
                    return Err(p.value_error("int_ior", "a coating needs int_ior and ext_ior to differ"));
                }
                let nonlinear = p.boolean("nonlinear", false)?;
                if p.ty == "plastic" {
                    Material::Plastic {
                        texture,
                        specular,
                        eta,
                        nonlinear,
                        specular_sampling_weight: None,
                    }
                } else {
                    if p.has("alpha_u") || p.has("alpha_v") {
                        return Err(p.error("roughplastic is isotropic: give alpha, not alpha_u and alpha_v"));
                    }
                    let (alpha, _, textured) = self.alphas(&p)?;
                    if textured.is_some() {
                        return Err(p.value_error(
                            "alpha",
                            "roughplastic's alpha must be a number (as in Mitsuba 3: its coating tables need one roughness)",
                        ));
                    }
                    p.ignore("sample_visible");
                    Material::RoughPlastic {
                        texture,
                        specular,
                        eta,
                        nonlinear,
                        alpha,
                        distribution: distribution(&p)?,
                        specular_sampling_weight: None,
                        tables: None,
                    }
                }
            }
            "principled" => self.principled(&p)?,
            "principledthin" => self.principled_thin(&p)?,
            "blendbsdf" => self.blendbsdf(&p)?,
            "mixturebsdf" => self.mixturebsdf(&p)?,
            "phong" => {
                let exponent = p.float("exponent", 30.0)?;
                if !(exponent >= 0.0 && exponent.is_finite()) {
                    return Err(p.value_error("exponent", "must be a finite number, at least 0"));
                }
                let specular = p.rgb("specular_reflectance", Vec3::splat(0.2))?;
                if !(specular.min_element() >= 0.0 && specular.is_finite()) {
                    return Err(p.value_error("specular_reflectance", "must not be negative"));
                }
                Material::Phong {
                    texture: self.texture_ref(&p, "diffuse_reflectance", Vec3::splat(0.5))?,
                    specular,
                    exponent,
                    specular_sampling_weight: None,
                }
            }
            other => return Err(p.error(format!("unsupported bsdf \"{other}\" (supported: {BSDFS})"))),
        };
        p.finish(&["bsdf", "texture"])?;
        Ok(m)
    }

    /// `bumpmap` (one nested `<texture>`, the heights, any name; `scale` 1),
    /// `normalmap` (the `<texture name="normalmap">`), each with `flip_invalid_normals`
    /// and `use_shadowing_function` (true); `mask` (`opacity` 0.5, a float or texture).
    /// Each wraps exactly one nested `<bsdf>`; a mask must be the outermost.
    pub(super) fn wrapper(&mut self, p: Plugin<'a>) -> Result<Material<TextureRef>> {
        let ty = p.ty.clone();
        let inner = p.objects("bsdf");
        let Some((b, _)) = inner.first() else {
            return Err(p.error(format!("a {ty} bsdf needs a nested <bsdf>")));
        };
        if let Some((_, at)) = inner.get(1) {
            return Err(at.error(format!("a {ty} bsdf takes one nested <bsdf>")));
        }
        let nested = self.material_value(b)?;
        let at = inner[0].1;
        if matches!(nested, Material::Mask { .. }) {
            return Err(at.error("a mask must be the outermost bsdf (put the others inside it)"));
        }
        if ty != "mask" && matches!(nested, Material::BumpMap { .. } | Material::NormalMap { .. }) {
            return Err(at.error("bump and normal maps cannot wrap each other"));
        }
        let inner = Box::new(nested);
        let options = || -> Result<crate::material::bump::PerturbOptions> {
            Ok(crate::material::bump::PerturbOptions {
                flip_invalid_normals: p.boolean("flip_invalid_normals", true)?,
                use_shadowing_function: p.boolean("use_shadowing_function", true)?,
            })
        };
        let m = match ty.as_str() {
            "bumpmap" => {
                let textures = p.objects("texture");
                let Some((t, _)) = textures.first() else {
                    return Err(p.error("a bumpmap bsdf needs a nested <texture> (the height field)"));
                };
                if let Some((_, at)) = textures.get(1) {
                    return Err(at.error("a bumpmap bsdf takes one nested <texture>"));
                }
                let scale = p.float("scale", 1.0)?;
                if !scale.is_finite() {
                    return Err(p.value_error("scale", "must be a finite number"));
                }
                Material::BumpMap {
                    height: TextureRef::Named(Located {
                        value: self.texture(t)?,
                        source: source(t),
                    }),
                    scale,
                    options: options()?,
                    inner,
                }
            }
            "normalmap" => {
                if !p.has("normalmap") {
                    return Err(p.error("a normalmap bsdf needs the texture \"normalmap\""));
                }
                Material::NormalMap {
                    normals: self.texture_ref(&p, "normalmap", Vec3::new(0.5, 0.5, 1.0))?,
                    options: options()?,
                    inner,
                }
            }
            _ => {
                let opacity = self.float_texture_ref(&p, "opacity", Vec3::splat(0.5))?;
                if let TextureRef::Color(c) = opacity {
                    if c.max_element() > 1.0 {
                        return Err(p.value_error("opacity", "must be between 0 and 1"));
                    }
                }
                Material::Mask { opacity, inner }
            }
        };
        p.finish(&["bsdf", "texture"])?;
        Ok(m)
    }

    /// `alpha` (0.1), or both `alpha_u` and `alpha_v`: numbers in [0, 10], or textures
    /// (read as floats); with a texture, both as texture references (the third value).
    pub(super) fn alphas(&mut self, p: &Plugin<'a>) -> Result<(f32, f32, Option<[TextureRef; 2]>)> {
        let keys = if p.has("alpha_u") || p.has("alpha_v") {
            if !(p.has("alpha_u") && p.has("alpha_v")) || p.has("alpha") {
                return Err(p.error("give either alpha, or both alpha_u and alpha_v"));
            }
            ["alpha_u", "alpha_v"]
        } else {
            ["alpha", "alpha"]
        };
        // a number's range first: a texture reference would call a negative one a colour
        for k in keys {
            if let Colour::Constant(c) = p.colour(k, Vec3::splat(0.1))? {
                if !(0.0..=10.0).contains(&c.x) {
                    return Err(p.value_error(k, format!("must be between 0 and 10, found {}", c.x)));
                }
            }
        }
        let refs = [
            self.float_texture_ref(p, keys[0], Vec3::splat(0.1))?,
            self.float_texture_ref(p, keys[1], Vec3::splat(0.1))?,
        ];
        let mut constants = [0.1; 2];
        for (r, a) in refs.iter().zip(&mut constants) {
            if let TextureRef::Color(c) = r {
                *a = c.x;
            }
        }
        let textured = refs.iter().any(|r| matches!(r, TextureRef::Named(_)));
        Ok((constants[0], constants[1], textured.then_some(refs)))
    }

    /// A conductor's η and k: `eta` (0) and `k` (1), colours or textures (then both as
    /// texture references, the third value), or `material` (a name from
    /// [`values::NAMED_CONDUCTORS`], or `none`, the default); the 0.6 `ext_eta` folded in.
    pub(super) fn conductor_eta_k(&mut self, p: &Plugin<'a>) -> Result<(Vec3, Vec3, Option<[TextureRef; 2]>)> {
        let named = p.string_opt("material")?;
        let textured = [("eta", Vec3::ZERO), ("k", Vec3::ONE)]
            .iter()
            .any(|&(k, default)| p.has(k) && matches!(p.colour(k, default), Ok(Colour::Texture(_))));
        if textured && !matches!(named.as_deref(), None | Some("none")) {
            return Err(p.value_error("material", "give either material or eta and k, not both"));
        }
        if textured {
            if p.float_opt("ext_eta")?.is_some_and(|e| e != 1.0) {
                return Err(p.value_error("ext_eta", "cannot be folded into a textured eta or k"));
            }
            let refs = [self.texture_ref(p, "eta", Vec3::ZERO)?, self.texture_ref(p, "k", Vec3::ONE)?];
            return Ok((Vec3::ZERO, Vec3::ONE, Some(refs)));
        }
        let (mut eta, mut k) = match named.as_deref() {
            Some(m) if m != "none" => {
                if p.has("eta") || p.has("k") {
                    return Err(p.value_error("material", "give either material or eta and k, not both"));
                }
                values::conductor(m).map_err(|e| p.value_error("material", e))?
            }
            _ => (p.rgb("eta", Vec3::ZERO)?, p.rgb("k", Vec3::ONE)?),
        };
        if !(eta.min_element() >= 0.0 && k.min_element() >= 0.0 && eta.is_finite() && k.is_finite()) {
            return Err(p.value_error(if p.has("k") { "k" } else { "eta" }, "must not be negative"));
        }
        if let Some(ext) = p.float_opt("ext_eta")? {
            if ext.is_nan() || ext <= 0.0 {
                return Err(p.value_error("ext_eta", "must be positive"));
            }
            // Mitsuba 3 has no ext_eta: η and k are relative to the outside
            eta /= ext;
            k /= ext;
            if ext != 1.0 {
                self.ids.warn(p.el, format!("ext_eta {ext} (Mitsuba 0.6) folded into eta and k"));
            }
        }
        Ok((eta, k, None))
    }
}

/// `int_ior` / `ext_ior` (numbers or names; `ext_ior` "air" by default).
pub(super) fn ior_ratio(p: &Plugin, int_default: &str) -> Result<f32> {
    let eta = p.ior("int_ior", int_default)? / p.ior("ext_ior", "air")?;
    if !(1e-3..=1e3).contains(&eta) {
        return Err(p.error(format!("int_ior / ext_ior = {eta} is out of range")));
    }
    Ok(eta)
}

/// A constant, non-negative reflectance or transmittance (1 by default); rdr's
/// dielectrics and coatings take no textures here.
pub(super) fn colour_of(p: &Plugin, name: &str) -> Result<Vec3> {
    let c = p.rgb(name, Vec3::ONE)?;
    if !(c.min_element() >= 0.0 && c.is_finite()) {
        return Err(p.value_error(name, "must not be negative"));
    }
    Ok(c)
}

/// `distribution`: `beckmann` (the default) or `ggx`.
pub(super) fn distribution(p: &Plugin) -> Result<Distribution> {
    match p.string("distribution", "beckmann")?.to_ascii_lowercase().as_str() {
        "beckmann" => Ok(Distribution::Beckmann),
        "ggx" => Ok(Distribution::Ggx),
        other => Err(p.value_error("distribution", format!("unknown distribution \"{other}\" (beckmann, ggx)"))),
    }
}
