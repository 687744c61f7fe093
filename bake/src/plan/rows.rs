//! The files between the steps of a planned bake: a shard's rows ([`Rows`], `rows-K-HASH.bin`)
//! and the cache a planned bake leaves beside its level (`OUT.rad.rows`, [`Cache`]) for a
//! later rebake (`docs/contract.md`, "Shard and cache files").
//!
//! Both are little-endian: an 8-byte magic, a version, the fields in order (each list led
//! by its length), and the BLAKE3 hash of everything before it, so that a truncated or
//! damaged file is refused as such. Written by hand, not by a serialisation crate: the
//! layout is part of the contract, and it is a dozen fields.

use crate::form_factor::cast::HitCounts;
use crate::pipeline::SystemRecord;
use glam::DVec3;

const ROWS_MAGIC: &[u8; 8] = b"RADROWS\0";
const CACHE_MAGIC: &[u8; 8] = b"RADCACHE";
/// Version of both layouts; part of every shard's name, so a shard of another version is
/// never taken for this one's.
pub const ROWS_VERSION: u32 = 1;

/// One shard's rows: the burial survey and ray-cast hit counts of its patches.
#[derive(Clone, Debug, PartialEq)]
pub struct Rows {
    /// [`super::Plan::hash`] of the plan.
    pub plan_hash: [u8; 32],
    /// [`super::scene_hash`] of the scene.
    pub scene_hash: [u8; 32],
    /// The shard (`u32::MAX`: every patch).
    pub shard: u32,
    /// Patches of the scene under the plan.
    pub n_patches: u32,
    /// Rays per patch.
    pub rays: u32,
    /// The shard's patches, increasing.
    pub patches: Vec<u32>,
    /// Each one's burial survey.
    pub burial: Vec<Vec<u32>>,
    /// Whether each one's survey asked about other points too
    /// ([`crate::geometry::Occluders::buried_traced`]).
    pub recursed: Vec<bool>,
    /// Each one's hit counts.
    pub counts: Vec<HitCounts>,
}

/// What a planned bake leaves for a later rebake: every patch's rows and identity, the
/// scene's triangles (to cast the old scene's rays again), and each system's inputs and
/// results.
#[derive(Clone, Debug, PartialEq)]
pub struct Cache {
    /// The plan's hash.
    pub plan_hash: [u8; 32],
    /// Rays per patch.
    pub rays: u32,
    /// Every patch's burial survey.
    pub burial: Vec<Vec<u32>>,
    /// Whether each survey asked about other points too.
    pub recursed: Vec<bool>,
    /// The scene's object names (the surveys name objects by index).
    pub objects: Vec<String>,
    /// Every patch's hit counts.
    pub counts: Vec<HitCounts>,
    /// Every patch's identity ([`crate::patch::identity::patch_keys`]).
    pub keys: Vec<[u8; 16]>,
    /// The scene's triangles.
    pub triangles: Vec<[DVec3; 3]>,
    /// Whether each emits.
    pub emits: Vec<bool>,
    /// The scene's coverage (empty: all opaque).
    pub coverage: Vec<f32>,
    /// Each system of the level, in order.
    pub systems: Vec<SystemRecord>,
    /// Each of the level's file patches' patch (its index in `keys`).
    pub sources: Vec<u32>,
}

impl Rows {
    /// The file name of `shard`'s rows of a scene and plan: the hash of the inputs, so a
    /// retried shard writes the same file and a stale one is never taken.
    pub fn file_name(scene_hash: &[u8; 32], plan_hash: &[u8; 32], shard: u32) -> String {
        let mut h = blake3::Hasher::new();
        h.update(&ROWS_VERSION.to_le_bytes());
        h.update(scene_hash);
        h.update(plan_hash);
        h.update(&shard.to_le_bytes());
        format!(
            "rows-{shard}-{}.bin",
            &super::hex(h.finalize().as_bytes())[..16]
        )
    }

    /// This shard's file name.
    pub fn name(&self) -> String {
        Self::file_name(&self.scene_hash, &self.plan_hash, self.shard)
    }

    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::new(ROWS_MAGIC);
        w.bytes(&self.plan_hash);
        w.bytes(&self.scene_hash);
        w.u32(self.shard);
        w.u32(self.n_patches);
        w.u32(self.rays);
        w.u32s(&self.patches);
        w.lists(&self.burial);
        w.flags(&self.recursed);
        w.counts(&self.counts);
        w.finish()
    }

    /// Reads a rows file's bytes; `Err` says what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let mut r = Reader::new(bytes, ROWS_MAGIC, "shard rows")?;
        let rows = Rows {
            plan_hash: r.array()?,
            scene_hash: r.array()?,
            shard: r.u32()?,
            n_patches: r.u32()?,
            rays: r.u32()?,
            patches: r.u32s()?,
            burial: r.lists()?,
            recursed: r.flags()?,
            counts: r.counts()?,
        };
        r.end()?;
        let n = rows.patches.len();
        if rows.burial.len() != n || rows.counts.len() != n || rows.recursed.len() != n {
            return Err("its lists disagree in length".into());
        }
        Ok(rows)
    }
}

