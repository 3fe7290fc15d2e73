//! `<integrator>`: the plugins Mitsuba renders with, as rdr's integrators.

use super::table::{differs, not_read, noted, read, PluginDoc, Status};
use super::{Reader, INTEGRATORS};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::Plugin;
use crate::desc::MAX_DEPTH;
use crate::error::Result;
use crate::integrator::{Bdpt, Integrator, PathProfile, PathTracer, PhotonMapper, Ptracer, Roulette, Sppm};

const MAX_DEPTH_DOC: super::table::Param = differs(
    "max_depth",
    "integer",
    "-1",
    "−1 is unbounded, capped at 1024 (with a warning when asked for more)",
);
const RR_DEPTH_DOC: super::table::Param = differs(
    "rr_depth",
    "integer",
    "5",
    "checked (at least 1), not used: rdr's Russian roulette is its own and unbiased",
);
const RR_DOC: super::table::Param = read(
    "rr",
    "string",
    "mitsuba",
    "rdr's own: `ears` for learned Russian roulette and splitting (EARS, Rath et al. 2022), see `path`'s `rr`",
);
const HIDE_EMITTERS_DOC: super::table::Param = read(
    "hide_emitters",
    "boolean",
    "false",
    "true: emitters and the environment seen directly by the camera are black",
);
const HIDE_EMITTERS_REFUSED: super::table::Param = super::table::refused(
    "hide_emitters",
    "boolean",
    "false",
    "true is refused (read by path, volpath and direct)",
);

/// The integrators' rows of the plugin table.
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "integrator",
        names: &["path", "volpath", "volpathmis"],
        status: Status::Differs,
        note: "rdr's unidirectional path tracer (MIS of BSDF and emitter sampling). `volpath` and `volpathmis` \
               render media (delta tracking with spectral MIS, ratio-tracked shadow rays, see [Media](../media.md)); \
               without media they are `path`, whose rays pass through `mask`s as volpath's shadow rays do. Mitsuba's \
               `path` renders media as vacuum, with a warning. No integrator: `path`.",
        params: &[MAX_DEPTH_DOC, RR_DEPTH_DOC, HIDE_EMITTERS_DOC, RR_DOC],
    },
    PluginDoc {
        element: "integrator",
        names: &["direct"],
        status: Status::Differs,
        note: "`path` with `max_depth` 2: light at the first surface by emitter and BSDF sampling, one of each per pass.",
        params: &[
            noted("emitter_samples", "integer", "a value other than 1 is warned about"),
            noted("bsdf_samples", "integer", "a value other than 1 is warned about"),
            noted("shading_samples", "integer", "(Mitsuba 0.6) a value other than 1 is warned about"),
            HIDE_EMITTERS_DOC,
        ],
    },
    PluginDoc {
        element: "integrator",
        names: &["ptracer"],
        status: Status::Read,
        note: "rdr's particle tracer (light paths splatted to the camera).",
        params: &[
            MAX_DEPTH_DOC,
            RR_DEPTH_DOC,
            noted("samples_per_pass", "integer", ""),
            HIDE_EMITTERS_REFUSED,
        ],
    },
    PluginDoc {
        element: "integrator",
        names: &["bdpt"],
        status: Status::Differs,
        note: "(Mitsuba 0.6) rdr's bidirectional path tracer, power heuristic.",
        params: &[
            MAX_DEPTH_DOC,
            RR_DEPTH_DOC,
            noted("light_image", "boolean", "rdr always splats light paths that reach the camera"),
            noted("sample_direct", "boolean", ""),
            noted("strict_normals", "boolean", ""),
            HIDE_EMITTERS_REFUSED,
        ],
    },
    PluginDoc {
        element: "integrator",
        names: &["photonmapper", "photon"],
        status: Status::Differs,
        note: "(Mitsuba 0.6) rdr's `photon`: a global photon map with final gathering.",
        params: &[
            MAX_DEPTH_DOC,
            read("global_photons", "integer", "100000", "photons stored"),
            read("lookup_size", "integer", "64", "photons per density estimate"),
            HIDE_EMITTERS_REFUSED,
        ],
    },
    PluginDoc {
        element: "integrator",
        names: &["sppm"],
        status: Status::Read,
        note: "(Mitsuba 0.6) stochastic progressive photon mapping.",
        params: &[
            MAX_DEPTH_DOC,
            read("photon_count", "integer", "250000", "photons per iteration"),
            read("initial_radius", "float", "0", "0: chosen from the scene's size"),
            read("alpha", "float", "0.7", "in (0, 1]"),
            HIDE_EMITTERS_REFUSED,
        ],
    },
    PluginDoc {
        element: "integrator",
        names: &["aov"],
        status: Status::Differs,
        note: "around one nested integrator, which renders; its layers are written as `--aov` writes them \
               (`--aov` on the command line replaces the list).",
        params: &[differs(
            "aovs",
            "string",
            "",
            "\"name:type, …\": types `albedo`, `depth`, `position`, `sh_normal` and `geo_normal` (both rdr's shading \
             normal) become rdr's layers; other types are warned about and not written",
        )],
    },
    not_read(
        "integrator",
        &["prb", "prb_basic", "prbvolpath", "prb_projective", "direct_projective"],
        Status::Refused,
        "Mitsuba 3's differentiable and spectral-MIS integrators (rdr renders forward only)",
    ),
    not_read("integrator", &["moment", "stokes", "depth"], Status::Refused, "not read"),
];

