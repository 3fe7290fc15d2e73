//! Mitsuba's value syntax: number lists, vectors, colours, spectra (constant,
//! `wavelength:value` pairs, or the 0.6 dialect's three RGB values), named indices of
//! refraction and conductors, transforms, and the camelCase → snake_case rule of
//! Mitsuba's upgrade of pre-2.0 files.

use super::cie_table::{CIE_5NM, CIE_Y_NORMALIZATION};
use crate::math::{Mat4, Vec3, Vec4};

/// Splits a value list at commas and whitespace (Mitsuba accepts either).
pub fn tokens(s: &str) -> Vec<&str> {
    s.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect()
}

/// One finite number (parsed as f64, which must fit an f32).
pub fn number(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v: f64 = t.parse().map_err(|_| format!("could not parse floating point value \"{t}\""))?;
    if !v.is_finite() || v.abs() > f32::MAX as f64 {
        return Err(format!("\"{t}\" is not a finite 32-bit number"));
    }
    Ok(v)
}

/// `n` numbers, or one number repeated when `one_repeats`.
pub fn numbers(s: &str, n: usize, one_repeats: bool) -> Result<Vec<f64>, String> {
    let t = tokens(s);
    if t.len() == 1 && one_repeats {
        return Ok(vec![number(t[0])?; n]);
    }
    if t.len() != n {
        let one = if one_repeats { "1 or " } else { "" };
        return Err(format!("expected {one}{n} values, found {} in \"{s}\"", t.len()));
    }
    t.iter().map(|x| number(x)).collect()
}

pub fn integer(s: &str) -> Result<i64, String> {
    let t = s.trim();
    t.parse::<i64>().map_err(|_| format!("could not parse integer value \"{t}\""))
}

pub fn boolean(s: &str) -> Result<bool, String> {
    match s.trim().to_ascii_lowercase().as_str() {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(format!("could not parse boolean value \"{s}\" (must be \"true\" or \"false\")")),
    }
}

