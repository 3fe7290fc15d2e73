//! `<sensor>`, its `<film>` and `<rfilter>`: the camera and the film.

use super::table::{differs, not_read, noted, read, refused, PluginDoc, Status};
use super::{focal_length_fov, Reader, FILTERS};
use crate::camera::CameraParams;
use crate::desc::xml::document::Element;
use crate::desc::xml::props::Plugin;
use crate::desc::{FilmDesc, MAX_FILTER_RADIUS};
use crate::error::Result;
use crate::film::Filter;
use crate::math::{Mat4, Vec3};

/// The sensors', films', filters' and samplers' rows of the plugin table.
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "sensor",
        names: &["perspective", "thinlens", "orthographic"],
        status: Status::Read,
        note: "One sensor; more are ignored with a warning. `thinlens` is JSON's camera `thinlens`; `orthographic` is \
               JSON's `orthographic` whose `height` is 2·s·height/width for `to_world`'s scale s.",
        params: &[
            read("fov", "float", "", "degrees along `fov_axis`; without it, `focal_length`"),
            read(
                "fov_axis",
                "string",
                "x",
                "`x`, `y`, `diagonal`, `smaller`, `larger`; ignored with `focal_length`",
            ),
            read("focal_length", "string", "50mm", "on the 36 × 24 mm film's diagonal"),
            read(
                "to_world",
                "transform",
                "identity",
                "rigid, or mirroring (a negative scale: the image is mirrored, as Mitsuba's); `thinlens`: no scale; \
                 `orthographic`: a scale equal in x and y sizes the window (2s wide)",
            ),
            read(
                "near_clip",
                "float",
                "0",
                "applied only when given (Mitsuba's 0.01 would change every ray's range)",
            ),
            read(
                "far_clip",
                "float",
                "unbounded (thinlens: 10⁴ as focus_distance's default)",
                "applied only when given",
            ),
            read("aperture_radius", "float", "", "`thinlens`, required; 0 is a pinhole"),
            read("focus_distance", "float", "far_clip (10⁴)", "`thinlens`"),
            refused("principal_point_offset_x", "float", "0", "an off-centre principal point is refused"),
            refused("principal_point_offset_y", "float", "0", "an off-centre principal point is refused"),
        ],
    },
    not_read(
        "sensor",
        &["radiancemeter", "irradiancemeter", "distant", "batch"],
        Status::Refused,
        "not read",
    ),
    PluginDoc {
        element: "film",
        names: &["hdrfilm"],
        status: Status::Read,
        note: "The film; its filter is the nested `<rfilter>` (default: `gaussian`).",
        params: &[
            read("width", "integer", "768", ""),
            read("height", "integer", "576", ""),
            noted("pixel_format", "string", "the output's format follows `-o`"),
            noted("component_format", "string", ""),
            noted("file_format", "string", ""),
            noted("high_quality_edges", "boolean", ""),
            noted("sample_border", "boolean", ""),
            noted("compensate", "boolean", ""),
            noted("banner", "boolean", "(Mitsuba 0.6) warned about: rdr writes no banner"),
            refused(
                "crop_offset_x",
                "integer",
                "",
                "cropped films are refused (`--crop` renders a region)",
            ),
            refused("crop_offset_y", "integer", "", ""),
            refused("crop_width", "integer", "", ""),
            refused("crop_height", "integer", "", ""),
        ],
    },
    not_read("film", &["specfilm"], Status::Refused, "not read"),
    PluginDoc {
        element: "rfilter",
        names: &["box"],
        status: Status::Read,
        note: "",
        params: &[differs(
            "radius",
            "float",
            "0.5",
            "Mitsuba 3's box is fixed at 0.5 and refuses the parameter (Mitsuba 0.6 read it)",
        )],
    },
    PluginDoc {
        element: "rfilter",
        names: &["tent"],
        status: Status::Read,
        note: "",
        params: &[read("radius", "float", "1", "")],
    },
    PluginDoc {
        element: "rfilter",
        names: &["gaussian"],
        status: Status::Read,
        note: "exp(−x²/2σ²), cut off at 4σ as Mitsuba's.",
        params: &[read("stddev", "float", "0.5", "")],
    },
    PluginDoc {
        element: "rfilter",
        names: &["mitchell"],
        status: Status::Read,
        note: "Radius 2.",
        params: &[read("B", "float", "0.3333333", ""), read("C", "float", "0.3333333", "")],
    },
    not_read("rfilter", &["catmullrom", "lanczos"], Status::Refused, "not read"),
    PluginDoc {
        element: "sampler",
        names: &["*"],
        status: Status::Differs,
        note: "Any type (`independent`, `stratified`, `multijitter`, `orthogonal`, `ldsampler`): only its sample \
               count is read; rdr uses its own Owen-scrambled Sobol sampler (other types are warned about).",
        params: &[
            read("sample_count", "integer", "4", "samples per pixel"),
            noted("seed", "integer", "`--seed` sets rdr's"),
            noted("jitter", "boolean", ""),
            noted("scramble", "integer", ""),
            noted("dimension", "integer", ""),
        ],
    },
];

