//! The film state of a render, in a file beside its image: `out.exr` is a plain,
//! ZIP-compressed RGB EXR (with the `--aov` layers) for viewers, and `out.state.exr`
//! holds everything `--resume` and `rdr merge` continue from. The state file is an EXR
//! too: the same float RGB image, so any viewer opens it, plus every piece of
//! [`FilmState`] as uint channels (each f64 sum, weight and splat split into its high
//! and low 32 bits, so nothing is rounded), uncompressed, and `rdr:` attributes saying
//! what made it. It carries its own identity (scene, assets, seed, integrator), so a
//! state file that went stale or was paired with the wrong image is refused by name,
//! never silently continued; and the image file no longer carries 20-odd state channels
//! that viewers show as junk layers.
//!
//! Channels of piece `i`: `rdr.state<i>.sum.{R,G,B}.{hi,lo}`, `…weight.{hi,lo}` and,
//! when the piece has splats, `…splat.{R,G,B}.{hi,lo}`; rows top-down like the image.
//! Attributes (all strings, no timestamps, so equal renders have equal headers):
//! `rdr:version`, `rdr:commit`, `rdr:scene`, `rdr:assets`, `rdr:integrator`,
//! `rdr:seed`, `rdr:target_spp`, `rdr:spp` (the passes of the whole render),
//! `rdr:block_passes`, `rdr:passes` (ranges held), `rdr:shard` (`K/N`, for a shard),
//! `rdr:state` (each piece's pass range, in channel order; in the state file only);
//! and the standard `chromaticities` (linear sRGB). The image file has the same
//! attributes but `rdr:state`.

use super::blocks::{format_ranges, parse_ranges, FilmState, Piece, BLOCK_PASSES};
use super::identity::RenderIdentity;
use crate::film::Sums;
use crate::imageio::{rgb_channels, ChannelData, ExrAttribute, ExrChannel, RawExr};
use crate::math::Vec3;
use anyhow::{bail, Result};
use std::path::Path;

/// What a state file's header says besides the pieces.
#[derive(Clone, Debug, PartialEq)]
pub struct StateHeader {
    pub identity: RenderIdentity,
    /// Passes of the whole render the file is (a part of).
    pub spp: u32,
    /// `(k, n)` for shard k of n.
    pub shard: Option<(u32, u32)>,
    pub version: String,
    pub commit: String,
}

/// A state file read back.
#[derive(Clone, Debug)]
pub struct StateFile {
    pub width: u32,
    pub height: u32,
    pub header: StateHeader,
    pub state: FilmState,
}

fn split(v: f64) -> (u32, u32) {
    let b = v.to_bits();
    ((b >> 32) as u32, b as u32)
}

/// The bytes of a state file: `pixels` (row 0 = top), the film state when the
/// integrator's passes can be resumed (else the attributes alone), and extra channels.
pub fn encode(
    width: u32,
    height: u32,
    pixels: &[Vec3],
    state: &FilmState,
    resumable: bool,
    header: &StateHeader,
    extra: Vec<ExrChannel>,
) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let mut channels = rgb_channels("", pixels);
    channels.extend(extra);
    let pieces_written = if resumable { &state.pieces[..] } else { &[] };
    // film rows are y up: row r of the file is film row h-1-r
    let top_down = |j: usize| (h - 1 - j / w) * w + j % w;
    for (i, p) in pieces_written.iter().enumerate() {
        let mut push = |name: String, f: &dyn Fn(usize) -> f64| {
            let (mut hi, mut lo) = (Vec::with_capacity(w * h), Vec::with_capacity(w * h));
            for j in 0..w * h {
                let (a, b) = split(f(top_down(j)));
                hi.push(a);
                lo.push(b);
            }
            channels.push(ExrChannel {
                name: format!("{name}.hi"),
                data: ChannelData::U32(hi),
            });
            channels.push(ExrChannel {
                name: format!("{name}.lo"),
                data: ChannelData::U32(lo),
            });
        };
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            push(format!("rdr.state{i}.sum.{n}"), &|j| p.sums.sum[j][c]);
        }
        push(format!("rdr.state{i}.weight"), &|j| p.sums.weight[j]);
        if let Some(s) = &p.sums.splat {
            for (c, n) in ["R", "G", "B"].iter().enumerate() {
                push(format!("rdr.state{i}.splat.{n}"), &|j| s[j][c]);
            }
        }
    }
    let attrs = attributes(state, resumable, header);
    crate::imageio::encode_exr_channels(width, height, &channels, &attrs)
}

