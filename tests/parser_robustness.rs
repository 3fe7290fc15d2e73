//! The fuzz test CI runs: thousands of deterministic pseudo-random mutations of valid
//! scene and OBJ text through the parsers (the same calls as `fuzz/fuzz_targets/scene_json.rs`),
//! which must never panic and must report errors on one line.

mod common;

use rdr::desc::json::{merge, parse_text};
use rdr::desc::{build, BuildOptions, SceneDesc};
use rdr::geometry::mesh::Mesh;
use rdr::geometry::obj;
use rdr::math::{Mat4, Vec3};
use serde_json::{json, Value};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Uses every section and type the format has, so mutations reach every branch.
const SCENE: &str = r#"{
  "integrator": {"type": "intersection_test", "spp": 2, "max_depth": 4, "point_light_position": [0, 1.5, 0.5],
                 "point_light_flux": [17, 12, 5], "lights": [{"type": "point", "position": [1, 1, 1], "flux": [1, 1, 1]}]},
  "film": {"resolution": [16, 12], "block_side_length": 8, "filter": {"type": "mitchell", "radius": 2, "B": 0.3, "C": 0.3}},
  "camera": {"position": [0, 1, 4], "look_at": [0, 1, 0], "ref_up": [0, 1, 0], "fov": 40, "focal_length": 1},
  "textures": {
    "white": {"type": "constant", "color": [0.8, 0.8, 0.8]},
    "check": {"type": "checkerboard", "color0": [1, 0, 0], "color1": [0, 0, 1],
              "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, 4], "delta": [0.5, 0]}}
  },
  "materials": {
    "matte": {"type": "diffuse", "texture_name": "check", "twosided": true},
    "metal": {"type": "roughconductor", "texture_name": "white", "etaI": [1, 1, 1], "etaT": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2],
              "alpha_x": 0.1, "alpha_y": 0.2},
    "glass": {"type": "glass", "R": [1, 1, 1], "T": [1, 1, 1], "eta": 1.5},
    "water": {"type": "refraction", "eta": 1.33}
  },
  "objects": [
    {"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5, "material_name": "glass"},
    {"type": "sphere", "center": [1, 0.5, 0], "radius": 0.25, "material_name": "water", "light": {"type": "area", "radiance": [2, 2, 2]}},
    {"type": "mesh", "path": "quad.obj", "material_name": "matte", "translate": [0, -0.01, 0],
     "transform": [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]},
    {"type": "mesh", "path": "quad.obj", "material_name": "metal", "light": {"radiance": [1, 1, 1]}}
  ],
  "environment_map": {"texture_name": "white", "scale": 0.5, "transform": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}
}
"#;

const QUAD_OBJ: &str = "# a quad\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\n\
                        g floor\nusemtl white\nf 1/1/1 2/2/1 3/3/1 4/4/1\nf -4//-1 -2//-1 -3//-1\nf 1 2 3 4 3 2\n";

/// Deterministic generator driving the mutations.
struct Rng(rdr::sampling::SplitMix64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
    fn pick<'a, T: ?Sized>(&mut self, items: &[&'a T]) -> &'a T {
        items[self.below(items.len())]
    }
}

/// Tokens that tend to break parsers, separated by spaces.
const NASTY: &str = r#"NaN -Infinity 1e39 -1e39 1e-46 1e308 -0 0 -1 2147483648 -2147483649 4294967296 1.5 0.0 "" "\ud800" "\u0000"
    "é" [] {} [[[[ ]]]] null true false , : "type" "mesh" "sphere" "objects" "path" "quad.obj" "/" ".." "transform"
    [0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0] [1,2] [1,2,3]"#;

fn is_punct(b: u8) -> bool {
    b.is_ascii_whitespace() || b"{}[],:\"/".contains(&b)
}

/// Token boundaries: positions where the byte class changes.
fn boundaries(b: &[u8]) -> Vec<usize> {
    let mut out = vec![0];
    for i in 1..b.len() {
        if is_punct(b[i]) || is_punct(b[i - 1]) {
            out.push(i);
        }
    }
    out.push(b.len());
    out
}

