//! Broken scenes through the real binary: every one must end with exit status 1 and
//! a single `error:` line that names the scene file and the offending JSON key,
//! never a panic. A few near-misses must be accepted (exit 0), some with a warning.
//!
//! Adding a case is one line in `cases()`.

mod common;

use serde_json::{json, Value};
use std::path::Path;
use std::process::Command;

/// A small valid scene: a sphere and a one-triangle mesh (`tri.obj`, beside it).
const BASE: &str = r#"{
  "integrator": {"type": "intersection_test", "spp": 1},
  "film": {"resolution": [8, 8], "filter": {"type": "box"}},
  "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 45},
  "textures": {"white": {"type": "constant", "color": [0.8, 0.8, 0.8]}},
  "materials": {"matte": {"type": "diffuse", "texture_name": "white"}},
  "objects": [
    {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material_name": "matte"},
    {"type": "mesh", "path": "tri.obj", "material_name": "matte"}
  ]
}
"#;

const TRI_OBJ: &str = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n";

type Edit = Box<dyn Fn(&mut Value)>;

/// What the scene file of a case contains.
enum Scene {
    /// `BASE` parsed, edited, written back.
    Json(Edit),
    /// `BASE` with one text replacement (which must match).
    Replace(&'static str, &'static str),
    /// These exact bytes.
    Raw(Vec<u8>),
    /// No scene file at all.
    Missing,
}

