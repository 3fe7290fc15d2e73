//! Materials (spec §9): a closed family. The `intersection_test` integrator uses
//! `diffuse` (Lambertian ρ/π) and `refraction` (a perfect refractor); the others are
//! for the path tracers. Besides the RDR171 ones, the BSDFs of Mitsuba 3 scenes
//! (`conductor`, `thindielectric`, `roughdielectric`, `plastic`, `roughplastic`,
//! `twosided`), named and parametrised as Mitsuba's (its parameter names in each
//! variant's documentation), so the XML reader maps onto them one to one.
//!
//! Mitsuba's `diffuse`, `dielectric` and `roughconductor` are rdr's `diffuse`
//! (`reflectance` = `texture_name`; both one-sided), `glass` (`eta` = `int_ior`/`ext_ior`,
//! `R`/`T` = `specular_reflectance`/`specular_transmittance`; the same Fresnel
//! choice and 1/η² radiance scaling) and `roughconductor` (`eta` = `etaT`/`etaI`,
//! `k` = `k`/`etaI`, `alpha_u`/`alpha_v` = `alpha_x`/`alpha_y`, `specular_reflectance`
//! = the texture; the same D, separable Smith G and visible-normal sampling). One
//! difference: rdr's `roughconductor` reflects on both sides (the RDR171 scenes rely
//! on it; Mitsuba scenes wrap it in `twosided`, which then changes nothing), where
//! Mitsuba's bare `roughconductor` is black from behind.

pub mod adjoint;
pub mod bsdf;
pub mod bump;
pub mod conductor;
pub mod dielectric;
pub mod fresnel;
pub mod microfacet;
pub mod phong;
pub mod plastic;
pub mod principled;
pub mod principledthin;
pub mod sample;

pub use adjoint::Normals;
pub use bsdf::{Bsdf, BsdfKind};
pub use microfacet::Distribution;
pub use sample::{BsdfSample, TransportMode};

use crate::math::{Frame, Vec2, Vec3};
use crate::texture::{TexCoord, Texture};
use bump::{Detail, PerturbOptions, ShadingGeometry};
use plastic::CoatingTables;
pub use principled::PrincipledParams;
pub use principledthin::PrincipledThinParams;