/// One random edit of `b`.
fn mutate(rng: &mut Rng, b: &mut Vec<u8>) {
    let nasty: Vec<&str> = NASTY.split_whitespace().collect();
    let len = b.len();
    let at = rng.below(len + 1);
    match rng.below(9) {
        0 if len > 0 => b[at.min(len - 1)] ^= 1 << rng.below(8),
        1 if len > 0 => {
            let bytes = b"{}[],:\"\\-.e9\n/\xff";
            b[at.min(len - 1)] = bytes[rng.below(bytes.len())];
        }
        2 => b.truncate(at),
        3 => {
            let end = (at + 1 + rng.below(16)).min(len);
            b.drain(at..end);
        }
        4 => {
            let end = (at + 1 + rng.below(32)).min(len);
            let copy = b[at..end].to_vec();
            let to = rng.below(len + 1);
            b.splice(to..to, copy);
        }
        5 | 6 => {
            // swap two tokens, or overwrite one with a nasty token
            let bounds = boundaries(b);
            if bounds.len() < 3 {
                return;
            }
            let t1 = rng.below(bounds.len() - 1);
            let (s1, e1) = (bounds[t1], bounds[t1 + 1]);
            if rng.below(2) == 0 {
                let t2 = rng.below(bounds.len() - 1);
                let (s2, e2) = (bounds[t2], bounds[t2 + 1]);
                let (first, second) = if s1 <= s2 { ((s1, e1), (s2, e2)) } else { ((s2, e2), (s1, e1)) };
                if first.1 <= second.0 {
                    let a = b[first.0..first.1].to_vec();
                    let c = b[second.0..second.1].to_vec();
                    b.splice(second.0..second.1, a);
                    b.splice(first.0..first.1, c);
                }
            } else {
                b.splice(s1..e1, rng.pick(&nasty).bytes());
            }
        }
        7 => {
            let bounds = boundaries(b);
            let to = bounds[rng.below(bounds.len())];
            b.splice(to..to, rng.pick(&nasty).bytes());
        }
        _ => {
            let c = b.get(at).copied().unwrap_or(b' ');
            b.insert(at.min(len), c);
        }
    }
}

fn one_line(what: &str, e: &dyn std::fmt::Display) -> Result<(), String> {
    let s = e.to_string();
    if s.contains('\n') {
        return Err(format!("{what} error spans lines: {s:?}"));
    }
    Ok(())
}

/// How far an input got: 0 = rejected by the first stage, 1 = by the second, …
type Stage = usize;

/// Scene text → value → description → render-ready scene (meshes from `dir`).
/// Also merges the text, as an `--override`, into the valid scene.
fn exercise_scene(text: &str, dir: &Path) -> Result<Stage, String> {
    let file = dir.join("fuzz.json");
    let mut stage = 0;
    match parse_text(text, &file) {
        Err(e) => one_line("parse_text", &e)?,
        Ok(value) => {
            stage = 1;
            match SceneDesc::from_value(&value, &file, dir) {
                Err(e) => one_line("from_value", &e)?,
                Ok(desc) => {
                    stage = 2;
                    match build(&desc, BuildOptions::default()) {
                        Err(e) => one_line("build", &e)?,
                        Ok(_) => stage = 3,
                    }
                }
            }
            if value.is_object() {
                let mut base: Value = serde_json::from_str(SCENE).unwrap();
                merge(&mut base, &value);
                if let Err(e) = SceneDesc::from_value(&base, &file, dir) {
                    one_line("from_value after merge", &e)?;
                }
            }
        }
    }
    Ok(stage)
}

/// OBJ text → parsed data → mesh, plain and transformed.
fn exercise_obj(text: &str) -> Result<Stage, String> {
    let data = match obj::parse(text) {
        Err(e) => return one_line("obj::parse", &e).map(|()| 0),
        Ok(data) => data,
    };
    let stage = if data.triangles.is_empty() { 1 } else { 2 };
    let m = Mat4::from_cols_array(&[0.5, 0.0, 0.0, 0.0, 0.0, -2.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 3.0, 1.0]);
    let _ = Mesh::from_obj(data.clone(), &Mat4::IDENTITY, Vec3::ZERO, true);
    let (mesh, _) = Mesh::from_obj(data, &m, Vec3::ONE, false);
    for i in 0..mesh.triangles.len() {
        let _ = mesh.area(i);
    }
    Ok(stage)
}