impl<'a> Reader<'a> {
    pub(super) fn sensor(&self, el: &'a Element) -> Result<(CameraParams, FilmDesc, u32)> {
        let p = Plugin::new(el, self.ids)?;
        if !["perspective", "thinlens", "orthographic"].contains(&p.ty.as_str()) {
            return Err(p.error(format!(
                "unsupported sensor \"{}\" (supported: perspective, thinlens, orthographic)",
                p.ty
            )));
        }
        let films = p.objects("film");
        let film = match films.first() {
            Some((f, _)) => self.film(f)?,
            None => FilmDesc {
                width: 768,
                height: 576,
                block_size: 16,
                filter: Filter::gaussian(2.0, 2.0),
                importance_sampling: false,
            },
        };
        let spp = match p.objects("sampler").first() {
            Some((s, _)) => {
                let sp = Plugin::new(s, self.ids)?;
                if sp.ty != "independent" {
                    self.ids.warn(
                        s,
                        format!("sampler \"{}\" noted: rdr uses its own (Owen-scrambled Sobol) sampler", sp.ty),
                    );
                }
                let n = sp.integer_in("sample_count", 4, 1, u32::MAX as i64)? as u32;
                for k in ["seed", "jitter", "scramble", "dimension"] {
                    sp.ignore(k);
                }
                sp.finish(&[])?;
                n
            }
            None => 4,
        };
        if p.ty == "orthographic" {
            for k in ["fov", "fov_axis", "focal_length"] {
                if p.has(k) {
                    self.ids.warn(el, format!("{k} is ignored by an orthographic sensor"));
                    p.ignore(k);
                }
            }
            return self.camera(&p, 45.0, "x", film, spp);
        }
        let axis = p.string("fov_axis", "x")?;
        let fov_deg = match p.float_opt("fov")? {
            Some(f) => f as f64,
            None => {
                let fov = focal_length_fov(&p)?;
                if p.has("fov_axis") {
                    self.ids
                        .warn(el, "fov_axis is ignored with focal_length (the film's diagonal is used)");
                }
                return self.camera(&p, fov, "diagonal", film, spp);
            }
        };
        self.camera(&p, fov_deg, &axis, film, spp)
    }

