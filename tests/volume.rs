//! Volumes (`src/volume/`): the `.vol` reader, Mitsuba 3's lookup convention (voxel
//! centres at `(i + ½)/res`, trilinear and nearest, the wrap modes), `to_world` and
//! `use_grid_bbox`, bad files, the Mitsuba `<volume>` reader, and the majorant grid's
//! bound and ray walk against brute force.

mod common;

use common::Rng;
use rdr::desc::xml::document::{read_str, Element, Params};
use rdr::geometry::Aabb;
use rdr::math::{Mat4, Vec3};
use rdr::volume::grid::GridOptions;
use rdr::volume::{vdb, vol_file, GridData, GridFilter, GridVolume, MajorantGrid, Volume, WrapMode};
use std::path::Path;

fn unit_box() -> Aabb {
    Aabb::new(Vec3::ZERO, Vec3::ONE)
}

/// A grid whose voxel `(x, y, z)` holds `1 + x + 10y + 100z` (channel c adds 1000c).
fn indexed(res: [usize; 3], channels: usize) -> GridData {
    let mut v = Vec::new();
    for z in 0..res[2] {
        for y in 0..res[1] {
            for x in 0..res[0] {
                for c in 0..channels {
                    v.push((1 + x + 10 * y + 100 * z + 1000 * c) as f32);
                }
            }
        }
    }
    GridData::new(res, channels, unit_box(), v).unwrap()
}

fn grid(data: GridData, filter: GridFilter, wrap: WrapMode) -> GridVolume {
    let opts = GridOptions {
        filter,
        wrap,
        ..GridOptions::default()
    };
    GridVolume::new(data, opts).unwrap()
}

fn centre(i: [usize; 3], res: [usize; 3]) -> Vec3 {
    Vec3::new(
        (i[0] as f32 + 0.5) / res[0] as f32,
        (i[1] as f32 + 0.5) / res[1] as f32,
        (i[2] as f32 + 0.5) / res[2] as f32,
    )
}

#[test]
fn vol_file_values_sit_at_voxel_centres() {
    let res = [5, 4, 3];
    for channels in [1, 3] {
        let bytes = vol_file::encode(&indexed(res, channels));
        let data = vol_file::parse(&bytes).unwrap();
        assert_eq!((data.res, data.channels), (res, channels));
        let near = grid(data.clone(), GridFilter::Nearest, WrapMode::Clamp);
        let tri = grid(data, GridFilter::Trilinear, WrapMode::Clamp);
        let mut worst = 0.0f32;
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..5 {
                    let want = (1 + x + 10 * y + 100 * z) as f32;
                    let c = centre([x, y, z], res);
                    for v in [near.eval(c), tri.eval(c)] {
                        for (k, got) in v.iter().enumerate() {
                            let want = want + if channels == 3 { 1000.0 * k as f32 } else { 0.0 };
                            worst = worst.max((got - want).abs());
                        }
                    }
                    // halfway between two centres along x: their mean
                    if x + 1 < 5 {
                        let mid = tri.eval(c + Vec3::new(0.5 / 5.0, 0.0, 0.0))[0];
                        worst = worst.max((mid - (want + 0.5)).abs());
                    }
                }
            }
        }
        println!("{channels} channel(s): largest error at voxel centres and midpoints {worst}");
        assert!(worst < 1e-3, "{channels} channel(s): lookups off by {worst}");
    }
}

#[test]
fn wrap_modes_fold_indices_as_mitsuba() {
    // a row of four voxels 1 2 3 4 (x only), looked up with nearest outside [0, 1]
    let data = GridData::new([4, 1, 1], 1, unit_box(), vec![1.0, 2.0, 3.0, 4.0]).unwrap();
    let at = |wrap, x: f32| grid(data.clone(), GridFilter::Nearest, wrap).eval(Vec3::new(x, 0.5, 0.5))[0];
    // voxel indices -1, -2, 4, 5, 9 for x = -0.1, -0.3, 1.1, 1.3, 2.4
    let xs = [-0.1, -0.3, 1.1, 1.3, 2.4];
    let clamp: Vec<f32> = xs.iter().map(|&x| at(WrapMode::Clamp, x)).collect();
    let repeat: Vec<f32> = xs.iter().map(|&x| at(WrapMode::Repeat, x)).collect();
    let mirror: Vec<f32> = xs.iter().map(|&x| at(WrapMode::Mirror, x)).collect();
    println!("clamp {clamp:?} repeat {repeat:?} mirror {mirror:?}");
    assert_eq!(clamp, [1.0, 1.0, 4.0, 4.0, 4.0]);
    assert_eq!(repeat, [4.0, 3.0, 1.0, 2.0, 2.0]);
    // mirrored tiles: ... 4 3 2 1 | 1 2 3 4 | 4 3 2 1 | 1 2 3 4 ...
    assert_eq!(mirror, [1.0, 2.0, 4.0, 3.0, 2.0]);
    // trilinear at x = 0: halfway between voxel -1 and voxel 0
    let tri = |wrap| grid(data.clone(), GridFilter::Trilinear, wrap).eval(Vec3::new(0.0, 0.5, 0.5))[0];
    assert_eq!(
        [tri(WrapMode::Clamp), tri(WrapMode::Repeat), tri(WrapMode::Mirror)],
        [1.0, 2.5, 1.0]
    );
}

