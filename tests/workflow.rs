//! Long renders as people run them (issue 16): `--resume`, `--checkpoint` (and a
//! SIGKILL), `--shard K/N` with `rdr merge`, and the refusals when parts do not
//! belong together. Every comparison is against one uninterrupted render of the same
//! passes, through the binary, at small resolutions; the bundled scenes only (no
//! ../shared needed).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn rdr() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rdr"))
}

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// Small renders of the bundled scenes with an integrator of each kind.
const SMALL: &str = r#"{"film":{"resolution":[40,28]}}"#;

struct Case {
    name: &'static str,
    scene: &'static str,
    overrides: &'static str,
}

/// `path` on the textured, gaussian-filtered showcase (image textures: the footprint
/// matters), `intersection_test` on the Cornell box, `bdpt` and `ptracer` (splats).
const CASES: [Case; 4] = [
    Case {
        name: "path",
        scene: "showcase.json",
        overrides: r#"{"integrator":{"max_depth":4}}"#,
    },
    Case {
        name: "intersection_test",
        scene: "cornell.json",
        overrides: "{}",
    },
    Case {
        name: "bdpt",
        scene: "cornell.json",
        overrides: r#"{"integrator":{"type":"bdpt","max_depth":4}}"#,
    },
    Case {
        name: "ptracer",
        scene: "showcase.json",
        overrides: r#"{"integrator":{"type":"ptracer","max_depth":3}}"#,
    },
];

fn run(mut cmd: Command) -> Output {
    cmd.output().expect("rdr runs")
}

fn render(case: &Case, out: &Path, extra: &[&str]) -> Output {
    let mut c = rdr();
    c.arg("render")
        .arg(scene(case.scene))
        .args(["--override", SMALL, "--override", case.overrides, "-q", "--threads", "2", "-o"])
        .arg(out)
        .args(extra);
    run(c)
}

