//! Hostile input through the real binary (issue 15): whatever the files and flags
//! say, `rdr` ends within seconds, under an address-space limit, with exit status 1
//! and one `error:` line naming the file and key — or, where the input is legal, a
//! correct image — never a panic (101), an abort (134) or a kill.
//!
//! Every child runs under `prlimit --as` (when the tool exists) so an allocation
//! the input talks us into fails instead of swapping the machine; the memory budget
//! the binary derives from that limit must refuse it first, with a clear message.
//!
//! Adding a case is one entry in `cases()`.

mod common;

use serde_json::{json, Value};
use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Address space each child may use: enough for the program, its threads and small
/// renders, far too little for what the hostile files claim.
const ADDRESS_SPACE: u64 = 3_000_000_000;
/// No single case may take longer than this.
const CASE_TIMEOUT: Duration = Duration::from_secs(15);

/// A small valid scene: a sphere, a one-triangle mesh and a glass sphere.
const BASE: &str = r#"{
  "integrator": {"type": "intersection_test", "spp": 1},
  "film": {"resolution": [8, 8]},
  "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 45},
  "textures": {"white": {"type": "constant", "color": [0.8, 0.8, 0.8]}},
  "materials": {"matte": {"type": "diffuse", "texture_name": "white"},
                "glass": {"type": "refraction", "eta": 1.5}},
  "objects": [
    {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material_name": "matte"},
    {"type": "mesh", "path": "tri.obj", "material_name": "matte"},
    {"type": "sphere", "center": [1, 0, 1], "radius": 0.5, "material_name": "glass"}
  ]
}
"#;

const TRI_OBJ: &str = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n";

struct Run {
    code: Option<i32>,
    signal: Option<i32>,
    stdout: String,
    stderr: String,
    seconds: f64,
    timed_out: bool,
}

/// The binary under test; `RDR_HOSTILE_BIN` runs the table against another one (an
/// older build, to see which cases it fails).
fn bin() -> String {
    std::env::var("RDR_HOSTILE_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_rdr").to_string())
}

fn have_prlimit() -> bool {
    Command::new("prlimit").arg("--version").output().is_ok_and(|o| o.status.success())
}

/// The binary under the address-space limit (through `prlimit`, no `unsafe`).
fn command(args: &[OsString]) -> Command {
    let mut c = if have_prlimit() {
        let mut c = Command::new("prlimit");
        c.arg(format!("--as={ADDRESS_SPACE}")).arg("--").arg(bin());
        c
    } else {
        Command::new(bin())
    };
    c.args(args).stdin(Stdio::null());
    c
}

/// Waits for `child` up to the case timeout, killing it past that.
fn finish(mut child: std::process::Child, start: Instant) -> Run {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    let mut out = child.stdout.take();
    let mut err = child.stderr.take();
    // read both pipes on threads so a chatty child cannot block on a full pipe
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(o) = out.as_mut() {
            let _ = o.read_to_string(&mut s);
        }
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(e) = err.as_mut() {
            let _ = e.read_to_string(&mut s);
        }
        s
    });
    let mut timed_out = false;
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if start.elapsed() > CASE_TIMEOUT {
            timed_out = true;
            let _ = child.kill();
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Run {
        code: status.code(),
        signal: status.signal(),
        stdout: t_out.join().unwrap(),
        stderr: t_err.join().unwrap(),
        seconds: start.elapsed().as_secs_f64(),
        timed_out,
    }
}

fn run(args: &[OsString]) -> Run {
    let start = Instant::now();
    let child = command(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    finish(child, start)
}

fn os(v: &[&dyn AsRef<OsStr>]) -> Vec<OsString> {
    v.iter().map(|s| s.as_ref().to_os_string()).collect()
}

enum Expect {
    /// Exit 1, one `error:` line (besides warnings) containing all of these.
    Error(Vec<String>),
    /// Exit 0, this file written, each string in some `warning:` line.
    Image(PathBuf, Vec<&'static str>),
}

struct Case {
    name: &'static str,
    args: Vec<OsString>,
    expect: Expect,
}

fn err(name: &'static str, args: Vec<OsString>, expect: &[&dyn std::fmt::Display]) -> Case {
    Case {
        name,
        args,
        expect: Expect::Error(expect.iter().map(|s| s.to_string()).collect()),
    }
}

fn image(name: &'static str, args: Vec<OsString>, out: &Path, warnings: &[&'static str]) -> Case {
    Case {
        name,
        args,
        expect: Expect::Image(out.to_path_buf(), warnings.to_vec()),
    }
}

/// The problems of a run with what a case expects (empty: fine).
fn check(run: &Run, expect: &Expect) -> Vec<String> {
    let mut p = Vec::new();
    if run.timed_out {
        p.push(format!("did not end within {CASE_TIMEOUT:?} (killed)"));
    }
    if let Some(s) = run.signal {
        p.push(format!("killed by signal {s}"));
    }
    for bad in ["panicked", "internal error", "memory allocation", "RUST_BACKTRACE"] {
        if run.stderr.contains(bad) {
            p.push(format!("stderr mentions '{bad}'"));
        }
    }
    let lines: Vec<&str> = run.stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    match expect {
        Expect::Error(want) => {
            if run.code != Some(1) {
                p.push(format!("exit status {:?}, expected 1", run.code));
            }
            let errors: Vec<&&str> = lines.iter().filter(|l| l.starts_with("error: ")).collect();
            let others = lines
                .iter()
                .filter(|l| !l.starts_with("error: ") && !l.starts_with("warning: "))
                .count();
            if errors.len() != 1 || others != 0 {
                p.push(format!(
                    "{} error line(s) and {others} other line(s), expected one error line",
                    errors.len()
                ));
            }
            if let Some(line) = errors.first() {
                for w in want {
                    if !line.contains(w.as_str()) {
                        p.push(format!("the error line does not contain '{w}'"));
                    }
                }
            }
        }
        Expect::Image(out, warnings) => {
            if run.code != Some(0) {
                p.push(format!("exit status {:?}, expected 0", run.code));
            }
            if lines.iter().any(|l| l.starts_with("error")) {
                p.push("an error line".into());
            }
            match rdr::imageio::read_exr(out) {
                Ok(img) => {
                    if !img.pixels.iter().all(|v| v.is_finite()) || img.pixels.iter().all(|v| *v == rdr::math::Vec3::ZERO) {
                        p.push("the image is not finite or all black".into());
                    }
                }
                Err(e) => p.push(format!("no readable image: {e:#}")),
            }
            for w in warnings {
                if !lines.iter().any(|l| l.starts_with("warning:") && l.contains(w)) {
                    p.push(format!("no warning contains '{w}'"));
                }
            }
        }
    }
    p
}

/// A Mitsuba scene: an 8×8 camera, `body`, a constant sky.
fn mitsuba(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>
<transform name="to_world"><lookat origin="0,0,50" target="0,0,0" up="0,1,0"/></transform>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
{body}<emitter type="constant"/></scene>
"#
    )
}