#[test]
fn to_world_and_use_grid_bbox_place_the_grid() {
    let mut data = indexed([4, 4, 4], 1);
    data.bbox = Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5));
    let to_world = Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::new(2.0, 1.0, 4.0));
    let plain = GridVolume::new(
        data.clone(),
        GridOptions {
            to_world,
            ..GridOptions::default()
        },
    )
    .unwrap();
    let boxed = GridVolume::new(
        data,
        GridOptions {
            to_world,
            use_grid_bbox: true,
            ..GridOptions::default()
        },
    )
    .unwrap();
    let (plain, boxed) = (Volume::Grid(plain), Volume::Grid(boxed));
    let b = plain.world_bounds();
    println!("world bounds: plain {b:?}, use_grid_bbox {:?}", boxed.world_bounds());
    assert!((b.min - Vec3::new(2.0, 0.0, 0.0)).abs().max_element() < 1e-5);
    assert!((b.max - Vec3::new(4.0, 1.0, 4.0)).abs().max_element() < 1e-5);
    let bb = boxed.world_bounds();
    assert!((bb.min - Vec3::new(1.0, -0.5, -2.0)).abs().max_element() < 1e-5);
    assert!((bb.max - Vec3::new(3.0, 0.5, 2.0)).abs().max_element() < 1e-5);
    // the centre of voxel (1, 2, 3) in each placement
    let local = centre([1, 2, 3], [4, 4, 4]);
    let want = (1 + 1 + 20 + 300) as f32;
    let p_plain = to_world.transform_point3(local);
    let p_boxed = to_world.transform_point3(local - Vec3::splat(0.5));
    assert!((plain.eval(p_plain)[0] - want).abs() < 1e-3, "{:?}", plain.eval(p_plain));
    assert!((boxed.eval(p_boxed)[0] - want).abs() < 1e-3, "{:?}", boxed.eval(p_boxed));
}

#[test]
fn max_value_may_raise_the_bound_never_lower_it() {
    let data = indexed([3, 3, 3], 1);
    let top = data.max();
    let with = |m| {
        GridVolume::new(
            data.clone(),
            GridOptions {
                max_value: Some(m),
                ..GridOptions::default()
            },
        )
    };
    assert_eq!(Volume::Grid(with(2.0 * top).unwrap()).max(), 2.0 * top);
    let e = with(0.5 * top).unwrap_err();
    println!("{e}");
    assert!(e.starts_with("max_value"), "{e}");
    assert_eq!(Volume::Grid(grid(data, GridFilter::Trilinear, WrapMode::Clamp)).max(), top);
}

#[test]
fn bad_vol_files_are_refused_in_one_line() {
    let good = vol_file::encode(&indexed([4, 4, 4], 1));
    let with = |at: usize, bytes: &[u8]| {
        let mut b = good.clone();
        b[at..at + bytes.len()].copy_from_slice(bytes);
        b
    };
    let nan = with(48 + 4 * 7, &f32::NAN.to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("short header", good[..20].to_vec(), "header"),
        ("not VOL", with(0, b"XOL"), "VOL"),
        ("version 2", with(3, &[2]), "version"),
        ("encoding 2", with(4, &2i32.to_le_bytes()), "encoding"),
        ("6 channels", with(20, &6i32.to_le_bytes()), "channels"),
        ("zero resolution", with(8, &0i32.to_le_bytes()), "resolution"),
        ("truncated", good[..good.len() - 4].to_vec(), "claims"),
        // 2^31-1 per axis: 10^28 values claimed by a 304-byte file
        (
            "lies about its size",
            with(8, &[0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff, 0x7f]),
            "claims",
        ),
        ("NaN", nan, "voxel (3, 1, 0)"),
        ("negative", with(48, &(-1.0f32).to_le_bytes()), "not negative"),
    ];
    for (what, bytes, expect) in cases {
        let e = vol_file::parse(&bytes).expect_err(what);
        println!("{what}: {e}");
        assert!(e.contains(expect) && !e.contains('\n'), "{what}: {e}");
    }
    // the reader names the file through the scene's build step
    refused_in_scene("lying.vol", &with(8, &1000i32.to_le_bytes()), "claims");
}

