//! `<shape>`: meshes, generated shapes, spheres, cylinders, sdfgrids, shape groups and instances.

use super::table::{differs, not_read, noted, read, PluginDoc, Status};
use super::{check_point, source, Reader, SHAPES};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::{where_is, Plugin};
use crate::desc::{
    AreaLightDesc, Located, MeshFile, MeshFormat, MeshNormals, MeshOptions, ObjectDesc, SdfGridFile, ShapeGroupDesc, TextureRef,
};
use crate::error::Result;
use crate::geometry::sdfgrid::SdfNormals;
use crate::geometry::sphere::Sphere;
use crate::math::{Mat4, Vec3};
use crate::scene::Shape;
use std::collections::HashMap;
use std::path::PathBuf;

const TO_WORLD: super::table::Param = read("to_world", "transform", "identity", "");
const FLIP_NORMALS: super::table::Param = read("flip_normals", "boolean", "false", "");
const FACE_NORMALS: super::table::Param = read(
    "face_normals",
    "boolean",
    "false",
    "false: the file's normals, or smooth vertex normals when it has none",
);
const FILENAME: super::table::Param = read("filename", "string", "", "required; found as Mitsuba's file resolver finds it");

/// The shapes' rows of the plugin table (and the `area` emitter's, read inside a shape).
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "shape",
        names: &["obj"],
        status: Status::Read,
        note: "Each shape takes one `<bsdf>` and one `area` `<emitter>`; a shape with neither gets Mitsuba's default, \
               a diffuse 0.5. Meshes whose triangles are all degenerate are warned about and skipped.",
        params: &[
            FILENAME,
            read("flip_tex_coords", "boolean", "true", ""),
            FACE_NORMALS,
            FLIP_NORMALS,
            TO_WORLD,
        ],
    },
    PluginDoc {
        element: "shape",
        names: &["ply"],
        status: Status::Read,
        note: "ASCII and binary; per-vertex and per-face attributes for `mesh_attribute`, named by Mitsuba's rules.",
        params: &[
            FILENAME,
            read("flip_tex_coords", "boolean", "false", ""),
            FACE_NORMALS,
            FLIP_NORMALS,
            TO_WORLD,
        ],
    },
    PluginDoc {
        element: "shape",
        names: &["serialized"],
        status: Status::Read,
        note: "Mitsuba's compressed meshes (format versions 3 and 4; a version 3 file without a precision flag is single \
               precision, as Mitsuba 3 reads it).",
        params: &[
            FILENAME,
            read("shape_index", "integer", "0", ""),
            FACE_NORMALS,
            noted("max_smooth_angle", "float", ""),
            FLIP_NORMALS,
            TO_WORLD,
        ],
    },
    PluginDoc {
        element: "shape",
        names: &["rectangle", "cube"],
        status: Status::Read,
        note: "Generated meshes.",
        params: &[FLIP_NORMALS, TO_WORLD],
    },
    PluginDoc {
        element: "shape",
        names: &["disk"],
        status: Status::Differs,
        note: "Tessellated into triangles (with a warning).",
        params: &[FLIP_NORMALS, TO_WORLD],
    },
    PluginDoc {
        element: "shape",
        names: &["sphere"],
        status: Status::Read,
        note: "Analytic; Mitsuba's uv (φ/2π, θ/π) about the object frame's z, held by rdr as (φ/2π, 1 − θ/π) like a \
               mesh's (JSON `uv_frame`).",
        params: &[
            read("center", "point", "0, 0, 0", ""),
            read("radius", "float", "1", ""),
            read("to_world", "transform", "identity", "a rotation, translation and uniform scale"),
            differs("flip_normals", "boolean", "false", "true is refused"),
        ],
    },
    PluginDoc {
        element: "shape",
        names: &["cylinder"],
        status: Status::Read,
        note: "Open, analytic; Mitsuba's uv (φ/2π, height), held by rdr as (φ/2π, 1 − height) like a mesh's.",
        params: &[
            read("p0", "point", "0, 0, 0", ""),
            read("p1", "point", "0, 0, 1", ""),
            read("radius", "float", "1", ""),
            FLIP_NORMALS,
            read(
                "to_world",
                "transform",
                "identity",
                "a rotation, translation and a scale uniform across the axis",
            ),
        ],
    },
    PluginDoc {
        element: "shape",
        names: &["shapegroup"],
        status: Status::Read,
        note: "An `id` and plain shapes inside (no emitters: Mitsuba refuses them too); rendered only through instances \
               (a two-level BVH, one bottom level per group).",
        params: &[],
    },
    PluginDoc {
        element: "shape",
        names: &["instance"],
        status: Status::Read,
        note: "A `<ref>` to a shapegroup.",
        params: &[read("to_world", "transform", "identity", "affine and invertible")],
    },
    PluginDoc {
        element: "shape",
        names: &["sdfgrid"],
        status: Status::Read,
        note: "A signed distance grid over the unit cube, its surface the trilinear interpolant's zero set, met per \
               voxel at the first root as in Mitsuba; no uv (zero), and not an area emitter (refused: Mitsuba's has no \
               area). Mitsuba's `grid` (a tensor) can be given from Python or C++ only, never in XML. Mitsuba 3.9.1 misses \
               the surface of grids whose x and z sample counts differ; rdr reads them as its documentation lays them out.",
        params: &[
            read("filename", "string", "", "required: a one-channel `.vol` grid, x fastest"),
            read(
                "normals",
                "string",
                "smooth",
                "`smooth` (the paper's blend across voxels) or `analytic`",
            ),
            differs(
                "to_world",
                "transform",
                "identity",
                "affine and invertible; rotations are placed exactly (Mitsuba warns about them and suggests an instance)",
            ),
        ],
    },
    not_read(
        "shape",
        &["bsplinecurve", "linearcurve", "ellipsoids", "ellipsoidsmesh", "merge"],
        Status::Refused,
        "not read",
    ),
    PluginDoc {
        element: "emitter",
        names: &["area"],
        status: Status::Read,
        note: "Inside a `<shape>`, or at the top level with an `id` that one shape refers to (Mitsuba 3's rule: \
               one shape per emitter; an unreferenced one is left out with a warning).",
        params: &[
            read(
                "radiance",
                "texture",
                "1",
                "a colour, or a texture looked up at the emitting point's uv",
            ),
            noted(
                "sampling_weight",
                "float",
                "rdr chooses lights by power (a value other than 1 is warned about)",
            ),
        ],
    },
];