/// Random OBJ-like text: mostly well-formed statements (so faces get built),
/// sprinkled with bad numbers, bad indices and odd face forms.
fn random_obj(rng: &mut Rng) -> String {
    let nasty_num = ["1e39", "-1e-45", "nan", "inf", "1e", "x", "--1", "+2", "1,5", "0x1", "-0"];
    let nasty_index = ["0", "7", "-9", "+1", "-0", "99999999999999999999", "1.0", "", "a", "/"];
    let num = |rng: &mut Rng| {
        if rng.below(150) == 0 {
            rng.pick(&nasty_num).to_string()
        } else {
            format!("{}", (rng.below(9) as f32 - 4.0) * 0.5)
        }
    };
    let index = |rng: &mut Rng| {
        if rng.below(150) == 0 {
            rng.pick(&nasty_index).to_string()
        } else if rng.below(4) == 0 {
            format!("-{}", 1 + rng.below(3))
        } else {
            format!("{}", 1 + rng.below(3))
        }
    };
    // Usually enough of each element first for the small indices to resolve.
    let mut s = String::new();
    for (kw, n) in [("v", 3), ("vt", 2), ("vn", 3)] {
        if kw == "v" || rng.below(8) != 0 {
            for _ in 0..3 {
                let coords: Vec<String> = (0..n).map(|_| num(rng)).collect();
                s.push_str(&format!("{kw} {}\n", coords.join(" ")));
            }
        }
    }
    for _ in 0..rng.below(30) {
        let kind = rng.below(12);
        match kind {
            0..=3 => {
                s.push('v');
                for _ in 0..if rng.below(30) == 0 { rng.below(5) } else { 3 } {
                    s.push(' ');
                    s.push_str(&num(rng));
                }
            }
            4 => s.push_str(&format!("vn {} {} {}", num(rng), num(rng), num(rng))),
            5 => s.push_str(&format!("vt {} {}", num(rng), num(rng))),
            6..=9 => {
                s.push('f');
                let form = [0, 1, 2, 4][rng.below(4)];
                for _ in 0..if rng.below(4) == 0 { rng.below(13) } else { 3 + rng.below(2) } {
                    s.push(' ');
                    s.push_str(&index(rng));
                    match if rng.below(50) == 0 { rng.below(5) } else { form } {
                        0 => s.push_str(&format!("/{}", index(rng))),
                        1 => s.push_str(&format!("//{}", index(rng))),
                        2 => s.push_str(&format!("/{}/{}", index(rng), index(rng))),
                        3 => s.push_str(rng.pick(&["/", "//", "///", "/ /"])),
                        _ => {}
                    }
                }
            }
            10 => s.push_str(rng.pick(&[
                "# comment f 1 2 3",
                "g",
                "o x",
                "s off",
                "usemtl m",
                "mtllib a.mtl",
                "curv2 1 2",
                "\t",
                "v 1 2 3 # x",
            ])),
            _ => s.push_str(QUAD_OBJ.lines().nth(rng.below(QUAD_OBJ.lines().count())).unwrap_or("")),
        }
        s.push_str(if rng.below(8) == 0 { "\r\n" } else { "\n" });
    }
    s
}

/// JSON pointers of every value inside `v`.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                pointers(x, format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
    out.push(at);
}

/// A structural edit of a valid scene: the text stays valid JSON, so the edit
/// reaches the scene reader and builder rather than the JSON parser.
fn mutate_value(rng: &mut Rng, v: &mut Value) {
    let replacements = [
        json!(-1),
        json!(0),
        json!(0.5),
        json!(1e39),
        json!(-1e-45),
        json!(180),
        json!(2147483648u64),
        json!(1.5),
        json!(""),
        json!("mesh"),
        json!("sphere"),
        json!("diffuse"),
        json!("quad.obj"),
        json!("missing.obj"),
        json!("white"),
        json!("nope"),
        Value::Null,
        json!(true),
        json!([]),
        json!({}),
        json!([1, 2]),
        json!([0, 1, 4]),
        json!([0, 0, 0]),
        json!([1, -1, 1]),
        json!([100000, 100000]),
        json!(vec![0; 16]),
        json!([[1, 2, 3]]),
        json!({"type": "sphere"}),
    ];
    let mut ptrs = Vec::new();
    pointers(v, String::new(), &mut ptrs);
    let ptr = ptrs[rng.below(ptrs.len())].clone();
    let Some(target) = v.pointer_mut(&ptr) else { return };
    match rng.below(6) {
        0 | 1 => *target = replacements[rng.below(replacements.len())].clone(),
        2 => {
            if let Some(x) = target.as_f64() {
                *target = json!(x * [-1.0, 0.0, 1e30, 1e-30, 0.5][rng.below(5)]);
            }
        }
        3 => match target {
            Value::Object(m) if !m.is_empty() => {
                let k = m.keys().nth(rng.below(m.len())).cloned().unwrap_or_default();
                m.remove(&k);
            }
            Value::Array(a) if !a.is_empty() => {
                a.remove(rng.below(a.len()));
            }
            _ => {}
        },
        4 => match target {
            Value::Object(m) => {
                let k = ["type", "fvo", "path", "light", "material_name", "radius", "lights"][rng.below(7)];
                m.insert(k.to_string(), replacements[rng.below(replacements.len())].clone());
            }
            Value::Array(a) if !a.is_empty() => {
                let x = a[rng.below(a.len())].clone();
                a.push(x);
            }
            _ => {}
        },
        _ => {
            // copy a subtree over another
            let from = v.pointer(&ptrs[rng.below(ptrs.len())]).cloned().unwrap_or(Value::Null);
            if let Some(target) = v.pointer_mut(&ptr) {
                *target = from;
            }
        }
    }
}