/// The header attributes of the image and state files (`rdr:state` when `with_state`).
fn attributes(state: &FilmState, with_state: bool, header: &StateHeader) -> Vec<ExrAttribute> {
    let id = &header.identity;
    let mut attrs = vec![
        ExrAttribute::text("rdr:version", &header.version),
        ExrAttribute::text("rdr:commit", &header.commit),
        ExrAttribute::text("rdr:scene", &id.scene),
        ExrAttribute::text("rdr:assets", &id.assets),
        ExrAttribute::text("rdr:integrator", &id.integrator),
        ExrAttribute::text("rdr:seed", &id.seed.to_string()),
        ExrAttribute::text("rdr:target_spp", &id.target_spp.to_string()),
        ExrAttribute::text("rdr:spp", &header.spp.to_string()),
        ExrAttribute::text("rdr:block_passes", &BLOCK_PASSES.to_string()),
        ExrAttribute::text("rdr:passes", &format_ranges(&state.ranges())),
    ];
    if let Some((k, n)) = header.shard {
        attrs.push(ExrAttribute::text("rdr:shard", &format!("{k}/{n}")));
    }
    if with_state {
        let pieces: Vec<_> = state.pieces.iter().map(|p| p.passes.clone()).collect();
        attrs.push(ExrAttribute::text("rdr:state", &format_ranges(&pieces)));
    }
    attrs.push(ExrAttribute::chromaticities_srgb());
    attrs
}

/// The bytes of the image file: `pixels` and the `extra` layers, ZIP-compressed, with
/// the attributes saying what made it (the state's pass ranges, not its sums).
pub fn encode_image(width: u32, height: u32, pixels: &[Vec3], state: &FilmState, header: &StateHeader, extra: Vec<ExrChannel>) -> Vec<u8> {
    let mut channels = rgb_channels("", pixels);
    channels.extend(extra);
    let attrs = attributes(state, false, header);
    crate::imageio::encode_exr_channels_as(width, height, &channels, &attrs, crate::imageio::ExrCompression::Zip)
}

/// Where the state of the image `output` goes: `out.exr` → `out.state.exr`.
pub fn state_path(output: &Path) -> std::path::PathBuf {
    output.with_extension("state.exr")
}

/// The state that goes with `path`: its state file when there is one, else the state
/// `path` itself holds (a state file named directly, or an output of an rdr that kept
/// the state inside the image). Returns the file read and its state; `Ok(None)` when
/// neither holds one.
pub fn read_for(path: &Path) -> Result<Option<(std::path::PathBuf, StateFile)>> {
    let beside = state_path(path);
    let file = if beside.exists() { beside } else { path.to_path_buf() };
    Ok(read(&file)?.map(|s| (file, s)))
}

/// Reads an output EXR with its film state. `Ok(None)` when the file is an image
/// without rdr's state (written by something else, or with `--compat rdr171`).
/// [`read`] on a file's bytes: `Ok(None)` for an EXR without rdr's state, an error for
/// anything that is not an EXR as rdr writes it or whose state is inconsistent.
pub fn decode_bytes(bytes: &[u8]) -> std::result::Result<Option<StateFile>, String> {
    let raw = crate::imageio::decode_exr_channels(bytes)?;
    if raw.text("rdr:state").is_none() {
        return Ok(None);
    }
    decode(&raw).map(Some)
}

pub fn read(path: &Path) -> Result<Option<StateFile>> {
    let raw = match crate::imageio::read_exr_channels(path) {
        Ok(r) => r,
        Err(_) if crate::imageio::read_exr(path).is_ok() => return Ok(None),
        Err(e) => return Err(e),
    };
    if raw.text("rdr:state").is_none() {
        return Ok(None);
    }
    decode(&raw).map(Some).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))
}

fn decode(raw: &RawExr) -> std::result::Result<StateFile, String> {
    let text = |n: &str| raw.text(n).ok_or_else(|| format!("attribute {n} missing"));
    let number = |n: &str| -> std::result::Result<u32, String> { text(n)?.parse().map_err(|_| format!("attribute {n} is not a number")) };
    if number("rdr:block_passes")? != BLOCK_PASSES {
        return Err(format!(
            "made with blocks of {} passes, this rdr adds blocks of {BLOCK_PASSES}",
            text("rdr:block_passes")?
        ));
    }
    let shard = match raw.text("rdr:shard") {
        None => None,
        Some(s) => {
            let bad = || format!("attribute rdr:shard '{s}' is not K/N");
            let (k, n) = s.split_once('/').ok_or_else(bad)?;
            Some((k.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?))
        }
    };
    let header = StateHeader {
        identity: RenderIdentity {
            scene: text("rdr:scene")?,
            assets: text("rdr:assets")?,
            integrator: text("rdr:integrator")?,
            seed: number("rdr:seed")?,
            target_spp: number("rdr:target_spp")?,
        },
        spp: number("rdr:spp")?,
        shard,
        version: text("rdr:version")?,
        commit: text("rdr:commit")?,
    };
    let ranges = parse_ranges(&text("rdr:state")?).ok_or("attribute rdr:state is not a list of pass ranges")?;
    let (w, h) = (raw.width as usize, raw.height as usize);
    let from_top = |j: usize| (h - 1 - j / w) * w + j % w;
    let mut state = FilmState::default();
    for (i, r) in ranges.into_iter().enumerate() {
        let f64s = |name: &str| -> Option<Vec<f64>> {
            let (ChannelData::U32(hi), ChannelData::U32(lo)) = (raw.channel(&format!("{name}.hi"))?, raw.channel(&format!("{name}.lo"))?)
            else {
                return None;
            };
            let mut out = vec![0.0; w * h];
            for j in 0..w * h {
                out[from_top(j)] = f64::from_bits(((hi[j] as u64) << 32) | lo[j] as u64);
            }
            Some(out)
        };
        let rgb = |what: &str| -> Option<Vec<[f64; 3]>> {
            let c: Vec<Vec<f64>> = ["R", "G", "B"]
                .iter()
                .map(|n| f64s(&format!("rdr.state{i}.{what}.{n}")))
                .collect::<Option<_>>()?;
            Some((0..w * h).map(|j| [c[0][j], c[1][j], c[2][j]]).collect())
        };
        let missing = || format!("channels of piece {i} (passes {}-{}) missing", r.start, r.end);
        let sums = Sums {
            sum: rgb("sum").ok_or_else(missing)?,
            weight: f64s(&format!("rdr.state{i}.weight")).ok_or_else(missing)?,
            splat: rgb("splat"),
        };
        state.pieces.push(Piece { passes: r, sums });
    }
    if let Some((a, b)) = state.overlap() {
        return Err(format!("pieces {}-{} and {}-{} overlap", a.start, a.end, b.start, b.end));
    }
    Ok(StateFile {
        width: raw.width,
        height: raw.height,
        header,
        state,
    })
}