/// A material, `materials.<name>` in a scene: `type` (`"diffuse"`) and the keys of
/// each variant below. Textures are `T`: references by name (or inline colours) in the
/// scene description, indices into the scene's textures (the default) once it is built.
///
/// ```json
/// "materials": {
///   "white": {"type": "diffuse", "texture_name": "white"},
///   "metal": {"type": "roughconductor", "texture_name": "white", "etaT": [0.2, 0.9, 1.1],
///             "k": [3.9, 2.4, 2.2], "alpha_x": 0.2, "alpha_y": 0.2, "distribution": "ggx"},
///   "gold": {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]},
///   "frosted": {"type": "roughdielectric", "eta": 1.5, "alpha_x": 0.2, "alpha_y": 0.2, "distribution": "ggx"},
///   "pane": {"type": "thindielectric", "eta": 1.5},
///   "red_plastic": {"type": "roughplastic", "texture_name": "red", "eta": 1.49, "alpha": 0.1},
///   "leaf": {"type": "twosided", "material_name": "red_plastic", "back_material_name": "white"}
/// }
/// ```
#[derive(Clone, Debug)]
pub enum Material<T = u32> {
    /// `diffuse`: Lambertian, albedo from a texture; one-sided unless `twosided`.
    /// `texture_name` (required; legacy scenes may give an inline `color` instead,
    /// accepted with a warning), `twosided` (false).
    Diffuse { texture: T, twosided: bool },
    /// `refraction`: perfect refraction with index `eta` (> 0, 1.5) inside, vacuum
    /// outside; weight 1.
    Refraction { eta: f32 },
    /// `glass`: a smooth dielectric; `R` (reflectance, vec3, (1,1,1)), `T`
    /// (transmittance, vec3, (1,1,1)), `eta` (> 0, 1.5).
    Glass { reflect: Vec3, transmit: Vec3, eta: f32 },
    /// `roughconductor`: `texture_name` (required, a tint; legacy scenes may give an
    /// inline `R` instead, accepted with a warning), `etaI`, `etaT`, `k` (vec3, (1,1,1)
    /// each), `alpha_x`, `alpha_y` (≥ 0, 0.1 each), `distribution` (`"beckmann"` |
    /// `"ggx"`, `"beckmann"`), `twosided` (true: it reflects on both sides, as RDR171
    /// specifies; false is Mitsuba's bare `roughconductor`, black from behind, which
    /// the XML reader gives unless a `twosided` wraps it). Example:
    /// `{"type": "roughconductor", "texture_name": "gold", "alpha_x": 0.2, "alpha_y": 0.2, "twosided": false}`.
    /// `alpha_x` and `alpha_y` may name textures instead (their values at the point;
    /// Mitsuba's textured `alpha_u`, `alpha_v`): see `alpha_textures`.
    RoughConductor {
        texture: T,
        eta_i: Vec3,
        eta_t: Vec3,
        k: Vec3,
        alpha_x: f32,
        alpha_y: f32,
        /// When either roughness is a texture: both, as textures (a constant one as a
        /// constant texture), read as floats at the point in place of `alpha_x`, `alpha_y`.
        alpha_textures: Option<[T; 2]>,
        /// When `etaT` or `k` is a texture (Mitsuba's textured `eta`, `k`): both, as
        /// textures (a constant one as a constant texture), read as colours at the
        /// point in place of `eta_t`, `k`.
        eta_k_textures: Option<[T; 2]>,
        distribution: Distribution,
        twosided: bool,
    },
    /// `conductor` (Mitsuba `conductor`): a smooth mirror with the conductor Fresnel
    /// reflectance of the complex relative index η + ik, one-sided. `texture_name`
    /// (a tint, Mitsuba's `specular_reflectance`; white when absent), `eta` (vec3,
    /// (0,0,0)), `k` (vec3, (1,1,1)): the defaults make a perfect mirror, as
    /// Mitsuba's `material="none"`. Normal-incidence reflectance ((η−1)²+k²)/((η+1)²+k²).
    /// `eta` and `k` may name textures (`eta_k_textures`, as the rough conductor's).
    Conductor {
        texture: T,
        eta: Vec3,
        k: Vec3,
        eta_k_textures: Option<[T; 2]>,
    },
    /// `thindielectric` (Mitsuba `thindielectric`): a thin pane, both faces alike;
    /// reflects 2F/(1+F) (inter-reflections inside the pane summed), lets the rest
    /// through undeflected. `R`, `T` (vec3, (1,1,1): `specular_reflectance`,
    /// `specular_transmittance`), `eta` (1.5; `int_ior`/`ext_ior`).
    ThinDielectric { reflect: Vec3, transmit: Vec3, eta: f32 },
    /// `roughdielectric` (Mitsuba `roughdielectric`; Walter et al. 2007): `R`, `T`
    /// (vec3, (1,1,1)), `eta` (1.5; `int_ior`/`ext_ior`), `alpha_x`, `alpha_y` (≥ 0,
    /// 0.1 each; Mitsuba's `alpha_u`, `alpha_v`, or its `alpha` for both), `distribution`
    /// (`"beckmann"` | `"ggx"`, `"beckmann"`). Index `eta` below the shading normal.
    /// The roughnesses may be textures, as in `roughconductor`.
    RoughDielectric {
        reflect: Vec3,
        transmit: Vec3,
        eta: f32,
        alpha_x: f32,
        alpha_y: f32,
        /// As in `roughconductor`.
        alpha_textures: Option<[T; 2]>,
        distribution: Distribution,
    },
    /// `plastic` (Mitsuba `plastic`): diffuse base under a smooth coating, one-sided.
    /// `texture_name` (`diffuse_reflectance`; constant 0.5 when absent),
    /// `specular_reflectance` (vec3, (1,1,1)), `eta` (1.49, `int_ior`/`ext_ior`; ≠ 1),
    /// `nonlinear` (false).
    Plastic {
        texture: T,
        specular: Vec3,
        eta: f32,
        nonlinear: bool,
        /// Derived, not a key: Mitsuba's `specular_sampling_weight` s̄/(d̄+s̄) from the
        /// means of the two reflectances; set by [`Material::prepare`] when the scene
        /// is built (`None` in a description: then the reflectance at the point is used).
        specular_sampling_weight: Option<f32>,
    },
    /// `roughplastic` (Mitsuba `roughplastic`): diffuse base under a rough coating.
    /// The keys of `plastic`, and `alpha` (≥ 0, 0.1; isotropic as Mitsuba's),
    /// `distribution` (`"beckmann"` | `"ggx"`, `"beckmann"`).
    RoughPlastic {
        texture: T,
        specular: Vec3,
        eta: f32,
        nonlinear: bool,
        alpha: f32,
        distribution: Distribution,
        /// Derived as in `plastic`.
        specular_sampling_weight: Option<f32>,
        /// Derived: the coating's transmittance tables, set by [`Material::prepare`]
        /// (looked up on every use when `None`).
        tables: Option<&'static CoatingTables>,
    },
    /// `phong` (Mitsuba 0.6's `phong`, which Mitsuba 3 dropped): Lambertian plus the
    /// normalised modified Phong lobe about the mirror direction ([`phong`]), one-sided.
    /// `texture_name` (`diffuse_reflectance`; constant 0.5 when absent),
    /// `specular_reflectance` (vec3, (0.2, 0.2, 0.2)), `exponent` (≥ 0, 30).
    ///
    /// ```json
    /// "shiny": {"type": "phong", "texture_name": "red", "specular_reflectance": [0.3, 0.3, 0.3], "exponent": 60}
    /// ```
    Phong {
        texture: T,
        specular: Vec3,
        exponent: f32,
        /// Derived as in `plastic`, from the mean luminances (as Mitsuba 0.6's).
        specular_sampling_weight: Option<f32>,
    },
    /// `twosided` (Mitsuba `twosided`): `material_name` (required) seen from the
    /// front, and from the back the same material or `back_material_name`, with the
    /// frame flipped so the back side is its front. Neither may transmit light nor be
    /// `twosided` itself (Mitsuba's rule).
    TwoSided {
        front: Box<Material<T>>,
        back: Option<Box<Material<T>>>,
    },
    /// `bumpmap` (Mitsuba `bumpmap`): `material_name` (required, the wrapped material),
    /// `texture_name` (required, the height field; its luminance's uv gradient is used,
    /// bilinear on the full-resolution image as Mitsuba's `bitmap`; constant and
    /// checkerboard textures have none), `scale` (1, Mitsuba's `scale`),
    /// `flip_invalid_normals` (true), `use_shadowing_function` (true). The shading frame
    /// it builds, and what it does about black fringes and light leaks: [`bump`].
    ///
    /// ```json
    /// "bumpy": {"type": "bumpmap", "material_name": "red_plastic", "texture_name": "heights", "scale": 0.5}
    /// ```
    BumpMap {
        height: T,
        scale: f32,
        options: PerturbOptions,
        inner: Box<Material<T>>,
    },
    /// `normalmap` (Mitsuba `normalmap`): `material_name` (required), `texture_name`
    /// (required, tangent-space normals encoded `(n + 1)/2`, read without filtering:
    /// give an EXR, or a PNG whose values are not sRGB-encoded colours),
    /// `flip_invalid_normals` (true), `use_shadowing_function` (true); see [`bump`].
    ///
    /// ```json
    /// "tiles": {"type": "normalmap", "material_name": "white", "texture_name": "tile_normals"}
    /// ```
    NormalMap {
        normals: T,
        options: PerturbOptions,
        inner: Box<Material<T>>,
    },
    /// `mask` (Mitsuba `mask`): alpha cut-outs. `material_name` (required), `opacity`
    /// (number in [0, 1], 0.5 as Mitsuba's) or `texture_name` (an opacity texture, its
    /// luminance). A hit is kept with probability `opacity` and otherwise passed through
    /// as if the surface were not there, by every ray — camera, bounce, shadow and light
    /// rays alike ([`crate::scene::Scene::intersect`]): Mitsuba's `volpath` semantics
    /// (its `path` integrator lets shadow rays stop at masked surfaces). Binary masks
    /// (opacity 0 or 1) are deterministic. An emitting object may not be masked.
    ///
    /// ```json
    /// "leaf": {"type": "mask", "material_name": "leaf_green", "texture_name": "leaf_alpha"}
    /// ```
    Mask { opacity: T, inner: Box<Material<T>> },
    /// `principled` (Mitsuba `principled`, Burley's Disney BSDF): the parameters in
    /// [`PrincipledParams`], their keys and defaults in [`principled`]'s reader
    /// (`crate::desc::principled`).
    Principled(Box<PrincipledParams<T>>),
    /// `principledthin` (Mitsuba `principledthin`): the thin-sheet variant, see
    /// [`principledthin`]; always counts as transmitting (Mitsuba's flags).
    PrincipledThin(Box<PrincipledThinParams<T>>),
    /// `blendbsdf` (Mitsuba `blendbsdf`): (1 − weight)·first + weight·second, `weight` a
    /// scalar texture clamped to [0, 1] (see [`bsdf::BlendBsdf`]).
    BlendBsdf {
        weight: T,
        first: Box<Material<T>>,
        second: Box<Material<T>>,
    },
}
impl<T> Material<T> {
    /// Specular materials have a Dirac-delta BSDF.
    pub fn is_delta(&self) -> bool {
        match self {
            Material::Refraction { .. } | Material::Glass { .. } | Material::Conductor { .. } | Material::ThinDielectric { .. } => true,
            Material::TwoSided { front, back } => front.is_delta() && back.as_ref().is_none_or(|b| b.is_delta()),
            Material::BumpMap { inner, .. } | Material::NormalMap { inner, .. } | Material::Mask { inner, .. } => inner.is_delta(),
            Material::BlendBsdf { first, second, .. } => first.is_delta() && second.is_delta(),
            _ => false,
        }
    }