fn ok(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "{what} failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The one `error:` line of a refused command (status 1, nothing else on stderr).
fn refused(o: &Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{what} should be refused, got {}: {err}", o.status);
    let lines: Vec<&str> = err.lines().collect();
    assert!(
        lines.len() == 1 && lines[0].starts_with("error: "),
        "{what}: expected one error line, got {err:?}"
    );
    lines[0].to_string()
}

/// Asserts two outputs are the same file; on failure says how many pixels differ
/// (and by how much), or that only the saved state does.
fn assert_same(a: &Path, b: &Path, what: &str) {
    let (x, y) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    if x == y {
        return;
    }
    let (p, q) = (common::read(a), common::read(b));
    let (mut n, mut worst) = (0, 0.0f32);
    for (u, v) in p.pixels.iter().zip(&q.pixels) {
        if u != v {
            n += 1;
            worst = worst.max(((*u - *v).abs() / (v.abs() + rdr::math::Vec3::splat(1e-6))).max_element());
        }
    }
    panic!(
        "{what}: {} and {} differ: {n} of {} pixels (largest relative difference {worst:.3e}){}",
        a.display(),
        b.display(),
        p.pixels.len(),
        if n == 0 { "; the film state differs" } else { "" }
    );
}

#[test]
fn resume_gives_the_bits_of_one_render() {
    let dir = common::temp_dir("rdr-resume");
    for case in &CASES {
        let full = dir.path().join(format!("{}_full.exr", case.name));
        ok(&render(case, &full, &["--spp", "40"]), "full render");
        // a finished render asked for more, across a block boundary, then a resume
        // from mid-block to the end
        let part = dir.path().join(format!("{}_part.exr", case.name));
        ok(&render(case, &part, &["--spp", "9"]), "first 9 passes");
        ok(&render(case, &part, &["--spp", "21", "--resume"]), "resume to 21");
        ok(&render(case, &part, &["--spp", "40", "--resume"]), "resume to 40");
        assert_same(&part, &full, &format!("{}: 9 → 21 → 40 passes", case.name));
        // asked again: nothing to do, file untouched
        let before = std::fs::read(&part).unwrap();
        ok(&render(case, &part, &["--spp", "40", "--resume"]), "resume when done");
        assert_eq!(std::fs::read(&part).unwrap(), before);
    }
    // --resume without the file starts afresh (the first run of a requeued job)
    let fresh = dir.path().join("fresh.exr");
    ok(&render(&CASES[1], &fresh, &["--spp", "40", "--resume"]), "resume without a file");
    assert_same(&fresh, &dir.path().join("intersection_test_full.exr"), "resume from nothing");
}

#[test]
fn shards_merge_into_the_bits_of_one_render() {
    let dir = common::temp_dir("rdr-shards");
    for case in &CASES[..3] {
        let full = dir.path().join(format!("{}_full.exr", case.name));
        ok(&render(case, &full, &["--spp", "72"]), "full render");
        for n in [2, 3] {
            let mut parts = Vec::new();
            for k in 0..n {
                let p = dir.path().join(format!("{}_{k}of{n}.exr", case.name));
                ok(&render(case, &p, &["--spp", "72", "--shard", &format!("{k}/{n}")]), "shard");
                parts.push(p);
            }
            // given in any order
            parts.reverse();
            let merged = dir.path().join(format!("{}_merged{n}.exr", case.name));
            let mut c = rdr();
            c.arg("merge").args(&parts).arg("-o").arg(&merged).arg("-q");
            ok(&run(c), "merge");
            assert_same(&merged, &full, &format!("{}: {n} shards merged", case.name));
        }
    }
    // a shard interrupted and resumed still merges to the same bits
    let case = &CASES[2];
    let p0 = dir.path().join("r0.exr");
    ok(
        &render(case, &p0, &["--spp", "72", "--shard", "0/2", "--time-limit", "0.000001"]),
        "cut shard",
    );
    ok(&render(case, &p0, &["--spp", "72", "--shard", "0/2", "--resume"]), "resumed shard");
    let merged = dir.path().join("r.exr");
    let mut c = rdr();
    c.arg("merge").arg(&p0).arg(dir.path().join("bdpt_1of2.exr")).arg("-o").arg(&merged);
    ok(&run(c), "merge resumed shard");
    assert_same(&merged, &dir.path().join("bdpt_full.exr"), "resumed shard merged");
}

#[test]
fn parts_that_do_not_belong_together_are_refused() {
    let dir = common::temp_dir("rdr-refuse");
    let case = &CASES[1];
    let d = |n: &str| dir.path().join(n);
    let shard = |k: u32, n: u32, spp: &str, extra: &[&str]| {
        let p = d(&format!("s{k}of{n}_{spp}{}.exr", extra.join("")));
        let s = format!("{k}/{n}");
        let mut args = vec!["--spp", spp, "--shard", &s];
        args.extend(extra);
        ok(&render(case, &p, &args), "shard");
        p
    };
    let (a, b, c) = (shard(0, 3, "48", &[]), shard(1, 3, "48", &[]), shard(2, 3, "48", &[]));
    let merge = |parts: &[&PathBuf], extra: &[&str]| {
        let mut m = rdr();
        m.arg("merge").args(parts).arg("-o").arg(d("m.exr")).args(extra);
        run(m)
    };
    let gap = refused(&merge(&[&a, &c], &[]), "a gap");
    assert!(gap.contains("16-32") && gap.contains("missing"), "{gap}");
    let o = merge(&[&a, &c], &["--partial"]);
    ok(&o, "--partial");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("16-32"),
        "--partial says what is missing"
    );
    let overlap = refused(&merge(&[&a, &b, &a], &[]), "an overlap");
    assert!(overlap.contains("overlap"), "{overlap}");
    let other_seed = shard(1, 3, "48", &["--seed", "5"]);
    let seed = refused(&merge(&[&a, &other_seed, &c], &[]), "another seed");
    assert!(seed.contains("seed"), "{seed}");
    let other_spp = shard(1, 2, "64", &[]);
    refused(&merge(&[&a, &other_spp], &[]), "another spp");

    // resume refusals leave the file as it was
    let out = d("r.exr");
    ok(&render(case, &out, &["--spp", "8"]), "render");
    let before = std::fs::read(&out).unwrap();
    let refusals: [(&[&str], &str); 5] = [
        (&["--spp", "16", "--seed", "1"], "seed"),
        (&["--spp", "16", "--override", r#"{"camera":{"fov":40}}"#], "scene"),
        (&["--spp", "16", "--override", r#"{"integrator":{"type":"path"}}"#], "integrator"),
        (&["--spp", "16", "--shard", "0/2"], "shard"),
        (&["--spp", "4"], "more than"),
    ];
    for (extra, says) in refusals {
        let mut args = vec!["--resume"];
        args.extend(extra);
        let e = refused(&render(case, &out, &args), says);
        assert!(e.contains(says), "{e}");
        assert_eq!(std::fs::read(&out).unwrap(), before, "refused resume must not touch the file");
    }
    // a changed asset: the showcase with its texture edited
    let copy = d("show");
    std::fs::create_dir_all(copy.join("showcase")).unwrap();
    std::fs::copy(scene("showcase.json"), copy.join("showcase.json")).unwrap();
    for f in std::fs::read_dir(scene("showcase")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, copy.join("showcase").join(f.file_name().unwrap())).unwrap();
    }
    let show = |out: &Path, extra: &[&str]| {
        let mut c = rdr();
        c.arg("render")
            .arg(copy.join("showcase.json"))
            .args(["--override", SMALL, "--override", CASES[0].overrides, "-q", "-o"])
            .arg(out)
            .args(extra);
        run(c)
    };
    let s = d("show.exr");
    ok(&show(&s, &["--spp", "2"]), "showcase");
    let tiles = copy.join("showcase/tiles.png");
    let mut bytes = std::fs::read(&tiles).unwrap();
    bytes.push(0);
    std::fs::write(&tiles, bytes).unwrap();
    let e = refused(&show(&s, &["--spp", "4", "--resume"]), "changed asset");
    assert!(e.contains("asset"), "{e}");

    // integrators whose passes depend on earlier ones, and the compat profile
    for (ty, flag) in [("sppm", "--shard"), ("photon", "--shard"), ("sppm", "--resume")] {
        let ov = format!(r#"{{"integrator":{{"type":"{ty}"}}}}"#);
        let mut args = vec!["--spp", "2", "--override", &ov, flag];
        if flag == "--shard" {
            args.push("0/2");
        }
        let e = refused(&render(case, &d("x.exr"), &args), ty);
        assert!(e.contains(ty) && e.contains("depend on earlier"), "{e}");
    }
    for flag in [&["--shard", "0/2"][..], &["--resume"]] {
        let mut args = vec!["--compat", "rdr171"];
        args.extend(flag);
        let e = refused(&render(case, &d("c.exr"), &args), "compat");
        assert!(e.contains("rdr171"), "{e}");
    }
    refused(&render(case, &d("x.png"), &["--resume"]), "png resume");
    refused(&render(case, &d("x.exr"), &["--shard", "3/3"]), "bad shard");
}

/// A render killed with SIGKILL after a checkpoint resumes to the bits of one render.
#[test]
fn sigkill_after_a_checkpoint_resumes_to_the_same_bits() {
    let dir = common::temp_dir("rdr-kill");
    let case = Case {
        name: "path",
        scene: "cornell.json",
        overrides: r#"{"integrator":{"type":"path","max_depth":6},"film":{"resolution":[48,48]}}"#,
    };
    let spp = "300";
    let full = dir.path().join("full.exr");
    let t = Instant::now();
    ok(&render(&case, &full, &["--spp", spp]), "full render");
    let full_s = t.elapsed().as_secs_f64();
    let out = dir.path().join("killed.exr");
    let mut child = rdr()
        .arg("render")
        .arg(scene(case.scene))
        .args([
            "--override",
            SMALL,
            "--override",
            case.overrides,
            "-q",
            "--threads",
            "2",
            "--spp",
            spp,
        ])
        .args(["--checkpoint", "0.05", "-o"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // kill it once a checkpoint holds some passes but not all
    let deadline = Instant::now() + Duration::from_secs(30);
    let held = loop {
        if let Ok(Some(f)) = rdr::render::statefile::read(&out) {
            let n = f.state.passes_done();
            if n > 0 {
                break n;
            }
        }
        assert!(Instant::now() < deadline, "no checkpoint within 30 s");
        std::thread::sleep(Duration::from_millis(5));
    };
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let after = rdr::render::statefile::read(&out).unwrap().expect("a whole checkpoint");
    assert!(
        after.state.passes_done() < 300,
        "the render finished before the kill ({full_s:.2} s for all passes): make it longer"
    );
    eprintln!("killed with {} passes checkpointed (first seen {held})", after.state.passes_done());
    ok(&render(&case, &out, &["--spp", spp, "--resume"]), "resume after SIGKILL");
    assert_same(&out, &full, "killed and resumed");
}

#[test]
fn header_says_what_made_the_image() {
    let dir = common::temp_dir("rdr-header");
    let out = dir.path().join("h.exr");
    ok(&render(&CASES[0], &out, &["--spp", "20", "--seed", "3"]), "render");
    let raw = rdr::imageio::read_exr_channels(&out).unwrap();
    for (k, v) in [
        ("rdr:seed", "3"),
        ("rdr:spp", "20"),
        ("rdr:target_spp", "64"),
        ("rdr:passes", "0-20"),
        ("rdr:state", "0-16,16-20"),
    ] {
        assert_eq!(raw.text(k).as_deref(), Some(v), "{k}");
    }
    for k in ["rdr:scene", "rdr:assets"] {
        let v = raw.text(k).unwrap();
        assert!(v.starts_with("sha256:") && v.len() == 7 + 64, "{k} = {v}");
    }
    assert!(raw.text("rdr:integrator").unwrap().contains(r#""type":"path""#));
    assert_eq!(raw.text("rdr:version").as_deref(), Some(env!("CARGO_PKG_VERSION")));
    let c = raw.attribute("chromaticities").expect("chromaticities");
    let xy: Vec<f32> = c.value.chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    assert_eq!(xy, [0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290]);
    // the exr crate reads the same RGB image and sees the chromaticities
    let meta = exr::meta::MetaData::read_from_file(&out, false).unwrap();
    assert!(meta.headers[0].shared_attributes.chromaticities.is_some());
    // equal renders, equal files: no timestamps; a different scene key, a different hash
    let again = dir.path().join("again.exr");
    ok(&render(&CASES[0], &again, &["--spp", "20", "--seed", "3"]), "render again");
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());
    let other = dir.path().join("other.exr");
    ok(
        &render(&CASES[0], &other, &["--spp", "1", "--override", r#"{"camera":{"fov":31}}"#]),
        "render other",
    );
    let raw2 = rdr::imageio::read_exr_channels(&other).unwrap();
    assert_ne!(raw.text("rdr:scene"), raw2.text("rdr:scene"));
    assert_eq!(raw.text("rdr:assets"), raw2.text("rdr:assets"));
}

/// `--preview` rewrites the PNG and the EXR while rendering; a reader polling them
/// never sees a half-written file.
#[test]
fn preview_files_are_never_half_written() {
    let dir = common::temp_dir("rdr-preview");
    let out = dir.path().join("p.exr");
    let png = dir.path().join("p.preview.png");
    let case = Case {
        name: "path",
        scene: "cornell.json",
        overrides: r#"{"integrator":{"type":"path","max_depth":4},"film":{"resolution":[48,48]}}"#,
    };
    let mut child = rdr()
        .arg("render")
        .arg(scene(case.scene))
        .args([
            "--override",
            case.overrides,
            "-q",
            "--threads",
            "1",
            "--spp",
            "400",
            "--preview",
            "0.02",
            "-o",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (mut reads, mut versions) = (0, std::collections::HashSet::new());
    let deadline = Instant::now() + Duration::from_secs(120);
    while child.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "render did not finish");
        if let Ok(bytes) = std::fs::read(&png) {
            let img = image::load_from_memory(&bytes).unwrap_or_else(|e| panic!("half-written preview ({} bytes): {e}", bytes.len()));
            assert_eq!((img.width(), img.height()), (48, 48));
            versions.insert(bytes);
            reads += 1;
        }
        if out.exists() {
            rdr::imageio::read_exr(&out).unwrap_or_else(|e| panic!("half-written EXR: {e:#}"));
            reads += 1;
        }
    }
    let status = child.wait_with_output().unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    eprintln!("{reads} whole reads, {} preview versions", versions.len());
    assert!(versions.len() >= 3, "the preview was rewritten only {} time(s)", versions.len());
    // the final preview is the final image
    let last = image::open(&png).unwrap().to_rgb8();
    let img = common::read(&out);
    let first = img.pixels[0];
    assert_eq!(last.get_pixel(0, 0)[0], rdr::imageio::linear_to_srgb8(first.x));
}

/// `--tev` against a fake tev on 127.0.0.1: a CreateImage packet, then UpdateImage
/// packets whose last full image is the written one.
#[test]
fn tev_stream_matches_the_protocol_and_the_image() {
    let dir = common::temp_dir("rdr-tev");
    let out = dir.path().join("t.exr");
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || {
        use std::io::Read;
        let (mut s, _) = listener.accept().unwrap();
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        all
    });
    let case = Case {
        name: "path",
        scene: "cornell.json",
        overrides: r#"{"integrator":{"type":"path","max_depth":4},"film":{"resolution":[30,20]}}"#,
    };
    ok(&render(&case, &out, &["--spp", "8", "--tev", &addr]), "render with --tev");
    let bytes = server.join().unwrap();
    // parse the packets
    let mut at = 0;
    let (mut created, mut updates) = (false, 0);
    let mut image = vec![[f32::NAN; 3]; 30 * 20];
    let cstr = |b: &[u8], at: &mut usize| {
        let end = b[*at..].iter().position(|&c| c == 0).unwrap() + *at;
        let s = String::from_utf8(b[*at..end].to_vec()).unwrap();
        *at = end + 1;
        s
    };
    let i32_at = |b: &[u8], at: &mut usize| {
        let v = i32::from_le_bytes(b[*at..*at + 4].try_into().unwrap());
        *at += 4;
        v
    };
    while at < bytes.len() {
        let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        let p = &bytes[at..at + len];
        at += len;
        let mut i = 5;
        match p[4] {
            4 => {
                assert!(!created, "one CreateImage");
                created = true;
                i += 1; // grab focus
                assert_eq!(cstr(p, &mut i), "t.exr");
                assert_eq!((i32_at(p, &mut i), i32_at(p, &mut i), i32_at(p, &mut i)), (30, 20, 3));
                assert_eq!([cstr(p, &mut i), cstr(p, &mut i), cstr(p, &mut i)], ["R", "G", "B"]);
                assert_eq!(i, p.len());
            }
            6 => {
                assert!(created, "CreateImage comes first");
                updates += 1;
                i += 1;
                assert_eq!(cstr(p, &mut i), "t.exr");
                assert_eq!(i32_at(p, &mut i), 3);
                assert_eq!([cstr(p, &mut i), cstr(p, &mut i), cstr(p, &mut i)], ["R", "G", "B"]);
                let (x, y, w, h) = (i32_at(p, &mut i), i32_at(p, &mut i), i32_at(p, &mut i), i32_at(p, &mut i));
                assert_eq!((x, w), (0, 30));
                let longs: Vec<i64> = (0..6)
                    .map(|k| i64::from_le_bytes(p[i + 8 * k..i + 8 * k + 8].try_into().unwrap()))
                    .collect();
                assert_eq!(longs, [0, 1, 2, 3, 3, 3], "offsets and strides");
                i += 48;
                let floats: Vec<f32> = p[i..].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
                assert_eq!(floats.len(), (w * h * 3) as usize);
                for (k, px) in floats.chunks(3).enumerate() {
                    image[y as usize * 30 + k] = [px[0], px[1], px[2]];
                }
            }
            t => panic!("unexpected packet type {t}"),
        }
    }
    assert!(created && updates >= 1);
    let written = common::read(&out);
    for (a, b) in image.iter().zip(&written.pixels) {
        assert_eq!(*a, [b.x, b.y, b.z]);
    }
    // nobody listening: one error line before rendering
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let e = refused(
        &render(&case, &dir.path().join("u.exr"), &["--tev", &format!("127.0.0.1:{port}")]),
        "no tev",
    );
    assert!(e.contains("tev"), "{e}");
}

/// Output files are ordinary files: 0666 less the umask, as `open` would create them
/// (tempfile's private 0600, kept by the rename, made every image unreadable to others).
#[cfg(unix)]
#[test]
fn outputs_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = common::temp_dir("rdr-umask");
    for (umask, mode, name) in [("022", 0o644, "a.exr"), ("077", 0o600, "b.png"), ("002", 0o664, "c.exr")] {
        let out = dir.path().join(name);
        let cmd = format!("umask {umask} && exec \"$0\" render \"$1\" --override '{SMALL}' --spp 1 -q -o \"$2\"",);
        let o = Command::new("sh")
            .args(["-c", &cmd, env!("CARGO_BIN_EXE_rdr")])
            .arg(scene("cornell.json"))
            .arg(&out)
            .output()
            .expect("sh runs");
        ok(&o, &format!("render under umask {umask}"));
        let got = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_eq!(got, mode, "{name} under umask {umask}: mode {got:o}, not {mode:o}");
    }
}