/// A grid file `name` holding `bytes`, read through a scene: the error names the file,
/// the key and says `expect`.
fn refused_in_scene(name: &str, bytes: &[u8], expect: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), bytes).unwrap();
    let xml = format!(r#"<volume type="gridvolume"><string name="filename" value="{name}"/></volume>"#);
    let e = build_from_xml(dir.path(), &xml).unwrap_err();
    println!("{e}");
    assert!(e.contains(name) && e.contains("filename") && e.contains(expect), "{e}");
}

/// A `<volume>` read from XML in `dir` (as `dir/scene.xml`) and built.
fn build_from_xml(dir: &Path, volume: &str) -> Result<Volume, String> {
    let file = dir.join("scene.xml");
    let text = format!("<scene version=\"3.0.0\"><medium type=\"heterogeneous\">{volume}</medium></scene>");
    let root = read_str(&text, &file, &mut Params::new(&[])).map_err(|e| e.to_string())?;
    let medium = &root.children[0];
    let named = medium_with_name(medium, "sigma_t");
    let desc = rdr::desc::xml::plugins::volume_property(&root, &named, "sigma_t", Vec3::ONE, &file).map_err(|e| e.to_string())?;
    rdr::desc::build_volume(&desc, &file, dir).map_err(|e| e.to_string())
}

/// `el` with its first child given the property name `name`.
fn medium_with_name(el: &Element, name: &str) -> Element {
    let mut m = el.clone();
    if let Some(c) = m.children.first_mut() {
        c.attrs.retain(|(k, _)| k != "name");
        c.attrs.push(("name".into(), name.into()));
    }
    m
}