    /// Whether light passes through (what `twosided` may not wrap).
    pub fn transmits(&self) -> bool {
        match self {
            Material::BumpMap { inner, .. } | Material::NormalMap { inner, .. } | Material::Mask { inner, .. } => inner.transmits(),
            Material::Principled(p) => p.transmits(),
            Material::PrincipledThin(_) => true,
            Material::BlendBsdf { first, second, .. } => first.transmits() || second.transmits(),
            _ => matches!(
                self,
                Material::Refraction { .. } | Material::Glass { .. } | Material::ThinDielectric { .. } | Material::RoughDielectric { .. }
            ),
        }
    }

    /// The material with any `mask` around it taken off: masks act when rays are
    /// intersected ([`crate::scene::Scene::intersect`]), what is hit is the inner material.
    pub fn unmasked(&self) -> &Material<T> {
        match self {
            Material::Mask { inner, .. } => inner.unmasked(),
            m => m,
        }
    }

    /// Whether the BSDF this material makes at a point reads more than the point's
    /// normals and direction: a texture that `constant` does not call constant (it
    /// looks at the uv or the mesh attributes), or the uv tangents ([`Material::needs_tangents`]).
    pub fn reads_surface(&self, constant: impl Fn(&T) -> bool) -> bool {
        self.try_map_textures(|t| if constant(t) { Ok(()) } else { Err(()) }).is_err() || self.needs_tangents()
    }