impl<'a> Reader<'a> {
    pub(super) fn shape(&mut self, el: &'a Element) -> Result<ObjectDesc> {
        let p = Plugin::new(el, self.ids)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        if to_world.determinant() == 0.0 {
            return Err(p.value_error("to_world", "the transform is singular"));
        }
        // Mitsuba's sdfgrid has no flip_normals (given, it is an unused property)
        let flip_normals = p.ty != "sdfgrid" && p.boolean("flip_normals", false)?;
        let mesh = |format: MeshFormat, path: Located<String>, flip_uv: bool, normals: MeshNormals| {
            Shape::Mesh(MeshFile {
                path,
                transform: to_world,
                translate: Vec3::ZERO,
                options: MeshOptions {
                    format,
                    normals,
                    flip_normals,
                    flip_uv,
                },
            })
        };
        let normals = |p: &Plugin| -> Result<MeshNormals> {
            Ok(if p.boolean("face_normals", false)? {
                MeshNormals::Face
            } else {
                MeshNormals::SmoothWhenMissing
            })
        };
        let none = Located {
            value: String::new(),
            source: source(el),
        };
        let shape = match p.ty.as_str() {
            "obj" => {
                let path = self.file(el, &p, "filename")?;
                // Mitsuba flips OBJ's v by default, which is rdr's orientation already
                let flip = !p.boolean("flip_tex_coords", true)?;
                mesh(MeshFormat::Obj, path, flip, normals(&p)?)
            }
            "ply" => {
                let path = self.file(el, &p, "filename")?;
                // Mitsuba's PLY reader keeps v as it is (v = 0 is an image's top row)
                let flip = !p.boolean("flip_tex_coords", false)?;
                mesh(MeshFormat::Ply, path, flip, normals(&p)?)
            }
            "serialized" => {
                let path = self.file(el, &p, "filename")?;
                let index = p.integer_in("shape_index", 0, 0, u32::MAX as i64)? as u32;
                let n = normals(&p)?;
                p.ignore("max_smooth_angle");
                mesh(MeshFormat::Serialized { shape_index: index }, path, true, n)
            }
            "rectangle" => mesh(MeshFormat::Rectangle, none, false, MeshNormals::AsInFile),
            "cube" => mesh(MeshFormat::Cube, none, false, MeshNormals::AsInFile),
            "disk" => {
                self.ids
                    .warn(el, format!("disk tessellated into {} triangles", crate::desc::DISK_SEGMENTS));
                mesh(MeshFormat::Disk, none, false, MeshNormals::AsInFile)
            }
            "sphere" => {
                let center = to_world.transform_point3(p.point_opt("center")?.unwrap_or(Vec3::ZERO));
                let r = p.float("radius", 1.0)?;
                // the transform's scale must be uniform for the sphere to stay one
                let axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| to_world.transform_vector3(a));
                let s = axes[0].length();
                let orthogonal = axes[0].dot(axes[1]).abs() + axes[1].dot(axes[2]).abs() + axes[0].dot(axes[2]).abs() < 1e-4 * s * s;
                if !orthogonal || axes.iter().any(|a| (a.length() - s).abs() > 1e-4 * s) {
                    return Err(p.value_error("to_world", "a sphere's transform must be a rotation, translation and uniform scale"));
                }
                if flip_normals {
                    return Err(p.value_error("flip_normals", "is not supported on spheres"));
                }
                let radius = r * s;
                if !(radius > 0.0 && radius <= crate::limits::MAX_COORD) {
                    return Err(p.value_error("radius", format!("must be positive, found {radius}")));
                }
                check_point(&p, "center", center)?;
                // Mitsuba's uv lives in the object frame (z the pole), v in its sense
                let frame = glam::Mat3::from_cols(axes[0] / s, axes[1] / s, axes[2] / s);
                let Some(q) = crate::desc::rotation_quat(&frame) else {
                    return Err(p.value_error(
                        "to_world",
                        "a sphere's transform must be a rotation, translation and uniform scale (this one mirrors)",
                    ));
                };
                Shape::Sphere(Sphere {
                    center,
                    radius,
                    uv_frame: Some(q),
                })
            }
            "cylinder" => {
                let p0 = p.point_opt("p0")?.unwrap_or(Vec3::ZERO);
                let p1 = p.point_opt("p1")?.unwrap_or(Vec3::Z);
                check_point(&p, "p0", p0)?;
                check_point(&p, "p1", p1)?;
                let c = crate::desc::cylinder_shape(p0, p1, p.float("radius", 1.0)?, flip_normals, &to_world).map_err(|(k, e)| {
                    let k = if k == "transform" { "to_world" } else { k };
                    p.value_error(k, e)
                })?;
                Shape::Cylinder(c)
            }
            "sdfgrid" => {
                crate::volume::check_affine(&to_world).map_err(|e| p.value_error("to_world", e))?;
                let path = self.file(el, &p, "filename")?;
                let normals = SdfNormals::from_name(&p.string("normals", "smooth")?).map_err(|e| p.value_error("normals", e))?;
                Shape::SdfGrid(SdfGridFile {
                    path,
                    transform: to_world,
                    normals,
                })
            }
            other => return Err(p.error(format!("unsupported shape \"{other}\" (supported: {SHAPES})"))),
        };
        let bsdfs = p.objects("bsdf");
        if let Some((_, second)) = bsdfs.get(1) {
            return Err(second.error("a shape takes one <bsdf>"));
        }
        let null_bsdf = bsdfs.first().is_some_and(|(b, _)| b.attr("type") == Some("null"));
        let mut material = match bsdfs.first() {
            Some((b, _)) if null_bsdf => {
                Plugin::new(b, self.ids)?.finish(&[])?;
                None
            }
            Some((b, at)) => Some(Located {
                value: self.material(b)?,
                source: source(at),
            }),
            None => None,
        };
        let emitters = p.objects("emitter");
        if let Some((_, second)) = emitters.get(1) {
            return Err(second.error("a shape takes one <emitter>"));
        }
        let light = match emitters.first() {
            None => None,
            Some((e, at)) => {
                let ep = Plugin::new(e, self.ids)?;
                if ep.ty != "area" {
                    return Err(at.error(format!("a shape's emitter must be \"area\", found \"{}\"", ep.ty)));
                }
                if let Some(first) = self.area_owner.insert(*e as *const Element, where_is(el)) {
                    return Err(at.error(format!(
                        "this area emitter is already attached to the shape at {first} (Mitsuba attaches an emitter to one shape)"
                    )));
                }
                // a constant, or a texture looked up at the emitting point's uv
                let (radiance, texture) = match self.texture_ref(&ep, "radiance", Vec3::ONE)? {
                    TextureRef::Color(c) => (c, None),
                    TextureRef::Named(t) => (Vec3::ONE, Some(t)),
                };
                if let Some(w) = ep.float_opt("sampling_weight")? {
                    if w != 1.0 {
                        self.ids.warn(
                            e,
                            format!("sampling_weight {w} noted: rdr chooses lights half by power, half uniformly"),
                        );
                    }
                }
                ep.finish(&[])?;
                Some(AreaLightDesc {
                    source: source(e),
                    radiance,
                    texture,
                })
            }
        };
        let (mut interior, mut exterior) = (None, None);
        for (m, at) in p.objects("medium") {
            let slot = match at.attr("name") {
                Some("interior") => &mut interior,
                Some("exterior") => &mut exterior,
                other => {
                    return Err(at.error(format!(
                        "a shape's <medium> must be named \"interior\" or \"exterior\", found {}",
                        other.map_or("no name".to_string(), |n| format!("\"{n}\""))
                    )))
                }
            };
            if slot.is_some() {
                return Err(at.error("a shape takes one interior and one exterior <medium>"));
            }
            *slot = Some(Located {
                value: self.medium(m)?,
                source: source(at),
            });
        }
        // a shape with a medium but no <bsdf> gets the default diffuse, as in Mitsuba 3
        if material.is_none() && light.is_none() && !null_bsdf {
            // Mitsuba gives a shape without a BSDF a diffuse of reflectance 0.5
            material = Some(Located {
                value: self.default_material(),
                source: source(el),
            });
        }
        p.finish(&["bsdf", "emitter", "medium"])?;
        Ok(ObjectDesc {
            source: source(el),
            shape,
            material,
            light,
            interior,
            exterior,
            null_bsdf,
        })
    }

    /// Reads a `<shape type="shapegroup">` once (however often instanced); returns its name.
    pub(super) fn shapegroup(
        &mut self,
        el: &'a Element,
        groups: &mut Vec<ShapeGroupDesc>,
        group_of: &mut HashMap<*const Element, String>,
    ) -> Result<String> {
        if let Some(n) = group_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        let p = Plugin::new(el, self.ids)?;
        let Some(id) = el.attr("id") else {
            return Err(p.error("a shapegroup needs an \"id\" (its instances refer to it)"));
        };
        let mut objects = Vec::new();
        for (m, at) in p.objects("shape") {
            if matches!(m.attr("type"), Some("shapegroup" | "instance")) {
                return Err(at.error("nested instancing is not supported (a shapegroup holds plain shapes, as in Mitsuba)"));
            }
            let o = self.shape(m)?;
            if let Some(l) = &o.light {
                return Err(l.source.error(
                    &PathBuf::new(),
                    "emitters inside a shapegroup are not supported (Mitsuba refuses them too)",
                ));
            }
            objects.push(o);
        }
        p.finish(&["shape"])?;
        let name = id.to_string();
        groups.push(ShapeGroupDesc {
            name: name.clone(),
            source: source(el),
            objects,
        });
        group_of.insert(el as *const Element, name.clone());
        Ok(name)
    }
}
