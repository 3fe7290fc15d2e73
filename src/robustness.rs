//! Entry points of the fuzz targets (`fuzz/fuzz_targets/*.rs`), shared with the
//! corpus replay and mutation test (`tests/fuzz_corpus.rs`) so stable `cargo test`
//! runs exactly what `cargo fuzz` runs. Each takes arbitrary bytes and must return
//! (an error is fine) without panicking, aborting or hanging.

use crate::geometry::mesh::Mesh;
use crate::geometry::{obj, ply};
use crate::math::{Mat4, Vec3};
use crate::texture::TextureConvention;
use std::path::Path;

/// The corpus folders and fuzz targets, by name.
pub const TARGETS: [&str; 10] = [
    "scene_json",
    "scene_xml",
    "obj",
    "ply",
    "serialized",
    "texture_image",
    "film_state",
    "ray_file",
    "vol_grid",
    "vdb_grid",
];

/// Runs target `name` on `data`; `Ok` when the input was accepted.
pub fn run(name: &str, data: &[u8]) -> Result<(), String> {
    match name {
        "scene_json" => scene_json(data),
        "scene_xml" => scene_xml(data),
        "serialized" => serialized_mesh(data),
        "obj" => obj_mesh(data),
        "ply" => ply_mesh(data),
        "texture_image" => texture_image(data),
        "film_state" => film_state(data),
        "ray_file" => ray_file(data),
        "vol_grid" => vol_grid(data),
        "vdb_grid" => vdb_grid(data),
        other => Err(format!("unknown fuzz target '{other}'")),
    }
}

/// The scene reader (and the OBJ reader on the same text).
pub fn scene_json(data: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(data);
    let file = Path::new("fuzz.json");
    let _ = obj::parse(&text);
    let value = crate::desc::json::parse_text(&text, file).map_err(|e| e.to_string())?;
    // `from_value` reads nothing from disk; the base folder only anchors paths
    let desc = crate::desc::SceneDesc::from_value(&value, file, Path::new(".")).map_err(|e| e.to_string())?;
    // the job (camera basis, film memory estimate) needs no file either
    crate::render::RenderJob::from_desc(&desc, crate::Profile::Physical).map_err(|e| e.to_string())?;
    Ok(())
}

/// The Mitsuba XML reader (structure, values and plugins; `<include>`s resolve in a
/// folder that does not exist, and no mesh or image is read).
pub fn scene_xml(data: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(data);
    let file = Path::new("fuzz-nonexistent-folder/fuzz.xml");
    let mut params = crate::desc::xml::document::Params::new(&[]);
    let root = crate::desc::xml::document::read_str(&text, file, &mut params).map_err(|e| e.to_string())?;
    let desc = crate::desc::xml::plugins::scene(&root, file).map_err(|e| e.to_string())?;
    crate::render::RenderJob::from_desc(&desc, crate::Profile::Physical).map_err(|e| e.to_string())?;
    Ok(())
}

/// The `.serialized` mesh reader (the first byte picks the mesh) and the mesh built from it.
pub fn serialized_mesh(data: &[u8]) -> Result<(), String> {
    let Some((&pick, bytes)) = data.split_first() else {
        return Err("empty".into());
    };
    let m = crate::geometry::serialized::parse(bytes, (pick % 4) as u32).map_err(|e| format!("{e:#}"))?;
    let _ = Mesh::from_obj(m.data, &Mat4::IDENTITY, Vec3::ZERO, true);
    Ok(())
}

/// The OBJ reader and the mesh built from it.
pub fn obj_mesh(data: &[u8]) -> Result<(), String> {
    let d = obj::parse_bytes(data).map_err(|e| e.to_string())?;
    let _ = Mesh::from_obj(d, &Mat4::IDENTITY, Vec3::ZERO, true);
    Ok(())
}

/// The PLY reader and the mesh built from it.
pub fn ply_mesh(data: &[u8]) -> Result<(), String> {
    let d = ply::parse_ply(data).map_err(|e| format!("{e:#}"))?;
    let _ = Mesh::from_obj(d, &Mat4::IDENTITY, Vec3::ZERO, true);
    Ok(())
}