    pub(super) fn camera(&self, p: &Plugin, fov_deg: f64, axis: &str, film: FilmDesc, spp: u32) -> Result<(CameraParams, FilmDesc, u32)> {
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(p.value_error("fov", format!("must be between 0 and 180 degrees, found {fov_deg}")));
        }
        let (w, h) = (film.width as f64, film.height as f64);
        let t = (fov_deg.to_radians() / 2.0).tan();
        let axis = match axis {
            "smaller" if w <= h => "x",
            "smaller" => "y",
            "larger" if w >= h => "x",
            "larger" => "y",
            a => a,
        };
        let vt = match axis {
            "x" => t * h / w,
            "y" => t,
            "diagonal" => t * h / w.hypot(h),
            other => return Err(p.value_error("fov_axis", format!("unknown axis \"{other}\" (x, y, diagonal, smaller, larger)"))),
        };
        // clipping only where the scene asks for it (Mitsuba's defaults, 0.01 and 10⁴, would
        // hide nothing in the scenes rdr reads but change every ray's range)
        let near_clip = p.float_opt("near_clip")?.unwrap_or(0.0);
        let far_clip = p.float_opt("far_clip")?.unwrap_or(f32::INFINITY);
        crate::camera::check_clip_range(near_clip, far_clip).map_err(|(key, why)| p.value_error(key, why))?;
        for k in ["principal_point_offset_x", "principal_point_offset_y"] {
            if p.float(k, 0.0)? != 0.0 {
                return Err(p.value_error(k, "an off-centre principal point is not supported"));
            }
        }
        let m = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let origin = m.transform_point3(Vec3::ZERO);
        let dir = m.transform_vector3(Vec3::Z);
        let up = m.transform_vector3(Vec3::Y);
        let left = m.transform_vector3(Vec3::X);
        if !(dir.length() > 0.0 && up.cross(dir).length() > 0.0) {
            return Err(p.value_error("to_world", "the camera transform is degenerate"));
        }
        // a negative scale (common in 0.6 scenes exported from 3D tools) mirrors the image
        let mirrored = left.dot(up.cross(dir)) < 0.0;
        let projection = match p.ty.as_str() {
            "thinlens" => {
                // Mitsuba: aperture_radius required (0 becomes a tiny one), focus_distance
                // defaulting to far_clip (10⁴); no scale in to_world
                let aperture_radius = p
                    .float_opt("aperture_radius")?
                    .ok_or_else(|| p.error(format!("{} needs the property \"aperture_radius\"", p.describe())))?;
                if !(0.0..1e15).contains(&aperture_radius) {
                    return Err(p.value_error("aperture_radius", format!("must be at least 0, found {aperture_radius}")));
                }
                let focus_distance = p.float("focus_distance", p.float("far_clip", 1e4)?)?;
                if !(focus_distance > 0.0 && focus_distance < 1e15) {
                    return Err(p.value_error("focus_distance", format!("must be positive, found {focus_distance}")));
                }
                let scaled = |v: Vec3| (v.length() - 1.0).abs() > 1e-4;
                if scaled(dir) || scaled(up) || scaled(left) {
                    return Err(p.value_error("to_world", "a thinlens sensor's transform cannot scale (Mitsuba refuses it too)"));
                }
                if aperture_radius == 0.0 {
                    crate::camera::Projection::Pinhole
                } else {
                    crate::camera::Projection::ThinLens {
                        aperture_radius,
                        focus_distance,
                    }
                }
            }
            "orthographic" => {
                // Mitsuba's window is x ∈ [−1, 1], y ∈ [−1/aspect, 1/aspect] in camera
                // space, scaled by to_world: height 2·s_y·h/w (and width 2·s_x)
                let (sx, sy) = (left.length(), up.length());
                if (sx - sy).abs() > 1e-4 * sx.max(sy) {
                    return Err(p.value_error(
                        "to_world",
                        format!("an orthographic sensor scaled differently in x ({sx}) and y ({sy}) is not supported"),
                    ));
                }
                let height = 2.0 * sy * film.height as f32 / film.width as f32;
                if !(height > 1e-6 && height < 1e15) {
                    return Err(p.value_error("to_world", format!("the orthographic window's height {height} is out of range")));
                }
                crate::camera::Projection::Orthographic { height }
            }
            _ => crate::camera::Projection::Pinhole,
        };
        let camera = CameraParams {
            position: origin,
            look_at: origin + dir.normalize(),
            ref_up: up.normalize(),
            fov: (2.0 * vt.atan()).to_degrees() as f32,
            focal_length: 1.0,
            projection,
            near_clip,
            far_clip,
            mirrored,
        };
        if origin.abs().max_element() > crate::limits::MAX_COORD || !crate::camera::Camera::new(&camera, 1, 1).is_finite() {
            return Err(p.value_error("to_world", "the camera's view basis is not finite"));
        }
        p.finish(&["film", "sampler", "medium"])?;
        Ok((camera, film, spp))
    }

    pub(super) fn film(&self, el: &Element) -> Result<FilmDesc> {
        let p = Plugin::new(el, self.ids)?;
        if p.ty != "hdrfilm" {
            return Err(p.error(format!("unsupported film \"{}\" (supported: hdrfilm)", p.ty)));
        }
        let w = p.integer_in("width", 768, 1, 1 << 20)?;
        let h = p.integer_in("height", 576, 1, 1 << 20)?;
        if w * h > 1 << 28 {
            return Err(p.error(format!("a film of {w}x{h} pixels is too large")));
        }
        for k in [
            "pixel_format",
            "component_format",
            "file_format",
            "high_quality_edges",
            "sample_border",
            "compensate",
        ] {
            p.ignore(k);
        }
        if p.has("banner") {
            p.ignore("banner");
            self.ids.warn(el, "banner noted (Mitsuba 0.6): rdr writes no banner");
        }
        for k in ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"] {
            if p.has(k) {
                return Err(p.value_error(k, "cropped films are not supported"));
            }
        }
        let filter = match p.objects("rfilter").first() {
            None => Filter::gaussian(2.0, 2.0),
            Some((f, _)) => self.filter(f)?,
        };
        p.finish(&["rfilter"])?;
        Ok(FilmDesc {
            width: w as u32,
            height: h as u32,
            block_size: 16,
            filter,
            importance_sampling: false,
        })
    }

    pub(super) fn filter(&self, el: &Element) -> Result<Filter> {
        let p = Plugin::new(el, self.ids)?;
        let radius = |default: f32| -> Result<f32> {
            let r = p.float("radius", default)?;
            if !(r > 0.0 && r <= MAX_FILTER_RADIUS) {
                return Err(p.value_error("radius", format!("must be in (0, {MAX_FILTER_RADIUS}], found {r}")));
            }
            Ok(r)
        };
        let f = match p.ty.as_str() {
            "box" => Filter::Box { radius: radius(0.5)? },
            "tent" => Filter::Tent { radius: radius(1.0)? },
            "gaussian" => {
                let s = p.float("stddev", 0.5)?;
                if !(s >= 0.05 && 4.0 * s <= MAX_FILTER_RADIUS) {
                    return Err(p.value_error("stddev", format!("must be between 0.05 and {}, found {s}", MAX_FILTER_RADIUS / 4.0)));
                }
                // exp(−x²/2σ²), cut off at 4σ as Mitsuba does
                Filter::gaussian(4.0 * s, 1.0 / (2.0 * s * s))
            }
            "mitchell" => Filter::Mitchell {
                radius: 2.0,
                b: p.float("B", 1.0 / 3.0)?,
                c: p.float("C", 1.0 / 3.0)?,
            },
            other => return Err(p.error(format!("unsupported rfilter \"{other}\" (supported: {FILTERS})"))),
        };
        p.finish(&[])?;
        Ok(f)
    }
}