impl Cache {
    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::new(CACHE_MAGIC);
        w.bytes(&self.plan_hash);
        w.u32(self.rays);
        w.lists(&self.burial);
        w.flags(&self.recursed);
        w.u64(self.objects.len() as u64);
        for o in &self.objects {
            w.u64(o.len() as u64);
            w.bytes(o.as_bytes());
        }
        w.counts(&self.counts);
        w.u64(self.keys.len() as u64);
        for k in &self.keys {
            w.bytes(k);
        }
        w.u64(self.triangles.len() as u64);
        for t in &self.triangles {
            for v in t.iter().flat_map(|p| p.to_array()) {
                w.f64(v);
            }
        }
        w.u64(self.emits.len() as u64);
        w.bytes(&self.emits.iter().map(|&e| u8::from(e)).collect::<Vec<_>>());
        w.u64(self.coverage.len() as u64);
        for &c in &self.coverage {
            w.bytes(&c.to_le_bytes());
        }
        w.u32s(&self.sources);
        w.u64(self.systems.len() as u64);
        for s in &self.systems {
            w.u32(s.region);
            w.bytes(&s.input);
            s.parts.iter().for_each(|p| w.bytes(p));
            w.f64(s.err2);
            w.f64(s.norm2);
            w.u64(s.matrix_bytes);
            w.u64(s.bounces_text.len() as u64);
            w.bytes(s.bounces_text.as_bytes());
        }
        w.finish()
    }

    /// Reads a cache file's bytes; `Err` says what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let mut r = Reader::new(bytes, CACHE_MAGIC, "bake cache")?;
        let plan_hash = r.array()?;
        let rays = r.u32()?;
        let burial = r.lists()?;
        let recursed = r.flags()?;
        let n = r.len(8)?;
        let mut objects = Vec::with_capacity(n);
        for _ in 0..n {
            let len = r.len(1)?;
            objects.push(
                String::from_utf8(r.take(len)?.to_vec())
                    .map_err(|_| "an object's name is not UTF-8".to_string())?,
            );
        }
        let counts = r.counts()?;
        let n = r.len(16)?;
        let keys = (0..n).map(|_| r.array()).collect::<Result<_, _>>()?;
        let n = r.len(72)?;
        let mut triangles = Vec::with_capacity(n);
        for _ in 0..n {
            let mut t = [DVec3::ZERO; 3];
            for p in &mut t {
                *p = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
            }
            triangles.push(t);
        }
        let n = r.len(1)?;
        let emits = r.take(n)?.iter().map(|&b| b != 0).collect();
        let n = r.len(4)?;
        let coverage = (0..n)
            .map(|_| r.array().map(f32::from_le_bytes))
            .collect::<Result<_, _>>()?;
        let sources = r.u32s()?;
        let n = r.len(112)?;
        let mut systems = Vec::with_capacity(n);
        for _ in 0..n {
            let region = r.u32()?;
            let input = r.array()?;
            let parts = [r.array()?, r.array()?, r.array()?];
            let (err2, norm2, matrix_bytes) = (r.f64()?, r.f64()?, r.u64()?);
            let len = r.len(1)?;
            let bounces_text = String::from_utf8(r.take(len)?.to_vec())
                .map_err(|_| "a system's text is not UTF-8".to_string())?;
            systems.push(SystemRecord {
                region,
                input,
                parts,
                err2,
                norm2,
                matrix_bytes,
                bounces_text,
            });
        }
        r.end()?;
        let cache = Cache {
            plan_hash,
            rays,
            burial,
            recursed,
            objects,
            counts,
            keys,
            triangles,
            emits,
            coverage,
            systems,
            sources,
        };
        let n = cache.keys.len();
        if cache.burial.len() != n
            || cache.recursed.len() != n
            || cache.counts.len() != n
            || cache.emits.len() != cache.triangles.len()
            || cache.counts.iter().flatten().any(|&(j, _)| j as usize >= n)
            || cache.sources.iter().any(|&i| i as usize >= n)
        {
            return Err("its lists disagree in length".into());
        }
        Ok(cache)
    }
}

struct Writer(Vec<u8>);

