//! Unit tests of the image readers and writers.
use super::*;

#[test]
fn an_exr_claiming_more_pixels_than_its_bytes_hold_is_refused_before_allocating() {
    // found by cargo-fuzz: 506 bytes whose second header claims 268 M pixels; decoding
    // allocated 3.2 GB before failing on the missing data
    let name = "fuzz/corpus/texture_image/exr-claims-268M-pixels";
    let bytes = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join(name)).unwrap();
    // the fuzz target's first byte picks the format (0: EXR)
    let e = decode_exr(&bytes[1..], Path::new("fuzz.exr"), 12).unwrap_err().to_string();
    assert!(e.contains("pixels, more than its 505 bytes can hold"), "{e}");
}

#[test]
fn tinyexr_rounding_is_half_away_from_zero() {
    // exactly halfway between two halves: 1 + 2^-11 → rounds up (RTNE would keep 1.0)
    assert_eq!(f32_to_half_tinyexr(1.0 + 2f32.powi(-11)), 0x3c01);
    assert_eq!(f32_to_half_tinyexr(1.0), 0x3c00);
    assert_eq!(f32_to_half_tinyexr(-2.0), 0xc000);
    assert_eq!(f32_to_half_tinyexr(65504.0), 0x7bff);
    assert_eq!(f32_to_half_tinyexr(1e6), 0x7c00);
    assert_eq!(f32_to_half_tinyexr(f32::NAN) & 0x7e00, 0x7e00);
    assert_eq!(f32_to_half_tinyexr(0.0), 0);
    // smallest half subnormal 2^-24
    assert_eq!(f32_to_half_tinyexr(2f32.powi(-24)), 1);
    // values away from ties agree with IEEE rounding
    for i in 0..10000 {
        let x = (i as f32 * 0.731).sin() * 100.0;
        let h = exr::prelude::f16::from_f32(x);
        let mid = (h.to_f32() - x).abs() * 2.0 == (h.to_f32() - exr::prelude::f16::from_bits(h.to_bits() ^ 1).to_f32()).abs();
        if !mid {
            assert_eq!(f32_to_half_tinyexr(x), h.to_bits(), "{x}");
        }
    }
}

