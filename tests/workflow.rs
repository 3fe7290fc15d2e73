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
/// matters), `intersection_test` on the Cornell box, `bdpt` and `ptracer` (splats),
/// and `path` through media (the Cornell box filled with chromatic, glowing fog: hero
/// channels, delta and ratio tracking draw their numbers per pass too).
const CASES: [Case; 5] = [
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
    Case {
        name: "path_media",
        scene: "cornell.json",
        overrides: r#"{"integrator":{"type":"path","max_depth":6},"camera":{"medium":"fog"},
            "media":{"fog":{"type":"homogeneous","sigma_t":[0.3,0.5,0.8],"albedo":0.8,"radiance":0.2,"phase":{"type":"hg","g":0.5}}}}"#,
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
    // the state files beside the images: the same sums, bit for bit
    let state = rdr::render::statefile::state_path;
    let (sa, sb) = (std::fs::read(state(a)).unwrap(), std::fs::read(state(b)).unwrap());
    assert!(
        sa == sb,
        "{what}: the state files beside {} and {} differ",
        a.display(),
        b.display()
    );
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
    for case in CASES[..3].iter().chain(&CASES[4..]) {
        let full = dir.path().join(format!("{}_full.exr", case.name));
        ok(&render(case, &full, &["--spp", "72"]), "full render");
        for n in [2, 3] {
            let mut parts = Vec::new();
            for k in 0..n {
                let p = dir.path().join(format!("{}_{k}of{n}.exr", case.name));
                ok(&render(case, &p, &["--spp", "72", "--shard", &format!("{k}/{n}")]), "shard");
                parts.push(p);
            }
            // given in any order; `part_*.exr` also names the state files: each part once
            parts.reverse();
            if n == 3 {
                parts.push(rdr::render::statefile::state_path(&parts[0]));
            }
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
fn renders_through_media_resume_and_shard_to_the_bits_of_one_render() {
    // the camera in chromatic fog filling the Cornell box: both light-path integrators
    const FOG: &str =
        r#"{"media":{"fog":{"type":"homogeneous","sigma_t":[0.2,0.3,0.4],"albedo":[0.9,0.8,0.7]}},"camera":{"medium":"fog"}}"#;
    fn fog<'a>(spp: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
        [&["--override", FOG, "--spp", spp][..], extra].concat()
    }
    let dir = common::temp_dir("rdr-media-parts");
    for case in &CASES[2..] {
        let out = |n: &str| dir.path().join(format!("{}_{n}.exr", case.name));
        let case = Case {
            scene: "cornell.json",
            ..*case
        };
        ok(&render(&case, &out("full"), &fog("24", &[])), "full render");
        ok(&render(&case, &out("part"), &fog("9", &[])), "first 9 passes");
        ok(&render(&case, &out("part"), &fog("24", &["--resume"])), "resume to 24");
        assert_same(&out("part"), &out("full"), &format!("{} in fog: 9 → 24 passes", case.name));
        let parts = [out("0of2"), out("1of2")];
        for (k, p) in parts.iter().enumerate() {
            ok(&render(&case, p, &fog("24", &["--shard", &format!("{k}/2")])), "shard");
        }
        let mut c = rdr();
        c.arg("merge").args(&parts).arg("-o").arg(out("merged")).arg("-q");
        ok(&run(c), "merge");
        assert_same(&out("merged"), &out("full"), &format!("{} in fog: 2 shards merged", case.name));
    }
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
    // --no-state: no state file, so nothing to resume or merge from, said by name
    let plain = d("plain.exr");
    ok(&render(case, &plain, &["--spp", "4", "--no-state"]), "--no-state");
    assert!(plain.exists() && !d("plain.state.exr").exists());
    let e = refused(&render(case, &plain, &["--spp", "8", "--resume"]), "resume without a state file");
    assert!(e.contains("plain.state.exr") && e.contains("--no-state"), "{e}");
    let e = refused(
        &render(case, &plain, &["--spp", "8", "--resume", "--no-state"]),
        "--resume --no-state",
    );
    assert!(e.contains("--no-state"), "{e}");
    let e = refused(&merge(&[&a, &plain], &[]), "merge a part without state");
    assert!(e.contains("plain.state.exr"), "{e}");
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
        if let Ok(Some(f)) = rdr::render::statefile::read(&rdr::render::statefile::state_path(&out)) {
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
    let after = rdr::render::statefile::read(&rdr::render::statefile::state_path(&out))
        .unwrap()
        .expect("a whole checkpoint");
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
    let state_file = rdr::render::statefile::state_path(&out);
    let state = rdr::imageio::read_exr_channels(&state_file).unwrap();
    for (k, v) in [
        ("rdr:seed", "3"),
        ("rdr:spp", "20"),
        ("rdr:target_spp", "64"),
        ("rdr:passes", "0-20"),
    ] {
        assert_eq!(raw.text(k).as_deref(), Some(v), "{k}");
        assert_eq!(state.text(k).as_deref(), Some(v), "state file's {k}");
    }
    // the image is plain (RGB, compressed); the film state is in the file beside it
    assert_eq!(raw.text("rdr:state"), None);
    assert_eq!(raw.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(), ["B", "G", "R"]);
    assert_eq!(state.text("rdr:state").as_deref(), Some("0-16,16-20"));
    assert_eq!(state.channels.len(), 3 + 2 * 8, "RGB and two pieces of 4 split sums");
    let (image_bytes, state_bytes) = (
        std::fs::metadata(&out).unwrap().len(),
        std::fs::metadata(&state_file).unwrap().len(),
    );
    assert_eq!(
        raw.attribute("compression").map(|a| a.value.clone()),
        Some(vec![3]),
        "the image is not ZIP-compressed"
    );
    eprintln!("image {image_bytes} bytes, state file {state_bytes} bytes");
    for (a, b) in state.channels.iter().filter(|c| c.name.len() == 1).zip(&raw.channels) {
        assert_eq!(a, b, "the state file's image is the image");
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
    assert_eq!(
        std::fs::read(&state_file).unwrap(),
        std::fs::read(rdr::render::statefile::state_path(&again)).unwrap()
    );
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

// --- Day one (issue 42): what a new user types ------------------------------------------

/// A copy of a bundled scene in `dir` as `name`, edited by `edit`, its relative asset
/// paths made absolute (so it renders from anywhere).
fn scene_copy(bundled: &str, dir: &Path, name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    fn absolute(v: &mut serde_json::Value, base: &Path) {
        match v {
            serde_json::Value::Object(m) => {
                for (k, x) in m.iter_mut() {
                    match x {
                        serde_json::Value::String(s) if k == "path" => *s = base.join(&*s).to_string_lossy().into_owned(),
                        _ => absolute(x, base),
                    }
                }
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(|x| absolute(x, base)),
            _ => {}
        }
    }
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(scene(bundled)).unwrap()).unwrap();
    absolute(&mut v, &scene(""));
    edit(&mut v);
    let out = dir.join(name);
    std::fs::write(&out, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    out
}

/// A Mitsuba XML scene in `dir` whose sensor has the property "fvo" (for "fov").
fn xml_with_a_typo(dir: &Path) -> PathBuf {
    let xml = dir.join("unknown.xml");
    std::fs::write(
        &xml,
        r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/><float name="fvo" value="40"/>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
<shape type="sphere"><bsdf type="diffuse"/></shape><emitter type="constant"/></scene>"#,
    )
    .unwrap();
    xml
}

fn rdr_with(args: &[&str], scene_path: Option<&Path>, out: Option<&Path>) -> Output {
    let mut c = rdr();
    c.args(args);
    if let Some(s) = scene_path {
        c.arg(s);
    }
    if let Some(o) = out {
        c.arg("-o").arg(o);
    }
    run(c)
}

/// Every refusal a new user meets on day one: one `error:` line, status 1, naming the
/// way out (the formats rdr reads, the closest flag or key, the flag that relaxes it).
#[test]
fn day_one_refusals_name_the_way_out() {
    let dir = common::temp_dir("rdr-dayone");
    let d = dir.path();
    let pbrt = d.join("a.pbrt");
    std::fs::write(&pbrt, "Film \"rgb\"\nWorldBegin\n").unwrap();
    let xml_as_txt = d.join("scene.txt");
    std::fs::write(&xml_as_txt, "<scene version=\"3.0.0\"/>\n").unwrap();
    let typo = scene_copy("cornell.json", d, "typo.json", |s| {
        s["film"]["resolutoin"] = serde_json::json!([8, 8])
    });
    let shapes = scene_copy("cornell.json", d, "shapes.json", |s| s["shapes"] = serde_json::json!([]));
    let both = scene_copy("cornell.json", d, "both.json", |s| {
        let (name, _) = s["materials"].as_object().unwrap().iter().next().unwrap();
        let name = name.clone();
        s["materials"][&name] = serde_json::json!({"type": "diffuse", "albedo": [0.8, 0.2, 0.2], "texture_name": "x"});
    });
    let xml = xml_with_a_typo(d);
    let exr = d.join("o.exr");
    let png = d.join("o.png");
    let cornell = scene("cornell.json");
    let cases: Vec<(&str, Output, Vec<&str>)> = vec![
        (
            "a .pbrt scene",
            rdr_with(&["render"], Some(&pbrt), Some(&exr)),
            vec!["a.pbrt", "pbrt scenes", ".json", ".xml"],
        ),
        (
            "XML named .txt",
            rdr_with(&["render"], Some(&xml_as_txt), Some(&exr)),
            vec!["looks like XML", ".xml"],
        ),
        (
            "no subcommand",
            rdr_with(&[], None, None),
            vec!["render", "merge", "convert", "compare", "bench"],
        ),
        (
            "--sp",
            rdr_with(&["render", "--sp", "4"], Some(&cornell), Some(&exr)),
            vec!["'--sp'", "did you mean '--spp'?"],
        ),
        (
            "rendr",
            rdr_with(&["rendr"], Some(&cornell), None),
            vec!["'rendr'", "did you mean 'render'?"],
        ),
        (
            "a misspelt film key",
            rdr_with(&["render"], Some(&typo), Some(&exr)),
            vec![
                "typo.json: film: unknown key 'resolutoin'",
                "did you mean 'resolution'?",
                "--lenient",
            ],
        ),
        (
            "a top-level shapes",
            rdr_with(&["render"], Some(&shapes), Some(&exr)),
            vec!["shapes.json: unknown key 'shapes'", "did you mean 'objects'?", "--lenient"],
        ),
        (
            "an unknown XML property with --strict",
            rdr_with(&["render", "--strict"], Some(&xml), Some(&exr)),
            vec!["unknown.xml", "unknown property \"fvo\"", "did you mean \"fov\"?", "--strict"],
        ),
        (
            "albedo and texture_name",
            rdr_with(&["render"], Some(&both), Some(&exr)),
            vec!["albedo", "not both"],
        ),
        (
            "--res 64",
            rdr_with(&["render", "--res", "64"], Some(&cornell), Some(&exr)),
            vec!["--res", "WIDTHxHEIGHT"],
        ),
        (
            "--integrator nope",
            rdr_with(&["render", "--integrator", "nope"], Some(&cornell), Some(&exr)),
            vec!["'nope'", "available: path"],
        ),
        (
            "--crop outside",
            rdr_with(&["render", "--res", "40x30", "--crop", "0,0,41,30"], Some(&cornell), Some(&exr)),
            vec!["--crop '0,0,41,30'", "outside the 40x30 film"],
        ),
        (
            "--crop of a splatting integrator",
            rdr_with(&["render", "--integrator", "bdpt", "--crop", "0,0,8,8"], Some(&cornell), Some(&exr)),
            vec!["--crop", "bdpt", "splats"],
        ),
        (
            "--exposure on .exr",
            rdr_with(&["render", "--exposure", "1"], Some(&cornell), Some(&exr)),
            vec!["--exposure", "PNG", "o.exr"],
        ),
        (
            "--exposure not a number",
            rdr_with(&["render", "--exposure", "inf"], Some(&cornell), Some(&png)),
            vec!["--exposure"],
        ),
    ];
    let mut failures = Vec::new();
    for (name, o, words) in &cases {
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        let one_line = err.lines().count() == 1 && err.starts_with("error: ");
        if o.status.code() != Some(1) || !one_line || words.iter().any(|w| !err.contains(w)) {
            failures.push(format!(
                "{name}: status {}, expected one error line with {words:?}, got {err:?}",
                o.status
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(!exr.exists() && !png.exists(), "a refused render wrote an image");
}

/// What the refusals above let through: `--lenient` (JSON) warns with the suggestion;
/// XML's unknown properties warn without `--strict`; the help texts name both formats.
#[test]
fn day_one_warnings_and_help_texts() {
    let dir = common::temp_dir("rdr-dayone-ok");
    let d = dir.path();
    let typo = scene_copy("cornell.json", d, "typo.json", |s| {
        s["film"]["resolutoin"] = serde_json::json!([8, 8])
    });
    let o = rdr_with(
        &["render", "--lenient", "--spp", "1", "--res", "8x8"],
        Some(&typo),
        Some(&d.join("t.exr")),
    );
    ok(&o, "--lenient");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: ") && err.contains("unknown key 'resolutoin' ignored (did you mean 'resolution'?)"),
        "{err}"
    );
    let xml = xml_with_a_typo(d);
    let o = rdr_with(&["render", "--spp", "1"], Some(&xml), Some(&d.join("x.exr")));
    ok(&o, "XML with an unknown property");
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown property \"fvo\""));
    let help = |args: &[&str]| String::from_utf8_lossy(&rdr_with(args, None, None).stdout).into_owned();
    let top = help(&["--help"]);
    assert!(top.contains("JSON") && top.contains("Mitsuba"), "{top}");
    let convert = help(&["convert", "--help"]);
    assert!(!convert.contains("are are") && convert.contains("OBJ"), "{convert}");
    let compare = help(&["compare", "--help"]);
    assert!(
        !compare.contains("shared/refs") && compare.contains("The image to measure"),
        "{compare}"
    );
    let render = help(&["render", "--help"]);
    for flag in ["--res", "--integrator", "--crop", "--exposure", "--lenient", "--strict"] {
        assert!(render.contains(flag), "render --help lacks {flag}");
    }
}

/// The pixels of two EXR renders are the same (the files' headers may differ).
fn same_pixels(a: &Path, b: &Path) -> bool {
    let (x, y) = (common::read(a), common::read(b));
    (x.width, x.height) == (y.width, y.height) && x.pixels == y.pixels
}

/// A scene without `integrator` renders as `path` at its defaults; `--integrator`
/// puts one in place of the scene's; `--res` is the film resolution in JSON and XML.
#[test]
fn integrator_default_and_everyday_flags() {
    let dir = common::temp_dir("rdr-dayone-flags");
    let d = dir.path();
    let small = |s: &mut serde_json::Value| s["film"]["resolution"] = serde_json::json!([24, 16]);
    let none = scene_copy("showcase.json", d, "none.json", |s| {
        small(s);
        s.as_object_mut().unwrap().remove("integrator");
    });
    let path = scene_copy("showcase.json", d, "path.json", |s| {
        small(s);
        s["integrator"] = serde_json::json!({"type": "path"});
    });
    let normals = scene_copy("showcase.json", d, "normals.json", |s| {
        small(s);
        // path's default spp: the declared spp sets the texture footprint, and stays
        s["integrator"] = serde_json::json!({"type": "normals", "spp": 32});
    });
    let r = |scene_path: &Path, name: &str, extra: &[&str]| -> PathBuf {
        let out = d.join(name);
        let mut args = vec!["render", "-q", "--threads", "2", "--spp", "2"];
        args.extend(extra);
        ok(&rdr_with(&args, Some(scene_path), Some(&out)), name);
        out
    };
    let (a, b) = (r(&none, "none.exr", &[]), r(&path, "path.exr", &[]));
    assert!(same_pixels(&a, &b), "a scene without integrator is not rendered as path");
    let c = r(&normals, "normals.exr", &[]);
    assert!(!same_pixels(&a, &c), "normals and path gave the same image");
    let e = r(&normals, "normals_as_path.exr", &["--integrator", "path"]);
    assert!(same_pixels(&a, &e), "--integrator path did not replace the scene's normals");
    // --res: the image of the resolution asked, the same as the scene saying it
    let f = r(&none, "res.exr", &["--res", "12x20"]);
    let res = scene_copy("showcase.json", d, "res.json", |s| {
        s["film"]["resolution"] = serde_json::json!([12, 20]);
        s.as_object_mut().unwrap().remove("integrator");
    });
    let g = r(&res, "res_scene.exr", &[]);
    let img = common::read(&f);
    assert_eq!((img.width, img.height), (12, 20));
    assert!(same_pixels(&f, &g), "--res 12x20 differs from a scene of 12x20");
    let xml = d.join("cornell.xml");
    ok(
        &rdr_with(&["convert", "-q"], Some(&scene("cornell.json")), Some(&xml)),
        "convert to XML",
    );
    let h = r(&xml, "xml_res.exr", &["--res", "10x6"]);
    let img = common::read(&h);
    assert_eq!((img.width, img.height), (10, 6), "--res on an XML scene");
}

/// `--crop` renders the region of the film it names: each pixel sees what it sees
/// in the whole image. The check is self-calibrated: the crop must be closer to
/// its own region of a full render than to the region shifted by 3 pixels.
#[test]
fn crop_renders_the_region_it_names() {
    let dir = common::temp_dir("rdr-dayone-crop");
    let d = dir.path();
    let (full, part) = (d.join("full.exr"), d.join("part.exr"));
    let args = ["render", "-q", "--threads", "2", "--spp", "16", "--res", "48x36"];
    ok(&rdr_with(&args, Some(&scene("cornell.json")), Some(&full)), "full render");
    let (x0, y0, x1, y1) = (6usize, 4usize, 40usize, 22usize);
    let mut crop_args = args.to_vec();
    crop_args.extend(["--crop", "6,4,40,22"]);
    ok(&rdr_with(&crop_args, Some(&scene("cornell.json")), Some(&part)), "cropped render");
    let (f, p) = (common::read(&full), common::read(&part));
    assert_eq!((p.width, p.height), (x1 - x0, y1 - y0));
    let diff = |dx: isize, dy: isize| -> f64 {
        let mut sum = 0.0;
        for y in 0..p.height {
            for x in 0..p.width {
                let (fx, fy) = ((x + x0) as isize + dx, (y + y0) as isize + dy);
                let q = f.pixels[fy as usize * f.width + fx as usize];
                sum += ((p.pixels[y * p.width + x] - q).abs()).element_sum() as f64;
            }
        }
        sum / (p.width * p.height) as f64
    };
    let (own, shifted) = (diff(0, 0), diff(0, 3).min(diff(3, 0)));
    eprintln!("crop: mean |difference| against its region {own:.4}, against the region 3 pixels off {shifted:.4}");
    assert!(
        own * 3.0 < shifted,
        "crop against its region {own:.4}, against the region 3 pixels off {shifted:.4}"
    );
}

/// `--exposure S` scales a PNG's radiance by 2^S before the sRGB conversion.
#[test]
fn exposure_brightens_png_output() {
    let dir = common::temp_dir("rdr-dayone-exposure");
    let d = dir.path();
    let (exr, png) = (d.join("e.exr"), d.join("e.png"));
    let args = ["render", "-q", "--threads", "2", "--spp", "2", "--res", "24x24"];
    ok(&rdr_with(&args, Some(&scene("cornell.json")), Some(&exr)), "exr");
    let mut a = args.to_vec();
    a.extend(["--exposure", "1.5"]);
    ok(&rdr_with(&a, Some(&scene("cornell.json")), Some(&png)), "png with --exposure");
    let (lin, img) = (common::read(&exr), rdr::imageio::read_texture_image_as(&png, true).unwrap());
    let gain = 2f32.powf(1.5);
    let worst = lin
        .pixels
        .iter()
        .zip(&img.pixels)
        .flat_map(|(l, p)| (0..3).map(move |c| (rdr::imageio::linear_to_srgb8(l[c] * gain) as f32 - p[c] * 255.0).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst <= 1.0, "PNG differs from the exposed radiance by {worst} levels");
}

/// A diffuse material's inline `albedo` renders as a constant texture of that colour
/// would, and survives `rdr convert` to XML and back as an inline colour.
#[test]
fn inline_albedo_renders_and_round_trips() {
    let dir = common::temp_dir("rdr-dayone-albedo");
    let d = dir.path();
    let first = |s: &serde_json::Value| s["materials"].as_object().unwrap().keys().next().unwrap().clone();
    let inline = scene_copy("cornell.json", d, "inline.json", |s| {
        let m = first(s);
        s["materials"][&m] = serde_json::json!({"type": "diffuse", "albedo": [0.8, 0.2, 0.2]});
    });
    let named = scene_copy("cornell.json", d, "named.json", |s| {
        let m = first(s);
        s["textures"]["inline_red"] = serde_json::json!({"type": "constant", "color": [0.8, 0.2, 0.2]});
        s["materials"][&m] = serde_json::json!({"type": "diffuse", "texture_name": "inline_red"});
    });
    let args = ["render", "-q", "--threads", "2", "--spp", "2", "--res", "16x16"];
    let (a, b) = (d.join("a.exr"), d.join("b.exr"));
    ok(&rdr_with(&args, Some(&inline), Some(&a)), "inline albedo");
    ok(&rdr_with(&args, Some(&named), Some(&b)), "named constant");
    assert!(
        same_pixels(&a, &b),
        "an inline albedo renders differently from its constant texture"
    );
    let (xml, back) = (d.join("inline.xml"), d.join("back.json"));
    ok(&rdr_with(&["convert", "-q"], Some(&inline), Some(&xml)), "to XML");
    ok(&rdr_with(&["convert", "-q"], Some(&xml), Some(&back)), "back to JSON");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&back).unwrap()).unwrap();
    let has = v["materials"]
        .as_object()
        .unwrap()
        .values()
        .any(|m| m["type"] == "diffuse" && m["albedo"] == serde_json::json!([0.8, 0.2, 0.2]));
    assert!(
        has,
        "no diffuse with albedo [0.8, 0.2, 0.2] after the round trip: {}",
        v["materials"]
    );
}

/// Every material with a `texture_name` also takes an inline colour there, rendering as
/// a constant texture of that colour would (issue 42: each colour needed its own entry).
#[test]
fn inline_colours_in_textured_materials_render_as_constant_textures() {
    let dir = common::temp_dir("rdr-dayone-inline");
    let d = dir.path();
    let first = |s: &serde_json::Value| s["materials"].as_object().unwrap().keys().next().unwrap().clone();
    let args = ["render", "-q", "--threads", "2", "--spp", "2", "--res", "16x16"];
    for ty in ["diffuse", "plastic", "roughplastic", "conductor", "roughconductor"] {
        let inline = scene_copy("cornell.json", d, &format!("{ty}_inline.json"), |s| {
            let m = first(s);
            s["materials"][&m] = serde_json::json!({"type": ty, "texture_name": [0.8, 0.2, 0.2]});
        });
        let named = scene_copy("cornell.json", d, &format!("{ty}_named.json"), |s| {
            let m = first(s);
            s["textures"]["inline_red"] = serde_json::json!({"type": "constant", "color": [0.8, 0.2, 0.2]});
            s["materials"][&m] = serde_json::json!({"type": ty, "texture_name": "inline_red"});
        });
        let (a, b) = (d.join(format!("{ty}_a.exr")), d.join(format!("{ty}_b.exr")));
        ok(&rdr_with(&args, Some(&inline), Some(&a)), &format!("{ty}: inline colour"));
        ok(&rdr_with(&args, Some(&named), Some(&b)), &format!("{ty}: named constant"));
        assert!(
            same_pixels(&a, &b),
            "{ty}: an inline colour renders differently from its constant texture"
        );
    }
}