/// A Mitsuba `.serialized` file of one single-precision mesh whose stream says `nv`
/// vertices and `nt` triangles, followed by `zeros` bytes of zeros.
fn serialized(nv: u64, nt: u64, zeros: usize) -> Vec<u8> {
    use std::io::Write;
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(&0x1000u32.to_le_bytes()).unwrap();
    z.write_all(b"m\0").unwrap();
    z.write_all(&nv.to_le_bytes()).unwrap();
    z.write_all(&nt.to_le_bytes()).unwrap();
    let block = vec![0u8; 1 << 20];
    for at in (0..zeros).step_by(block.len()) {
        z.write_all(&block[..block.len().min(zeros - at)]).unwrap();
    }
    let mut out = vec![0x1c, 0x04, 4, 0];
    out.extend(z.finish().unwrap());
    out.extend(0u64.to_le_bytes());
    out.extend(1u32.to_le_bytes());
    out
}

/// Writes `BASE` edited by `f` to `dir/name.json`.
fn scene(dir: &Path, name: &str, f: impl FnOnce(&mut Value)) -> PathBuf {
    let mut v: Value = serde_json::from_str(BASE).unwrap();
    f(&mut v);
    let p = dir.join(format!("{name}.json"));
    std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    p
}

/// An `image` texture on the matte material.
fn textured(v: &mut Value, path: &str) {
    v["textures"]["img"] = json!({"type": "image", "path": path, "tex_coordinate_generator": {"type": "uvmapping2d"}});
    v["materials"]["matte"]["texture_name"] = json!("img");
}