#[test]
fn exr_round_trip_float_and_half() {
    let dir = std::env::temp_dir().join(format!("rdr-exr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let px: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, 0.5 * i as f32, 0.25)).collect();
    for (kind, name) in [(ExrPixels::Float, "f.exr"), (ExrPixels::HalfTinyexr, "h.exr")] {
        let p = dir.join(name);
        write_exr(&p, 3, 2, &px, kind).unwrap();
        let img = read_exr(&p).unwrap();
        assert_eq!((img.width, img.height), (3, 2));
        assert_eq!(img.pixels, px);
    }
    let size = std::fs::metadata(dir.join("h.exr")).unwrap().len();
    assert_eq!(size, 313 + 2 * 8 + 2 * (8 + 6 * 3));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn channel_writer_reads_back_half_float_and_uint() {
    let px: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, 0.5 * i as f32, 0.25)).collect();
    // half channels (RDR171's files) read back as their bit patterns, beside float ones
    let half = decode_exr_channels(&encode_exr(3, 2, &px, ExrPixels::HalfTinyexr)).unwrap();
    let bits: Vec<u16> = px.iter().map(|p| f32_to_half_tinyexr(p.y)).collect();
    assert_eq!(half.channel("G"), Some(&ChannelData::F16(bits)));
    assert_eq!(half.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(), ["B", "G", "R"]);
    let mut ch = rgb_channels("", &px);
    ch.push(ExrChannel {
        name: "rdr.x".into(),
        data: ChannelData::U32(vec![1, 2, 3, u32::MAX, 5, 6]),
    });
    let attrs = [ExrAttribute::text("rdr:seed", "7"), ExrAttribute::chromaticities_srgb()];
    let bytes = encode_exr_channels(3, 2, &ch, &attrs);
    let raw = decode_exr_channels(&bytes).unwrap();
    assert_eq!(raw.text("rdr:seed").as_deref(), Some("7"));
    assert_eq!(raw.channel("rdr.x"), Some(&ChannelData::U32(vec![1, 2, 3, u32::MAX, 5, 6])));
    assert!(decode_exr_channels(&bytes[..bytes.len() - 1]).is_err());
    // the exr crate reads the RGB of such a file
    let img = decode_exr(&bytes, Path::new("x.exr"), 12).unwrap();
    assert_eq!(img.pixels, px);
}

#[test]
fn zip_exr_reads_back_exactly_here_and_in_the_exr_crate() {
    // 37x41: the last block of 16 rows is short; a smooth ramp compresses, the
    // hashed channel does not (its blocks are stored as they are)
    let (w, h) = (37usize, 41usize);
    let px: Vec<Vec3> = (0..w * h)
        .map(|i| Vec3::new((i % w) as f32 / 7.0, (i / w) as f32 * 0.25, 0.5))
        .collect();
    let noise: Vec<u32> = (0..w * h)
        .map(|i| (i as u32).wrapping_mul(0x9e37_79b9).rotate_left(13) ^ 0x5bd1_e995)
        .collect();
    let mut ch = rgb_channels("", &px);
    ch.push(ExrChannel {
        name: "rdr.noise".into(),
        data: ChannelData::U32(noise.clone()),
    });
    ch.push(ExrChannel {
        name: "half.Y".into(),
        data: ChannelData::F16(px.iter().map(|p| f32_to_half_tinyexr(p.x)).collect()),
    });
    let attrs = [ExrAttribute::text("rdr:seed", "7")];
    let zip = encode_exr_channels_as(w as u32, h as u32, &ch, &attrs, ExrCompression::Zip);
    let plain = encode_exr_channels(w as u32, h as u32, &ch, &attrs);
    assert!(zip.len() < plain.len(), "{} vs {} bytes", zip.len(), plain.len());
    let raw = decode_exr_channels(&zip).unwrap();
    assert_eq!(raw.text("rdr:seed").as_deref(), Some("7"));
    assert_eq!(raw.channel("rdr.noise"), Some(&ChannelData::U32(noise)));
    let mut want = ch.clone();
    want.sort_by(|a, b| a.name.cmp(&b.name));
    assert_eq!(raw.channels, want);
    // an independent reader: the exr crate's ZIP decoder gives the same pixels
    let img = decode_exr(&zip, Path::new("x.exr"), 16).unwrap();
    let differ = img.pixels.iter().zip(&px).filter(|(a, b)| a != b).count();
    assert!(differ == 0, "the exr crate reads {differ} of {} pixels differently", px.len());
    // a cut or corrupt file is an error, not a panic
    assert!(decode_exr_channels(&zip[..zip.len() - 3]).is_err());
    let mut bad = zip.clone();
    let n = bad.len();
    bad[n - 40] ^= 0x55;
    assert!(decode_exr_channels(&bad).is_err() || decode_exr_channels(&bad).unwrap().channels != want);
}

/// cargo-fuzz's film_state finding: a header listing no channels and claiming
/// 1073741828x18 pixels passed the size checks (no channels, no bytes needed) and a
/// buffer of every pixel was reserved anyway (77 GB).
#[test]
fn an_exr_without_channels_is_refused_before_allocating() {
    // ZIP, 40 rows: the file holds the offsets of the two blocks 18 rows make
    let mut b = encode_exr_channels_as(1, 40, &rgb_channels("", &[Vec3::ONE; 40]), &[], ExrCompression::Zip);
    let key = b"channels\0chlist\0";
    let at = b.windows(key.len()).position(|x| x == key).unwrap() + key.len() + 4;
    b[at] = 0; // the list ends before its first channel
    let key = b"dataWindow\0box2i\0";
    let at = b.windows(key.len()).position(|x| x == key).unwrap() + key.len() + 4;
    b[at + 8..at + 12].copy_from_slice(&0x4000_0003i32.to_le_bytes());
    b[at + 12..at + 16].copy_from_slice(&17i32.to_le_bytes());
    assert_eq!(decode_exr_channels(&b).unwrap_err(), "the header lists no channels");
}

#[test]
fn srgb_encoding() {
    assert_eq!(linear_to_srgb8(0.0), 0);
    assert_eq!(linear_to_srgb8(1.0), 255);
    assert_eq!(linear_to_srgb8(0.2159), 128);
    assert_eq!(linear_to_srgb8(7.0), 255);
}
