//! What made an image, as the `rdr:` EXR attributes say it: hashes of the resolved
//! scene description and of its assets' bytes, the integrator and its keys, the seed.
//! A resume or a merge is refused when any of them differs.

use crate::desc::SceneDesc;
use serde_json::Value;
use std::path::Path;

/// The identity of a render's passes: two renders with equal identities render equal
/// passes (the total spp and the shard aside).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderIdentity {
    /// SHA-256 of the description (overrides applied, `integrator.spp` left out: it is
    /// the render's length, not what a pass computes), canonical JSON; for Mitsuba XML
    /// the top file's bytes, the `-D` defines and every `<include>`d file's bytes.
    pub scene: String,
    /// SHA-256 over every asset file's path (as written) and bytes, in scene order.
    pub assets: String,
    /// The integrator section as canonical JSON, `spp` left out.
    pub integrator: String,
    pub seed: u32,
    /// The spp the scene declares (see `RenderJob::target_spp`).
    pub target_spp: u32,
}

impl RenderIdentity {
    /// The identity of `desc` (read from `file` with `overrides`, and a Mitsuba XML
    /// file's `-D` `defines`) rendered with `seed`.
    pub fn of(
        file: &Path,
        overrides: &[String],
        defines: &[(String, String)],
        desc: &SceneDesc,
        seed: u32,
    ) -> anyhow::Result<RenderIdentity> {
        let mut value = resolved_json(file, overrides)?;
        if !defines.is_empty() {
            let d: serde_json::Map<String, Value> = defines.iter().map(|(k, v)| (k.clone(), Value::String(v.clone()))).collect();
            value = serde_json::json!({"file": value, "defines": d});
        }
        if !desc.included.is_empty() {
            // an XML scene's included files are part of its description: their bytes
            let mut files = Vec::new();
            for p in &desc.included {
                let bytes = crate::limits::read_input_file(p, crate::limits::max_input_file())
                    .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", p.display()))?;
                files.push(serde_json::json!([p.to_string_lossy(), Sha256::digest_hex(&bytes)]));
            }
            value = serde_json::json!({"file": value, "included": files});
        }
        let integrator = value.get("integrator").map_or_else(|| "{}".into(), canonical);
        let scene = Sha256::digest_hex(canonical(&value).as_bytes());
        let mut assets = Sha256::new();
        for p in desc.asset_paths() {
            let full = desc.base_dir.join(&p);
            let bytes = std::fs::read(&full).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", full.display()))?;
            assets.update(&(p.len() as u64).to_le_bytes());
            assets.update(p.as_bytes());
            assets.update(&(bytes.len() as u64).to_le_bytes());
            assets.update(&bytes);
        }
        Ok(RenderIdentity {
            scene: format!("sha256:{scene}"),
            assets: format!("sha256:{}", hex(&assets.finish())),
            integrator,
            seed,
            target_spp: desc.integrator.spp,
        })
    }
}

/// The scene file's JSON with the overrides merged, as the description layer reads it.
fn resolved_json(file: &Path, overrides: &[String]) -> anyhow::Result<Value> {
    let bytes = crate::limits::read_input_file(file, crate::limits::max_input_file())
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", file.display()))?;
    let mut value: Value = match serde_json::from_slice(&bytes) {
        Ok(v) => v,
        // not JSON (a format the description layer reads some other way): its bytes
        Err(_) => Value::String(String::from_utf8_lossy(&bytes).into_owned()),
    };
    for o in overrides {
        if let Ok(p) = serde_json::from_str::<Value>(o) {
            crate::desc::json::merge(&mut value, &p);
        }
    }
    if let Some(i) = value.get_mut("integrator").and_then(Value::as_object_mut) {
        i.remove("spp");
    }
    Ok(value)
}