/// The texture loader: the first byte picks the file name's extension (the decoder
/// also guesses from the content), the rest is the file; then its MIP pyramid.
pub fn texture_image(data: &[u8]) -> Result<(), String> {
    let Some((&pick, bytes)) = data.split_first() else {
        return Err("empty".into());
    };
    let name = ["fuzz.exr", "fuzz.png", "fuzz.hdr", "fuzz.jpg"][pick as usize % 4];
    let conv = if pick & 4 == 0 {
        TextureConvention::Physical
    } else {
        TextureConvention::Rdr171
    };
    crate::texture::image::decode_mipmap(bytes, Path::new(name), conv, true).map_err(|e| format!("{e:#}"))?;
    Ok(())
}

/// The film state an output EXR carries (`--resume`, `rdr merge`): the EXR reader, the
/// state's decoding, the image made from it and a merge of the file with itself (which
/// must be refused as overlapping or pass).
pub fn film_state(data: &[u8]) -> Result<(), String> {
    let Some(file) = crate::render::statefile::decode_bytes(data)? else {
        return Ok(());
    };
    let _ = crate::render::statefile::image(file.width, file.height, &file.state);
    let path = std::path::PathBuf::from("fuzz.exr");
    let _ = crate::render::statefile::merge(vec![(path.clone(), file.clone()), (path, file)], true);
    Ok(())
}

/// The `rdr bench --ray-file` reader.
pub fn ray_file(data: &[u8]) -> Result<(), String> {
    crate::bench::ray_file::parse_rays(data, Path::new("fuzz.rays.f32")).map_err(|e| format!("{e:#}"))?;
    Ok(())
}

/// Mitsuba's `.vol` grid reader, then the grid's lookups and majorant grid; and the
/// same bytes as an `sdfgrid`'s distances (its checks, voxels, hits and normals).
pub fn vol_grid(data: &[u8]) -> Result<(), String> {
    sdf_grid(data);
    grid_lookups(crate::volume::vol_file::parse(data)?, crate::math::Mat4::IDENTITY)
}

/// A `.vol` file read as an sdfgrid, and rays through the first of its voxels: from
/// outside each voxel's box, through its centre.
fn sdf_grid(data: &[u8]) {
    use crate::geometry::sdfgrid::{SdfGrid, SdfNormals};
    let Ok(f) = crate::volume::vol_file::parse_file(data) else { return };
    if f.channels != 1 {
        return;
    }
    let Ok(g) = SdfGrid::new(f.res, f.values, Mat4::IDENTITY, SdfNormals::Smooth) else {
        return;
    };
    for v in g.voxels().take(64) {
        let b = v.bounds();
        let (c, e) = (b.centroid(), b.extent() + crate::math::Vec3::ONE);
        for d in [
            crate::math::Vec3::new(1.0, 0.3, 0.2),
            crate::math::Vec3::new(-0.2, 1.0, -0.7),
            crate::math::Vec3::Z,
        ] {
            if let Some(t) = v.intersect(c - d * e, d, 0.0, f32::INFINITY) {
                let p = c - d * e + d * t;
                let _ = g.shading_normal(p, v.normal(p));
            }
        }
    }
}

/// The OpenVDB reader on grid `density` (made dense within a budget of at most 64 MB
/// here, so the fuzzer's memory limit is not what stops a file that lies), then the
/// grid's lookups and majorant grid.
pub fn vdb_grid(data: &[u8]) -> Result<(), String> {
    crate::limits::set_memory_budget(crate::limits::memory_budget().min(64 << 20));
    let g = crate::volume::vdb::parse(data, "density")?;
    grid_lookups(g.data, g.to_world)
}

fn grid_lookups(data: crate::volume::GridData, to_world: Mat4) -> Result<(), String> {
    use crate::volume::{grid::GridOptions, GridFilter, GridVolume, MajorantGrid, Volume, WrapMode};
    for (filter, wrap) in [(GridFilter::Trilinear, WrapMode::Clamp), (GridFilter::Nearest, WrapMode::Mirror)] {
        let opts = GridOptions {
            filter,
            wrap,
            to_world,
            ..GridOptions::default()
        };
        let v = Volume::Grid(GridVolume::new(data.clone(), opts)?);
        let m = MajorantGrid::new(&v, [4, 4, 4]);
        let b = v.world_bounds();
        for s in m.iter(b.min - (b.max - b.min), b.max - b.min, 0.0, 3.0) {
            let _ = v.eval(b.min + 0.5 * (s.t0 + s.t1) * (b.max - b.min) - (b.max - b.min));
        }
    }
    Ok(())
}
