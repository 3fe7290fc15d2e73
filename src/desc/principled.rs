//! `principled` and `blendbsdf` in scene descriptions: the one list of their keys
//! (Mitsuba's parameter names, which the JSON format uses too), read from JSON here,
//! from Mitsuba XML by [`super::xml`] and written back by [`super::convert`].
//!
//! `principled` (Mitsuba's `principled`, Burley's Disney BSDF; see
//! [`crate::material::principled`] for the lobes). Each texture key takes a number
//! (a constant), a texture name (a string: its value at the point; float keys read the
//! luminance of a colour texture) or, for `base_color`, a colour `[r, g, b]`:
//! * `base_color` (0.5), `roughness` (0.5), `metallic` (0), `specular` (0.5, a number;
//!   sets η = 2/(1 − √(0.08·specular)) − 1) or `eta` (a number, the index inside over
//!   outside; not both), `spec_tint` (0), `anisotropic` (0), `sheen` (0), `sheen_tint`
//!   (0), `clearcoat` (0), `clearcoat_gloss` (0), `spec_trans` (0), `flatness` (0);
//! * `main_specular_sampling_rate`, `clearcoat_sampling_rate`,
//!   `diffuse_reflectance_sampling_rate` (numbers ≥ 0, 1 each): how often each lobe is
//!   sampled, relative to its weight.
//!
//! Constants must not be negative; with `spec_trans` given (not 0), `eta` = 1 becomes
//! 1.001 and `specular` = 0 becomes 0.001, as in Mitsuba.
//!
//! `principledthin` (Mitsuba's `principledthin`, a thin sheet; see
//! [`crate::material::principledthin`]): `base_color` (0.5), `roughness` (0.5),
//! `anisotropic`, `spec_trans`, `spec_tint`, `sheen`, `sheen_tint`, `flatness` (0),
//! `eta` (1.5; a texture too), `diff_trans` (0, up to 2: the share of the diffuse
//! reflection given to diffuse transmission), and the sampling rates
//! `specular_reflectance_sampling_rate`, `specular_transmittance_sampling_rate`,
//! `diffuse_reflectance_sampling_rate`, `diffuse_transmittance_sampling_rate` (1 each).
//!
//! `blendbsdf` (Mitsuba's `blendbsdf`): `weight` (required: a number or a texture name,
//! clamped to [0, 1]), `material_names` (required, two material names: the first is
//! used at weight 0, the second at weight 1; either may be any material, a
//! `twosided` or another `blendbsdf`, but not the blend itself).
//!
//! ```json
//! "materials": {
//!   "car_paint": {"type": "principled", "base_color": [0.6, 0.05, 0.05], "roughness": 0.35,
//!                 "metallic": 0.3, "clearcoat": 1, "clearcoat_gloss": 0.8},
//!   "frosted":   {"type": "principled", "base_color": 1, "roughness": "rough_map",
//!                 "spec_trans": 1, "eta": 1.5},
//!   "worn":      {"type": "blendbsdf", "weight": "rust_mask", "material_names": ["car_paint", "rust"]}
//! }
//! ```

use super::json::Props;
use super::TextureRef;
use crate::error::Result;
use crate::material::principled::eta_from_specular;
use crate::material::{Material, PrincipledParams, PrincipledThinParams};
use crate::math::Vec3;
use serde_json::Value;

/// The texture keys of `principled` in [`PrincipledParams`]' order, with their
/// defaults; `base_color` is the one colour, the others are floats.
pub const TEXTURE_KEYS: [(&str, f32); 11] = [
    ("base_color", 0.5),
    ("roughness", 0.5),
    ("metallic", 0.0),
    ("spec_tint", 0.0),
    ("anisotropic", 0.0),
    ("sheen", 0.0),
    ("sheen_tint", 0.0),
    ("clearcoat", 0.0),
    ("clearcoat_gloss", 0.0),
    ("spec_trans", 0.0),
    ("flatness", 0.0),
];

/// The sampling-rate keys (numbers, 1 each), in [`PrincipledParams`]' order.
pub const RATE_KEYS: [&str; 3] = [
    "main_specular_sampling_rate",
    "clearcoat_sampling_rate",
    "diffuse_reflectance_sampling_rate",
];

/// The textures of `p` in [`TEXTURE_KEYS`] order.
pub fn textures<T>(p: &PrincipledParams<T>) -> [&T; 11] {
    [
        &p.base_color,
        &p.roughness,
        &p.metallic,
        &p.spec_tint,
        &p.anisotropic,
        &p.sheen,
        &p.sheen_tint,
        &p.clearcoat,
        &p.clearcoat_gloss,
        &p.spec_trans,
        &p.flatness,
    ]
}