/// JSON with object keys sorted at every level, no spaces.
fn canonical(v: &Value) -> String {
    match v {
        Value::Object(m) => {
            let mut keys: Vec<&String> = m.keys().collect();
            keys.sort();
            let items: Vec<String> = keys
                .iter()
                .map(|k| format!("{}:{}", Value::String((*k).clone()), canonical(&m[*k])))
                .collect();
            format!("{{{}}}", items.join(","))
        }
        Value::Array(a) => format!("[{}]", a.iter().map(canonical).collect::<Vec<_>>().join(",")),
        other => other.to_string(),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 (FIPS 180-4), written out: the hashes only identify inputs, and a crate
/// for one function would add a handful of dependencies.
pub struct Sha256 {
    state: [u32; 8],
    buffer: Vec<u8>,
    length: u64,
}

const K: [u32; 64] = [
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be,
    0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa,
    0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85,
    0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3,
    0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f,
    0x682e6ff3, 0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2,
];

impl Default for Sha256 {
    fn default() -> Self {
        Self::new()
    }
}

impl Sha256 {
    pub fn new() -> Self {
        Sha256 {
            state: [
                0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19,
            ],
            buffer: Vec::with_capacity(64),
            length: 0,
        }
    }

    pub fn update(&mut self, mut data: &[u8]) {
        self.length += data.len() as u64;
        if !self.buffer.is_empty() {
            let take = (64 - self.buffer.len()).min(data.len());
            self.buffer.extend_from_slice(&data[..take]);
            data = &data[take..];
            if self.buffer.len() == 64 {
                let block: [u8; 64] = self.buffer[..].try_into().unwrap();
                self.compress(&block);
                self.buffer.clear();
            }
        }
        let mut chunks = data.chunks_exact(64);
        for c in &mut chunks {
            self.compress(c.try_into().unwrap());
        }
        self.buffer.extend_from_slice(chunks.remainder());
    }

    pub fn finish(mut self) -> [u8; 32] {
        let bits = self.length.wrapping_mul(8);
        let mut pad = vec![0x80u8];
        while (self.buffer.len() + pad.len()) % 64 != 56 {
            pad.push(0);
        }
        pad.extend_from_slice(&bits.to_be_bytes());
        let len = self.length;
        self.update(&pad);
        self.length = len;
        let mut out = [0u8; 32];
        for (i, w) in self.state.iter().enumerate() {
            out[4 * i..4 * i + 4].copy_from_slice(&w.to_be_bytes());
        }
        out
    }

    pub fn digest_hex(data: &[u8]) -> String {
        let mut h = Sha256::new();
        h.update(data);
        hex(&h.finish())
    }

    fn compress(&mut self, block: &[u8; 64]) {
        let mut w = [0u32; 64];
        for i in 0..16 {
            w[i] = u32::from_be_bytes(block[4 * i..4 * i + 4].try_into().unwrap());
        }
        for i in 16..64 {
            let s0 = w[i - 15].rotate_right(7) ^ w[i - 15].rotate_right(18) ^ (w[i - 15] >> 3);
            let s1 = w[i - 2].rotate_right(17) ^ w[i - 2].rotate_right(19) ^ (w[i - 2] >> 10);
            w[i] = w[i - 16].wrapping_add(s0).wrapping_add(w[i - 7]).wrapping_add(s1);
        }
        let [mut a, mut b, mut c, mut d, mut e, mut f, mut g, mut h] = self.state;
        for i in 0..64 {
            let s1 = e.rotate_right(6) ^ e.rotate_right(11) ^ e.rotate_right(25);
            let ch = (e & f) ^ (!e & g);
            let t1 = h.wrapping_add(s1).wrapping_add(ch).wrapping_add(K[i]).wrapping_add(w[i]);
            let s0 = a.rotate_right(2) ^ a.rotate_right(13) ^ a.rotate_right(22);
            let maj = (a & b) ^ (a & c) ^ (b & c);
            let t2 = s0.wrapping_add(maj);
            h = g;
            g = f;
            f = e;
            e = d.wrapping_add(t1);
            d = c;
            c = b;
            b = a;
            a = t1.wrapping_add(t2);
        }
        for (s, v) in self.state.iter_mut().zip([a, b, c, d, e, f, g, h]) {
            *s = s.wrapping_add(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_test_vectors() {
        assert_eq!(
            Sha256::digest_hex(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            Sha256::digest_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let long = b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
        assert_eq!(
            Sha256::digest_hex(long),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"
        );
        // fed in pieces of odd sizes
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
        let mut h = Sha256::new();
        for c in data.chunks(37) {
            h.update(c);
        }
        assert_eq!(hex(&h.finish()), Sha256::digest_hex(&data));
    }

    #[test]
    fn canonical_json_sorts_keys() {
        let a: Value = serde_json::from_str(r#"{"b": [1, {"y": 2, "x": 1}], "a": "s"}"#).unwrap();
        assert_eq!(canonical(&a), r#"{"a":"s","b":[1,{"x":1,"y":2}]}"#);
    }
}