enum Expect {
    /// Exit 1, one `error:` line containing these (and the scene file name).
    Error(Vec<&'static str>),
    /// Exit 0; each string must appear in some `warning:` line.
    Ok(Vec<&'static str>),
}

struct Case {
    name: &'static str,
    scene: Scene,
    /// Contents of `<case>.obj`, which `objects[1].path` then points at.
    obj: Option<&'static str>,
    args: Vec<String>,
    /// `-o` value, relative to the temporary folder; default `<case>.exr`.
    output: Option<&'static str>,
    expect: Expect,
}

fn case(name: &'static str, scene: Scene) -> Case {
    Case {
        name,
        scene,
        obj: None,
        args: Vec::new(),
        output: None,
        expect: Expect::Ok(Vec::new()),
    }
}
fn edit(name: &'static str, f: impl Fn(&mut Value) + 'static) -> Case {
    case(name, Scene::Json(Box::new(f)))
}
fn replace(name: &'static str, from: &'static str, to: &'static str) -> Case {
    case(name, Scene::Replace(from, to))
}
fn raw(name: &'static str, bytes: impl Into<Vec<u8>>) -> Case {
    case(name, Scene::Raw(bytes.into()))
}
/// The base scene as it is (for command-line cases).
fn unchanged(name: &'static str) -> Case {
    edit(name, |_| {})
}
fn obj(name: &'static str, text: &'static str) -> Case {
    Case {
        obj: Some(text),
        ..unchanged(name)
    }
}

impl Case {
    fn err(self, expect: &[&'static str]) -> Case {
        Case {
            expect: Expect::Error(expect.to_vec()),
            ..self
        }
    }
    fn ok(self, warnings: &[&'static str]) -> Case {
        Case {
            expect: Expect::Ok(warnings.to_vec()),
            ..self
        }
    }
    /// Adds `arg` to the command line.
    fn with_arg(mut self, arg: &str) -> Case {
        self.args.push(arg.to_string());
        self
    }
    /// Adds `--override <json>` to the command line.
    fn with_override(mut self, json: &str) -> Case {
        self.args.extend(["--override".to_string(), json.to_string()]);
        self
    }
    fn out(self, output: &'static str) -> Case {
        Case {
            output: Some(output),
            ..self
        }
    }
}

/// An `image` texture reading `path` (`tex.png`, a 2×2 PNG, exists beside the scenes).
fn image_texture(path: &str) -> Value {
    json!({"type": "image", "path": path, "tex_coordinate_generator": {"type": "uvmapping2d"}})
}

fn remove(v: &mut Value, key: &str) {
    v.as_object_mut().expect("an object").remove(key);
}

fn cases() -> Vec<Case> {
    vec![
        // --- JSON syntax -------------------------------------------------------------
        replace("missing opening brace", r#""film": {"resolution""#, r#""film": "resolution""#).err(&["invalid JSON", "film"]),
        replace("missing final brace", "]\n}\n", "]\n").err(&["invalid JSON", "EOF", "objects"]),
        replace("trailing comma in object", r#""spp": 1}"#, r#""spp": 1,}"#).err(&["trailing comma", "integrator"]),
        replace("trailing comma in array", "[8, 8]", "[8, 8,]").err(&["trailing comma", "film.resolution"]),
        replace("NaN literal in vector", "[0, 0, 5]", "[0, NaN, 5]").err(&["invalid JSON", "camera.position[1]"]),
        replace("Infinity literal", r#""fov": 45"#, r#""fov": Infinity"#).err(&["invalid JSON", "camera.fov"]),
        raw("empty file", "").err(&["invalid JSON", "EOF"]),
        raw("not UTF-8", b"{\"film\": \"\xff\xfe\"}".to_vec()).err(&["cannot read scene", "UTF-8"]),
        raw("nesting too deep", format!("{{\"film\": {}{}}}", "[".repeat(200), "]".repeat(200))).err(&["recursion limit", "film[0][0]"]),
        raw("root is an array", "[1, 2, 3]").err(&["must be a JSON object", "array"]),
        case("scene file missing", Scene::Missing).err(&["cannot read scene"]),
        // --- numbers and types ---------------------------------------------------------
        replace("number too large for f32", "[0, 0, 5]", "[0, 1e39, 5]").err(&["camera.position[1]", "finite 32-bit"]),
        edit("f32 overflow in a matrix", |s| {
            s["objects"][1]["transform"] = json!([1, 0, 0, 0, 0, 1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
        })
        .err(&["objects[1].transform[5]"]),
        edit("vector too short", |s| s["camera"]["position"] = json!([0, 5])).err(&["camera.position", "array of 3"]),
        edit("vector of strings", |s| s["camera"]["look_at"] = json!(["0", "0", "0"])).err(&["camera.look_at[0]", "string"]),
        edit("spp is a string", |s| s["integrator"]["spp"] = json!("many")).err(&["integrator.spp", "integer"]),
        edit("spp is fractional", |s| s["integrator"]["spp"] = json!(1.5)).err(&["integrator.spp", "integer"]),
        edit("spp is zero", |s| s["integrator"]["spp"] = json!(0)).err(&["integrator.spp", "at least 1"]),
        edit("spp beyond i32", |s| s["integrator"]["spp"] = json!(4294967296u64)).err(&["integrator.spp"]),
        edit("fov is a string", |s| s["camera"]["fov"] = json!("wide")).err(&["camera.fov", "number"]),
        edit("fov of 180", |s| s["camera"]["fov"] = json!(180)).err(&["camera.fov"]),
        edit("fractional resolution", |s| s["film"]["resolution"] = json!([512.5, 512])).err(&["film.resolution[0]", "integer"]),
        edit("resolution zero", |s| s["film"]["resolution"] = json!([0, 8])).err(&["film.resolution", "positive"]),
        edit("resolution negative", |s| s["film"]["resolution"] = json!([8, -8])).err(&["film.resolution", "positive"]),
        edit("resolution too large", |s| s["film"]["resolution"] = json!([100000, 100000])).err(&["film.resolution", "too large"]),
        edit("resolution one number", |s| s["film"]["resolution"] = json!(8)).err(&["film.resolution", "array of 2"]),
        edit("twosided is a string", |s| s["materials"]["matte"]["twosided"] = json!("yes")).err(&["materials.matte.twosided"]),
        // --- bumpmap, normalmap, mask, mesh_attribute (issue 17) -------------------------------
        edit("bumpmap without texture_name", |s| {
            s["materials"]["b"] = json!({"type": "bumpmap", "material_name": "matte"})
        })
        .err(&["materials.b.texture_name", "missing"]),
        edit(
            "bumpmap scale is a string",
            |s| s["materials"]["b"] = json!({"type": "bumpmap", "material_name": "matte", "texture_name": "white", "scale": "big"}),
        )
        .err(&["materials.b.scale", "number"]),
        edit("bumpmap of an unknown material", |s| {
            s["materials"]["b"] = json!({"type": "bumpmap", "material_name": "nothing", "texture_name": "white"})
        })
        .err(&["materials.b.material_name", "no material named 'nothing'"]),
        edit("bumpmap of an unknown texture", |s| {
            s["materials"]["b"] = json!({"type": "bumpmap", "material_name": "matte", "texture_name": "nothing"})
        })
        .err(&["materials.b.texture_name", "no texture named 'nothing'"]),
        edit("normalmap without material_name", |s| {
            s["materials"]["n"] = json!({"type": "normalmap", "texture_name": "white"})
        })
        .err(&["materials.n.material_name", "missing"]),
        edit(
            "normalmap flip is a number",
            |s| {
                s["materials"]["n"] =
                    json!({"type": "normalmap", "material_name": "matte", "texture_name": "white", "flip_invalid_normals": 1})
            },
        )
        .err(&["materials.n.flip_invalid_normals"]),
        edit("bump and normal maps in a cycle", |s| {
            s["materials"]["n"] = json!({"type": "normalmap", "material_name": "m", "texture_name": "white"});
            s["materials"]["m"] = json!({"type": "mask", "material_name": "n"});
        })
        .err(&["material_name"]),
        edit("mask opacity above 1", |s| {
            s["materials"]["m"] = json!({"type": "mask", "material_name": "matte", "opacity": 1.5})
        })
        .err(&["materials.m.opacity"]),
        edit("mask opacity is a string", |s| {
            s["materials"]["m"] = json!({"type": "mask", "material_name": "matte", "opacity": "half"})
        })
        .err(&["materials.m.opacity", "number"]),
        edit(
            "mask with opacity and texture",
            |s| s["materials"]["m"] = json!({"type": "mask", "material_name": "matte", "opacity": 0.5, "texture_name": "white"}),
        )
        .err(&["materials.m.opacity", "not both"]),
        edit("sphere uv_frame not a rotation", |s| {
            s["objects"][0]["uv_frame"] = json!([2, 0, 0, 0, 1, 0, 0, 0, 1])
        })
        .err(&["objects[0].uv_frame", "rotation"]),
        edit("sphere uv_frame mirrored", |s| {
            s["objects"][0]["uv_frame"] = json!([-1, 0, 0, 0, 1, 0, 0, 0, 1])
        })
        .err(&["objects[0].uv_frame", "determinant 1"]),
        edit("sphere uv_frame of 4 numbers", |s| {
            s["objects"][0]["uv_frame"] = json!([0, 0, 0, 1])
        })
        .err(&["objects[0].uv_frame"]),
        edit("roughconductor twosided as a string", |s| {
            s["materials"]["m"] = json!({"type": "roughconductor", "texture_name": "white", "twosided": "no"})
        })
        .err(&["materials.m.twosided", "true or false"]),
        edit("mask inside a twosided", |s| {
            s["materials"]["m"] = json!({"type": "mask", "material_name": "matte"});
            s["materials"]["t"] = json!({"type": "twosided", "material_name": "m"});
        })
        .err(&["materials.t.material_name", "outermost"]),
        edit("mask on an emitter", |s| {
            s["materials"]["m"] = json!({"type": "mask", "material_name": "matte"});
            s["objects"][0]["material_name"] = json!("m");
            s["objects"][0]["light"] = json!({"type": "area", "radiance": [1, 1, 1]});
        })
        .err(&["objects[0].material_name", "emitting object"]),
        edit("mesh_attribute without name", |s| {
            s["textures"]["attr"] = json!({"type": "mesh_attribute"})
        })
        .err(&["textures.attr.name", "missing"]),
        edit("mesh_attribute of a name not vertex_ or face_", |s| {
            s["textures"]["attr"] = json!({"type": "mesh_attribute", "name": "uv"})
        })
        .err(&["textures.attr.name", "\"uv\" must start with \"vertex_\" or \"face_\""]),
        edit("mesh_attribute on a mesh without colours", |s| {
            s["textures"]["attr"] = json!({"type": "mesh_attribute", "name": "vertex_color"});
            s["materials"]["matte"]["texture_name"] = json!("attr");
        })
        .err(&["objects[0].material_name", "vertex_color"]),
        edit("block size zero", |s| s["film"]["block_side_length"] = json!(0)).err(&["film.block_side_length"]),
        edit("filter radius negative", |s| s["film"]["filter"]["radius"] = json!(-1)).err(&["film.filter.radius"]),
        // --- structure ------------------------------------------------------------------
        edit("camera section missing", |s| remove(s, "camera")).err(&["camera", "missing"]),
        edit("camera is a list", |s| s["camera"] = json!([0, 0, 5])).err(&["camera", "expected an object"]),
        edit("texture color missing", |s| remove(&mut s["textures"]["white"], "color")).err(&["textures.white.color", "missing"]),
        edit("texture not an object", |s| s["textures"]["white"] = json!(0.5)).err(&["textures.white", "expected an object"]),
        edit("objects not a list", |s| s["objects"] = json!({})).err(&["objects", "array"]),
        edit("object not an object", |s| s["objects"][1] = json!("tri.obj")).err(&["objects[1]", "expected an object"]),
        edit("object type missing", |s| remove(&mut s["objects"][0], "type")).err(&["objects[0].type", "missing"]),
        edit("no material and no light", |s| remove(&mut s["objects"][0], "material_name")).err(&["objects[0]", "material_name"]),
        // --- unknown names and types -------------------------------------------------------
        edit("unknown integrator", |s| s["integrator"]["type"] = json!("magic")).err(&["integrator.type", "magic"]),
        edit("bdpt strategy with t = 0", |s| {
            s["integrator"] = json!({"type": "bdpt", "strategy": [2, 0]})
        })
        .err(&["integrator.strategy", "t ≥ 1"]),
        edit("bdpt one strategy and all of them", |s| {
            s["integrator"] = json!({"type": "bdpt", "strategy": [1, 2], "visualize_strategies": true})
        })
        .err(&["integrator.visualize_strategies", "strategy"]),
        edit("bdpt negative connection roulette", |s| {
            s["integrator"] = json!({"type": "bdpt", "connection_roulette": -0.5})
        })
        .err(&["integrator.connection_roulette", "between"]),
        edit("guided learn_fraction not a bool", |s| {
            s["integrator"] = json!({"type": "guided", "learn_fraction": 1})
        })
        .err(&["integrator.learn_fraction"]),
        edit("guided unknown learn_from", |s| {
            s["integrator"] = json!({"type": "guided", "learn_from": "importons"})
        })
        .err(&["integrator.learn_from", "importons", "paths, photons"]),
        edit("guided unknown target", |s| {
            s["integrator"] = json!({"type": "guided", "target": "irradiance"})
        })
        .err(&["integrator.target", "irradiance", "radiance, variance"]),
        edit("guided variance target from photons", |s| {
            s["integrator"] = json!({"type": "guided", "target": "variance", "learn_from": "photons"})
        })
        .err(&["integrator.learn_from", "target 'variance'", "paths"]),
        edit("guided rr_threshold above 1", |s| {
            s["integrator"] = json!({"type": "guided", "rr_threshold": 2.0})
        })
        .err(&["integrator.rr_threshold", "[0, 1]"]),
        edit("unknown object type", |s| s["objects"][0]["type"] = json!("cube")).err(&["objects[0].type", "cube"]),
        edit("unknown filter", |s| s["film"]["filter"]["type"] = json!("lanczos")).err(&["film.filter.type", "lanczos"]),
        edit("unknown texture type", |s| s["textures"]["white"]["type"] = json!("noise")).err(&["textures.white.type", "noise"]),
        edit("unknown material type", |s| s["materials"]["matte"]["type"] = json!("velvet")).err(&["materials.matte.type", "velvet"]),
        edit("unknown material name", |s| s["objects"][1]["material_name"] = json!("nope")).err(&["objects[1].material_name", "nope"]),
        edit("unknown texture name", |s| s["materials"]["matte"]["texture_name"] = json!("nope"))
            .err(&["materials.matte.texture_name", "nope"]),
        // principled and blendbsdf
        edit("principled roughness a bool", |s| {
            s["materials"]["matte"] = json!({"type": "principled", "roughness": true})
        })
        .err(&["materials.matte.roughness", "a number or a texture name"]),
        edit("principled unknown texture", |s| {
            s["materials"]["matte"] = json!({"type": "principled", "roughness": "nope"})
        })
        .err(&["materials.matte.roughness", "no texture named 'nope'"]),
        edit("principled eta and specular", |s| {
            s["materials"]["matte"] = json!({"type": "principled", "eta": 1.5, "specular": 0.5})
        })
        .err(&["materials.matte.specular", "either eta or specular"]),
        edit("principled negative sheen", |s| {
            s["materials"]["matte"] = json!({"type": "principled", "sheen": -1})
        })
        .err(&["materials.matte.sheen", "negative"]),
        edit("principled eta a string", |s| {
            s["materials"]["matte"] = json!({"type": "principled", "eta": "glass"})
        })
        .err(&["materials.matte.eta", "number"]),
        edit("principledthin eta negative", |s| {
            s["materials"]["matte"] = json!({"type": "principledthin", "eta": -1})
        })
        .err(&["materials.matte.eta", "negative"]),
        edit("principledthin diff_trans a list", |s| {
            s["materials"]["matte"] = json!({"type": "principledthin", "diff_trans": [1]})
        })
        .err(&["materials.matte.diff_trans", "a number or a texture name"]),
        edit("blendbsdf without weight", |s| {
            s["materials"]["b"] = json!({"type": "blendbsdf", "material_names": ["matte", "matte"]})
        })
        .err(&["materials.b.weight", "missing"]),
        edit("blendbsdf weight a list", |s| {
            s["materials"]["b"] = json!({"type": "blendbsdf", "weight": [0.5], "material_names": ["matte", "matte"]})
        })
        .err(&["materials.b.weight", "a number or a texture name"]),
        edit("blendbsdf one material", |s| {
            s["materials"]["b"] = json!({"type": "blendbsdf", "weight": 0.5, "material_names": ["matte"]})
        })
        .err(&["materials.b.material_names", "two material names"]),
        edit("blendbsdf unknown material", |s| {
            s["materials"]["b"] = json!({"type": "blendbsdf", "weight": 0.5, "material_names": ["matte", "nope"]})
        })
        .err(&["materials.b.material_names", "no material named 'nope'"]),
        edit("blendbsdf cycle", |s| {
            s["materials"]["b"] = json!({"type": "blendbsdf", "weight": 0.5, "material_names": ["matte", "c"]});
            s["materials"]["c"] = json!({"type": "blendbsdf", "weight": 0.5, "material_names": ["b", "matte"]})
        })
        .err(&["material_names", "a cycle"]),
        edit("unknown environment texture", |s| {
            s["environment_map"] = json!({"texture_name": "sky"})
        })
        .err(&["environment_map.texture_name", "sky"]),
        edit("unknown light type", |s| {
            s["integrator"]["lights"] = json!([{"type": "laser", "position": [0, 1, 0], "flux": [1, 1, 1]}])
        })
        .err(&["integrator.lights[0].type", "laser", "spot, directional"]),
        edit("spot without a direction", |s| {
            s["integrator"]["lights"] = json!([{"type": "spot", "position": [0, 1, 0]}])
        })
        .err(&["integrator.lights[0].look_at", "required"]),
        edit(
            "spot beam wider than its cutoff",
            |s| {
                s["integrator"]["lights"] =
                    json!([{"type": "spot", "position": [0, 1, 0], "direction": [0, -1, 0], "cutoff_angle": 10, "beam_width": 20}])
            },
        )
        .err(&["integrator.lights[0].beam_width", "cutoff_angle"]),
        edit("directional of zero direction", |s| {
            s["integrator"]["lights"] = json!([{"type": "directional", "direction": [0, 0, 0]}])
        })
        .err(&["integrator.lights[0].direction", "zero"]),
        edit("image texture file missing", |s| s["textures"]["white"] = image_texture("a.png")).err(&["textures.white.path", "a.png"]),
        edit("image texture not an image", |s| s["textures"]["white"] = image_texture("tri.obj")).err(&["textures.white.path", "tri.obj"]),
        edit("image texture is a folder", |s| s["textures"]["white"] = image_texture(".")).err(&["textures.white.path"]),
        edit("image texture unknown filter", |s| {
            s["textures"]["white"] = image_texture("tex.png");
            s["textures"]["white"]["filter"] = json!("bicubic");
        })
        .err(&[
            "textures.white.filter",
            "unknown image filter 'bicubic'",
            "trilinear, bilinear, nearest",
        ]),
        edit("image texture raw not a bool", |s| {
            s["textures"]["white"] = image_texture("tex.png");
            s["textures"]["white"]["raw"] = json!("yes");
        })
        .err(&["textures.white.raw"]),
        // --- geometry and camera values ----------------------------------------------------
        edit("look_at equals position", |s| s["camera"]["look_at"] = json!([0, 0, 5])).err(&["camera.look_at", "position"]),
        edit("ref_up along the view", |s| s["camera"]["ref_up"] = json!([0, 0, 1])).err(&["camera.ref_up"]),
        edit("singular transform", |s| s["objects"][1]["transform"] = json!(vec![0; 16])).err(&["objects[1].transform", "singular"]),
        edit("transform of 15 numbers", |s| s["objects"][1]["transform"] = json!(vec![1; 15])).err(&["objects[1].transform", "16"]),
        edit("negative sphere radius", |s| s["objects"][0]["radius"] = json!(-1)).err(&["objects[0].radius", "positive"]),
        // --- cylinders, shape groups and instances ------------------------------------------
        edit("negative cylinder radius", |s| {
            s["objects"][0] = json!({"type": "cylinder", "radius": -1, "material_name": "matte"})
        })
        .err(&["objects[0].radius", "positive"]),
        edit("cylinder radius as a string", |s| {
            s["objects"][0] = json!({"type": "cylinder", "radius": "1", "material_name": "matte"})
        })
        .err(&["objects[0].radius", "expected a number"]),
        edit("cylinder p0 = p1", |s| {
            s["objects"][0] = json!({"type": "cylinder", "p1": [0, 0, 0], "material_name": "matte"})
        })
        .err(&["objects[0].p1", "differ from p0"]),
        edit(
            "cylinder skewed",
            |s| {
                s["objects"][0] =
                    json!({"type": "cylinder", "transform": [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], "material_name": "matte"})
            },
        )
        .err(&["objects[0].transform", "uniform across its axis"]),
        edit("instance of an unknown shapegroup", |s| {
            s["objects"][0] = json!({"type": "instance", "shapegroup": "nope"})
        })
        .err(&["objects[0].shapegroup", "no shapegroup named 'nope'"]),
        edit("instance without a shapegroup", |s| s["objects"][0] = json!({"type": "instance"})).err(&["objects[0].shapegroup", "missing"]),
        edit("instance shapegroup as a number", |s| {
            s["objects"][0] = json!({"type": "instance", "shapegroup": 3})
        })
        .err(&["objects[0].shapegroup", "expected a string"]),
        edit("instance singular", |s| {
            s["shapegroups"] = json!({"g": {"objects": [{"type": "sphere", "material_name": "matte"}]}});
            s["objects"][0] = json!({"type": "instance", "shapegroup": "g", "transform": vec![0; 16]});
        })
        .err(&["objects[0].transform"]),
        edit("instance with a material", |s| {
            s["shapegroups"] = json!({"g": {"objects": [{"type": "sphere", "material_name": "matte"}]}});
            s["objects"][0] = json!({"type": "instance", "shapegroup": "g", "material_name": "matte"});
        })
        .err(&["objects[0].material_name", "shapegroup"]),
        edit("emitter in a shapegroup", |s| {
            s["shapegroups"] = json!({"g": {"objects": [{"type": "sphere", "light": {"radiance": [1, 1, 1]}}]}});
        })
        .err(&["shapegroups.g.objects[0].light", "emitters inside a shapegroup"]),
        edit("instance in a shapegroup", |s| {
            s["shapegroups"] = json!({"g": {"objects": [{"type": "instance", "shapegroup": "g"}]}});
        })
        .err(&["shapegroups.g.objects[0].type", "nested instancing"]),
        {
            let mut c = edit("cylinder under --compat rdr171", |s| {
                s["objects"][0] = json!({"type": "cylinder", "material_name": "matte"})
            })
            .err(&["objects[0].type", "--compat rdr171", "cylinders"]);
            c.args.extend(["--compat".to_string(), "rdr171".to_string()]);
            c
        },
        edit("shapegroup objects not a list", |s| s["shapegroups"] = json!({"g": {"objects": 3}})).err(&["shapegroups.g.objects"]),
        edit("negative legacy flux", |s| s["integrator"]["point_light_flux"] = json!([1, -1, 1])).err(&["integrator.point_light_flux"]),
        edit("negative list flux", |s| {
            s["integrator"]["lights"] = json!([{"type": "point", "position": [0, 1, 0], "flux": [1, -1, 1]}])
        })
        .err(&["integrator.lights[0].flux"]),
        edit("negative area radiance", |s| {
            s["objects"][0]["light"] = json!({"radiance": [-1, 0, 0]})
        })
        .err(&["objects[0].light.radiance"]),
        // --- meshes ------------------------------------------------------------------------
        edit("mesh file missing", |s| s["objects"][1]["path"] = json!("missing.obj")).err(&["objects[1].path", "missing.obj"]),
        edit("mesh path is a folder", |s| s["objects"][1]["path"] = json!(".")).err(&["objects[1].path", "cannot read mesh"]),
        obj("OBJ face index out of range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").err(&["objects[1].path", "line 4", "out of range"]),
        obj("OBJ face index zero", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").err(&["objects[1].path", "line 4", "out of range"]),
        obj("OBJ bad face index", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n").err(&["objects[1].path", "line 4", "'x'"]),
        obj("OBJ normal index out of range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n").err(&["line 4", "normal"]),
        obj("OBJ non-number", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n").err(&["objects[1].path", "line 2", "'zero'"]),
        obj("OBJ NaN", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").err(&["objects[1].path", "line 2", "finite"]),
        obj("OBJ too few numbers", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n").err(&["objects[1].path", "line 2"]),
        obj("OBJ no faces", "v 0 0 0\nv 1 0 0\nv 0 1 0\n").err(&["objects[1].path", "no faces"]),
        obj("OBJ empty", "").err(&["objects[1].path", "no faces"]),
        obj("OBJ only degenerate", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").ok(&["1 mesh(es) with only degenerate", "skipped"]),
        // --- command line ----------------------------------------------------------------
        unchanged("override not JSON")
            .with_override("{film:")
            .err(&["--override", "not valid JSON"]),
        unchanged("override not an object")
            .with_override("[1]")
            .err(&["--override", "object"]),
        unchanged("override breaks a key")
            .with_override(r#"{"film": {"resolution": [0, 8]}}"#)
            .err(&["film.resolution"]),
        // --- accepted ----------------------------------------------------------------------
        edit("unknown key is an error", |s| s["camera"]["fvo"] = json!(60)).err(&[
            "camera",
            "unknown key 'fvo'",
            "did you mean 'fov'?",
            "--lenient",
        ]),
        edit("unknown key warns with --lenient", |s| s["camera"]["fvo"] = json!(60))
            .with_arg("--lenient")
            .ok(&["camera", "fvo"]),
        edit("integer matrix", |s| {
            s["objects"][1]["transform"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
        })
        .ok(&[]),
        edit("integral float for an int key", |s| s["integrator"]["spp"] = json!(1.0)).ok(&[]),
        edit("empty objects list", |s| s["objects"] = json!([])).ok(&[]),
        obj(
            "OBJ degenerate and good triangle",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n",
        )
        .ok(&["degenerate", "line 5"]),
        obj("OBJ unknown statement warns", "v 0 0 0\nv 1 0 0\nv 0 1 0\nbevel 1\nf 1 2 3\n").ok(&["bevel"]),
        edit("image texture", |s| s["textures"]["white"] = image_texture("tex.png")).ok(&[]),
        edit("image texture nearest, raw", |s| {
            s["textures"]["white"] = image_texture("tex.png");
            s["textures"]["white"]["filter"] = json!("nearest");
            s["textures"]["white"]["raw"] = json!(true);
        })
        .ok(&[]),
        unchanged("png output").out("png-output.png").ok(&[]),
        unchanged("upper-case extension").out("upper.EXR").ok(&[]),
    ]
}

/// Output-path failures: exit 1, one error line naming the output path.
const BAD_OUTPUTS: &[&str] = &["out.jpg", "no/such/folder/out.exr", "out"];

struct Run {
    code: Option<i32>,
    stderr: String,
}

fn rdr(args: &[&std::ffi::OsStr]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_rdr")).args(args).output().expect("cannot run rdr");
    Run {
        code: out.status.code(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn slug(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '-' })
        .collect()
}

/// The problems with one error run, if any.
fn check_error(run: &Run, names: &[String], expect: &[&str]) -> Vec<String> {
    let mut problems = Vec::new();
    if run.code != Some(1) {
        problems.push(format!("exit status {:?}, expected 1", run.code));
    }
    if run.stderr.contains("panicked") {
        problems.push("panicked".to_string());
    }
    let lines: Vec<&str> = run.stderr.lines().collect();
    if lines.len() != 1 {
        problems.push(format!("{} lines on stderr, expected 1", lines.len()));
    }
    let Some(line) = lines.first() else { return problems };
    if !line.starts_with("error:") {
        problems.push("the line does not start with 'error:'".to_string());
    }
    for s in names.iter().map(String::as_str).chain(expect.iter().copied()) {
        if !line.contains(s) {
            problems.push(format!("the line does not contain '{s}'"));
        }
    }
    problems
}

#[test]
fn broken_scenes_fail_with_one_line_naming_file_and_key() {
    let tmp = common::temp_dir("rdr-bad-input");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    rdr::imageio::write_png(&dir.join("tex.png"), 2, 2, &[rdr::math::Vec3::splat(0.5); 4]).unwrap();
    let base: Value = serde_json::from_str(BASE).unwrap();

    // The base scene itself must render.
    let scene = dir.join("base.json");
    std::fs::write(&scene, BASE).unwrap();
    let run = rdr(&[
        "render".as_ref(),
        scene.as_os_str(),
        "-o".as_ref(),
        dir.join("base.exr").as_os_str(),
    ]);
    assert!(
        run.code == Some(0) && !run.stderr.contains("warning") && dir.join("base.exr").is_file(),
        "the base scene must render cleanly; exit {:?}, stderr:\n{}",
        run.code,
        run.stderr
    );

    let mut failures = Vec::new();
    let mut names = std::collections::HashSet::new();
    let cases = cases();
    for c in &cases {
        let slug = slug(c.name);
        assert!(names.insert(slug.clone()), "duplicate case name {}", c.name);
        let scene = dir.join(format!("{slug}.json"));
        let mut value = base.clone();
        if let Some(text) = c.obj {
            std::fs::write(dir.join(format!("{slug}.obj")), text).unwrap();
            value["objects"][1]["path"] = json!(format!("{slug}.obj"));
        }
        match &c.scene {
            Scene::Json(f) => {
                f(&mut value);
                std::fs::write(&scene, serde_json::to_string_pretty(&value).unwrap()).unwrap();
            }
            Scene::Replace(from, to) => {
                assert!(BASE.contains(from), "case '{}': '{from}' is not in the base scene", c.name);
                std::fs::write(&scene, BASE.replacen(from, to, 1)).unwrap();
            }
            Scene::Raw(bytes) => std::fs::write(&scene, bytes).unwrap(),
            Scene::Missing => {}
        }
        let output = dir.join(c.output.map(str::to_string).unwrap_or(format!("{slug}.exr")));
        let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), scene.as_os_str(), "-o".as_ref(), output.as_os_str()];
        args.extend(c.args.iter().map(std::ffi::OsStr::new));
        let run = rdr(&args);

        let problems = match &c.expect {
            Expect::Error(expect) => {
                // OBJ errors name both the scene and the OBJ file.
                let files: Vec<String> = std::iter::once(format!("{slug}.json"))
                    .chain(c.obj.map(|_| format!("{slug}.obj")))
                    .collect();
                let mut p = check_error(&run, &files, expect);
                if output.exists() {
                    p.push("an image was written".to_string());
                }
                p
            }
            Expect::Ok(warnings) => {
                let mut p = Vec::new();
                if run.code != Some(0) || run.stderr.contains("panicked") || run.stderr.contains("error") {
                    p.push(format!("exit status {:?} (expected 0), or an error or panic on stderr", run.code));
                }
                if !output.is_file() {
                    p.push("no image written".to_string());
                }
                let warning_lines: Vec<&str> = run.stderr.lines().filter(|l| l.starts_with("warning:")).collect();
                if warnings.is_empty() && !warning_lines.is_empty() {
                    p.push("unexpected warnings".to_string());
                }
                for w in warnings {
                    // Scene warnings name the scene file, mesh warnings the OBJ file: both carry the slug.
                    if !warning_lines.iter().any(|l| l.contains(w) && l.contains(&slug)) {
                        p.push(format!("no warning line names the case's file and contains '{w}'"));
                    }
                }
                p
            }
        };
        if !problems.is_empty() {
            failures.push(format!(
                "case '{}': {}\n  stderr: {}",
                c.name,
                problems.join("; "),
                run.stderr.trim_end().replace('\n', "\n          ")
            ));
        }
    }

    // An output path that cannot be written fails before rendering, naming it.
    let scene = dir.join("base.json");
    for bad in BAD_OUTPUTS {
        let output = dir.join(bad);
        let run = rdr(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), output.as_os_str()]);
        let problems = check_error(&run, &[output.display().to_string()], &[]);
        if !problems.is_empty() {
            failures.push(format!(
                "output '{bad}': {}\n  stderr: {}",
                problems.join("; "),
                run.stderr.trim_end()
            ));
        }
    }

    if !failures.is_empty() {
        // keep the files of a failing run for inspection
        let _ = tmp.keep();
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed (their files are kept in {}):\n{}",
        failures.len(),
        cases.len() + BAD_OUTPUTS.len(),
        dir.display(),
        failures.join("\n")
    );
}

#[test]
fn valid_scene_fixture_parses() {
    // Guards the fixture: if BASE stops being valid, every error case passes for the wrong reason.
    let v: Value = serde_json::from_str(BASE).unwrap();
    let desc = rdr::desc::SceneDesc::from_value(&v, Path::new("base.json"), Path::new(".")).unwrap();
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    assert_eq!(desc.objects.len(), 2);
}