/// What a reader found for one key of `principled`.
pub struct Given<T> {
    pub textures: [T; 11],
    pub eta: Option<f32>,
    pub specular: Option<f32>,
    pub rates: [f32; 3],
}

/// Checks and completes what a reader found (`error(key, message)` makes its error):
/// η from `eta` or `specular` (not both), Mitsuba's adjustments with `spec_trans`.
pub fn params<E>(given: Given<TextureRef>, error: impl Fn(&str, String) -> E) -> std::result::Result<PrincipledParams<TextureRef>, E> {
    for ((key, _), t) in TEXTURE_KEYS.iter().zip(&given.textures) {
        if let TextureRef::Color(c) = t {
            if !(c.min_element() >= 0.0 && c.is_finite()) {
                return Err(error(key, format!("must not be negative, found {c}")));
            }
        }
    }
    for (key, r) in RATE_KEYS.iter().zip(given.rates) {
        if !(r >= 0.0 && r.is_finite()) {
            return Err(error(key, format!("must be a finite number of at least 0, found {r}")));
        }
    }
    let [base_color, roughness, metallic, spec_tint, anisotropic, sheen, sheen_tint, clearcoat, clearcoat_gloss, spec_trans, flatness] =
        given.textures;
    if let TextureRef::Color(c) = &anisotropic {
        if c.max_element() > 1.0 {
            return Err(error("anisotropic", format!("must be at most 1, found {}", c.max_element())));
        }
    }
    let has_spec_trans = !matches!(&spec_trans, TextureRef::Color(c) if *c == Vec3::ZERO);
    let (eta, specular) = match (given.eta, given.specular) {
        (Some(_), Some(_)) => return Err(error("specular", "give either eta or specular, not both".into())),
        (Some(eta), None) => {
            if !(1e-3..=1e3).contains(&eta) {
                return Err(error("eta", format!("must be between 0.001 and 1000, found {eta}")));
            }
            (if has_spec_trans && eta == 1.0 { 1.001 } else { eta }, None)
        }
        (None, s) => {
            let s = s.unwrap_or(0.5);
            if !(0.0..=10.0).contains(&s) {
                return Err(error("specular", format!("must be between 0 and 10, found {s}")));
            }
            let s = if has_spec_trans && s == 0.0 { 1e-3 } else { s };
            (eta_from_specular(s), Some(s))
        }
    };
    Ok(PrincipledParams {
        base_color,
        roughness,
        metallic,
        spec_tint,
        anisotropic,
        sheen,
        sheen_tint,
        clearcoat,
        clearcoat_gloss,
        spec_trans,
        flatness,
        eta,
        specular,
        spec_srate: given.rates[0],
        clearcoat_srate: given.rates[1],
        diffuse_srate: given.rates[2],
        has_spec_trans,
    })
}

/// A texture key of a JSON material: a number, a texture name, or (`colour` keys) `[r, g, b]`.
pub fn json_texture(p: &Props, key: &str, default: f32, colour: bool) -> Result<TextureRef> {
    match p.raw(key) {
        None => Ok(TextureRef::Color(Vec3::splat(default))),
        Some(Value::String(s)) => Ok(TextureRef::Named(p.located(key, s.clone()))),
        Some(Value::Number(_)) => Ok(TextureRef::Color(Vec3::splat(p.f32_or(key, default)?))),
        Some(Value::Array(_)) if colour => Ok(TextureRef::Color(p.vec3(key)?)),
        Some(_) => Err(p.error(
            key,
            if colour {
                "expected a number, [r, g, b] or a texture name".to_string()
            } else {
                "expected a number or a texture name".to_string()
            },
        )),
    }
}

/// `principled` from JSON (keys in the module documentation).
pub fn json_principled(p: &Props) -> Result<Material<TextureRef>> {
    let mut textures = Vec::with_capacity(11);
    for (i, (key, default)) in TEXTURE_KEYS.iter().enumerate() {
        textures.push(json_texture(p, key, *default, i == 0)?);
    }
    let mut rates = [1.0; 3];
    for (r, key) in rates.iter_mut().zip(RATE_KEYS) {
        *r = p.f32_or(key, 1.0)?;
    }
    let given = Given {
        textures: textures.try_into().unwrap_or_else(|_| unreachable!("11 keys")),
        eta: p.contains("eta").then(|| p.f32_or("eta", 1.5)).transpose()?,
        specular: p.contains("specular").then(|| p.f32_or("specular", 0.5)).transpose()?,
        rates,
    };
    Ok(Material::Principled(Box::new(params(given, |k, m| p.error(k, m))?)))
}