/// Mitsuba's AOV types as rdr's `--aov` layers (`None`: rdr does not make that layer).
fn rdr_aov(mitsuba_type: &str) -> Option<&'static str> {
    match mitsuba_type {
        "albedo" => Some("albedo"),
        "depth" => Some("depth"),
        "position" => Some("position"),
        "sh_normal" | "geo_normal" => Some("normal"),
        _ => None,
    }
}

/// An integrator, a warning about its depth (where, what) and an `--aov` list.
type Outer<'a> = (Integrator, Option<(&'a Element, String)>, Option<String>);

impl<'a> Reader<'a> {
    /// The scene's integrator: Mitsuba's `aov` (`aovs` = "name:type, …" around the
    /// integrator that renders) gives its nested integrator and an `--aov` list.
    pub(super) fn outer_integrator(&self, el: &'a Element) -> Result<Outer<'a>> {
        if el.attr("type") != Some("aov") {
            let (integrator, note) = self.integrator(el)?;
            return Ok((integrator, note, None));
        }
        let p = Plugin::new(el, self.ids)?;
        let list = p.string("aovs", "")?;
        let mut layers: Vec<&str> = Vec::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let Some((name, ty)) = item.split_once(':') else {
                return Err(p.value_error("aovs", format!("expected \"name:type\" entries, found \"{item}\"")));
            };
            match rdr_aov(ty.trim()) {
                Some(layer) => {
                    if ty.trim() == "geo_normal" {
                        self.ids
                            .warn(el, format!("AOV \"{item}\": rdr writes the shading normal (layer \"normal\")"));
                    }
                    if !layers.contains(&layer) {
                        layers.push(layer);
                    }
                }
                None => self.ids.warn(
                    el,
                    format!(
                        "AOV \"{item}\" ({}) is not written: rdr makes albedo, normal, depth, position",
                        name.trim()
                    ),
                ),
            }
        }
        let inner = p.objects("integrator");
        let [(inner, _)] = inner.as_slice() else {
            return Err(p.error("<integrator type=\"aov\"> needs exactly one nested <integrator> (the one that renders)"));
        };
        p.finish(&["integrator"])?;
        let (integrator, note) = self.integrator(inner)?;
        Ok((integrator, note, (!layers.is_empty()).then(|| layers.join(","))))
    }