    /// Whether the material needs the surface's uv tangent: bump and normal maps, and
    /// lobes that may be anisotropic (oriented along ∂p/∂u, as Mitsuba's); principled
    /// counts always (its `anisotropic` may be a texture).
    fn needs_tangents(&self) -> bool {
        match self {
            Material::BumpMap { .. } | Material::NormalMap { .. } => true,
            Material::Principled(_) | Material::PrincipledThin(_) => true,
            Material::RoughConductor {
                alpha_x,
                alpha_y,
                alpha_textures,
                ..
            }
            | Material::RoughDielectric {
                alpha_x,
                alpha_y,
                alpha_textures,
                ..
            } => alpha_x != alpha_y || alpha_textures.is_some(),
            Material::TwoSided { front, back } => front.needs_tangents() || back.as_ref().is_some_and(|b| b.needs_tangents()),
            Material::Mask { inner, .. } => inner.needs_tangents(),
            Material::BlendBsdf { first, second, .. } => first.needs_tangents() || second.needs_tangents(),
            _ => false,
        }
    }

    /// The opacity texture of a `mask` (the outermost wrapper only).
    pub fn mask_opacity(&self) -> Option<&T> {
        match self {
            Material::Mask { opacity, .. } => Some(opacity),
            _ => None,
        }
    }

    /// The same material with every texture replaced by `f(texture)` (in declaration
    /// order): how a description's texture references become indices.
    pub fn try_map_textures<U, E>(&self, f: impl FnMut(&T) -> Result<U, E>) -> Result<Material<U>, E> {
        let mut f = f;
        self.map_with(&mut f)
    }