/// A tiny EXR (written by rdr, 1×1) whose data window then claims `w`×`h` pixels.
fn lying_exr(w: i32, h: i32) -> Vec<u8> {
    let mut b = rdr::imageio::encode_exr(1, 1, &[rdr::math::Vec3::ONE], rdr::imageio::ExrPixels::Float);
    let key = b"dataWindow\0box2i\0";
    let at = b.windows(key.len()).position(|x| x == key).unwrap() + key.len() + 4;
    b[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
    b[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    b
}

fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A PNG whose header claims `w`×`h` RGB pixels, with a few bytes of (bogus) data.
fn lying_png(w: u32, h: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |ty: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = ty.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(b"IEND", &[]);
    out
}

fn mkfifo(p: &Path) -> bool {
    Command::new("mkfifo").arg(p).status().is_ok_and(|s| s.success())
}

fn cases(dir: &Path) -> Vec<Case> {
    let d = |n: &str| dir.join(n);
    let o = |n: &str| d(&format!("{n}.exr"));
    let base = d("base.json");
    let render = |s: &Path, out: &Path, extra: &[&str]| {
        let mut a = os(&[&"render", &s, &"-o", &out, &"-q"]);
        a.extend(extra.iter().map(OsString::from));
        a
    };
    let over = |s: &Path, name: &str, json: &str| render(s, &o(name), &["--override", json]);
    let edited = |name: &'static str, f: &dyn Fn(&mut Value)| scene(dir, name, f);
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json");
    let small = r#"{"film":{"resolution":[16,16]}}"#;

    // files
    std::fs::write(d("lying.exr"), lying_exr(100_000, 100_000)).unwrap();
    std::fs::write(d("lying.png"), lying_png(23170, 23170)).unwrap();
    std::fs::write(
        d("vertex4e9.ply"),
        "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nend_header\n",
    )
    .unwrap();
    std::fs::write(
        d("junk2p64.ply"),
        "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n",
    )
    .unwrap();
    std::fs::write(
        d("vertexprops.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
    )
    .unwrap();
    let fifo = d("fifo.obj");
    let have_fifo = mkfifo(&fifo);
    std::fs::write(d("tri.obj"), TRI_OBJ).unwrap();
    std::fs::write(d("huge_tri.obj"), "v -1e20 -1e20 0\nv 1e20 -1e20 0\nv 0 1e20 0\nf 1 2 3\n").unwrap();
    // a convex 300,000-gon
    let n = 300_000;
    let mut big = String::with_capacity(n * 40);
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        big.push_str(&format!("v {:.7} {:.7} 0\n", a.cos(), a.sin()));
    }
    big.push('f');
    for i in 1..=n {
        big.push_str(&format!(" {i}"));
    }
    big.push('\n');
    std::fs::write(d("bigpoly.obj"), big).unwrap();
    rdr::imageio::write_exr(&d("img4.exr"), 4, 4, &[rdr::math::Vec3::ONE; 16], rdr::imageio::ExrPixels::Float).unwrap();
    rdr::imageio::write_exr(&d("img2.exr"), 2, 2, &[rdr::math::Vec3::ONE; 4], rdr::imageio::ExrPixels::Float).unwrap();
    rdr::imageio::write_exr(&d("img8.exr"), 8, 8, &[rdr::math::Vec3::ONE; 64], rdr::imageio::ExrPixels::Float).unwrap();
    std::fs::create_dir_all(d("folder.exr")).unwrap();
    let self_named = d("selfnamed.exr");
    std::fs::write(&self_named, BASE).unwrap();
    let self_copy = std::fs::read(&self_named).unwrap();
    assert!(!self_copy.is_empty());
    // issue 42: nested 8,000 deep (a stack overflow), 150,000 properties and 20,000
    // instances (loading was quadratic), a sky with NaN, infinite and negative texels,
    // serialized meshes with a corrupt stream and with counts their stream cannot hold
    let n = 8000;
    std::fs::write(
        d("deep.xml"),
        format!("<scene version=\"3.0.0\">{}{}</scene>", "<x>".repeat(n), "</x>".repeat(n)),
    )
    .unwrap();
    let floats: String = (0..150_000).map(|i| format!("<float name=\"f{i}\" value=\"{i}.5\"/>\n")).collect();
    std::fs::write(
        d("floats.xml"),
        mitsuba(&format!(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\">\n{floats}</bsdf></shape>\n"
        )),
    )
    .unwrap();
    let instances: String = (0..20_000)
        .map(|i| {
            let (x, y) = (i % 100, i / 100 % 100);
            format!("<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate x=\"{x}\" y=\"{y}\"/></transform></shape>\n")
        })
        .collect();
    let group = r#"<shape type="shapegroup" id="g"><shape type="sphere"><float name="radius" value="0.2"/></shape></shape>"#;
    std::fs::write(d("instances.xml"), mitsuba(&format!("{group}\n{instances}"))).unwrap();
    // issue 42, found auditing it: 300,000 attributes on one element (the XML parser's
    // duplicate check is quadratic: minutes), and scenes whose parsed form outgrows the
    // budget (an XML element takes some 1.2 kB, a JSON zero 48 bytes: the 1/8-of-the-
    // budget file size cap let a scene file take several times the budget)
    let attrs: String = (0..300_000).map(|i| format!(" a{i}=\"{i}\"")).collect();
    std::fs::write(d("attrs.xml"), mitsuba(&format!("<shape type=\"sphere\"{attrs}/>\n"))).unwrap();
    let mut zeros: Value = serde_json::from_str(BASE).unwrap();
    zeros["integrator"]["lights"] = json!(vec![0; 3_000_000]);
    std::fs::write(d("zeros.json"), serde_json::to_string(&zeros).unwrap()).unwrap();
    let mut sky = vec![rdr::math::Vec3::ONE; 8];
    sky[1].x = f32::NAN;
    sky[2].y = f32::INFINITY;
    sky[5].z = -1.0;
    rdr::imageio::write_exr(&d("sky.exr"), 4, 2, &sky, rdr::imageio::ExrPixels::Float).unwrap();
    let mut corrupt = serialized(3, 1, 48);
    corrupt[6] |= 0x07; // the first deflate block's type: 3, which does not exist
    std::fs::write(d("corrupt.serialized"), corrupt).unwrap();
    let lying = serialized(30_000_000, 60_000_000, 450 << 20);
    assert!((400_000..520_000).contains(&lying.len()), "{} bytes", lying.len());
    std::fs::write(d("lying.serialized"), &lying).unwrap();
    // outputs that are inputs: a texture, a mesh through a symbolic link, a merged part
    std::os::unix::fs::symlink(d("tri.obj"), d("trilink.obj")).unwrap();
    for k in 0..2 {
        let part = d(&format!("part{k}.exr"));
        let shard = format!("{k}/2");
        let r = run(&os(&[&"render", &base, &"-o", &part, &"-q", &"--shard", &shard, &"--spp", &"2"]));
        assert_eq!(r.code, Some(0), "shard {k}: {}", r.stderr);
    }
    let serialized_scene = |name: &str| {
        let p = d(&format!("{name}.xml"));
        let shape = format!(r#"<shape type="serialized"><string name="filename" value="{name}.serialized"/></shape>"#);
        std::fs::write(&p, mitsuba(&shape)).unwrap();
        p
    };

    let mut c = vec![
        // 1. NaN and infinite rays
        err(
            "focal length 1e-45",
            over(&cornell, "f1", r#"{"camera":{"focal_length":1e-45}}"#),
            &[&"cornell.json", &"camera.focal_length"],
        ),
        err(
            "camera at +3e38",
            over(&cornell, "c1", r#"{"camera":{"position":[3e38,0,0]}}"#),
            &[&"cornell.json", &"camera.position"],
        ),
        err(
            "camera at -3e38",
            over(&cornell, "c2", r#"{"camera":{"position":[0,-3e38,1]}}"#),
            &[&"cornell.json", &"camera.position"],
        ),
        err(
            "look_at at 3e38",
            over(&cornell, "c3", r#"{"camera":{"look_at":[0,0,3e38]}}"#),
            &[&"cornell.json", &"camera.look_at"],
        ),
        err(
            "eta 1e20",
            over(&base, "e1", r#"{"materials":{"glass":{"eta":1e20}}}"#),
            &[&"base.json", &"materials.glass.eta"],
        ),
        err(
            "eta 1e-20",
            over(&base, "e2", r#"{"materials":{"glass":{"eta":1e-20}}}"#),
            &[&"base.json", &"materials.glass.eta"],
        ),
        err(
            "bench scene with a NaN camera",
            os(&[&"bench", &cornell, &"--override", &r#"{"camera":{"focal_length":1e-45}}"#]),
            &[&"camera.focal_length"],
        ),
        err(
            "sphere centre 1e30",
            over(
                &base,
                "s1",
                r#"{"objects":[{"type":"sphere","center":[1e30,0,0],"radius":1,"material_name":"matte"}]}"#,
            ),
            &[&"objects[0].center"],
        ),
        err(
            "sphere radius 1e30",
            over(
                &base,
                "s2",
                r#"{"objects":[{"type":"sphere","radius":1e30,"material_name":"matte"}]}"#,
            ),
            &[&"objects[0].radius"],
        ),
        err(
            "point light at 1e38",
            over(&base, "l1", r#"{"integrator":{"point_light_position":[1e38,0,0]}}"#),
            &[&"integrator.point_light_position"],
        ),
        // 2. sample counts
        image(
            "--spp 2^32-1 with a time limit",
            {
                let mut a = over(&cornell, "spp1", small);
                a.extend(os(&[&"--spp", &"4294967295", &"--time-limit", &"1"]));
                a
            },
            &o("spp1"),
            &[],
        ),
        image(
            "JSON spp 2^31-1 with a time limit",
            {
                let mut a = over(
                    &cornell,
                    "spp2",
                    r#"{"film":{"resolution":[16,16]},"integrator":{"spp":2147483647}}"#,
                );
                a.extend(os(&[&"--time-limit", &"1"]));
                a
            },
            &o("spp2"),
            &[],
        ),
        err("--spp 2^32", render(&base, &o("spp3"), &["--spp", "4294967296"]), &[&"--spp"]),
        err("--spp 0", render(&base, &o("spp4"), &["--spp", "0"]), &[&"--spp"]),
        // 3. tiny files that claim huge sizes
        err(
            "EXR texture claiming 100000x100000",
            render(&edited("exrtex", &|v| textured(v, "lying.exr")), &o("x1"), &[]),
            &[&"lying.exr", &"textures.img.path", &"100000x100000"],
        ),
        err(
            "compare an EXR claiming 100000x100000",
            os(&[&"compare", &d("lying.exr"), &d("img4.exr")]),
            &[&"lying.exr", &"100000x100000"],
        ),
        err(
            "compare against an EXR claiming 100000x100000",
            os(&[&"compare", &d("img4.exr"), &d("lying.exr")]),
            &[&"lying.exr"],
        ),
        err(
            "PNG texture claiming 23170x23170",
            render(&edited("pngtex", &|v| textured(v, "lying.png")), &o("x2"), &[]),
            &[&"lying.png", &"textures.img.path", &"23170x23170", &"more than its"],
        ),
        err(
            "PLY vertex count 4e9 without properties",
            os(&[&"bench", &d("vertex4e9.ply")]),
            &[&"vertex4e9.ply", &"vertex"],
        ),
        err(
            "PLY vertex count 4e9 with properties",
            os(&[&"bench", &d("vertexprops.ply")]),
            &[&"vertexprops.ply", &"4000000000"],
        ),
        err(
            "PLY element count 2^64-1 without properties",
            os(&[&"bench", &d("junk2p64.ply")]),
            &[&"junk2p64.ply", &"no (non-degenerate) triangles"],
        ),
        err(
            "film 16384x16384",
            over(&base, "film1", r#"{"film":{"resolution":[16384,16384]}}"#),
            &[&"base.json", &"film.resolution", &"16384x16384", &"memory"],
        ),
        err(
            "film within --max-memory 1M",
            {
                let mut a = over(&base, "film2", r#"{"film":{"resolution":[1000,1000]}}"#);
                a.extend(os(&[&"--max-memory", &"1M"]));
                a
            },
            &[&"film.resolution", &"--max-memory"],
        ),
        err(
            "--max-memory nonsense",
            render(&base, &o("mm"), &["--max-memory", "lots"]),
            &[&"--max-memory"],
        ),
        err(
            "film with a huge filter reach and 1-pixel blocks",
            over(
                &base,
                "film3",
                r#"{"film":{"resolution":[4000,4000],"block_side_length":1,"filter":{"type":"box","radius":32}}}"#,
            ),
            &[&"film.resolution", &"memory"],
        ),
        // 4. outputs
        err(
            "output is a folder",
            render(&base, &d("folder.exr"), &[]),
            &[&"folder.exr", &"folder"],
        ),
        err(
            "output folder not writable",
            render(&base, Path::new("/proc/rdr-out.exr"), &[]),
            &[&"/proc/rdr-out.exr"],
        ),
        err("output folder missing", render(&base, &d("nowhere/out.exr"), &[]), &[&"nowhere"]),
        err(
            "scene named x.exr rendered without -o",
            os(&[&"render", &self_named]),
            &[&"selfnamed.exr", &"does not read an image as a scene"],
        ),
        err("-o the scene itself", render(&base, &base, &[]), &[&"base.json"]),
        // 5. hangs
        err(
            "box filter of radius 1e6",
            over(&base, "h1", r#"{"film":{"filter":{"type":"box","radius":1e6}}}"#),
            &[&"film.filter.radius"],
        ),
        image(
            "box filter of radius 32 (the largest) on a small film",
            over(&base, "h2", r#"{"film":{"filter":{"type":"box","radius":32}}}"#),
            &o("h2"),
            &[],
        ),
        image(
            "light_samples 2^31-1",
            {
                let s = edited("ls", &|v| {
                    v["integrator"]["light_samples"] = json!(2147483647);
                    v["objects"][0]["light"] = json!({"type": "area", "radiance": [1, 1, 1]});
                });
                render(&s, &o("ls"), &[]).into_iter().filter(|a| a != "-q").collect()
            },
            &o("ls"),
            &["light_samples"],
        ),
        image(
            "max_depth 2^31-1 inside glass",
            {
                let s = edited("md", &|v| v["integrator"]["max_depth"] = json!(2147483647));
                render(&s, &o("md"), &[]).into_iter().filter(|a| a != "-q").collect()
            },
            &o("md"),
            &["max_depth"],
        ),
        image(
            "a 300000-vertex polygon",
            {
                let s = edited("bigpoly", &|v| v["objects"][1]["path"] = json!("bigpoly.obj"));
                render(&s, &o("bigpoly"), &[]).into_iter().filter(|a| a != "-q").collect()
            },
            &o("bigpoly"),
            &["fan-triangulated"],
        ),
        err(
            "--threads 100000",
            render(&base, &o("t1"), &["--threads", "100000"]),
            &[&"--threads"],
        ),
        err(
            "bench --threads 100000",
            os(&[&"bench", &d("tri.obj"), &"--threads", &"100000"]),
            &[&"--threads"],
        ),
        err(
            "bench --repeat 2^32",
            os(&[&"bench", &d("tri.obj"), &"--repeat", &"4294967296"]),
            &[&"--repeat"],
        ),
        // 6. other
        err(
            "compare with a smaller variance image",
            os(&[&"compare", &d("img4.exr"), &d("img4.exr"), &"--variance", &d("img2.exr")]),
            &[&"img2.exr", &"2x2"],
        ),
        err(
            "compare with a larger variance image",
            os(&[&"compare", &d("img4.exr"), &d("img4.exr"), &"--variance", &d("img8.exr")]),
            &[&"img8.exr", &"8x8"],
        ),
        err(
            "/dev/zero as the scene",
            render(Path::new("/dev/zero"), &o("z1"), &[]),
            &[&"/dev/zero", &"not a regular file"],
        ),
        err(
            "/dev/zero as a mesh",
            render(&edited("zmesh", &|v| v["objects"][1]["path"] = json!("/dev/zero")), &o("z2"), &[]),
            &[&"objects[1].path", &"not a regular file"],
        ),
        err(
            "/dev/zero as a texture",
            render(&edited("ztex", &|v| textured(v, "/dev/zero")), &o("z3"), &[]),
            &[&"textures.img.path", &"not a regular file"],
        ),
        err(
            "/dev/zero in compare",
            os(&[&"compare", &"/dev/zero", &d("img4.exr")]),
            &[&"/dev/zero", &"not a regular file"],
        ),
        err(
            "/dev/zero in bench",
            os(&[&"bench", &"/dev/zero"]),
            &[&"/dev/zero", &"not a regular file"],
        ),
        err(
            "a folder as a texture",
            render(&edited("dtex", &|v| textured(v, ".")), &o("z4"), &[]),
            &[&"textures.img.path", &"folder"],
        ),
        // 7. silent or misleading
        err(
            "gaussian alpha 0",
            over(&base, "g1", r#"{"film":{"filter":{"type":"gaussian","radius":1.5,"alpha":0}}}"#),
            &[&"film.filter.alpha"],
        ),
        err(
            "gaussian alpha 1e-12",
            over(&base, "g2", r#"{"film":{"filter":{"type":"gaussian","radius":1.5,"alpha":1e-12}}}"#),
            &[&"film.filter.alpha"],
        ),
        err(
            "gaussian alpha 1e6",
            over(&base, "g3", r#"{"film":{"filter":{"type":"gaussian","radius":1.5,"alpha":1e6}}}"#),
            &[&"film.filter.alpha"],
        ),
        err(
            "camera at [0,1,1e20] is blamed on the position",
            over(&cornell, "c4", r#"{"camera":{"position":[0,1,1e20]}}"#),
            &[&"camera.position"],
        ),
        err(
            "a huge valid triangle is not called degenerate",
            render(
                &edited("hugetri", &|v| {
                    v["objects"] = json!([{"type": "mesh", "path": "huge_tri.obj", "material_name": "matte"}]);
                }),
                &o("hugetri"),
                &[],
            ),
            &[&"huge_tri.obj", &"too large"],
        ),
        err("unknown flag", render(&base, &o("p1"), &["--bogus"]), &[&"--bogus"]),
        err("bad --spp value", render(&base, &o("p2"), &["--spp", "many"]), &[&"many"]),
        err("no subcommand", vec![], &[&"subcommand"]),
        err("unknown subcommand", os(&[&"paint"]), &[&"paint"]),
        err(
            "control characters in a name",
            render(
                &edited("ctl", &|v| {
                    v["objects"][0]["material_name"] = json!("\u{1b}[2J\u{1b}[31mred\r");
                }),
                &o("ctl"),
                &[],
            ),
            &[&"objects[0].material_name", &"\\u{1b}[2J"],
        ),
        // 8. issue 42
        err(
            "XML nested 8,000 deep",
            render(&d("deep.xml"), &o("deep1"), &[]),
            &[&"deep.xml", &"line 1, column 321", &"nested deeper than 100"],
        ),
        err(
            "XML nested 8,000 deep, converted",
            os(&[&"convert", &d("deep.xml"), &"-o", &d("deep.json")]),
            &[&"deep.xml", &"line 1, column 321", &"nested deeper than 100"],
        ),
        image(
            "XML with 150,000 <float> elements (5 MB)",
            render(&d("floats.xml"), &o("floats"), &[]),
            &o("floats"),
            &[],
        ),
        image(
            "XML with 20,000 instances",
            render(&d("instances.xml"), &o("instances"), &[]),
            &o("instances"),
            &[],
        ),
        image(
            "a sky with NaN, infinite and negative texels",
            {
                let s = edited("nansky", &|v| {
                    v["textures"]["sky"] = json!({"type": "image", "path": "sky.exr", "tex_coordinate_generator": {"type": "uvmapping2d"}});
                    v["environment_map"] = json!({"texture_name": "sky"});
                });
                render(&s, &o("nansky"), &[]).into_iter().filter(|a| a != "-q").collect()
            },
            &o("nansky"),
            &["sky.exr: environment map with 2 NaN or infinite and 1 negative texel(s) of 8"],
        ),
        image(
            "a material texture with NaN and infinite texels",
            {
                let s = edited("nantex", &|v| {
                    textured(v, "sky.exr");
                    v["integrator"] = json!({"type": "path", "spp": 4});
                });
                render(&s, &o("nantex"), &[]).into_iter().filter(|a| a != "-q").collect()
            },
            &o("nantex"),
            &["sky.exr: image texture with 2 NaN or infinite texel(s) of 8; they are read as black"],
        ),
        err(
            "an XML element with 300,000 attributes (3.5 MB)",
            render(&d("attrs.xml"), &o("attrs"), &[]),
            &[&"attrs.xml", &"line 4, column 1", &"<shape> has more than 100 attributes"],
        ),
        err(
            "XML with 150,000 <float> elements under a 64 MB budget",
            render(&d("floats.xml"), &o("floats64"), &["--max-memory", "64M"]),
            &[&"floats.xml", &"150011 elements", &"more than the 67 MB allowed", &"--max-memory"],
        ),
        err(
            "a JSON scene with 3,000,000 numbers (6 MB) under a 64 MB budget",
            render(&d("zeros.json"), &o("zeros"), &["--max-memory", "64M"]),
            &[&"zeros.json", &"reading its JSON", &"more than the 67 MB allowed"],
        ),
        err(
            "serialized mesh with a corrupt zlib stream",
            render(&serialized_scene("corrupt"), &o("corrupt"), &[]),
            &[&"corrupt.serialized", &"compressed mesh data is corrupt"],
        ),
        err(
            "a serialized mesh of about 460 KB claiming 30M vertices and 60M triangles",
            // a budget that lets the counts through: the stream's size must refuse them
            render(&serialized_scene("lying"), &o("lying"), &["--max-memory", "16G"]),
            &[&"lying.serialized", &"30000000 vertices", &"more than its"],
        ),
        err(
            "-o one of the scene's textures",
            render(&edited("ownertex", &|v| textured(v, "img4.exr")), &d("img4.exr"), &[]),
            &[&"img4.exr", &"one of the scene's files"],
        ),
        err(
            "-o the scene's mesh through a symbolic link",
            render(&base, &d("trilink.obj"), &[]),
            &[&"trilink.obj", &"tri.obj", &"one of the scene's files"],
        ),
        err(
            "merge -o one of its parts",
            os(&[&"merge", &d("part0.exr"), &d("part1.exr"), &"-o", &d("part1.exr")]),
            &[&"part1.exr", &"one of the parts merged"],
        ),
    ];
    c.extend(media_cases(dir));
    if have_fifo {
        c.push(err(
            "a FIFO as the mesh",
            render(
                &edited("fifomesh", &|v| v["objects"][1]["path"] = json!("fifo.obj")),
                &o("ff1"),
                &[],
            ),
            &[&"fifo.obj", &"not a regular file"],
        ));
        c.push(err(
            "a FIFO as the scene",
            render(&fifo, &o("ff2"), &[]),
            &[&"fifo.obj", &"does not read a mesh as a scene"],
        ));
        c.push(err(
            "a FIFO in compare",
            os(&[&"compare", &fifo, &d("img4.exr")]),
            &[&"fifo.obj", &"not a regular file"],
        ));
        c.push(err(
            "a FIFO in bench",
            os(&[&"bench", &fifo]),
            &[&"fifo.obj", &"not a regular file"],
        ));
    }
    c
}

/// Issue 38's bad media: grid files that lie about their size or hold NaN or negative
/// densities, majorants that do not bound, parameters out of range, in XML and JSON.
fn media_cases(dir: &Path) -> Vec<Case> {
    let d = |n: &str| dir.join(n);
    let values: Vec<f32> = (0..64).map(|i| (i % 7) as f32).collect();
    let bbox = rdr::geometry::Aabb::new(rdr::math::Vec3::ZERO, rdr::math::Vec3::ONE);
    let good = rdr::volume::vol_file::encode(&rdr::volume::GridData::new([4, 4, 4], 1, bbox, values).unwrap());
    let with = |at: usize, bytes: &[u8]| {
        let mut b = good.clone();
        b[at..at + bytes.len()].copy_from_slice(bytes);
        b
    };
    std::fs::write(d("good.vol"), &good).unwrap();
    // 1000³ voxels claimed by a 304-byte file
    let mut lying = with(8, &1000i32.to_le_bytes());
    lying[12..16].copy_from_slice(&1000i32.to_le_bytes());
    lying[16..20].copy_from_slice(&1000i32.to_le_bytes());
    std::fs::write(d("lying.vol"), lying).unwrap();
    std::fs::write(d("nan.vol"), with(48 + 4 * 9, &f32::NAN.to_le_bytes())).unwrap();
    std::fs::write(d("negative.vol"), with(48 + 4 * 9, &(-2.0f32).to_le_bytes())).unwrap();
    // 1e30 beside values up to 6 in one majorant cell: delta tracking would stall there
    std::fs::write(d("dense.vol"), with(48 + 4 * 9, &1e30f32.to_le_bytes())).unwrap();
    // the first root child of "density" moved 2^30 voxels away: a box of 2^90 voxels
    let mut vdb = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/vdb/small_raw.vdb")).unwrap();
    let t = vdb.windows(24).position(|w| w == b"UniformScaleTranslateMap").unwrap() + 24 + 18 * 8;
    vdb[t + 16..t + 20].copy_from_slice(&(1i32 << 30).to_le_bytes());
    std::fs::write(d("lying.vdb"), vdb).unwrap();
    let xml = |name: &str, medium: &str| {
        let p = d(&format!("{name}.xml"));
        let body = format!(
            r#"<integrator type="volpath"/><shape type="cube"><bsdf type="null"/><medium type="heterogeneous" name="interior">{medium}</medium></shape>"#
        );
        std::fs::write(&p, mitsuba(&body)).unwrap();
        p
    };
    let grid = |file: &str, extra: &str| {
        format!(r#"<volume type="gridvolume" name="sigma_t"><string name="filename" value="{file}"/>{extra}</volume>"#)
    };
    let render = |s: PathBuf, out: &str, extra: &[&str]| {
        let mut a = os(&[&"render", &s, &"-o", &d(&format!("{out}.exr")), &"-q", &"--spp", &"1"]);
        a.extend(extra.iter().map(OsString::from));
        a
    };
    let base = d("base.json");
    let json = |out: &str, media: &str| render(base.clone(), out, &["--override", media]);
    vec![
        err(
            "a .vol claiming 1000³ voxels in 304 bytes",
            render(xml("vol_lying", &grid("lying.vol", "")), "m1", &[]),
            &[&"vol_lying.xml", &"filename", &"lying.vol"],
        ),
        err(
            "a .vol holding NaN",
            render(xml("vol_nan", &grid("nan.vol", "")), "m2", &[]),
            &[&"vol_nan.xml", &"filename", &"nan.vol", &"NaN"],
        ),
        err(
            "a .vol holding a negative density",
            render(xml("vol_negative", &grid("negative.vol", "")), "m3", &[]),
            &[&"vol_negative.xml", &"filename", &"negative.vol", &"not negative"],
        ),
        err(
            "a .vol holding 1e30 beside thin densities",
            render(xml("vol_dense", &grid("dense.vol", "")), "m3d", &[]),
            &[&"vol_dense.xml", &"\"sigma_t\"", &"optical depth"],
        ),
        err(
            "JSON: a .vol holding 1e30 beside thin densities",
            json(
                "m3j",
                r#"{"media": {"smoke": {"type": "heterogeneous", "sigma_t": {"type": "gridvolume", "filename": "dense.vol"}}}}"#,
            ),
            &[&"base.json", &"media.smoke.sigma_t", &"optical depth"],
        ),
        err(
            "a .vdb claiming 2^90 voxels",
            render(xml("vdb_lying", &grid("lying.vdb", "")), "m4", &[]),
            &[&"vdb_lying.xml", &"filename", &"lying.vdb", &"memory"],
        ),
        err(
            "max_value 0 under densities up to 6",
            render(
                xml("max_zero", &grid("good.vol", r#"<float name="max_value" value="0"/>"#)),
                "m5",
                &[],
            ),
            &[&"max_zero.xml", &"max_value"],
        ),
        err(
            "max_value NaN",
            render(
                xml("max_nan", &grid("good.vol", r#"<float name="max_value" value="nan"/>"#)),
                "m6",
                &[],
            ),
            &[&"max_nan.xml", &"max_value"],
        ),
        err(
            "hg g = 1",
            render(xml("g_one", r#"<phase type="hg"><float name="g" value="1"/></phase>"#), "m7", &[]),
            &[&"g_one.xml", &"\"g\""],
        ),
        err(
            "albedo 1.5",
            render(xml("albedo_high", r#"<float name="albedo" value="1.5"/>"#), "m8", &[]),
            &[&"albedo_high.xml", &"\"albedo\""],
        ),
        err(
            "albedo from a grid up to 6",
            render(xml("albedo_grid", &grid("good.vol", "").replace("sigma_t", "albedo")), "m9", &[]),
            &[&"albedo_grid.xml", &"\"albedo\""],
        ),
        err(
            "sigma_t × scale overflowing",
            render(
                xml(
                    "overflow",
                    r#"<float name="sigma_t" value="1e30"/><float name="scale" value="1e30"/>"#,
                ),
                "m10",
                &[],
            ),
            &[&"overflow.xml", &"\"scale\""],
        ),
        err(
            "JSON: a .vol claiming 1000³ voxels",
            json(
                "m11",
                r#"{"media": {"smoke": {"type": "heterogeneous", "sigma_t": {"type": "gridvolume", "filename": "lying.vol"}}}}"#,
            ),
            &[&"base.json", &"media.smoke.sigma_t.filename", &"lying.vol"],
        ),
        err(
            "JSON: max_value 0",
            json(
                "m12",
                r#"{"media": {"smoke": {"type": "heterogeneous", "sigma_t": {"type": "gridvolume", "filename": "good.vol", "max_value": 0}}}}"#,
            ),
            &[&"base.json", &"media.smoke.sigma_t.max_value"],
        ),
        err(
            "JSON: g = -1",
            json(
                "m13",
                r#"{"media": {"fog": {"type": "homogeneous", "phase": {"type": "hg", "g": -1}}}}"#,
            ),
            &[&"base.json", &"media.fog.phase.g"],
        ),
        err(
            "JSON: albedo -0.1",
            json("m14", r#"{"media": {"fog": {"type": "homogeneous", "albedo": [0.5, -0.1, 0.5]}}}"#),
            &[&"base.json", &"media.fog.albedo"],
        ),
        err(
            "JSON: radiance -1",
            json("m15", r#"{"media": {"fog": {"type": "homogeneous", "radiance": -1}}}"#),
            &[&"base.json", &"media.fog.radiance"],
        ),
        err(
            "JSON: sigma_t × scale overflowing",
            json(
                "m16",
                r#"{"media": {"fog": {"type": "homogeneous", "sigma_t": 1e30, "scale": 1e30}}}"#,
            ),
            &[&"base.json", &"media.fog.scale"],
        ),
    ]
}

#[test]
fn hostile_inputs_end_quickly_with_one_error_line_or_a_correct_image() {
    let t0 = Instant::now();
    let tmp = common::temp_dir("rdr-hostile");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("base.json"), BASE).unwrap();
    let cases = cases(&dir);
    let self_named = std::fs::read(dir.join("selfnamed.exr")).unwrap();
    let mut failures = Vec::new();
    let mut slowest = (0.0, "");
    for c in &cases {
        let r = run(&c.args);
        if r.seconds > slowest.0 {
            slowest = (r.seconds, c.name);
        }
        let problems = check(&r, &c.expect);
        if !problems.is_empty() {
            failures.push(format!(
                "case '{}' ({:.1} s): {}\n  stderr: {}\n  stdout: {}",
                c.name,
                r.seconds,
                problems.join("; "),
                r.stderr.trim_end().replace('\n', "\n          "),
                r.stdout.trim_end()
            ));
        }
    }
    assert_eq!(
        std::fs::read(dir.join("selfnamed.exr")).unwrap(),
        self_named,
        "the scene x.exr was overwritten"
    );
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind: {leftovers:?}");
    let total = t0.elapsed().as_secs_f64();
    eprintln!(
        "{} cases in {total:.1} s (slowest: '{}', {:.1} s)",
        cases.len(),
        slowest.1,
        slowest.0
    );
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
    assert!(total < 60.0, "the table took {total:.1} s (at most 60)");
}

/// A long render: 64×64 at a huge spp, stopped by a signal or a time limit.
fn long_render(dir: &Path, out: &Path, extra: &[&str]) -> Command {
    let s = scene(dir, "long", |v| v["film"]["resolution"] = json!([64, 64]));
    let mut a = os(&[&"render", &s, &"-o", &out, &"--spp", &"1000000"]);
    a.extend(extra.iter().map(OsString::from));
    let mut c = command(&a);
    c.stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

#[test]
fn sigterm_and_sighup_save_the_finished_passes() {
    let tmp = common::temp_dir("rdr-hostile-signals");
    let dir = tmp.path();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    for sig in ["TERM", "HUP", "INT"] {
        let out = dir.join(format!("sig{sig}.exr"));
        let start = Instant::now();
        let child = long_render(dir, &out, &[]).spawn().unwrap();
        std::thread::sleep(Duration::from_millis(700));
        // prlimit execs the binary, so the pid is rdr's
        let ok = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(ok.success());
        let r = finish(child, start);
        assert_eq!(r.code, Some(130), "SIG{sig}: exit {:?} signal {:?}\n{}", r.code, r.signal, r.stderr);
        assert!(r.stderr.contains("interrupted"), "SIG{sig}: {}", r.stderr);
        let img = rdr::imageio::read_exr(&out).unwrap_or_else(|e| panic!("SIG{sig}: no image: {e:#}"));
        assert_eq!((img.width, img.height), (64, 64));
        assert!(r.seconds < 10.0);
    }
}

/// Two signals close together (`timeout` signals rdr and then its process group; a
/// closing terminal sends SIGHUP and SIGTERM): the finished passes are saved all the same.
/// The film is large enough that its save takes longer than the gap.
#[test]
fn a_signal_twice_still_saves_the_finished_passes() {
    let tmp = common::temp_dir("rdr-hostile-twice");
    let dir = tmp.path();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    let s = scene(dir, "twice", |v| v["film"]["resolution"] = json!([512, 512]));
    for gap_ms in [2, 20, 100] {
        let out = dir.join(format!("twice{gap_ms}.exr"));
        let start = Instant::now();
        let mut c = command(&os(&[&"render", &s, &"-o", &out, &"--spp", &"1000000"]));
        let child = c.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        std::thread::sleep(Duration::from_millis(1000));
        for _ in 0..2 {
            let ok = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap();
            assert!(ok.success());
            std::thread::sleep(Duration::from_millis(gap_ms));
        }
        let r = finish(child, start);
        assert_eq!(
            r.code,
            Some(130),
            "gap {gap_ms} ms: exit {:?} signal {:?}\n{}",
            r.code,
            r.signal,
            r.stderr
        );
        assert!(!r.stderr.contains("not saved"), "gap {gap_ms} ms: {}", r.stderr);
        let img = rdr::imageio::read_exr(&out).unwrap_or_else(|e| panic!("gap {gap_ms} ms: no image: {e:#}\n{}", r.stderr));
        assert_eq!((img.width, img.height), (512, 512));
        let state = rdr::render::statefile::read(&rdr::render::statefile::state_path(&out)).unwrap();
        assert!(
            state.is_some_and(|f| f.state.passes_done() > 0),
            "gap {gap_ms} ms: no passes in the state file"
        );
    }
}

/// A tev viewer that accepts the connection and never reads: the render ends when it
/// would without the viewer, with a warning, and its image is saved.
#[test]
fn a_stalled_tev_viewer_costs_the_render_nothing() {
    let tmp = common::temp_dir("rdr-hostile-tev");
    let dir = tmp.path();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    // 1024x1024: one update (12 MB) is more than the socket buffers hold
    let s = scene(dir, "tev", |v| v["film"]["resolution"] = json!([1024, 1024]));
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        if let Ok((stream, _)) = listener.accept() {
            let _ = tx.send(stream);
        }
    });
    let limit = "2";
    let time = |extra: &[&str]| {
        let out = dir.join(format!("tev{}.exr", extra.len()));
        let mut a = os(&[&"render", &s, &"-o", &out, &"--spp", &"1000000", &"--time-limit", &limit]);
        a.extend(extra.iter().map(OsString::from));
        let r = run(&a);
        assert_eq!(r.code, Some(0), "{extra:?}: exit {:?}, {:.1} s\n{}", r.code, r.seconds, r.stderr);
        assert!(rdr::imageio::read_exr(&out).is_ok(), "{extra:?}: no image");
        r
    };
    let plain = time(&[]);
    let stalled = time(&["--tev", &addr]);
    // held open, never read, until here
    let viewer = rx.recv_timeout(Duration::from_secs(1));
    assert!(viewer.is_ok(), "rdr never connected");
    eprintln!(
        "time-limited render: {:.2} s alone, {:.2} s with a stalled viewer",
        plain.seconds, stalled.seconds
    );
    assert!(stalled.stderr.contains("warning: --tev:"), "{}", stalled.stderr);
    assert!(
        stalled.seconds < plain.seconds + 3.0,
        "{:.1} s with a stalled viewer, {:.1} s without",
        stalled.seconds,
        plain.seconds
    );
}

#[test]
fn closed_stdout_and_full_stderr_end_quietly() {
    let tmp = common::temp_dir("rdr-hostile-pipes");
    let dir = tmp.path();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    let s = scene(dir, "pipe", |_| {});
    // `rdr render … | true`: the reader is gone before the path is printed
    let out = dir.join("pipe.exr");
    let start = Instant::now();
    let mut child = command(&os(&[&"render", &s, &"-o", &out]))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let r = finish(child, start);
    assert_eq!(r.code, Some(0), "closed stdout: {}", r.stderr);
    assert!(!r.stderr.contains("panicked") && !r.stderr.contains("error"), "{}", r.stderr);
    assert!(out.is_file());
    // a full stderr: warnings and errors cannot be printed, the exit status still tells
    for (scene, code) in [(s.clone(), 0), (dir.join("missing.json"), 1)] {
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
        let status = command(&os(&[&"render", &scene, &"-o", &dir.join("full.exr")]))
            .stdout(Stdio::null())
            .stderr(full)
            .status()
            .unwrap();
        assert_eq!(status.code(), Some(code), "full stderr, scene {}", scene.display());
    }
}

#[test]
fn concurrent_renders_to_one_output_both_succeed_with_a_whole_image() {
    let tmp = common::temp_dir("rdr-hostile-concurrent");
    let dir = tmp.path();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    let a = scene(dir, "a", |v| v["film"]["resolution"] = json!([48, 48]));
    let b = scene(dir, "b", |v| {
        v["film"]["resolution"] = json!([48, 48]);
        v["textures"]["white"]["color"] = json!([0.2, 0.9, 0.2]);
    });
    let out = dir.join("shared.exr");
    // a planted link at the old, predictable temporary name must never be followed
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    std::os::unix::fs::symlink(&victim, dir.join("shared.exr.partial")).unwrap();
    std::os::unix::fs::symlink(&victim, dir.join("shared.exr.exr.partial")).unwrap();
    // the two images, rendered alone (renders are deterministic)
    let mut refs = Vec::new();
    for (sc, name) in [(&a, "ref_a.exr"), (&b, "ref_b.exr")] {
        let r = run(&os(&[&"render", sc, &"-o", &dir.join(name), &"-q", &"--spp", &"8"]));
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        refs.push(rdr::imageio::read_exr(&dir.join(name)).unwrap().pixels);
    }
    assert_ne!(refs[0], refs[1]);
    for round in 0..3 {
        let start = Instant::now();
        let spawn = |sc: &Path| {
            command(&os(&[&"render", &sc, &"-o", &out, &"-q", &"--spp", &"8"]))
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (ca, cb) = (spawn(&a), spawn(&b));
        let (ra, rb) = (finish(ca, start), finish(cb, start));
        assert_eq!(
            (ra.code, rb.code),
            (Some(0), Some(0)),
            "round {round}: {} / {}",
            ra.stderr,
            rb.stderr
        );
        let img = rdr::imageio::read_exr(&out).unwrap();
        assert!(
            img.pixels == refs[0] || img.pixels == refs[1],
            "round {round}: the image is neither render whole"
        );
    }
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious", "a planted link was followed");
    let leftovers = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".shared.exr."))
        .count();
    assert_eq!(leftovers, 0, "temporary files left behind");
}

#[test]
fn an_image_whose_output_vanished_is_saved_in_the_temp_folder() {
    let tmp = common::temp_dir("rdr-hostile-lost");
    let dir = tmp.path();
    std::fs::write(dir.join("tri.obj"), TRI_OBJ).unwrap();
    let outdir = dir.join("out");
    std::fs::create_dir(&outdir).unwrap();
    let spill = dir.join("spill");
    std::fs::create_dir(&spill).unwrap();
    let out = outdir.join("lost.exr");
    let start = Instant::now();
    let child = long_render(dir, &out, &["--time-limit", "1.5", "-q"])
        .env("TMPDIR", &spill)
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    std::fs::remove_dir_all(&outdir).unwrap();
    let r = finish(child, start);
    assert_eq!(r.code, Some(1), "{}", r.stderr);
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{}", r.stderr);
    assert!(
        lines[0].starts_with("error: ")
            && lines[0].contains("lost.exr")
            && lines[0].contains("lost.state.exr")
            && lines[0].contains("saved to"),
        "{}",
        r.stderr
    );
    // the image and its state file, each named in the error
    let mut saved: Vec<PathBuf> = std::fs::read_dir(&spill)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .collect();
    saved.sort();
    assert_eq!(saved.len(), 2, "{saved:?}");
    for s in &saved {
        assert!(lines[0].contains(&*s.to_string_lossy()), "{} not named: {}", s.display(), lines[0]);
        let img = rdr::imageio::read_exr(s).unwrap();
        assert_eq!((img.width, img.height), (64, 64));
    }
    let state = saved.iter().filter_map(|s| rdr::render::statefile::read(s).unwrap()).count();
    assert_eq!(state, 1, "one of them holds the film state");
}