/// Why the passes of `file` (described by `theirs`) cannot be added to a render
/// described by `ours`, or `None`. `what` is "resume" or "merge".
pub fn mismatch(ours: &RenderIdentity, theirs: &RenderIdentity) -> Option<String> {
    if ours.integrator != theirs.integrator {
        return Some(format!(
            "it was rendered with integrator {}, not {}",
            theirs.integrator, ours.integrator
        ));
    }
    if ours.seed != theirs.seed {
        return Some(format!("it was rendered with seed {}, not {}", theirs.seed, ours.seed));
    }
    if ours.scene != theirs.scene {
        return Some("it was rendered from a different scene description (file or --override)".into());
    }
    if ours.assets != theirs.assets {
        return Some("an asset (mesh or texture file) of the scene has changed since it was rendered".into());
    }
    if ours.target_spp != theirs.target_spp {
        return Some(format!(
            "the scene declared spp {} then, {} now (it sets the texture filtering)",
            theirs.target_spp, ours.target_spp
        ));
    }
    None
}

/// The parts of a render merged: identical headers (shard aside), no overlap, and
/// no gap unless `partial`. Returns the merged file and the pass ranges missing.
pub fn merge(parts: Vec<(std::path::PathBuf, StateFile)>, partial: bool) -> Result<(StateFile, Vec<std::ops::Range<u32>>)> {
    let Some((first_path, first)) = parts.first().cloned() else {
        bail!("merge: no parts given");
    };
    let mut owner: Vec<(std::ops::Range<u32>, &Path)> = Vec::new();
    for (path, p) in &parts {
        if (p.width, p.height) != (first.width, first.height) {
            bail!(
                "{}: {}x{} pixels, but {} has {}x{}: not parts of one render",
                path.display(),
                p.width,
                p.height,
                first_path.display(),
                first.width,
                first.height
            );
        }
        if let Some(why) = mismatch(&first.header.identity, &p.header.identity) {
            bail!("{}: not a part of the render of {}: {why}", path.display(), first_path.display());
        }
        if p.header.spp != first.header.spp {
            bail!(
                "{}: a part of a render of {} passes, but {} is of {}",
                path.display(),
                p.header.spp,
                first_path.display(),
                first.header.spp
            );
        }
        for piece in &p.state.pieces {
            if let Some((r, other)) = owner.iter().find(|(r, _)| r.start < piece.passes.end && piece.passes.start < r.end) {
                bail!(
                    "{}: passes {}-{} overlap passes {}-{} of {}",
                    path.display(),
                    piece.passes.start,
                    piece.passes.end,
                    r.start,
                    r.end,
                    other.display()
                );
            }
            owner.push((piece.passes.clone(), path));
        }
    }
    let mut state = FilmState {
        pieces: parts.iter().flat_map(|(_, p)| p.state.pieces.clone()).collect(),
    };
    state.combine();
    let mut missing = Vec::new();
    let mut at = 0;
    for r in state.ranges() {
        if r.start > at {
            missing.push(at..r.start);
        }
        at = r.end;
    }
    if at < first.header.spp {
        missing.push(at..first.header.spp);
    }
    if !missing.is_empty() && !partial {
        bail!(
            "passes {} of {} are missing (no part holds them; --partial merges what there is)",
            format_ranges(&missing),
            first.header.spp
        );
    }
    let header = StateHeader {
        shard: None,
        ..first.header.clone()
    };
    Ok((
        StateFile {
            width: first.width,
            height: first.height,
            header,
            state,
        },
        missing,
    ))
}

/// The image of a state: its pieces' sum, splats scaled by 1 / passes held.
pub fn image(width: u32, height: u32, state: &FilmState) -> Vec<Vec3> {
    match state.total() {
        Some(s) => crate::film::rgb_rows(width, height, &s, None, 1.0 / state.passes_done().max(1) as f64),
        None => vec![Vec3::ZERO; width as usize * height as usize],
    }
}