/// `blendbsdf`'s `weight` (required) from JSON.
pub fn json_weight(p: &Props) -> Result<TextureRef> {
    if !p.contains("weight") {
        return Err(p.error("weight", "required key is missing"));
    }
    let w = json_texture(p, "weight", 0.5, false)?;
    if let TextureRef::Color(c) = &w {
        if !c.is_finite() {
            return Err(p.error("weight", "must be finite"));
        }
    }
    Ok(w)
}

/// A float-valued texture key as JSON: the number of a grey constant, the name of a texture.
fn json_of(t: &TextureRef, colour: bool) -> Value {
    match t {
        TextureRef::Named(n) => Value::String(n.value.clone()),
        TextureRef::Color(c) if colour && !(c.x == c.y && c.y == c.z) => serde_json::json!([c.x, c.y, c.z]),
        TextureRef::Color(c) => serde_json::json!(c.x),
    }
}

/// `principled` as JSON (what [`json_principled`] reads back).
pub fn to_json(p: &PrincipledParams<TextureRef>) -> Value {
    let mut m = serde_json::Map::new();
    m.insert("type".into(), "principled".into());
    for (i, ((key, _), t)) in TEXTURE_KEYS.iter().zip(textures(p)).enumerate() {
        m.insert((*key).into(), json_of(t, i == 0));
    }
    match p.specular {
        Some(s) => m.insert("specular".into(), serde_json::json!(s)),
        None => m.insert("eta".into(), serde_json::json!(p.eta)),
    };
    for (key, r) in RATE_KEYS.iter().zip([p.spec_srate, p.clearcoat_srate, p.diffuse_srate]) {
        if r != 1.0 {
            m.insert((*key).into(), serde_json::json!(r));
        }
    }
    Value::Object(m)
}

/// One texture key as a Mitsuba property: `<float>` for a grey constant of a float
/// key, `<rgb>` for a colour, `texture(name, reference)` for a named texture.
pub fn xml_property(key: &str, t: &TextureRef, colour: bool, texture: &dyn Fn(&str, &TextureRef) -> String) -> String {
    match t {
        TextureRef::Color(c) if !colour && c.x == c.y && c.y == c.z => format!("<float name=\"{key}\" value=\"{}\"/>", c.x),
        TextureRef::Color(c) => format!("<rgb name=\"{key}\" value=\"{}, {}, {}\"/>", c.x, c.y, c.z),
        TextureRef::Named(_) => texture(key, t),
    }
}

/// The properties of a Mitsuba `<bsdf type="principled">` (what the XML reader reads back).
pub fn xml_properties(p: &PrincipledParams<TextureRef>, texture: &dyn Fn(&str, &TextureRef) -> String) -> String {
    let mut s = String::new();
    for (i, ((key, default), t)) in TEXTURE_KEYS.iter().zip(textures(p)).enumerate() {
        if matches!(t, TextureRef::Color(c) if *c == Vec3::splat(*default)) {
            continue;
        }
        s += &xml_property(key, t, i == 0, texture);
    }
    s += &match p.specular {
        Some(v) => format!("<float name=\"specular\" value=\"{v}\"/>"),
        None => format!("<float name=\"eta\" value=\"{}\"/>", p.eta),
    };
    for (key, r) in RATE_KEYS.iter().zip([p.spec_srate, p.clearcoat_srate, p.diffuse_srate]) {
        if r != 1.0 {
            s += &format!("<float name=\"{key}\" value=\"{r}\"/>");
        }
    }
    s
}

/// The texture keys of `principledthin` in [`PrincipledThinParams`]' order, with their
/// defaults (`base_color` the colour; `eta` a texture too, as in Mitsuba; `diff_trans`
/// runs from 0 to 2).
pub const THIN_TEXTURE_KEYS: [(&str, f32); 10] = [
    ("base_color", 0.5),
    ("roughness", 0.5),
    ("anisotropic", 0.0),
    ("spec_trans", 0.0),
    ("eta", 1.5),
    ("spec_tint", 0.0),
    ("sheen", 0.0),
    ("sheen_tint", 0.0),
    ("flatness", 0.0),
    ("diff_trans", 0.0),
];