    fn map_with<U, E>(&self, f: &mut impl FnMut(&T) -> Result<U, E>) -> Result<Material<U>, E> {
        Ok(match self {
            Material::Diffuse { texture, twosided } => Material::Diffuse {
                texture: f(texture)?,
                twosided: *twosided,
            },
            Material::Refraction { eta } => Material::Refraction { eta: *eta },
            Material::Glass { reflect, transmit, eta } => Material::Glass {
                reflect: *reflect,
                transmit: *transmit,
                eta: *eta,
            },
            Material::RoughConductor {
                texture,
                eta_i,
                eta_t,
                k,
                alpha_x,
                alpha_y,
                alpha_textures,
                eta_k_textures,
                distribution,
                twosided,
            } => Material::RoughConductor {
                texture: f(texture)?,
                eta_i: *eta_i,
                eta_t: *eta_t,
                k: *k,
                alpha_x: *alpha_x,
                alpha_y: *alpha_y,
                alpha_textures: map_pair(alpha_textures, f)?,
                eta_k_textures: map_pair(eta_k_textures, f)?,
                distribution: *distribution,
                twosided: *twosided,
            },
            Material::Conductor {
                texture,
                eta,
                k,
                eta_k_textures,
            } => Material::Conductor {
                texture: f(texture)?,
                eta: *eta,
                k: *k,
                eta_k_textures: map_pair(eta_k_textures, f)?,
            },
            Material::ThinDielectric { reflect, transmit, eta } => Material::ThinDielectric {
                reflect: *reflect,
                transmit: *transmit,
                eta: *eta,
            },
            Material::RoughDielectric {
                reflect,
                transmit,
                eta,
                alpha_x,
                alpha_y,
                alpha_textures,
                distribution,
            } => Material::RoughDielectric {
                reflect: *reflect,
                transmit: *transmit,
                eta: *eta,
                alpha_x: *alpha_x,
                alpha_y: *alpha_y,
                alpha_textures: map_pair(alpha_textures, f)?,
                distribution: *distribution,
            },
            Material::Plastic {
                texture,
                specular,
                eta,
                nonlinear,
                specular_sampling_weight,
            } => Material::Plastic {
                texture: f(texture)?,
                specular: *specular,
                eta: *eta,
                nonlinear: *nonlinear,
                specular_sampling_weight: *specular_sampling_weight,
            },
            Material::RoughPlastic {
                texture,
                specular,
                eta,
                nonlinear,
                alpha,
                distribution,
                specular_sampling_weight,
                tables,
            } => Material::RoughPlastic {
                texture: f(texture)?,
                specular: *specular,
                eta: *eta,
                nonlinear: *nonlinear,
                alpha: *alpha,
                distribution: *distribution,
                specular_sampling_weight: *specular_sampling_weight,
                tables: *tables,
            },
            Material::Phong {
                texture,
                specular,
                exponent,
                specular_sampling_weight,
            } => Material::Phong {
                texture: f(texture)?,
                specular: *specular,
                exponent: *exponent,
                specular_sampling_weight: *specular_sampling_weight,
            },
            Material::TwoSided { front, back } => Material::TwoSided {
                front: Box::new(front.map_with(f)?),
                back: match back {
                    Some(b) => Some(Box::new(b.map_with(f)?)),
                    None => None,
                },
            },
            Material::BumpMap {
                height,
                scale,
                options,
                inner,
            } => Material::BumpMap {
                height: f(height)?,
                scale: *scale,
                options: *options,
                inner: Box::new(inner.map_with(f)?),
            },
            Material::NormalMap { normals, options, inner } => Material::NormalMap {
                normals: f(normals)?,
                options: *options,
                inner: Box::new(inner.map_with(f)?),
            },
            Material::Mask { opacity, inner } => Material::Mask {
                opacity: f(opacity)?,
                inner: Box::new(inner.map_with(f)?),
            },
            Material::Principled(p) => Material::Principled(Box::new(p.try_map(f)?)),
            Material::PrincipledThin(p) => Material::PrincipledThin(Box::new(p.try_map(f)?)),
            Material::BlendBsdf { weight, first, second } => Material::BlendBsdf {
                weight: f(weight)?,
                first: Box::new(first.map_with(f)?),
                second: Box::new(second.map_with(f)?),
            },
        })
    }

    /// Fills in what is derived from the parameters once, when the scene is built:
    /// the plastics' specular sampling weight from the mean of their diffuse texture
    /// (`mean`) and specular reflectance, and the rough coating's tables.
    pub fn prepare(&mut self, mean: &impl Fn(&T) -> Vec3) {
        match self {
            Material::Plastic {
                texture,
                specular,
                specular_sampling_weight,
                ..
            } => *specular_sampling_weight = Some(sampling_weight(mean(texture), *specular)),
            Material::RoughPlastic {
                texture,
                specular,
                eta,
                alpha,
                distribution,
                specular_sampling_weight,
                tables,
                ..
            } => {
                *specular_sampling_weight = Some(sampling_weight(mean(texture), *specular));
                *tables = Some(CoatingTables::get(*distribution, alpha.max(1e-4), *eta));
            }
            Material::Phong {
                texture,
                specular,
                specular_sampling_weight,
                ..
            } => *specular_sampling_weight = Some(phong_sampling_weight(mean(texture), *specular)),
            Material::TwoSided { front, back } => {
                front.prepare(mean);
                if let Some(b) = back {
                    b.prepare(mean);
                }
            }
            Material::BumpMap { inner, .. } | Material::NormalMap { inner, .. } | Material::Mask { inner, .. } => inner.prepare(mean),
            Material::BlendBsdf { first, second, .. } => {
                first.prepare(mean);
                second.prepare(mean);
            }
            _ => {}
        }
    }
}