#[test]
fn mitsuba_volumes_are_read_and_built() {
    let dir = tempfile::tempdir().unwrap();
    let mut data = indexed([4, 3, 2], 1);
    data.bbox = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
    std::fs::write(dir.path().join("g.vol"), vol_file::encode(&data)).unwrap();
    let v = build_from_xml(
        dir.path(),
        r#"<volume type="gridvolume"><string name="filename" value="g.vol"/><string name="filter_type" value="nearest"/>
           <string name="wrap_mode" value="mirror"/><float name="max_value" value="500"/><boolean name="use_grid_bbox" value="true"/>
           <transform name="to_world"><scale value="2"/></transform></volume>"#,
    )
    .unwrap();
    let Volume::Grid(g) = &v else { panic!("not a grid") };
    assert_eq!((g.filter(), g.wrap(), g.max()), (GridFilter::Nearest, WrapMode::Mirror, 500.0));
    let b = v.world_bounds();
    assert!(
        (b.min + Vec3::splat(2.0)).abs().max_element() < 1e-5 && (b.max - Vec3::splat(2.0)).abs().max_element() < 1e-5,
        "{b:?}"
    );
    // defaults: trilinear, clamp, the grid's max, the unit cube
    let v = build_from_xml(
        dir.path(),
        r#"<volume type="gridvolume"><string name="filename" value="g.vol"/></volume>"#,
    )
    .unwrap();
    let Volume::Grid(g) = &v else { panic!("not a grid") };
    assert_eq!(
        (g.filter(), g.wrap(), g.max()),
        (GridFilter::Trilinear, WrapMode::Clamp, data.max())
    );
    assert_eq!(v.world_bounds(), Aabb::new(Vec3::ZERO, Vec3::ONE));
    // constants: a constvolume, or the shorthand number / rgb
    let c = build_from_xml(
        dir.path(),
        r#"<volume type="constvolume"><rgb name="value" value="0.5, 2, 3"/></volume>"#,
    )
    .unwrap();
    assert_eq!((c.eval(Vec3::splat(7.0)), c.max()), ([0.5, 2.0, 3.0], 3.0));
    let c = build_from_xml(dir.path(), r#"<rgb value="0.25, 0.5, 1"/>"#).unwrap();
    assert_eq!(c.eval(Vec3::ZERO), [0.25, 0.5, 1.0]);
    let c = build_from_xml(dir.path(), r#"<float value="4"/>"#).unwrap();
    assert_eq!(c.eval(Vec3::ZERO), [4.0; 3]);
    // errors name the line and the key
    for (xml, key) in [
        (
            r#"<volume type="gridvolume"><string name="filename" value="g.vol"/><string name="filter_type" value="cubic"/></volume>"#,
            "filter_type",
        ),
        (
            r#"<volume type="gridvolume"><string name="filename" value="g.vol"/><string name="wrap_mode" value="border"/></volume>"#,
            "wrap_mode",
        ),
        (
            r#"<volume type="gridvolume"><string name="filename" value="g.vol"/><float name="max_value" value="3"/></volume>"#,
            "max_value",
        ),
        (
            r#"<volume type="gridvolume"><string name="filename" value="g.vol"/><string name="grid" value="density"/></volume>"#,
            "grid",
        ),
        (
            r#"<volume type="gridvolume"><string name="filename" value="missing.vol"/></volume>"#,
            "filename",
        ),
        (r#"<volume type="gridvolume"/>"#, "filename"),
        (r#"<volume type="constvolume"><float name="value" value="-1"/></volume>"#, "value"),
        (
            r#"<volume type="constvolume"><transform name="to_world"><scale value="0"/></transform></volume>"#,
            "to_world",
        ),
        (r#"<volume type="cloud"/>"#, "constvolume, gridvolume"),
        (r#"<float value="-2"/>"#, "sigma_t"),
        (r#"<texture type="checkerboard"/>"#, "<volume>"),
    ] {
        let e = build_from_xml(dir.path(), xml).expect_err(xml);
        println!("{e}");
        assert!(
            e.contains(key) && e.contains("scene.xml: line 1") && !e.contains('\n'),
            "{xml}: {e}"
        );
    }
}

/// A sparse grid: mostly zero, with isolated spikes, so a bound that misses one voxel
/// of a cell's trilinear footprint is caught.
fn spiky(rng: &mut Rng, res: [usize; 3], channels: usize) -> GridData {
    let n = res.iter().product::<usize>() * channels;
    let v = (0..n).map(|_| if rng.chance(0.04) { rng.rangef(1.0, 10.0) } else { 0.0 }).collect();
    GridData::new(res, channels, unit_box(), v).unwrap()
}

/// Random rays at `volume`: each majorant segment must lie in `[t_min, t_max]`, follow
/// the previous one, and bound `eval` at random points on it; every point of the ray
/// inside the volume's box must be covered. Returns the largest `eval / bound` seen.
fn check_majorant(rng: &mut Rng, volume: &Volume, majorant: &MajorantGrid, rays: usize) -> f32 {
    let b = volume.world_bounds();
    let (centre, size) = (0.5 * (b.min + b.max), (b.max - b.min).max_element());
    let to_local = volume.to_local();
    let mut worst = 0.0f32;
    for _ in 0..rays {
        let o = centre + size * Vec3::new(rng.rangef(-1.0, 1.0), rng.rangef(-1.0, 1.0), rng.rangef(-1.0, 1.0));
        let d = Vec3::new(rng.rangef(-1.0, 1.0), rng.rangef(-1.0, 1.0), rng.rangef(-1.0, 1.0)) * rng.rangef(0.2, 3.0);
        let (t_min, t_max) = (rng.rangef(-1.0, 0.5), rng.rangef(0.5, 4.0));
        let segs: Vec<_> = majorant.iter(o, d, t_min, t_max).collect();
        for w in segs.windows(2) {
            assert_eq!(w[0].t1, w[1].t0, "segments must follow each other");
        }
        for s in &segs {
            assert!(t_min <= s.t0 && s.t0 <= s.t1 && s.t1 <= t_max, "{s:?} outside [{t_min}, {t_max}]");
            for _ in 0..4 {
                let t = rng.rangef(s.t0, s.t1);
                let v = volume.eval(o + t * d);
                let m = v[0].max(v[1]).max(v[2]);
                if m > 0.0 {
                    worst = worst.max(m / s.scale.max(f32::MIN_POSITIVE));
                }
            }
        }
        // coverage: points well inside the box are inside some segment
        for _ in 0..8 {
            let t = rng.rangef(t_min, t_max);
            let u = to_local.transform_point3(o + t * d);
            if u.cmpgt(Vec3::splat(1e-3)).all() && u.cmplt(Vec3::splat(1.0 - 1e-3)).all() {
                assert!(
                    segs.iter().any(|s| s.t0 <= t && t <= s.t1),
                    "t = {t} inside the box but not covered"
                );
            }
        }
    }
    worst
}

#[test]
fn majorant_grid_bounds_the_volume_along_random_rays() {
    let mut rng = Rng::new(38);
    let to_world = Mat4::from_translation(Vec3::new(1.0, -2.0, 0.5))
        * Mat4::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7)
        * Mat4::from_scale(Vec3::new(2.0, 1.0, 3.0));
    let mut worst_all = 0.0f32;
    for (res, channels, filter, wrap, mres) in [
        ([23, 17, 29], 1, GridFilter::Trilinear, WrapMode::Clamp, [16, 16, 16]),
        ([23, 17, 29], 3, GridFilter::Trilinear, WrapMode::Repeat, [16, 16, 16]),
        ([20, 9, 31], 1, GridFilter::Trilinear, WrapMode::Mirror, [7, 5, 3]),
        ([40, 40, 40], 1, GridFilter::Nearest, WrapMode::Clamp, [16, 16, 16]),
        ([8, 8, 8], 1, GridFilter::Trilinear, WrapMode::Repeat, [16, 16, 16]),
    ] {
        let data = spiky(&mut rng, res, channels);
        let g = GridVolume::new(
            data,
            GridOptions {
                filter,
                wrap,
                to_world,
                ..GridOptions::default()
            },
        )
        .unwrap();
        let volume = Volume::Grid(g);
        let majorant = MajorantGrid::new(&volume, mres);
        // the bound is per cell, not the global maximum everywhere: some cells are
        // below half of it
        let [mx, my, mz] = majorant.res();
        let cells: Vec<f32> = (0..mz)
            .flat_map(|z| (0..my).flat_map(move |y| (0..mx).map(move |x| (x, y, z))))
            .map(|(x, y, z)| majorant.cell(x, y, z))
            .collect();
        let low = cells.iter().filter(|&&c| c < 0.5 * volume.max()).count() as f32 / cells.len() as f32;
        let worst = check_majorant(&mut rng, &volume, &majorant, 3000);
        println!(
            "{res:?}×{channels} {filter:?} {wrap:?} majorant {mres:?}: largest eval/bound {worst:.6}, {:.1}% of cells below half the maximum",
            100.0 * low
        );
        assert!(mres != [16, 16, 16] || low > 0.0, "the majorant is the global maximum everywhere");
        worst_all = worst_all.max(worst);
    }
    assert!(worst_all <= 1.0 + 1e-5, "a majorant below the volume: eval/bound up to {worst_all}");
    // a constant volume: one cell, its largest channel
    let c = Volume::Constant(rdr::volume::ConstVolume {
        value: Vec3::new(0.5, 2.0, 1.0),
        to_world,
    });
    let m = MajorantGrid::new(&c, [16, 16, 16]);
    assert_eq!((m.res(), m.cell(0, 0, 0)), ([1, 1, 1], 2.0));
    assert!(check_majorant(&mut rng, &c, &m, 200) <= 1.0);
}

#[test]
fn shared_smoke_grid_reads_and_bounds() {
    let Some(shared) = common::shared() else { return };
    let path = shared.join("volumes/smoke.vol");
    let data = vol_file::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    // make_smoke_vol.py: 64³, one channel, normalised to a maximum of 1, box [-0.5, 0.5]³
    assert_eq!((data.res, data.channels, data.max()), ([64, 64, 64], 1, 1.0));
    assert_eq!(data.bbox, Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5)));
    let volume = Volume::Grid(GridVolume::new(data, GridOptions::default()).unwrap());
    let majorant = MajorantGrid::new(&volume, rdr::volume::majorant::DEFAULT_RES);
    let worst = check_majorant(&mut Rng::new(64), &volume, &majorant, 3000);
    println!("smoke.vol: largest eval/bound {worst:.6}");
    assert!(worst <= 1.0 + 1e-5, "{worst}");
}

fn vdb_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/vdb")
}

/// `(grid, world point, OpenVDB's value)` from `tests/data/vdb/expected.txt`.
fn openvdb_values() -> Vec<(String, Vec3, f32)> {
    let text = std::fs::read_to_string(vdb_dir().join("expected.txt")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let n: Vec<f32> = f[1..].iter().map(|s| s.parse().unwrap()).collect();
            (f[0].to_string(), Vec3::new(n[0], n[1], n[2]), n[3])
        })
        .collect()
}

#[test]
fn openvdb_files_read_as_openvdb_reads_them() {
    let expected = openvdb_values();
    let shift = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
    for file in ["small_zip.vdb", "small_raw.vdb"] {
        for name in ["density", "temperature"] {
            let g = vdb::read(&vdb_dir().join(file), name).unwrap_or_else(|e| panic!("{file} {name}: {e}"));
            let (mut inside, mut outside, mut worst) = (0, 0, 0.0f32);
            for filter in [GridFilter::Nearest, GridFilter::Trilinear] {
                let opts = GridOptions {
                    filter,
                    to_world: shift * g.to_world,
                    ..GridOptions::default()
                };
                let v = Volume::Grid(GridVolume::new(g.data.clone(), opts).unwrap());
                let b = v.world_bounds();
                for (_, p, want) in expected.iter().filter(|(n, _, _)| n == name) {
                    let p = shift.transform_point3(*p);
                    if p.cmpgt(b.min + 1e-3).all() && p.cmplt(b.max - 1e-3).all() {
                        inside += 1;
                        worst = worst.max((v.eval(p)[0] - want).abs() / want.abs().max(1.0));
                    } else {
                        // nothing lost outside the box: OpenVDB's background there
                        outside += 1;
                        assert_eq!(*want, 0.0, "{file} {name}: {p} outside the box holds {want}");
                    }
                }
            }
            println!("{file} {name}: {inside} voxel centres inside, {outside} outside, largest relative difference {worst}");
            assert!(inside > 50 && worst < 1e-5, "{file} {name}: {worst}");
        }
    }
}

#[test]
fn bad_vdb_files_are_refused_in_one_line() {
    let raw = std::fs::read(vdb_dir().join("small_raw.vdb")).unwrap();
    let patch = |find: f32, put: f32| {
        let at = raw.windows(4).position(|w| w == find.to_le_bytes()).expect("value in the file");
        let mut b = raw.clone();
        b[at..at + 4].copy_from_slice(&put.to_le_bytes());
        b
    };
    // the first root child of "density" moved 2^30 voxels away: a dense box of 2^90 voxels
    let mut far = raw.clone();
    let t = far.windows(24).position(|w| w == b"UniformScaleTranslateMap").unwrap() + 24 + 18 * 8;
    far[t + 16..t + 20].copy_from_slice(&(1i32 << 30).to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, &str, &str)> = vec![
        (
            "blosc",
            std::fs::read(vdb_dir().join("small_blosc.vdb")).unwrap(),
            "density",
            "Blosc",
        ),
        ("vec3s grid", raw.clone(), "velocity", "float grids"),
        ("missing grid", raw.clone(), "smoke", "\"density\", \"temperature\", \"velocity\""),
        ("truncated", raw[..raw.len() / 2].to_vec(), "density", "past the end of the file"),
        ("not vdb", b"VOL\x03 and more bytes".to_vec(), "density", "not an OpenVDB file"),
        ("NaN", patch(4.5, f32::NAN), "density", "voxel (20, 3, -5) holds NaN"),
        ("negative", patch(4.5, -4.5), "density", "not negative"),
        ("far apart", far, "density", "memory"),
    ];
    for (what, bytes, grid, expect) in cases {
        let e = vdb::parse(&bytes, grid).expect_err(what);
        println!("{what}: {e}");
        assert!(e.contains(expect) && !e.contains('\n'), "{what}: {e}");
    }
    // through a scene: the file and the key are named
    refused_in_scene("b.vdb", &std::fs::read(vdb_dir().join("small_blosc.vdb")).unwrap(), "Blosc");
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(vdb_dir().join("small_zip.vdb"), dir.path().join("z.vdb")).unwrap();
    let v = build_from_xml(
        dir.path(),
        r#"<volume type="gridvolume"><string name="filename" value="z.vdb"/><string name="grid" value="temperature"/></volume>"#,
    )
    .unwrap();
    assert_eq!(v.max(), 9.5);
}