/// Outcomes of all inputs.
struct Tally {
    failures: Vec<String>,
    /// `stages[name][k]`: inputs of that kind that reached stage `k`.
    stages: std::collections::BTreeMap<&'static str, [usize; 4]>,
}

impl Tally {
    /// Runs `f` on one input; records a panic or a multi-line error, else counts the stage reached.
    fn check(&mut self, what: &'static str, input: &[u8], f: impl FnOnce() -> Result<Stage, String>) {
        match catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|_| Err("panicked".to_string())) {
            Ok(stage) => self.stages.entry(what).or_default()[stage] += 1,
            Err(msg) => {
                let text = String::from_utf8_lossy(input);
                let shown: String = text.chars().take(600).collect();
                self.failures
                    .push(format!("{what}: {msg}\n  input ({} bytes): {shown:?}", input.len()));
            }
        }
    }
}

#[test]
fn mutated_scenes_and_objs_never_panic() {
    let tmp = common::temp_dir("rdr-robustness");
    let dir = tmp.path();
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    // The seeds are valid: mutations start from something that loads.
    assert_eq!(exercise_scene(SCENE, dir), Ok(3));
    assert_eq!(exercise_obj(QUAD_OBJ), Ok(2));
    assert_eq!(obj::parse(QUAD_OBJ).unwrap().triangles.len(), 7);

    let mut rng = Rng(rdr::sampling::SplitMix64(0x5eed_0171));
    let mut t = Tally {
        failures: Vec::new(),
        stages: Default::default(),
    };
    let scene: Value = serde_json::from_str(SCENE).unwrap();
    for _ in 0..20_000 {
        let mut v = scene.clone();
        for _ in 0..1 + rng.below(3) {
            mutate_value(&mut rng, &mut v);
        }
        let text = serde_json::to_string_pretty(&v).unwrap();
        t.check("edited scene", text.as_bytes(), || exercise_scene(&text, dir));
    }
    for _ in 0..20_000 {
        let mut b = SCENE.as_bytes().to_vec();
        for _ in 0..1 + rng.below(4) {
            mutate(&mut rng, &mut b);
        }
        let text = String::from_utf8_lossy(&b).into_owned();
        t.check("mutated scene", &b, || exercise_scene(&text, dir));
    }
    for _ in 0..2000 {
        let b: Vec<u8> = (0..rng.below(200)).map(|_| rng.next() as u8).collect();
        let text = String::from_utf8_lossy(&b).into_owned();
        t.check("random bytes as scene", &b, || exercise_scene(&text, dir));
        t.check("random bytes as OBJ", &b, || exercise_obj(&text));
    }
    for _ in 0..20_000 {
        let text = random_obj(&mut rng);
        t.check("random OBJ", text.as_bytes(), || exercise_obj(&text));
    }
    for _ in 0..10_000 {
        let mut b = QUAD_OBJ.as_bytes().to_vec();
        for _ in 0..1 + rng.below(4) {
            mutate(&mut rng, &mut b);
        }
        let text = String::from_utf8_lossy(&b).into_owned();
        t.check("mutated OBJ", &b, || exercise_obj(&text));
    }

    for (what, n) in &t.stages {
        eprintln!("{what:>22}: inputs by stage reached {n:?}");
    }
    let runs: usize = t.stages.values().flatten().sum::<usize>() + t.failures.len();
    let shown: Vec<&str> = t.failures.iter().take(10).map(String::as_str).collect();
    assert!(
        t.failures.is_empty(),
        "{} of {runs} inputs failed (first {}):\n{}",
        t.failures.len(),
        shown.len(),
        shown.join("\n")
    );
    // The mutations must not all die in the first stage, or the later stages go untested.
    let share = |what: &str, from: usize| {
        let n = t.stages[what];
        n[from..].iter().sum::<usize>() as f64 / n.iter().sum::<usize>() as f64
    };
    assert!(share("mutated scene", 1) > 0.03, "{:?}", t.stages);
    assert!(share("edited scene", 2) > 0.2 && share("edited scene", 3) > 0.1, "{:?}", t.stages);
    assert!(share("random OBJ", 2) > 0.3 && share("mutated OBJ", 2) > 0.05, "{:?}", t.stages);
}