/// Mitsuba 0.6's `phong` weight s̄/(d̄ + s̄), s̄ and d̄ the reflectances' luminances.
fn phong_sampling_weight(diffuse: Vec3, specular: Vec3) -> f32 {
    let (d, s) = (crate::texture::luminance(diffuse), crate::texture::luminance(specular));
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.5
    }
}

/// Mitsuba's `specular_sampling_weight` s̄/(d̄ + s̄), s̄ and d̄ the channel means.
fn sampling_weight(diffuse: Vec3, specular: Vec3) -> f32 {
    let (d, s) = (diffuse.element_sum() / 3.0, specular.element_sum() / 3.0);
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.5
    }
}

impl Material {
    /// The BSDF at a point with shading normal `ns`, seen from `wo`; `tint`
    /// evaluates a texture there. One-sided materials keep `ns`; two-sided ones
    /// (`twosided` diffuse, `roughconductor`, dielectrics) face the viewer or handle
    /// both sides themselves.
    /// Without a surface's uv tangents: bump and normal maps see an arbitrary frame
    /// around `ns` and a flat height field (use [`Material::bsdf_at`] for them).
    pub fn bsdf(&self, ns: Vec3, wo: Vec3, tint: impl Fn(u32) -> Vec3) -> Bsdf {
        let (dpdu, dpdv) = crate::math::coordinate_system(ns);
        let g = ShadingGeometry {
            ns,
            ng: ns,
            dpdu,
            dpdv,
            wo,
        };
        self.bsdf_with(&g, &Tint(tint))
    }

    /// The BSDF at the surface point `it`, its textures looked up in `textures`: what
    /// the integrators use (bump and normal maps need the point's uv tangents).
    ///
    /// Inlined, the diffuse case alone: the general case is a call of its own, so that
    /// the common one does not pay for its set-up (whether the compiler folded that
    /// into this function moved with unrelated code, by 2-3 % of a path-traced sample).
    #[inline]
    pub fn bsdf_at(&self, it: &crate::geometry::interaction::Interaction, textures: &[Texture]) -> Bsdf {
        // the common case without the general path's set-up (the same values)
        if let Material::Diffuse { texture, twosided } = *self {
            let n = if twosided && it.ns.dot(it.wo) < 0.0 { -it.ns } else { it.ns };
            return Bsdf {
                frame: Frame::from_normal(n),
                kind: BsdfKind::Diffuse {
                    albedo: textures[texture as usize].eval(it.tex_coord()),
                },
                perturbed: None,
            };
        }
        self.bsdf_at_general(it, textures)
    }

    /// [`Material::bsdf_at`] of any material.
    #[inline(never)]
    fn bsdf_at_general(&self, it: &crate::geometry::interaction::Interaction, textures: &[Texture]) -> Bsdf {
        let g = ShadingGeometry {
            ns: it.ns,
            ng: it.ng,
            dpdu: it.dpdu,
            dpdv: it.dpdv,
            wo: it.wo,
        };
        self.bsdf_with(
            &g,
            &SceneTextures {
                textures,
                tc: it.tex_coord(),
            },
        )
    }