/// `principledthin`'s sampling-rate keys (numbers, 1 each).
pub const THIN_RATE_KEYS: [&str; 4] = [
    "specular_reflectance_sampling_rate",
    "specular_transmittance_sampling_rate",
    "diffuse_reflectance_sampling_rate",
    "diffuse_transmittance_sampling_rate",
];

/// Checks what a reader found for `principledthin`: constants not negative, a
/// constant `eta` in [0.001, 1000] and `diff_trans` at most 2, rates ≥ 0.
pub fn thin_params<E>(
    textures: [TextureRef; 10],
    rates: [f32; 4],
    error: impl Fn(&str, String) -> E,
) -> std::result::Result<PrincipledThinParams<TextureRef>, E> {
    for ((key, _), t) in THIN_TEXTURE_KEYS.iter().zip(&textures) {
        if let TextureRef::Color(c) = t {
            if !(c.min_element() >= 0.0 && c.is_finite()) {
                return Err(error(key, format!("must not be negative, found {c}")));
            }
            if *key == "eta" && !(1e-3..=1e3).contains(&c.x) {
                return Err(error(key, format!("must be between 0.001 and 1000, found {}", c.x)));
            }
            if *key == "diff_trans" && c.max_element() > 2.0 {
                return Err(error(key, format!("must be at most 2, found {}", c.max_element())));
            }
            if *key == "anisotropic" && c.max_element() > 1.0 {
                return Err(error(key, format!("must be at most 1, found {}", c.max_element())));
            }
        }
    }
    for (key, r) in THIN_RATE_KEYS.iter().zip(rates) {
        if !(r >= 0.0 && r.is_finite()) {
            return Err(error(key, format!("must be a finite number of at least 0, found {r}")));
        }
    }
    let [base_color, roughness, anisotropic, spec_trans, eta, spec_tint, sheen, sheen_tint, flatness, diff_trans] = textures;
    Ok(PrincipledThinParams {
        base_color,
        roughness,
        anisotropic,
        spec_trans,
        eta,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        diff_trans,
        rates,
    })
}

/// `principledthin` from JSON: the keys of [`THIN_TEXTURE_KEYS`] (numbers or texture
/// names; `base_color` also `[r, g, b]`) and [`THIN_RATE_KEYS`].
pub fn json_principled_thin(p: &Props) -> Result<Material<TextureRef>> {
    let mut textures = Vec::with_capacity(10);
    for (i, (key, default)) in THIN_TEXTURE_KEYS.iter().enumerate() {
        textures.push(json_texture(p, key, *default, i == 0)?);
    }
    let mut rates = [1.0; 4];
    for (r, key) in rates.iter_mut().zip(THIN_RATE_KEYS) {
        *r = p.f32_or(key, 1.0)?;
    }
    let textures: [TextureRef; 10] = textures.try_into().unwrap_or_else(|_| unreachable!("10 keys"));
    Ok(Material::PrincipledThin(Box::new(thin_params(textures, rates, |k, m| {
        p.error(k, m)
    })?)))
}

/// `principledthin` as JSON.
pub fn thin_to_json(p: &PrincipledThinParams<TextureRef>) -> Value {
    let mut m = serde_json::Map::new();
    m.insert("type".into(), "principledthin".into());
    for (i, ((key, _), t)) in THIN_TEXTURE_KEYS.iter().zip(p.textures()).enumerate() {
        m.insert((*key).into(), json_of(t, i == 0));
    }
    for (key, r) in THIN_RATE_KEYS.iter().zip(p.rates) {
        if r != 1.0 {
            m.insert((*key).into(), serde_json::json!(r));
        }
    }
    Value::Object(m)
}

/// The properties of a Mitsuba `<bsdf type="principledthin">`.
pub fn thin_xml_properties(p: &PrincipledThinParams<TextureRef>, texture: &dyn Fn(&str, &TextureRef) -> String) -> String {
    let mut s = String::new();
    for (i, ((key, default), t)) in THIN_TEXTURE_KEYS.iter().zip(p.textures()).enumerate() {
        if matches!(t, TextureRef::Color(c) if *c == Vec3::splat(*default)) {
            continue;
        }
        s += &xml_property(key, t, i == 0, texture);
    }
    for (key, r) in THIN_RATE_KEYS.iter().zip(p.rates) {
        if r != 1.0 {
            s += &format!("<float name=\"{key}\" value=\"{r}\"/>");
        }
    }
    s
}