impl Writer {
    fn new(magic: &[u8; 8]) -> Self {
        let mut w = Writer(magic.to_vec());
        w.u32(ROWS_VERSION);
        w
    }
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32s(&mut self, v: &[u32]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|&x| self.u32(x));
    }
    fn flags(&mut self, v: &[bool]) {
        self.u64(v.len() as u64);
        self.bytes(&v.iter().map(|&b| u8::from(b)).collect::<Vec<_>>());
    }
    fn lists(&mut self, v: &[Vec<u32>]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|l| self.u32s(l));
    }
    fn counts(&mut self, v: &[HitCounts]) {
        self.u64(v.len() as u64);
        for row in v {
            self.u64(row.len() as u64);
            for &(j, c) in row {
                self.u32(j);
                self.u32(c);
            }
        }
    }
    fn finish(mut self) -> Vec<u8> {
        let hash = *blake3::hash(&self.0).as_bytes();
        self.bytes(&hash);
        self.0
    }
}

struct Reader<'a> {
    body: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn new(bytes: &'a [u8], magic: &[u8; 8], what: &str) -> Result<Self, String> {
        if bytes.len() < 8 + 4 + 32 || &bytes[..8] != magic {
            return Err(format!("not a {what} file"));
        }
        let (body, hash) = bytes.split_at(bytes.len() - 32);
        if blake3::hash(body).as_bytes() != hash {
            return Err("damaged or truncated: its checksum does not match".into());
        }
        let mut r = Reader { body, at: 8 };
        let version = r.u32()?;
        if version != ROWS_VERSION {
            return Err(format!(
                "version {version}: this build reads version {ROWS_VERSION}"
            ));
        }
        Ok(r)
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.body.len());
        let end = end.ok_or("ends early")?;
        let out = &self.body[self.at..end];
        self.at = end;
        Ok(out)
    }
    fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        Ok(self.take(N)?.try_into().expect("N bytes"))
    }
    fn u32(&mut self) -> Result<u32, String> {
        self.array().map(u32::from_le_bytes)
    }
    fn u64(&mut self) -> Result<u64, String> {
        self.array().map(u64::from_le_bytes)
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.array().map(f64::from_le_bytes)
    }
    /// A list's length, refused where its `each`-byte items could not fit in what is left.
    fn len(&mut self, each: usize) -> Result<usize, String> {
        let n = self.u64()?;
        let left = (self.body.len() - self.at) as u64;
        if n.saturating_mul(each as u64) > left {
            return Err("a list is longer than the file".into());
        }
        Ok(n as usize)
    }
    fn u32s(&mut self) -> Result<Vec<u32>, String> {
        let n = self.len(4)?;
        (0..n).map(|_| self.u32()).collect()
    }
    fn flags(&mut self) -> Result<Vec<bool>, String> {
        let n = self.len(1)?;
        Ok(self.take(n)?.iter().map(|&b| b != 0).collect())
    }
    fn lists(&mut self) -> Result<Vec<Vec<u32>>, String> {
        let n = self.len(8)?;
        (0..n).map(|_| self.u32s()).collect()
    }
    fn counts(&mut self) -> Result<Vec<HitCounts>, String> {
        let n = self.len(8)?;
        (0..n)
            .map(|_| {
                let m = self.len(8)?;
                (0..m).map(|_| Ok((self.u32()?, self.u32()?))).collect()
            })
            .collect()
    }
    fn end(&self) -> Result<(), String> {
        if self.at == self.body.len() {
            Ok(())
        } else {
            Err("has bytes past its end".into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_and_damage_is_refused() {
        let rows = Rows {
            plan_hash: [1; 32],
            scene_hash: [2; 32],
            shard: 3,
            n_patches: 10,
            rays: 64,
            patches: vec![0, 4, 9],
            burial: vec![vec![], vec![u32::MAX, 2], vec![]],
            recursed: vec![false, true, false],
            counts: vec![vec![(1, 5)], vec![], vec![(0, 1), (4, 60)]],
        };
        let bytes = rows.to_bytes();
        assert_eq!(Rows::from_bytes(&bytes).unwrap(), rows);
        let mut bad = bytes.clone();
        bad[40] ^= 1;
        assert!(Rows::from_bytes(&bad).unwrap_err().contains("checksum"));
        assert!(Rows::from_bytes(&bytes[..bytes.len() - 5]).is_err());
        assert!(Rows::from_bytes(b"RADCACHE and more bytes than that, forty-four").is_err());
        // The name follows the inputs (scene, plan, shard), not the contents.
        assert_eq!(rows.name(), Rows::file_name(&[2; 32], &[1; 32], 3));
        assert_ne!(rows.name(), Rows::file_name(&[1; 32], &[2; 32], 3));
        assert_ne!(rows.name(), Rows::file_name(&[2; 32], &[1; 32], 4));
        assert!(rows.name().starts_with("rows-3-"));
    }
}