pub fn vec3(v: &[f64]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// Mitsuba's rule for names in files older than 2.0: an uppercase letter after a
/// lowercase one starts a `_`-separated lowercase word, and the uppercase letters
/// right after it join that word (`toWorld` → `to_world`, `intIOR` → `int_ior`).
pub fn camel_to_snake(s: &str) -> String {
    let c: Vec<char> = s.chars().collect();
    let mut out = String::with_capacity(s.len() + 4);
    let mut i = 0;
    while i < c.len() {
        if i > 0 && c[i - 1].is_ascii_lowercase() && c[i].is_ascii_uppercase() {
            out.push('_');
            out.push(c[i].to_ascii_lowercase());
            while i + 1 < c.len() && c[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(c[i].to_ascii_lowercase());
            }
        } else {
            out.push(c[i]);
        }
        i += 1;
    }
    out
}

// ---------------------------------------------------------------------------
// Transforms
// ---------------------------------------------------------------------------

/// `<translate>`.
pub fn translate(v: Vec3) -> Mat4 {
    Mat4::from_translation(v)
}

/// `<scale>`.
pub fn scale(v: Vec3) -> Mat4 {
    Mat4::from_scale(v)
}

/// `<rotate>`: `angle` degrees counter-clockwise about `axis` (right-handed).
pub fn rotate(axis: Vec3, degrees: f64) -> Result<Mat4, String> {
    if axis == Vec3::ZERO {
        return Err("rotation axis cannot be zero".into());
    }
    Ok(Mat4::from_axis_angle(axis.normalize(), (degrees as f32).to_radians()))
}

/// `<matrix>`: 16 (4×4) or 9 (3×3) values, row-major.
pub fn matrix(s: &str) -> Result<Mat4, String> {
    let t = tokens(s);
    let n = match t.len() {
        16 => 4,
        9 => 3,
        k => return Err(format!("matrix must have 9 or 16 values, got {k}")),
    };
    let mut m = [[0.0f32; 4]; 4];
    for (r, row) in m.iter_mut().enumerate() {
        row[r] = 1.0;
    }
    for i in 0..n {
        for j in 0..n {
            m[i][j] = number(t[i * n + j])? as f32;
        }
    }
    // glam is column-major: column j holds m[·][j]
    Ok(Mat4::from_cols(
        Vec4::new(m[0][0], m[1][0], m[2][0], m[3][0]),
        Vec4::new(m[0][1], m[1][1], m[2][1], m[3][1]),
        Vec4::new(m[0][2], m[1][2], m[2][2], m[3][2]),
        Vec4::new(m[0][3], m[1][3], m[2][3], m[3][3]),
    ))
}

/// `<lookat>`: local +z towards `target`, +y close to `up`, +x = up × dir ("left"),
/// origin at `origin`. A zero `up` is replaced by any perpendicular (as Mitsuba does).
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Result<Mat4, String> {
    let dir = (target - origin).normalize();
    if !dir.is_finite() {
        return Err("invalid lookat transformation (origin equals target)".into());
    }
    let up = if up == Vec3::ZERO {
        crate::math::coordinate_system(dir).0
    } else {
        up
    };
    let left = up.normalize().cross(dir);
    if left.length_squared().is_nan() || left.length_squared() <= 1e-12 {
        return Err("invalid lookat transformation (up is parallel to the viewing direction)".into());
    }
    let left = left.normalize();
    let new_up = dir.cross(left);
    Ok(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// A matrix as 16 row-major numbers (the JSON and `<matrix>` order).
pub fn row_major(m: &Mat4) -> [f32; 16] {
    m.transpose().to_cols_array()
}

// ---------------------------------------------------------------------------
// Spectra
// ---------------------------------------------------------------------------

/// How Mitsuba's RGB variants turn a spectrum into RGB, which depends on where it is
/// (see `docs/src/mitsuba/spectra.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumRole {
    /// A reflectance (or any value outside an emitter): weighted by D65, clamped to [0, 1].
    Reflectance,
    /// A property of an `<emitter>` itself: equal-energy, unbounded.
    Emission,
    /// `eta`, `k`, `int_ior`, `ext_ior`, `sigma_t` outside emitters: weighted by D65, unbounded.
    Unbounded,
}

impl SpectrumRole {
    /// Mitsuba's rule: the property's name and whether its plugin is an emitter decide.
    pub fn of(name: &str, in_emitter: bool) -> SpectrumRole {
        let unbounded = matches!(name, "eta" | "k" | "int_ior" | "ext_ior" | "sigma_t");
        match (in_emitter, unbounded) {
            (true, false) => SpectrumRole::Emission,
            (_, true) => SpectrumRole::Unbounded,
            (false, false) => SpectrumRole::Reflectance,
        }
    }
}

/// The CIE table row (x̄, ȳ, z̄, D65) at `lambda` nm, interpolated linearly (zero outside).
fn cie_at(lambda: f64) -> [f64; 4] {
    let t = (lambda - 360.0) / 5.0;
    let n = CIE_5NM.len();
    if !(0.0..=(n - 1) as f64).contains(&t) {
        return [0.0; 4];
    }
    let i = (t.floor() as usize).min(n - 2);
    let f = t - i as f64;
    std::array::from_fn(|c| CIE_5NM[i][c] * (1.0 - f) + CIE_5NM[i + 1][c] * f)
}

/// Linear sRGB (Rec. 709 primaries, D65 white) from CIE XYZ.
fn xyz_to_srgb([x, y, z]: [f64; 3]) -> [f64; 3] {
    [
        3.240479 * x - 1.537150 * y - 0.498535 * z,
        -0.969256 * x + 1.875991 * y + 0.041556 * z,
        0.055648 * x - 0.204043 * y + 1.057311 * z,
    ]
}

/// Equal-energy light of radiance 1 in linear sRGB: a constant emission spectrum.
pub fn equal_energy_rgb() -> Vec3 {
    let c = xyz_to_srgb([1.0; 3]);
    Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
}

/// The RGB of a spectrum given as `(wavelength nm, value)` pairs (increasing
/// wavelengths), as Mitsuba's RGB variants compute it: the piecewise-linear spectrum
/// (zero outside the given range) integrated against the CIE 1931 curves over 360–830 nm
/// at 1,000 points, weighted by D65 unless it is an emission, normalised so that a
/// constant 1 has Y = 1, converted to linear sRGB; negative components become 0, and a
/// reflectance is clamped to at most 1.
pub fn spectrum_to_rgb(pairs: &[(f64, f64)], role: SpectrumRole) -> Vec3 {
    const STEPS: usize = 1000;
    let (lo, hi) = (360.0, 830.0);
    let (first, last) = (pairs[0].0, pairs[pairs.len() - 1].0);
    let mut xyz = [0.0f64; 3];
    for i in 0..STEPS {
        let w = lo + (hi - lo) * i as f64 / (STEPS - 1) as f64;
        if w < first || w > last {
            continue;
        }
        let k = pairs.partition_point(|p| p.0 <= w).clamp(1, pairs.len() - 1) - 1;
        let ((w0, v0), (w1, v1)) = (pairs[k], pairs[k + 1]);
        let v = v0 + (v1 - v0) * (w - w0) / (w1 - w0);
        let cie = cie_at(w);
        let weight = if role == SpectrumRole::Emission { 1.0 } else { cie[3] };
        for c in 0..3 {
            xyz[c] += cie[c] * v * weight;
        }
    }
    let rgb = xyz_to_srgb(xyz.map(|c| c * CIE_Y_NORMALIZATION * (hi - lo) / STEPS as f64));
    let top = if role == SpectrumRole::Reflectance { 1.0 } else { f64::INFINITY };
    Vec3::from_array(rgb.map(|c| c.clamp(0.0, top) as f32))
}

/// Planck's law: the spectral radiance of a black body at `kelvin`, in W/(m²·sr·nm).
pub fn planck(lambda_nm: f64, kelvin: f64) -> f64 {
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;
    const K: f64 = 1.380_649e-23;
    let l = lambda_nm * 1e-9;
    2.0 * H * C * C / l.powi(5) / ((H * C / (l * K * kelvin)).exp() - 1.0) * 1e-9
}

/// A `blackbody` spectrum at `kelvin` between two wavelengths, converted as `role` says.
pub fn blackbody_rgb(kelvin: f64, range: (f64, f64), role: SpectrumRole) -> Vec3 {
    let n = ((range.1 - range.0).ceil() as usize).max(1);
    let pairs: Vec<(f64, f64)> = (0..=n)
        .map(|i| range.0 + (range.1 - range.0) * i as f64 / n as f64)
        .map(|w| (w, planck(w, kelvin)))
        .collect();
    spectrum_to_rgb(&pairs, role)
}

/// What a `<spectrum value="…">` says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpectrumValue {
    /// One number: the same at every wavelength.
    Constant(f32),
    /// Three numbers, which the 0.6 dialect read as RGB.
    Rgb(Vec3),
    /// A spectrum converted to RGB by Mitsuba's rule ([`SpectrumRole`]).
    Converted(Vec3),
}

/// A `<spectrum value="…">` as Mitsuba's RGB variants read it in `role`.
pub fn spectrum(s: &str, role: SpectrumRole) -> Result<SpectrumValue, String> {
    let t = tokens(s);
    if t.iter().any(|x| x.contains(':')) {
        let mut pairs = Vec::with_capacity(t.len());
        for x in &t {
            let (w, v) = x
                .split_once(':')
                .ok_or_else(|| format!("expected wavelength:value pairs, found \"{x}\""))?;
            pairs.push((number(w)?, number(v)?));
        }
        if pairs.len() < 2 || pairs.windows(2).any(|p| p[1].0 <= p[0].0) {
            return Err("a sampled spectrum needs at least two wavelengths in increasing order".into());
        }
        return Ok(SpectrumValue::Converted(spectrum_to_rgb(&pairs, role)));
    }
    match t.len() {
        1 if role == SpectrumRole::Emission => Ok(SpectrumValue::Converted(number(t[0])? as f32 * equal_energy_rgb())),
        1 => Ok(SpectrumValue::Constant(number(t[0])? as f32)),
        3 => Ok(SpectrumValue::Rgb(vec3(&numbers(s, 3, false)?))),
        n => Err(format!("expected one value or wavelength:value pairs, found {n} values")),
    }
}

// ---------------------------------------------------------------------------
// Named materials
// ---------------------------------------------------------------------------

/// Mitsuba's named indices of refraction (its documentation's table, at 589 nm).
pub const NAMED_IORS: [(&str, f32); 28] = [
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
    ("polycarbonate", 1.58),
    ("sapphire", 1.77),
    ("cubic zirconia", 2.16),
    ("moissanite", 2.65),
    ("silicon", 3.48),
];

/// An index of refraction given as a number or a name from [`NAMED_IORS`].
pub fn ior(s: &str) -> Result<f32, String> {
    if let Ok(v) = number(s) {
        return Ok(v as f32);
    }
    let key = s.trim().to_ascii_lowercase();
    NAMED_IORS.iter().find(|(n, _)| *n == key).map(|(_, v)| *v).ok_or_else(|| {
        let names: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
        format!("unknown index of refraction \"{s}\" (a number, or one of: {})", names.join(", "))
    })
}

/// Mitsuba's named conductors (`material="Au"` on `conductor` and `roughconductor`) as
/// RGB η and k: its `data/ior/<name>.{eta,k}.spd` spectra converted by
/// [`spectrum_to_rgb`] (generated by `scripts/make_conductor_table.py`; within 2 % of
/// Mitsuba 3's own `scalar_rgb` values for the metals, whose CIE curves are tabulated
/// rather than fitted). `none` (η 0, k 1: a perfect mirror) is not in the table.
pub const NAMED_CONDUCTORS: [(&str, [f32; 3], [f32; 3]); 71] = [
    ("Ag", [0.15454, 0.11695, 0.13824], [4.7996, 3.133, 2.1443]),
    ("Al", [1.6434, 0.88571, 0.52031], [9.1747, 6.2874, 4.8314]),
    ("AlAs", [3.5923, 3.2357, 2.2169], [0.00058006, 0.0, 0.0073732]),
    ("AlAs_palik", [3.5923, 3.2357, 2.2169], [0.00058006, 0.0, 0.0073732]),
    ("AlSb", [0.0001, 4.1257, 4.6684], [0.0, 0.09207, 1.2993]),
    ("AlSb_palik", [0.0001, 4.1257, 4.6684], [0.0, 0.09207, 1.2993]),
    ("Au", [0.14561, 0.37286, 1.4414], [3.9565, 2.3955, 1.6007]),
    ("Be", [4.1682, 3.1907, 2.7813], [3.8201, 3.015, 2.8662]),
    ("Be_palik", [4.1682, 3.1907, 2.7813], [3.8201, 3.015, 2.8662]),
    ("Cr", [4.3458, 2.9259, 1.6526], [5.1865, 4.2377, 3.7516]),
    ("CsI", [2.1369, 1.7048, 1.6608], [0.0, 0.0, 0.0]),
    ("CsI_palik", [2.1369, 1.7048, 1.6608], [0.0, 0.0, 0.0]),
    ("Cu", [0.20365, 0.92203, 1.1017], [3.8845, 2.4632, 2.1396]),
    ("Cu2O", [3.5404, 2.9532, 2.7495], [0.11491, 0.19324, 0.60542]),
    ("Cu2O_palik", [3.5404, 2.9532, 2.7495], [0.11491, 0.19324, 0.60542]),
    ("CuO", [3.2324, 2.4529, 2.208], [0.52148, 0.56955, 0.72159]),
    ("CuO_palik", [3.2324, 2.4529, 2.208], [0.52148, 0.56955, 0.72159]),
    ("Cu_palik", [0.2159, 0.91799, 1.1019], [3.8931, 2.4676, 2.134]),
    ("Hg", [2.3829, 1.4462, 0.90826], [6.2949, 4.3837, 3.418]),
    ("HgTe", [4.7587, 3.2384, 2.6572], [1.6332, 1.5794, 1.7282]),
    ("HgTe_palik", [4.7587, 3.2384, 2.6572], [1.6332, 1.5794, 1.7282]),
    ("Hg_palik", [2.3829, 1.4462, 0.90826], [6.2949, 4.3837, 3.418]),
    ("Ir", [3.0713, 2.0877, 1.616], [5.5659, 4.0765, 3.2638]),
    ("Ir_palik", [3.0713, 2.0877, 1.616], [5.5659, 4.0765, 3.2638]),
    ("K", [0.063822, 0.046489, 0.038144], [2.0916, 1.3536, 0.9121]),
    ("K_palik", [0.063822, 0.046489, 0.038144], [2.0916, 1.3536, 0.9121]),
    ("Li", [0.26447, 0.19605, 0.22067], [3.52, 2.3187, 1.6666]),
    ("Li_palik", [0.26447, 0.19605, 0.22067], [3.52, 2.3187, 1.6666]),
    ("MgO", [2.0817, 1.6532, 1.5933], [0.0, 3.5105e-12, 1.9867e-11]),
    ("MgO_palik", [2.0817, 1.6532, 1.5933], [0.0, 3.5105e-12, 1.9867e-11]),
    ("Mo", [4.4643, 3.5322, 2.7732], [4.0942, 3.4264, 3.1478]),
    ("Mo_palik", [4.4643, 3.5322, 2.7732], [4.0942, 3.4264, 3.1478]),
    ("Na_palik", [0.060115, 0.05617, 0.061938], [3.1612, 2.1191, 1.5772]),
    ("Nb", [3.4099, 2.7934, 2.3934], [3.4273, 2.742, 2.5775]),
    ("Nb_palik", [3.4099, 2.7934, 2.3934], [3.4273, 2.742, 2.5775]),
    ("Ni_palik", [2.3547, 1.6678, 1.4654], [4.4748, 3.0589, 2.3427]),
    ("Rh", [2.5729, 1.8646, 1.5528], [6.7472, 4.7154, 3.9716]),
    ("Rh_palik", [2.5729, 1.8646, 1.5528], [6.7472, 4.7154, 3.9716]),
    ("Se", [4.0614, 2.8427, 2.818], [0.75767, 0.63716, 0.52108]),
    ("Se-e", [5.7304, 4.1636, 4.0781], [0.87897, 1.1017, 1.5635]),
    ("Se-e_palik", [5.7304, 4.1636, 4.0781], [0.87897, 1.1017, 1.5635]),
    ("Se_palik", [4.0614, 2.8427, 2.818], [0.75767, 0.63716, 0.52108]),
    ("SiC", [3.1605, 2.5296, 2.4769], [0.0, 0.0, 9.9438e-06]),
    ("SiC_palik", [3.1605, 2.5296, 2.4769], [0.0, 0.0, 9.9438e-06]),
    ("SnTe", [4.4974, 1.9922, 1.2792], [0.0, 0.0, 0.0]),
    ("SnTe_palik", [4.4974, 1.9922, 1.2792], [0.0, 0.0, 0.0]),
    ("Ta", [2.0637, 2.3913, 2.6262], [2.3909, 1.7472, 1.9449]),
    ("Ta_palik", [2.0637, 2.3913, 2.6262], [2.3909, 1.7472, 1.9449]),
    ("Te", [7.3538, 4.4965, 2.6336], [3.2601, 3.5246, 3.2899]),
    ("Te-e", [7.461, 4.3162, 2.366], [5.5767, 4.9493, 3.9942]),
    ("Te-e_palik", [7.461, 4.3162, 2.366], [5.5767, 4.9493, 3.9942]),
    ("Te_palik", [7.3538, 4.4965, 2.6336], [3.2601, 3.5246, 3.2899]),
    ("ThF4", [1.8237, 1.4444, 1.3863], [0.0, 0.0, 0.0]),
    ("ThF4_palik", [1.8237, 1.4444, 1.3863], [0.0, 0.0, 0.0]),
    ("TiC", [3.6841, 2.8429, 2.5797], [3.2508, 2.3566, 2.1704]),
    ("TiC_palik", [3.6841, 2.8429, 2.5797], [3.2508, 2.3566, 2.1704]),
    ("TiN", [1.6402, 1.1531, 1.3782], [3.3469, 1.9518, 1.1003]),
    ("TiN_palik", [1.6402, 1.1531, 1.3782], [3.3469, 1.9518, 1.1003]),
    ("TiO2", [3.4443, 2.8054, 2.9023], [8.0362e-05, 0.0, 0.00063657]),
    ("TiO2-e", [3.0956, 2.5164, 2.5798], [1.1199e-05, 0.0, 0.00017652]),
    ("TiO2-e_palik", [3.0956, 2.5164, 2.5798], [1.1199e-05, 0.0, 0.00017652]),
    ("TiO2_palik", [3.4443, 2.8054, 2.9023], [8.0362e-05, 0.0, 0.00063657]),
    ("VC", [3.6416, 2.7581, 2.5301], [3.0541, 2.2036, 1.9611]),
    ("VC_palik", [3.6416, 2.7581, 2.5301], [3.0541, 2.2036, 1.9611]),
    ("VN", [2.8524, 2.1236, 1.938], [3.0171, 2.0616, 1.6144]),
    ("VN_palik", [2.8524, 2.1236, 1.938], [3.0171, 2.0616, 1.6144]),
    ("V_palik", [4.2624, 3.5181, 2.7587], [3.4774, 2.8934, 3.1088]),
    ("W", [4.3505, 3.3072, 2.9951], [3.486, 2.61, 2.2709]),
    ("a-C", [2.9324, 2.2311, 1.9662], [0.88503, 0.79991, 0.81457]),
    ("d-C", [2.7331, 2.3088, 2.2277], [0.0, 0.0, 0.0]),
    ("d-C_palik", [2.7331, 2.3088, 2.2277], [0.0, 0.0, 0.0]),
];

/// η and k of a named conductor from [`NAMED_CONDUCTORS`], or of `none`.
pub fn conductor(name: &str) -> Result<(Vec3, Vec3), String> {
    if name == "none" {
        return Ok((Vec3::ZERO, Vec3::ONE));
    }
    NAMED_CONDUCTORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, eta, k)| (Vec3::from_array(*eta), Vec3::from_array(*k)))
        .ok_or_else(|| {
            let names: Vec<&str> = NAMED_CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
            format!("unknown conductor \"{name}\" (known: none, {})", names.join(", "))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_upgrade_follows_mitsubas_rule() {
        for (a, b) in [
            ("toWorld", "to_world"),
            ("fovAxis", "fov_axis"),
            ("intIOR", "int_ior"),
            ("extEta", "ext_eta"),
            ("sampleCount", "sample_count"),
            ("specularReflectance", "specular_reflectance"),
            ("max_depth", "max_depth"),
            ("Ab", "Ab"),
        ] {
            assert_eq!(camel_to_snake(a), b);
        }
    }

    #[test]
    fn transforms() {
        let m = matrix("1 0 0 2  0 1 0 3  0 0 1 4  0 0 0 1").unwrap();
        assert_eq!(m.w_axis.truncate(), Vec3::new(2.0, 3.0, 4.0));
        let r = rotate(Vec3::Z, 90.0).unwrap();
        assert!((r.transform_vector3(Vec3::X) - Vec3::Y).length() < 1e-6);
        let l = look_at(Vec3::new(0.0, 1.0, 6.8), Vec3::new(0.0, 1.0, 0.0), Vec3::Y).unwrap();
        assert!((l.transform_vector3(Vec3::Z) - Vec3::NEG_Z).length() < 1e-6);
        // +x of a camera looking down −z with +y up is "left" in the image: world −x
        assert!((l.transform_vector3(Vec3::X) - Vec3::NEG_X).length() < 1e-6);
        assert!(matrix("1 2 3").is_err());
        assert!(rotate(Vec3::ZERO, 1.0).is_err());
    }

    #[test]
    fn spectra() {
        use SpectrumRole::*;
        assert_eq!(spectrum("0.5", Reflectance).unwrap(), SpectrumValue::Constant(0.5));
        assert!(matches!(spectrum("0.1, 0.2, 0.3", Reflectance).unwrap(), SpectrumValue::Rgb(_)));
        // a flat reflectance stays grey (D65 is sRGB's white); flat light is pink in sRGB
        let SpectrumValue::Converted(grey) = spectrum("360:0.5, 830:0.5", Reflectance).unwrap() else {
            panic!()
        };
        assert!((grey - Vec3::splat(0.5)).abs().max_element() < 0.005, "{grey}");
        let SpectrumValue::Converted(e) = spectrum("2", Emission).unwrap() else {
            panic!()
        };
        assert!((e - 2.0 * equal_energy_rgb()).abs().max_element() < 1e-6 && e.x > 1.15 * e.z, "{e}");
        // a red-only spectrum is red
        let SpectrumValue::Converted(r) = spectrum("600:0, 620:1, 700:1, 720:0", Reflectance).unwrap() else {
            panic!()
        };
        assert!(r.x > 5.0 * r.y && r.z < 0.01, "{r}");
        assert!(spectrum("500:1, 400:1", Reflectance).is_err());
        assert_eq!(SpectrumRole::of("eta", false), Unbounded);
        assert_eq!(SpectrumRole::of("radiance", true), Emission);
        assert_eq!(SpectrumRole::of("reflectance", false), Reflectance);
        assert_eq!(ior("bk7").unwrap(), 1.5046);
        assert_eq!(ior("1.33").unwrap(), 1.33);
        assert!(ior("unobtainium").unwrap_err().contains("bk7"));
    }
}