    fn bsdf_with<L: TextureLookup>(&self, g: &ShadingGeometry, lookup: &L) -> Bsdf {
        let (ns, wo) = (g.ns, g.wo);
        let tint = &|t: u32| lookup.eval(t);
        let facing = if ns.dot(wo) < 0.0 { -ns } else { ns };
        let (n, kind) = match *self {
            Material::Diffuse { texture, twosided } => (if twosided { facing } else { ns }, BsdfKind::Diffuse { albedo: tint(texture) }),
            Material::Refraction { eta } => (ns, BsdfKind::PerfectRefraction { eta }),
            Material::Glass { reflect, transmit, eta } => (
                ns,
                BsdfKind::Dielectric {
                    r: reflect,
                    t: transmit,
                    eta,
                },
            ),
            Material::RoughConductor {
                texture,
                eta_i,
                eta_t,
                k,
                alpha_x,
                alpha_y,
                alpha_textures,
                eta_k_textures,
                distribution,
                twosided,
            } => {
                // as the XML reader keeps a constant η from 0 (a textured one here)
                let (eta_t, k) = eta_k_at(eta_t, k, eta_k_textures, tint, 1e-4);
                (
                    if twosided { facing } else { ns },
                    BsdfKind::Conductor {
                        tint: tint(texture),
                        eta: eta_t / eta_i,
                        k: k / eta_i,
                        mf: microfacet_at(distribution, alpha_x, alpha_y, alpha_textures, tint),
                    },
                )
            }
            Material::Conductor {
                texture,
                eta,
                k,
                eta_k_textures,
            } => {
                let (eta, k) = eta_k_at(eta, k, eta_k_textures, tint, 0.0);
                (
                    ns,
                    BsdfKind::SmoothConductor(conductor::SmoothConductor {
                        tint: tint(texture),
                        eta,
                        k,
                    }),
                )
            }
            Material::ThinDielectric { reflect, transmit, eta } => (
                ns,
                BsdfKind::ThinDielectric(dielectric::ThinDielectric {
                    r: reflect,
                    t: transmit,
                    eta,
                }),
            ),
            Material::RoughDielectric {
                reflect,
                transmit,
                eta,
                alpha_x,
                alpha_y,
                alpha_textures,
                distribution,
            } => (
                ns,
                BsdfKind::RoughDielectric(dielectric::RoughDielectric {
                    r: reflect,
                    t: transmit,
                    eta,
                    mf: microfacet_at(distribution, alpha_x, alpha_y, alpha_textures, tint),
                }),
            ),
            Material::Plastic {
                texture,
                specular,
                eta,
                nonlinear,
                specular_sampling_weight,
            } => {
                let diffuse = tint(texture);
                (
                    ns,
                    BsdfKind::Plastic(plastic::Plastic {
                        diffuse,
                        specular,
                        eta,
                        nonlinear,
                        specular_sampling_weight: specular_sampling_weight.unwrap_or_else(|| sampling_weight(diffuse, specular)),
                    }),
                )
            }
            Material::RoughPlastic {
                texture,
                specular,
                eta,
                nonlinear,
                alpha,
                distribution,
                specular_sampling_weight,
                tables,
            } => {
                let diffuse = tint(texture);
                let mf = microfacet::Microfacet::new(distribution, alpha, alpha);
                (
                    ns,
                    BsdfKind::RoughPlastic(plastic::RoughPlastic {
                        diffuse,
                        specular,
                        eta,
                        nonlinear,
                        specular_sampling_weight: specular_sampling_weight.unwrap_or_else(|| sampling_weight(diffuse, specular)),
                        mf,
                        tables: tables.unwrap_or_else(|| CoatingTables::get(distribution, mf.alpha_x, eta)),
                    }),
                )
            }
            Material::Phong {
                texture,
                specular,
                exponent,
                specular_sampling_weight,
            } => {
                let diffuse = tint(texture);
                (
                    ns,
                    BsdfKind::Phong(phong::Phong {
                        diffuse,
                        specular,
                        exponent,
                        specular_sampling_weight: specular_sampling_weight.unwrap_or_else(|| phong_sampling_weight(diffuse, specular)),
                    }),
                )
            }
            Material::TwoSided { ref front, ref back } => {
                // the back side is the (back) material's front: its frame flipped
                let flipped = ShadingGeometry { ns: -ns, ng: -g.ng, ..*g };
                return match (ns.dot(wo) >= 0.0, back) {
                    (true, _) => front.bsdf_with(g, lookup),
                    (false, None) => front.bsdf_with(&flipped, lookup),
                    (false, Some(b)) => b.bsdf_with(&flipped, lookup),
                };
            }
            Material::BumpMap {
                height,
                scale,
                options,
                ref inner,
            } => {
                return perturbed(inner, g, lookup, Detail::Heights(scale * lookup.gradient(height)), options);
            }
            Material::NormalMap {
                normals,
                options,
                ref inner,
            } => {
                return perturbed(inner, g, lookup, Detail::Normal(lookup.eval_unfiltered(normals)), options);
            }
            Material::Mask { ref inner, .. } => return inner.bsdf_with(g, lookup),
            // Mitsuba's frame: the shading normal, whichever side the viewer is on
            Material::Principled(ref p) => (ns, BsdfKind::Principled(p.at(tint))),
            Material::PrincipledThin(ref p) => (ns, BsdfKind::PrincipledThin(p.at(tint))),
            Material::BlendBsdf {
                weight,
                ref first,
                ref second,
            } => {
                let blend = bsdf::BlendBsdf::new(
                    principled::scalar(tint(weight)),
                    first.bsdf_with(g, lookup),
                    second.bsdf_with(g, lookup),
                );
                (ns, BsdfKind::Blend(Box::new(blend)))
            }
        };
        // Mitsuba's tangent (∂p/∂u made orthogonal to the normal) where the lobes need
        // one; isotropic lobes keep the cheaper arbitrary frame (the same BSDF)
        let frame = if kind.is_anisotropic() {
            Frame::with_tangent(n, g.dpdu)
        } else {
            Frame::from_normal(n)
        };
        Bsdf {
            frame,
            kind,
            perturbed: None,
        }
    }
}