    pub(super) fn integrator(&self, el: &'a Element) -> Result<(Integrator, Option<(&'a Element, String)>)> {
        let p = Plugin::new(el, self.ids)?;
        let hide_emitters = p.boolean("hide_emitters", false)?;
        let mut note = None;
        let mut depth = |default: i64| -> Result<u32> {
            let d = p.integer("max_depth", default)?;
            // Mitsuba's default -1 (unbounded) needs no word: roulette ends paths long
            // before the bound; a -1 the scene writes out is told once
            if d == -1 {
                if p.has("max_depth") {
                    note = Some((
                        el,
                        format!("max_depth -1 (unbounded) is rendered with at most {MAX_DEPTH} segments"),
                    ));
                }
                return Ok(MAX_DEPTH);
            }
            if d > MAX_DEPTH as i64 {
                note = Some((
                    el,
                    format!("max_depth {d} is more than the {MAX_DEPTH} supported; using {MAX_DEPTH}"),
                ));
                return Ok(MAX_DEPTH);
            }
            if d < 1 {
                return Err(p.value_error("max_depth", format!("must be −1 (unbounded) or at least 1, found {d}")));
            }
            Ok(d as u32)
        };
        let integrator = match p.ty.as_str() {
            // one estimator: `volpath` and `volpathmis` are `path`, which tracks media (a
            // Mitsuba `path` scene's media are removed when it is read, as Mitsuba ignores them)
            "path" | "volpath" | "volpathmis" => {
                let max_depth = depth(-1)?;
                p.integer_in("rr_depth", 5, 1, i32::MAX as i64)?;
                let rr = p.string("rr", Roulette::Mitsuba.name())?;
                let rr = Roulette::from_name(&rr).ok_or_else(|| {
                    p.value_error(
                        "rr",
                        format!("unknown Russian roulette '{rr}' (available: {})", Roulette::NAMES.join(", ")),
                    )
                })?;
                Integrator::Path(PathTracer {
                    max_depth,
                    profile: PathProfile::Mis,
                    rr_threshold: 0.1,
                    hide_emitters,
                    rr,
                })
            }
            "direct" => {
                for k in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                    if let Some(n) = p.integer_opt(k)? {
                        if n != 1 {
                            self.ids
                                .warn(el, format!("{k} {n} noted: rdr takes one emitter and one BSDF sample per pass"));
                        }
                    }
                }
                Integrator::Path(PathTracer {
                    max_depth: 2,
                    profile: PathProfile::Mis,
                    rr_threshold: 0.1,
                    hide_emitters,
                    rr: Roulette::Mitsuba,
                })
            }
            "ptracer" => {
                let max_depth = depth(-1)?;
                p.integer_in("rr_depth", 5, 1, i32::MAX as i64)?;
                p.ignore("samples_per_pass");
                Integrator::Ptracer(Ptracer {
                    max_depth,
                    rr_threshold: 0.1,
                })
            }
            "bdpt" => {
                let max_depth = depth(-1)?;
                p.integer_in("rr_depth", 5, 1, i32::MAX as i64)?;
                for k in ["light_image", "sample_direct", "strict_normals"] {
                    p.ignore(k);
                }
                Integrator::Bdpt(Bdpt::new(max_depth))
            }
            "photonmapper" | "photon" => {
                let max_depth = depth(-1)?;
                Integrator::Photon(PhotonMapper {
                    n_photons: p.integer_in("global_photons", 100_000, 1, i32::MAX as i64)? as u32,
                    n_iterations: 1,
                    n_near_photons: p.integer_in("lookup_size", 64, 1, 1 << 20)? as u32,
                    max_depth,
                    rr_threshold: 0.1,
                })
            }
            "sppm" => {
                let max_depth = depth(-1)?;
                let alpha = p.float("alpha", 0.7)?;
                if !(alpha > 0.0 && alpha <= 1.0) {
                    return Err(p.value_error("alpha", "must lie in (0, 1]"));
                }
                let r = p.float_opt("initial_radius")?.filter(|r| *r > 0.0);
                Integrator::Sppm(Sppm {
                    photons_per_iteration: p.integer_in("photon_count", 250_000, 1, i32::MAX as i64)? as u32,
                    initial_radius: r,
                    alpha,
                    max_depth,
                    rr_threshold: 0.1,
                })
            }
            other => return Err(p.error(format!("unsupported integrator \"{other}\" (supported: {INTEGRATORS})"))),
        };
        if hide_emitters && !matches!(integrator, Integrator::Path(_)) {
            return Err(p.value_error("hide_emitters", format!("is read by path, volpath and direct only, not {}", p.ty)));
        }
        p.finish(&[])?;
        Ok((integrator, note))
    }
}