/// A conductor's η and k at the point: the textures' values when it has them (η at
/// least `min_eta`, k at least 0), else the constants.
fn eta_k_at(eta: Vec3, k: Vec3, textures: Option<[u32; 2]>, tint: &impl Fn(u32) -> Vec3, min_eta: f32) -> (Vec3, Vec3) {
    match textures {
        Some([e, kt]) => (tint(e).max(Vec3::splat(min_eta)), tint(kt).max(Vec3::ZERO)),
        None => (eta, k),
    }
}

/// A rough lobe's distribution at a point: its constant roughnesses, or its roughness
/// textures' values there (read as floats, as Mitsuba's `eval_1`).
fn microfacet_at(
    kind: Distribution,
    alpha_x: f32,
    alpha_y: f32,
    textures: Option<[u32; 2]>,
    tint: &impl Fn(u32) -> Vec3,
) -> microfacet::Microfacet {
    match textures {
        None => microfacet::Microfacet::new(kind, alpha_x, alpha_y),
        Some([tx, ty]) => microfacet::Microfacet::new(kind, principled::scalar(tint(tx)), principled::scalar(tint(ty))),
    }
}

/// Both textures of a pair mapped by `f` ([`Material::try_map_textures`]).
fn map_pair<T, U, E>(pair: &Option<[T; 2]>, f: &mut impl FnMut(&T) -> Result<U, E>) -> Result<Option<[U; 2]>, E> {
    Ok(match pair {
        None => None,
        Some([a, b]) => Some([f(a)?, f(b)?]),
    })
}

/// `inner`'s BSDF in the frame a bump or normal map's `detail` makes at `g`.
fn perturbed<L: TextureLookup>(inner: &Material, g: &ShadingGeometry, lookup: &L, detail: Detail, options: PerturbOptions) -> Bsdf {
    let (frame, p) = bump::perturb(g, detail, options);
    let mut b = inner.bsdf_with(&ShadingGeometry { ns: frame.n, ..*g }, lookup);
    if b.frame.n == frame.n {
        b.frame = frame; // Mitsuba's tangent, for anisotropic materials
    }
    b.perturbed = Some(p);
    b
}

/// How a material reads its textures at the point it is evaluated.
trait TextureLookup {
    /// The value, filtered by the point's footprint.
    fn eval(&self, t: u32) -> Vec3;
    /// The value on the full-resolution image (bilinear), as Mitsuba's `bitmap`.
    fn eval_unfiltered(&self, t: u32) -> Vec3;
    /// The uv gradient of the luminance (zero where the texture has none).
    fn gradient(&self, t: u32) -> Vec2;
}

struct Tint<F>(F);

impl<F: Fn(u32) -> Vec3> TextureLookup for Tint<F> {
    fn eval(&self, t: u32) -> Vec3 {
        (self.0)(t)
    }
    fn eval_unfiltered(&self, t: u32) -> Vec3 {
        (self.0)(t)
    }
    fn gradient(&self, _: u32) -> Vec2 {
        Vec2::ZERO
    }
}

struct SceneTextures<'a> {
    textures: &'a [Texture],
    tc: TexCoord,
}

impl TextureLookup for SceneTextures<'_> {
    #[inline]
    fn eval(&self, t: u32) -> Vec3 {
        self.textures[t as usize].eval(self.tc)
    }
    fn eval_unfiltered(&self, t: u32) -> Vec3 {
        self.textures[t as usize].eval(TexCoord {
            duvdx: Vec2::ZERO,
            duvdy: Vec2::ZERO,
            ..self.tc
        })
    }
    fn gradient(&self, t: u32) -> Vec2 {
        self.textures[t as usize].luminance_gradient(self.tc.uv)
    }
}
